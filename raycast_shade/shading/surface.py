"""Geometry at a hit: the point, the view vector, and the normals shading uses.

Orientation (two-sided lighting): the geometric normal ``ng`` is turned to
the viewer; a shading normal seen from the back is negated with it, and one
that still points into the far hemisphere (coarse silhouettes, inconsistent
data) is reflected across the tangent plane into the viewer's hemisphere,
which is continuous where plain negation would jump. An interpolated normal
that cancels (``|a| < 1e-6``) falls back to ``ng``.

In Phong mode the shadow-ray origin is first lifted onto the vertices'
tangent planes (Hanika, Ray Tracing Gems II ch. 4) so that coarse meshes
with smooth normals do not shadow themselves at the terminator.
"""

from __future__ import annotations

import numpy as np
from ..common.inline import inline_jit

from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_ORTHO
from .jit import HELPER
from .records import dot, face_forward, normalize, reflect_into

__all__ = []

_CANCEL = 1e-6  # |interpolated normal| below this counts as cancelled


@inline_jit(**HELPER)
def _view(cam, p):
    """Unit vector from point ``p`` to the eye (orthographic: against the view)."""
    back = (-cam[CAM_FORWARD + 0], -cam[CAM_FORWARD + 1], -cam[CAM_FORWARD + 2])
    if cam[CAM_ORTHO] != 0.0:
        return back
    v, length = normalize((cam[CAM_EYE + 0] - p[0], cam[CAM_EYE + 1] - p[1], cam[CAM_EYE + 2] - p[2]))
    if length == 0.0:
        return back
    return v


@inline_jit(**HELPER)
def _facing(fnormals, f, v):
    """Face ``f``'s geometric normal turned to ``v``, and the sign that turned it."""
    g = (fnormals[f, 0], fnormals[f, 1], fnormals[f, 2])
    if g[0] == 0.0 and g[1] == 0.0 and g[2] == 0.0:  # degenerate face: face the viewer
        return v, 1.0
    return face_forward(g, v)


@inline_jit(**HELPER)
def interpolated_normal(normals, tri, b1, b2):
    """The vertex normals of triangle ``tri = (i0, i1, i2)`` blended by the weights
    ``(1 - b1 - b2, b1, b2)``, not renormalised: ``(ax, ay, az)`` and its length ``al``."""
    i0, i1, i2 = tri
    b0 = 1.0 - b1 - b2
    ax = b0 * normals[i0, 0] + b1 * normals[i1, 0] + b2 * normals[i2, 0]
    ay = b0 * normals[i0, 1] + b1 * normals[i1, 1] + b2 * normals[i2, 1]
    az = b0 * normals[i0, 2] + b1 * normals[i1, 2] + b2 * normals[i2, 2]
    return ax, ay, az, np.sqrt(ax * ax + ay * ay + az * az)


@inline_jit(**HELPER)
def _shading_normal(normals, tri, b1, b2, g, sgn):
    """Interpolated, renormalised normal of triangle ``tri = (i0, i1, i2)``, oriented into the
    viewer's hemisphere of ``g``."""
    ax, ay, az, al = interpolated_normal(normals, tri, b1, b2)
    if not al >= _CANCEL:
        return g
    s = sgn / al
    return reflect_into((ax * s, ay * s, az * s), g)


@inline_jit(**HELPER)
def _convex_weights(b1, b2):
    """Interpolation weights ``(b0, b1, b2)`` clamped onto the triangle.

    Embree's ``u, v`` can stray a few ulps outside the triangle (at a vertex
    seen from very close, for one), and a weight of -1e-7 on a vertex shade
    of 1e11 next to a point light made a Gouraud pixel -1e4: clamped, every
    interpolated value lies between its vertex values. Weights already inside
    pass unchanged."""
    if not (b1 >= 0.0 and b2 >= 0.0 and b1 + b2 <= 1.0):
        b1 = min(max(b1, 0.0), 1.0)
        b2 = min(max(b2, 0.0), 1.0)
        s = b1 + b2
        if s > 1.0:
            b1 /= s
            b2 /= s
    b0 = 1.0 - b1 - b2
    if b0 < 0.0:  # b1 + b2 rounded down to 1
        b0 = 0.0
    return b0, b1, b2


@inline_jit(**HELPER)
def _triangle(faces, f):
    """The vertex indices ``(i0, i1, i2)`` of face ``f``."""
    return faces[f, 0], faces[f, 1], faces[f, 2]


@inline_jit(**HELPER)
def _hit_point(verts, tri, b1, b2):
    """The point with barycentrics (1 - b1 - b2, b1, b2) on triangle ``tri = (i0, i1, i2)``."""
    i0, i1, i2 = tri
    b0 = 1.0 - b1 - b2
    px = b0 * verts[i0, 0] + b1 * verts[i1, 0] + b2 * verts[i2, 0]
    py = b0 * verts[i0, 1] + b1 * verts[i1, 1] + b2 * verts[i2, 1]
    pz = b0 * verts[i0, 2] + b1 * verts[i1, 2] + b2 * verts[i2, 2]
    return px, py, pz


@inline_jit(**HELPER)
def _terminator_point(verts, normals, tri, b1, b2, p, sgn):
    """Hanika's shadow-ray origin: ``p`` lifted onto the vertices' tangent planes
    (only upwards), so a flat facet under a smooth normal does not shadow itself
    near the terminator."""
    i0, i1, i2 = tri
    px, py, pz = p
    b0 = 1.0 - b1 - b2
    qx = px
    qy = py
    qz = pz
    for k in range(3):
        i = i0 if k == 0 else (i1 if k == 1 else i2)
        w = b0 if k == 0 else (b1 if k == 1 else b2)
        nx = sgn * normals[i, 0]
        ny = sgn * normals[i, 1]
        nz = sgn * normals[i, 2]
        d = (px - verts[i, 0]) * nx + (py - verts[i, 1]) * ny + (pz - verts[i, 2]) * nz
        if d < 0.0:
            qx -= w * d * nx
            qy -= w * d * ny
            qz -= w * d * nz
    return qx, qy, qz
