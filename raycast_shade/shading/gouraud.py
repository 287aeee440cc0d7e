"""Gouraud shading: the reflectance equation at each vertex with its averaged
normal; the colours interpolated over each triangle with the barycentrics.

A vertex is lit from whichever side the viewer sees its triangle: front (its
normal) or back (negated). Only the sides some visible face needs are shaded
(:mod:`.gouraud_sides`): a closed mesh's visible vertices are seen from one
side only, half the lighting of shading both. A face whose side is certain
and whose corners' stored shades all serve is marked there, and its pixels
interpolate the stored shades at once, without the hit point, the view and
the corner tests (every pixel's colour is the one those give, bit for bit).
Shadow rays leave the vertex, so Gouraud's shadows are as coarse as its
highlights.

Vertex colours are the vertices' kd, inside their shades as any kd is. A
model with a colour map or face colours is shaded the classic "modulate" way
instead: each vertex stores its diffuse light ``sum att Ii (n.s)`` and its
specular light ``sum att Ii (r.v)^t`` separately (kd = ks = 1), both are
interpolated, and the pixel is ``Ia ka + D kd + S ks + ke`` with the pixel's own
(textured) coefficients.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import in_parts, share
from ..common.layout import COLOR_VERTEX, MAT_KA_COLORS, METHOD_GOURAUD
from ..common.prefetch import beyond_caches, prefetch
from ..common.schedule import BLOCK_ROWS, spread_step
from .gouraud_sides import _near_face
from .illumination import _illuminate, _illuminate_call
from .jit import CALLED, CHUNK, FLT32_MAX, HELPER, JIT, compile_variants
from .records import At, Hit, dot, reflect_into
from ..visibility.secondary import ray_scratch
from .surface import _convex_weights, _facing, _hit_point, _triangle, _view
from .texture import _point_coefficients, _row_coefficients

__all__ = ["prefetch_distance"]

_AHEAD = 16  # pixels ahead the pixel kernels prefetch for, beyond the caches (8: 14% slower, 32: 6%)
_DIFFUSE_ONLY = (0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # ka, kd, ks, ke of the modulate
_SPECULAR_ONLY = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0)  # path's two passes


@inline_jit(**HELPER)
def _corner_normal(normals, i, side, g):
    """Vertex ``i``'s normal as lit from ``side`` (0 front, 1 back: negated) of a face whose
    viewer-facing geometric normal is ``g``, and whether the stored vertex shade serves.

    It serves when the normal lies in the face's viewer hemisphere, as on consistent data. A
    vertex without a normal borrows the face's; one whose normal points to the far side of
    this face (opposite normals, a wrongly wound face) is reflected across the face's plane,
    Phong's rule at the vertex, instead of being lit from behind. Both are rare, so they are
    shaded on the spot."""
    sg = 1.0 - 2.0 * side
    n = (sg * normals[i, 0], sg * normals[i, 1], sg * normals[i, 2])
    if n[0] == 0.0 and n[1] == 0.0 and n[2] == 0.0:
        return g, False
    if dot(n, g) < 0.0:
        return reflect_into(n, g), False
    return n, True


@inline_jit(**HELPER)
def _vertex_point(verts, cam, i):
    """Vertex ``i`` and the unit vector from it to the eye."""
    p = (verts[i, 0], verts[i, 1], verts[i, 2])
    return p, _view(cam, p)


@inline_jit(**HELPER)
def _corner_shade(vcol, G, i, side, g, materials, m, cam, L, S, coef, spec_on, att_on):
    """A vertex's Gouraud shade for a face seen from ``side`` with geometric normal ``g``:
    the stored one, or shaded on the spot (:func:`_corner_normal`). ``G``, ``L`` as in
    :class:`~raycast_shade.shading.inputs.FrameInputs`."""
    verts, normals, _, _ = G
    n, stored = _corner_normal(normals, i, side, g)
    if stored:
        return vcol[i, side, 0], vcol[i, side, 1], vcol[i, side, 2]
    p, v = _vertex_point(verts, cam, i)
    return _illuminate_call(Hit(p, v, g, 1.0, n, p), coef, materials, m, L, S, spec_on, att_on)


@inline_jit(**HELPER)
def _vertex_kd(materials, m, cmode, vcolors, i, tex_on):
    """The coefficients a vertex is shaded with: the row's, kd its colour if it has one (and ka
    scaled by it with the row's ka-colours flag)."""
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb, ker, keg, keb = _row_coefficients(materials, m)
    if tex_on and cmode[m] == COLOR_VERTEX:
        cr, cg, cb = vcolors[i, 0], vcolors[i, 1], vcolors[i, 2]
        if materials[m, MAT_KA_COLORS] != 0.0:  # ambient follows the colours
            return kar * cr, kag * cg, kab * cb, cr, cg, cb, ksr, ksg, ksb, ker, keg, keb
        return kar, kag, kab, cr, cg, cb, ksr, ksg, ksb, ker, keg, keb
    return kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb, ker, keg, keb


@inline_jit(**CALLED)
def _split_shade(hp, materials, m, L, S, spec_on, att_on):
    """A vertex's diffuse and specular light apart (kd = 1, ks = 1, no ambient), for the
    "modulate" path: ``(diffuse rgb, specular rgb)``. Two evaluations, so shadow rays are
    traced twice."""
    diffuse = _illuminate_call(hp, _DIFFUSE_ONLY, materials, m, L, S, False, att_on)
    specular = (0.0, 0.0, 0.0)
    if spec_on:
        specular = _illuminate_call(hp, _SPECULAR_ONLY, materials, m, L, S, spec_on, att_on)
    return diffuse, specular


@inline_jit(**HELPER)
def _corner_split(vcol, vspec, G, i, side, g, materials, m, cam, L, S, spec_on, att_on):
    """:func:`_corner_shade` for the modulate path: diffuse and specular light."""
    verts, normals, _, _ = G
    n, stored = _corner_normal(normals, i, side, g)
    if stored:
        return ((vcol[i, side, 0], vcol[i, side, 1], vcol[i, side, 2]),
                (vspec[i, side, 0], vspec[i, side, 1], vspec[i, side, 2]))
    p, v = _vertex_point(verts, cam, i)
    return _split_shade(Hit(p, v, g, 1.0, n, p), materials, m, L, S, spec_on, att_on)


@inline_jit(**HELPER)
def _stored_pixel(vcol, tri, side, b1, b2, image, y, x):
    """A pixel of a face whose corners' stored shades serve: their shades from ``side``
    interpolated into ``image[y, x]`` (as the general pixel does); returns the weights."""
    i0, i1, i2 = tri
    w0, w1, w2 = _convex_weights(b1, b2)
    for c in range(3):
        image[y, x, c] = min(w0 * vcol[i0, side, c] + w1 * vcol[i1, side, c] + w2 * vcol[i2, side, c], FLT32_MAX)
    return w0, w1, w2


def prefetch_distance(faces, vcol) -> int:
    """How many pixels ahead the pixel kernels prefetch: :data:`_AHEAD` when the face rows and
    vertex shades they gather exceed the caches (:func:`~raycast_shade.common.prefetch.beyond_caches`;
    at 82k triangles the hint cost 16-36% of the kernel), else 0."""
    return _AHEAD if beyond_caches(faces, vcol) else 0


@inline_jit(**HELPER)
def _prefetch_pixel(prim, geom, face_off, faces, vcol, y, x, ahead):
    """On a mesh beyond the caches, the rows the pixel ``ahead`` columns on will read: its
    face's vertex indices now, and the vertex shades of the pixel half as far on (whose face
    row an earlier call asked for)."""
    w = prim.shape[1]
    xa = x + ahead
    if xa < w and prim[y, xa] >= 0:
        prefetch(faces, face_off[geom[y, xa]] + prim[y, xa])
    xb = x + ahead // 2
    if xb < w and prim[y, xb] >= 0:
        f = face_off[geom[y, xb]] + prim[y, xb]
        for k in range(3):
            prefetch(vcol, faces[f, k])


def _make_vertices(tex_on: bool = False):
    """The per-vertex kernel for one variant (see :mod:`.jit`; ``tex_on``: vertex colours
    and the modulate path)."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _shade_vertices_kernel(vertex_flags, G, vertex_model, materials, cam, L, T, out, spec_out, part):
        """Gouraud: the shade of each visible vertex from each side its faces need
        (``vertex_flags`` (V, 2): front, lit with its normal, and back, with the negated
        one); ``out`` (V, 2, 3) float64. For a model on the modulate path (``T``'s split
        flag), ``out`` holds the diffuse light and ``spec_out`` (V, 2, 3) the specular light."""
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        verts, normals, _, _ = G
        vcolors, fcolors, cmode, tindex, ttexels, tinfo, split = T
        n = verts.shape[0]
        nchunk = (n + CHUNK - 1) // CHUNK
        step = spread_step(nchunk)
        for it in range(*share(nchunk, part)):  # this part's chunks, in a balanced order
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
                    hp = Hit(p, view, nv, 1.0, nv, p)  # a vertex: its own normal is its geometric one
                    if tex_on and split[m] != 0:
                        rgb, spec = _split_shade(hp, materials, m, L, S, spec_on, att_on)
                        for k in range(3):
                            spec_out[i, side, k] = spec[k]
                    else:
                        rgb = _illuminate(hp, coef, materials, m, L, S, spec_on, att_on)
                    out[i, side, 0] = rgb[0]
                    out[i, side, 1] = rgb[1]
                    out[i, side, 2] = rgb[2]

    return _shade_vertices_kernel


@inline_jit(**HELPER)
def _modulate(vcol, vspec, G, at, side, g, materials, cam, L, S, coef, spec_on, att_on):
    """A modulate-path pixel at hit ``at``: ``Ia ka + D kd + S ks + ke``, with the corners'
    diffuse light ``D`` and specular light ``S`` interpolated and the pixel's own
    (textured, footprint-filtered) coefficients ``coef``."""
    i0, i1, i2 = _triangle(G.faces, at.f)
    m = at.gm
    (d0r, d0g, d0b), (s0r, s0g, s0b) = _corner_split(vcol, vspec, G, i0, side, g, materials, m, cam, L, S,
                                                     spec_on, att_on)
    (d1r, d1g, d1b), (s1r, s1g, s1b) = _corner_split(vcol, vspec, G, i1, side, g, materials, m, cam, L, S,
                                                     spec_on, att_on)
    (d2r, d2g, d2b), (s2r, s2g, s2b) = _corner_split(vcol, vspec, G, i2, side, g, materials, m, cam, L, S,
                                                     spec_on, att_on)
    ambient = L.ambient
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb, ker, keg, keb = coef
    w0, w1, w2 = _convex_weights(at.b1, at.b2)
    r = ambient[0] * kar + (w0 * d0r + w1 * d1r + w2 * d2r) * kdr + (w0 * s0r + w1 * s1r + w2 * s2r) * ksr
    gg = ambient[1] * kag + (w0 * d0g + w1 * d1g + w2 * d2g) * kdg + (w0 * s0g + w1 * s1g + w2 * s2g) * ksg
    b = ambient[2] * kab + (w0 * d0b + w1 * d1b + w2 * d2b) * kdb + (w0 * s0b + w1 * s1b + w2 * s2b) * ksb
    return r + ker, gg + keg, b + keb  # the pixel's own emission, added last as in _illuminate


def _make_interpolate(tex_on: bool = False):
    """The pixel kernel for one variant (see :mod:`.jit`; ``tex_on``: vertex colours in the
    corner fallbacks and the modulate path): its rare corner fallbacks evaluate the
    reflectance equation."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _interp_gouraud_kernel(hits, G, B, face_off, materials, cam, L, T, background, modes, shades,
                               image, part):
        """Gouraud: interpolate vertex shades over the models whose method is METHOD_GOURAUD;
        ``shades`` = ``(vcol, vspec, y0, state, ahead)``: the vertex kernel's, the image row of
        the buffer's first row (a band of the frame; textures need the image position), the
        faces' states (:func:`~raycast_shade.shading.gouraud_sides._face_sides_kernel`) and
        how many pixels ahead to prefetch (0: not at all)."""
        prim, geom, u, v = hits  # the hit buffer's (h, W) arrays (once: not per pixel)
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        vcol, vspec, y0, state, ahead = shades
        verts, normals, faces, fnormals = G
        uvs = B.uvs
        vcolors, fcolors, cmode, tindex, ttexels, tinfo, split = T
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in range(*share(nblk, part)):  # this part's blocks of rows, in a balanced order
            blk = (it * step) % nblk
            for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
                S = ray_scratch()
                for x in range(w):
                    if ahead > 0:
                        _prefetch_pixel(prim, geom, face_off, faces, vcol, y, x, ahead)
                    p = prim[y, x]
                    if p < 0:
                        for c in range(3):
                            image[y, x, c] = background[c]
                        continue
                    g = geom[y, x]
                    if modes[g] != METHOD_GOURAUD:
                        continue
                    f = face_off[g] + p
                    b1 = np.float64(u[y, x])
                    b2 = np.float64(v[y, x])
                    tri = _triangle(faces, f)
                    if state[f] != 0 and _near_face(b1, b2) and not (tex_on and split[g] != 0):
                        _stored_pixel(vcol, tri, state[f] - 1, b1, b2, image, y, x)  # the usual pixel
                        continue
                    i0, i1, i2 = np.int64(tri[0]), np.int64(tri[1]), np.int64(tri[2])  # as _shade_vertices_kernel's
                    view = _view(cam, _hit_point(verts, tri, b1, b2))
                    gn, sgn = _facing(fnormals, f, view)
                    side = 0 if sgn > 0.0 else 1
                    if tex_on and split[g] != 0:
                        at = At(f, g, b1, b2)
                        coef = _point_coefficients(G, uvs, at, cam, x, y0 + y, True, materials, T)
                        r, gg, b = _modulate(vcol, vspec, G, at, side, gn, materials, cam, L, S, coef,
                                             spec_on, att_on)
                        image[y, x, 0] = min(r, FLT32_MAX)
                        image[y, x, 1] = min(gg, FLT32_MAX)
                        image[y, x, 2] = min(b, FLT32_MAX)
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

    return _interp_gouraud_kernel


_VERTICES = compile_variants(_make_vertices)  # the family's registry (see .jit)
_INTERPOLATE = compile_variants(_make_interpolate)  # the family's registry (see .jit)
