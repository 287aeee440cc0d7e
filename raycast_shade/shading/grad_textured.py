"""Reverse-mode gradients of a frame whose models have mesh colours or colour maps.

The material, ambient, light and vertex-normal gradients of :mod:`.grad_frame`, with each point's
coefficients the ones the forward pass shades it with: Phong's pixels and Gouraud's modulate path
(a model with a map or face colours) :func:`~raycast_shade.shading.texture._point_coefficients`
(the pixel's footprint), flat faces :func:`~raycast_shade.shading.texture._coefficients` at the
centre (the face's UV footprint), Gouraud's vertices
:func:`~raycast_shade.shading.gouraud._vertex_kd` (the vertex colour in place of kd). These are the
forward pass's own functions, called here, not copies.

What the material gradients mean on such a scene: the gradient with respect to the material's
scalar factors, the row's ``ka``, ``kd``, ``ks`` (RGB). The forward pass's point coefficients are

    kd = kd_row * kd_map(uv)                  (no mesh colours)
    kd = colour * kd_map(uv)                  (vertex or face colours: kd_row is not used)
    ka = ka_row * [colour if ka_colors] * ka_map(uv) * (1 + s (ao(uv) - 1))
    ks = ks_row * ks_map(uv)

so ``dL/dkd_row = F_kd dL/dkd_point`` with ``F_kd`` the point's coefficient computed with unit rows
(0 where the colour replaces kd), likewise ``ka`` and ``ks``: the factors are
``_point_coefficients`` evaluated once more with unit ``ka, kd, ks, ke`` rows (``unit``). The light,
ambient and normal gradients go through :func:`~raycast_shade.shading.grad_terms._reflected_vjp`
with the point's true coefficients. Each point's slots are written into a scratch row first and
folded into the part's accumulator row scaled (:func:`_fold`): the sums keep a fixed order (Phong
pixels and flat faces in :data:`~raycast_shade.shading.grad_frame.PARTS` fixed parts, Gouraud's
pixels serially in row-major order), bit-identical on any number of threads.

Gouraud's modulate pixel is ``Ia ka + D kd + S ks + ke`` with ``D``, ``S`` the corners' diffuse and
specular light interpolated: each corner's share ``w_k gI`` goes through ``_reflected_vjp`` at the
point the forward pass lights the corner, with the pixel's coefficients (their ambient parts sum to
the pixel's ``Ia ka``, the weights summing to 1).

The geometry (vertex positions, camera) on such a scene: :mod:`.grad_geometry`'s terms at each
point's own coefficients, plus the coefficients' own motion with the hit's barycentrics
(:mod:`.grad_geotex`: the vertex colours' differences, the maps' bilinear derivative times
``d(uv)/d(b)``, a mip-mapped map's level held). Flat faces take their coefficients at the centre over
the face's UV footprint, which do not move with the geometry.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import COLOR_NONE, MAT_KA, MAT_KD, MAT_KE, MAT_KS, METHOD_FLAT, METHOD_GOURAUD, METHOD_PHONG
from ..common.parallel import launch, share
from ..visibility.secondary import ray_scratch
from .gouraud import _vertex_kd
from .grad_bump import perturb_partials
from .grad_frame import PARTS, _flat_gather, _phong_normals_scatter, _point_grads, _reduce
from .grad_geometry import faces_scatter, points_scatter
from .grad_geotex import coefficients_bary_vjp, pixel_footprint, tex_pixels_scatter
from .grad_normal import _normal_vjp
from .grad_terms import GM_KA, GM_KD, GM_KS, GM_SIZE, GM_T, _reflected_vjp, layout
from .grad_walk import (chunk_items, chunks, corner_hit, corner_normal_grad, face_grad, gouraud_pixel, pixel_at,
                        pixel_grad, vertex_grad)
from .illumination import _illuminate
from .jit import HELPER, JIT
from .phong import _shading_point
from .records import At
from .surface import _triangle
from .texture import _coefficients, _face_footprint, _point_coefficients

__all__ = ["textured_vjp", "unit_rows"]


@njit(**HELPER)
def _fold(scratch, acc, k, mi, amb, fac, kd_free):
    """``acc[k] += scratch[0]`` for one point's slots, model ``mi``'s ``ka, kd, ks`` scaled by the
    point's factors ``fac`` (its unit-row coefficients; kd's 0 unless ``kd_free``: a colour replaces
    kd), and those slots of ``scratch`` zeroed. The ambient and the lights' slots (from ``amb`` to
    the end) are copied as they are."""
    mb = mi * GM_SIZE
    for c in range(3):
        acc[k, mb + GM_KA + c] += fac[c] * scratch[0, mb + GM_KA + c]
        if kd_free:
            acc[k, mb + GM_KD + c] += fac[3 + c] * scratch[0, mb + GM_KD + c]
        acc[k, mb + GM_KS + c] += fac[6 + c] * scratch[0, mb + GM_KS + c]
        scratch[0, mb + GM_KA + c] = 0.0
        scratch[0, mb + GM_KD + c] = 0.0
        scratch[0, mb + GM_KS + c] = 0.0
    acc[k, mb + GM_T] += scratch[0, mb + GM_T]
    scratch[0, mb + GM_T] = 0.0
    for j in range(amb, scratch.shape[1]):
        acc[k, j] += scratch[0, j]
        scratch[0, j] = 0.0


@njit(**HELPER)
def _point_gcoef(scratch, mi, gI):
    """The point's ``dL/d(ka, kd, ks, ke)`` (twelve floats): the material slots
    :func:`_reflected_vjp` wrote into ``scratch`` (before :func:`_fold` scales them), and ``gI`` for
    the emission (added once)."""
    mb = mi * GM_SIZE
    return (scratch[0, mb + GM_KA], scratch[0, mb + GM_KA + 1], scratch[0, mb + GM_KA + 2],
            scratch[0, mb + GM_KD], scratch[0, mb + GM_KD + 1], scratch[0, mb + GM_KD + 2],
            scratch[0, mb + GM_KS], scratch[0, mb + GM_KS + 1], scratch[0, mb + GM_KS + 2], gI[0], gI[1], gI[2])


@njit(nogil=True, **JIT)
def _phong_tex_kernel(hits, G, B, L, T, face_off, materials, unit, cam, modes, gimg, lay, acc, gpx, part):
    """Phong pixels with their textured coefficients: ``acc[k]`` (part ``k``) += ``dL/dparameters``;
    ``gpx`` (H, W, 9) as :func:`~raycast_shade.shading.grad_frame._phong_vjp_kernel`'s (``dL/da``,
    ``dL/dp``, ``dL/dv``), or (0, 0, 9) for none. The coefficients' ``dL/db`` for the geometry is
    :func:`_phong_coefficients_kernel`'s pass (its own kernel: its compile is paid only when asked)."""
    cmode = T[2]
    want_n = gpx.shape[0] != 0
    k = part[0]
    scratch = np.zeros((1, acc.shape[1]))
    h, w = hits[0].shape
    for y in range(*share(h, part)):
        S = ray_scratch()
        for x in range(w):
            shaded, at, gI = pixel_grad(hits, face_off, modes, METHOD_PHONG, gimg, y, x)
            if not shaded:
                continue
            gm = at.gm
            coef = _point_coefficients(G, B.uvs, at, cam, x, y, True, materials, T)
            fac = _point_coefficients(G, B.uvs, at, cam, x, y, True, unit, T)
            hp = _shading_point(G, B, L, cam, at, np.bool_(False), (0.0, 0.0, 0.0))
            gn, gp, gv = _reflected_vjp(hp, coef, materials, gm, L, S, gI, scratch, 0, lay)
            _fold(scratch, acc, k, gm, lay[0], fac, cmode[gm] == COLOR_NONE)
            if want_n:
                ga = _normal_vjp(G.normals, _triangle(G.faces, at.f), at.b1, at.b2, hp.g, hp.sgn, gn)
                for c in range(3):
                    gpx[y, x, c] = ga[c]
                    gpx[y, x, 3 + c] = gp[c]
                    gpx[y, x, 6 + c] = gv[c]


@njit(nogil=True, **JIT)
def _phong_coefficients_kernel(hits, G, B, L, T, face_off, materials, cam, modes, gimg, lay, size, gbc, part):
    """Phong pixels, for the geometry: ``gbc[y, x]`` = ``dL/d(b1, b2)`` through the pixel's
    coefficients (:func:`~raycast_shade.shading.grad_geotex.coefficients_bary_vjp`), their
    ``dL/d(ka, kd, ks)`` read from :func:`_reflected_vjp`'s material slots (a scratch row per pixel)."""
    scratch = np.zeros((1, size))
    h, w = hits[0].shape
    for y in range(*share(h, part)):
        S = ray_scratch()
        for x in range(w):
            shaded, at, gI = pixel_grad(hits, face_off, modes, METHOD_PHONG, gimg, y, x)
            if not shaded:
                continue
            gm = at.gm
            coef = _point_coefficients(G, B.uvs, at, cam, x, y, True, materials, T)
            hp = _shading_point(G, B, L, cam, at, np.bool_(False), (0.0, 0.0, 0.0))
            scratch[0, :] = 0.0
            _reflected_vjp(hp, coef, materials, gm, L, S, gI, scratch, 0, lay)
            gb = coefficients_bary_vjp(materials, T, at, _triangle(G.faces, at.f), B.uvs,
                                       pixel_footprint(G, B.uvs, at, cam, x, y), _point_gcoef(scratch, gm, gI))
            gbc[y, x, 0] = gb[0]
            gbc[y, x, 1] = gb[1]


@njit(nogil=True, **JIT)
def _flat_tex_kernel(gface, G, T, uvs, face_model, materials, unit, cam, L, lay, acc, gfg, part):
    """Flat faces at their centres with the coefficients the forward pass gives them (the centre's,
    filtered over the face's UV footprint: they do not move with the geometry): ``acc[k]`` += the
    parameters' gradients; ``gfg`` (F, 9) the face's ``dL/dn``, ``dL/dp``, ``dL/dv`` for the
    geometry, or (0, 9) for none."""
    cmode = T[2]
    k = part[0]
    scratch = np.zeros((1, acc.shape[1]))
    nf = G.faces.shape[0]
    third = 1.0 / 3.0
    for ch in range(*chunks(nf, part)):
        S = ray_scratch()
        for f in range(*chunk_items(nf, ch)):
            shaded, hp, gI = face_grad(G, cam, gface, f)
            if not shaded:
                continue
            tri = _triangle(G.faces, f)
            m = face_model[f]
            at = At(f, m, third, third)
            coef = _coefficients(materials, T, at, tri, uvs, _face_footprint(uvs, tri))
            fac = _coefficients(unit, T, at, tri, uvs, _face_footprint(uvs, tri))
            gr = _reflected_vjp(hp, coef, materials, m, L, S, gI, scratch, 0, lay)
            _fold(scratch, acc, k, m, lay[0], fac, cmode[m] == COLOR_NONE)
            if gfg.shape[0] != 0:
                for j in range(3):
                    for c in range(3):
                        gfg[f, 3 * j + c] = gr[j][c]


@njit(**JIT)
def _gouraud_tex_gather(hits, G, B, L, T, face_off, materials, unit, cam, modes, gimg, lay, out):
    """Serially, in row-major order, the Gouraud pixels: a modulate-path pixel (``T``'s flag) is
    differentiated here, each corner at its point with the pixel's coefficients and its share
    ``w_k gI``, into ``serial[0]`` and ``gnormals``; another pixel's ``dL/dI`` goes onto its corners'
    stored shades ``gvert`` (V, 2, 3), and a corner shaded on the spot is differentiated here.
    ``out = (serial, gvert, gnormals, gvg, gbc)``; for the geometry (``gbc`` (H, W, 2), else
    (0, 0, 2)) the corners' ``dL/dp``, ``dL/dv`` go into ``gvg`` (V, 6) and each pixel's
    ``dL/d(b1, b2)`` into ``gbc``: ``gI . (shade_j - shade_0)`` of its corners' shades (modulate: each
    corner lit with the pixel's coefficients), plus, on the modulate path, the coefficients' own
    (:func:`~raycast_shade.shading.grad_geotex.coefficients_bary_vjp`)."""
    serial, gvert, gnormals, gvg, gbc = out
    vcolors, _, cmode, _, _, _, modulate = T
    want_g = gbc.shape[0] != 0
    scratch = np.zeros((1, serial.shape[1]))
    gk = np.zeros(9)
    shd = np.zeros((3, 3))
    S = ray_scratch()
    h, w = hits[0].shape
    for y in range(h):
        for x in range(w):
            shaded, at = pixel_at(hits, face_off, modes, METHOD_GOURAUD, y, x)
            if not shaded:
                continue
            gm = at.gm
            tri, gn, side, wts = gouraud_pixel(G, cam, at)
            split = modulate[gm] != 0
            if split:
                coef = _point_coefficients(G, B.uvs, at, cam, x, y, True, materials, T)
                fac = _point_coefficients(G, B.uvs, at, cam, x, y, True, unit, T)
            gk[:] = 0.0
            for corner in range(3):
                i = tri[corner]
                wk = wts[corner]
                gI = (wk * gimg[y, x, 0], wk * gimg[y, x, 1], wk * gimg[y, x, 2])
                hp, stored = corner_hit(G, cam, i, side, gn)
                if want_g:  # the corner's shade, as the pixel interpolates it
                    ck = coef if split else _vertex_kd(materials, gm, cmode, vcolors, i, True)
                    sh = _illuminate(hp, ck, materials, gm, L, S, L.spec_on, L.att_on)
                    for c in range(3):
                        shd[corner, c] = sh[c]
                if not split:
                    if stored:
                        for cc in range(3):
                            gvert[i, side, cc] += gI[cc]
                        continue
                    coef = _vertex_kd(materials, gm, cmode, vcolors, i, True)
                    fac = _vertex_kd(unit, gm, cmode, vcolors, i, True)
                gr = _reflected_vjp(hp, coef, materials, gm, L, S, gI, scratch, 0, lay)
                if want_g:
                    gc = _point_gcoef(scratch, gm, gI)
                    for j in range(9):
                        gk[j] += gc[j]
                    _point_grads(gvg, i, gr)
                _fold(scratch, serial, 0, gm, lay[0], fac, cmode[gm] == COLOR_NONE)
                corner_normal_grad(G, i, side, gn, gr[0], gnormals)
            if want_g:
                gI = (np.float64(gimg[y, x, 0]), np.float64(gimg[y, x, 1]), np.float64(gimg[y, x, 2]))
                gb1 = gb2 = 0.0
                for c in range(3):
                    gb1 += gI[c] * (shd[1, c] - shd[0, c])
                    gb2 += gI[c] * (shd[2, c] - shd[0, c])
                if split:
                    cb = coefficients_bary_vjp(materials, T, at, tri, B.uvs, pixel_footprint(G, B.uvs, at, cam, x, y),
                                               (gk[0], gk[1], gk[2], gk[3], gk[4], gk[5], gk[6], gk[7], gk[8],
                                                gI[0], gI[1], gI[2]))
                    gb1 += cb[0]
                    gb2 += cb[1]
                gbc[y, x, 0] = gb1
                gbc[y, x, 1] = gb2


@njit(nogil=True, **JIT)
def _gouraud_tex_vertices(gvert, G, T, vertex_model, materials, unit, cam, L, lay, acc, gnormals, gvg, part):
    """Gouraud vertices off the modulate path (lit with their own normal, their colour as kd):
    ``acc[k]`` += the parameters' gradients, ``gnormals[i]`` += the normal's (each vertex in one
    part); ``gvg`` (V, 6) the vertex's ``dL/dp``, ``dL/dv`` for the geometry, or (0, 6) for none."""
    vcolors, _, cmode, _, _, _, _ = T
    k = part[0]
    scratch = np.zeros((1, acc.shape[1]))
    n = G.verts.shape[0]
    for ch in range(*chunks(n, part)):
        S = ray_scratch()
        for i in range(*chunk_items(n, ch)):
            for side in range(2):
                shaded, hp, gI = vertex_grad(G, cam, gvert, i, side)
                if not shaded:
                    continue
                m = vertex_model[i]
                coef = _vertex_kd(materials, m, cmode, vcolors, i, True)
                fac = _vertex_kd(unit, m, cmode, vcolors, i, True)
                gr = _reflected_vjp(hp, coef, materials, m, L, S, gI, scratch, 0, lay)
                _fold(scratch, acc, k, m, lay[0], fac, cmode[m] == COLOR_NONE)
                _point_grads(gvg, i, gr)
                sg = 1.0 - 2.0 * side
                for c in range(3):
                    gnormals[i, c] += sg * gr[0][c]


def unit_rows(materials) -> np.ndarray:
    """The material rows with ``ka``, ``kd``, ``ks`` and ``ke`` set to 1: the forward pass's
    coefficient functions then return what multiplies each row at a point (its colour and maps)."""
    unit = materials.copy()
    for slot in (MAT_KA, MAT_KD, MAT_KS, MAT_KE):
        unit[:, slot:slot + 3] = 1.0
    return unit


def textured_vjp(hits, inputs, modes, gimg, geo, want_normals: bool = False, want_geometry: bool = False):
    """:func:`~raycast_shade.shading.grad_frame.frame_vjp` for a frame whose models have colours or
    maps (``inputs.tex_on``): ``(params (R,), gnormals (V, 3) or None, gverts (V, 3) or None,
    gcam (6,) or None)``, the material slots with respect to the rows' scalar factors (see the module
    docstring); the geometry's with the coefficients moving with each hit's barycentrics
    (:mod:`.grad_geotex`)."""
    G, B, L, T = inputs.geometry, inputs.bumps, inputs.lighting, inputs.colours
    mats, cam, face_off = inputs.materials, inputs.cam, inputs.face_off
    unit = unit_rows(mats)
    amb, lb, size = layout(mats.shape[0], L.lights.shape[0])
    lay = (np.int64(amb), np.int64(lb))
    acc = np.zeros((PARTS, size))
    serial = np.zeros((1, size))
    nv, nf = G.verts.shape[0], G.faces.shape[0]
    gnormals = np.zeros((nv, 3))
    gverts = np.zeros((nv, 3))
    gcam = np.zeros(6)
    hit = (hits.prim, hits.geom, hits.u, hits.v)
    gpx = np.zeros(gimg.shape[:2] + (9,) if want_normals or want_geometry else (0, 0, 9))
    gbc = np.zeros(gimg.shape[:2] + (2,) if want_geometry else (0, 0, 2))
    if np.any(modes == METHOD_PHONG):
        launch(_phong_tex_kernel, hit, G, B, L, T, face_off, mats, unit, cam, modes, gimg, lay, acc, gpx,
               parts=PARTS, dynamic=True)
        if want_geometry:
            launch(_phong_coefficients_kernel, hit, G, B, L, T, face_off, mats, cam, modes, gimg, lay, size, gbc,
                   parts=PARTS, dynamic=True)
        if want_normals and (np.any(B.bump_index >= 0) or np.any(B.nmap_index >= 0)):
            perturb_partials(hits, inputs, modes, gimg, gpx)  # bumped pixels' dL/da through the bent normal
        if want_normals:
            _phong_normals_scatter(*hit, G.faces, face_off, modes, gpx, gnormals)
    if np.any(modes == METHOD_FLAT):
        gface = np.zeros((nf, 3))
        gfg = np.zeros((nf if want_geometry else 0, 9))
        _flat_gather(hits.prim, hits.geom, face_off, modes, gimg, gface)
        launch(_flat_tex_kernel, gface, G, T, B.uvs, geo.face_model, mats, unit, cam, L, lay, acc, gfg, parts=PARTS,
               dynamic=True)
        if want_geometry:
            faces_scatter(gfg, G, cam, gverts, gcam)
    if np.any(modes == METHOD_GOURAUD):
        gvert = np.zeros((nv, 2, 3))
        gvg = np.zeros((nv if want_geometry else 0, 6))
        _gouraud_tex_gather(hit, G, B, L, T, face_off, mats, unit, cam, modes, gimg, lay,
                            (serial, gvert, gnormals, gvg, gbc))
        launch(_gouraud_tex_vertices, gvert, G, T, geo.vertex_model, mats, unit, cam, L, lay, acc, gnormals, gvg,
               parts=PARTS, dynamic=True)
        if want_geometry:
            points_scatter(gvg, G.verts, cam, gverts, gcam)
    if want_geometry and (np.any(modes == METHOD_PHONG) or np.any(modes == METHOD_GOURAUD)):
        tex_pixels_scatter(hit, G, face_off, cam, modes, gpx, gbc, gverts, gcam)
    return (serial[0] + _reduce(acc), gnormals if want_normals else None, gverts if want_geometry else None,
            gcam if want_geometry else None)
