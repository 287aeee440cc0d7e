"""Flat shading: the reflectance equation once per triangle, at its centre,
with its true (geometric) normal; every pixel of the triangle takes that shade.

Only the faces some pixel sees are shaded (:func:`.shade._visible_kernel`
marks them); the shadow ray of a face leaves its centre.
"""

from __future__ import annotations

from numba import njit, prange

from ..common.schedule import spread_step
from .illumination import _illuminate
from .jit import CHUNK, FLT32_MAX, JIT, compile_variants
from .shadows import _scratch
from .surface import _facing, _hit_point, _view
from .texture import _coefficients, _face_footprint, _row_coefficients

__all__ = []


def _make_flat(spec_on: bool, att_on: bool, tex_on: bool = False):
    """The per-face kernel for one variant (see :mod:`.jit`); ``tex_on``: the
    face's coefficients come from its colours and maps (:mod:`.texture`)."""

    @njit(parallel=True, **JIT)
    def _shade_faces_kernel(face_flags, G, face_model, materials, cam, L, T, uvs, out):
        """Flat shading: one shade per visible face, at its centre.

        ``G``, ``L`` and ``T`` as in :func:`~raycast_shade.shading.inputs.kernel_inputs`;
        ``out`` (F, 3) float64. A textured face takes the texel at its centre
        from the mip level whose texels are as large as the face's UV
        triangle: the face's average colour, one shade per polygon."""
        verts, _, faces, fnormals = G
        ambient, lights, dmin, handle, unit = L
        vcolors, fcolors, cmode, tindex, texels, tinfo, _ = T
        n = faces.shape[0]
        nchunk = (n + CHUNK - 1) // CHUNK
        step = spread_step(nchunk)
        for it in prange(nchunk):  # chunks in a balanced order (see common.schedule)
            c = (it * step) % nchunk
            S = _scratch()
            for f in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                if face_flags[f] == 0:
                    continue
                third = 1.0 / 3.0
                px, py, pz = _hit_point(verts, faces[f, 0], faces[f, 1], faces[f, 2], third, third)
                vx, vy, vz = _view(cam, px, py, pz)
                gx, gy, gz, sgn = _facing(fnormals, f, vx, vy, vz)
                m = face_model[f]
                if tex_on:
                    i0 = faces[f, 0]
                    i1 = faces[f, 1]
                    i2 = faces[f, 2]
                    dudx, dvdx, dudy, dvdy = _face_footprint(uvs, i0, i1, i2)
                    coef = _coefficients(materials, m, f, i0, i1, i2, third, third, uvs, vcolors, fcolors, cmode,
                                         tindex, texels, tinfo, dudx, dvdx, dudy, dvdy)
                else:
                    coef = _row_coefficients(materials, m)
                r, g, b = _illuminate(px, py, pz, gx, gy, gz, vx, vy, vz, materials, m, coef, ambient, lights, dmin, handle, unit, S, px, py, pz, gx, gy, gz,
                                      spec_on, att_on)
                out[f, 0] = r
                out[f, 1] = g
                out[f, 2] = b

    return _shade_faces_kernel


_FLAT = compile_variants(_make_flat)
_FLAT_TEX = compile_variants(lambda s, a: _make_flat(s, a, True))


@njit(parallel=True, **JIT)
def _lookup_flat_kernel(prim, geom, face_off, fcol, background, modes, image):
    """Flat: each pixel of the models whose method is 0 takes its face's shade."""
    h, w = prim.shape
    for y in prange(h):
        for x in range(w):
            p = prim[y, x]
            if p < 0:
                for c in range(3):
                    image[y, x, c] = background[c]
                continue
            g = geom[y, x]
            if modes[g] != 0:
                continue
            f = face_off[g] + p
            for c in range(3):
                image[y, x, c] = min(fcol[f, c], FLT32_MAX)
