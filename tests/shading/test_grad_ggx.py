"""``rs.grad`` through GGX (glTF metallic-roughness) materials against central differences in float64.

The loss is ``sum(W * I)`` over the frame's hit buffer, differenced on the NumPy twin of the kernels
(``study.reference.shade_reference``, whose GGX terms are ``study.ggx``'s, checked against ``rs.render``'s
image first), steps 1e-5; relative error <= 1e-4 (test_grad_fd.py's rule). The material sits inside
its clamps (metallic 0.3, roughness 0.4); at metallic 0 the derivative is the one-sided one into the
valid range, and below the roughness floor (shaded at ``MIN_ROUGHNESS``) it is 0.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.shading.reflectance import MIN_ROUGHNESS
from raycast_shade.study.reference import shade_reference

from .test_grad_fd import H, RTOL, W, _check_family, _frame_and_grads

STEP = 1e-5


def _ggx_scene(metallic=0.3, roughness=0.4):
    material = rs.Material(kd=(0.6, 0.4, 0.3), ka=(0.5, 0.6, 0.7), specular="ggx", metallic=metallic,
                           roughness=roughness)
    lights = [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
              rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6))]
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), material)], lights=lights,
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H), ambient=(0.1, 0.12, 0.08))


def _with(scene, **fields):
    model = scene.models[0]
    return scene.replace(models=(dataclasses.replace(model, material=dataclasses.replace(model.material, **fields)),))


def _loss(scene, hits, shading, weights):
    return float(np.sum(weights * shade_reference(scene, scene.camera, hits, shading)))


@pytest.fixture(scope="module")
def weights():
    return np.random.default_rng(7).standard_normal((H, W, 3))


@pytest.mark.parametrize("shading", ["phong", "gouraud", "flat"])
def test_ggx_gradients_match_central_differences(shading, weights):
    scene = _ggx_scene()
    wrt = ("ka", "kd", "ks", "shininess", "metallic", "roughness", "ambient", "light_position", "light_direction",
           "light_radiance")
    frame, g = _frame_and_grads(scene, shading, weights, wrt)
    for name in ("ka", "kd", "ambient", "light_radiance"):
        _check_family(scene, frame, shading, weights, g, name)
    _check_family(scene, frame, shading, weights, g, "light_position", skip_rows=(1,))
    _check_family(scene, frame, shading, weights, g, "light_direction", skip_rows=(0,))
    assert np.all(g["ks"] == 0.0) and np.all(g["shininess"] == 0.0)  # GGX has neither
    for name in ("metallic", "roughness"):
        assert g[name].shape == (1,)
        v = getattr(scene.models[0].material, name)
        fd = (_loss(_with(scene, **{name: v + STEP}), frame.hits, shading, weights)
              - _loss(_with(scene, **{name: v - STEP}), frame.hits, shading, weights)) / (2.0 * STEP)
        assert abs(fd) > 1e-2
        assert abs(g[name][0] - fd) <= RTOL * abs(fd), f"{name}: kernel {g[name][0]!r}, finite difference {fd!r}"


@pytest.mark.parametrize("shading", ["phong", "gouraud"])
def test_ggx_vertex_normal_gradients_match_central_differences(shading, weights):
    scene = _ggx_scene()
    frame = rs.render(scene, shading)
    g = rs.grad(scene, weights, "normals", shading=shading, frame=frame)["normals"]
    normals = scene.geometry.normals
    top = float(np.max(np.abs(g)))
    for i in np.argsort(-np.abs(g).max(axis=1))[:3]:
        for c in range(3):
            keep = normals[i, c]
            out = []
            for h in (STEP, -STEP):
                normals[i, c] = keep + h
                out.append(_loss(scene, frame.hits, shading, weights))
            normals[i, c] = keep
            fd = (out[0] - out[1]) / (2.0 * STEP)
            assert abs(g[i, c] - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"normal {i}, {c}: {g[i, c]} vs {fd}"


def test_ggx_clamps_one_sided_at_metallic_zero_and_zero_below_the_roughness_floor(weights):
    """metallic 0 is the clamp's bound: the gradient is the derivative into [0, 1] (second-order
    one-sided differences); a roughness below the floor is shaded at the floor: no gradient."""
    scene = _ggx_scene(metallic=0.0, roughness=0.5)
    frame = rs.render(scene, "phong")
    g = rs.grad(scene, weights, ("metallic", "roughness"), frame=frame)
    f = [_loss(_with(scene, metallic=k * STEP), frame.hits, "phong", weights) for k in range(3)]
    fd = (-3.0 * f[0] + 4.0 * f[1] - f[2]) / (2.0 * STEP)
    assert abs(g["metallic"][0] - fd) <= RTOL * abs(fd), (g["metallic"][0], fd)
    floor = _ggx_scene(roughness=0.5 * MIN_ROUGHNESS)
    gf = rs.grad(floor, weights, ("roughness", "metallic"), frame=rs.render(floor, "phong"))
    assert gf["roughness"][0] == 0.0 and gf["metallic"][0] != 0.0


def test_ggx_colours_and_texels_are_still_refused_by_name(weights):
    scene = _ggx_scene()
    with pytest.raises(ValueError, match="specular='ggx' has no gradients on a scene with colours, maps"):
        rs.grad(scene, weights, "kd_map")
