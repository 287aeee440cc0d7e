"""The ray-triangle hit's closed-form VJP (``grad_geometry.pixel_hit_vjp``) against central
differences of the exact intersection (plain NumPy, float64), on random triangles, pixels and
cotangents (hypothesis), perspective and orthographic: vertices, eye and rotation."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.shading.grad_geometry import pixel_hit_vjp, rotate_vectors
from raycast_shade.visibility.rays import camera_frame

W, H = 16, 12


def _hit(cam, x, y, P):
    """``(p, b1, b2)`` of pixel ``(x, y)``'s ray on triangle ``P`` (3, 3): Möller-Trumbore, float64."""
    sx, sy = 2.0 * (x + 0.5) / W - 1.0, 1.0 - 2.0 * (y + 0.5) / H
    R, U, F = cam[3:6], cam[6:9], cam[9:12]
    if cam[12] != 0.0:
        o, d = cam[0:3] + sx * R + sy * U, F
    else:
        o, d = cam[0:3], (F + sx * R + sy * U) / np.linalg.norm(F + sx * R + sy * U)
    t, b1, b2 = np.linalg.solve(np.stack([-d, P[1] - P[0], P[2] - P[0]], axis=1), o - P[0])
    return o + t * d, b1, b2


def _turned(cam, w):
    c = cam.copy()
    c[3:6], c[6:9], c[9:12] = rotate_vectors(w, np.stack([cam[3:6], cam[6:9], cam[9:12]]))
    return c


@settings(max_examples=40, deadline=None)
@given(st.integers(0, W - 1), st.integers(0, H - 1), st.booleans(),
       st.lists(st.floats(-1.0, 1.0), min_size=18, max_size=18))
def test_hit_vjp_matches_central_differences(x, y, ortho, r):
    r = np.array(r)
    camera = rs.Camera(eye=(0.1, 0.2, 3.0), target=(0.0, 0.0, 0.0), width=W, height=H,
                       **({"projection": "orthographic", "ortho_height": 2.0} if ortho else {}))
    cam = camera_frame(camera)
    # a triangle around the pixel's ray, about 1.5 units from the eye, its corners jittered
    p_mid, _, _ = _hit(cam, x, y, np.array([[-9.0, -9.0, 0.5], [9.0, -9.0, 0.3], [0.0, 9.0, 0.4]]))
    P = p_mid + np.array([[-0.8, -0.6, 0.0], [0.9, -0.5, 0.1], [0.0, 0.9, -0.1]]) + 0.2 * r[:9].reshape(3, 3)
    gp, gb = r[9:12], r[12:14]

    def loss(P_, cam_):
        p, b1, b2 = _hit(cam_, x, y, P_)
        return gp @ p + gb[0] * b1 + gb[1] * b2

    p, b1, b2 = _hit(cam, x, y, P)
    gverts = np.zeros((3, 3))
    gcam = np.zeros(6)
    pixel_hit_vjp(cam, x, y, tuple(P[0]), tuple(P[1]), tuple(P[2]), b1, b2, tuple(gp), gb[0], gb[1], gverts,
                  (np.int64(0), np.int64(1), np.int64(2)), gcam)
    h = 1e-6
    fd_v = np.zeros((3, 3))
    fd_cam = np.zeros(6)
    for i in range(3):
        for c in range(3):
            e = np.zeros((3, 3))
            e[i, c] = h
            fd_v[i, c] = (loss(P + e, cam) - loss(P - e, cam)) / (2 * h)
    for c in range(3):
        e = np.zeros(16)
        e[c] = h
        fd_cam[c] = (loss(P, cam + e) - loss(P, cam - e)) / (2 * h)
        w = np.zeros(3)
        w[c] = h
        fd_cam[3 + c] = (loss(P, _turned(cam, w)) - loss(P, _turned(cam, -w))) / (2 * h)
    scale = max(1.0, float(np.max(np.abs(fd_v))), float(np.max(np.abs(fd_cam))))
    assert np.allclose(gverts, fd_v, atol=1e-6 * scale)
    assert np.allclose(gcam, fd_cam, atol=1e-6 * scale)
