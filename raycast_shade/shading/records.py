"""The records the shading helpers pass each other, and 3-vector arithmetic on tuples.

Inside the kernels a 3-vector is a tuple of three floats: Numba keeps it in registers, and
after LLVM inlines the helpers the arithmetic is exactly the scalar code it replaces (the
golden images are bit-identical). Records are named tuples, so a helper reads ``hp.n``
rather than the twelfth of fifteen return values.

``Hit``, a shading point (Phong's pixel, flat's face centre, Gouraud's vertex):

==========  =============================================================================
``p``       the point (re-centred world coordinates)
``v``       unit vector towards the viewer (``-d`` for a secondary ray)
``g``       geometric normal turned to the viewer (a Gouraud vertex: its own normal)
``sgn``     the sign that turned it (+1 front, -1 back)
``n``       the unit shading normal (interpolated, oriented, bumped)
``o``       where shadow rays start (``p``, or Hanika's terminator point in Phong mode)
==========  =============================================================================

``At``, where a hit lies: face ``f`` (scene-wide index), model ``gm``, barycentrics ``b1, b2``
of vertices 1 and 2.

The packed frame inputs (:class:`~raycast_shade.shading.inputs.FrameInputs`) travel as the
tuples ``G``, ``B``, ``L`` and ``T`` themselves: the helpers are compiled without reference
counting (:data:`~raycast_shade.shading.jit.HELPER`), so handing them a tuple of arrays costs
nothing per pixel, where unpacking it in a kernel's loop would.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .jit import HELPER

__all__ = ["Hit", "At"]

Hit = namedtuple("Hit", ["p", "v", "g", "sgn", "n", "o"])
At = namedtuple("At", ["f", "gm", "b1", "b2"])


@njit(**HELPER)
def dot(a, b):
    """``a . b``, summed x, y, z in that order."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(**HELPER)
def neg(a):
    """``-a``."""
    return -a[0], -a[1], -a[2]


@njit(**HELPER)
def normalize(a):
    """``(a / |a|, |a|)``; ``a`` unchanged with length 0 when it is zero."""
    length = np.sqrt(dot(a, a))
    if length == 0.0:
        return a, 0.0
    return (a[0] / length, a[1] / length, a[2] / length), length


@njit(**HELPER)
def face_forward(g, v):
    """``(g, 1.0)`` when ``g`` faces ``v`` (``g . v >= 0``), else ``(-g, -1.0)``."""
    if dot(g, v) < 0.0:
        return neg(g), -1.0
    return g, 1.0


@njit(**HELPER)
def reflect_into(a, g):
    """``a`` reflected across the plane of unit ``g`` when it points below it (``a . g < 0``),
    else ``a``: how the shading helpers keep a bent vector in the viewer's hemisphere."""
    c = dot(a, g)
    if c < 0.0:
        return a[0] - 2.0 * c * g[0], a[1] - 2.0 * c * g[1], a[2] - 2.0 * c * g[2]
    return a
