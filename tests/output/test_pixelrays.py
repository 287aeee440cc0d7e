"""The ray-row helpers' branch-free selects (raycast_shade.output.pixelrays): where the vector loop
chooses instead of branching, each choice against its closed form."""

from __future__ import annotations

import numpy as np
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
    plane = np.zeros((6, w))
    plane[:3] = np.array([[0, 0, 2], [0, 0, 2], [0, 0, 2], [0, 0, -2], [0, 0, 2]], np.float64).T
    plane[3:] = np.array([[0, 0, 1], [0, 0, 1], [0, 0, 0], [0, 0, 1], [0, 0, 1]], np.float64).T
    prim = np.array([[0, 0, 0, 0, -1]], np.int32)
    t = np.array([[9.0, 3.0, 4.0, 5.0, 7.0]], np.float32)
    origin = np.array([10.0, 20.0, 30.0])
    position = np.full((1, w, 3), np.nan, np.float32)
    _position(ray, prim, t, plane, origin, position)
    s = np.array([2.0, 3.0, 4.0, 5.0])
    expected = np.vstack([d[:4] * s[:, None] + origin, np.zeros(3)]).astype(np.float32)
    np.testing.assert_array_equal(position[0], expected)
    assert not np.signbit(position[0, 4]).any()


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
