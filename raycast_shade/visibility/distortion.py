"""Exact lens distortion: each pixel's ray through the distorted pixel centre.

A camera with ``distortion`` (:class:`~raycast_shade.scene.camera.Camera`)
sees point ``X`` at OpenCV's distorted pixel ``(u, v)``; the ray of pixel
``(i, j)`` is the direction that distorts onto ``(u, v) = (i, j)`` (OpenCV's
pixel centres). Each pixel centre is undistorted by Newton's method in
float64 (a Numba kernel), so the rays are cast directly (:func:`~raycast_shade.visibility.cast.cast_camera`
through :func:`~raycast_shade.visibility.cast.cast_rays`, watertight) and every buffer
(depth, ids, normals, masks) is that of the distorted image: no pinhole image
is warped, no depth or label is interpolated across an edge.

Models, in normalised coordinates ``x = X/Z, y = Y/Z``
(``x_d = (u - cx) / fx``, ``y_d = (v - cy) / fy``):

``"opencv"`` ``(k1, k2, p1, p2[, k3])``, as ``cv2.projectPoints``
    ``r2 = x^2 + y^2``, ``s = 1 + k1 r2 + k2 r2^2 + k3 r2^3``;
    ``x_d = x s + 2 p1 x y + p2 (r2 + 2 x^2)``,
    ``y_d = y s + p1 (r2 + 2 y^2) + 2 p2 x y``.
``"fisheye"`` ``(k1, k2, k3, k4)``, as ``cv2.fisheye.projectPoints``
    ``theta = atan(r)``, ``theta_d = theta (1 + k1 theta^2 + k2 theta^4 +
    k3 theta^6 + k4 theta^8)``, ``(x_d, y_d) = (theta_d / r) (x, y)``.

A pixel has no ray (it stays empty: a miss) where the model cannot be
inverted: Newton does not converge to a residual below ``1e-12``, or it
converges past a fold of the model (where the Jacobian's determinant,
fisheye: ``d theta_d / d theta``, is not positive, so that several
directions distort onto the pixel), or a fisheye angle reaches 90 degrees.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.parallel import KERNEL, in_parts, share

__all__ = ["distort", "undistort", "ray_directions", "MAX_ITERATIONS", "RESIDUAL"]

MAX_ITERATIONS = 100
RESIDUAL = 1e-12  # normalised units: 1e-12 focal lengths
_STEP = 1e-15  # Newton stops when a step is this small (relative): float64's resolution


@njit(cache=True)
def _opencv_forward(x, y, k1, k2, p1, p2, k3):
    """Distorted ``(x_d, y_d)`` of ``(x, y)`` and the Jacobian ``(a, b, c, d)`` = d(x_d, y_d)/d(x, y)."""
    r2 = x * x + y * y
    s = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    ds = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # ds / d(r2)
    xd = x * s + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * s + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    off = 2.0 * x * y * ds + 2.0 * p1 * x + 2.0 * p2 * y
    a = s + 2.0 * x * x * ds + 2.0 * p1 * y + 6.0 * p2 * x
    d = s + 2.0 * y * y * ds + 6.0 * p1 * y + 2.0 * p2 * x
    return xd, yd, a, off, off, d


@in_parts
@njit(**KERNEL)
def _undistort_opencv_kernel(xd, yd, k, out, ok, part):
    k1, k2, p1, p2, k3 = k[0], k[1], k[2], k[3], k[4]
    for i in range(*share(xd.shape[0], part)):  # this part's share (common.parallel)
        tx, ty = xd[i], yd[i]
        x, y = tx, ty
        for _ in range(MAX_ITERATIONS):
            fx_, fy_, a, b, c, d = _opencv_forward(x, y, k1, k2, p1, p2, k3)
            ex, ey = fx_ - tx, fy_ - ty
            det = a * d - b * c
            if not (det > 0.0) or not np.isfinite(ex + ey):
                break
            sx = (d * ex - b * ey) / det
            sy = (a * ey - c * ex) / det
            x -= sx
            y -= sy
            if abs(sx) + abs(sy) <= _STEP * (1.0 + abs(x) + abs(y)):  # at float64's resolution
                break
        # Converged to the tolerance, on the near side of any fold of the model?
        fx_, fy_, a, b, c, d = _opencv_forward(x, y, k1, k2, p1, p2, k3)
        good = (a * d - b * c > 0.0) and abs(fx_ - tx) + abs(fy_ - ty) <= RESIDUAL * (1.0 + abs(tx) + abs(ty))
        ok[i] = good
        inv = 1.0 / np.sqrt(x * x + y * y + 1.0)
        out[i, 0] = x * inv
        out[i, 1] = y * inv
        out[i, 2] = inv


@njit(cache=True)
def _fisheye_forward(theta, k1, k2, k3, k4):
    t2 = theta * theta
    td = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
    dtd = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
    return td, dtd


@in_parts
@njit(**KERNEL)
def _undistort_fisheye_kernel(xd, yd, k, out, ok, part):
    k1, k2, k3, k4 = k[0], k[1], k[2], k[3]
    half_pi = 0.5 * np.pi
    for i in range(*share(xd.shape[0], part)):  # this part's share (common.parallel)
        rd = np.sqrt(xd[i] * xd[i] + yd[i] * yd[i])
        theta = min(rd, 1.0)
        good = rd == 0.0
        if not good:
            for _ in range(MAX_ITERATIONS):
                td, dtd = _fisheye_forward(theta, k1, k2, k3, k4)
                if not (dtd > 0.0) or not np.isfinite(td):
                    break
                step = (td - rd) / dtd
                theta -= step
                if abs(step) <= _STEP * (1.0 + theta):
                    break
            td, dtd = _fisheye_forward(theta, k1, k2, k3, k4)
            good = 0.0 <= theta < half_pi and dtd > 0.0 and abs(td - rd) <= RESIDUAL * (1.0 + rd)
        ok[i] = good
        if rd == 0.0:
            out[i, 0], out[i, 1], out[i, 2] = 0.0, 0.0, 1.0
        else:
            st = np.sin(theta) / rd
            out[i, 0] = xd[i] * st
            out[i, 1] = yd[i] * st
            out[i, 2] = np.cos(theta)


def _coefficients(camera) -> np.ndarray:
    k = np.zeros(5)
    k[:len(camera.distortion)] = camera.distortion
    return k


def distort(camera, x, y):
    """The distorted normalised coordinates of undistorted ones, the forward model
    (:func:`raycast_shade.scene.projection.distort_normalised`)."""
    from ..scene.projection import distort_normalised

    return distort_normalised(camera, x, y)


def undistort(camera, xd, yd):
    """Unit ray directions (OpenCV camera axes) whose points distort onto ``(xd, yd)``.

    Parameters
    ----------
    camera : Camera
    xd, yd : (N,) float
        Distorted normalised coordinates, ``((u - cx) / fx, (v - cy) / fy)``.

    Returns
    -------
    directions : (N, 3) float64
        Unit vectors with ``z > 0``.
    ok : (N,) bool
        False where the model cannot be inverted (see the module docstring).
    """
    xd = np.ascontiguousarray(xd, dtype=np.float64).ravel()
    yd = np.ascontiguousarray(yd, dtype=np.float64).ravel()
    out = np.empty((len(xd), 3))
    ok = np.empty(len(xd), np.bool_)
    if camera.distortion_model == "fisheye":
        _undistort_fisheye_kernel(xd, yd, _coefficients(camera), out, ok)
    else:
        _undistort_opencv_kernel(xd, yd, _coefficients(camera), out, ok)
    return out, ok


def ray_directions(camera):
    """World-space unit ray directions of every pixel centre of a distorted camera, row-major.

    Returns
    -------
    directions : (H*W, 3) float64
    ok : (H*W,) bool
        Pixels that have a ray (see :func:`undistort`).
    """
    from ..scene.projection import extrinsics, intrinsics

    fx, fy, cx, cy = intrinsics(camera)
    jj, ii = np.mgrid[0:camera.height, 0:camera.width]
    d_cam, ok = undistort(camera, (ii.ravel() - cx) / fx, (jj.ravel() - cy) / fy)
    R, _ = extrinsics(camera)
    return d_cam @ R, ok  # R^T d for each row: camera axes to world
