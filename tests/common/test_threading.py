"""The threading default (OpenMP's wait policy) and the serial re-cast of a few rays."""

import os
import subprocess
import sys

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common.threads import WAIT_POLICY, apply_wait_policy
from raycast_shade.study.twins import suspicious_numpy
from raycast_shade.visibility import cast, holes
from raycast_shade.visibility.accel import embree_accel
from raycast_shade.visibility.rays import camera_frame

from tests.visibility.test_watertight import _vertex_grid

_CHILD = r"""
import os, sys
import numpy as np, numba
import raycast_shade
from raycast_shade.visibility.holes import _suspicious_rows_kernel
_suspicious_rows_kernel(np.zeros((4, 4), np.int32), np.ones((4, 4), np.float32), 1e-3)  # a parallel launch
print(repr(os.environ.get("OMP_WAIT_POLICY")), numba.threading_layer())
"""


def _child(env_extra):
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT",
                                                             "NUMBA_THREADING_LAYER", "OMP_DISPLAY_ENV")}
    env.update(env_extra, OMP_DISPLAY_ENV="VERBOSE")  # GNU OpenMP prints its settings on load
    proc = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    policy, layer = proc.stdout.split()
    return eval(policy), layer, proc.stderr


def test_the_wait_policy_is_set_only_when_the_user_chose_none():
    env = {}
    assert apply_wait_policy(env) is True and env == {"OMP_WAIT_POLICY": "PASSIVE"}
    for chosen in ({"OMP_WAIT_POLICY": "active"}, {"GOMP_SPINCOUNT": "10000"}, {"OMP_WAIT_POLICY": ""}):
        env = dict(chosen)
        assert apply_wait_policy(env) is False and env == chosen


def test_importing_the_package_sets_passive_before_openmp_loads():
    """A fresh process with no wait chosen: the package sets PASSIVE, and GNU
    OpenMP (loaded by the first parallel launch) took it: no spinning (its
    own default, unset, shows as PASSIVE too but spins 300,000 times)."""
    policy, layer, err = _child({})
    assert policy == WAIT_POLICY == "PASSIVE"
    if layer == "omp" and "OPENMP DISPLAY ENVIRONMENT" in err:
        assert "OMP_WAIT_POLICY = 'PASSIVE'" in err and "GOMP_SPINCOUNT = '0'" in err


@pytest.mark.parametrize("env, policy, shown", [
    ({"OMP_WAIT_POLICY": "active"}, "active", "OMP_WAIT_POLICY = 'ACTIVE'"),
    ({"GOMP_SPINCOUNT": "1000"}, None, "GOMP_SPINCOUNT = '1000'")])
def test_the_users_wait_choice_is_kept(env, policy, shown):
    got, layer, err = _child(env)
    assert got == policy
    if layer == "omp" and "OPENMP DISPLAY ENVIRONMENT" in err:
        assert shown in err


def _grid_scene(step=1):
    cam = rs.Camera(eye=(3.0, -40.0, 50.0), target=(0.0, 0.2, 0.0), width=128, height=96, fov=2.0)
    floor = rs.shapes.plane(size=400.0, center=(0.0, 0.0, -1.0), normal="+z")
    return rs.Scene([rs.Model(_vertex_grid(cam, step)), rs.Model(floor)], camera=cam)


def test_the_serial_cast_is_a_separate_compile_with_the_same_hits():
    """``cast_rays_serial`` is compiled without ``parallel`` under its own name (so
    its disk-cache entry is not the parallel kernel's) and gives the parallel
    kernel's hits bit for bit, on rays through every vertex of a grid."""
    assert cast.cast_rays_serial.py_func.__qualname__ != cast.cast_rays_kernel.py_func.__qualname__
    assert not cast.cast_rays_serial.targetoptions.get("parallel")
    assert cast.cast_rays_kernel.targetoptions.get("parallel")
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
