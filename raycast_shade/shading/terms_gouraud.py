"""Gouraud's terms in the image's own pass: each visible vertex's equation evaluated once, its
parts stored beside its colours, and interpolated by the pixel kernel that interpolates the
image.

The vertex record ``V`` is a terms record (:mod:`.terms_kernel`) of float64 rows ``2 i + side``
(vertex ``i`` lit from the front, side 0, or the back, side 1), followed by :data:`VERT_REACH`
(L, 2V, 1) float64, each light's ``cone (n.s)`` at the vertex (0 where it does not reach: the
shadow probe's unit light; written only in a frame with shadow rays, the only one whose mask
reads it), the vertex colours ``vcol`` and ``vspec`` of
:mod:`.gouraud` (V, 2, 3) float64, the image row of the buffer's first row, and the faces' states
(F,) uint8 (:mod:`.gouraud_sides`) with the pixels' prefetch distance
(:func:`~raycast_shade.shading.gouraud.prefetch_distance`). Only the vertex sides some
seen face needs are written (and read). Each pixel
interpolates every term with the weights its colour is interpolated with, as the variant
passes of :mod:`.terms` do, so the numbers are theirs (measured equal, bit for bit, on the test
scenes); the shadow mask is ``sum w_k vis_k reach_k / sum w_k reach_k`` (each sum rounded to
float32 first, as the probe's image is), exact unless a blocked vertex's ``reach`` is below
float32's smallest subnormal. A model on the "modulate" path (maps or face colours) stores each
vertex's diffuse and specular light (kd = ks = 1), and the pixel multiplies them by its own
coefficients, as its colour does. A corner whose stored shade does not serve (a flipped or
missing vertex normal, :func:`~raycast_shade.shading.gouraud._corner_normal`) is shaded on the
spot into its parallel task's rows of a scratch record, as the image's corner is.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import in_parts, share
from ..common.layout import LIGHT_SHADOWS, METHOD_GOURAUD
from ..common.prefetch import prefetch
from ..common.schedule import BLOCK_ROWS, spread_step
from .gouraud import (_corner_normal, _corner_shade, _modulate, _prefetch_pixel, _split_shade, _stored_pixel,
                      _vertex_kd, _vertex_point)
from .gouraud_sides import _near_face
from .illumination import _light_at, _samples
from .jit import CALLED, CHUNK, FLT32_MAX, HELPER, JIT, compile_variants
from .records import At, Hit, dot
from ..visibility.secondary import ray_scratch
from .surface import _convex_weights, _facing, _hit_point, _triangle, _view
from .terms_kernel import (TERM_AMBIENT, TERM_DIFFUSE, TERM_EMISSIVE, TERM_SPECULAR, TERMS_BACKGROUND_RGB,
                           TERMS_EACH, TERMS_EMIT_ON, TERMS_SHADOW, _hit_background, _illuminate_terms, _miss,
                           _store)
from .texture import _point_coefficients

__all__ = ["VERT_REACH", "VERT_COL", "VERT_SPEC", "VERT_Y0", "VERT_STATE", "VERT_AHEAD", "VERT_SCRATCH",
           "scratch_slots"]

# The vertex record's slots after the terms record's; VERT_SCRATCH on: scratch_slots().
VERT_REACH, VERT_COL, VERT_SPEC, VERT_Y0, VERT_STATE, VERT_AHEAD, VERT_SCRATCH = 10, 11, 12, 13, 14, 15, 16
_SPLIT = (0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0)  # the modulate path's kd = ks = 1


@inline_jit(**HELPER)
def _reach(lights, p, n, dmin, att_on, reach, row, ext):
    """Each light's ``cone (n.s)`` at ``p`` with normal ``n``, summed over its samples, into
    ``reach[:, row, 0]`` (0 where it does not reach): what the shadow probe's unit light gives
    there unshadowed. ``ext``: the frame's ``L.ext`` (:func:`.illumination._light_at`)."""
    for i in range(lights.shape[0]):
        total = 0.0
        for j in range(_samples(lights, i, ext)):
            s, d, att, cone = _light_at(lights, i, j, p, dmin, np.bool_(att_on), ext)
            if d == 0.0 or cone == 0.0:
                continue
            ndots = dot(n, s)
            if ndots <= 0.0:
                continue
            if ndots > 1.0:
                ndots = 1.0
            total += cone * ndots
        reach[i, row, 0] = total


@inline_jit(**HELPER)
def _vertex_side(V, hp, coef, materials, m, L, S, spec_on, att_on, splitting, i, side):
    """Vertex ``i`` lit from ``side``: its colours (as :mod:`.gouraud`'s vertex kernel stores
    them) and its terms (row ``2 i + side`` of ``V``)."""
    vcol, vspec = V[VERT_COL], V[VERT_SPEC]
    row = 2 * i + side
    if splitting:
        rgb, spec = _split_shade(hp, materials, m, L, S, spec_on, att_on)
        for k in range(3):
            vspec[i, side, k] = spec[k]
        _illuminate_terms(hp, _SPLIT, materials, m, L, S, spec_on, att_on, V, row, 0)
    else:
        rgb = _illuminate_terms(hp, coef, materials, m, L, S, spec_on, att_on, V, row, 0)
    vcol[i, side, 0] = rgb[0]
    vcol[i, side, 1] = rgb[1]
    vcol[i, side, 2] = rgb[2]
    if L.handle != 0:  # the reach is read only for the mask of a light with shadow rays (_pixel_lights)
        _reach(L.lights, hp.p, hp.n, L.dmin, att_on, V[VERT_REACH], row, L.ext)


def _make_vertex_terms(tex_on: bool = False):
    """The per-vertex colours-and-terms kernel for one variant (see :mod:`.jit`)."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _vertex_terms_kernel(vertex_flags, G, vertex_model, materials, cam, L, T, V, part):
        """Each flagged vertex side's colours and terms (``vertex_flags`` (V, 2): front, back;
        ``V``: the vertex record, see the module docstring)."""
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        verts, normals, _, _ = G
        vcolors, fcolors, cmode, tindex, ttexels, tinfo, split = T
        n = verts.shape[0]
        nchunk = (n + CHUNK - 1) // CHUNK
        step = spread_step(nchunk)
        for it in range(*share(nchunk, part)):  # this part's share (common.parallel)
            c = (it * step) % nchunk
            S = ray_scratch()
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                if vertex_flags[i, 0] == 0 and vertex_flags[i, 1] == 0:
                    continue
                p, view = _vertex_point(verts, cam, i)
                m = vertex_model[i]
                coef = _vertex_kd(materials, m, cmode, vcolors, i, tex_on)
                for side in range(2):
                    if vertex_flags[i, side] == 0:
                        continue
                    sg = 1.0 - 2.0 * side
                    nv = (sg * normals[i, 0], sg * normals[i, 1], sg * normals[i, 2])
                    _vertex_side(V, Hit(p, view, nv, 1.0, nv, p), coef, materials, m, L, S, spec_on, att_on,
                                 tex_on and split[m] != 0, i, side)

    return _vertex_terms_kernel


@inline_jit(**HELPER)
def _copy_row(V, row, C, k):
    """Row ``row`` of the vertex record into row ``k`` of the corner scratch ``C``."""
    for c in range(3):
        C[TERM_AMBIENT][k, 0, c] = V[TERM_AMBIENT][row, 0, c]
        C[TERM_DIFFUSE][k, 0, c] = V[TERM_DIFFUSE][row, 0, c]
        C[TERM_SPECULAR][k, 0, c] = V[TERM_SPECULAR][row, 0, c]
        if V[TERMS_EMIT_ON]:
            C[TERM_EMISSIVE][k, 0, c] = V[TERM_EMISSIVE][row, 0, c]
    each, reach = V[TERMS_EACH], V[VERT_REACH]
    for i in range(reach.shape[0]):
        C[TERMS_SHADOW][i, k, 0] = V[TERMS_SHADOW][i, row, 0]
        C[VERT_REACH][i, k, 0] = reach[i, row, 0]
        if each.shape[1] > 0:
            for c in range(3):
                C[TERMS_EACH][0, i, k, 0, c] = each[0, i, row, 0, c]
                C[TERMS_EACH][1, i, k, 0, c] = each[1, i, row, 0, c]


@inline_jit(**HELPER)
def _corner_terms(V, C, G, i, side, g, materials, m, cam, L, S, coef, spec_on, att_on, k):
    """Corner ``k``'s terms into the scratch ``C``: vertex ``i``'s stored ones, or, where they
    do not serve, shaded on the spot as :func:`~raycast_shade.shading.gouraud._corner_shade`
    shades the corner's colour."""
    verts, normals, _, _ = G
    n, stored = _corner_normal(normals, i, side, g)
    if stored:
        _copy_row(V, 2 * i + side, C, k)
        return
    p, v = _vertex_point(verts, cam, i)
    _illuminate_terms(Hit(p, v, g, 1.0, n, p), coef, materials, m, L, S, spec_on, att_on, C, k, 0)
    if L.handle != 0:
        _reach(L.lights, p, n, L.dmin, att_on, C[VERT_REACH], k, L.ext)


@inline_jit(**HELPER)
def _lerp(a, rows, w, c):
    """``w0 a[r0] + w1 a[r1] + w2 a[r2]`` of channel ``c`` of an (N, 1, 3) array of corner
    rows, as the pixel kernel interpolates the corners' colours."""
    return w[0] * a[rows[0], 0, c] + w[1] * a[rows[1], 0, c] + w[2] * a[rows[2], 0, c]


@inline_jit(**HELPER)
def _lerp3(a, rows, w):
    return _lerp(a, rows, w, 0), _lerp(a, rows, w, 1), _lerp(a, rows, w, 2)


@inline_jit(**HELPER)
def _pixel_terms(R, C, rows, L, w, ty, x, coef, splitting):
    """The pixel's terms from its corners' (rows ``rows`` of the record ``C``: the vertex
    record, or the corner scratch) with weights ``w``: interpolated, or on the modulate path
    (``splitting``) the interpolated light times the pixel's coefficients (``L`` whole: an
    array taken out of it in the kernel's loop would cost a reference count per pixel)."""
    ambient = L.ambient
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb, ker, keg, keb = coef
    if splitting:
        _store(R[TERM_AMBIENT], ty, x, ambient[0] * kar, ambient[1] * kag, ambient[2] * kab)
        dr, dg, db = _lerp3(C[TERM_DIFFUSE], rows, w)
        _store(R[TERM_DIFFUSE], ty, x, dr * kdr, dg * kdg, db * kdb)
        sr, sg, sb = _lerp3(C[TERM_SPECULAR], rows, w)
        _store(R[TERM_SPECULAR], ty, x, sr * ksr, sg * ksg, sb * ksb)
        if R[TERMS_EMIT_ON]:
            _store(R[TERM_EMISSIVE], ty, x, ker, keg, keb)
    else:
        r, g, b = _lerp3(C[TERM_AMBIENT], rows, w)
        _store(R[TERM_AMBIENT], ty, x, r, g, b)
        r, g, b = _lerp3(C[TERM_DIFFUSE], rows, w)
        _store(R[TERM_DIFFUSE], ty, x, r, g, b)
        r, g, b = _lerp3(C[TERM_SPECULAR], rows, w)
        _store(R[TERM_SPECULAR], ty, x, r, g, b)
        if R[TERMS_EMIT_ON]:
            r, g, b = _lerp3(C[TERM_EMISSIVE], rows, w)
            _store(R[TERM_EMISSIVE], ty, x, r, g, b)
    _hit_background(R, ty, x)
    _pixel_lights(R, C, rows, L, w, ty, x, coef, splitting)


@inline_jit(**HELPER)
def _pixel_lights(R, C, rows, L, w, ty, x, coef, splitting):
    """The pixel's per-light terms and shadow mask from its corners' (see :func:`_pixel_terms`);
    a light that casts no shadow rays (or a frame without a scene handle) lets all of its
    light through: its mask is 1, as the variant passes' (whose ratio is then ``x / x``), and
    its corners are not read."""
    w0, w1, w2 = w
    r0, r1, r2 = rows
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb, ker, keg, keb = coef
    lights, handle = L.lights, L.handle
    each, shadow, reach, vis = R[TERMS_EACH], R[TERMS_SHADOW], C[VERT_REACH], C[TERMS_SHADOW]
    for i in range(shadow.shape[0]):
        if handle == 0 or lights[i, LIGHT_SHADOWS] == 0.0:
            shadow[i, ty, x] = 1.0
        else:
            _mask(shadow, vis, reach, i, rows, w, ty, x)
        if each.shape[1] > 0:
            dr, dg, db = _lerp3(C[TERMS_EACH][0, i], rows, w)
            sr, sg, sb = _lerp3(C[TERMS_EACH][1, i], rows, w)
            if splitting:
                _store(each[0, i], ty, x, dr * kdr, dg * kdg, db * kdb)
                _store(each[1, i], ty, x, sr * ksr, sg * ksg, sb * ksb)
            else:
                _store(each[0, i], ty, x, dr, dg, db)
                _store(each[1, i], ty, x, sr, sg, sb)


@inline_jit(**HELPER)
def _mask(shadow, vis, reach, i, rows, w, ty, x):
    """Light ``i``'s mask at the pixel: the corners' light let through over the light reaching them."""
    w0, w1, w2 = w
    r0, r1, r2 = rows
    through = w0 * (vis[i, r0, 0] * reach[i, r0, 0]) + w1 * (vis[i, r1, 0] * reach[i, r1, 0]) + w2 * (
        vis[i, r2, 0] * reach[i, r2, 0])
    reached = w0 * reach[i, r0, 0] + w1 * reach[i, r1, 0] + w2 * reach[i, r2, 0]
    t32 = np.float32(min(through, FLT32_MAX))  # the probe's image values, rounded as stored
    r32 = np.float32(min(reached, FLT32_MAX))
    shadow[i, ty, x] = min(np.float64(t32) / np.float64(r32), 1.0) if r32 > 0.0 else 1.0


@inline_jit(**HELPER)
def _corners_stored(normals, tri, side, g):
    """Whether every corner's stored vertex shade serves the face (:func:`_corner_normal`)."""
    return (_corner_normal(normals, tri[0], side, g)[1] and _corner_normal(normals, tri[1], side, g)[1]
            and _corner_normal(normals, tri[2], side, g)[1])


@inline_jit(**CALLED)
def _fallback_terms(R, V, G, tri, side, gn, materials, m, cam, L, S, coefs, spec_on, att_on, where):
    """A pixel with a corner whose stored shade does not serve: its three corners' terms
    gathered into its task's rows of the scratch slots of ``V`` (:data:`VERT_SCRATCH`), the one
    it does not serve shaded on the spot, then interpolated. ``coefs``: the corners' and the
    pixel's coefficients; ``where``: (weights, image row, column, task, modulate path). A call,
    not inlined: it runs only for such rare pixels, and its light loops would swell the hot
    pixel loop; the scratch is the caller's (an array made in a parallel loop costs a
    reference count on every pixel)."""
    w, ty, x, blk, splitting = where
    C = (V[16], V[17], V[18], V[19], V[19], V[20], V[21], V[TERMS_EMIT_ON], False,  # VERT_SCRATCH = 16 on
         V[TERMS_BACKGROUND_RGB], V[22])
    r = 3 * blk
    for k in range(3):
        _corner_terms(V, C, G, tri[k], side, gn, materials, m, cam, L, S, coefs[k], spec_on, att_on, r + k)
    _pixel_terms(R, C, (r, r + 1, r + 2), L, w, ty, x, coefs[3], splitting)


def scratch_slots(V, tasks: int) -> tuple:
    """The corner scratch of :func:`_fallback_terms`, three rows per parallel task, laid out as
    ``V``'s terms and reach: the slots ``VERT_SCRATCH`` on of the vertex record."""
    nl, each = V[TERMS_SHADOW].shape[0], V[TERMS_EACH].shape[1]
    rows = 3 * max(int(tasks), 1)
    return tuple(np.empty((rows, 1, 3)) for _ in range(4)) + (
        np.empty((2, each, rows, 1, 3)), np.empty((nl, rows, 1)), np.empty((nl, rows, 1)))


@inline_jit(**HELPER)
def _prefetch_terms(prim, geom, face_off, faces, V, y, x, ahead):
    """:func:`~raycast_shade.shading.gouraud._prefetch_pixel` for the terms kernel: also the local
    terms' rows (both sides: rows ``2 i`` and ``2 i + 1`` share a cache line or two)."""
    _prefetch_pixel(prim, geom, face_off, faces, V[VERT_COL], y, x, ahead)
    xb = x + ahead // 2
    if xb < prim.shape[1] and prim[y, xb] >= 0:
        f = face_off[geom[y, xb]] + prim[y, xb]
        for k in range(3):
            i = 2 * faces[f, k]
            prefetch(V[TERM_AMBIENT], i)
            prefetch(V[TERM_DIFFUSE], i)
            prefetch(V[TERM_SPECULAR], i)


def _make_gouraud_terms(tex_on: bool = False):
    """The Gouraud image-and-terms pixel kernel for one variant (see :mod:`.jit`)."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _gouraud_terms_kernel(hits, G, B, face_off, materials, cam, L, T, modes, image, R, V, part):
        """:mod:`.gouraud`'s pixel kernel (the image, the same arithmetic) that also writes each
        pixel's terms into ``R`` at row ``y0 + y`` (``y0`` and the vertex colours: ``V``)."""
        prim, geom, u, v = hits  # the hit buffer's (h, W) arrays (once: not per pixel)
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        vcol, vspec, y0 = V[VERT_COL], V[VERT_SPEC], V[VERT_Y0]
        state, ahead = V[VERT_STATE], V[VERT_AHEAD]
        verts, normals, faces, fnormals = G
        uvs = B.uvs
        vcolors, fcolors, cmode, tindex, ttexels, tinfo, split = T
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in range(*share(nblk, part)):  # this part's share (common.parallel)
            blk = (it * step) % nblk
            for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
                S = ray_scratch()
                ty = y0 + y
                for x in range(w):
                    if ahead > 0:
                        _prefetch_terms(prim, geom, face_off, faces, V, y, x, ahead)
                    p = prim[y, x]
                    if p < 0:
                        _miss(image, R, y, ty, x)
                        continue
                    g = geom[y, x]
                    if modes[g] != METHOD_GOURAUD:
                        continue
                    f = face_off[g] + p
                    b1 = np.float64(u[y, x])
                    b2 = np.float64(v[y, x])
                    tri = _triangle(faces, f)
                    i0, i1, i2 = tri
                    if state[f] != 0 and _near_face(b1, b2) and not (tex_on and split[g] != 0):  # the usual pixel
                        side = state[f] - 1
                        w3 = _stored_pixel(vcol, tri, side, b1, b2, image, y, x)
                        _pixel_terms(R, V, (2 * i0 + side, 2 * i1 + side, 2 * i2 + side), L, w3, ty, x,
                                     _vertex_kd(materials, g, cmode, vcolors, i0, tex_on), False)
                        continue
                    view = _view(cam, _hit_point(verts, tri, b1, b2))
                    gn, sgn = _facing(fnormals, f, view)
                    side = 0 if sgn > 0.0 else 1
                    if tex_on and split[g] != 0:
                        at = At(f, g, b1, b2)
                        coef = _point_coefficients(G, uvs, at, cam, x, ty, True, materials, T)
                        r, gg, b = _modulate(vcol, vspec, G, at, side, gn, materials, cam, L, S, coef,
                                             spec_on, att_on)
                        image[y, x, 0] = min(r, FLT32_MAX)
                        image[y, x, 1] = min(gg, FLT32_MAX)
                        image[y, x, 2] = min(b, FLT32_MAX)
                        w3 = _convex_weights(at.b1, at.b2)
                        if _corners_stored(normals, tri, side, gn):
                            _pixel_terms(R, V, (2 * i0 + side, 2 * i1 + side, 2 * i2 + side), L, w3, ty, x, coef,
                                         True)
                            continue
                        _fallback_terms(R, V, G, tri, side, gn, materials, g, cam, L, S, (_SPLIT, _SPLIT, _SPLIT, coef),
                                        spec_on, att_on, (w3, ty, x, blk, True))
                        continue
                    k0 = _vertex_kd(materials, g, cmode, vcolors, i0, tex_on)
                    k1 = _vertex_kd(materials, g, cmode, vcolors, i1, tex_on)
                    k2 = _vertex_kd(materials, g, cmode, vcolors, i2, tex_on)
                    r0, g0, c0 = _corner_shade(vcol, G, i0, side, gn, materials, g, cam, L, S, k0, spec_on, att_on)
                    r1, g1, c1 = _corner_shade(vcol, G, i1, side, gn, materials, g, cam, L, S, k1, spec_on, att_on)
                    r2, g2, c2 = _corner_shade(vcol, G, i2, side, gn, materials, g, cam, L, S, k2, spec_on, att_on)
                    b0, b1, b2 = _convex_weights(b1, b2)
                    image[y, x, 0] = min(b0 * r0 + b1 * r1 + b2 * r2, FLT32_MAX)
                    image[y, x, 1] = min(b0 * g0 + b1 * g1 + b2 * g2, FLT32_MAX)
                    image[y, x, 2] = min(b0 * c0 + b1 * c1 + b2 * c2, FLT32_MAX)
                    if _corners_stored(normals, tri, side, gn):  # the usual case: the vertex record's rows
                        _pixel_terms(R, V, (2 * i0 + side, 2 * i1 + side, 2 * i2 + side), L, (b0, b1, b2), ty, x,
                                     k0, False)
                        continue
                    _fallback_terms(R, V, G, tri, side, gn, materials, g, cam, L, S, (k0, k1, k2, k0), spec_on, att_on,
                                    ((b0, b1, b2), ty, x, blk, False))

    return _gouraud_terms_kernel


_VERTEX_TERMS = compile_variants(_make_vertex_terms)  # the families' registries (see .jit)
_GOURAUD_TERMS = compile_variants(_make_gouraud_terms)
