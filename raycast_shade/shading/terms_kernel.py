"""The terms in the shading pass itself: each point's equation evaluated once, the image and
its parts stored together.

:func:`_illuminate_terms` is the one evaluator,
:func:`~raycast_shade.shading.illumination._reflected`, given a terms record: each part is also
accumulated apart and stored in its own output, and the summed colour is the one the plain
frame's kernels get from the same function, so the image a terms pass writes is the plain
frame's, bit for bit. The
kernels below write the image and the terms of their method's pixels in one pass, where the
variant passes of :mod:`.terms` would shade the frame once per term, per light and per shadow
probe. ``R``, the terms record every kernel writes into, is the flat tuple
``(ambient, diffuse, specular, emissive, background, per_light, shadow, emit_on, bg_on, rgb)``
(``rgb`` the scene's background, (3,) float64; slots :data:`TERM_SLOTS`, then ``TERMS_*``):

==========================  ===================================================================
output                      per point
==========================  ===================================================================
``ambient``                 ``Ia ka``, (H, W, 3) float32 (as the next four)
``diffuse``                 ``sum_i vis_i att_i Ii kd (n.s_i)``
``specular``                ``sum_i vis_i att_i Ii Ks spec_i``
``emissive``                ``ke``, the point's emission (written only with ``emit_on``)
``background``             the scene's background where nothing is seen, else 0 (written
                            only with ``bg_on``)
``per_light[0, i]``         light ``i``'s diffuse part (``per_light[1, i]`` its specular),
                            (2, L, H, W, 3) float32, or (2, 0, ...): none
``shadow[i]``               0 where light ``i``'s shadow ray is blocked (and the light would
                            reach the point), else 1, (L, H, W) float32
==========================  ===================================================================

A term not written (no emission, a black background) is a zero array nobody touches: its
pages are never faulted in. ``ka, kd, Ks`` are the point's (maps, colours: :mod:`.texture`),
as the variants' are: the equation is linear in them.

The kernels take the frame's full-size term arrays and write the rows ``y0 + y`` of a band's
row ``y`` (the whole frame: ``y0 = 0``), so the banded renderer and the whole-frame one run the
same compiled kernels. Flat shading stores each visible face's terms once, in face-sized arrays
of the same layout (``(F, 1, 3)``: row ``f``, column 0), and its pixel kernel copies them
(:func:`_face_terms`); its kernels are :mod:`.flat`'s, built with ``terms_on``. The batched
Phong kernel (:mod:`.phong_fast`) writes the same terms where it applies (its lanes':
:func:`_scatter_terms`).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import in_parts, share
from ..common.layout import METHOD_PHONG
from ..common.schedule import BLOCK_ROWS, spread_step
from .illumination import _reflected
from .jit import FLT32_MAX, HELPER, JIT, compile_variants
from .lanes import _KA, _KE, _TD, _TS, LANES
from .phong import _surface
from .records import (TERM_AMBIENT, TERM_BACKGROUND, TERM_DIFFUSE, TERM_EMISSIVE, TERM_SLOTS, TERM_SPECULAR,
                      TERMS_BACKGROUND_RGB, TERMS_BG_ON, TERMS_EACH, TERMS_EMIT_ON, TERMS_SHADOW, At, Hit, store3)
from ..visibility.secondary import ray_scratch
from .surface import _terminator_point, _triangle
from .texture import _point_coefficients, _row_coefficients

__all__ = ["TERM_AMBIENT", "TERM_DIFFUSE", "TERM_SPECULAR", "TERM_EMISSIVE", "TERM_BACKGROUND", "TERM_SLOTS",
           "TERMS_EACH", "TERMS_SHADOW", "TERMS_EMIT_ON", "TERMS_BG_ON", "TERMS_BACKGROUND_RGB"]

_store = store3  # the name the terms kernels have used


@inline_jit(**HELPER)
def _illuminate_terms(hp, coef, mats, mi, L, S, spec_on, att_on, R, y, x):
    """:func:`~raycast_shade.shading.illumination._reflected` at ``hp`` with the terms record ``R``:
    the same RGB (the same evaluator), its parts also stored at ``(y, x)`` of ``R`` (see the
    module docstring); shadow rays traced one at a time."""
    return _reflected(hp, coef, mats, mi, L, S, L.no_vis, np.int64(-1), spec_on, att_on, R, y, x, L.ext)


@inline_jit(**HELPER)
def _miss(image, R, y, ty, x):
    """A pixel that sees nothing: the background into ``image`` row ``y``; zero terms, the
    background term and an unshadowed mask into ``R`` at row ``ty``."""
    per_light, shadow, background = R[TERMS_EACH], R[TERMS_SHADOW], R[TERMS_BACKGROUND_RGB]
    for c in range(3):
        image[y, x, c] = background[c]
        R[TERM_AMBIENT][ty, x, c] = 0.0
        R[TERM_DIFFUSE][ty, x, c] = 0.0
        R[TERM_SPECULAR][ty, x, c] = 0.0
        if R[TERMS_EMIT_ON]:
            R[TERM_EMISSIVE][ty, x, c] = 0.0
        if R[TERMS_BG_ON]:
            R[TERM_BACKGROUND][ty, x, c] = background[c]
    for i in range(shadow.shape[0]):
        shadow[i, ty, x] = 1.0
        if per_light.shape[1] > 0:
            for c in range(3):
                per_light[0, i, ty, x, c] = 0.0
                per_light[1, i, ty, x, c] = 0.0


@inline_jit(**HELPER)
def _hit_background(R, y, x):
    """A seen pixel's zero background term (when the background term is written at all)."""
    if R[TERMS_BG_ON]:
        for c in range(3):
            R[TERM_BACKGROUND][y, x, c] = 0.0


@inline_jit(**HELPER)
def _scatter_terms(S, XY, n, R, y0, ambient):
    """Write the first ``n`` lanes' terms to the terms record ``R`` at rows ``y0 + y``: ambient
    ``Ia ka``, the summed diffuse and specular parts, the emission (with ``emit_on``), a zero
    background term (with ``bg_on``) and an unshadowed mask (no light casts shadows here)."""
    shadow = R[TERMS_SHADOW]
    for k in range(n):
        ty = y0 + XY[k]
        x = XY[LANES + k]
        _store(R[TERM_AMBIENT], ty, x, ambient[0] * S[(_KA + 0) * LANES + k], ambient[1] * S[(_KA + 1) * LANES + k],
               ambient[2] * S[(_KA + 2) * LANES + k])
        _store(R[TERM_DIFFUSE], ty, x, S[(_TD + 0) * LANES + k], S[(_TD + 1) * LANES + k], S[(_TD + 2) * LANES + k])
        _store(R[TERM_SPECULAR], ty, x, S[(_TS + 0) * LANES + k], S[(_TS + 1) * LANES + k], S[(_TS + 2) * LANES + k])
        if R[TERMS_EMIT_ON]:
            _store(R[TERM_EMISSIVE], ty, x, S[(_KE + 0) * LANES + k], S[(_KE + 1) * LANES + k],
                   S[(_KE + 2) * LANES + k])
        _hit_background(R, ty, x)
        for i in range(shadow.shape[0]):
            shadow[i, ty, x] = 1.0


def _make_phong_terms(tex_on: bool = False):
    """The Phong image-and-terms kernel for one variant (see :mod:`.jit`)."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _phong_terms_kernel(hits, G, B, L, T, face_off, materials, cam, modes, image, y0, R, part):
        """Every Phong pixel's colour into ``image`` (the band's rows) and its terms into ``R``
        at row ``y0 + y`` (see the module docstring); misses get the background, zero terms
        and an unshadowed mask."""
        prim, geom, u, v = hits  # the hit buffer's (h, W) arrays (once: not per pixel)
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        uvs = B.uvs
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in range(*share(nblk, part)):  # this part's share (common.parallel)
            blk = (it * step) % nblk
            for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
                S = ray_scratch()
                ty = y0 + y
                for x in range(w):
                    p = prim[y, x]
                    if p < 0:
                        _miss(image, R, y, ty, x)
                        continue
                    gm = geom[y, x]
                    if modes[gm] != METHOD_PHONG:
                        continue
                    at = At(face_off[gm] + p, gm, np.float64(u[y, x]), np.float64(v[y, x]))
                    if tex_on:
                        coef = _point_coefficients(G, uvs, at, cam, x, ty, True, materials, T)
                    else:
                        coef = _row_coefficients(materials, gm)
                    hp = _surface(G, B, cam, at, np.bool_(False), (0.0, 0.0, 0.0))
                    if L.handle != 0:  # shadow rays leave past the terminator, as _shade_surface's
                        verts, normals, faces, _ = G
                        o = _terminator_point(verts, normals, _triangle(faces, at.f), at.b1, at.b2, hp.p, hp.sgn)
                        hp = Hit(hp.p, hp.v, hp.g, hp.sgn, hp.n, o)
                    rgb = _illuminate_terms(hp, coef, materials, gm, L, S, spec_on, att_on, R, ty, x)
                    _hit_background(R, ty, x)
                    image[y, x, 0] = min(rgb[0], FLT32_MAX)
                    image[y, x, 1] = min(rgb[1], FLT32_MAX)
                    image[y, x, 2] = min(rgb[2], FLT32_MAX)

    return _phong_terms_kernel


@inline_jit(**HELPER)
def _face_terms(R, F, f, ty, x):
    """Face ``f``'s terms (row ``f`` of the face record ``F``) into ``R`` at ``(ty, x)``."""
    per_light, shadow = R[TERMS_EACH], R[TERMS_SHADOW]
    fper, fshadow = F[TERMS_EACH], F[TERMS_SHADOW]
    for c in range(3):
        R[TERM_AMBIENT][ty, x, c] = F[TERM_AMBIENT][f, 0, c]
        R[TERM_DIFFUSE][ty, x, c] = F[TERM_DIFFUSE][f, 0, c]
        R[TERM_SPECULAR][ty, x, c] = F[TERM_SPECULAR][f, 0, c]
        if R[TERMS_EMIT_ON]:
            R[TERM_EMISSIVE][ty, x, c] = F[TERM_EMISSIVE][f, 0, c]
    _hit_background(R, ty, x)
    for i in range(shadow.shape[0]):
        shadow[i, ty, x] = fshadow[i, f, 0]
        if per_light.shape[1] > 0:
            for c in range(3):
                per_light[0, i, ty, x, c] = fper[0, i, f, 0, c]
                per_light[1, i, ty, x, c] = fper[1, i, f, 0, c]


_PHONG_TERMS = compile_variants(_make_phong_terms)  # the family's registry (see .jit)
