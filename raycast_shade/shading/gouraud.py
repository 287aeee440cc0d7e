"""Gouraud shading: the reflectance equation at each vertex with its averaged
normal; the colours interpolated over each triangle with the barycentrics.

A vertex is lit from whichever side the viewer sees its triangle, so each
visible vertex gets two shades, front (its normal) and back (negated).
Shadow rays leave the vertex, so Gouraud's shadows are as coarse as its
highlights.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..common.schedule import BLOCK_ROWS, spread_step
from .illumination import _illuminate, _illuminate_call
from .jit import CHUNK, FLT32_MAX, JIT, compile_variants
from .shadows import _scratch
from .surface import _convex_weights, _facing, _hit_point, _view

__all__ = []


@njit(inline="always", **JIT)
def _corner_shade(vcol, normals, verts, i, side, gx, gy, gz, materials, m, cam, ambient, lights, dmin, handle, unit,
                  S, spec_on, att_on):
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
    return _illuminate_call(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m, ambient, lights, dmin, handle, unit,
                            S, px, py, pz, gx, gy, gz, spec_on, att_on)


def _make_vertices(spec_on: bool, att_on: bool):
    """The per-vertex kernel for one variant (see :mod:`.jit`)."""

    @njit(parallel=True, **JIT)
    def _shade_vertices_kernel(vertex_flags, G, vertex_model, materials, cam, L, out):
        """Gouraud: the shade of each visible vertex, lit from the front (normal)
        and from the back (negated normal); ``out`` (V, 2, 3) float64."""
        verts, normals, _, _ = G
        ambient, lights, dmin, handle, unit = L
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
                for side in range(2):
                    sg = 1.0 - 2.0 * side
                    nx = sg * normals[i, 0]
                    ny = sg * normals[i, 1]
                    nz = sg * normals[i, 2]
                    r, g, b = _illuminate(px, py, pz, nx, ny, nz, vx, vy, vz, materials, m,
                                          ambient, lights, dmin, handle, unit, S, px, py, pz, nx, ny, nz,
                                          spec_on, att_on)
                    out[i, side, 0] = r
                    out[i, side, 1] = g
                    out[i, side, 2] = b

    return _shade_vertices_kernel


def _make_interpolate(spec_on: bool, att_on: bool):
    """The pixel kernel for one variant (see :mod:`.jit`): its rare corner
    fallbacks evaluate the reflectance equation."""

    @njit(parallel=True, **JIT)
    def _interp_gouraud_kernel(prim, geom, u, v, G, face_off, materials, cam, L, background, modes, vcol, image):
        """Gouraud: interpolate vertex shades over the models whose method is 1."""
        verts, normals, faces, fnormals = G
        ambient, lights, dmin, handle, unit = L
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
                    r0, g0, c0 = _corner_shade(vcol, normals, verts, i0, side, gx, gy, gz, materials, g, cam,
                                               ambient, lights, dmin, handle, unit, S, spec_on, att_on)
                    r1, g1, c1 = _corner_shade(vcol, normals, verts, i1, side, gx, gy, gz, materials, g, cam,
                                               ambient, lights, dmin, handle, unit, S, spec_on, att_on)
                    r2, g2, c2 = _corner_shade(vcol, normals, verts, i2, side, gx, gy, gz, materials, g, cam,
                                               ambient, lights, dmin, handle, unit, S, spec_on, att_on)
                    b0, b1, b2 = _convex_weights(b1, b2)
                    image[y, x, 0] = min(b0 * r0 + b1 * r1 + b2 * r2, FLT32_MAX)
                    image[y, x, 1] = min(b0 * g0 + b1 * g1 + b2 * g2, FLT32_MAX)
                    image[y, x, 2] = min(b0 * c0 + b1 * c1 + b2 * c2, FLT32_MAX)

    return _interp_gouraud_kernel


_VERTICES = compile_variants(_make_vertices)
_INTERPOLATE = compile_variants(_make_interpolate)
