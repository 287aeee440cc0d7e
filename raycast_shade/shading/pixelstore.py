"""Where a Phong pixel is stored: the helpers every Phong kernel (general, tile packets, batched) calls.

A module of its own so that :mod:`.phong` and :mod:`.phong_fast` both import it without importing
each other (the terms kernels import :mod:`.phong`, and the batched kernel the terms kernels).
"""

from __future__ import annotations

from ..common.inline import inline_jit
from .jit import FLT32_MAX, HELPER

__all__ = ["saturate", "store_pixel", "store_background"]


@inline_jit(**HELPER)
def saturate(c):
    """Colour channel ``c`` (float64) saturated at the float32 maximum, as every Phong kernel stores it:
    radiance beyond float32 becomes its maximum, not inf."""
    return min(c, FLT32_MAX)


@inline_jit(**HELPER)
def store_pixel(outs, y, x, rgb, n):
    """Write pixel ``(y, x)`` of ``outs = (image, normal)``: its colour ``rgb`` saturated at the
    float32 maximum and, when ``normal`` is an array (not the (0, 0, 3) stand-in), its shading
    normal ``n``. The general and tile-packet kernels store their pixels here; the batched kernel
    stores its lanes' (:func:`.phong_fast._scatter`) with the same :func:`saturate`."""
    image, normal = outs
    image[y, x, 0] = saturate(rgb[0])
    image[y, x, 1] = saturate(rgb[1])
    image[y, x, 2] = saturate(rgb[2])
    if normal.shape[0] != 0:
        normal[y, x, 0] = n[0]
        normal[y, x, 1] = n[1]
        normal[y, x, 2] = n[2]


@inline_jit(**HELPER)
def store_background(outs, y, x, bg):
    """Write background pixel ``(y, x)`` of ``outs = (image, normal)``: the colour ``bg`` (three
    float32) and, when ``normal`` is an array, a zero normal. The batched kernel's queue loop and
    the shadowed kernel's strip pass (:func:`.shadows._strip_background`) store their misses here."""
    image, normal = outs
    image[y, x, 0] = bg[0]
    image[y, x, 1] = bg[1]
    image[y, x, 2] = bg[2]
    if normal.shape[0] != 0:
        for c in range(3):
            normal[y, x, c] = 0.0
