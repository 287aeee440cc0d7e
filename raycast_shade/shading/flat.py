"""Flat shading: the reflectance equation once per triangle, at its centre,
with its true (geometric) normal; every pixel of the triangle takes that shade.

Only the faces some pixel sees are shaded (:func:`.shade._visible_kernel`
marks them); the shadow ray of a face leaves its centre.

Each kernel comes in two builds from one body: the plain one, and with ``terms_on`` the one
``render(terms=True)`` runs (:mod:`.termshade`), which also stores each face's terms
(:func:`~raycast_shade.shading.terms_kernel._illuminate_terms`, the same colour bit for bit)
and copies them to its pixels. The flag is a closure constant: Numba drops the other build's
branches before typing, so the plain kernels compile to what they were.
"""

from __future__ import annotations

from numba import njit

from ..common.parallel import in_parts, share
from ..common.layout import METHOD_FLAT
from ..common.schedule import spread_step
from .illumination import _illuminate
from .jit import CHUNK, FLT32_MAX, JIT, compile_variants
from .records import At, Hit
from ..visibility.secondary import ray_scratch
from .surface import _facing, _hit_point, _triangle, _view
from .terms_kernel import _face_terms, _illuminate_terms, _miss
from .texture import _coefficients, _face_footprint, _row_coefficients

__all__ = []


def _make_flat(tex_on: bool = False, terms_on: bool = False):
    """The per-face kernel for one variant (see :mod:`.jit`); ``tex_on``: the
    face's coefficients come from its colours and maps (:mod:`.texture`); ``terms_on``: the
    build that also stores each face's terms."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _shade_faces_kernel(face_flags, G, face_model, materials, cam, L, T, uvs, out, part):
        """Flat shading: one shade per visible face, at its centre.

        ``G``, ``L`` and ``T`` as in :class:`~raycast_shade.shading.inputs.FrameInputs`;
        ``out`` (F, 3) float64 (the terms build: ``(out, F)``, each face's terms into the
        face-sized terms record ``F`` at row ``f``, :mod:`.terms_kernel`). A textured face
        takes the texel at its centre from the mip level whose texels are as large as the
        face's UV triangle: the face's average colour, one shade per polygon."""
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        if terms_on:  # a closure constant: the other build's branches are dropped before typing
            fcol, F = out
        else:
            fcol = out
        verts, _, faces, fnormals = G
        n = faces.shape[0]
        nchunk = (n + CHUNK - 1) // CHUNK
        step = spread_step(nchunk)
        for it in range(*share(nchunk, part)):  # this part's chunks, in a balanced order
            c = (it * step) % nchunk
            S = ray_scratch()
            for f in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                if face_flags[f] == 0:
                    continue
                third = 1.0 / 3.0
                tri = _triangle(faces, f)
                p = _hit_point(verts, tri, third, third)
                v = _view(cam, p)
                gn, sgn = _facing(fnormals, f, v)
                m = face_model[f]
                if tex_on:
                    coef = _coefficients(materials, T, At(f, m, third, third), tri, uvs, _face_footprint(uvs, tri))
                else:
                    coef = _row_coefficients(materials, m)
                # The face's centre, lit with its true normal; shadow rays leave the centre.
                hp = Hit(p, v, gn, sgn, gn, p)
                if terms_on:
                    r, g, b = _illuminate_terms(hp, coef, materials, m, L, S, spec_on, att_on, F, f, 0)
                else:
                    r, g, b = _illuminate(hp, coef, materials, m, L, S, spec_on, att_on)
                fcol[f, 0] = r
                fcol[f, 1] = g
                fcol[f, 2] = b

    return _shade_faces_kernel


_FLAT = compile_variants(_make_flat)  # the families' registries (see .jit)
_FLAT_TERMS = compile_variants(lambda tex_on: _make_flat(tex_on, True))


def _make_lookup(terms_on: bool):
    """The flat pixel kernel; ``terms_on``: the build that also copies each pixel's face terms."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _lookup_flat_kernel(prim, geom, face_off, fcol, background, modes, image, part):
        """Flat: each pixel of the models whose method is METHOD_FLAT takes its face's shade.
        The terms build's ``image`` is ``(image, y0, R, F)``: also the face's terms (the face
        record ``F``) into the frame's terms record ``R`` at row ``y0 + y``, and zero terms on
        the background (records travel whole into the helpers: Numba's parallel loops do not
        take a tuple of arrays unpacked from one)."""
        if terms_on:
            img, y0, R, F = image
        else:
            img = image
        h, w = prim.shape
        for y in range(*share(h, part)):  # this part's share (common.parallel)
            for x in range(w):
                p = prim[y, x]
                if p < 0:
                    if terms_on:
                        _miss(img, R, y, y0 + y, x)  # the background too
                    else:
                        for c in range(3):
                            img[y, x, c] = background[c]
                    continue
                g = geom[y, x]
                if modes[g] != METHOD_FLAT:
                    continue
                f = face_off[g] + p
                for c in range(3):
                    img[y, x, c] = min(fcol[f, c], FLT32_MAX)
                if terms_on:
                    _face_terms(R, F, f, y0 + y, x)

    return _lookup_flat_kernel


_lookup_flat_kernel = _make_lookup(False)
_lookup_flat_terms = _make_lookup(True)
