"""One point's inputs for :mod:`raycast_shade.insight.explain`: coefficients (mesh colours, colour
maps), a spot light's cone factor, and the bump-mapped normal.

Each helper follows the kernel it names (:mod:`raycast_shade.shading.texture`,
:mod:`raycast_shade.shading.illumination`) for one point, in float64 Python:
the same texel corners (huge coordinates reduced the same way), the same
footprint from the camera ray's differential, the same trilinear level.
"""

from __future__ import annotations

import math

import numpy as np

from ..common.layout import (BUMP_CLAMP, BUMP_COLS, BUMP_OFFSET, BUMP_ROWS, BUMP_SCALE, BUMP_TILE_U, BUMP_TILE_V,
                             CAM_FORWARD, CAM_HEIGHT, CAM_RIGHT, CAM_UP, CAM_WIDTH, COLOR_FACE, COLOR_VERTEX, MAT_KA,
                             MAT_KA_COLORS, MAT_KD, MAT_KE, MAT_KS)
from ..study.reference import footprint_rho as _rho

__all__ = []


def _short(x):
    return "(" + ", ".join(f"{c:.4g}" for c in x) + ")"


def _spot_factor(light, s) -> float:
    """Warn's factor of a spot light for the unit direction ``s`` towards it
    (:func:`raycast_shade.shading.illumination._spot_factor`): 0 outside the outer cone."""
    c = -float(s @ np.asarray(light.direction, np.float64))
    co, ci = light.cos_outer, light.cos_inner
    if not c > co:
        return 0.0
    c = min(c, 1.0)
    f = c ** float(light.exponent)
    if c < ci:
        t = (c - co) / (ci - co)
        f *= t * t * (3.0 - 2.0 * t)
    return f


_WHOLE = 2.0 ** 52  # from here on a float64 is a whole number (and int() of it may overflow the kernels' int64)


def _texel_corner(x, n, clamp):
    """Texel coordinate ``x`` (centres at integers) of a row of ``n`` texels: the two
    texel indices around it and the weight of the second (the kernels' ``_texel_corners``)."""
    if not abs(x) < _WHOLE:  # huge or infinite: the border (clamp), or a whole number of periods (repeat)
        x = (-1.0 if x < 0.0 else float(n)) if clamp else (math.fmod(x, n) if math.isfinite(x) else 0.0)
    j0 = math.floor(x)
    t = x - j0
    j1 = j0 + 1
    if clamp:
        return min(max(j0, 0), n - 1), min(max(j1, 0), n - 1), t
    return j0 % n, j1 % n, t


def _sample_level(tex, level, u, v):
    """Bilinear (3,) float64 of one pyramid level at (u, v) (:func:`raycast_shade.shading.texture._sample_level`)."""
    img = tex.pyramid[level]
    h, w = img.shape[:2]
    clamp = tex.wrap == "clamp"
    su, sv = u * tex.tiling[0], v * tex.tiling[1]
    if not clamp:  # repeat's period is 1: past 2**52 (or overflowed) u * tiling is a whole number of them
        su = su if abs(su) < _WHOLE else 0.0
        sv = sv if abs(sv) < _WHOLE else 0.0
    j0, j1, tx = _texel_corner(su * w - 0.5, w, clamp)
    i0, i1, ty = _texel_corner(sv * h - 0.5, h, clamp)
    t = lambda i, j: img[i, j].astype(np.float64)  # noqa: E731
    return (t(i0, j0) * ((1.0 - tx) * (1.0 - ty)) + t(i0, j1) * (tx * (1.0 - ty)) + t(i1, j0) * ((1.0 - tx) * ty)
            + t(i1, j1) * (tx * ty))


def _sample(tex, u, v, duv):
    """(3,) float64: the texture at (u, v), trilinear at level ``log2 rho`` for a
    mip-mapped texture whose footprint ``duv`` (2, 2) covers more than a texel."""
    rho = float(_rho(tex, duv[None])[0]) if duv is not None else 0.0
    if tex.filter != "mipmap" or not rho > 1.0:
        return _sample_level(tex, 0, u, v)
    top = len(tex.pyramid) - 1
    lod = min(math.log2(rho), float(top))
    l0 = int(math.floor(lod))
    frac = lod - l0
    a = _sample_level(tex, l0, u, v)
    if frac == 0.0 or l0 >= top:
        return a
    return a + frac * (_sample_level(tex, l0 + 1, u, v) - a)


def _footprint(ctx, f, p, x, y):
    """(2, 2) ``d(u, v)/dx`` and ``d(u, v)/dy`` of pixel (x, y) at point ``p`` of face ``f``:
    the camera ray's differential on the face's plane (:func:`raycast_shade.shading.texture._uv_derivatives`)."""
    geo, cam = ctx.geo, ctx.cam
    w, h = cam[CAM_WIDTH], cam[CAM_HEIGHT]
    right, up, fwd = cam[CAM_RIGHT:CAM_RIGHT + 3], cam[CAM_UP:CAM_UP + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    n = geo.face_normals[f]
    if ctx.ortho:
        d, t = fwd, 1.0
    else:
        d = fwd + (2.0 * (x + 0.5) / w - 1.0) * right + (1.0 - 2.0 * (y + 0.5) / h) * up
    dn = float(d @ n)
    if not ctx.ortho:
        t = float((p - ctx.eye) @ n) / dn if dn != 0.0 else math.inf
    if dn == 0.0 or not math.isfinite(t):
        return np.full((2, 2), np.inf)
    tri = geo.faces[f]
    e1, e2 = geo.vertices[tri[1]] - geo.vertices[tri[0]], geo.vertices[tri[2]] - geo.vertices[tri[0]]
    m = np.cross(e1, e2)
    mm = float(m @ m)
    if not mm > 0.0:
        return np.zeros((2, 2))
    g1, g2 = np.cross(e2, m) / mm, np.cross(m, e1) / mm
    d1, d2 = geo.uvs[tri[1]] - geo.uvs[tri[0]], geo.uvs[tri[2]] - geo.uvs[tri[0]]
    out = np.empty((2, 2))
    for k, step in enumerate((2.0 * right / w, -2.0 * up / h)):
        a = t * step
        dp = a - d * (float(a @ n) / dn)
        out[k] = d1 * float(g1 @ dp) + d2 * float(g2 @ dp)
    return out


def _face_footprint(geo, f):
    """Flat's footprint: the side of the UV square as large as the face's UV triangle."""
    t = geo.uvs[geo.faces[f]]
    d1, d2 = t[1] - t[0], t[2] - t[0]
    side = math.sqrt(0.5 * abs(d1[0] * d2[1] - d1[1] * d2[0]))
    return np.array([[side, 0.0], [0.0, side]])


def _coefficients(ctx, f, model, bary, duv, vertex=None):
    """``(ka, kd, ks, ke, note)`` at the point of face ``f`` with barycentrics ``bary`` (3,):
    the material row's, kd the mesh's colour, each times its map's texel filtered by
    ``duv`` (None: level 0). ``vertex``: a Gouraud vertex, whose coefficients are the
    row's with kd its colour (maps and face colours are the pixel's: modulate)."""
    geo = ctx.geo
    row = geo.materials[model]
    ka, kd, ks = row[MAT_KA:MAT_KA + 3].copy(), row[MAT_KD:MAT_KD + 3].copy(), row[MAT_KS:MAT_KS + 3].copy()
    ke = row[MAT_KE:MAT_KE + 3].copy()
    notes = []
    mode = geo.color_mode[model] if geo.textured else -1
    follow = row[MAT_KA_COLORS] != 0.0
    if vertex is not None:
        if mode == COLOR_VERTEX:
            kd, notes = geo.vertex_colors[vertex].copy(), [f"kd = the vertex's colour"]
            if follow:
                ka = ka * kd
                notes.append("ka x the vertex's colour (ka_colors)")
        return ka, kd, ks, ke, "; ".join(notes)
    tri = geo.faces[f]
    if mode == COLOR_VERTEX:
        kd = bary @ geo.vertex_colors[tri]
        notes.append(f"kd = sum mu_k (vertex colour)_k = {_short(kd)}")
    elif mode == COLOR_FACE:
        kd = geo.face_colors[f].copy()
        notes.append("kd = the face's colour")
    if follow and mode in (COLOR_VERTEX, COLOR_FACE):
        ka = ka * kd
        notes.append("ka x that colour (ka_colors)")
    mat = ctx.scene.models[model].material
    maps = mat.maps if geo.textured else (None,) * 5
    if any(m is not None for m in maps):
        u, v = bary @ geo.uvs[tri]
        for name, target, tex in zip(("ka", "kd", "Ks", "ke"), (ka, kd, ks, ke), maps):
            if tex is not None:
                texel = _sample(tex, u, v, duv)
                target *= texel
                notes.append(f"{name} x {name}_map{'' if duv is not None else ' (level 0)'} "
                             f"at uv ({u:.4g}, {v:.4g}) = {_short(texel)}")
        if maps[4] is not None:
            ao = float(_sample(maps[4], u, v, duv)[0])
            occ = 1.0 + mat.ao_strength * (ao - 1.0)
            ka *= occ
            notes.append(f"ka x occlusion 1 + s (ao - 1) = 1 + {mat.ao_strength:.4g} x ({ao:.4g} - 1) = {occ:.4g}")
    return ka, kd, ks, ke, "; ".join(notes)


def _modulated(ctx, model) -> bool:
    """Whether Gouraud shades ``model`` the modulate way (a map or face colours)."""
    geo = ctx.geo
    return bool(geo.textured and ((geo.tex_index[model] >= 0).any() or geo.color_mode[model] == COLOR_FACE))


def _bilinear(tex, base, rows, cols, clamp, x, y):
    j0, j1, tx = _texel_corner(x, cols, clamp)
    i0, i1, ty = _texel_corner(y, rows, clamp)
    t = lambda i, j: float(tex[base + i * cols + j])  # noqa: E731
    a = t(i0, j0) * (1.0 - tx) + t(i0, j1) * tx
    b = t(i1, j0) * (1.0 - tx) + t(i1, j1) * tx
    return a * (1.0 - ty) + b * ty


def _bumped(geo, n, f, model, tri, bary, front):
    """Blinn's perturbed normal, as :mod:`raycast_shade.shading.bump` computes it; ``n`` without a bump map."""
    k = geo.bump_index[model]
    if k < 0:
        return n
    tu, tv = bary @ geo.uvs[tri]
    info = geo.bump_info[k]
    base, rows, cols = int(info[BUMP_OFFSET]), int(info[BUMP_ROWS]), int(info[BUMP_COLS])
    clamp, su, sv, scale = info[BUMP_CLAMP] != 0.0, info[BUMP_TILE_U], info[BUMP_TILE_V], info[BUMP_SCALE]
    x, y = tu * su * cols - 0.5, tv * sv * rows - 0.5
    tex = geo.bump_texels
    bu = (_bilinear(tex, base, rows, cols, clamp, x + 0.5, y)
          - _bilinear(tex, base, rows, cols, clamp, x - 0.5, y)) * cols * su * scale
    bv = (_bilinear(tex, base, rows, cols, clamp, x, y + 0.5)
          - _bilinear(tex, base, rows, cols, clamp, x, y - 0.5)) * rows * sv * scale
    pu, pv = geo.tangents[f, 0:3], geo.tangents[f, 3:6]
    c = np.cross(pu, pv)
    if c @ front < 0.0:  # left-handed UVs
        bu, bv = -bu, -bv
    a = np.sqrt(c @ c) * n + bu * np.cross(n, pv) - bv * np.cross(n, pu)
    al = float(np.sqrt(a @ a))
    if not (0.0 < al < np.inf):
        return n
    return a / al


def _terminator(geo, tri, bary, p, sgn):
    """Hanika's shadow-ray origin (:func:`raycast_shade.shading.surface._terminator_point`)."""
    q = p.copy()
    for k in range(3):
        nk = sgn * geo.normals[tri[k]]
        d = float((p - geo.vertices[tri[k]]) @ nk)
        if d < 0.0:
            q -= bary[k] * d * nk
    return q


def _convex_weights(b1, b2):
    """Gouraud's weights clamped onto the triangle (:func:`raycast_shade.shading.surface._convex_weights`)."""
    if not (b1 >= 0.0 and b2 >= 0.0 and b1 + b2 <= 1.0):
        b1, b2 = min(max(b1, 0.0), 1.0), min(max(b2, 0.0), 1.0)
        s = b1 + b2
        if s > 1.0:
            b1, b2 = b1 / s, b2 / s
    return np.array([max(1.0 - b1 - b2, 0.0), b1, b2])
