"""Pictures in a notebook: nearest-neighbour upscaling to a legible size.

A 160×120 frame shown at its native size is a thumbnail on a projector, and
a browser that stretches it blurs the pixels together. Here the 8-bit image
is repeated ``scale × scale`` times per pixel before it is encoded, so each
rendered pixel stays a sharp square (the lecture's point is often one
pixel: a Mach band, a Gouraud highlight that misses a vertex).

* :class:`Picture`: an 8-bit image with a display scale; Jupyter shows it
  (``_repr_png_``); ``frame.show()`` returns one;
* :class:`ImageArray`: an ndarray subclass for a linear (H, W, 3) image
  (``frame.overlay()``) that is still an array but displays as its picture.

The default scale makes the picture at least :data:`MIN_WIDTH` pixels wide,
never more than :data:`MAX_WIDTH` (an integer scale, 1 for a big frame).
"""

from __future__ import annotations

import math

import numpy as np

from ..common.validate import as_int
from .imagefile import png_bytes
from .tonemap import to_uint8

__all__ = ["Picture", "ImageArray", "display_scale", "upscale", "MIN_WIDTH", "MAX_WIDTH"]

MIN_WIDTH = 480  # display pixels: legible from the back of a lecture hall at the notebook's width
MAX_WIDTH = 1024  # and never wider than a 1366-pixel screen's notebook column


def display_scale(shape, scale=None, width=None) -> int:
    """The integer upscaling factor for an image of ``shape`` (H, W, ...).

    Parameters
    ----------
    shape : tuple of int
        ``(H, W)`` or ``(H, W, C)``.
    scale : int, optional
        Taken as is (>= 1).
    width : int, optional
        Display width in pixels: the largest integer scale whose width does not
        exceed it (at least 1). Not together with ``scale``.

    Returns
    -------
    int
        >= 1. By default the smallest scale that reaches :data:`MIN_WIDTH`,
        capped so that the width stays within :data:`MAX_WIDTH`.
    """
    w = int(shape[1])
    if scale is not None and width is not None:
        raise ValueError("scale, width: give one of them, not both")
    if scale is not None:
        return as_int(scale, "scale", minimum=1, maximum=64)
    if width is not None:
        width = as_int(width, "width", minimum=1, maximum=16384)
        return max(1, width // max(w, 1))
    s = max(1, math.ceil(MIN_WIDTH / max(w, 1)))
    return max(1, min(s, MAX_WIDTH // max(w, 1)))


def upscale(rgb: np.ndarray, scale: int) -> np.ndarray:
    """(H s, W s, C) copy of ``rgb`` (H, W, C), each pixel an ``s × s`` block (nearest neighbour)."""
    if scale == 1:
        return rgb
    return np.repeat(np.repeat(rgb, scale, axis=0), scale, axis=1)


class Picture:
    """An 8-bit RGB image that a notebook shows ``scale`` times its size, pixels as squares.

    Parameters
    ----------
    rgb : (H, W, 3) uint8
    scale : int
        Display pixels per image pixel, each way.

    Attributes
    ----------
    rgb : (H, W, 3) uint8
        The image at its own size.
    scale : int
    """

    def __init__(self, rgb, scale: int = 1):
        rgb = np.asarray(rgb)
        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise ValueError(f"rgb: expected an (H, W, 3) uint8 image, got {rgb.dtype} {rgb.shape}")
        self.rgb = rgb
        self.scale = as_int(scale, "scale", minimum=1, maximum=64)

    @property
    def pixels(self) -> np.ndarray:
        """(H scale, W scale, 3) uint8: what the notebook shows."""
        return upscale(self.rgb, self.scale)

    def _repr_png_(self) -> bytes:
        return png_bytes(self.pixels)

    def __repr__(self) -> str:
        h, w = self.rgb.shape[:2]
        return f"Picture({w}x{h}, shown at {self.scale}x: {w * self.scale}x{h * self.scale})"

    def save(self, path) -> None:
        """Write the upscaled picture as a PNG (``path`` ends in ``.png``)."""
        import pathlib

        path = pathlib.Path(path)
        if path.suffix.lower() != ".png":
            raise ValueError(f"path: a Picture is written as .png, got {path.suffix or 'no extension'!r}")
        path.write_bytes(self._repr_png_())


def show(image, scale=None, width=None, **tone) -> Picture:
    """A :class:`Picture` of a linear (H, W, 3) image, tone-mapped by :func:`to_uint8` with ``tone``."""
    a = np.asarray(image)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"image: expected an (H, W, 3) linear image, got shape {a.shape}")
    return Picture(to_uint8(a, **tone), display_scale(a.shape, scale, width))


class ImageArray(np.ndarray):
    """A linear (H, W, 3) float image that is an ordinary array everywhere and a
    picture in a notebook (``_repr_png_``: tone-mapped as :func:`to_uint8` by
    default, upscaled as :func:`display_scale`). Arithmetic on it gives a plain
    ndarray; slices stay ImageArrays and show as pictures when still (H, W, 3).
    """

    tone: dict = {}  # default exposure, tonemap, gamma of the picture (a frame's own); never mutated

    def __array_finalize__(self, obj):
        self.tone = getattr(obj, "tone", {})

    def __array_wrap__(self, arr, context=None, return_scalar=False):
        if return_scalar:
            return arr[()]
        return np.asarray(arr).view(np.ndarray)

    def show(self, scale=None, width=None, **tone) -> Picture:
        """:class:`Picture` of this image: ``scale`` or ``width`` as :func:`display_scale`,
        ``tone`` (``exposure``, ``tonemap``, ``gamma``) as :func:`to_uint8`."""
        return show(self.view(np.ndarray), scale, width, **{**self.tone, **tone})

    def _repr_png_(self):
        a = self.view(np.ndarray)
        if a.ndim != 3 or a.shape[2] != 3 or a.shape[0] == 0 or a.shape[1] == 0 or not np.all(np.isfinite(a)):
            return None  # not a picture: IPython falls back to the array's text
        return self.show()._repr_png_()
