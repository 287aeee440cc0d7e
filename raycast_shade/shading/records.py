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
named tuples ``G`` (:class:`Geometry`), ``B`` (:class:`Bumps`), ``L`` (:class:`Lighting`) and
``T`` (:class:`Colours`) themselves, read by name (``L.handle``, ``B.nmap_index``): the helpers
are compiled without reference counting (:data:`~raycast_shade.shading.jit.HELPER`), so handing
them a tuple of arrays costs nothing per pixel, where unpacking it in a kernel's loop would.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from ..common.inline import inline_jit

from .jit import FLT32_MAX, HELPER

__all__ = ["Hit", "At", "Geometry", "Bumps", "Lighting", "Colours", "TERM_SLOTS"]

Hit = namedtuple("Hit", ["p", "v", "g", "sgn", "n", "o"])
At = namedtuple("At", ["f", "gm", "b1", "b2"])

# The frame's packed inputs, one definition each (row layouts: raycast_shade.common.layout).
Geometry = namedtuple("Geometry", ["verts", "normals", "faces", "face_normals"])
"""``G``: verts (V, 3) f8, normals (V, 3) f8, faces (F, 3) i4, face normals (F, 3) f8."""
Bumps = namedtuple("Bumps", ["uvs", "tangents", "bump_index", "bump_texels", "bump_info", "nmap_index",
                             "nmap_texels", "nmap_info", "nmap_scale", "vertex_tangents", "ext"])
"""``B``: uvs (V, 2) f8, face tangents (F, 6) f8, height-map row per model (G,) i4 (-1 none), its
texels (T,) f4 and rows (B, BUMP_SIZE) f8, normal-map row per model (G,) i4, its texels (N,) f4 and
rows (K, TEX_SIZE) f8, normal scale per model (G,) f8, vertex tangents (V, 4) f8; ``ext``, the frame's
extensions marker (as ``Lighting.ext``)."""
Lighting = namedtuple("Lighting", ["ambient", "lights", "dmin", "handle", "unit", "spec_on", "att_on", "no_vis",
                                   "ext"])
"""``L``: ambient (3,) f8, light rows (L, LIGHT_SIZE) f8, the inverse-square clamp ``dmin`` f8, the
Embree scene handle (uintp; 0 when no light casts shadows), the scene's size ``unit`` f8 (ray
offsets), and the frame's flags ``spec_on`` (some material has a specular term) and ``att_on``
(some light attenuates), run-time booleans that skip arithmetic no model or light needs; ``no_vis``
(1, 1) i1, the packet answers of a point shaded without packets (never read: its lane is -1). A
writable array of the packets' own type, so that the evaluator compiles once for both. ``ext``: None
when the frame needs nothing beyond the lecture's models (:data:`.illumination.LEAN`), else True; a
compile-time marker, not a flag: the kernels compile one build for each (Numba prunes the branches
of spot and area lights, the GGX model and normal maps where it is None, before typing them)."""
Colours = namedtuple("Colours", ["vertex_colors", "face_colors", "color_mode", "tex_index", "tex_texels",
                                 "tex_info", "modulate"])
"""``T``: vertex colours (V, 3) f8, face colours (F, 3) f8, colour mode per model (G,) i1, map rows
(G, TEXMAP_COUNT) i4 (-1 none), texels (N,) f4, rows (K, TEX_SIZE) f8, Gouraud's modulate flag per
model (G,) u1 (a map or face colours)."""

# The terms record ``R`` the evaluator writes a point's parts into (the one-pass terms,
# :mod:`.terms_kernel`): one flat tuple, as Numba's parallel loops take a tuple of arrays as an
# argument, not a tuple of tuples. Its five term images first, in the order of frame.terms' names:
TERM_AMBIENT, TERM_DIFFUSE, TERM_SPECULAR, TERM_EMISSIVE, TERM_BACKGROUND = 0, 1, 2, 3, 4
TERM_SLOTS = ("ambient", "diffuse", "specular", "emissive", "background")
# then the per-light parts, the shadow masks, the two write flags and the background colour.
TERMS_EACH, TERMS_SHADOW, TERMS_EMIT_ON, TERMS_BG_ON, TERMS_BACKGROUND_RGB = 5, 6, 7, 8, 9


@inline_jit(**HELPER)
def store3(arr, y, x, r, g, b):
    """``arr[y, x] = (r, g, b)``, each saturated at float32's largest (a term image is float32)."""
    arr[y, x, 0] = min(r, FLT32_MAX)
    arr[y, x, 1] = min(g, FLT32_MAX)
    arr[y, x, 2] = min(b, FLT32_MAX)


@inline_jit(**HELPER)
def dot(a, b):
    """``a . b``, summed x, y, z in that order."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@inline_jit(**HELPER)
def neg(a):
    """``-a``."""
    return -a[0], -a[1], -a[2]


@inline_jit(**HELPER)
def normalize(a):
    """``(a / |a|, |a|)``; ``a`` unchanged with length 0 when it is zero."""
    length = np.sqrt(dot(a, a))
    if length == 0.0:
        return a, 0.0
    return (a[0] / length, a[1] / length, a[2] / length), length


@inline_jit(**HELPER)
def face_forward(g, v):
    """``(g, 1.0)`` when ``g`` faces ``v`` (``g . v >= 0``), else ``(-g, -1.0)``."""
    if dot(g, v) < 0.0:
        return neg(g), -1.0
    return g, 1.0


@inline_jit(**HELPER)
def reflect_into(a, g):
    """``a`` reflected across the plane of unit ``g`` when it points below it (``a . g < 0``),
    else ``a``: how the shading helpers keep a bent vector in the viewer's hemisphere."""
    c = dot(a, g)
    if c < 0.0:
        return a[0] - 2.0 * c * g[0], a[1] - 2.0 * c * g[1], a[2] - 2.0 * c * g[2]
    return a
