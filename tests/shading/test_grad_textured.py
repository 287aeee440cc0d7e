"""``rs.grad``'s material, ambient, light and normal gradients on scenes with mesh colours and colour
maps (shading/grad_textured.py) against central differences of the NumPy twin over the frame's hits.

On such a scene ``dL/dkd`` is with respect to the material's scalar ``kd`` (the map's multiplier;
0 where a mesh colour replaces kd), ``ka`` likewise (times the colour with ``ka_colors``, the ka map
and the occlusion), ``ks`` (times the ks map). Relative error <= 1e-4, as in test_grad_fd.py.
"""

from __future__ import annotations

import dataclasses

import numba
import numpy as np
import pytest

import raycast_shade as rs

from .test_grad_fd import RTOL, _check_family, _loss, perturbed
from .test_grad_maps import _frame, _moved_texel, _scene, _texture

FAMILIES = ("ka", "kd", "ks", "shininess", "ambient", "light_radiance", "light_intensity")


@pytest.fixture(scope="module")
def weights():
    from .test_grad_fd import H, W
    return np.random.default_rng(11).standard_normal((H, W, 3))


def _textured(kind):
    """``"maps"``: kd, ks, ka and occlusion maps (a mip-mapped kd), no colours; ``"vertex"``: vertex
    colours (ambient follows them) and a kd map; ``"vertex-plain"``: vertex colours alone (Gouraud's
    vertex path); ``"face"``: face colours."""
    base = rs.shapes.icosphere(2)
    rng = np.random.default_rng(6)
    if kind == "maps":
        return _scene(kd_map=_texture(3, "repeat", (40, 56), "mipmap"), ks_map=_texture(4, "clamp", (5, 7)),
                      ka_map=_texture(5, "repeat", (6, 8)), ao_map=_texture(7, "repeat", (4, 6)))
    if kind == "vertex":
        return _scene(rng.uniform(0.2, 0.9, (base.vertices.shape[0], 3)), "vertex", kd_map=_texture(3, "repeat", (6, 8)))
    if kind == "vertex-plain":
        return _scene(rng.uniform(0.2, 0.9, (base.vertices.shape[0], 3)), "vertex")
    return _scene(rng.uniform(0.2, 0.9, (base.faces.shape[0], 3)), "face", ka_colors=False)


def _check(scene, frame, shading, weights, grads, name):
    if name == "kd" and scene.geometry.color_mode[0] != 0:  # a colour replaces kd: its row is not used
        assert np.all(grads["kd"] == 0.0)
        assert _loss(perturbed(scene, "kd", (0, 0), 0.1), frame.hits, shading, weights) == \
            _loss(scene, frame.hits, shading, weights)
        return
    _check_family(scene, frame, shading, weights, grads, name)


@pytest.mark.parametrize("shading,kind", [("phong", "maps"), ("phong", "vertex"), ("phong", "face"),
                                          ("gouraud", "maps"), ("gouraud", "vertex-plain"), ("gouraud", "face"),
                                          ("flat", "maps"), ("flat", "vertex")])
def test_material_and_light_gradients_on_textured_scenes_match_central_differences(shading, kind, weights):
    scene = _textured(kind)
    frame = _frame(scene, shading)
    grads = rs.grad(scene, weights, None, shading=shading, frame=frame)
    for name in FAMILIES:
        _check(scene, frame, shading, weights, grads, name)
    _check_family(scene, frame, shading, weights, grads, "light_position", skip_rows=(1,))
    _check_family(scene, frame, shading, weights, grads, "light_direction", skip_rows=(0,))


@pytest.mark.parametrize("shading,kind", [("phong", "maps"), ("gouraud", "vertex-plain"), ("gouraud", "maps")])
def test_normal_gradients_on_textured_scenes_match_central_differences(shading, kind, weights):
    scene = _textured(kind)
    frame = _frame(scene, shading)
    g = rs.grad(scene, weights, ("normals", "kd_map"), shading=shading, frame=frame)["normals"]
    normals = scene.geometry.normals
    top = float(np.max(np.abs(g)))
    assert top > 0
    for i in np.argsort(-np.abs(g).max(axis=1))[:3]:
        for c in range(3):
            keep = normals[i, c]
            fd = []
            for h in (1e-5, -1e-5):
                normals[i, c] = keep + h
                fd.append(_loss(scene, frame.hits, shading, weights))
            normals[i, c] = keep
            fd = (fd[0] - fd[1]) / 2e-5
            assert abs(g[i, c] - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"normal {i}, {c}: {g[i, c]} vs {fd}"


def test_geometry_on_a_textured_scene_is_given_beside_the_other_families(weights):
    """The geometry is no longer refused on a coloured, mapped scene (its checks against differences:
    tests/shading/test_grad_geotex.py); asked with kd, both come back, and kd is the same as alone."""
    scene = _textured("vertex")
    g = rs.grad(scene, weights, ("kd", "ka", "vertices"))
    assert np.any(g["vertices"] != 0.0)
    assert np.array_equal(g["ka"], rs.grad(scene, weights, ("ka",))["ka"])


def test_textured_gradients_are_bit_identical_across_thread_counts(weights):
    scene = _textured("maps")
    scene = scene.replace(models=scene.models + (dataclasses.replace(
        scene.models[0], pose=np.array([[1, 0, 0, 1.3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])),))
    shading = ["phong", "gouraud"]
    frame = rs.render(scene, shading)
    runs = []
    before = numba.get_num_threads()
    try:
        for threads in (1, 2, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            runs.append(rs.grad(scene, weights, ("kd", "ka", "ks", "light_position", "normals"), shading=shading,
                                frame=frame))
    finally:
        numba.set_num_threads(before)
    for run in runs[1:]:
        for name, value in runs[0].items():
            assert value.tobytes() == run[name].tobytes(), name
    assert all(np.any(runs[0][n] != 0) for n in ("kd", "ks", "normals"))


@pytest.mark.parametrize("shading,colours,filt", [("phong", False, "mipmap"), ("phong", True, "bilinear"),
                                                  ("flat", True, "mipmap"), ("gouraud", False, "bilinear")])
def test_ka_ke_and_occlusion_texel_gradients_match_central_differences(shading, colours, filt, weights):
    """The ambient (times the vertex colour with ``ka_colors``, and the occlusion), emission and
    occlusion maps' texels: the image is linear in each, so step 0.25 is exact (as test_grad_maps)."""
    shapes = ((6, 8), (5, 7), (4, 6)) if filt == "bilinear" else ((40, 56), (36, 44), (30, 46))
    n = rs.shapes.icosphere(2).vertices.shape[0]
    rgb = np.random.default_rng(8).uniform(0.2, 0.9, (n, 3)) if colours else None
    scene = _scene(rgb, "vertex", ka_map=_texture(3, "repeat", shapes[0], filt),
                   ke_map=_texture(4, "clamp", shapes[1], filt), ao_map=_texture(5, "repeat", shapes[2], filt),
                   ke=(0.3, 0.2, 0.4), ao_strength=0.7)
    frame = _frame(scene, shading)
    g = rs.grad(scene, weights, ("ka_map", "ke_map", "ao_map"), shading=shading, frame=frame)
    for slot in ("ka_map", "ke_map", "ao_map"):
        (gm,) = g[slot]
        assert gm.shape == getattr(scene.models[0].material, slot).texels.shape
        if slot == "ao_map":
            assert np.all(gm[..., 1:] == 0.0)  # the occlusion reads the red channel only
        top = float(np.max(np.abs(gm)))
        assert top > 0
        order = np.argsort(-np.abs(gm).ravel())
        picks = [np.unravel_index(k, gm.shape) for k in order[:3]] + [np.unravel_index(order[-1], gm.shape)]
        for i, j, c in picks:
            up = _loss(_moved_texel(scene, slot, i, j, c, 0.25), frame.hits, shading, weights)
            down = _loss(_moved_texel(scene, slot, i, j, c, -0.25), frame.hits, shading, weights)
            fd = (up - down) / 0.5
            assert abs(gm[i, j, c] - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"{slot}[{i}, {j}, {c}]: {gm[i, j, c]} vs {fd}"
