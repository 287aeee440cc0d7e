"""Camera rays: one per pixel centre.

The renderer fuses ray generation into its casting kernel; this module keeps
the same arithmetic as a stand-alone Numba kernel (for the embreex caster and
the benchmarks); its plain-NumPy twin is in :mod:`raycast_shade.study.twins`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["camera_frame", "generate_rays"]


def camera_frame(camera, origin=np.zeros(3)):
    """Packed camera parameters for the kernels.

    Parameters
    ----------
    camera : Camera
    origin : (3,) float64
        Scene re-centring offset, subtracted from the eye.

    Returns
    -------
    (16,) float64
        eye(3), right*half_width(3), up*half_height(3), forward(3),
        orthographic flag, width, height, unused.
    """
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    out = np.empty(16)
    out[0:3] = camera.eye - origin
    out[3:6] = right * hw
    out[6:9] = up * hh
    out[9:12] = fwd
    out[12] = 1.0 if camera.orthographic else 0.0
    out[13] = camera.width
    out[14] = camera.height
    out[15] = 0.0
    return out


@njit(cache=True, inline="always")
def pixel_ray(cam, x, y):
    """Origin and unit direction of the ray through pixel centre (x+.5, y+.5)."""
    w = cam[13]
    h = cam[14]
    sx = 2.0 * (x + 0.5) / w - 1.0
    sy = 1.0 - 2.0 * (y + 0.5) / h
    if cam[12] != 0.0:
        ox = cam[0] + sx * cam[3] + sy * cam[6]
        oy = cam[1] + sx * cam[4] + sy * cam[7]
        oz = cam[2] + sx * cam[5] + sy * cam[8]
        return ox, oy, oz, cam[9], cam[10], cam[11]
    dx = cam[9] + sx * cam[3] + sy * cam[6]
    dy = cam[10] + sx * cam[4] + sy * cam[7]
    dz = cam[11] + sx * cam[5] + sy * cam[8]
    inv = 1.0 / np.sqrt(dx * dx + dy * dy + dz * dz)
    return cam[0], cam[1], cam[2], dx * inv, dy * inv, dz * inv


@njit(cache=True, parallel=True)
def _rays_kernel(cam, origins, directions):
    w = int(cam[13])
    h = int(cam[14])
    for y in prange(h):
        for x in range(w):
            ox, oy, oz, dx, dy, dz = pixel_ray(cam, x, y)
            i = y * w + x
            origins[i, 0] = ox
            origins[i, 1] = oy
            origins[i, 2] = oz
            directions[i, 0] = dx
            directions[i, 1] = dy
            directions[i, 2] = dz


def generate_rays(camera, origin=np.zeros(3), dtype=np.float32):
    """Rays for every pixel, row-major.

    Returns
    -------
    origins, directions : (H*W, 3) ``dtype``
    """
    cam = camera_frame(camera, origin)
    n = camera.width * camera.height
    origins = np.empty((n, 3), dtype)
    directions = np.empty((n, 3), dtype)
    _rays_kernel(cam, origins, directions)
    return origins, directions
