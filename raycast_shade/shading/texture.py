"""Per-point coefficients: colour textures and mesh colours, sampled where shading happens.

A point's ``ka, kd, ks`` are the material row's, with the mesh's colour (per
vertex, interpolated, or per face) in place of kd (and scaling ka where the
material's ``ka_colors`` says so), each times its map's texel when the
material has one; likewise the emission ``ke``. An occlusion map's red
channel ``ao`` scales ka by ``1 + s (ao - 1)``, ``s`` the material's strength. Maps are sampled bilinearly at the point's UV and,
for ``filter="mipmap"``, trilinearly between two levels of the pyramid
(:class:`raycast_shade.Texture`): level ``log2(rho)`` with ``rho`` the larger
of the pixel's two footprint axes in texels,

    rho = max(|d(s, t)/dx|, |d(s, t)/dy|),    (s, t) = (u w tu, v h tv)

(the OpenGL rule). ``d(u, v)/dx`` comes from the camera ray's differential
(Igehy 1999): the ray through the next pixel over differs by ``dD = 2 R / W``
(``-2 U / H`` downwards) in direction, or by that much in origin for an
orthographic camera; intersected with the triangle's plane that moves the
hit by ``dP``, and the triangle's barycentric gradients turn ``dP`` into
``du, dv``. A plane at distance ``d`` facing a perspective camera therefore
gets ``rho = texels per world unit * 2 d tan(fov / 2) / H`` exactly. Mirror
bounces have no ray differential and sample level 0.

Texels are packed as in :meth:`raycast_shade.Texture.packed_info`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import in_parts, share
from ..common.layout import (CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_UP, CAM_WIDTH, COLOR_FACE,
                             COLOR_NONE, COLOR_VERTEX, MAT_AO_STRENGTH, MAT_KA, MAT_KA_COLORS, MAT_KD, MAT_KE, MAT_KS, TEX_CLAMP, TEX_HEIGHT, TEX_LEVELS, TEX_MIPMAP,
                             TEX_OFFSET, TEX_TILE_U, TEX_TILE_V, TEX_WIDTH, TEXMAP_AO, TEXMAP_KA, TEXMAP_KD,
                             TEXMAP_KE, TEXMAP_KS)
from .bump import _texel_corners
from .jit import HELPER, JIT

__all__ = ["texture_levels"]


@inline_jit(**HELPER)
def _bilinear3(tex, base, w, h, clamp, x, y):
    """Bilinear RGB at texel coordinates (x, y) (centres at integers) of a
    (h, w, 3) level stored from ``base``."""
    i0, i1, j0, j1, tx, ty = _texel_corners(h, w, clamp, x, y)
    a00 = base + 3 * (i0 * w + j0)
    a01 = base + 3 * (i0 * w + j1)
    a10 = base + 3 * (i1 * w + j0)
    a11 = base + 3 * (i1 * w + j1)
    w00 = (1.0 - tx) * (1.0 - ty)
    w01 = tx * (1.0 - ty)
    w10 = (1.0 - tx) * ty
    w11 = tx * ty
    r = w00 * tex[a00] + w01 * tex[a01] + w10 * tex[a10] + w11 * tex[a11]
    g = w00 * tex[a00 + 1] + w01 * tex[a01 + 1] + w10 * tex[a10 + 1] + w11 * tex[a11 + 1]
    b = w00 * tex[a00 + 2] + w01 * tex[a01 + 2] + w10 * tex[a10 + 2] + w11 * tex[a11 + 2]
    return r, g, b


@inline_jit(**HELPER)
def _level_rho(info, k, dudx, dvdx, dudy, dvdy):
    """The footprint ``rho`` in level-0 texels of texture ``k`` (see the module docstring)."""
    su = info[k, TEX_WIDTH] * info[k, TEX_TILE_U]
    sv = info[k, TEX_HEIGHT] * info[k, TEX_TILE_V]
    ax = dudx * su
    ay = dvdx * sv
    bx = dudy * su
    by = dvdy * sv
    return max(np.sqrt(ax * ax + ay * ay), np.sqrt(bx * bx + by * by))


@inline_jit(**HELPER)
def _level_texel(info, k, u, v, lvl):
    """Where (u, v) falls on level ``lvl`` of texture ``k``: ``(base, w, h, clamp, x, y)``, the
    level's first texel in ``texels``, its size, its wrap, and the texel coordinates (centres at
    integers) :func:`_sample_level` filters at and the gradients differentiate at."""
    w = int(info[k, TEX_WIDTH])
    h = int(info[k, TEX_HEIGHT])
    base = int(info[k, TEX_OFFSET])
    for _ in range(lvl):
        base += 3 * w * h
        w = max(1, w >> 1)
        h = max(1, h >> 1)
    clamp = info[k, TEX_CLAMP] != 0.0
    su = u * info[k, TEX_TILE_U]
    sv = v * info[k, TEX_TILE_V]
    if not clamp:  # repeat's period is 1: past 2**52 (or overflowed) u * tiling is a whole number of periods
        if not abs(su) < 4503599627370496.0:
            su = 0.0
        if not abs(sv) < 4503599627370496.0:
            sv = 0.0
    return base, w, h, clamp, su * w - 0.5, sv * h - 0.5


@inline_jit(**HELPER)
def _sample_level(tex, info, k, u, v, lvl):
    """Bilinear RGB of level ``lvl`` of texture ``k`` at (u, v)."""
    base, w, h, clamp, x, y = _level_texel(info, k, u, v, lvl)
    return _bilinear3(tex, base, w, h, clamp, x, y)


@inline_jit(**HELPER)
def _sample(tex, info, k, u, v, dudx, dvdx, dudy, dvdy):
    """Texture ``k`` at (u, v): bilinear at level 0 when magnified (or not
    mip-mapped), else trilinear at level ``log2(rho)``."""
    rho = _level_rho(info, k, dudx, dvdx, dudy, dvdy)
    if info[k, TEX_MIPMAP] == 0.0 or not rho > 1.0:
        return _sample_level(tex, info, k, u, v, 0)
    top = int(info[k, TEX_LEVELS]) - 1
    lod = min(math.log2(rho), float(top))  # rho = inf (grazing): the 1 x 1 average
    l0 = int(math.floor(lod))
    frac = lod - l0
    r0, g0, b0 = _sample_level(tex, info, k, u, v, l0)
    if frac == 0.0 or l0 >= top:
        return r0, g0, b0
    r1, g1, b1 = _sample_level(tex, info, k, u, v, l0 + 1)
    return r0 + frac * (r1 - r0), g0 + frac * (g1 - g0), b0 + frac * (b1 - b0)


@inline_jit(**HELPER)
def _uv_derivatives(verts, uvs, fnormals, tri, f, cam, p, eye, x, y):
    """``du/dx, dv/dx, du/dy, dv/dy`` per pixel at hit ``p`` of face ``f`` (triangle
    ``tri = (i0, i1, i2)``) seen from ``eye`` through pixel (x, y) (see the module
    docstring); inf at grazing incidence, zero for a face with a degenerate 3D shape."""
    i0, i1, i2 = tri
    px, py, pz = p
    ex, ey, ez = eye
    w = cam[CAM_WIDTH]
    h = cam[CAM_HEIGHT]
    sx = 2.0 * (x + 0.5) / w - 1.0
    sy = 1.0 - 2.0 * (y + 0.5) / h
    dxx = 2.0 * cam[CAM_RIGHT + 0] / w
    dxy = 2.0 * cam[CAM_RIGHT + 1] / w
    dxz = 2.0 * cam[CAM_RIGHT + 2] / w
    dyx = -2.0 * cam[CAM_UP + 0] / h
    dyy = -2.0 * cam[CAM_UP + 1] / h
    dyz = -2.0 * cam[CAM_UP + 2] / h
    nx = fnormals[f, 0]
    ny = fnormals[f, 1]
    nz = fnormals[f, 2]
    if cam[CAM_ORTHO] != 0.0:
        ddx = cam[CAM_FORWARD + 0]
        ddy = cam[CAM_FORWARD + 1]
        ddz = cam[CAM_FORWARD + 2]
        t = 1.0  # the origin moves, not the direction
    else:
        ddx = cam[CAM_FORWARD + 0] + sx * cam[CAM_RIGHT + 0] + sy * cam[CAM_UP + 0]
        ddy = cam[CAM_FORWARD + 1] + sx * cam[CAM_RIGHT + 1] + sy * cam[CAM_UP + 1]
        ddz = cam[CAM_FORWARD + 2] + sx * cam[CAM_RIGHT + 2] + sy * cam[CAM_UP + 2]
    dn = ddx * nx + ddy * ny + ddz * nz
    if cam[CAM_ORTHO] == 0.0:
        t = ((px - ex) * nx + (py - ey) * ny + (pz - ez) * nz) / dn if dn != 0.0 else np.inf
    if dn == 0.0 or not np.isfinite(t):
        return np.inf, np.inf, np.inf, np.inf
    # dP = a - D (a.n) / (D.n), a = t dD (perspective) or dO (orthographic)
    ax = t * dxx
    ay = t * dxy
    az = t * dxz
    c = (ax * nx + ay * ny + az * nz) / dn
    pxx = ax - c * ddx
    pxy = ay - c * ddy
    pxz = az - c * ddz
    ax = t * dyx
    ay = t * dyy
    az = t * dyz
    c = (ax * nx + ay * ny + az * nz) / dn
    pyx = ax - c * ddx
    pyy = ay - c * ddy
    pyz = az - c * ddz
    # Barycentric gradients: grad b1 = (e2 x m) / |m|^2, grad b2 = (m x e1) / |m|^2, m = e1 x e2.
    e1x = verts[i1, 0] - verts[i0, 0]
    e1y = verts[i1, 1] - verts[i0, 1]
    e1z = verts[i1, 2] - verts[i0, 2]
    e2x = verts[i2, 0] - verts[i0, 0]
    e2y = verts[i2, 1] - verts[i0, 1]
    e2z = verts[i2, 2] - verts[i0, 2]
    mx = e1y * e2z - e1z * e2y
    my = e1z * e2x - e1x * e2z
    mz = e1x * e2y - e1y * e2x
    mm = mx * mx + my * my + mz * mz
    if not mm > 0.0:
        return 0.0, 0.0, 0.0, 0.0
    g1x = (e2y * mz - e2z * my) / mm
    g1y = (e2z * mx - e2x * mz) / mm
    g1z = (e2x * my - e2y * mx) / mm
    g2x = (my * e1z - mz * e1y) / mm
    g2y = (mz * e1x - mx * e1z) / mm
    g2z = (mx * e1y - my * e1x) / mm
    d1u = uvs[i1, 0] - uvs[i0, 0]
    d1v = uvs[i1, 1] - uvs[i0, 1]
    d2u = uvs[i2, 0] - uvs[i0, 0]
    d2v = uvs[i2, 1] - uvs[i0, 1]
    b1x = g1x * pxx + g1y * pxy + g1z * pxz
    b2x = g2x * pxx + g2y * pxy + g2z * pxz
    b1y = g1x * pyx + g1y * pyy + g1z * pyz
    b2y = g2x * pyx + g2y * pyy + g2z * pyz
    return d1u * b1x + d2u * b2x, d1v * b1x + d2v * b2x, d1u * b1y + d2u * b2y, d1v * b1y + d2v * b2y


@inline_jit(**HELPER)
def _face_footprint(uvs, tri):
    """A flat face's footprint: the side ``s`` of the UV square as large as the
    face's UV triangle ``tri = (i0, i1, i2)``, as ``(s, 0, 0, s)`` derivatives."""
    i0, i1, i2 = tri
    d1u = uvs[i1, 0] - uvs[i0, 0]
    d1v = uvs[i1, 1] - uvs[i0, 1]
    d2u = uvs[i2, 0] - uvs[i0, 0]
    d2v = uvs[i2, 1] - uvs[i0, 1]
    s = np.sqrt(0.5 * abs(d1u * d2v - d1v * d2u))
    return s, 0.0, 0.0, s


@inline_jit(**HELPER)
def _row_coefficients(mats, mi):
    """The material row's ``ka, kd, ks, ke``: the twelve scalars
    :func:`~raycast_shade.shading.illumination._illuminate` takes for a point
    without textures or colours."""
    return (mats[mi, MAT_KA + 0], mats[mi, MAT_KA + 1], mats[mi, MAT_KA + 2],
            mats[mi, MAT_KD + 0], mats[mi, MAT_KD + 1], mats[mi, MAT_KD + 2],
            mats[mi, MAT_KS + 0], mats[mi, MAT_KS + 1], mats[mi, MAT_KS + 2],
            mats[mi, MAT_KE + 0], mats[mi, MAT_KE + 1], mats[mi, MAT_KE + 2])


@inline_jit(**HELPER)
def _coefficients(mats, T, at, tri, uvs, footprint):
    """``ka, kd, ks, ke`` (twelve floats) at hit ``at`` (:class:`~raycast_shade.shading.records.At`:
    barycentrics (1 - b1 - b2, b1, b2) on face f, triangle ``tri``, of model gm): the material
    row's, kd replaced by the mesh's colour (ka scaled by it with the row's ka-colours flag), each times its map's texel filtered over
    ``footprint = (du/dx, dv/dx, du/dy, dv/dy)``. ``T`` as in
    :class:`~raycast_shade.shading.inputs.FrameInputs`."""
    vcolors, fcolors, cmode, tindex, texels, tinfo, _ = T
    f, gm, b1, b2 = at
    i0, i1, i2 = tri
    dudx, dvdx, dudy, dvdy = footprint
    kar = mats[gm, MAT_KA + 0]
    kag = mats[gm, MAT_KA + 1]
    kab = mats[gm, MAT_KA + 2]
    kdr = mats[gm, MAT_KD + 0]
    kdg = mats[gm, MAT_KD + 1]
    kdb = mats[gm, MAT_KD + 2]
    ksr = mats[gm, MAT_KS + 0]
    ksg = mats[gm, MAT_KS + 1]
    ksb = mats[gm, MAT_KS + 2]
    ker = mats[gm, MAT_KE + 0]
    keg = mats[gm, MAT_KE + 1]
    keb = mats[gm, MAT_KE + 2]
    b0 = 1.0 - b1 - b2
    mode = cmode[gm]
    if mode == COLOR_VERTEX:
        kdr = b0 * vcolors[i0, 0] + b1 * vcolors[i1, 0] + b2 * vcolors[i2, 0]
        kdg = b0 * vcolors[i0, 1] + b1 * vcolors[i1, 1] + b2 * vcolors[i2, 1]
        kdb = b0 * vcolors[i0, 2] + b1 * vcolors[i1, 2] + b2 * vcolors[i2, 2]
    elif mode == COLOR_FACE:
        kdr = fcolors[f, 0]
        kdg = fcolors[f, 1]
        kdb = fcolors[f, 2]
    if mode != COLOR_NONE and mats[gm, MAT_KA_COLORS] != 0.0:  # ambient follows the colours
        kar *= kdr
        kag *= kdg
        kab *= kdb
    if tindex[gm, TEXMAP_KA] >= 0 or tindex[gm, TEXMAP_KD] >= 0 or tindex[gm, TEXMAP_KS] >= 0 \
            or tindex[gm, TEXMAP_KE] >= 0 or tindex[gm, TEXMAP_AO] >= 0:
        u = b0 * uvs[i0, 0] + b1 * uvs[i1, 0] + b2 * uvs[i2, 0]
        v = b0 * uvs[i0, 1] + b1 * uvs[i1, 1] + b2 * uvs[i2, 1]
        k = tindex[gm, TEXMAP_KA]
        if k >= 0:
            r, g, b = _sample(texels, tinfo, k, u, v, dudx, dvdx, dudy, dvdy)
            kar *= r
            kag *= g
            kab *= b
        k = tindex[gm, TEXMAP_KD]
        if k >= 0:
            r, g, b = _sample(texels, tinfo, k, u, v, dudx, dvdx, dudy, dvdy)
            kdr *= r
            kdg *= g
            kdb *= b
        k = tindex[gm, TEXMAP_KS]
        if k >= 0:
            r, g, b = _sample(texels, tinfo, k, u, v, dudx, dvdx, dudy, dvdy)
            ksr *= r
            ksg *= g
            ksb *= b
        k = tindex[gm, TEXMAP_KE]
        if k >= 0:
            r, g, b = _sample(texels, tinfo, k, u, v, dudx, dvdx, dudy, dvdy)
            ker *= r
            keg *= g
            keb *= b
        k = tindex[gm, TEXMAP_AO]
        if k >= 0:  # occlusion: the red channel scales the ambient term
            r, g, b = _sample(texels, tinfo, k, u, v, dudx, dvdx, dudy, dvdy)
            occ = 1.0 + mats[gm, MAT_AO_STRENGTH] * (r - 1.0)
            kar *= occ
            kag *= occ
            kab *= occ
    return kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb, ker, keg, keb


def texture_levels(scene, camera, hits, slot: str = "kd") -> np.ndarray:
    """The mip level (``log2 rho``, before clamping to the pyramid) each pixel's
    footprint selects in its model's ``slot`` map.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    hits : HitBuffer
    slot : {"ka", "kd", "ks", "ke", "ao"}

    Returns
    -------
    (H, W) float64
        NaN on the background and on models without that map.
    """
    slots = {"ka": TEXMAP_KA, "kd": TEXMAP_KD, "ks": TEXMAP_KS, "ke": TEXMAP_KE, "ao": TEXMAP_AO}
    if slot not in slots:
        raise ValueError(f"slot: expected one of {list(slots)}, got {slot!r}")
    from ..visibility.rays import camera_frame

    geo = scene.geometry
    cam = camera_frame(camera, geo.origin)
    out = np.empty(hits.shape, np.float64)
    _rho_kernel(hits.prim, hits.geom, hits.u, hits.v, geo.vertices, geo.faces, geo.face_normals, geo.uvs,
                geo.face_offsets, geo.tex_index, geo.tex_info, cam, slots[slot], out)
    with np.errstate(divide="ignore"):
        return np.log2(out)


@inline_jit(**HELPER)
def _point_coefficients(G, uvs, at, cam, x, y, footprint_on, materials, T):
    """:func:`_coefficients` at hit ``at`` (:class:`~raycast_shade.shading.records.At`):
    filtered by pixel (x, y)'s footprint when ``footprint_on`` (a camera ray), at level 0
    otherwise. ``G`` and ``T`` as in :class:`~raycast_shade.shading.inputs.FrameInputs`."""
    verts, _, faces, fnormals = G
    f, gm, b1, b2 = at
    tri = (faces[f, 0], faces[f, 1], faces[f, 2])
    footprint = (0.0, 0.0, 0.0, 0.0)
    if footprint_on:
        i0, i1, i2 = tri
        b0 = 1.0 - b1 - b2
        px = b0 * verts[i0, 0] + b1 * verts[i1, 0] + b2 * verts[i2, 0]
        py = b0 * verts[i0, 1] + b1 * verts[i1, 1] + b2 * verts[i2, 1]
        pz = b0 * verts[i0, 2] + b1 * verts[i1, 2] + b2 * verts[i2, 2]
        footprint = _uv_derivatives(verts, uvs, fnormals, tri, f, cam, (px, py, pz),
                                    (cam[CAM_EYE + 0], cam[CAM_EYE + 1], cam[CAM_EYE + 2]), x, y)
    return _coefficients(materials, T, at, tri, uvs, footprint)


@in_parts
@njit(nogil=True, **JIT)
def _rho_kernel(prim, geom, u, v, verts, faces, fnormals, uvs, face_off, tindex, tinfo, cam, slot, out, part):
    """``rho`` per pixel for :func:`texture_levels` (NaN where there is no map)."""
    h, w = prim.shape
    ex = cam[CAM_EYE + 0]
    ey = cam[CAM_EYE + 1]
    ez = cam[CAM_EYE + 2]
    for y in range(*share(h, part)):  # this part's share (common.parallel)
        for x in range(w):
            out[y, x] = np.nan
            p = prim[y, x]
            if p < 0:
                continue
            gm = geom[y, x]
            k = tindex[gm, slot]
            if k < 0:
                continue
            f = face_off[gm] + p
            i0 = faces[f, 0]
            i1 = faces[f, 1]
            i2 = faces[f, 2]
            b1 = np.float64(u[y, x])
            b2 = np.float64(v[y, x])
            b0 = 1.0 - b1 - b2
            px = b0 * verts[i0, 0] + b1 * verts[i1, 0] + b2 * verts[i2, 0]
            py = b0 * verts[i0, 1] + b1 * verts[i1, 1] + b2 * verts[i2, 1]
            pz = b0 * verts[i0, 2] + b1 * verts[i1, 2] + b2 * verts[i2, 2]
            dudx, dvdx, dudy, dvdy = _uv_derivatives(verts, uvs, fnormals, (i0, i1, i2), f, cam, (px, py, pz),
                                                     (ex, ey, ez), x, y)
            out[y, x] = _level_rho(tinfo, k, dudx, dvdx, dudy, dvdy)
