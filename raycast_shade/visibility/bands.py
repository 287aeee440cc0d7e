"""The camera's hit buffer band by band, for a renderer that shades each band at once.

A frame that asks for no per-pixel buffer needs its hits only while it shades
them. :func:`cast_bands` casts the frame in bands of :data:`BAND_ROWS` rows
into one small window (5 MB at 1920 pixels a row, 20 MB at 7680, reused by every band), repairs
each band's slipped rays (:mod:`.holes`) and hands it over finished, so the
frame never holds a full-frame hit buffer (20 bytes a pixel: 663 MB at
7680x4320) and never page-faults one in.

The bands are exactly the rows of :func:`.cast.cast_camera`'s buffer, bit for
bit:

* each band's new rows start at a multiple of the packet tile's height, so
  every ray travels in the same 16-ray packet as in the whole-frame cast;
* the repair test reads each pixel's neighbours *as cast*: the window keeps
  the row above the band (as cast, before its repair) and the band's last row
  waits, unrepaired, until the next band has cast the row below it; image
  borders stay borders (the first band starts at row 0, the last ends at H-1);
* repaired pixels take the hits of the same jittered rays and exact re-tests,
  in image coordinates.
"""

from __future__ import annotations

import numpy as np

from . import holes
from .accel import embree_accel
from .cast import _TILE_H, _cast_camera_kernel, _fill_holes, cast_camera, check_camera_reach
from .hits import HitBuffer, image_buffer
from .rays import camera_frame

__all__ = ["cast_bands", "BAND_ROWS", "MIN_PIXELS"]

# Rows per band: a multiple of the tile height. Measured on 2 cores (docs/performance.md): at 1080p
# bands of 128 or 256 rows beat the whole frame by 8-12%, 64 rows lose (each band is three parallel
# launches, and a launch that wakes sleeping workers costs about 0.1 ms here).
BAND_ROWS = 128
assert BAND_ROWS % _TILE_H == 0
# Smaller frames keep the whole-frame path: its hit buffer is under 10 MB, and there bands gain
# nothing (1280x720: equal) or lose a little (640x480: 3-5%).
MIN_PIXELS = 1 << 19


def cast_bands(geometry, camera, rows: int = BAND_ROWS):
    """Yield the camera's hit buffer in bands of rows, top to bottom.

    Parameters
    ----------
    geometry : SceneGeometry
    camera : Camera
    rows : int
        Rows per band, a positive multiple of the packet tile's height (4).

    Yields
    ------
    y : int
        The image row of the band's first row.
    hits : HitBuffer
        (R, W) views of the band (``R <= rows``; the bands tile the image):
        valid until the next band is asked for.

    Raises
    ------
    ValueError
        For ``rows`` that is not a positive multiple of 4, or a camera beyond
        Embree's range, before any kernel runs.
    """
    if not isinstance(rows, (int, np.integer)) or rows <= 0 or rows % _TILE_H:
        raise ValueError(f"rows: expected a positive multiple of {_TILE_H}, got {rows!r}")
    rows = int(rows)
    h, w = camera.height, camera.width
    if h <= rows or camera.distorted:  # one band: the frame itself (distorted: cast_camera's own rays)
        yield 0, cast_camera(geometry, camera, "embree")
        return
    check_camera_reach(geometry, camera)
    cam = camera_frame(camera, geometry.origin)
    handle = embree_accel(geometry).handle
    win = image_buffer(None, rows + 2, w)  # the row above the band, the last band's last row, then new rows
    counts = np.zeros(rows + 2, np.int64)  # suspicious pixels per window row, counted by the cast kernel
    top = 0  # window rows before the new ones: 0 for the first band, then 2
    g = 0  # image row of the first new row (a multiple of the tile height)
    above = np.empty(w, np.int32), np.empty(w, np.float32)  # prim, t of the last finished row, as cast
    while True:
        m = min(rows, h - g)
        n = top + m
        last = g + m == h
        lo, hi = (1 if top else 0), (n if last else n - 1)
        counts[:] = 0
        _cast_camera_kernel(handle, cam, *(a[:n] for a in win), g - top, top, lo, hi, counts[:n], holes._JUMP)
        if not last:  # the next window's row above, before this band's repair changes it
            above[0][:] = win.prim[n - 2]
            above[1][:] = win.t[n - 2]
        window = HitBuffer(*(a[:n] for a in win))
        _fill_holes(geometry, cam, window, "embree", rows=(lo, hi), y0=g - top, counts=counts[:n])
        yield g - top + lo, HitBuffer(*(a[lo:hi] for a in win))
        if last:
            return
        for a in win:  # the waiting row (as cast: the repair never touched it) moves up
            a[1] = a[n - 1]
        win.prim[0] = above[0]
        win.t[0] = above[1]
        top = 2
        g += m
