"""The terms of a Phong frame in one pass: each pixel's equation evaluated once, its parts stored.

The light loop is :func:`~raycast_shade.shading.illumination._illuminate`'s, with
each part accumulated apart and stored in its own output slot, where the variant
passes of :mod:`.terms` would each shade the frame again (one pass per term, per
light and per shadow probe):

=================  ===================================================================
output             per pixel
=================  ===================================================================
``local[TERM_AMBIENT]``   ``Ia ka``
``local[TERM_DIFFUSE]``   ``sum_i vis_i att_i Ii kd (n.s_i)``
``local[TERM_SPECULAR]``  ``sum_i vis_i att_i Ii Ks spec_i``
``local[TERM_EMISSIVE]``  ``ke``, the point's emission
``per_light[0, i]``       light ``i``'s diffuse part (``per_light[1, i]`` its specular)
``shadow[i]``             0 where light ``i``'s shadow ray is blocked (and the light would
                          reach the point), else 1
=================  ===================================================================

``ka, kd, Ks`` are the point's (maps, colours: :mod:`.texture`), as the variants'
are: the equation is linear in them. A new term is one more slot of ``local``
(:data:`TERM_SLOTS`) written where its part is computed, as the emission is,
stored in ``local[TERM_EMISSIVE]`` beside the ambient line of :func:`_illuminate_terms`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..common.layout import LIGHT_RADIANCE, LIGHT_SHADOWS, LIGHT_VEC, MAT_KS, MAT_MODEL, MAT_SHININESS, METHOD_PHONG
from ..common.schedule import BLOCK_ROWS, spread_step
from .illumination import _light_at, _power
from .jit import FLT32_MAX, HELPER, JIT, compile_variants
from .phong import _surface
from .records import At, Hit, dot
from .reflectance import _specular_cosine
from .shadows import _occluded, _scratch
from .surface import _terminator_point, _triangle
from .texture import _point_coefficients, _row_coefficients

__all__ = ["TERM_AMBIENT", "TERM_DIFFUSE", "TERM_SPECULAR", "TERM_EMISSIVE", "TERM_SLOTS"]

TERM_AMBIENT, TERM_DIFFUSE, TERM_SPECULAR, TERM_EMISSIVE = 0, 1, 2, 3
TERM_SLOTS = ("ambient", "diffuse", "specular", "emissive")  # local's slots, in order: the names on frame.terms


@njit(**HELPER)
def _store(arr, y, x, r, g, b):
    arr[y, x, 0] = min(r, FLT32_MAX)
    arr[y, x, 1] = min(g, FLT32_MAX)
    arr[y, x, 2] = min(b, FLT32_MAX)


@njit(**HELPER)
def _illuminate_terms(hp, coef, mats, mi, L, S, spec_on, att_on, local, per_light, shadow, y, x):
    """:func:`~raycast_shade.shading.illumination._illuminate` at pixel ``(x, y)``, its parts
    stored in ``local`` (K, H, W, 3), ``per_light`` (2, L, H, W, 3) (or (2, 0, ...): none) and
    ``shadow`` (L, H, W) instead of summed."""
    ambient, lights, dmin, handle, unit = L
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb, ker, keg, keb = coef
    n = hp.n
    _store(local[TERM_AMBIENT], y, x, ambient[0] * kar, ambient[1] * kag, ambient[2] * kab)
    _store(local[TERM_EMISSIVE], y, x, ker, keg, keb)
    dr = dg = db = sr = sg = sb = 0.0
    shin = mats[mi, MAT_SHININESS]
    model = mats[mi, MAT_MODEL]
    has_spec = mats[mi, MAT_KS + 0] > 0.0 or mats[mi, MAT_KS + 1] > 0.0 or mats[mi, MAT_KS + 2] > 0.0
    each = per_light.shape[1] > 0
    for i in range(lights.shape[0]):
        shadow[i, y, x] = 1.0
        if each:
            for c in range(3):
                per_light[0, i, y, x, c] = 0.0
                per_light[1, i, y, x, c] = 0.0
        s, d, att, cone = _light_at(lights, i, hp.p, dmin, att_on)
        if d == 0.0 or cone == 0.0:
            continue
        ndots = dot(n, s)
        if ndots <= 0.0:
            continue
        if ndots > 1.0:
            ndots = 1.0
        if lights[i, LIGHT_SHADOWS] != 0.0 and handle != 0:
            target = (lights[i, LIGHT_VEC + 0], lights[i, LIGHT_VEC + 1], lights[i, LIGHT_VEC + 2])
            if _occluded(handle, S, hp.o, hp.g, s, target, d < np.inf, unit):
                # The variants' probe: blocked where a unit light would have reached it (float32).
                if np.float32(cone * ndots) > 0.0:
                    shadow[i, y, x] = 0.0
                continue
        att *= cone
        spec = 0.0
        if spec_on and has_spec:
            c = _specular_cosine(model, n, s, hp.v, ndots)
            if c > 0.0:
                spec = _power(min(c, 1.0), shin)
        ar = att * lights[i, LIGHT_RADIANCE + 0]
        ag = att * lights[i, LIGHT_RADIANCE + 1]
        ab = att * lights[i, LIGHT_RADIANCE + 2]
        dr += ar * (kdr * ndots)
        dg += ag * (kdg * ndots)
        db += ab * (kdb * ndots)
        sr += ar * (ksr * spec)
        sg += ag * (ksg * spec)
        sb += ab * (ksb * spec)
        if each:
            _store(per_light[0, i], y, x, ar * (kdr * ndots), ag * (kdg * ndots), ab * (kdb * ndots))
            _store(per_light[1, i], y, x, ar * (ksr * spec), ag * (ksg * spec), ab * (ksb * spec))
    _store(local[TERM_DIFFUSE], y, x, dr, dg, db)
    _store(local[TERM_SPECULAR], y, x, sr, sg, sb)


def _make_phong_terms(spec_on: bool, att_on: bool, tex_on: bool = False):
    """The Phong terms kernel for one variant (see :mod:`.jit`)."""

    @njit(parallel=True, **JIT)
    def _phong_terms_kernel(prim, geom, u, v, G, B, L, T, face_off, materials, cam, modes, local, per_light, shadow):
        """Every Phong pixel's terms (see the module docstring); misses get zero terms and an
        unshadowed mask."""
        uvs = B[0]
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in prange(nblk):
            blk = (it * step) % nblk
            for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
                S = _scratch()
                for x in range(w):
                    p = prim[y, x]
                    if p < 0 or modes[geom[y, x]] != METHOD_PHONG:
                        for k in range(local.shape[0]):
                            for c in range(3):
                                local[k, y, x, c] = 0.0
                        for i in range(shadow.shape[0]):
                            shadow[i, y, x] = 1.0
                            for k in range(per_light.shape[0] if per_light.shape[1] > 0 else 0):
                                for c in range(3):
                                    per_light[k, i, y, x, c] = 0.0
                        continue
                    gm = geom[y, x]
                    at = At(face_off[gm] + p, gm, np.float64(u[y, x]), np.float64(v[y, x]))
                    if tex_on:
                        coef = _point_coefficients(G, uvs, at, cam, x, y, True, materials, T)
                    else:
                        coef = _row_coefficients(materials, gm)
                    hp = _surface(G, B, cam, at, False, (0.0, 0.0, 0.0))
                    if L[3] != 0:  # shadow rays leave past the terminator, as _shade_surface's
                        verts, normals, faces, _ = G
                        o = _terminator_point(verts, normals, _triangle(faces, at.f), at.b1, at.b2, hp.p, hp.sgn)
                        hp = Hit(hp.p, hp.v, hp.g, hp.sgn, hp.n, o)
                    _illuminate_terms(hp, coef, materials, gm, L, S, spec_on, att_on, local, per_light, shadow, y, x)

    return _phong_terms_kernel


_PHONG_TERMS = compile_variants(_make_phong_terms)
