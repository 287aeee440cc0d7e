"""Which sides of which vertices a Gouraud frame needs, decided per face, not per pixel.

A pixel of a Gouraud face takes its corners' shades from the side it sees the face from,
:func:`~raycast_shade.shading.surface._facing`'s sign of ``g . v`` at its hit point. For a
plane that sign is the same at every point of the face, up to rounding: each face a frame sees
is therefore tested once (:func:`_face_sides_kernel`), from the eye and constants of the face
kept with the geometry (:func:`face_planes`), and where the test clears the rounding by a wide
margin the face's vertices are shaded from that side alone (a closed mesh seen from outside:
front only). Where it does not (an eye near the face's plane, a degenerate face), both sides are
shaded and each pixel decides, as before.

The margin: a face's side is certain when every corner's ``g . (eye - v)`` clears 0 by
:data:`_CERTAIN` of ``sum |g| (|eye| + |v|)``. A pixel whose weights lie within :data:`_NEAR` of
the triangle (:func:`_near_face`; Embree's stray by a few float32 ulps) computes a ``g . v``
that differs from the plane's by at most ``4 _NEAR`` plus some 40 ulps of that scale (hit
point, view, dot product; the float32 face constants add 2^-24): under ``1e-5``, a tenth of the
margin. A pixel whose weights stray further marks both sides of its corners itself (the
visible pass, :func:`~raycast_shade.shading.shade._visible_kernel`).

A face of certain side whose corners' stored shades all serve (each corner's normal clearly on
the face's side of its plane, ``n . g > 1e-12 sum |n||g|``: the test of
:func:`~raycast_shade.shading.gouraud._corner_normal`, the same for both sides, beyond any
rounding) gets a state, and its near-face pixels interpolate the stored shades at once. Every
pixel's colour is the one the per-pixel tests give, bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import in_parts, share
from ..common.layout import CAM_EYE, CAM_ORTHO
from .jit import CHUNK, HELPER, JIT
from .surface import _facing, _triangle, _view

__all__ = ["face_planes"]

_CERTAIN = 1e-4
_NEAR = 1e-6
_SERVE = 1e-12  # a corner's stored shade serves when n . g > _SERVE sum |n||g| (0 within rounding: not)
_PLANES = "shading.gouraud_planes"  # the geometry's memo key
_LO, _HI, _SCALE, _SERVED = 0, 1, 2, 3  # face_planes' columns


@inline_jit(**HELPER)
def _near_face(b1, b2):
    """Whether the weights ``(1 - b1 - b2, b1, b2)`` lie within :data:`_NEAR` of the triangle:
    then the pixel sees its face from the face's side, when that is certain."""
    return b1 >= -_NEAR and b2 >= -_NEAR and b1 + b2 <= 1.0 + _NEAR


@in_parts
@njit(nogil=True, **JIT)
def _face_planes_kernel(G, planes, part):
    """:func:`face_planes` of the geometry ``G`` = ``(verts, normals, faces, fnormals)``."""
    verts, normals, faces, fnormals = G
    for f in range(*share(faces.shape[0], part)):  # this part's share (common.parallel)
        g = (fnormals[f, 0], fnormals[f, 1], fnormals[f, 2])
        lo, hi, scale, served = np.inf, -np.inf, 0.0, True
        for k in range(3):
            i = faces[f, k]
            gv, s, ng, na = 0.0, 0.0, 0.0, 0.0
            for c in range(3):
                gv += g[c] * verts[i, c]
                s += abs(g[c]) * abs(verts[i, c])
                ng += normals[i, c] * g[c]
                na += abs(normals[i, c]) * abs(g[c])
            lo, hi, scale = min(lo, gv), max(hi, gv), max(scale, s)
            zero = normals[i, 0] == 0.0 and normals[i, 1] == 0.0 and normals[i, 2] == 0.0
            served = served and not zero and ng > _SERVE * na
        planes[f, _LO] = lo
        planes[f, _HI] = hi
        planes[f, _SCALE] = scale
        planes[f, _SERVED] = 1.0 if served else 0.0


def face_planes(geo) -> np.ndarray:
    """The faces' constants the side test reads, kept with the geometry.

    Parameters
    ----------
    geo : SceneGeometry

    Returns
    -------
    (F, 4) float32
        Per face: the least and the greatest ``g . v`` over its corners (``g`` its normal), the
        greatest ``sum |g| |v|``, and 1 where every corner's stored shade serves the face (see
        the module docstring), else 0.
    """
    arrays = (geo.vertices, geo.normals, geo.faces, geo.face_normals)

    def build(_=None):
        planes = np.empty((len(geo.faces), 4), np.float32)
        _face_planes_kernel(arrays, planes)
        return planes

    kept = geo.memo(_PLANES, lambda _: arrays + (build(),))
    if all(a is b for a, b in zip(kept[:4], arrays)):
        return kept[4]
    return build()  # a twin geometry (copy.copy) with arrays of its own: not kept


@inline_jit(**HELPER)
def _face_side(fnormals, planes, cam, f):
    """The side (0 front, 1 back) from which every near-face pixel of face ``f`` sees it, or -1
    where that is not certain (see the module docstring). An orthographic view's side is the
    pixels' own test."""
    g = (fnormals[f, 0], fnormals[f, 1], fnormals[f, 2])
    if g[0] == 0.0 and g[1] == 0.0 and g[2] == 0.0:  # the pixels face the viewer with v itself
        return -1
    if cam[CAM_ORTHO] != 0.0:
        _, sgn = _facing(fnormals, f, _view(cam, g))  # the view ignores the point
        return 0 if sgn > 0.0 else 1
    ge, se = 0.0, 0.0
    for c in range(3):
        ge += g[c] * cam[CAM_EYE + c]
        se += abs(g[c]) * abs(cam[CAM_EYE + c])
    margin = _CERTAIN * (se + planes[f, _SCALE])
    if ge - planes[f, _HI] > margin:
        return 0
    if ge - planes[f, _LO] < -margin:
        return 1
    return -1  # NaN lands here too


@in_parts
@njit(nogil=True, **JIT)
def _face_sides_kernel(face_flags, G, cam, planes, state, vertex_flags, part):
    """The flagged faces' sides: each face's pixels need its corners' shades from its side
    (:func:`_face_side`), or from either where that is not certain; ``vertex_flags`` (V, 2)
    uint8 gets 1 at ``[i, side]`` for each. ``state`` (F,) uint8: ``1 + side`` for a face of
    certain side whose corners' stored shades all serve (``planes``: :func:`face_planes`), whose
    near-face pixels interpolate them at once; 0 for the others."""
    faces, fnormals = G.faces, G.face_normals
    n = faces.shape[0]
    nchunk = (n + CHUNK - 1) // CHUNK
    for c in range(*share(nchunk, part)):  # this part's share: cheap, even work: plain chunks
        for f in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            if face_flags[f] == 0:
                continue
            side = _face_side(fnormals, planes, cam, f)
            tri = _triangle(faces, f)
            for k in range(3):  # racy, but every writer stores the same 1
                if side != 1:
                    vertex_flags[tri[k], 0] = 1
                if side != 0:
                    vertex_flags[tri[k], 1] = 1
            state[f] = 1 + side if side >= 0 and planes[f, _SERVED] != 0.0 else 0
