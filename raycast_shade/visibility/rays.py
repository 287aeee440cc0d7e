"""Camera rays: one per pixel centre.

The renderer fuses ray generation into its casting kernel; this module keeps
the same arithmetic as a stand-alone Numba kernel (for the embreex caster and
the benchmarks); its plain-NumPy twin is in :mod:`raycast_shade.study.twins`.

Anti-aliasing rays through other points of the pixel come from
:func:`subpixel_camera`: the same camera with its principal point moved, so
that every caster, the rasterizer and the screen-space weights take them
without a kernel of their own.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.parallel import KERNEL, in_parts, share
from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_SIZE, CAM_UP, CAM_WIDTH

__all__ = ["camera_frame", "generate_rays", "subpixel_camera", "offset_pair"]


def camera_frame(camera, origin=np.zeros(3)):
    """Packed camera parameters for the kernels.

    Parameters
    ----------
    camera : Camera
    origin : (3,) float64
        Scene re-centring offset, subtracted from the eye.

    Returns
    -------
    (CAM_SIZE,) = (16,) float64
        eye(3), right*half_width(3), up*half_height(3), forward(3),
        orthographic flag, width, height, unused (slots named in
        :mod:`raycast_shade.common.layout`). With intrinsics (``camera.fx``),
        ``forward`` (perspective; then not unit) or ``eye`` (orthographic)
        carries the principal point's shift.
    """
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    out = np.zeros(CAM_SIZE)
    out[CAM_EYE:CAM_EYE + 3] = camera.eye - origin
    out[CAM_RIGHT:CAM_RIGHT + 3] = right * hw
    out[CAM_UP:CAM_UP + 3] = up * hh
    out[CAM_FORWARD:CAM_FORWARD + 3] = fwd
    out[CAM_ORTHO] = 1.0 if camera.orthographic else 0.0
    out[CAM_WIDTH] = camera.width
    out[CAM_HEIGHT] = camera.height
    if camera.fx is not None:
        # Intrinsics: the principal point shifts the central ray (perspective:
        # its direction, d = forward + ox right + oy up + sx R + sy U) or the
        # ray origins (orthographic); a camera without them keeps its bits.
        ox, oy = camera.principal_offset()
        shift = ox * right + oy * up
        if camera.orthographic:
            out[CAM_EYE:CAM_EYE + 3] += shift
        else:
            out[CAM_FORWARD:CAM_FORWARD + 3] += shift
    return out


@njit(cache=True, inline="always")
def pixel_ray(cam, x, y):
    """Origin and unit direction of the ray through pixel centre (x+.5, y+.5)."""
    w = cam[CAM_WIDTH]
    h = cam[CAM_HEIGHT]
    sx = 2.0 * (x + 0.5) / w - 1.0
    sy = 1.0 - 2.0 * (y + 0.5) / h
    if cam[CAM_ORTHO] != 0.0:
        ox = cam[CAM_EYE + 0] + sx * cam[CAM_RIGHT + 0] + sy * cam[CAM_UP + 0]
        oy = cam[CAM_EYE + 1] + sx * cam[CAM_RIGHT + 1] + sy * cam[CAM_UP + 1]
        oz = cam[CAM_EYE + 2] + sx * cam[CAM_RIGHT + 2] + sy * cam[CAM_UP + 2]
        return ox, oy, oz, cam[CAM_FORWARD + 0], cam[CAM_FORWARD + 1], cam[CAM_FORWARD + 2]
    dx = cam[CAM_FORWARD + 0] + sx * cam[CAM_RIGHT + 0] + sy * cam[CAM_UP + 0]
    dy = cam[CAM_FORWARD + 1] + sx * cam[CAM_RIGHT + 1] + sy * cam[CAM_UP + 1]
    dz = cam[CAM_FORWARD + 2] + sx * cam[CAM_RIGHT + 2] + sy * cam[CAM_UP + 2]
    inv = 1.0 / np.sqrt(dx * dx + dy * dy + dz * dz)
    return cam[CAM_EYE + 0], cam[CAM_EYE + 1], cam[CAM_EYE + 2], dx * inv, dy * inv, dz * inv


@in_parts
@njit(**KERNEL)
def _rays_kernel(cam, origins, directions, part):
    w = int(cam[CAM_WIDTH])
    h = int(cam[CAM_HEIGHT])
    for y in range(*share(h, part)):  # this part's share (common.parallel)
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


def subpixel_camera(camera, dx: float, dy: float):
    """The camera whose pixel ``(x, y)`` ray passes through ``camera``'s image
    point ``(x + 0.5 + dx, y + 0.5 + dy)`` instead of the pixel centre.

    The principal point moves by ``(-dx, -dy)`` pixels (OpenCV's intrinsics,
    :mod:`raycast_shade.scene.projection`); eye, axes and focal lengths stay.
    Perspective rays keep their origin (the eye) and orthographic ones their
    direction, so a hit seen through either camera is shaded the same way.

    Parameters
    ----------
    camera : Camera
    dx, dy : float
        Sub-pixel offset in pixels (``y`` down), finite.

    Returns
    -------
    Camera
        ``camera`` itself for ``(0, 0)``.
    """
    from ..common.validate import as_scalar
    from ..scene.projection import intrinsics

    dx, dy = as_scalar(dx, "offset[0]"), as_scalar(dy, "offset[1]")
    if dx == 0.0 and dy == 0.0:
        return camera
    fx, fy, cx, cy = intrinsics(camera)
    return camera.replace(fx=fx, fy=fy, cx=cx - dx, cy=cy - dy)


def offset_pair(offset, name: str = "offset"):
    """``offset`` as ``(dx, dy)``: two finite numbers (TypeError/ValueError naming ``name``)."""
    from ..common.validate import as_scalar

    if isinstance(offset, (str, bytes, dict)) or not hasattr(offset, "__len__") or len(offset) != 2:
        raise TypeError(f"{name}: expected (dx, dy), got {offset!r}")
    return as_scalar(offset[0], f"{name}[0]"), as_scalar(offset[1], f"{name}[1]")
