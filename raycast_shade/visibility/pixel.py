"""One camera pixel's hit, cast alone, bit for bit the whole frame's.

A frame shaded band by band keeps no hit buffer, only the recipe of its cast
(:class:`CameraCast`). :func:`cast_pixel` gives one pixel's hit without the
frame: what the packet caster (:func:`.cast.cast_camera`) computes for that
pixel depends on

* its 16-ray packet: the rows are cast with the frame's own kernel from a
  tile-aligned row, so every ray travels in the packet it travels in the
  whole frame (tiles start at column 0: whole rows are cast, 4 or 8 of them);
* the vertex-slip repair (:mod:`.holes`), which reads the pixel's four
  neighbours *as cast*: the rows above and below are in the window, and only
  the pixel's row is repaired, with the same jittered rays and exact
  re-tests in image coordinates (a pixel's repair reads no other repair).

At 1920 pixels a row that is at most 15,360 rays, about 1% of the frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .accel import embree_accel
from .cast import _TILE_H, _cast_camera_kernel, _fill_holes, cast_camera, check_camera_reach
from .hits import HitBuffer, image_buffer
from .holes import _JUMP, _suspicious
from .rays import camera_frame

__all__ = ["cast_pixel", "CameraCast"]


def cast_pixel(geometry, camera, x: int, y: int) -> HitBuffer:
    """The packet caster's hit of pixel ``(x, y)``, repaired, without casting the frame.

    Parameters
    ----------
    geometry : SceneGeometry
    camera : Camera
        A pinhole or orthographic camera (no lens distortion).
    x, y : int
        ``0 <= x < width``, ``0 <= y < height`` (not checked here).

    Returns
    -------
    HitBuffer
        (1, 1) arrays: ``cast_camera(geometry, camera, "embree")[y, x]``, bit for bit.

    Raises
    ------
    ValueError
        For a distorted camera (its rays are not the packet caster's).
    """
    if camera.distorted:
        raise ValueError("camera: cast_pixel follows the pinhole's packets; a distorted camera has its own rays")
    check_camera_reach(geometry, camera)
    h, w = camera.height, camera.width
    lo = max(y - 1, 0) // _TILE_H * _TILE_H  # tile-aligned: the frame's own packets
    hi = min(h, ((y + 1) // _TILE_H + 1) * _TILE_H)  # the row below included (image border: none)
    cam = camera_frame(camera, geometry.origin)
    win = image_buffer(None, hi - lo, w)
    n = hi - lo  # the window's rows, cast from its top; no rows counted (the repair's test runs below)
    _cast_camera_kernel(embree_accel(geometry).handle, cam, *win, lo, 0, 0, 0, np.zeros(n, np.int64), _JUMP)
    r = y - lo  # an inner row of the window unless it is the image's first or last
    if _suspicious(win.prim, win.t, _JUMP, r, x):  # the repair's own test (most pixels: no repair to run)
        _fill_holes(geometry, cam, win, "embree", rows=(r, r + 1), y0=lo)
    return HitBuffer(*(a[r:r + 1, x:x + 1].copy() for a in win))


@dataclass(frozen=True, eq=False)
class CameraCast:
    """The recipe of a frame's hit buffer: ``cast_camera(geometry, camera, caster)``, run on call.

    A banded frame (:func:`raycast_shade.render`) keeps this instead of its buffer;
    :meth:`pixel` gives one pixel's hit without running it.
    """

    geometry: object
    camera: object
    caster: str

    def __call__(self) -> HitBuffer:
        """(H, W) the whole frame's hits."""
        return cast_camera(self.geometry, self.camera, self.caster)

    def pixel(self, x: int, y: int) -> HitBuffer:
        """(1, 1) pixel ``(x, y)``'s hit: :func:`cast_pixel` for the packet caster and a
        pinhole camera, else the whole cast's pixel."""
        if self.caster == "embree" and not self.camera.distorted:
            return cast_pixel(self.geometry, self.camera, x, y)
        return HitBuffer(*(a[y:y + 1, x:x + 1].copy() for a in self()))
