"""Blinn bump mapping: the height map's gradient bends the shading normal.

Height maps are packed as in :meth:`raycast_shade.HeightMap.packed_info`:
all texels in one flat array, one row of ``BUMP_SIZE`` slots per map
(:mod:`raycast_shade.common.layout`).
"""

from __future__ import annotations

import math

import numpy as np
from ..common.inline import inline_jit

from ..common.layout import BUMP_CLAMP, BUMP_COLS, BUMP_OFFSET, BUMP_ROWS, BUMP_SCALE, BUMP_TILE_U, BUMP_TILE_V
from .jit import HELPER

__all__ = []


@inline_jit(**HELPER)
def _texel_corners(rows, cols, clamp, x, y):
    """The four texels around texel coordinates (x, y) (centres at integers) of a
    ``rows`` x ``cols`` grid, clamped to its border or wrapped, and the weights'
    fractions: ``i0, i1, j0, j1, tx, ty``. Shared by the height and colour samplers.

    From 2**52 on a float64 is a whole number, and ``int()`` of one past 2**63
    overflows: such an ``x`` (or an infinite one) is reduced first, to the border
    when clamping, exactly modulo the grid when wrapping; the same texels."""
    if not abs(x) < 4503599627370496.0:
        x = (-1.0 if x < 0.0 else float(cols)) if clamp else (np.fmod(x, float(cols)) if np.isfinite(x) else 0.0)
    if not abs(y) < 4503599627370496.0:
        y = (-1.0 if y < 0.0 else float(rows)) if clamp else (np.fmod(y, float(rows)) if np.isfinite(y) else 0.0)
    j0 = math.floor(x)
    i0 = math.floor(y)
    tx = x - j0
    ty = y - i0
    j0 = int(j0)
    i0 = int(i0)
    j1 = j0 + 1
    i1 = i0 + 1
    if clamp:
        j0 = min(max(j0, 0), cols - 1)
        j1 = min(max(j1, 0), cols - 1)
        i0 = min(max(i0, 0), rows - 1)
        i1 = min(max(i1, 0), rows - 1)
    else:
        j0 %= cols
        j1 %= cols
        i0 %= rows
        i1 %= rows
    return i0, i1, j0, j1, tx, ty


@inline_jit(**HELPER)
def _bilinear(tex, base, rows, cols, clamp, x, y):
    """Bilinear sample at texel coordinates (x, y) (texel centres at integers)."""
    i0, i1, j0, j1, tx, ty = _texel_corners(rows, cols, clamp, x, y)
    a = tex[base + i0 * cols + j0] * (1.0 - tx) + tex[base + i0 * cols + j1] * tx
    b = tex[base + i1 * cols + j0] * (1.0 - tx) + tex[base + i1 * cols + j1] * tx
    return a * (1.0 - ty) + b * ty


@inline_jit(**HELPER)
def _bump_slopes(B, k, at, tri, front):
    """Height map ``k``'s slopes at the hit, and the face's UV axes: what :func:`_bump` bends the
    normal with, and what its gradient (:mod:`.grad_bump`) goes back through (one lookup for both).

    Returns ``(x, y, bu, bv, ku, kv, pu, pv, area)``: the texel coordinates ``(x, y)`` of the
    hit's UV (texel centres at integers); ``bu = ku (h(x + 1/2, y) - h(x - 1/2, y))`` and
    ``bv = kv (h(x, y + 1/2) - h(x, y - 1/2))``, the one-texel central differences of the bilinear
    heights (exact for heights linear in u, v); ``ku = +-cols su scale``, ``kv = +-rows sv scale``,
    negative where the UV map is left-handed (``(Pu x Pv).front < 0``); the face's ``Pu``, ``Pv``
    (3-tuples) and ``area = |Pu x Pv|``. ``B`` as for :func:`_bump`; ``at`` the hit on triangle
    ``tri``; ``front`` its front (winding) normal."""
    uvs, tangents, texels, info = B.uvs, B.tangents, B.bump_texels, B.bump_info
    f, gm, b1, b2 = at
    i0, i1, i2 = tri
    fx, fy, fz = front
    b0 = 1.0 - b1 - b2
    tu = b0 * uvs[i0, 0] + b1 * uvs[i1, 0] + b2 * uvs[i2, 0]
    tv = b0 * uvs[i0, 1] + b1 * uvs[i1, 1] + b2 * uvs[i2, 1]
    base = int(info[k, BUMP_OFFSET])
    rows = int(info[k, BUMP_ROWS])
    cols = int(info[k, BUMP_COLS])
    clamp = info[k, BUMP_CLAMP] != 0.0
    su = info[k, BUMP_TILE_U]
    sv = info[k, BUMP_TILE_V]
    scale = info[k, BUMP_SCALE]
    x = tu * su * cols - 0.5
    y = tv * sv * rows - 0.5
    # Central differences one texel wide: exact for heights linear in u, v.
    bu = (_bilinear(texels, base, rows, cols, clamp, x + 0.5, y)
          - _bilinear(texels, base, rows, cols, clamp, x - 0.5, y)) * cols * su * scale
    bv = (_bilinear(texels, base, rows, cols, clamp, x, y + 0.5)
          - _bilinear(texels, base, rows, cols, clamp, x, y - 0.5)) * rows * sv * scale
    ku = cols * su * scale
    kv = rows * sv * scale
    pux = tangents[f, 0]
    puy = tangents[f, 1]
    puz = tangents[f, 2]
    pvx = tangents[f, 3]
    pvy = tangents[f, 4]
    pvz = tangents[f, 5]
    cx = puy * pvz - puz * pvy
    cy = puz * pvx - pux * pvz
    cz = pux * pvy - puy * pvx
    area = np.sqrt(cx * cx + cy * cy + cz * cz)  # |N| = |Pu x Pv|
    if cx * fx + cy * fy + cz * fz < 0.0:  # left-handed UVs: Pu x Pv points inwards
        bu = -bu
        bv = -bv
        ku = -ku
        kv = -kv
    return x, y, bu, bv, ku, kv, (pux, puy, puz), (pvx, pvy, pvz), area


@inline_jit(**HELPER)
def _bump(n, B, at, tri, front):
    """Blinn's perturbed normal N' = N + (Bu (N x Pv) - Bv (N x Pu)) / |N|,
    with N = n |Pu x Pv| along the (oriented) unit shading normal ``n`` (3-tuple).

    The surface is displaced along its front (winding) normal ``front``, not
    along ``Pu x Pv``: where the UV map is left-handed (``(Pu x Pv).front < 0``,
    e.g. the spherical mapping seen from outside), the perturbation changes
    sign, so a negative height is a dent on every mesh. ``B`` is the height-map
    tuple of :class:`~raycast_shade.shading.inputs.FrameInputs`; ``at`` the hit
    (:class:`~raycast_shade.shading.records.At`) on triangle ``tri = (i0, i1, i2)``."""
    nx, ny, nz = n
    k = B.bump_index[at.gm]
    if k < 0:
        return n
    _, _, bu, bv, _, _, pu, pv, area = _bump_slopes(B, k, at, tri, front)
    pux, puy, puz = pu
    pvx, pvy, pvz = pv
    # (N x Pv) / |N| = n x Pv, likewise for Pu
    ax = area * nx + bu * (ny * pvz - nz * pvy) - bv * (ny * puz - nz * puy)
    ay = area * ny + bu * (nz * pvx - nx * pvz) - bv * (nz * pux - nx * puz)
    az = area * nz + bu * (nx * pvy - ny * pvx) - bv * (nx * puy - ny * pux)
    al = np.sqrt(ax * ax + ay * ay + az * az)
    if not (al > 0.0 and al < np.inf):
        return n
    return ax / al, ay / al, az / al
