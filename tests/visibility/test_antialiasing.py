"""Anti-aliasing (render(..., samples=N)): the sample pattern, bit-identity at one sample, exact
centre buffers, shared per-face/per-vertex work, and coverage converging to the exact area
fraction of a half-plane's edge pixels on both backends; the grouped mean and the reused hit buffers."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common.samples import MAX_SAMPLES, check_samples, sample_offsets
from raycast_shade.shading.shade import SampleShading, shade_hits
from raycast_shade.visibility.cast import cast_camera
from raycast_shade.visibility.hits import HitBuffer
from raycast_shade.visibility.raster import rasterize
from raycast_shade.visibility.rays import subpixel_camera

BACKENDS = ("raycast", "raster")


# -- the pattern ------------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [1, 2, 3, 4, 7, 16, 64])
def test_pattern_is_n_rooks_with_the_centre_first(n):
    off = sample_offsets(n)
    assert off.shape == (n, 2) and off.dtype == np.float64
    assert np.array_equal(off[0], [0.0, 0.0])
    assert np.all(off >= -0.5) and np.all(off < 0.5)
    cols = np.floor((off[:, 0] + 0.5) * n + 1e-9).astype(int)  # one sample per 1/n-wide column
    assert sorted(cols) == list(range(n))
    assert len(np.unique(off, axis=0)) == n


@pytest.mark.parametrize("m", [2, 4, 6])
def test_pattern_is_a_0_m_2_net_for_powers_of_two(m):
    """Every dyadic box of area 1/N (2^a by 2^(m-a) cells) holds exactly one sample."""
    n = 2 ** m
    p = sample_offsets(n) + 0.5
    for a in range(m + 1):
        cx = np.floor(p[:, 0] * 2 ** a).astype(int)
        cy = np.floor(p[:, 1] * 2 ** (m - a)).astype(int)
        assert len(set(zip(cx, cy))) == n


def test_samples_are_checked():
    assert check_samples(np.int64(4)) == 4
    for bad, exc in ((0, ValueError), (MAX_SAMPLES + 1, ValueError), (2.0, TypeError), (True, TypeError),
                     ("4", TypeError)):
        with pytest.raises(exc, match="samples"):
            check_samples(bad)
    scene = _plane_scene()
    with pytest.raises(ValueError, match="^samples: must be >= 1"):
        rs.render(scene, samples=0)
    with pytest.raises(TypeError, match="^samples"):
        rs.render(scene, samples=1.5)


# -- scenes -----------------------------------------------------------------------------------------
def _plane_scene(width=24, height=16):
    return rs.Scene([rs.Model(rs.shapes.plane(size=1.4), rs.Material(kd=(0.7, 0.5, 0.3)))],
                    lights=[rs.DirectionalLight((0.3, -0.2, -1.0))], ambient=0.1, background=(0.2, 0.3, 0.9),
                    camera=rs.Camera(eye=(0.3, 0.4, 2.0), target=(0, 0, 0), width=width, height=height))


def _sphere_scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=30)),
                     rs.Model(rs.shapes.icosphere(1, radius=0.5, center=(1.2, 0.3, 0)), rs.Material(kd=0.6))],
                    lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square"),
                            rs.DirectionalLight((-1, -1, -1), intensity=0.3)],
                    camera=rs.Camera(eye=(0.4, 0.2, 3.5), width=40, height=30))


# -- one sample, the centre, shared work --------------------------------------------------------------
@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong", ("flat", "phong")])
def test_one_sample_is_the_frame_of_today(backend, shading):
    scene = _sphere_scene()
    a = rs.render(scene, shading, backend=backend)
    b = rs.render(scene, shading, backend=backend, samples=1, buffers=("coverage", "mask"))
    assert np.array_equal(a.image, b.image)
    assert all(np.array_equal(x, y) for x, y in zip(a.hits, b.hits))
    assert np.array_equal(b.buffers["coverage"], b.buffers["mask"].astype(np.float32))


@pytest.mark.parametrize("backend", BACKENDS)
def test_many_samples_keep_the_centre_buffers(backend):
    """ids, depth and normals stay the pixel centre's: exactly the one-sample frame's."""
    scene = _sphere_scene()
    names = ("depth", "normal", "model_id", "triangle_id", "mask", "coverage")
    one = rs.render(scene, "gouraud", backend=backend, buffers=names)
    many = rs.render(scene, "gouraud", backend=backend, samples=8, buffers=names)
    assert all(np.array_equal(x, y) for x, y in zip(one.hits, many.hits))
    for name in names[:-1]:
        assert np.array_equal(one.buffers[name], many.buffers[name]), name
    assert not np.array_equal(one.image, many.image)  # the edges did change
    cov = many.buffers["coverage"]
    assert set(np.unique(cov * 8)) <= set(range(9))
    assert np.all(cov[one.buffers["mask"] & (cov < 1)] > 0)  # a hit centre is one hit sample at least


@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong", ("gouraud", "flat")])
def test_shared_shading_is_shade_hits_bit_for_bit(shading):
    """The faces and vertices shaded once for all samples give each sample the image shade_hits gives."""
    scene = _sphere_scene()
    cam = scene.camera
    shader = SampleShading(scene, cam, shading)
    for dx, dy in sample_offsets(4):
        sub = subpixel_camera(cam, dx, dy)
        hits = cast_camera(scene.geometry, sub)
        assert np.array_equal(shader.shade(hits), shade_hits(scene, cam, hits, shading))
    if shader.flat:
        assert shader.seen.face_done.sum() > 0
    if shader.gouraud:
        assert shader.seen.vertex_done.sum() > 0


def test_box_filter_of_a_uniform_colour_is_that_colour():
    """A plane lit by a directional light under flat shading is one colour: every pixel that all
    samples hit keeps it exactly, and every pixel mixes it with the background by its coverage."""
    scene = _plane_scene()
    one = rs.render(scene, "flat")
    colour = one.image[one.hits.prim >= 0][0]
    for backend in BACKENDS:
        f = rs.render(scene, "flat", backend=backend, samples=16, buffers=("coverage",))
        cov = f.buffers["coverage"][..., None]
        expect = cov * colour + (1 - cov) * np.asarray(scene.background, np.float32)
        np.testing.assert_allclose(f.image, expect, atol=2e-7)
        assert np.array_equal(f.image[cov[..., 0] == 1], np.broadcast_to(colour, f.image[cov[..., 0] == 1].shape))


def test_offset_moves_the_rays_by_that_much():
    """An offset of a whole pixel is the neighbouring pixel's ray, on both backends."""
    scene = _sphere_scene()
    geo, cam = scene.geometry, scene.camera
    centre = cast_camera(geo, cam)
    right = cast_camera(geo, cam, offset=(1.0, 0.0))
    down = rasterize(geo, cam, offset=(0.0, 1.0))
    assert np.mean(right.prim[:, :-1] == centre.prim[:, 1:]) > 0.995
    assert np.mean(down.prim[:-1] == rasterize(geo, cam).prim[1:]) > 0.995
    np.testing.assert_allclose(right.t[:, :-1][right.prim[:, :-1] == centre.prim[:, 1:]],
                               centre.t[:, 1:][right.prim[:, :-1] == centre.prim[:, 1:]], rtol=1e-5)
    with pytest.raises(TypeError, match="^offset"):
        cast_camera(geo, cam, offset=0.5)
    with pytest.raises(ValueError, match=r"^offset\[1\]"):
        rasterize(geo, cam, offset=(0.0, np.nan))


@pytest.mark.parametrize("dx, dy", [(0.25, -0.375), (-0.5, 0.125)])
def test_backends_agree_off_centre(dx, dy):
    scene = _sphere_scene()
    a = cast_camera(scene.geometry, scene.camera, offset=(dx, dy))
    b = rasterize(scene.geometry, scene.camera, offset=(dx, dy))
    same = (a.prim == b.prim) & (a.geom == b.geom)
    assert same.mean() > 0.99
    np.testing.assert_allclose(a.t[same & (a.prim >= 0)], b.t[same & (b.prim >= 0)], rtol=1e-5)


# -- the half-plane: coverage -> exact area fraction ------------------------------------------------
ANGLE = np.radians(30.0)
W = H = 48


def _half_plane():
    """A triangle so large that, on screen, it is the half-plane n.(p - p0) >= 0 with a straight edge at
    30 degrees through p0, seen orthographically at one world unit per pixel."""
    d = np.array([np.cos(ANGLE), np.sin(ANGLE), 0.0])
    n = np.array([-d[1], d[0], 0.0])
    p0 = np.array([0.3141, -0.2718, 0.0])
    big = 4000.0
    verts = np.array([p0 - big * d, p0 + big * d, p0 + big * n])
    mesh = rs.Mesh(verts, np.array([[0, 1, 2]]))
    cam = rs.Camera(eye=(0, 0, 10), target=(0, 0, 0), width=W, height=H, projection="orthographic",
                    ortho_height=float(H))
    scene = rs.Scene([rs.Model(mesh, rs.Material(kd=0.5))], lights=[rs.DirectionalLight((0, 0, -1))], camera=cam)
    return scene, p0, n


def _exact_fraction(p0, n):
    """(H, W) area of each pixel square on the covered side (polygon clipping, shoelace)."""
    out = np.zeros((H, W))
    for j in range(H):
        for i in range(W):
            x0, y1 = -W / 2 + i, H / 2 - j  # the pixel spans [x0, x0 + 1] x [y1 - 1, y1]
            square = [(x0, y1 - 1), (x0 + 1, y1 - 1), (x0 + 1, y1), (x0, y1)]
            f = [n[0] * (x - p0[0]) + n[1] * (y - p0[1]) for x, y in square]
            poly = []
            for k in range(4):
                a, b, fa, fb = square[k], square[(k + 1) % 4], f[k], f[(k + 1) % 4]
                if fa >= 0:
                    poly.append(a)
                if fa * fb < 0:
                    s = fa / (fa - fb)
                    poly.append((a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])))
            if len(poly) >= 3:
                x, y = np.array(poly).T
                out[j, i] = 0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1)))
    return out


@pytest.mark.parametrize("backend", BACKENDS)
def test_edge_coverage_converges_to_the_area_fraction(backend):
    scene, p0, n = _half_plane()
    exact = _exact_fraction(p0, n)
    edge = (exact > 1e-9) & (exact < 1 - 1e-9)
    assert edge.sum() > 40
    worst, mean = [], []
    for samples in (1, 4, 16, 64, 256):
        cov = rs.render(scene, "flat", backend=backend, samples=samples, buffers=("coverage",)).buffers["coverage"]
        assert np.array_equal(cov[~edge], exact[~edge].round())  # whole pixels: exact at any N
        err = np.abs(cov[edge] - exact[edge])
        worst.append(err.max())
        mean.append(err.mean())
        assert err.max() <= 1.0 / np.sqrt(samples) + 1e-6, (samples, err.max())
    assert worst[-1] < 0.02 and mean[-1] < 0.005
    assert all(a > b for a, b in zip(mean, mean[1:])), mean
    assert all(a > b for a, b in zip(worst[1:], worst[2:])), worst


def test_backends_agree_on_coverage():
    scene, _, _ = _half_plane()
    a, b = (rs.render(scene, "flat", backend=be, samples=16, buffers=("coverage",)).buffers["coverage"]
            for be in BACKENDS)
    assert np.abs(a - b).max() <= 1.0 / 16


def test_scene_file_and_cli_take_samples(tmp_path):
    from raycast_shade.apps.args import add_render_options, overrides
    import argparse

    path = tmp_path / "s.toml"
    path.write_text('[camera]\neye = [0, 0, 3]\nwidth = 20\nheight = 10\n[[object]]\nshape = "icosphere"\n'
                    '[[light]]\ntype = "directional"\ndirection = [0, 0, -1]\n[render]\nsamples = 4\n')
    f = rs.render_file(path)
    one = rs.render_file(path, samples=1)
    assert all(np.array_equal(x, y) for x, y in zip(f.hits, one.hits))
    assert not np.array_equal(f.image, one.image)
    p = argparse.ArgumentParser()
    add_render_options(p)
    assert overrides(p.parse_args(["--samples", "16"]))["samples"] == 16
    with pytest.raises(SystemExit):
        p.parse_args(["--samples", "0"])
    path.write_text(path.read_text().replace("samples = 4", "samples = 0"))
    with pytest.raises(ValueError, match="render.samples: must be >= 1"):
        rs.render_file(path)


# -- the mean's passes, and the reused buffers ----------------------------------------------------------
@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("samples", [2, 4, 5, 9])
def test_grouped_mean_is_the_sample_by_sample_mean(backend, samples):
    """Groups of samples per accumulator pass, reused hit buffers: the float64 mean of the
    samples' own images added one at a time, bit for bit, and their coverage."""
    scene = _sphere_scene()
    cam = scene.camera
    shader = SampleShading(scene, cam, "phong")
    acc = np.zeros((cam.height, cam.width, 3))
    hit = np.zeros((cam.height, cam.width))
    for dx, dy in sample_offsets(samples):
        sub = subpixel_camera(cam, dx, dy)
        hits = cast_camera(scene.geometry, sub) if backend == "raycast" else rasterize(scene.geometry, sub)
        acc += shader.shade(hits)
        hit += hits.prim >= 0
    for buffers in ((), ("coverage",)):
        f = rs.render(scene, "phong", backend=backend, samples=samples, buffers=buffers)
        assert np.array_equal(f.image, (acc / samples).astype(np.float32))
    assert np.array_equal(f.buffers["coverage"], (hit * (1.0 / samples)).astype(np.float32))


@pytest.mark.parametrize("backend", BACKENDS)
def test_out_buffer_is_filled_in_place(backend):
    scene = _sphere_scene()
    cam = subpixel_camera(scene.camera, 0.25, -0.25)
    visibility = cast_camera if backend == "raycast" else rasterize
    fresh = visibility(scene.geometry, cam)
    out = HitBuffer.empty(cam.height, cam.width)
    for a in out:
        a.fill(7)  # stale values must all be overwritten
    got = visibility(scene.geometry, cam, out=out)
    assert all(x is y for x, y in zip(got, out))
    assert all(np.array_equal(x, y) for x, y in zip(fresh, out))
    with pytest.raises(ValueError, match="out.prim"):
        visibility(scene.geometry, cam, out=HitBuffer.empty(cam.height + 1, cam.width))
    with pytest.raises(TypeError, match="out"):
        visibility(scene.geometry, cam, out=tuple(out))
