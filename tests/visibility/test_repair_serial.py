"""The serial repair of slipped camera rays (``holes._repair_serial``: a few flagged pixels
repaired in one kernel) against the NumPy rounds of ``holes.fill_holes`` it replaces, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.visibility import bands, cast, holes
from raycast_shade.visibility.rays import camera_frame

from .test_watertight import _vertex_grid


def _grid_scene(width=64, height=48, step=1):
    """Pixel rays through the vertices of a grid, a plane behind: rays slip all over the image."""
    cam = rs.Camera(eye=(3.0, -40.0, 50.0), target=(0.0, 0.2, 0.0), width=width, height=height, fov=2.0)
    floor = rs.shapes.plane(size=400.0, center=(0.0, 0.0, -1.0), normal="+z")
    return rs.Scene([rs.Model(_vertex_grid(cam, step)), rs.Model(floor)], camera=cam)


def _gap_scene():
    """Orthographic: a pixel-wide gap between two squares, a plane behind (genuine: stays open)."""
    w, h, pitch = 64, 48, 1.0 / 16.0
    left = rs.shapes.plane(size=1.0, center=(-0.5, 0.0, 0.0))
    right = rs.shapes.plane(size=1.0, center=(0.5 + pitch, 0.0, 0.0))
    back = rs.shapes.plane(size=8.0, center=(0.0, 0.0, -2.0))
    cam = rs.Camera(eye=(0.0, 0.0, 3.0), width=w, height=h, projection="orthographic", ortho_height=h * pitch)
    return rs.Scene([rs.Model(left), rs.Model(right), rs.Model(back)], camera=cam)


def _noisy_scene():
    """A sphere with its vertices moved radially: silhouette gaps flagged every frame."""
    from benchmarks.bench_peers import make_mesh, make_scene

    return make_scene(make_mesh("noisy_sphere", 5), 200, 152)


def _counted(monkeypatch):
    calls = []
    serial = holes._repair_serial

    def counting(*args):
        calls.append(int(args[4].sum()))
        return serial(*args)

    monkeypatch.setattr(holes, "_repair_serial", counting)
    return calls


@pytest.mark.parametrize("make", [_grid_scene, _gap_scene, _noisy_scene])
def test_the_serial_repair_is_the_numpy_rounds_bit_for_bit(monkeypatch, make):
    scene = make()
    geo, cam = scene.geometry, scene.camera
    calls = _counted(monkeypatch)
    monkeypatch.setattr(cast, "SERIAL_BELOW", 0)  # every round through NumPy and the parallel kernels
    rounds = rs.cast_camera(geo, cam, "embree")
    rounds_bands = [tuple(a.copy() for a in b) for _, b in bands.cast_bands(geo, cam, 8)]
    assert calls == []
    monkeypatch.setattr(cast, "SERIAL_BELOW", 10 ** 9)
    serial = rs.cast_camera(geo, cam, "embree")
    serial_bands = [tuple(a.copy() for a in b) for _, b in bands.cast_bands(geo, cam, 8)]
    assert len(calls) >= 2 and sum(calls) > 0  # the serial repair ran, on flagged pixels
    for a, b in zip(rounds, serial):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    for p, q in zip(rounds_bands, serial_bands):
        for a, b in zip(p, q):
            assert np.array_equal(a, b)
    monkeypatch.setattr(holes, "_JITTER", ())
    plain = rs.cast_camera(geo, cam, "embree")
    changed = sum(int(np.count_nonzero(a != b)) for a, b in zip(plain, serial))
    if make is _grid_scene:  # the repair did something there (the gap stays open, the noisy silhouette too)
        assert changed > 0 and (serial.geom == 0).all()


def test_the_ray_of_the_serial_repair_is_rays_at_bit_for_bit():
    """Perspective and orthographic, integer pixels and jittered points, off-centre image rows."""
    rng = np.random.default_rng(7)
    for projection in ("perspective", "orthographic"):
        cam = rs.Camera(eye=(0.3, -1.7, 4.2), target=(0.1, 0.2, -0.3), width=333, height=217, projection=projection)
        cf = camera_frame(cam, np.array([0.5, -0.25, 0.125]))
        xi, yi = rng.integers(0, 333, 300), rng.integers(0, 217, 300)  # pixels: the re-tested own rays
        xf, yf = rng.uniform(-1, 334, 300), rng.uniform(-1, 218, 300)  # points: the jittered rays
        oo, dd = np.empty(3), np.empty(3)
        for xs, ys in ((xi, yi), (xf, yf)):
            o, d = holes.rays_at(cf, xs, ys)
            for i in range(len(xs)):
                holes._ray_at(cf, xs[i], ys[i], oo, dd)
                assert np.array_equal(oo, o[i]) and np.array_equal(dd, d[i])
