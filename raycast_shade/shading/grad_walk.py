"""The points the gradient kernels walk, read once: pixels of the hit buffer, flat faces, Gouraud
vertices and corners.

Each gradient kernel (:mod:`.grad_frame`, :mod:`.grad_textured`, :mod:`.grad_maps`,
:mod:`.grad_bump`, :mod:`.grad_geometry`) visits the points where its method evaluates the
reflectance equation and skips the ones with nothing to add. These helpers say, for one point,
whether the kernel differentiates it and what it needs there (the hit, ``dL/dI``, the point lit);
the kernel keeps its loops and its own step. They are inlined
(:data:`~raycast_shade.shading.jit.HELPER`, :func:`~raycast_shade.common.inline.inline_jit`) and
compute what the kernels computed in place, with the same functions and expressions: the
gradients are the same, bit for bit. A point that is skipped comes back with a placeholder of the
same types (not to be read).

The geometry's pixel scatters (:func:`~.grad_geometry.pixels_scatter`,
:func:`~.grad_geotex.tex_pixels_scatter`) keep their own reads of the hit: read through a helper
like :func:`pixel_at` (placeholder and all), their code let LLVM fuse a multiply and an add
differently (``contract``), and their vertex gradients moved by an ulp."""

from __future__ import annotations

import numpy as np

from ..common.inline import inline_jit
from ..common.parallel import share
from .jit import CHUNK, HELPER
from .records import At, Hit, dot
from .surface import _convex_weights, _facing, _hit_point, _triangle, _view

__all__ = ["pixel_at", "pixel_dI", "pixel_grad", "triangle_points", "gouraud_pixel", "corner_hit",
           "corner_gather", "corner_normal_grad", "chunks", "chunk_items", "face_grad", "vertex_grad"]

_NONE3 = (0.0, 0.0, 0.0)


@inline_jit(**HELPER)
def pixel_at(hits, face_off, modes, method, y, x):
    """Pixel ``(y, x)`` of the hit buffer ``hits = (prim, geom, u, v)`` for a kernel of ``method``:
    ``(shaded, at)``, ``shaded`` False for a miss and for a pixel of a model whose ``modes`` entry
    is not ``method``; ``at`` the hit (:class:`~raycast_shade.shading.records.At`: packed face,
    model, barycentrics in float64)."""
    prim, geom, u, v = hits
    p = prim[y, x]
    gm = geom[y, x]
    if p < 0 or modes[gm] != method:
        return False, At(face_off[0] + p, gm, 0.0, 0.0)
    return True, At(face_off[gm] + p, gm, np.float64(u[y, x]), np.float64(v[y, x]))


@inline_jit(**HELPER)
def pixel_dI(gimg, y, x):
    """Pixel ``(y, x)``'s ``gI = dL/dI`` (three float64): ``(nonzero, gI)``; a zero one adds nothing."""
    gI = (np.float64(gimg[y, x, 0]), np.float64(gimg[y, x, 1]), np.float64(gimg[y, x, 2]))
    return not (gI[0] == 0.0 and gI[1] == 0.0 and gI[2] == 0.0), gI


@inline_jit(**HELPER)
def pixel_grad(hits, face_off, modes, method, gimg, y, x):
    """:func:`pixel_at` and :func:`pixel_dI`: ``(shaded, at, gI)``, not shaded where either says so."""
    shaded, at = pixel_at(hits, face_off, modes, method, y, x)
    if not shaded:
        return False, at, _NONE3
    nonzero, gI = pixel_dI(gimg, y, x)
    return nonzero, at, gI


@inline_jit(**HELPER)
def triangle_points(verts, tri):
    """The triangle ``tri``'s three vertices ``(P0, P1, P2)``, 3-tuples."""
    i0, i1, i2 = tri
    return ((verts[i0, 0], verts[i0, 1], verts[i0, 2]), (verts[i1, 0], verts[i1, 1], verts[i1, 2]),
            (verts[i2, 0], verts[i2, 1], verts[i2, 2]))


@inline_jit(**HELPER)
def gouraud_pixel(G, cam, at):
    """A Gouraud pixel's corners as the forward pass interpolates them: ``(tri, gn, side, wts)``,
    its triangle's vertices, the face normal turned to the viewer, the side it is lit from (0 front,
    1 back) and the corners' weights (:func:`~raycast_shade.shading.surface._convex_weights`)."""
    tri = _triangle(G.faces, at.f)
    gn, sgn = _facing(G.face_normals, at.f, _view(cam, _hit_point(G.verts, tri, at.b1, at.b2)))
    return tri, gn, 0 if sgn > 0.0 else 1, _convex_weights(at.b1, at.b2)


@inline_jit(**HELPER)
def corner_hit(G, cam, i, side, gn):
    """The point a Gouraud corner is lit at (:func:`~raycast_shade.shading.gouraud._corner_normal`):
    vertex ``i`` with its normal from ``side``, the stored shade's (``True``), or shaded on the spot
    with the face's normal ``gn`` (a zero normal) or its normal reflected across the face's plane."""
    verts, normals, _, _ = G
    sg = 1.0 - 2.0 * side
    n = (sg * normals[i, 0], sg * normals[i, 1], sg * normals[i, 2])
    p = (verts[i, 0], verts[i, 1], verts[i, 2])
    view = _view(cam, p)
    if n[0] == 0.0 and n[1] == 0.0 and n[2] == 0.0:
        return Hit(p, view, gn, 1.0, gn, p), False
    c = dot(n, gn)
    if c < 0.0:
        return Hit(p, view, gn, 1.0, (n[0] - 2.0 * c * gn[0], n[1] - 2.0 * c * gn[1], n[2] - 2.0 * c * gn[2]), p), False
    return Hit(p, view, n, 1.0, n, p), True


@inline_jit(**HELPER)
def corner_gather(G, cam, gimg, y, x, i, wk, side, gn, gvert):
    """Corner ``i`` (weight ``wk``) of Gouraud pixel ``(y, x)`` lit from ``side``: ``(spot, hp, gI)``,
    ``gI`` its share ``wk dL/dI`` of the pixel's. A corner with a stored shade (:func:`corner_hit`)
    has its share added onto ``gvert[i, side]`` (V, 2, 3) here; one shaded on the spot (``spot``)
    is the caller's to differentiate at ``hp``."""
    gI = (wk * gimg[y, x, 0], wk * gimg[y, x, 1], wk * gimg[y, x, 2])
    hp, stored = corner_hit(G, cam, i, side, gn)
    if stored:
        for c in range(3):
            gvert[i, side, c] += gI[c]
    return not stored, hp, gI


@inline_jit(**HELPER)
def corner_normal_grad(G, i, side, gn, gr0, gnormals):
    """``gnormals[i] +=`` the vertex normal's share of ``dL/dn`` ``gr0`` at a corner lit from ``side``
    (:func:`corner_hit`'s point: none for a zero normal, which borrows the face's; through the
    reflection across the face's plane for one turned away)."""
    normals = G.normals
    sg = 1.0 - 2.0 * side
    n = (sg * normals[i, 0], sg * normals[i, 1], sg * normals[i, 2])
    if n[0] == 0.0 and n[1] == 0.0 and n[2] == 0.0:
        return
    q = 0.0
    if dot(n, gn) < 0.0:
        q = 2.0 * dot(gr0, gn)
    for c in range(3):
        gnormals[i, c] += sg * (gr0[c] - q * gn[c])


@inline_jit(**HELPER)
def chunks(n, part):
    """The chunks of :data:`~raycast_shade.shading.jit.CHUNK` items of ``0 .. n`` that ``part`` runs
    (:func:`~raycast_shade.common.parallel.share` of them): ``range(*chunks(n, part))``."""
    return share((n + CHUNK - 1) // CHUNK, part)


@inline_jit(**HELPER)
def chunk_items(n, ch):
    """The items of chunk ``ch`` of ``0 .. n``: ``range(*chunk_items(n, ch))``."""
    return ch * CHUNK, min(n, (ch + 1) * CHUNK)


@inline_jit(**HELPER)
def face_grad(G, cam, gface, f):
    """Flat face ``f`` as the forward pass shades it (its centre, its true normal turned to the
    viewer): ``(shaded, hp, gI)`` with ``gI`` its pixels' summed ``dL/dI`` (``gface`` (F, 3)), not
    shaded where that is zero."""
    verts, _, faces, fnormals = G
    gI = (gface[f, 0], gface[f, 1], gface[f, 2])
    if gI[0] == 0.0 and gI[1] == 0.0 and gI[2] == 0.0:
        return False, Hit(_NONE3, _NONE3, _NONE3, 1.0, _NONE3, _NONE3), gI
    third = 1.0 / 3.0
    p = _hit_point(verts, _triangle(faces, f), third, third)
    vv = _view(cam, p)
    gn, sgn = _facing(fnormals, f, vv)
    return True, Hit(p, vv, gn, sgn, gn, p), gI


@inline_jit(**HELPER)
def vertex_grad(G, cam, gvert, i, side):
    """Gouraud vertex ``i`` lit from ``side`` as the forward pass stores its shade (its own normal,
    negated for the back): ``(shaded, hp, gI)`` with ``gI`` the side's gathered ``dL/dI``
    (``gvert`` (V, 2, 3)), not shaded where that is zero."""
    verts, normals, _, _ = G
    gI = (gvert[i, side, 0], gvert[i, side, 1], gvert[i, side, 2])
    if gI[0] == 0.0 and gI[1] == 0.0 and gI[2] == 0.0:
        return False, Hit(_NONE3, _NONE3, _NONE3, 1.0, _NONE3, _NONE3), gI
    sg = 1.0 - 2.0 * side
    p = (verts[i, 0], verts[i, 1], verts[i, 2])
    nv = (sg * normals[i, 0], sg * normals[i, 1], sg * normals[i, 2])
    return True, Hit(p, _view(cam, p), nv, 1.0, nv, p), gI
