"""Gouraud shading: the reflectance equation at each vertex with its averaged
normal; the colours interpolated over each triangle with the barycentrics.

A vertex is lit from whichever side the viewer sees its triangle, so each
visible vertex gets two shades, front (its normal) and back (negated).
Shadow rays leave the vertex, so Gouraud's shadows are as coarse as its
highlights.

Vertex colours are the vertices' kd, inside their shades as any kd is. A
model with a colour map or face colours is shaded the classic "modulate" way
instead: each vertex stores its diffuse light ``sum att Ii (n.s)`` and its
specular light ``sum att Ii (r.v)^t`` separately (kd = ks = 1), both are
interpolated, and the pixel is ``Ia ka + D kd + S ks`` with the pixel's own
(textured) coefficients.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..common.schedule import BLOCK_ROWS, spread_step
from .illumination import _illuminate, _illuminate_call
from .jit import CALLED, CHUNK, FLT32_MAX, HELPER, JIT, compile_variants
from .shadows import _scratch
from .surface import _convex_weights, _facing, _hit_point, _view
from ..common.layout import COLOR_VERTEX
from .texture import _point_coefficients, _row_coefficients

__all__ = []


@njit(**HELPER)
def _corner_shade(vcol, normals, verts, i, side, gx, gy, gz, materials, m, cam, ambient, lights, dmin, handle, unit,
                  S, coef, spec_on, att_on):
    """A vertex's Gouraud shade for a face seen from ``side``.

    The precomputed shade serves when the vertex normal (negated on the back
    side) lies in the face's viewer hemisphere, as on consistent data. A
    vertex without a normal borrows the face's; one whose normal points to
    the far side of this face (opposite normals, a wrongly wound face) is
    reflected across the face's plane, Phong's rule at the vertex, instead
    of being lit from behind. Both are rare, so they are shaded on the spot.
    """
    sg = 1.0 - 2.0 * side
    nx = sg * normals[i, 0]
    ny = sg * normals[i, 1]
    nz = sg * normals[i, 2]
    c = nx * gx + ny * gy + nz * gz
    if nx == 0.0 and ny == 0.0 and nz == 0.0:
        nx, ny, nz = gx, gy, gz
    elif c < 0.0:
        nx -= 2.0 * c * gx
        ny -= 2.0 * c * gy
        nz -= 2.0 * c * gz
    else:
        return vcol[i, side, 0], vcol[i, side, 1], vcol[i, side, 2]
    px = verts[i, 0]
    py = verts[i, 1]
    pz = verts[i, 2]
    vx, vy, vz = _view(cam, px, py, pz)
    return _illuminate_call(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m, coef, ambient, lights, dmin, handle,
                            unit, S, px, py, pz, gx, gy, gz, spec_on, att_on)


@njit(**HELPER)
def _vertex_kd(materials, m, cmode, vcolors, i, tex_on):
    """The coefficients a vertex is shaded with: the row's, kd its colour if it has one."""
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb = _row_coefficients(materials, m)
    if tex_on and cmode[m] == COLOR_VERTEX:
        return kar, kag, kab, vcolors[i, 0], vcolors[i, 1], vcolors[i, 2], ksr, ksg, ksb
    return kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb


@njit(**CALLED)
def _split_shade(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m, ambient, lights, dmin, handle, unit, S,
                 gx, gy, gz, spec_on, att_on):
    """A vertex's diffuse and specular light apart (kd = 1, ks = 1, no ambient),
    for the "modulate" path: two evaluations, so shadow rays are traced twice."""
    dr, dg, db = _illuminate_call(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m,
                                  (0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0), ambient, lights, dmin, handle, unit, S, px, py, pz, gx, gy, gz,
                                  False, att_on)
    sr = sg = sb = 0.0
    if spec_on:
        sr, sg, sb = _illuminate_call(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m,
                                      (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0), ambient, lights, dmin, handle, unit, S,
                                      px, py, pz, gx, gy, gz, spec_on, att_on)
    return dr, dg, db, sr, sg, sb


@njit(**HELPER)
def _corner_split(vcol, vspec, normals, verts, i, side, gx, gy, gz, materials, m, cam, ambient, lights, dmin,
                  handle, unit, S, spec_on, att_on):
    """:func:`_corner_shade` for the modulate path: diffuse and specular light."""
    sg = 1.0 - 2.0 * side
    nx = sg * normals[i, 0]
    ny = sg * normals[i, 1]
    nz = sg * normals[i, 2]
    c = nx * gx + ny * gy + nz * gz
    if nx == 0.0 and ny == 0.0 and nz == 0.0:
        nx, ny, nz = gx, gy, gz
    elif c < 0.0:
        nx -= 2.0 * c * gx
        ny -= 2.0 * c * gy
        nz -= 2.0 * c * gz
    else:
        return (vcol[i, side, 0], vcol[i, side, 1], vcol[i, side, 2],
                vspec[i, side, 0], vspec[i, side, 1], vspec[i, side, 2])
    px = verts[i, 0]
    py = verts[i, 1]
    pz = verts[i, 2]
    vx, vy, vz = _view(cam, px, py, pz)
    return _split_shade(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m, ambient, lights, dmin, handle, unit, S,
                        gx, gy, gz, spec_on, att_on)


def _make_vertices(spec_on: bool, att_on: bool, tex_on: bool = False):
    """The per-vertex kernel for one variant (see :mod:`.jit`; ``tex_on``: vertex colours
    and the modulate path)."""

    @njit(parallel=True, **JIT)
    def _shade_vertices_kernel(vertex_flags, G, vertex_model, materials, cam, L, T, out, spec_out):
        """Gouraud: the shade of each visible vertex, lit from the front (normal)
        and from the back (negated normal); ``out`` (V, 2, 3) float64. For a
        model on the modulate path (``T``'s split flag), ``out`` holds the
        diffuse light and ``spec_out`` (V, 2, 3) the specular light."""
        verts, normals, _, _ = G
        ambient, lights, dmin, handle, unit = L
        vcolors, fcolors, cmode, tindex, ttexels, tinfo, split = T
        n = verts.shape[0]
        nchunk = (n + CHUNK - 1) // CHUNK
        step = spread_step(nchunk)
        for it in prange(nchunk):  # chunks in a balanced order (see common.schedule)
            c = (it * step) % nchunk
            S = _scratch()
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                if vertex_flags[i] == 0:
                    continue
                px = verts[i, 0]
                py = verts[i, 1]
                pz = verts[i, 2]
                vx, vy, vz = _view(cam, px, py, pz)
                m = vertex_model[i]
                coef = _vertex_kd(materials, m, cmode, vcolors, i, tex_on)
                for side in range(2):
                    sg = 1.0 - 2.0 * side
                    nx = sg * normals[i, 0]
                    ny = sg * normals[i, 1]
                    nz = sg * normals[i, 2]
                    if tex_on and split[m] != 0:
                        r, g, b, sr, sgr, sb = _split_shade(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m,
                                                            ambient, lights, dmin, handle, unit, S, nx, ny, nz,
                                                            spec_on, att_on)
                        spec_out[i, side, 0] = sr
                        spec_out[i, side, 1] = sgr
                        spec_out[i, side, 2] = sb
                    else:
                        r, g, b = _illuminate(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m, coef, ambient, lights, dmin, handle, unit, S, px, py, pz, nx, ny, nz,
                                              spec_on, att_on)
                    out[i, side, 0] = r
                    out[i, side, 1] = g
                    out[i, side, 2] = b

    return _shade_vertices_kernel


@njit(**HELPER)
def _modulate(vcol, vspec, normals, verts, faces, f, g, b1, b2, side, gx, gy, gz, materials, cam, ambient, lights,
              dmin, handle, unit, S, coef, spec_on, att_on):
    """A modulate-path pixel: ``Ia ka + D kd + S ks``, with the corners' diffuse
    light ``D`` and specular light ``S`` interpolated and the pixel's own
    (textured, footprint-filtered) coefficients ``coef``."""
    i0 = faces[f, 0]
    i1 = faces[f, 1]
    i2 = faces[f, 2]
    d0r, d0g, d0b, s0r, s0g, s0b = _corner_split(vcol, vspec, normals, verts, i0, side, gx, gy, gz, materials, g,
                                                 cam, ambient, lights, dmin, handle, unit, S, spec_on, att_on)
    d1r, d1g, d1b, s1r, s1g, s1b = _corner_split(vcol, vspec, normals, verts, i1, side, gx, gy, gz, materials, g,
                                                 cam, ambient, lights, dmin, handle, unit, S, spec_on, att_on)
    d2r, d2g, d2b, s2r, s2g, s2b = _corner_split(vcol, vspec, normals, verts, i2, side, gx, gy, gz, materials, g,
                                                 cam, ambient, lights, dmin, handle, unit, S, spec_on, att_on)
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb = coef
    w0, w1, w2 = _convex_weights(b1, b2)
    r = ambient[0] * kar + (w0 * d0r + w1 * d1r + w2 * d2r) * kdr + (w0 * s0r + w1 * s1r + w2 * s2r) * ksr
    gg = ambient[1] * kag + (w0 * d0g + w1 * d1g + w2 * d2g) * kdg + (w0 * s0g + w1 * s1g + w2 * s2g) * ksg
    b = ambient[2] * kab + (w0 * d0b + w1 * d1b + w2 * d2b) * kdb + (w0 * s0b + w1 * s1b + w2 * s2b) * ksb
    return r, gg, b


def _make_interpolate(spec_on: bool, att_on: bool, tex_on: bool = False):
    """The pixel kernel for one variant (see :mod:`.jit`; ``tex_on``: vertex colours in the
    corner fallbacks and the modulate path): its rare corner fallbacks evaluate the
    reflectance equation."""

    @njit(parallel=True, **JIT)
    def _interp_gouraud_kernel(prim, geom, u, v, G, B, face_off, materials, cam, L, T, background, modes, vcol,
                               vspec, image):
        """Gouraud: interpolate vertex shades over the models whose method is 1."""
        verts, normals, faces, fnormals = G
        uvs = B[0]
        ambient, lights, dmin, handle, unit = L
        vcolors, fcolors, cmode, tindex, ttexels, tinfo, split = T
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in prange(nblk):  # blocks of rows in a balanced order (see common.schedule)
            blk = (it * step) % nblk
            for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
                S = _scratch()
                for x in range(w):
                    p = prim[y, x]
                    if p < 0:
                        for c in range(3):
                            image[y, x, c] = background[c]
                        continue
                    g = geom[y, x]
                    if modes[g] != 1:
                        continue
                    f = face_off[g] + p
                    i0 = faces[f, 0]
                    i1 = faces[f, 1]
                    i2 = faces[f, 2]
                    b1 = np.float64(u[y, x])
                    b2 = np.float64(v[y, x])
                    px, py, pz = _hit_point(verts, i0, i1, i2, b1, b2)
                    vx, vy, vz = _view(cam, px, py, pz)
                    gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
                    side = 0 if sgn > 0.0 else 1
                    if tex_on and split[g] != 0:
                        coef = _point_coefficients(verts, uvs, fnormals, faces, f, g, b1, b2, cam, x, y, True,
                                                   materials, vcolors, fcolors, cmode, tindex, ttexels, tinfo)
                        r, gg, b = _modulate(vcol, vspec, normals, verts, faces, f, g, b1, b2, side, gx, gy, gz,
                                             materials, cam, ambient, lights, dmin, handle, unit, S, coef,
                                             spec_on, att_on)
                        image[y, x, 0] = min(r, FLT32_MAX)
                        image[y, x, 1] = min(gg, FLT32_MAX)
                        image[y, x, 2] = min(b, FLT32_MAX)
                        continue
                    k0 = _vertex_kd(materials, g, cmode, vcolors, i0, tex_on)
                    k1 = _vertex_kd(materials, g, cmode, vcolors, i1, tex_on)
                    k2 = _vertex_kd(materials, g, cmode, vcolors, i2, tex_on)
                    r0, g0, c0 = _corner_shade(vcol, normals, verts, i0, side, gx, gy, gz, materials, g, cam,
                                               ambient, lights, dmin, handle, unit, S, k0, spec_on, att_on)
                    r1, g1, c1 = _corner_shade(vcol, normals, verts, i1, side, gx, gy, gz, materials, g, cam,
                                               ambient, lights, dmin, handle, unit, S, k1, spec_on, att_on)
                    r2, g2, c2 = _corner_shade(vcol, normals, verts, i2, side, gx, gy, gz, materials, g, cam,
                                               ambient, lights, dmin, handle, unit, S, k2, spec_on, att_on)
                    b0, b1, b2 = _convex_weights(b1, b2)
                    image[y, x, 0] = min(b0 * r0 + b1 * r1 + b2 * r2, FLT32_MAX)
                    image[y, x, 1] = min(b0 * g0 + b1 * g1 + b2 * g2, FLT32_MAX)
                    image[y, x, 2] = min(b0 * c0 + b1 * c1 + b2 * c2, FLT32_MAX)

    return _interp_gouraud_kernel


_VERTICES = compile_variants(_make_vertices)
_INTERPOLATE = compile_variants(_make_interpolate)
_VERTICES_TEX = compile_variants(lambda s, a: _make_vertices(s, a, True))
_INTERPOLATE_TEX = compile_variants(lambda s, a: _make_interpolate(s, a, True))
