"""``rs.grad`` on bump- and normal-mapped scenes (shading/grad_bump.py) against central differences.

The NumPy twin has no bump mapping, so the differences are taken on ``frame.explain(x, y).total``,
the float64 re-derivation of a pixel (bumps and normal maps included), over a loss on a few dozen
pixels (``dL/dI`` zero elsewhere). Texels and heights are float32 multiples of 1/64; the step 2**-10
keeps the moved values exact. The image is not linear in them (the normalisations): central
differences err by O(step^2), far below the tolerance (relative 1e-4, as test_grad_fd.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common.layout import BUMP_COLS, BUMP_OFFSET

from .test_grad_fd import RTOL, perturbed

H, W = 40, 48
STEP = 2.0 ** -10
LIGHTS = (rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
          rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6)))


def _scene(bump=True, nmap=False, kd_map=False):
    rng = np.random.default_rng(3)
    extra = {}
    if bump:
        extra["bump"] = rs.HeightMap(rng.integers(0, 64, (6, 8)) / 64.0, scale=0.05)
    if nmap:
        t = np.empty((5, 7, 3))
        t[..., :2] = rng.integers(20, 44, (5, 7, 2)) / 64.0
        t[..., 2] = rng.integers(52, 64, (5, 7)) / 64.0
        extra["normal_map"] = rs.Texture(t, name="nmap")
        extra["normal_scale"] = 0.8
    if kd_map:
        extra["kd_map"] = rs.Texture(rng.integers(16, 64, (4, 6, 3)) / 64.0, name="kd")
    mat = rs.Material(kd=(0.6, 0.4, 0.3), ka=(0.5, 0.6, 0.7), ks=(0.5, 0.4, 0.6), shininess=20.0, **extra)
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), mat)], lights=LIGHTS,
                    camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H), ambient=(0.1, 0.12, 0.08))


def _moved_nmap(scene, ijc, delta):
    mat = scene.models[0].material
    texels = np.array(mat.normal_map.texels, np.float64)
    texels[ijc] += delta
    new = dataclasses.replace(mat, normal_map=rs.Texture(texels, name="nmap"))
    return scene.replace(models=(dataclasses.replace(scene.models[0], material=new),))


def _pixels(frame, count=40):
    ys, xs = np.nonzero(frame.hits.prim >= 0)
    pick = np.random.default_rng(4).choice(ys.size, count, replace=False)
    return list(zip(xs[pick], ys[pick]))


def _weights(pixels):
    g = np.zeros((H, W, 3))
    rng = np.random.default_rng(9)
    for x, y in pixels:
        g[y, x] = rng.standard_normal(3)
    return g


def _loss(frame, pixels, g):
    return float(sum(np.dot(g[y, x], frame.explain(x, y).total) for x, y in pixels))


def _check_array(g, packed_get, packed_set, loss, picks, step):
    top = float(np.max(np.abs(g)))
    assert top > 0
    for idx, gi in picks:
        keep = packed_get(idx)
        packed_set(idx, keep + step)
        up = loss()
        packed_set(idx, keep - step)
        down = loss()
        packed_set(idx, keep)
        fd = (up - down) / (2.0 * step)
        assert abs(gi - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"{idx}: {gi} vs {fd}"


@pytest.mark.parametrize("bump,nmap", [(True, False), (False, True), (True, True)])
def test_map_texel_and_normal_gradients_match_central_differences(bump, nmap):
    scene = _scene(bump, nmap)
    frame = rs.render(scene, "phong")
    pixels = _pixels(frame)
    gimg = _weights(pixels)
    names = ("normals",) + (("bump_map",) if bump else ()) + (("normal_map",) if nmap else ())
    g = rs.grad(scene, gimg, names, frame=frame)
    geo = scene.geometry
    loss = lambda: _loss(frame, pixels, gimg)  # noqa: E731
    if bump:
        (gb,) = g["bump_map"]
        assert gb.shape == scene.models[0].material.bump.heights.shape
        base, cols = int(geo.bump_info[0, BUMP_OFFSET]), int(geo.bump_info[0, BUMP_COLS])
        at = lambda ij: base + ij[0] * cols + ij[1]  # noqa: E731
        order = np.argsort(-np.abs(gb).ravel())[:4]
        picks = [(np.unravel_index(k, gb.shape), gb.ravel()[k]) for k in order]
        _check_array(gb, lambda ij: float(geo.bump_texels[at(ij)]),
                     lambda ij, val: geo.bump_texels.__setitem__(at(ij), val), loss, picks, STEP)
    if nmap:
        (gn,) = g["normal_map"]
        assert gn.shape == scene.models[0].material.normal_map.texels.shape
        order = np.argsort(-np.abs(gn).ravel())[:5]
        picks = [(np.unravel_index(k, gn.shape), gn.ravel()[k]) for k in order]
        for ijc, gi in picks:  # the frame's Texture is read by explain(): a moved copy, rendered again
            fd = (_loss(rs.render(_moved_nmap(scene, ijc, STEP), "phong"), pixels, gimg)
                  - _loss(rs.render(_moved_nmap(scene, ijc, -STEP), "phong"), pixels, gimg)) / (2.0 * STEP)
            assert abs(gi - fd) <= RTOL * max(abs(fd), 1e-2 * float(np.max(np.abs(gn)))), f"{ijc}: {gi} vs {fd}"
    gv = g["normals"]
    order = np.argsort(-np.abs(gv).ravel())[:5]
    picks = [(np.unravel_index(k, gv.shape), gv.ravel()[k]) for k in order]
    _check_array(gv, lambda ic: float(geo.normals[ic]), lambda ic, val: geo.normals.__setitem__(ic, val), loss,
                 picks, 1e-6)


@pytest.mark.parametrize("kd_map", [False, True])
def test_material_and_light_gradients_on_a_bumped_scene_match_central_differences(kd_map):
    """The material, ambient and light gradients at the bent normals (and textured coefficients)."""
    scene = _scene(True, True, kd_map)
    frame = rs.render(scene, "phong")
    pixels = _pixels(frame)
    gimg = _weights(pixels)
    names = ("ka", "kd", "ks", "shininess", "ambient", "light_position", "light_radiance")
    g = rs.grad(scene, gimg, names, frame=frame)
    for name in names:
        top = float(np.max(np.abs(g[name])))
        assert top > 0, name
        rows = [(0, None)] if name == "shininess" else [(None, c) for c in range(3)] if name == "ambient" else \
            [(r, c) for r in range(1 if name in ("ka", "kd", "ks") else (1 if name == "light_position" else 2))
             for c in range(3)]
        for index in rows:
            h = 1e-4 if name == "shininess" else 1e-6
            vals = []
            for d in (h, -h):
                moved = perturbed(scene, name, index, d)
                vals.append(_loss(rs.render(moved, "phong"), pixels, gimg))
            fd = (vals[0] - vals[1]) / (2.0 * h)
            r, c = index
            got = g[name][c] if r is None else (g[name][r] if c is None else g[name][r, c])
            assert abs(got - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"{name}{index}: {got} vs {fd}"


def test_geometry_on_a_bumped_scene_is_refused_and_other_methods_get_zero_texel_gradients():
    scene = _scene(True, True)
    gimg = np.random.default_rng(1).standard_normal((H, W, 3))
    with pytest.raises(ValueError, match="bump and normal maps: the geometry"):
        rs.grad(scene, gimg, ("vertices",))
    with pytest.warns(rs.BumpIgnoredWarning):  # Gouraud ignores both maps: said at render, and zero here
        g = rs.grad(scene, gimg, ("bump_map", "normal_map"), shading="gouraud")
    assert np.all(g["bump_map"][0] == 0.0) and np.all(g["normal_map"][0] == 0.0)
    plain = rs.grad(_scene(False, False), gimg, ("bump_map", "normal_map"))
    assert plain == {"bump_map": (None,), "normal_map": (None,)}


def test_samples_on_a_textured_bumped_scene_match_differences_of_the_antialiased_image():
    """``samples=4``: each sample's hits differentiated (the textured and bumped passes included),
    against central differences of ``render(samples=4)``'s float32 image in kd (step 0.01; the image
    is linear in kd, so only float32's rounding is left: seen 2e-6 relative)."""
    scene = _scene(True, False, kd_map=True)
    gimg = np.random.default_rng(1).standard_normal((H, W, 3))
    frame = rs.render(scene, "phong", samples=4)
    g = rs.grad(scene, gimg, ("kd", "bump_map"), frame=frame, samples=4)
    assert g["bump_map"][0].shape == scene.models[0].material.bump.heights.shape and np.any(g["bump_map"][0] != 0)
    for c in range(3):
        vals = [float(np.sum(gimg * rs.render(perturbed(scene, "kd", (0, c), d), "phong", samples=4).image))
                for d in (0.01, -0.01)]
        fd = (vals[0] - vals[1]) / 0.02
        assert abs(g["kd"][0, c] - fd) <= RTOL * abs(fd), f"kd[{c}]: {g['kd'][0, c]} vs {fd}"
