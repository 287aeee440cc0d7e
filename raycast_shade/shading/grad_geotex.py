"""The geometry's gradients on scenes with mesh colours and colour maps: how a point's coefficients
move with its barycentrics.

When a vertex or the camera moves, each pixel's hit slides on its (held) triangle: its barycentrics
``(b1, b2)`` change, and with them the interpolated vertex colour and the UV at which the maps are
sampled. The forward pass's point coefficients (:func:`~raycast_shade.shading.texture._coefficients`)
are::

    kd = base(b) * kd_map(uv(b))                 base: the row's kd, the face colour, or
    ka = ka_row * [base(b)] * ka_map(uv) * occ   sum_k b_k c_k of the vertex colours
    ks = ks_row * ks_map(uv),  ke = ke_row * ke_map(uv),  occ = 1 + s (ao_map(uv).r - 1)
    uv(b) = (1 - b1 - b2) uv_0 + b1 uv_1 + b2 uv_2

so for ``g = dL/d(ka, kd, ks, ke)`` of the point, :func:`coefficients_bary_vjp` gives
``dL/db_j = g . d(coefficients)/db_j`` by the product rule: ``d base/db_j = c_j - c_0`` (vertex
colours; 0 otherwise), ``d map/db_j = d map/du du/db_j + d map/dv dv/db_j``, ``du/db_j = u_j - u_0``.
A bilinear sample at texel coordinates ``x = u w tu - 1/2`` (likewise ``y``) with fractions
``tx, ty`` has ``d/dx = (1 - ty)(a01 - a00) + ty (a11 - a10)``, ``d/dy = (1 - tx)(a10 - a00) +
tx (a11 - a01)`` (a clamped border: the two texels are one, 0). A mip-mapped map's level of detail
(the pixel's footprint, a ray differential, or a flat face's UV area) is **held**: the two levels'
derivatives are blended with the forward pass's weights, the weights themselves not moved.

Kinks: bilinear filtering is C0 across a texel cell's edge (``x`` or ``y`` an integer, i.e. the
sample point on a line through texel centres): there the derivative jumps, and the gradient is the
one-sided derivative of the cell the point is in. A clamped map's border (``x < 0`` or
``x > w - 1``) is another such edge.

:func:`tex_pixels_scatter` then takes each pixel's ``dL/db`` (with Phong's point and view terms)
through :func:`~raycast_shade.shading.grad_geometry.pixel_hit_vjp`, the hit's closed-form derivative,
serially in row-major order (deterministic on any number of threads).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..common.layout import (CAM_EYE, COLOR_FACE, COLOR_NONE, COLOR_VERTEX, MAT_AO_STRENGTH, MAT_KA, MAT_KA_COLORS, MAT_KD,
                             MAT_KE, MAT_KS,
                             METHOD_GOURAUD, METHOD_PHONG, TEX_LEVELS, TEX_MIPMAP,
                             TEX_TILE_U, TEX_TILE_V, TEXMAP_AO, TEXMAP_KA, TEXMAP_KD,
                             TEXMAP_KE, TEXMAP_KS)
from .bump import _texel_corners
from .grad_geometry import _add_cam, _view_vjp, pixel_hit_vjp
from .grad_walk import triangle_points
from .jit import HELPER, JIT
from .surface import _hit_point, _triangle
from .texture import _level_rho, _level_texel, _sample, _uv_derivatives

__all__ = ["coefficients_bary_vjp", "pixel_footprint", "tex_pixels_scatter"]


@njit(**HELPER)
def _bilinear_dxy(tex, base, w, h, clamp, x, y):
    """``d rgb/dx`` and ``d rgb/dy`` (two 3-tuples) of the bilinear sample at texel coordinates
    ``(x, y)`` of a (h, w, 3) level stored from ``base``: the derivative inside the cell the point
    is in (see the module docstring)."""
    i0, i1, j0, j1, tx, ty = _texel_corners(h, w, clamp, x, y)
    a00 = base + 3 * (i0 * w + j0)
    a01 = base + 3 * (i0 * w + j1)
    a10 = base + 3 * (i1 * w + j0)
    a11 = base + 3 * (i1 * w + j1)
    dx = ((1.0 - ty) * (tex[a01] - tex[a00]) + ty * (tex[a11] - tex[a10]),
          (1.0 - ty) * (tex[a01 + 1] - tex[a00 + 1]) + ty * (tex[a11 + 1] - tex[a10 + 1]),
          (1.0 - ty) * (tex[a01 + 2] - tex[a00 + 2]) + ty * (tex[a11 + 2] - tex[a10 + 2]))
    dy = ((1.0 - tx) * (tex[a10] - tex[a00]) + tx * (tex[a11] - tex[a01]),
          (1.0 - tx) * (tex[a10 + 1] - tex[a00 + 1]) + tx * (tex[a11 + 1] - tex[a01 + 1]),
          (1.0 - tx) * (tex[a10 + 2] - tex[a00 + 2]) + tx * (tex[a11 + 2] - tex[a01 + 2]))
    return dx, dy


@njit(**HELPER)
def _level_duv(tex, info, k, u, v, lvl):
    """``d rgb/du``, ``d rgb/dv`` of level ``lvl`` of texture ``k`` at (u, v), as
    :func:`~raycast_shade.shading.texture._sample_level` samples it."""
    base, w, h, clamp, x, y = _level_texel(info, k, u, v, lvl)  # the forward's texel coordinates
    dx, dy = _bilinear_dxy(tex, base, w, h, clamp, x, y)
    sx = info[k, TEX_TILE_U] * w
    sy = info[k, TEX_TILE_V] * h
    return (sx * dx[0], sx * dx[1], sx * dx[2]), (sy * dy[0], sy * dy[1], sy * dy[2])


@njit(**HELPER)
def _sample_duv(tex, info, k, u, v, fp):
    """``d rgb/du``, ``d rgb/dv`` of :func:`~raycast_shade.shading.texture._sample` at (u, v) with
    the footprint ``fp`` (its level of detail) held."""
    rho = _level_rho(info, k, fp[0], fp[1], fp[2], fp[3])
    if info[k, TEX_MIPMAP] == 0.0 or not rho > 1.0:
        return _level_duv(tex, info, k, u, v, 0)
    top = int(info[k, TEX_LEVELS]) - 1
    lod = min(math.log2(rho), float(top))
    l0 = int(math.floor(lod))
    frac = lod - l0
    du0, dv0 = _level_duv(tex, info, k, u, v, l0)
    if frac == 0.0 or l0 >= top:
        return du0, dv0
    du1, dv1 = _level_duv(tex, info, k, u, v, l0 + 1)
    return ((du0[0] + frac * (du1[0] - du0[0]), du0[1] + frac * (du1[1] - du0[1]), du0[2] + frac * (du1[2] - du0[2])),
            (dv0[0] + frac * (dv1[0] - dv0[0]), dv0[1] + frac * (dv1[1] - dv0[1]), dv0[2] + frac * (dv1[2] - dv0[2])))


@njit(**HELPER)
def _map_at(T, k, u, v, fp, duv):
    """Map ``k``'s sample at (u, v) and its derivatives along ``b1`` and ``b2`` (``duv`` =
    ``(du/db1, du/db2, dv/db1, dv/db2)``): three 3-tuples; a missing map (``k < 0``) is 1, still."""
    if k < 0:
        return (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    texels, tinfo = T[4], T[5]
    s = _sample(texels, tinfo, k, u, v, fp[0], fp[1], fp[2], fp[3])
    du, dv = _sample_duv(texels, tinfo, k, u, v, fp)
    return (s, (du[0] * duv[0] + dv[0] * duv[2], du[1] * duv[0] + dv[1] * duv[2], du[2] * duv[0] + dv[2] * duv[2]),
            (du[0] * duv[1] + dv[0] * duv[3], du[1] * duv[1] + dv[1] * duv[3], du[2] * duv[1] + dv[2] * duv[3]))


@njit(**HELPER)
def coefficients_bary_vjp(mats, T, at, tri, uvs, fp, gcoef):
    """``(dL/db1, dL/db2)`` through the point coefficients of hit ``at`` on triangle ``tri``
    (:func:`~raycast_shade.shading.texture._coefficients`' with the footprint ``fp`` held), given
    ``gcoef = dL/d(ka, kd, ks, ke)`` of the point (twelve floats)."""
    vcolors, _, cmode, tindex, _, _, _ = T
    f, gm, b1, b2 = at
    i0, i1, i2 = tri
    b0 = 1.0 - b1 - b2
    base = (mats[gm, MAT_KD + 0], mats[gm, MAT_KD + 1], mats[gm, MAT_KD + 2])
    dbase1 = (0.0, 0.0, 0.0)
    dbase2 = (0.0, 0.0, 0.0)
    mode = cmode[gm]
    if mode == COLOR_VERTEX:
        base = (b0 * vcolors[i0, 0] + b1 * vcolors[i1, 0] + b2 * vcolors[i2, 0],
                b0 * vcolors[i0, 1] + b1 * vcolors[i1, 1] + b2 * vcolors[i2, 1],
                b0 * vcolors[i0, 2] + b1 * vcolors[i1, 2] + b2 * vcolors[i2, 2])
        dbase1 = (vcolors[i1, 0] - vcolors[i0, 0], vcolors[i1, 1] - vcolors[i0, 1], vcolors[i1, 2] - vcolors[i0, 2])
        dbase2 = (vcolors[i2, 0] - vcolors[i0, 0], vcolors[i2, 1] - vcolors[i0, 1], vcolors[i2, 2] - vcolors[i0, 2])
    elif mode == COLOR_FACE:  # constant on the face
        base = (T[1][f, 0], T[1][f, 1], T[1][f, 2])
    ka_col = mode != COLOR_NONE and mats[gm, MAT_KA_COLORS] != 0.0
    mapped = (tindex[gm, TEXMAP_KA] >= 0 or tindex[gm, TEXMAP_KD] >= 0 or tindex[gm, TEXMAP_KS] >= 0
              or tindex[gm, TEXMAP_KE] >= 0 or tindex[gm, TEXMAP_AO] >= 0)
    u = v = 0.0
    duv = (0.0, 0.0, 0.0, 0.0)
    if mapped:
        u = b0 * uvs[i0, 0] + b1 * uvs[i1, 0] + b2 * uvs[i2, 0]
        v = b0 * uvs[i0, 1] + b1 * uvs[i1, 1] + b2 * uvs[i2, 1]
        duv = (uvs[i1, 0] - uvs[i0, 0], uvs[i2, 0] - uvs[i0, 0], uvs[i1, 1] - uvs[i0, 1], uvs[i2, 1] - uvs[i0, 1])
    ska, dka1, dka2 = _map_at(T, tindex[gm, TEXMAP_KA] if mapped else -1, u, v, fp, duv)
    skd, dkd1, dkd2 = _map_at(T, tindex[gm, TEXMAP_KD] if mapped else -1, u, v, fp, duv)
    sks, dks1, dks2 = _map_at(T, tindex[gm, TEXMAP_KS] if mapped else -1, u, v, fp, duv)
    ske, dke1, dke2 = _map_at(T, tindex[gm, TEXMAP_KE] if mapped else -1, u, v, fp, duv)
    sao, dao1, dao2 = _map_at(T, tindex[gm, TEXMAP_AO] if mapped else -1, u, v, fp, duv)
    st = mats[gm, MAT_AO_STRENGTH] if mapped and tindex[gm, TEXMAP_AO] >= 0 else 0.0
    occ = 1.0 + st * (sao[0] - 1.0)
    g1 = 0.0
    g2 = 0.0
    for c in range(3):
        kd1 = dbase1[c] * skd[c] + base[c] * dkd1[c]
        kd2 = dbase2[c] * skd[c] + base[c] * dkd2[c]
        col, dcol1, dcol2 = 1.0, 0.0, 0.0
        if ka_col:
            col, dcol1, dcol2 = base[c], dbase1[c], dbase2[c]
        ka = mats[gm, MAT_KA + c]
        ka1 = ka * (dcol1 * ska[c] * occ + col * dka1[c] * occ + col * ska[c] * st * dao1[0])
        ka2 = ka * (dcol2 * ska[c] * occ + col * dka2[c] * occ + col * ska[c] * st * dao2[0])
        g1 += (gcoef[c] * ka1 + gcoef[3 + c] * kd1 + gcoef[6 + c] * mats[gm, MAT_KS + c] * dks1[c]
               + gcoef[9 + c] * mats[gm, MAT_KE + c] * dke1[c])
        g2 += (gcoef[c] * ka2 + gcoef[3 + c] * kd2 + gcoef[6 + c] * mats[gm, MAT_KS + c] * dks2[c]
               + gcoef[9 + c] * mats[gm, MAT_KE + c] * dke2[c])
    return g1, g2


@njit(**HELPER)
def pixel_footprint(G, uvs, at, cam, x, y):
    """Pixel (x, y)'s footprint ``(du/dx, dv/dx, du/dy, dv/dy)`` at hit ``at``, as
    :func:`~raycast_shade.shading.texture._point_coefficients` computes it for a camera ray."""
    verts, _, faces, fnormals = G
    f, _, b1, b2 = at
    tri = (faces[f, 0], faces[f, 1], faces[f, 2])
    i0, i1, i2 = tri
    b0 = 1.0 - b1 - b2
    p = (b0 * verts[i0, 0] + b1 * verts[i1, 0] + b2 * verts[i2, 0],
         b0 * verts[i0, 1] + b1 * verts[i1, 1] + b2 * verts[i2, 1],
         b0 * verts[i0, 2] + b1 * verts[i1, 2] + b2 * verts[i2, 2])
    return _uv_derivatives(verts, uvs, fnormals, tri, f, cam, p, (cam[CAM_EYE + 0], cam[CAM_EYE + 1],
                                                                    cam[CAM_EYE + 2]), x, y)


@njit(**JIT)
def tex_pixels_scatter(hits, G, face_off, cam, modes, gpx, gbc, gverts, gcam):
    """Serially, in row-major order, the Phong and Gouraud pixels of a textured frame: each hit
    moved with its triangle and ray. ``gpx`` (H, W, 9): a Phong pixel's ``dL/da`` of its
    interpolated normal, ``dL/dp``, ``dL/dv``; ``gbc`` (H, W, 2): its ``dL/d(b1, b2)`` from the
    coefficients (Gouraud: from the corners' shades and the coefficients)."""
    prim, geom, u, v = hits
    verts, normals, faces, _ = G
    h, w = prim.shape
    for y in range(h):
        for x in range(w):
            pr = prim[y, x]
            if pr < 0:
                continue
            gm = geom[y, x]
            if modes[gm] != METHOD_PHONG and modes[gm] != METHOD_GOURAUD:
                continue
            tri = _triangle(faces, face_off[gm] + pr)
            i0, i1, i2 = tri
            P0, P1, P2 = triangle_points(verts, tri)
            b1 = np.float64(u[y, x])
            b2 = np.float64(v[y, x])
            gb1 = gbc[y, x, 0]
            gb2 = gbc[y, x, 1]
            gp = (0.0, 0.0, 0.0)
            if modes[gm] == METHOD_PHONG:
                gpv, geye, gw = _view_vjp(cam, _hit_point(verts, tri, b1, b2), (gpx[y, x, 6], gpx[y, x, 7],
                                                                                 gpx[y, x, 8]))
                _add_cam(gcam, geye, gw)
                gp = (gpx[y, x, 3] + gpv[0], gpx[y, x, 4] + gpv[1], gpx[y, x, 5] + gpv[2])
                for c in range(3):  # a = sum b_k n_k
                    gb1 += gpx[y, x, c] * (normals[i1, c] - normals[i0, c])
                    gb2 += gpx[y, x, c] * (normals[i2, c] - normals[i0, c])
            if gb1 == 0.0 and gb2 == 0.0 and gp[0] == 0.0 and gp[1] == 0.0 and gp[2] == 0.0:
                continue
            pixel_hit_vjp(cam, x, y, P0, P1, P2, b1, b2, gp, gb1, gb2, gverts, tri, gcam)
