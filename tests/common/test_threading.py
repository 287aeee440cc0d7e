"""The serial re-cast of a few rays: the same build and the same hits as the cast in parts."""

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.twins import suspicious_numpy
from raycast_shade.visibility import cast, holes
from raycast_shade.visibility.accel import embree_accel
from raycast_shade.visibility.rays import camera_frame

from tests.visibility.test_watertight import _vertex_grid


def _grid_scene(step=1):
    cam = rs.Camera(eye=(3.0, -40.0, 50.0), target=(0.0, 0.2, 0.0), width=128, height=96, fov=2.0)
    floor = rs.shapes.plane(size=400.0, center=(0.0, 0.0, -1.0), normal="+z")
    return rs.Scene([rs.Model(_vertex_grid(cam, step)), rs.Model(floor)], camera=cam)


def test_the_serial_cast_is_the_same_build_with_the_same_hits():
    """``cast_rays_serial`` runs the kernel in parts whole, in the calling thread: the same
    compiled function (no second build, no second cache entry), and the parts' hits bit for
    bit, on rays through every vertex of a grid."""
    assert cast.cast_rays_serial.__self__ is cast.cast_rays_kernel
    scene = _grid_scene()
    geo = scene.geometry
    cf = camera_frame(scene.camera, geo.origin)
    ys, xs = np.mgrid[0:scene.camera.height, 0:scene.camera.width]
    o, d = holes.rays_at(cf, xs.ravel().astype(float), ys.ravel().astype(float))
    n = len(o)
    out = []
    for kernel in (cast.cast_rays_kernel, cast.cast_rays_serial):
        hits = holes.empty_hits(n)
        kernel(embree_accel(geo).handle, o, d, np.zeros(n), np.full(n, np.inf), *hits)
        out.append(hits)
    assert (out[0].geom == 1).sum() > 0  # some rays slip through to the floor: not a trivial case
    for a, b in zip(*out):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("caster", ["embree", "embreex"])
def test_the_hole_re_cast_is_the_same_serial_or_parallel(monkeypatch, caster):
    """The vertex grid's slipped pixels, re-cast serially (every round below the
    threshold) and in parallel (threshold 0): the same hit buffer bit for bit,
    and one cast of the four jitters equals four casts, one per jitter."""
    scene = _grid_scene()
    geo, cam = scene.geometry, scene.camera
    cf = camera_frame(cam, geo.origin)
    monkeypatch.setattr(holes, "_JITTER", ())
    plain = rs.cast_camera(geo, cam, caster=caster)
    monkeypatch.undo()
    rows = holes._suspicious_rows_kernel(plain.prim, plain.t, holes._JUMP)
    n = int(rows.sum())
    assert n > 0
    out = []
    for below in (0, 10 ** 9):
        monkeypatch.setattr(cast, "SERIAL_BELOW", below)
        hits = rs.cast_camera(geo, cam, caster=caster)
        assert (hits.geom == 0).all()  # every slipped pixel found the grid
        out.append(hits)
    for a, b in zip(*out):
        assert np.array_equal(a, b)
    ys, xs = np.empty(n, np.int64), np.empty(n, np.int64)
    holes._gather_kernel(plain.prim, plain.t, holes._JUMP, rows, ys, xs)
    offsets = [(1e-3, 1e-3), (-1e-3, 1e-3), (1e-3, -1e-3), (-1e-3, -1e-3)]
    for below in (0, 10 ** 9):
        monkeypatch.setattr(cast, "SERIAL_BELOW", below)
        one = cast._cast_points(geo, cf, np.concatenate([xs + jx for jx, _ in offsets]),
                                np.concatenate([ys + jy for _, jy in offsets]), caster)
        each = [cast._cast_points(geo, cf, xs + jx, ys + jy, caster) for jx, jy in offsets]
        for a, parts in zip(one, zip(*each)):
            assert np.array_equal(a, np.concatenate(parts))


@pytest.mark.parametrize("density", [0.3, 0.7, 0.97])
def test_the_gather_lists_the_mask_in_row_major_order(density):
    rng = np.random.default_rng(int(density * 100))
    for shape in [(1, 1), (1, 7), (7, 1), (3, 3), (37, 53)]:
        hit = rng.random(shape) < density
        prim = np.where(hit, 5, -1).astype(np.int32)
        t = np.where(hit, rng.choice([1.0, 1.0005, 2.0], size=shape), np.inf).astype(np.float32)
        mask = suspicious_numpy(prim, t, 1e-3)
        rows = holes._suspicious_rows_kernel(prim, t, 1e-3)
        assert rows.tolist() == mask.sum(axis=1).tolist()
        n = int(rows.sum())
        ys, xs = np.empty(n, np.int64), np.empty(n, np.int64)
        holes._gather_kernel(prim, t, 1e-3, rows, ys, xs)
        want_y, want_x = np.nonzero(mask)
        assert ys.tolist() == want_y.tolist() and xs.tolist() == want_x.tolist()
