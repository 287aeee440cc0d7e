"""Band-by-band rendering (issue 16): the same bits as the whole frame, without its hit buffer.

A Phong frame that asks for no buffer is cast and shaded in bands of rows
(:mod:`raycast_shade.visibility.bands`); its hit buffer is cast again only if
someone reads ``frame.hits``. These tests hold the band path to the
whole-frame path bit for bit (the casts, with their vertex repairs across band
borders; the shaded images, textures and shadows included), check what the
frame keeps, and bound the memory a render allocates.
"""

from __future__ import annotations

import pathlib
import sys
import threading
import tracemalloc

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.visibility import bands, cast, holes
from raycast_shade.visibility.accel import embree_accel
from raycast_shade.visibility.rays import camera_frame

from tests.visibility.test_watertight import _vertex_grid  # the failure catalogue's vertex grid

RENDER = sys.modules["raycast_shade.render"]


@pytest.fixture
def small_bands(monkeypatch):
    """The band path for this file's small frames, in bands of 16 rows (several per frame)."""
    monkeypatch.setattr(bands, "BAND_ROWS", 16)
    monkeypatch.setattr(bands, "MIN_PIXELS", 0)


def _grid_scene(width=130, height=98):
    """Every pixel ray passes through a vertex or an edge of a grid, a plane behind it:
    dozens of rays slip and are repaired, on rows all over the image."""
    cam = rs.Camera(eye=(3.0, -40.0, 50.0), target=(0.0, 0.2, 0.0), width=width, height=height, fov=2.0)
    floor = rs.shapes.plane(size=400.0, center=(0.0, 0.0, -1.0), normal="+z")
    return rs.Scene([rs.Model(_vertex_grid(cam, 1)), rs.Model(floor)], lights=[rs.PointLight((0, 0, 40.0))],
                    camera=cam)


def _stitched(geometry, camera, rows):
    out = rs.HitBuffer.empty(camera.height, camera.width)
    starts = []
    for y, band in bands.cast_bands(geometry, camera, rows):
        starts.append((y, band.shape[0]))
        for dst, src in zip(out, band):
            dst[y:y + band.shape[0]] = src
    return out, starts


@pytest.mark.parametrize("rows", [4, 8, 12, 64])
def test_bands_are_the_whole_frame_cast_bit_for_bit(rows):
    scene = _grid_scene()
    geo, cam = scene.geometry, scene.camera
    whole = rs.cast_camera(geo, cam)
    raw = rs.HitBuffer.empty(cam.height, cam.width)
    cast._cast_camera_kernel(embree_accel(geo).handle, camera_frame(cam, geo.origin), *raw, 0, 0, 0, 0,
                             np.empty(cam.height, np.int64), 1e-3)
    repaired = np.flatnonzero((raw.prim != whole.prim).ravel()) // cam.width
    assert len(repaired) >= 10 and len(np.unique(repaired // rows)) >= min(3, -(-cam.height // rows))  # in most bands
    got, starts = _stitched(geo, cam, rows)
    for a, b in zip(got, whole):
        np.testing.assert_array_equal(a, b)
    # The bands tile the image, top to bottom.
    assert [s for s, _ in starts] == list(np.cumsum([0] + [n for _, n in starts[:-1]]))
    assert sum(n for _, n in starts) == cam.height


@pytest.mark.parametrize("top, lo, hi", [(0, 0, 0), (0, 0, -1), (2, 1, -1), (2, 1, 0), (2, 5, -40)])
def test_the_cast_kernel_counts_the_slips_it_casts(top, lo, hi):
    """The suspicious-pixel count folded into the packet loop: after the serial finish of
    the rows it leaves at block boundaries, each row of ``lo .. hi`` has the count of the
    separate test over the same window (rows before ``top`` cast beforehand, as a band's
    neighbours are); rows outside keep their value. The hits are the whole frame's rows.
    Rows beyond the window are refused."""
    scene = _grid_scene(width=130, height=98 + 2)
    geo, cam = scene.geometry, scene.camera
    handle, cf = embree_accel(geo).handle, camera_frame(cam, geo.origin)
    whole = rs.HitBuffer.empty(cam.height, cam.width)
    cast._cast_camera_kernel(handle, cf, *whole, 0, 0, 0, 0, np.empty(cam.height, np.int64), 1e-3)
    y0 = 4 - top  # window row ``top`` is image row 4 (a tile boundary)
    n = top + 96
    hi += n  # ``hi`` given from the window's end
    win = rs.HitBuffer.empty(n, cam.width)
    for dst, src in zip(win, whole):
        dst[:top] = src[y0:y0 + top]  # the rows "cast before"
    counts = np.full(n, 7, np.int64)
    cast._cast_camera_kernel(handle, cf, *win, y0, top, lo, hi, counts, holes._JUMP)
    for dst, src in zip(win, whole):
        np.testing.assert_array_equal(dst, src[y0:y0 + n])
    assert (counts[:lo] == 7).all() and (counts[hi:] == 7).all()
    holes.finish_counts(win.prim, win.t, 1.0 + holes._JUMP, counts, lo, hi)
    want = holes._suspicious_rows_kernel(win.prim, win.t, holes._JUMP)
    assert counts[lo:hi].tolist() == want[lo:hi].tolist() and want[lo:hi].sum() >= 10
    with pytest.raises(ValueError, match="rows"):
        cast._cast_camera_kernel(handle, cf, *win, y0, top, lo, n + 1, counts, holes._JUMP)


def test_a_frame_no_taller_than_a_band_is_one_band():
    scene = _grid_scene(height=40)
    (y, band), = list(bands.cast_bands(scene.geometry, scene.camera, 64))
    assert y == 0 and band.shape == (40, 130)
    np.testing.assert_array_equal(band.t, rs.cast_camera(scene.geometry, scene.camera).t)


@pytest.mark.parametrize("rows", [0, -4, 6, 4.0, "8", True])
def test_band_rows_must_be_a_positive_multiple_of_the_tile(rows):
    scene = _grid_scene()
    with pytest.raises(ValueError, match="rows"):
        next(bands.cast_bands(scene.geometry, scene.camera, rows))


def _both(scene, **kw):
    """The same frame through the band path and the whole-frame path."""
    banded = rs.render(scene, "phong", **kw)
    saved = RENDER._banded
    try:
        RENDER._banded = lambda *a: False
        whole = rs.render(scene, "phong", **kw)
    finally:
        RENDER._banded = saved
    return banded, whole


def _textured_sphere(**cam):
    from raycast_shade.scene.texture import Texture

    mesh = rs.shapes.uv_sphere(24, 48)
    mat = rs.Material(kd_map=Texture.checker(16, 8), ks=0.4, shininess=30)
    return rs.Scene([rs.Model(mesh, mat), rs.Model(rs.shapes.plane(size=6.0, center=(0, -1.0, 0), normal="+y"))],
                    lights=[rs.PointLight((2, 3, 4), intensity=20.0, shadows=True)],
                    camera=rs.Camera(eye=(0.4, 0.6, 3.0), width=101, height=150, **cam))


@pytest.mark.parametrize("cam", [dict(fov=45.0), dict(projection="orthographic", ortho_height=3.0),
                                 dict(fx=120.0, fy=125.0, cx=40.3, cy=90.7)], ids=["perspective", "ortho", "intrinsics"])
@pytest.mark.usefixtures("small_bands")
def test_a_banded_frame_is_the_whole_frame_bit_for_bit(cam):
    """Textures (whose footprint needs each pixel's image row), shadows, both projections and a
    shifted principal point: the band path's image, mask and (cast again) hits are the whole
    frame's."""
    banded, whole = _both(_textured_sphere(**cam))
    assert callable(banded.__dict__["_hits"]) and not callable(whole.__dict__["_hits"])
    np.testing.assert_array_equal(banded.image, whole.image)
    np.testing.assert_array_equal(banded.mask, whole.mask)
    assert 0.2 < banded.mask.mean() < 1.0
    for a, b in zip(banded.hits, whole.hits):
        np.testing.assert_array_equal(a, b)
    assert set(banded.timings) >= {"cast", "shade", "total"}


@pytest.mark.usefixtures("small_bands")
def test_the_vertex_grid_renders_the_same_banded():
    banded, whole = _both(_grid_scene())
    np.testing.assert_array_equal(banded.image, whole.image)
    assert (banded.hits.geom == 0).all()  # no pixel shows the plane behind the grid


@pytest.mark.parametrize("kw", [dict(interpolation="screen"), dict(backend="raster")])
@pytest.mark.usefixtures("small_bands")
def test_frames_that_need_the_whole_hit_buffer_keep_it(kw):
    """(Terms are banded, in the image's own pass: tests/shading/test_terms.py.)"""
    frame = rs.render(_textured_sphere(fov=45.0), "phong", **kw)
    assert not callable(frame.__dict__["_hits"])


def _both_methods(scene, shading, **kw):
    """:func:`_both` for any methods."""
    banded = rs.render(scene, shading, **kw)
    saved = RENDER._banded
    try:
        RENDER._banded = lambda *a: False
        whole = rs.render(scene, shading, **kw)
    finally:
        RENDER._banded = saved
    return banded, whole


def _same(banded, whole):
    assert callable(banded.__dict__["_hits"]) and not callable(whole.__dict__["_hits"])
    np.testing.assert_array_equal(banded.image, whole.image)
    np.testing.assert_array_equal(banded.mask, whole.mask)
    assert list(banded.buffers) == list(whole.buffers)
    for name in whole.buffers:
        a, b = banded.buffers[name], whole.buffers[name]
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)


ALL_BUFFERS = tuple(n for n in rs.output.buffers.BUFFER_NAMES)


@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong", ("gouraud", "flat")])
@pytest.mark.parametrize("cam", [dict(fov=45.0), dict(fx=120.0, fy=125.0, cx=40.3, cy=90.7)],
                         ids=["perspective", "intrinsics"])
@pytest.mark.usefixtures("small_bands")
def test_every_method_and_buffer_is_the_whole_frame_bit_for_bit(shading, cam):
    """Flat faces and Gouraud vertices shaded once, by the first band that sees them; textures
    (a colour-mapped Gouraud model takes the modulate path, whose lookups need the image row)
    and shadows; every buffer."""
    banded, whole = _both_methods(_textured_sphere(**cam), shading, buffers=ALL_BUFFERS)
    _same(banded, whole)
    assert 0.2 < banded.mask.mean() < 1.0 and len(banded.buffers) == len(ALL_BUFFERS)


@pytest.mark.parametrize("kw", [dict(samples=2), dict(samples=4, buffers=("coverage", "zdepth")),
                                dict(samples=5), dict(samples=9, buffers=("coverage", "normal_camera"))],
                         ids=["2", "4-coverage", "5", "9-coverage"])
@pytest.mark.parametrize("shading", ["phong", "gouraud", "flat"])
@pytest.mark.usefixtures("small_bands")
def test_samples_are_banded_and_the_whole_frame_bit_for_bit(kw, shading):
    banded, whole = _both_methods(_textured_sphere(fov=45.0), shading, **kw)
    _same(banded, whole)
    if "coverage" in whole.buffers:
        cov = whole.buffers["coverage"]
        assert ((cov > 0) & (cov < 1)).any()  # edge pixels partly covered
    for a, b in zip(banded.hits, whole.hits):
        np.testing.assert_array_equal(a, b)


@pytest.mark.usefixtures("small_bands")
def test_a_distorted_camera_is_one_band_with_its_buffers():
    scene = _textured_sphere(fov=45.0)
    cam = rs.Camera.from_opencv(np.array([[120.0, 0, 50.5], [0, 120.0, 75.0], [0, 0, 1]]), np.eye(3),
                                np.array([-0.4, -0.6, 3.0]), 101, 150, dist=(0.05, -0.01, 0.0, 0.0, 0.0))
    _same(*_both_methods(scene, "gouraud", camera=cam, buffers=("zdepth", "position", "normal"), samples=2))


@pytest.mark.parametrize("depth", [1, 3])
@pytest.mark.usefixtures("small_bands")
def test_mirror_frames_are_banded_and_the_whole_frame_bit_for_bit(depth):
    """Mirror bounces follow each band (tests/shading/test_mirror_packets.py cuts them further)."""
    scene = _textured_sphere(fov=45.0)
    shiny = scene.replace(models=[rs.Model(m.mesh, rs.Material(reflectivity=0.5)) for m in scene.models])
    banded, whole = _both(shiny, max_depth=depth)
    _same(banded, whole)
    assert np.abs(banded.image - _both(shiny, max_depth=0)[0].image).max() > 0.05  # it does reflect


@pytest.mark.usefixtures("small_bands")
def test_the_deferred_hit_buffer_is_cast_once_for_every_thread():
    frame = rs.render(_textured_sphere(fov=45.0), "phong")
    calls = []
    recipe = frame.__dict__["_hits"]
    frame.__dict__["_hits"] = lambda: calls.append(1) or recipe()
    barrier = threading.Barrier(6)
    got = []

    def read():
        barrier.wait()
        got.append(frame.hits)

    threads = [threading.Thread(target=read) for _ in range(6)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert len(calls) == 1 and all(g is got[0] for g in got)
    assert frame.depth.shape == frame.mask.shape == (150, 101)


@pytest.mark.usefixtures("small_bands")
def test_a_new_tone_does_not_cast_the_hits():
    frame = rs.render(_textured_sphere(fov=45.0), "phong")
    toned = frame.with_tone({"exposure": 2.0})
    assert toned.tone == {"exposure": 2.0} and frame.tone == {}
    assert callable(toned.__dict__["_hits"]) and toned.image is frame.image
    np.testing.assert_array_equal(toned.to_uint8(), rs.to_uint8(frame.image, exposure=2.0))


@pytest.mark.usefixtures("small_bands")
def test_a_frame_mask_is_a_fresh_array():
    frame = rs.render(_textured_sphere(fov=45.0), "phong")
    m = frame.mask
    m[:] = False
    assert frame.mask.any()


def _peak(fn):
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_a_banded_frame_allocates_the_image_not_the_hit_buffer():
    """NumPy reports its allocations to tracemalloc: the band path's peak is the image (12
    bytes a pixel), its mask (1) and one band's window; the whole-frame path adds the hit
    buffer (20 bytes a pixel)."""
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(3))], lights=[rs.PointLight((2, 3, 4))],
                     camera=rs.Camera(eye=(0, 0, 3), width=1024, height=768))
    rs.render(scene, "phong")  # BVH, kernels
    px = 1024 * 768
    window = 20 * 1024 * (bands.BAND_ROWS + 2)
    banded = _peak(lambda: rs.render(scene, "phong"))
    assert banded < 13 * px + 2 * window + 4_000_000, banded / px
    saved = RENDER._banded
    try:
        RENDER._banded = lambda *a: False
        whole = _peak(lambda: rs.render(scene, "phong"))
    finally:
        RENDER._banded = saved
    assert whole >= 32 * px


@pytest.mark.parametrize("kw", [dict(), dict(buffers=("zdepth",)), dict(samples=5), dict(backend="raster")],
                         ids=["banded", "buffers", "samples", "raster"])
@pytest.mark.usefixtures("small_bands")
def test_out_receives_the_image_of_a_fresh_render(kw):
    scene = _textured_sphere(fov=45.0)
    fresh = rs.render(scene, "phong", **kw)
    out = np.full((150, 101, 3), np.nan, np.float32)
    frame = rs.render(scene, "phong", out=out, **kw)
    assert frame.image is out
    np.testing.assert_array_equal(out, fresh.image)


@pytest.mark.parametrize("out, exc", [(np.zeros((150, 101, 3), np.float64), ValueError),
                                      (np.zeros((101, 150, 3), np.float32), ValueError),
                                      (np.zeros((150, 101, 3), np.float32)[:, ::-1], ValueError),
                                      (np.zeros((150, 101, 3), np.float32).tolist(), TypeError)])
def test_a_bad_out_is_refused_naming_it(out, exc):
    with pytest.raises(exc, match="out"):
        rs.render(_textured_sphere(fov=45.0), "phong", out=out)
    ro = np.zeros((150, 101, 3), np.float32)
    ro.setflags(write=False)
    with pytest.raises(ValueError, match="out"):
        rs.render(_textured_sphere(fov=45.0), "phong", out=ro)


def test_only_large_frames_are_banded():
    """Below MIN_PIXELS (or one band tall) the whole-frame path runs: its hit buffer is small and
    a band's parallel launches would cost more than they save."""
    scene = _textured_sphere(fov=45.0)
    small = rs.render(scene, "phong")  # 101 x 150
    assert 101 * 150 < bands.MIN_PIXELS and not callable(small.__dict__["_hits"])
    side = int(np.ceil(np.sqrt(bands.MIN_PIXELS)))
    big = rs.render(scene, "phong", camera=scene.camera.replace(width=side, height=side))
    assert side > bands.BAND_ROWS and callable(big.__dict__["_hits"])
