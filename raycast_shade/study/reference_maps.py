"""NumPy twins of bilinear texture sampling and of the tangent-space normal maps
(:mod:`raycast_shade.shading.normalmap`), for :mod:`.reference` and ``explain``."""

from __future__ import annotations

import numpy as np

__all__ = ["normal_mapped"]


def _dot(a, b):
    """Row-wise dot product of two (N, 3) arrays -> (N,)."""
    return np.einsum("ij,ij->i", a, b)


_WHOLE = 2.0 ** 52


def _reduced(x, n, wrap):
    """Texel coordinates (N,) with every ``|x| >= 2**52`` (or inf) reduced: the border, or modulo ``n``."""
    big = ~(np.abs(x) < _WHOLE)
    if not big.any():
        return x
    if wrap == "clamp":
        return np.where(big, np.where(x < 0.0, -1.0, float(n)), x)
    return np.where(big, np.where(np.isfinite(x), np.fmod(x, float(n)), 0.0), x)


def _bilinear_level(level, wrap, tiling, u, v):
    """Bilinear RGB (N, 3) of one (h, w, 3) level at UVs (N,), texel centres at (j + 1/2) / w."""
    h, w = level.shape[:2]
    su, sv = u * tiling[0], v * tiling[1]
    with np.errstate(invalid="ignore"):
        if wrap != "clamp":  # repeat's period is 1: past 2**52 (or overflowed) a whole number of periods
            su, sv = np.where(np.abs(su) < _WHOLE, su, 0.0), np.where(np.abs(sv) < _WHOLE, sv, 0.0)
        # Texel coordinates past 2**52 are whole numbers (int64 overflows past 2**63): the border, or
        # exactly modulo the grid, as the kernels' _texel_corners.
        x, y = _reduced(su * w - 0.5, w, wrap), _reduced(sv * h - 0.5, h, wrap)
    j0, i0 = np.floor(x), np.floor(y)
    tx, ty = (x - j0)[:, None], (y - i0)[:, None]
    j0, i0 = j0.astype(np.int64), i0.astype(np.int64)

    def idx(i, n):
        return np.clip(i, 0, n - 1) if wrap == "clamp" else np.mod(i, n)

    j1, i1 = idx(j0 + 1, w), idx(i0 + 1, h)
    j0, i0 = idx(j0, w), idx(i0, h)
    lv = level.astype(np.float64)
    return ((1 - tx) * (1 - ty) * lv[i0, j0] + tx * (1 - ty) * lv[i0, j1] + (1 - tx) * ty * lv[i1, j0]
            + tx * ty * lv[i1, j1])


def normal_mapped(scene, n, g, sgn, tri, bary, model):
    """The tangent-space normal map's bent normal (N, 3) at hits with oriented shading normals ``n``
    (N, 3), oriented geometric normals ``g``, signs ``sgn`` (N,), triangles ``tri`` (N, 3), barycentrics
    ``bary`` (N, 3) of models ``model`` (N,): :mod:`raycast_shade.shading.normalmap` in NumPy, level-0
    bilinear texels, ``n`` where a model has no map (or the frame degenerates)."""
    geo = scene.geometry
    out = n.copy()
    for k, m in enumerate(scene.models):
        tex = m.material.normal_map
        sel = model == k
        if tex is None or not sel.any():
            continue
        uv = np.einsum("nk,nkc->nc", bary[sel], geo.uvs[tri[sel]])
        r, gg, b = _bilinear_level(tex.pyramid[0], tex.wrap, tex.tiling, uv[:, 0], uv[:, 1]).T
        s = m.material.normal_scale
        x, y, z = (2.0 * r - 1.0) * s, (2.0 * gg - 1.0) * s, 2.0 * b - 1.0
        N = sgn[sel, None] * n[sel]
        frame = np.einsum("nk,nkc->nc", bary[sel], geo.vertex_tangents[tri[sel]])
        w = np.where(frame[:, 3] < 0.0, -1.0, 1.0)
        t = frame[:, :3] - N * _dot(frame[:, :3], N)[:, None]
        tl = np.sqrt(_dot(t, t))
        t = t / tl[:, None]
        bt = w[:, None] * np.cross(N, t)
        a = t * x[:, None] + bt * y[:, None] + N * z[:, None]
        al = np.sqrt(_dot(a, a))
        res = a * (sgn[sel] / al)[:, None]
        c = _dot(res, g[sel])
        res = np.where((c < 0.0)[:, None], res - 2.0 * c[:, None] * g[sel], res)
        ok = (tl > 1e-12) & (tl < np.inf) & (al > 0.0) & (al < np.inf)
        out[np.flatnonzero(sel)[ok]] = res[ok]
    return out
