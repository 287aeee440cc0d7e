"""Tangent-space normal maps: the texel gives the shading normal in the surface's own frame.

The modern form of Blinn's perturbed normal (:mod:`.bump`): instead of a height
map's gradient, the texture stores the bent normal itself, ``(r, g, b) = (n' + 1) / 2``
in the frame ``(T, B, N)`` of the tangent (along increasing u), the bitangent and
the interpolated normal (glTF's ``normalTexture``):

    n' = normalize(T (2r - 1) s + B (2g - 1) s + N (2b - 1)),    B = w (N x T)

with ``s`` the material's ``normal_scale`` and ``w`` the tangents' handedness.
``T`` is interpolated over the triangle and made orthogonal to ``N``; the result
is oriented as the bump path's (the viewer's side, reflected into the viewer's
hemisphere of the geometric normal). Sampled bilinearly at level 0 of the map.
"""

from __future__ import annotations

import numpy as np
from ..common.inline import inline_jit

from .jit import HELPER
from .records import reflect_into
from .texture import _sample_level

__all__ = []


@inline_jit(**HELPER)
def _nmap_sample(B, k, at, tri):
    """Normal map ``k`` at the hit: what :func:`_normal_map` bends the normal with, and what its
    gradient (:mod:`.grad_bump`) goes back through (one lookup for both).

    Returns ``(tu, tv, x, y, z, t, w)``: the hit's UV; the texel's tangent-space normal
    ``x = (2r - 1) s``, ``y = (2g - 1) s``, ``z = 2b - 1`` (level 0, bilinear; ``s`` the material's
    ``normal_scale``); the interpolated vertex tangent ``t`` (3-tuple, not yet orthogonal to the
    normal) and its handedness ``w`` (+-1). ``B``, ``at``, ``tri`` as for :func:`_normal_map`."""
    uvs = B.uvs
    scale = B.nmap_scale[at.gm]
    tangents = B.vertex_tangents
    i0, i1, i2 = tri
    b1 = at.b1
    b2 = at.b2
    b0 = 1.0 - b1 - b2
    tu = b0 * uvs[i0, 0] + b1 * uvs[i1, 0] + b2 * uvs[i2, 0]
    tv = b0 * uvs[i0, 1] + b1 * uvs[i1, 1] + b2 * uvs[i2, 1]
    r, gg, bb = _sample_level(B.nmap_texels, B.nmap_info, k, tu, tv, 0)
    x = (2.0 * r - 1.0) * scale
    y = (2.0 * gg - 1.0) * scale
    z = 2.0 * bb - 1.0
    tx = b0 * tangents[i0, 0] + b1 * tangents[i1, 0] + b2 * tangents[i2, 0]
    ty = b0 * tangents[i0, 1] + b1 * tangents[i1, 1] + b2 * tangents[i2, 1]
    tz = b0 * tangents[i0, 2] + b1 * tangents[i1, 2] + b2 * tangents[i2, 2]
    w = b0 * tangents[i0, 3] + b1 * tangents[i1, 3] + b2 * tangents[i2, 3]
    w = -1.0 if w < 0.0 else 1.0
    return tu, tv, x, y, z, (tx, ty, tz), w


@inline_jit(**HELPER)
def _normal_map(n, B, normals, at, tri, g, sgn, ext):
    """``n`` (the oriented unit shading normal, 3-tuple) bent by the model's normal map,
    or ``n`` itself when the model has none. ``B`` is the height-map tuple of
    :class:`~raycast_shade.shading.inputs.FrameInputs` (its normal-map fields from index 5);
    ``normals`` the vertex normals; ``at`` the hit on triangle ``tri``; ``g, sgn`` the
    geometric normal turned to the viewer and the sign that turned it; ``ext`` the frame's ``B.ext``
    (None: no model has a normal map, nor any other extension, and this compiles to ``n``)."""
    if ext is None:
        return n
    k = B.nmap_index[at.gm]
    if k < 0:
        return n
    _, _, x, y, z, t, w = _nmap_sample(B, k, at, tri)
    tx, ty, tz = t
    # The surface's own normal (the viewer's flip undone), and its tangent made orthogonal to it.
    nx = sgn * n[0]
    ny = sgn * n[1]
    nz = sgn * n[2]
    c = tx * nx + ty * ny + tz * nz
    tx -= c * nx
    ty -= c * ny
    tz -= c * nz
    tl = np.sqrt(tx * tx + ty * ty + tz * tz)
    if not (tl > 1e-12 and tl < np.inf):
        return n
    tx /= tl
    ty /= tl
    tz /= tl
    bx = w * (ny * tz - nz * ty)
    by = w * (nz * tx - nx * tz)
    bz = w * (nx * ty - ny * tx)
    ax = tx * x + bx * y + nx * z
    ay = ty * x + by * y + ny * z
    az = tz * x + bz * y + nz * z
    al = np.sqrt(ax * ax + ay * ay + az * az)
    if not (al > 0.0 and al < np.inf):
        return n
    s = sgn / al
    return reflect_into((ax * s, ay * s, az * s), g)
