"""``rs.grad`` through area lights against central differences in float64.

An area light is evaluated at N fixed points of its frame (``centre + a eu + b ev``, a rank-1 lattice
whose ``(a, b)`` do not depend on the light), each a point light of ``1/N`` of its intensity with its
own shadow ray: its position, radiance, intensity and edges ``u``, ``v`` move the samples smoothly.
Without shadows the differences are taken on the NumPy twin of the kernels
(``study.reference.shade_reference``, which evaluates the samples as the kernels do). With shadows the
twin has no visibility: the oracle is the sum over the samples of the twin's shade under each sample
alone (a point light at ``sample_points()[j]``), times that sample's shadow mask from the renderer's own
terms pass (one shadow ray per pixel; Phong and flat, whose masks are 0 or 1), the masks held as the
gradient holds them; the oracle is first checked to be ``rs.render``'s image, and the masks of the
perturbed scenes are checked unchanged (no sample's shadow moves under the steps). Steps 1e-5; relative
error <= 1e-4 (test_grad_fd.py's rule).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.reference import shade_reference

from .test_grad_fd import H, RTOL, W, _check_family, _frame_and_grads

STEP = 1e-5
AXES = ("light_u", "light_v")


def _material():
    return rs.Material(kd=(0.6, 0.4, 0.3), ka=(0.5, 0.6, 0.7), ks=(0.5, 0.4, 0.6), shininess=20.0)


def _sphere_scene(shape="rectangle", shadows=False):
    if shape == "rectangle":
        area = rs.AreaLight((1.5, 2.5, 3.0), u=(1.2, 0.0, -0.6), v=(0.0, 0.8, 0.0), samples=5, intensity=30.0,
                            attenuation="inverse_square", color=(1.0, 0.9, 0.8), shadows=shadows)
    else:
        area = rs.AreaLight.disc((-2.0, 2.0, 2.5), normal=(0.6, -0.5, -0.6), radius=0.7, samples=6, intensity=8.0,
                                 attenuation="heuristic", k=1.5, shadows=shadows)
    lights = [area, rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6))]
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), _material())], lights=lights,
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H), ambient=(0.1, 0.12, 0.08))


def _as_points(light, position=None, u=None, v=None, shadows=None):
    """The area light's samples as point lights of ``1/N`` of its intensity each, at
    ``position + a eu + b ev`` with the lattice's fixed ``(a, b)`` (read back from ``sample_points()``)
    and the half-axes ``eu, ev`` of ``u, v`` (the light's own unless given: ``u``, ``v`` need not stay
    perpendicular here, as an AreaLight's must)."""
    half = 0.5 if light.shape == "rectangle" else 1.0
    eu, ev = half * np.asarray(light.u, float), half * np.asarray(light.v, float)
    rel = light.sample_points() - np.asarray(light.position, float)
    a, b = rel @ eu / (eu @ eu), rel @ ev / (ev @ ev)
    c = np.asarray(light.position if position is None else position, float)
    eu = eu if u is None else half * np.asarray(u, float)
    ev = ev if v is None else half * np.asarray(v, float)
    color = tuple(np.broadcast_to(np.asarray(light.color, float), 3))
    return [rs.PointLight(tuple(c + aj * eu + bj * ev), intensity=light.intensity / light.samples, color=color,
                          attenuation=light.attenuation, k=light.k,
                          shadows=light.shadows if shadows is None else shadows) for aj, bj in zip(a, b)]


def _moved_axis(scene, name, col, delta):
    """The scene with the area light (light 0) as its samples, one component of its ``u`` or ``v`` moved."""
    light = scene.lights[0]
    field = name[-1]
    value = np.array(getattr(light, field), float)
    value[col] += delta
    return scene.replace(lights=tuple(_as_points(light, **{field: value})) + tuple(scene.lights[1:]))


def _loss(scene, hits, shading, weights):
    return float(np.sum(weights * shade_reference(scene, scene.camera, hits, shading)))


@pytest.fixture(scope="module")
def weights():
    return np.random.default_rng(5).standard_normal((H, W, 3))


@pytest.mark.parametrize("shading,shape", [("phong", "rectangle"), ("gouraud", "disc"), ("flat", "rectangle"),
                                           ("phong", "disc")])
def test_area_light_gradients_match_central_differences(shading, shape, weights):
    scene = _sphere_scene(shape)
    wrt = ("kd", "ks", "shininess", "light_position", "light_radiance", "light_intensity", "light_k") + AXES
    frame, g = _frame_and_grads(scene, shading, weights, wrt)
    for name in ("kd", "ks", "shininess", "light_radiance", "light_intensity"):
        _check_family(scene, frame, shading, weights, g, name)
    _check_family(scene, frame, shading, weights, g, "light_position", skip_rows=(1,))
    if shape == "disc":
        _check_family(scene, frame, shading, weights, g, "light_k", skip_rows=(1,))
    points = scene.replace(lights=tuple(_as_points(scene.lights[0])) + tuple(scene.lights[1:]))
    np.testing.assert_allclose(shade_reference(points, scene.camera, frame.hits, shading),
                               shade_reference(scene, scene.camera, frame.hits, shading), rtol=1e-12, atol=1e-14)
    for name in AXES:
        assert g[name].shape == (2, 3) and np.all(g[name][1] == 0.0)  # a directional light has no edges
        top = float(np.max(np.abs(g[name])))
        assert top > 0.0
        for col in range(3):
            fd = (_loss(_moved_axis(scene, name, col, STEP), frame.hits, shading, weights)
                  - _loss(_moved_axis(scene, name, col, -STEP), frame.hits, shading, weights)) / (2.0 * STEP)
            assert abs(g[name][0, col] - fd) <= RTOL * max(abs(fd), 1e-2 * top), (name, col, g[name][0, col], fd)


def _floor_scene(light):
    floor = rs.Model(rs.shapes.plane(6.0, 4, center=(0.0, -1.0, 0.0), normal="+y"),
                     rs.Material(kd=(0.7, 0.7, 0.6), ks=0.2, shininess=8.0))
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), _material()), floor], lights=[light],
                    camera=rs.Camera(eye=(0.0, 1.5, 4.5), target=(0.0, -0.5, 0.0), width=W, height=H),
                    ambient=(0.1, 0.12, 0.08))


def _shadowed(**kw):
    return _floor_scene(rs.AreaLight((0.8, 3.0, 0.5), u=(1.5, 0.0, 0.0), v=(0.0, 0.0, 1.0), samples=4,
                                     intensity=25.0, attenuation="inverse_square", shadows=True, **kw))


def _masks(scene, shading):
    """Each sample's shadow mask (N, H, W) by the renderer's terms pass on its point lights."""
    frame = rs.render(scene.replace(lights=tuple(_as_points(scene.lights[0]))), shading, terms=True)
    return np.asarray(frame.terms["shadow"], np.float64)


def _oracle(scene, hits, shading, masks, points):
    """The image with each sample's visibility held: ambient, plus each sample's unshadowed shade
    (the twin; ``points`` the samples as point lights) times its mask."""
    out = shade_reference(scene.replace(lights=()), scene.camera, hits, shading)
    dark = scene.replace(lights=(), ambient=0.0)
    base = shade_reference(dark, scene.camera, hits, shading)  # the background where nothing is hit
    for q, mask in zip(points, masks):
        alone = dark.replace(lights=(dataclasses.replace(q, shadows=False),))
        out += mask[..., None] * (shade_reference(alone, scene.camera, hits, shading) - base)
    return out


@pytest.mark.parametrize("shading", ["phong", "flat"])
def test_area_light_with_hard_shadows_per_sample_matches_central_differences(shading, weights):
    scene = _shadowed()
    frame = rs.render(scene, shading)
    masks = _masks(scene, shading)
    assert 0 < np.count_nonzero(masks == 0.0), "some sample should be blocked somewhere"
    assert np.all((masks == 0.0) | (masks == 1.0))
    np.testing.assert_allclose(_oracle(scene, frame.hits, shading, masks, _as_points(scene.lights[0])), frame.image, rtol=2e-6, atol=1e-6)
    assert np.any(masks.min(axis=0) != masks.max(axis=0)), "a penumbra: some pixel sees some samples, not all"
    g = rs.grad(scene, weights, ("kd", "light_position", "light_intensity") + AXES, shading=shading, frame=frame)

    def loss(**moved):
        light = scene.lights[0]
        intensity = moved.pop("intensity", light.intensity)
        points = [dataclasses.replace(q, intensity=intensity / light.samples) for q in _as_points(light, **moved)]
        moved_scene = scene.replace(lights=tuple(points))
        masks_now = np.asarray(rs.render(moved_scene, shading, terms=True).terms["shadow"], np.float64)
        assert np.array_equal(masks_now, masks), "a sample's shadow moved under the step"
        return float(np.sum(weights * _oracle(scene, frame.hits, shading, masks, points)))

    light = scene.lights[0]
    fd = (loss(intensity=light.intensity + STEP) - loss(intensity=light.intensity - STEP)) / (2.0 * STEP)
    assert abs(g["light_intensity"][0] - fd) <= RTOL * abs(fd), (g["light_intensity"][0], fd)
    for name, field in (("light_position", "position"), ("light_u", "u"), ("light_v", "v")):
        top = float(np.max(np.abs(g[name])))
        for col in range(3):
            value = np.array(getattr(light, field), float)
            diffs = []
            for d in (STEP, -STEP):
                moved = value.copy()
                moved[col] += d
                diffs.append(loss(**{field: moved}))
            fd = (diffs[0] - diffs[1]) / (2.0 * STEP)
            assert abs(g[name][0, col] - fd) <= RTOL * max(abs(fd), 1e-2 * top), (name, col, g[name][0, col], fd)


def test_area_and_ggx_gradients_are_bit_identical_across_thread_counts(weights):
    """Area-light samples, shadows and a GGX material in one frame, all three methods: the sums keep
    their fixed order on 1 and 2 threads."""
    import numba

    ggx = rs.Material(kd=(0.6, 0.4, 0.3), specular="ggx", metallic=0.4, roughness=0.35)
    scene = _shadowed()
    scene = scene.replace(models=(dataclasses.replace(scene.models[0], material=ggx), scene.models[1]))
    shading = ["phong", "gouraud"]
    frame = rs.render(scene, shading)
    wrt = ("kd", "metallic", "roughness", "light_position", "light_u", "light_v", "normals")
    before = numba.get_num_threads()
    runs = []
    try:
        for threads in (1, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            runs.append(rs.grad(scene, weights, wrt, shading=shading, frame=frame))
    finally:
        numba.set_num_threads(before)
    for name in wrt:
        assert runs[0][name].tobytes() == runs[1][name].tobytes(), name
    assert np.any(runs[0]["metallic"] != 0) and np.any(runs[0]["light_u"] != 0)
