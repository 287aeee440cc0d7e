"""The gradient kernels (shading/grad_terms.py, grad_frame.py) against central finite differences.

The loss is ``L = sum(W * I)`` with a fixed random ``W``, so ``dL/dI = W``. The finite differences
are taken in float64 on the NumPy twin of the shading kernels (``study.reference.shade_reference``)
over the frame's own hit buffer, and the twin is first checked to be ``rs.render``'s image (to
float32's rounding): the finite differences are those of the image ``rs.render`` returns, without
its float32 storage. Steps: 1e-5 for coefficients, ambient, radiance, positions, directions,
``k`` and normals; 1e-4 for the shininess (about 20). Relative error <= 1e-4 of each component
(of the family's largest component where the component itself is within 1% of it: a component
near 0 has no relative scale of its own).
"""

from __future__ import annotations

import dataclasses

import numba
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.gradients import WRT
from raycast_shade.study.reference import shade_reference

H, W = 36, 48
STEP = {"shininess": 1e-4}
RTOL = 1e-4


def _scene(specular="phong", lights=None, **mat):
    material = rs.Material(**{"kd": (0.6, 0.4, 0.3), "ka": (0.5, 0.6, 0.7), "ks": (0.5, 0.4, 0.6), "shininess": 20.0,
                              "specular": specular, **mat})
    if lights is None:
        lights = [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
                  rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6))]
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), material)], lights=lights,
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H), ambient=(0.1, 0.12, 0.08))


def _spot_scene():
    """Blinn-Phong lit by a spot light whose cone edge crosses the sphere (Warn's smooth step) with the
    heuristic law, and a point light with the heuristic law."""
    lights = [rs.SpotLight((0.5, 2.5, 3.0), direction=(-0.2, -0.8, -1.0), intensity=6.0, exponent=3.0,
                           inner_angle=8.0, outer_angle=18.0, attenuation="heuristic", k=0.7),
              rs.PointLight((-3.0, 1.0, 2.0), intensity=4.0, attenuation="heuristic", k=1.5, color=(0.9, 1.0, 0.7))]
    return _scene("blinn", lights)


def _rgb(v):
    return np.array(np.broadcast_to(v, 3), float)


def perturbed(scene, name, index, delta):
    """``scene`` with one component of a parameter moved by ``delta`` (``index = (row, column)``)."""
    row, col = index
    if name in ("ka", "kd", "ks", "shininess"):
        models = list(scene.models)
        mat = models[row].material
        if name == "shininess":
            new = dataclasses.replace(mat, shininess=mat.shininess + delta)
        else:
            v = _rgb(getattr(mat, name)).copy()
            v[col] += delta
            new = dataclasses.replace(mat, **{name: tuple(v)})
        models[row] = dataclasses.replace(models[row], material=new)
        return scene.replace(models=tuple(models))
    if name == "ambient":
        a = _rgb(scene.ambient).copy()
        a[col] += delta
        return scene.replace(ambient=tuple(a))
    lights = list(scene.lights)
    light = lights[row]
    if name == "light_position":
        p = np.array(light.position, float)
        p[col] += delta
        lights[row] = dataclasses.replace(light, position=tuple(p))
    elif name == "light_direction":
        d = np.array(light.direction, float)
        d[col] += delta
        lights[row] = dataclasses.replace(light, direction=tuple(d))
    elif name == "light_radiance":
        c = _rgb(light.color).copy()
        c[col] += delta / light.intensity
        lights[row] = dataclasses.replace(light, color=tuple(c))
    elif name == "light_intensity":
        lights[row] = dataclasses.replace(light, intensity=light.intensity + delta)
    elif name == "light_k":
        lights[row] = dataclasses.replace(light, k=light.k + delta)
    return scene.replace(lights=tuple(lights))


def _loss(scene, hits, shading, weights):
    return float(np.sum(weights * shade_reference(scene, scene.camera, hits, shading)))


def _fd(scene, hits, shading, weights, name, index):
    h = STEP.get(name, 1e-5)
    up = _loss(perturbed(scene, name, index, h), hits, shading, weights)
    down = _loss(perturbed(scene, name, index, -h), hits, shading, weights)
    return (up - down) / (2.0 * h)


def _indices(name, scene):
    if name in ("shininess", "light_intensity", "light_k"):
        rows = range(len(scene.lights)) if name.startswith("light") else range(len(scene.models))
        return [(r, None) for r in rows]
    if name == "ambient":
        return [(None, c) for c in range(3)]
    rows = range(len(scene.lights)) if name.startswith("light") else range(len(scene.models))
    return [(r, c) for r in rows for c in range(3)]


def _component(g, index):
    r, c = index
    if r is None:
        return g[c]
    return g[r] if c is None else g[r, c]


def _check_family(scene, frame, shading, weights, grads, name, skip_rows=()):
    g = grads[name]
    top = float(np.max(np.abs(g)))
    assert top > 0, f"{name}: no gradient at all"
    checked = 0
    for index in _indices(name, scene):
        if index[0] in skip_rows:
            continue
        fd = _fd(scene, frame.hits, shading, weights, name, index)
        got = _component(g, index)
        scale = max(abs(fd), 1e-2 * top)
        assert abs(got - fd) <= RTOL * scale, f"{name}{index}: kernel {got!r}, finite difference {fd!r}"
        checked += 1
    assert checked > 0


@pytest.fixture(scope="module")
def weights():
    return np.random.default_rng(7).standard_normal((H, W, 3))


def _frame_and_grads(scene, shading, weights, wrt=None):
    frame = rs.render(scene, shading)
    # The twin is rs.render's image: finite differences on it are those of the library's image.
    np.testing.assert_allclose(shade_reference(scene, scene.camera, frame.hits, shading), frame.image,
                               rtol=2e-6, atol=1e-7)
    return frame, rs.grad(scene, weights, wrt, shading=shading, frame=frame)


MATERIAL = ("ka", "kd", "ks", "shininess", "ambient")


@pytest.mark.parametrize("shading", ["phong", "gouraud", "flat"])
def test_material_and_light_gradients_match_central_differences(shading, weights):
    scene = _scene()
    frame, grads = _frame_and_grads(scene, shading, weights)
    for name in MATERIAL + ("light_radiance", "light_intensity"):
        _check_family(scene, frame, shading, weights, grads, name)
    _check_family(scene, frame, shading, weights, grads, "light_position", skip_rows=(1,))
    _check_family(scene, frame, shading, weights, grads, "light_direction", skip_rows=(0,))
    assert np.all(grads["light_position"][1] == 0) and np.all(grads["light_direction"][0] == 0)
    assert np.all(grads["light_k"] == 0)  # no heuristic light


def test_blinn_spot_and_heuristic_gradients_match_central_differences(weights):
    scene = _spot_scene()
    frame, grads = _frame_and_grads(scene, "phong", weights)
    for name in MATERIAL + ("light_position", "light_radiance", "light_k"):
        _check_family(scene, frame, "phong", weights, grads, name)


@pytest.mark.parametrize("shading", ["phong", "gouraud"])
def test_vertex_normal_gradients_match_central_differences(shading, weights):
    scene = _scene()
    frame, grads = _frame_and_grads(scene, shading, weights, ("normals",))
    g = grads["normals"]
    assert g.shape == scene.geometry.normals.shape
    normals = scene.geometry.normals
    top = float(np.max(np.abs(g)))
    for i in np.argsort(-np.abs(g).max(axis=1))[:4]:  # the vertices that matter most
        for c in range(3):
            keep = normals[i, c]
            fd = []
            for h in (1e-5, -1e-5):
                normals[i, c] = keep + h
                fd.append(_loss(scene, frame.hits, shading, weights))
            normals[i, c] = keep
            fd = (fd[0] - fd[1]) / 2e-5
            assert abs(g[i, c] - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"normal {i}, {c}: {g[i, c]} vs {fd}"


def test_flat_vertex_normal_gradient_is_exactly_zero_and_gouraud_is_not(weights):
    scene = _scene()
    flat = rs.grad(scene, weights, "normals", shading="flat")["normals"]
    gouraud = rs.grad(scene, weights, "normals", shading="gouraud")["normals"]
    assert np.all(flat == 0.0)
    assert np.count_nonzero(gouraud) > 100


def _moved(x):
    pose = np.eye(4)
    pose[0, 3] = x
    return pose


def _mixed_scene(shadows):
    mats = [rs.Material(kd=(0.6, 0.4, 0.3), ks=0.5, shininess=20.0),
            rs.Material(kd=(0.3, 0.6, 0.4), ks=0.3, shininess=9.0, specular="blinn"),
            rs.Material(kd=(0.4, 0.3, 0.6), ks=0.2, shininess=30.0)]
    models = [rs.Model(rs.shapes.icosphere(2), m, pose=_moved(x)) for x, m in zip((-1.2, 0.0, 1.2), mats)]
    lights = [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square", shadows=shadows),
              rs.DirectionalLight((-1.0, -0.2, -0.3), intensity=0.7, shadows=shadows)]
    return rs.Scene(models, lights=lights, camera=rs.Camera(eye=(0.0, 0.0, 6.0), width=W, height=H))


@pytest.mark.parametrize("shadows", [False, True])
def test_gradients_are_bit_identical_run_to_run_and_across_thread_counts(shadows, weights):
    scene = _mixed_scene(shadows)
    shading = ["flat", "gouraud", "phong"]
    frame = rs.render(scene, shading)
    runs = []
    before = numba.get_num_threads()
    try:
        for threads in (1, 2, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            runs.append(rs.grad(scene, weights, WRT, shading=shading, frame=frame))
    finally:
        numba.set_num_threads(before)
    for run in runs[1:]:
        for name, value in runs[0].items():
            if isinstance(value, tuple):  # per model (the maps' texels): no maps here
                assert value == run[name] == (None, None, None), name
                continue
            assert value.tobytes() == run[name].tobytes(), name
    assert all(np.any(runs[0][n] != 0) for n in ("kd", "ks", "shininess", "light_position", "normals"))
