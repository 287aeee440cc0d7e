"""explain() on a banded frame casts one pixel's rays, not the frame (issue 27).

A frame shaded band by band keeps only the recipe of its hit buffer.
``frame.explain(x, y)`` takes the pixel's hit from
:func:`raycast_shade.visibility.pixel.cast_pixel`: the pixel's packet rows and
the neighbours the vertex-slip repair reads. These tests hold that hit to the
whole frame's hit buffer bit for bit, on the vertex grid whose rays slip and are
repaired on rows all over the image (across band borders), at the image's
borders and on a frame whose height is no multiple of the packet tile; and they
check that explaining leaves the frame's recipe unrun.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.visibility import bands
from raycast_shade.visibility.accel import embree_accel
from raycast_shade.visibility.holes import _JUMP
from raycast_shade.visibility.cast import _cast_camera_kernel
from raycast_shade.visibility.pixel import CameraCast, cast_pixel
from raycast_shade.visibility.rays import camera_frame

from tests.insight.test_explain import RTOL, _close
from tests.visibility.test_bands import _grid_scene, _textured_sphere

BAND = 16


@pytest.fixture
def small_bands(monkeypatch):
    """The band path for these small frames, in bands of 16 rows."""
    monkeypatch.setattr(bands, "BAND_ROWS", BAND)
    monkeypatch.setattr(bands, "MIN_PIXELS", 0)


def _repaired(geo, cam, whole):
    """(ys, xs) of the pixels the vertex repair changed."""
    raw = rs.HitBuffer.empty(cam.height, cam.width)
    n = cam.height
    _cast_camera_kernel(embree_accel(geo).handle, camera_frame(cam, geo.origin), *raw, 0, 0, 0, 0, np.zeros(n, np.int64),
                        _JUMP)
    return np.nonzero((raw.prim != whole.prim) | (raw.t != whole.t))


def _pixels(cam, repaired, seed, n=40):
    """The repaired pixels, every corner and edge midpoint, the rows on each side of every band
    border, and random pixels."""
    h, w = cam.height, cam.width
    rng = np.random.default_rng(seed)
    out = set(zip(repaired[1].tolist(), repaired[0].tolist()))
    out |= {(x, y) for x in (0, w // 2, w - 1) for y in (0, h // 2, h - 1)}
    for b in range(BAND, h, BAND):
        out |= {(int(rng.integers(w)), y) for y in (b - 1, b)}
    out |= {(int(rng.integers(w)), int(rng.integers(h))) for _ in range(n)}
    return sorted(out)


@pytest.mark.parametrize("height", [98, 61])
def test_one_pixel_cast_is_the_whole_frame_hit_bit_for_bit(height):
    scene = _grid_scene(height=height)
    geo, cam = scene.geometry, scene.camera
    whole = rs.cast_camera(geo, cam)
    repaired = _repaired(geo, cam, whole)
    assert len(repaired[0]) >= 10 and len(np.unique(repaired[0] // BAND)) >= 3  # repairs in several bands
    for x, y in _pixels(cam, repaired, height):
        got = cast_pixel(geo, cam, x, y)
        for name, a, b in zip(("prim", "geom", "u", "v", "t"), got, whole):
            assert a.shape == (1, 1)
            assert a[0, 0] == b[y, x] and a.dtype == b.dtype, (name, x, y)
        assert np.array_equal(np.float32(got.t[0, 0]).view(np.uint32), whole.t[y, x].view(np.uint32))


@pytest.mark.usefixtures("small_bands")
def test_explain_on_a_banded_frame_casts_no_frame_and_equals_the_pixel():
    scene = _grid_scene()
    frame = rs.render(scene, "phong")
    assert callable(frame.__dict__["_hits"])  # banded: the hit buffer is a recipe
    whole = rs.cast_camera(scene.geometry, scene.camera)
    repaired = _repaired(scene.geometry, scene.camera, whole)
    for x, y in _pixels(scene.camera, repaired, 7, n=10)[::3]:
        hit = frame.hit(x, y)
        assert all(a[0, 0] == b[y, x] for a, b in zip(hit, whole))
        e = frame.explain(x, y)
        assert e.model == whole.geom[y, x] and e.triangle == whole.prim[y, x]
        assert np.array_equal(e.barycentrics[1:], [float(whole.u[y, x]), float(whole.v[y, x])])
        assert _close(e.total, frame.image[y, x], RTOL), (x, y, e.total, frame.image[y, x])
    assert callable(frame.__dict__["_hits"])  # still unrun: explain cast the pixels' rows only
    for a, b in zip(frame.hits, whole):  # and the recipe, run, is the same buffer
        np.testing.assert_array_equal(a, b)


@pytest.mark.usefixtures("small_bands")
def test_explain_is_the_same_on_the_banded_and_the_whole_frame(monkeypatch):
    """Textures (filtered by the pixel's footprint) and shadows: the banded frame's explanation is
    the whole frame's, number for number, and both equal the pixel."""
    scene = _textured_sphere(fov=45.0)
    banded = rs.render(scene, "phong")
    monkeypatch.setattr(sys.modules["raycast_shade.render"], "_banded", lambda *a: False)
    whole = rs.render(scene, "phong")  # the whole-frame path: it keeps its hit buffer
    assert callable(banded.__dict__["_hits"]) and not callable(whole.__dict__["_hits"])
    rng = np.random.default_rng(3)
    ys, xs = np.nonzero(whole.mask)
    for i in rng.choice(len(xs), 12, replace=False):
        x, y = int(xs[i]), int(ys[i])
        a, b = banded.explain(x, y), whole.explain(x, y)
        assert str(a) == str(b)
        np.testing.assert_array_equal(a.total, b.total)
        assert _close(a.total, banded.image[y, x], RTOL)
    assert callable(banded.__dict__["_hits"])


def test_the_recipe_runs_the_whole_cast_and_other_casters_take_its_pixel():
    scene = _grid_scene(height=40)
    geo, cam = scene.geometry, scene.camera
    whole = rs.cast_camera(geo, cam)
    for caster in ("embree", "embreex"):
        recipe = CameraCast(geo, cam, caster)
        for a, b in zip(recipe(), rs.cast_camera(geo, cam, caster)):
            np.testing.assert_array_equal(a, b)
        hit = recipe.pixel(5, 7)
        ref = rs.cast_camera(geo, cam, caster)
        assert all(a[0, 0] == b[7, 5] for a, b in zip(hit, ref))
    assert all(a[0, 0] == b[7, 5] for a, b in zip(CameraCast(geo, cam, "embree").pixel(5, 7), whole))


def test_cast_pixel_refuses_a_distorted_camera():
    scene = _grid_scene(height=40)
    cam = scene.camera
    bent = rs.Camera(eye=cam.eye, target=(0.0, 0.2, 0.0), width=cam.width, height=cam.height, fov=2.0,
                     distortion=(0.1, 0.0, 0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="distorted"):
        cast_pixel(scene.geometry, bent, 3, 3)
