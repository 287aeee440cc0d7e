"""The ray-row helpers' branch-free selects (raycast_shade.output.pixelrays): where the vector loop
chooses instead of branching, each choice against its closed form."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from raycast_shade.output import pixelrays


@njit(error_model="numpy")
def _position(ray, prim, t, plane, origin, position):
    pixelrays._position_row(0, ray, prim, t, plane, origin, position)


def test_position_falls_back_to_the_cast_t_where_the_plane_gives_no_point_and_misses_are_zero():
    """Pixel 0 meets its plane at s = 2; pixel 1's ray is parallel to its plane (d . n = 0), pixel 2's
    triangle is degenerate (n = 0: 0 / 0), pixel 3's plane is behind the eye (s = -2): those three
    take the cast's t along the ray; pixel 4 is a miss (0)."""
    w = 5
    d = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1]], np.float64)
    ray = np.zeros((6, w))
    ray[3:] = d.T
    p0 = np.array([[0, 0, 2], [0, 0, 2], [0, 0, 2], [0, 0, -2], [0, 0, 2]], np.float64)
    n = np.array([[0, 0, 1], [0, 0, 1], [0, 0, 0], [0, 0, 1], [0, 0, 1]], np.float64)
    plane = np.vstack([n.T, (p0 * n).sum(axis=1)[None]])  # n and (p0 - o) . n, the origin o at 0
    prim = np.array([[0, 0, 0, 0, -1]], np.int32)
    t = np.array([[9.0, 3.0, 4.0, 5.0, 7.0]], np.float32)
    origin = np.array([10.0, 20.0, 30.0])
    position = np.full((1, w, 3), np.nan, np.float32)
    _position(ray, prim, t, plane, origin, position)
    s = np.array([2.0, 3.0, 4.0, 5.0])
    expected = np.vstack([d[:4] * s[:, None] + origin, np.zeros(3)]).astype(np.float32)
    np.testing.assert_array_equal(position[0], expected)
    assert not np.signbit(position[0, 4]).any()


@pytest.mark.parametrize("one_origin", [True, False])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_position_row_is_its_numpy_twin_bit_for_bit(seed, one_origin):
    """``_position_row`` (the vectorised loop over a row's gathered normals and numerators) is
    the plain-NumPy evaluation of the same float64 operations, to the bit of its float32 output:
    rays from one origin (a perspective row) and from one origin each (an orthographic row),
    with misses, a ray parallel to its plane, a degenerate triangle and planes behind the origin
    (those fall back to the cast's ``t``)."""
    rng = np.random.default_rng(seed)
    w = 257
    o = np.repeat(rng.normal(size=(3, 1)) * 3.0, w, axis=1) if one_origin else rng.normal(size=(3, w)) * 3.0
    d = rng.normal(size=(3, w))
    d /= np.linalg.norm(d, axis=0)
    ray = np.vstack([o, d])
    p0 = rng.normal(size=(3, w))
    n = rng.normal(size=(3, w)) * 10.0 ** rng.uniform(-3, 3, size=w)
    n[:, 5] = np.cross(d[:, 5], [0.0, 0.0, 1.0])  # parallel to its plane: den 0 up to rounding
    n[:, 9] = 0.0  # a degenerate triangle: den exactly 0
    num = (p0[0] - o[0]) * n[0] + (p0[1] - o[1]) * n[1] + (p0[2] - o[2]) * n[2]
    prim = rng.integers(-1, 50, size=(1, w)).astype(np.int32)
    t = rng.uniform(0.1, 9.0, size=(1, w)).astype(np.float32)
    origin = rng.normal(size=3)
    got = np.full((1, w, 3), np.nan, np.float32)
    _position(ray, prim, t, np.vstack([n, num[None]]), origin, got)

    with np.errstate(divide="ignore", invalid="ignore"):
        den = d[0] * n[0] + d[1] * n[1] + d[2] * n[2]
        q = num / den
    ok = (den != 0.0) & np.isfinite(q) & (q > 0.0)
    s = np.where(ok, q, t[0].astype(np.float64))
    want = np.where((prim[0] >= 0)[:, None], ((o + s * d) + origin[:, None]).T, 0.0).astype(np.float32)
    assert (~ok).sum() >= 3 and (prim < 0).any()  # the fallbacks and the misses are exercised
    assert np.array_equal(got[0].view(np.uint32), want.view(np.uint32))


@njit(error_model="numpy")
def _turned(ray, prim, g, R, world, camera):
    pixelrays._turned_row(0, R, ray, prim, g, world[0].reshape(-1))
    pixelrays._turned_row_camera(0, R, ray, prim, g, camera[0].reshape(-1))


def test_face_normals_turn_to_the_viewer_keep_their_zeros_signs_and_misses_are_zero():
    """Normal 0 faces the ray (n . d > 0: turned), normal 1 already faces away from it (kept, its
    zero components' signs too), pixel 2 is a miss; the camera normals are R n of the turned ones."""
    w = 3
    ray = np.zeros((6, w))
    ray[3:] = np.array([[0, 0, 1], [0, 0, 1], [0, 0, 1]], np.float64).T
    g = np.array([[0.6, 0.0, 0.8], [-0.0, 0.0, -1.0], [0.0, 0.0, 1.0]]).T.copy()
    prim = np.array([[3, 4, -1]], np.int32)
    c, s_ = np.cos(0.3), np.sin(0.3)
    R = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])
    world = np.full((1, w, 3), np.nan, np.float32)
    camera = np.full((1, w, 3), np.nan, np.float32)
    _turned(ray, prim, g, R, world, camera)
    turned = np.array([[-0.6, -0.0, -0.8], [-0.0, 0.0, -1.0]])
    np.testing.assert_array_equal(world[0, :2], turned.astype(np.float32))
    assert np.signbit(world[0, :2]).tolist() == np.signbit(turned).tolist()
    rot = turned[:, :1] * R[:, 0] + turned[:, 1:2] * R[:, 1] + turned[:, 2:] * R[:, 2]  # (R n) row by row
    np.testing.assert_array_equal(camera[0, :2], rot.astype(np.float32))
    np.testing.assert_array_equal(world[0, 2], 0.0)
    np.testing.assert_array_equal(camera[0, 2], 0.0)
