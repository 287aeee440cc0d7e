"""Phong shading: the reflectance equation at every pixel, at the true 3D hit
point, with the normal interpolated (``a = n1 + mu1 (n2 - n1) + mu2 (n3 - n1)``),
renormalised, and perturbed by the material's bump map if it has one.

Shadow rays leave the pixel's point, lifted past the terminator
(:func:`~raycast_shade.shading.surface._terminator_point`).

Speed notes. The kernels take the packed tuples of
:func:`~raycast_shade.shading.inputs.kernel_inputs` but unpack them once,
outside the pixel loop, and hand plain arrays to the inlined helpers:
unpacking a tuple of arrays inside the loop makes Numba take and drop a
reference on every array for every pixel (atomic operations on counters that
both threads share), which cost more than the shading arithmetic (measured on
a 1080p Phong frame of an 81,920-triangle sphere on 2 cores: 36 ms with the
unpacking in the loop, 19 ms without, repeated squaring included).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..common.schedule import BLOCK_ROWS, spread_step
from .bump import _bump
from .illumination import _illuminate
from .jit import FLT32_MAX, HELPER, JIT, compile_variants
from .shadows import _scratch
from .surface import _facing, _hit_point, _shading_normal, _terminator_point, _view
from .texture import _point_coefficients, _row_coefficients

__all__ = []


@njit(**HELPER)
def _surface(verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info, cam, f, gm, b1, b2,
             use_dir, dx, dy, dz):
    """Everything about a hit that shading needs.

    The arrays are the unpacked ``G`` and ``B`` of
    :func:`~raycast_shade.shading.inputs.kernel_inputs`. The view vector is
    towards the eye, or ``-d`` for a secondary ray. Returns p, v, oriented
    geometric normal g, its sign, and the oriented (and bumped) shading
    normal n.
    """
    i0 = faces[f, 0]
    i1 = faces[f, 1]
    i2 = faces[f, 2]
    px, py, pz = _hit_point(verts, i0, i1, i2, b1, b2)
    if use_dir:
        vx = -dx
        vy = -dy
        vz = -dz
    else:
        vx, vy, vz = _view(cam, px, py, pz)
    gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
    nx, ny, nz = _shading_normal(normals, i0, i1, i2, b1, b2, gx, gy, gz, sgn)
    nx, ny, nz = _bump(nx, ny, nz, f, gm, i0, i1, i2, b1, b2, uvs, tangents, bump_index, texels, info,
                       sgn * gx, sgn * gy, sgn * gz)
    return px, py, pz, vx, vy, vz, gx, gy, gz, sgn, nx, ny, nz


@njit(**HELPER)
def _shade_surface(verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info,
                   ambient, lights, dmin, handle, unit, S, materials, cam, f, gm, b1, b2, use_dir, dx, dy, dz,
                   coef, spec_on, att_on):
    """Phong shading of one hit: colour, plus the point and normals for mirrors.

    The arrays and scalars before ``S`` are the unpacked ``G``, ``B`` and
    ``L`` of :func:`~raycast_shade.shading.inputs.kernel_inputs`; they stay
    separate arguments because this runs inside the pixel loop. ``coef``:
    the point's nine ``ka, kd, ks`` (:mod:`.texture`)."""
    px, py, pz, vx, vy, vz, gx, gy, gz, sgn, nx, ny, nz = _surface(
        verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info, cam, f, gm, b1, b2,
        use_dir, dx, dy, dz)
    ox = px
    oy = py
    oz = pz
    if handle != 0:  # shadow rays will be traced: start them past the terminator
        ox, oy, oz = _terminator_point(verts, normals, faces[f, 0], faces[f, 1], faces[f, 2], b1, b2, px, py, pz, sgn)
    r, g, b = _illuminate(px, py, pz, nx, ny, nz, vx, vy, vz, materials, gm, coef, ambient, lights, dmin, handle,
                          unit, S, ox, oy, oz, gx, gy, gz, spec_on, att_on)
    return r, g, b, px, py, pz, vx, vy, vz, gx, gy, gz, nx, ny, nz


def _make_phong(spec_on: bool, att_on: bool, tex_on: bool = False):
    """The Phong pixel kernel for one variant (see :mod:`.jit`; ``tex_on``: textured coefficients)."""

    @njit(parallel=True, **JIT)
    def _shade_phong_kernel(prim, geom, u, v, G, B, L, T, face_off, materials, cam, background, modes, image, y0):
        """Phong: shade every pixel of the models whose method is 2; array row ``r`` is
        image row ``y0 + r`` (a band of the frame; textures need the image position)."""
        verts, normals, faces, fnormals = G
        uvs, tangents, bump_index, texels, info = B
        ambient, lights, dmin, handle, unit = L
        vcolors, fcolors, cmode, tindex, ttexels, tinfo, _ = T
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
                    gm = geom[y, x]
                    if modes[gm] != 2:
                        continue
                    f = face_off[gm] + p
                    b1 = np.float64(u[y, x])
                    b2 = np.float64(v[y, x])
                    if tex_on:
                        coef = _point_coefficients(verts, uvs, fnormals, faces, f, gm, b1, b2, cam, x, y0 + y, True,
                                                   materials, vcolors, fcolors, cmode, tindex, ttexels, tinfo)
                    else:
                        coef = _row_coefficients(materials, gm)
                    r, g, b, _, _, _, _, _, _, _, _, _, _, _, _ = _shade_surface(
                        verts, normals, faces, fnormals, uvs, tangents, bump_index, texels, info,
                        ambient, lights, dmin, handle, unit, S, materials, cam, f, gm,
                        b1, b2, False, 0.0, 0.0, 0.0, coef, spec_on, att_on)
                    image[y, x, 0] = min(r, FLT32_MAX)
                    image[y, x, 1] = min(g, FLT32_MAX)
                    image[y, x, 2] = min(b, FLT32_MAX)

    return _shade_phong_kernel


_PHONG = compile_variants(_make_phong)
_PHONG_TEX = compile_variants(lambda s, a: _make_phong(s, a, True))
