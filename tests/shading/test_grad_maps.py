"""``rs.grad``'s mesh colours and colour-map texels (shading/grad_maps.py) against central differences.

The image is linear in a colour and in a texel (for the methods and filters differentiated here), so
central differences are exact up to float64's rounding at any step: 0.1 for colours, 0.25 for texels
(texel values multiples of 1/64, so the float32 texels hold the moved values exactly). Each difference
is taken on the NumPy twin of the kernels (``study.reference.shade_reference``) over the frame's own
hit buffer, itself checked against ``rs.render``'s image. Relative error <= 1e-4 (seen: ~1e-13).
"""

from __future__ import annotations

import dataclasses

import numba
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.reference import shade_reference

from .test_grad_fd import H, RTOL, W

LIGHTS = (rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
          rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6)))


def _scene(colors=None, color_mode="vertex", ka_colors=True, **maps):
    base = rs.shapes.icosphere(2)
    mesh = rs.Mesh(base.vertices, base.faces, normals=base.normals, uvs=base.uvs, colors=colors,
                   color_mode=color_mode if colors is not None else "auto")
    mat = rs.Material(kd=(0.6, 0.4, 0.3), ka=(0.5, 0.6, 0.7), ks=(0.5, 0.4, 0.6), shininess=20.0,
                      ka_colors=ka_colors, **maps)
    return rs.Scene([rs.Model(mesh, mat)], lights=LIGHTS, camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H),
                    ambient=(0.1, 0.12, 0.08))


def _texture(seed, wrap="repeat", shape=(6, 8), filt="bilinear"):
    texels = np.random.default_rng(seed).integers(16, 64, shape + (3,)) / 64.0
    return rs.Texture(texels, wrap=wrap, filter=filt, name=f"tex{seed}")


@pytest.fixture(scope="module")
def weights():
    return np.random.default_rng(5).standard_normal((H, W, 3))


def _loss(scene, hits, shading, weights):
    return float(np.sum(weights * shade_reference(scene, scene.camera, hits, shading)))


def _frame(scene, shading):
    frame = rs.render(scene, shading)
    np.testing.assert_allclose(shade_reference(scene, scene.camera, frame.hits, shading), frame.image,
                               rtol=2e-6, atol=1e-7)
    return frame


def _check_packed(scene, frame, shading, weights, g, packed, step=0.1, rows=4):
    """``g`` against central differences of the packed array ``packed`` (moved in place), on the
    ``rows`` rows with the largest gradient."""
    top = float(np.max(np.abs(g)))
    assert top > 0
    for i in np.argsort(-np.abs(g).max(axis=1))[:rows]:
        for c in range(3):
            keep = packed[i, c]
            packed[i, c] = keep + step
            up = _loss(scene, frame.hits, shading, weights)
            packed[i, c] = keep - step
            down = _loss(scene, frame.hits, shading, weights)
            packed[i, c] = keep
            fd = (up - down) / (2.0 * step)
            assert abs(g[i, c] - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"row {i}, {c}: {g[i, c]} vs {fd}"


@pytest.mark.parametrize("shading", ["phong", "gouraud", "flat"])
def test_vertex_colour_gradients_match_central_differences(shading, weights):
    n = rs.shapes.icosphere(2).vertices.shape[0]
    scene = _scene(np.random.default_rng(1).uniform(0.2, 0.9, (n, 3)))
    frame = _frame(scene, shading)
    g = rs.grad(scene, weights, "vertex_colors", shading=shading, frame=frame)["vertex_colors"]
    assert g.shape == scene.geometry.vertex_colors.shape
    _check_packed(scene, frame, shading, weights, g, scene.geometry.vertex_colors)


@pytest.mark.parametrize("shading", ["phong", "gouraud", "flat"])
def test_face_colour_gradients_match_central_differences(shading, weights):
    f = rs.shapes.icosphere(2).faces.shape[0]
    scene = _scene(np.random.default_rng(2).uniform(0.2, 0.9, (f, 3)), "face", ka_colors=False)
    frame = _frame(scene, shading)
    g = rs.grad(scene, weights, ("face_colors", "vertex_colors"), shading=shading, frame=frame)
    assert g["face_colors"].shape == scene.geometry.face_colors.shape
    assert np.all(g["vertex_colors"] == 0.0)  # the mesh has face colours only
    _check_packed(scene, frame, shading, weights, g["face_colors"], scene.geometry.face_colors)


def _moved_texel(scene, slot, i, j, c, delta):
    mat = scene.models[0].material
    tex = getattr(mat, slot)
    texels = np.array(tex.texels, np.float64)
    texels[i, j, c] += delta
    new = dataclasses.replace(mat, **{slot: rs.Texture(texels, wrap=tex.wrap, filter=tex.filter, name=tex.name)})
    return scene.replace(models=(dataclasses.replace(scene.models[0], material=new),))


@pytest.mark.parametrize("shading,wrap,filt", [("phong", "repeat", "bilinear"), ("phong", "clamp", "bilinear"),
                                               ("flat", "repeat", "bilinear"), ("gouraud", "repeat", "bilinear"),
                                               ("phong", "repeat", "mipmap"), ("phong", "clamp", "mipmap"),
                                               ("flat", "repeat", "mipmap"), ("gouraud", "clamp", "mipmap")])
def test_texel_gradients_match_central_differences(shading, wrap, filt, weights):
    """Bilinear: 6x8 and 5x7 maps (magnified). Mip-mapped: 96x128 and 75x105 maps (odd sizes: the
    pyramid's 3-wide boxes), minified on the 48x36 sphere, so the pixels sample between levels."""
    shapes = ((6, 8), (5, 7)) if filt == "bilinear" else ((96, 128), (75, 105))
    scene = _scene(kd_map=_texture(3, wrap, shapes[0], filt), ks_map=_texture(4, wrap, shapes[1], filt))
    frame = _frame(scene, shading)
    if filt == "mipmap" and shading == "phong":
        levels = rs.shading.texture.texture_levels(scene, scene.camera, frame.hits, "kd")
        assert np.nanmin(levels) > 0.0 and np.nanmax(levels) > 3.0  # minified: blends between several levels
    g = rs.grad(scene, weights, ("kd_map", "ks_map"), shading=shading, frame=frame)
    for slot in ("kd_map", "ks_map"):
        (gm,) = g[slot]
        assert gm.shape == getattr(scene.models[0].material, slot).texels.shape
        top = float(np.max(np.abs(gm)))
        assert top > 0
        flat_order = np.argsort(-np.abs(gm).ravel())
        picks = [np.unravel_index(k, gm.shape) for k in flat_order[:4]] + [np.unravel_index(flat_order[-1], gm.shape)]
        for i, j, c in picks:
            up = _loss(_moved_texel(scene, slot, i, j, c, 0.25), frame.hits, shading, weights)
            down = _loss(_moved_texel(scene, slot, i, j, c, -0.25), frame.hits, shading, weights)
            fd = (up - down) / 0.5
            assert abs(gm[i, j, c] - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"{slot}[{i}, {j}, {c}]: {gm[i, j, c]} vs {fd}"


@pytest.mark.parametrize("shading,mode", [("phong", "vertex"), ("gouraud", "vertex"), ("flat", "vertex"),
                                          ("phong", "face")])
def test_colours_and_maps_on_one_model_match_central_differences(shading, mode, weights):
    """Colours times a kd map (mip-mapped), ka times the colour and a ka map and the occlusion: the
    colour's gradient carries the samples, the kd texels' the colour (the ks map's the row's ks)."""
    base = rs.shapes.icosphere(2)
    n = (base.vertices if mode == "vertex" else base.faces).shape[0]
    scene = _scene(np.random.default_rng(6).uniform(0.2, 0.9, (n, 3)), mode, kd_map=_texture(3, "repeat", (40, 56), "mipmap"),
                   ks_map=_texture(4), ka_map=_texture(8), ao_map=_texture(9))
    frame = _frame(scene, shading)
    g = rs.grad(scene, weights, (f"{mode}_colors", "kd_map", "ks_map"), shading=shading, frame=frame)
    packed = scene.geometry.vertex_colors if mode == "vertex" else scene.geometry.face_colors
    _check_packed(scene, frame, shading, weights, g[f"{mode}_colors"], packed, rows=3)
    for slot in ("kd_map", "ks_map"):
        (gm,) = g[slot]
        top = float(np.max(np.abs(gm)))
        for k in np.argsort(-np.abs(gm).ravel())[:3]:
            i, j, c = np.unravel_index(k, gm.shape)
            up = _loss(_moved_texel(scene, slot, i, j, c, 0.25), frame.hits, shading, weights)
            down = _loss(_moved_texel(scene, slot, i, j, c, -0.25), frame.hits, shading, weights)
            fd = (up - down) / 0.5
            assert abs(gm[i, j, c] - fd) <= RTOL * max(abs(fd), 1e-2 * top), f"{slot}[{i}, {j}, {c}]: {gm[i, j, c]} vs {fd}"


def test_colour_gradients_are_bit_identical_across_thread_counts(weights):
    n = rs.shapes.icosphere(2).vertices.shape[0]
    scene = _scene(np.random.default_rng(1).uniform(0.2, 0.9, (n, 3)))
    frame = rs.render(scene, "phong")
    before = numba.get_num_threads()
    runs = []
    try:
        for threads in (1, 2, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            runs.append(rs.grad(scene, weights, "vertex_colors", frame=frame)["vertex_colors"])
    finally:
        numba.set_num_threads(before)
    assert runs[0].tobytes() == runs[1].tobytes() == runs[2].tobytes()


def test_the_sampled_image_gradient_is_the_mean_of_its_samples(weights):
    """``samples=4``: the image is the mean of four sub-pixel images, each linear in the colours and
    texels: the gradient equals the differences of ``render(samples=4)`` (float32 images: step 0.25,
    texel values exact in float32, tolerance 1e-4 of the largest component)."""
    n = rs.shapes.icosphere(2).vertices.shape[0]
    scene = _scene(np.random.default_rng(1).uniform(0.25, 0.75, (n, 3)), kd_map=_texture(3))
    g = rs.grad(scene, weights, ("vertex_colors", "kd_map"), samples=4)
    loss = lambda s: float(np.sum(weights * rs.render(s, "phong", samples=4).image.astype(np.float64)))
    (gm,) = g["kd_map"]
    for k in np.argsort(-np.abs(gm).ravel())[:2]:
        i, j, c = np.unravel_index(k, gm.shape)
        fd = (loss(_moved_texel(scene, "kd_map", i, j, c, 0.25)) - loss(_moved_texel(scene, "kd_map", i, j, c, -0.25))) / 0.5
        assert abs(gm[i, j, c] - fd) <= 1e-4 * np.max(np.abs(gm)), (gm[i, j, c], fd)
    one = rs.grad(scene, weights, ("vertex_colors",))["vertex_colors"]
    assert not np.allclose(one, g["vertex_colors"])  # the samples' own hits, not the centre's


def test_what_is_not_differentiated_is_refused_by_name(weights):
    n = rs.shapes.icosphere(2).vertices.shape[0]
    coloured = _scene(np.full((n, 3), 0.5))
    g = rs.grad(coloured, weights, ("vertex_colors", "vertices"))  # the geometry: tests/shading/test_grad_geotex.py
    assert np.any(g["vertices"] != 0.0) and np.any(g["vertex_colors"] != 0.0)
    textured = _scene(kd_map=_texture(3))
    assert rs.grad(textured, weights, "ks_map")["ks_map"] == (None,)  # no ks map: nothing to differentiate
    plain = _scene()  # no colours, no maps: zeros beside the other families, in the order asked
    g = rs.grad(plain, weights, ("kd_map", "kd", "vertex_colors", "face_colors"))
    assert list(g) == ["kd_map", "kd", "vertex_colors", "face_colors"] and g["kd_map"] == (None,)
    assert np.all(g["vertex_colors"] == 0) and np.all(g["face_colors"] == 0) and np.any(g["kd"] != 0)


@pytest.mark.parametrize("wrap", ["repeat", "clamp"])
def test_the_texel_scatter_is_the_samplers_transpose_even_at_huge_uvs(wrap):
    """The scatter's weights applied to the texels give the forward sampler's value
    (``texture._sample_level``), huge, infinite and NaN UVs included (reduced as the sampler reduces them)."""
    from raycast_shade.shading.grad_texels import texel_scatter as _texel_scatter
    from raycast_shade.shading.texture import _sample_level

    tex = rs.Texture(np.random.default_rng(0).uniform(0.0, 1.0, (5, 7, 3)), wrap=wrap, filter="bilinear")
    info = tex.packed_info(0)[None]
    for u, v in [(0.3, 0.7), (-0.05, 1.02), (1e17, 3.0), (-1e300, 0.2), (np.inf, 0.5), (np.nan, 0.1),
                 (2.0 ** 53 + 3, -7.25)]:
        want = np.array(_sample_level(tex.packed_texels(), info, 0, u, v, 0))
        weights = _texel_scatter(info, 0, np.array([[u, v]]), np.ones((1, 3)))
        got = np.einsum("ijc,ijc->c", weights, tex.texels.astype(np.float64))
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15, err_msg=f"uv {(u, v)}")
