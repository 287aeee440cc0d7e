"""Texel gradients: a point's ``dL/d sample`` onto the texels the forward sampler read.

The colour, occlusion and normal maps' samplers (:mod:`.texture`) and the height maps' (:mod:`.bump`)
read four texels with the bilinear weights (wrapped or clamped by
:func:`~raycast_shade.shading.bump._texel_corners`); a mip-mapped map two levels blended by the
level of detail, each level the box filter of the one below. :func:`texel_scatter` and
:func:`grid_scatter` are the transpose of one bilinear read, :func:`texel_gradient` of the
trilinear read and the pyramid (the level of detail held: it depends on the geometry). The sums run
in NumPy in index order (``np.bincount``): deterministic.
"""

from __future__ import annotations

import numpy as np

from ..common.layout import TEX_CLAMP, TEX_HEIGHT, TEX_LEVELS, TEX_MIPMAP, TEX_TILE_U, TEX_TILE_V, TEX_WIDTH
from .texture import _rho_kernel

__all__ = ["grid_scatter", "texel_scatter", "texel_gradient", "face_rho", "pixel_rho", "add_rows"]

_WHOLE = 4503599627370496.0  # 2**52: from here on a float64 is a whole number (the samplers' reduction)


def add_rows(out, idx, vals) -> None:
    """``out[idx[k]] += vals[k]`` for each ``k`` in order (``np.bincount`` per column: sequential, so
    deterministic, and several times faster than ``np.add.at``)."""
    flat = out.reshape(out.shape[0] if out.ndim == 2 else -1, out.shape[-1])
    for c in range(flat.shape[1]):
        flat[:, c] += np.bincount(idx, weights=vals[:, c], minlength=flat.shape[0])


def texel_scatter(info, k, uv, g, level=0):
    """``g`` (N, 3) at UVs ``uv`` (N, 2) onto level ``level`` of texture ``k`` with the bilinear
    weights (:func:`~raycast_shade.shading.texture._sample_level`, wrapped or clamped as there):
    (h_l, w_l, 3), rows as the texture's ``texels``."""
    w = max(1, int(info[k, TEX_WIDTH]) >> level)
    h = max(1, int(info[k, TEX_HEIGHT]) >> level)
    clamp = info[k, TEX_CLAMP] != 0.0
    su = uv[:, 0] * info[k, TEX_TILE_U]
    sv = uv[:, 1] * info[k, TEX_TILE_V]
    with np.errstate(invalid="ignore"):
        if not clamp:  # as _sample_level: past 2**52 a whole number of periods
            su = np.where(np.abs(su) < _WHOLE, su, 0.0)
            sv = np.where(np.abs(sv) < _WHOLE, sv, 0.0)
    return grid_scatter(h, w, clamp, su * w - 0.5, sv * h - 0.5, g)


def grid_scatter(h, w, clamp, x, y, g):
    """``g`` (N, C) at texel coordinates ``x``, ``y`` (N,) (centres at integers) onto an (h, w, C)
    grid with the bilinear weights, wrapped or clamped as
    :func:`~raycast_shade.shading.bump._texel_corners` picks the four texels."""
    with np.errstate(invalid="ignore"):
        if clamp:  # as bump._texel_corners: to the border, or exactly modulo the grid
            x = np.where(np.abs(x) < _WHOLE, x, np.where(x < 0.0, -1.0, float(w)))
            y = np.where(np.abs(y) < _WHOLE, y, np.where(y < 0.0, -1.0, float(h)))
        else:
            x = np.where(np.abs(x) < _WHOLE, x, np.where(np.isfinite(x), np.fmod(x, float(w)), 0.0))
            y = np.where(np.abs(y) < _WHOLE, y, np.where(np.isfinite(y), np.fmod(y, float(h)), 0.0))
    j0, i0 = np.floor(x), np.floor(y)
    tx, ty = x - j0, y - i0
    j0, i0 = j0.astype(np.int64), i0.astype(np.int64)
    j1, i1 = j0 + 1, i0 + 1
    if clamp:
        j0, j1, i0, i1 = (np.clip(a, 0, n - 1) for a, n in ((j0, w), (j1, w), (i0, h), (i1, h)))
    else:
        j0, j1, i0, i1 = j0 % w, j1 % w, i0 % h, i1 % h
    out = np.zeros((h, w, g.shape[1]))
    for ii, jj, wt in ((i0, j0, (1.0 - tx) * (1.0 - ty)), (i0, j1, tx * (1.0 - ty)), (i1, j0, (1.0 - tx) * ty),
                       (i1, j1, tx * ty)):
        add_rows(out, ii * w + jj, wt[:, None] * g)
    return out


def _halve_adjoint(g, n, axis):
    """The transpose of :class:`~raycast_shade.Texture`'s pyramid step along ``axis`` (pairs
    averaged; an odd length's last three samples averaged into the last output): ``g`` on the
    ``max(1, n // 2)`` halved samples back onto the ``n`` of the level below."""
    if n == 1:
        return g
    m = n // 2
    g = np.moveaxis(g, axis, 0)
    out = np.zeros((n,) + g.shape[1:])
    out[0:2 * m:2] += 0.5 * g
    out[1:2 * m:2] += 0.5 * g
    if n % 2:  # the last output is (a[n-3] + a[n-2] + a[n-1]) / 3, not a pair's mean
        out[n - 3:n - 1] -= 0.5 * g[m - 1]
        out[n - 3:n] += g[m - 1] / 3.0
    return np.moveaxis(out, 0, axis)


def _levels(info, k, rho):
    """Each point's mip levels and weights as :func:`~raycast_shade.shading.texture._sample` picks
    them from its footprint ``rho`` (N,): ``(l0, w0, w1)``, level ``l0`` weighted ``w0`` and
    ``l0 + 1`` weighted ``w1`` (0 where one level is sampled)."""
    top = int(info[k, TEX_LEVELS]) - 1
    mip = info[k, TEX_MIPMAP] != 0.0
    trilinear = mip & (rho > 1.0)  # NaN: not > 1, level 0
    with np.errstate(divide="ignore", invalid="ignore"):
        lod = np.where(trilinear, np.minimum(np.log2(np.where(trilinear, rho, 1.0)), float(top)), 0.0)
    l0 = np.floor(lod)
    frac = lod - l0
    l0 = l0.astype(np.int64)
    single = (frac == 0.0) | (l0 >= top)
    return l0, np.where(single, 1.0, 1.0 - frac), np.where(single, 0.0, frac)


def texel_gradient(info, k, uv, g, rho):
    """``g`` (N, 3) at UVs ``uv`` with footprints ``rho`` (N,) onto texture ``k``'s level 0 through
    the trilinear filter and the pyramid's box filters (bilinear textures: level 0 alone)."""
    l0, w0, w1 = _levels(info, k, rho)
    w, h = int(info[k, TEX_WIDTH]), int(info[k, TEX_HEIGHT])
    top = int(info[k, TEX_LEVELS]) - 1
    acc = None
    for lvl in range(top, -1, -1):  # from the top down: each level's gradient onto the one below
        here = np.zeros((max(1, h >> lvl), max(1, w >> lvl), 3))
        for sel, wt in ((l0 == lvl, w0), (l0 + 1 == lvl, w1)):
            sel = sel & (wt != 0.0)
            if np.any(sel):
                here += texel_scatter(info, k, uv[sel], wt[sel, None] * g[sel], lvl)
        if acc is not None:
            here += _halve_adjoint(_halve_adjoint(acc, max(1, w >> lvl), 1), max(1, h >> lvl), 0)
        acc = here
    return acc


def face_rho(info, k, uvs, tri):
    """A flat face's footprint in level-0 texels (:func:`~raycast_shade.shading.texture._face_footprint`
    through :func:`~raycast_shade.shading.texture._level_rho`)."""
    d1 = uvs[tri[:, 1]] - uvs[tri[:, 0]]
    d2 = uvs[tri[:, 2]] - uvs[tri[:, 0]]
    side = np.sqrt(0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]))
    su = info[k, TEX_WIDTH] * info[k, TEX_TILE_U]
    sv = info[k, TEX_HEIGHT] * info[k, TEX_TILE_V]
    return np.maximum(np.abs(side * su), np.abs(side * sv))


def pixel_rho(hits, inputs, slot):
    """Each pixel's footprint ``rho`` in its model's ``slot`` map (row-major; NaN without one): the
    forward pass's (:func:`~raycast_shade.shading.texture.texture_levels`' kernel)."""
    G, T = inputs.geometry, inputs.colours
    out = np.empty(hits.shape, np.float64)
    _rho_kernel(hits.prim, hits.geom, hits.u, hits.v, G.verts, G.faces, G.face_normals, inputs.bumps.uvs,
                inputs.face_off, T.tex_index, T.tex_info, inputs.cam, slot, out)
    return out.ravel()
