"""Phong shading: the reflectance equation at every pixel, at the true 3D hit
point, with the normal interpolated (``a = n1 + mu1 (n2 - n1) + mu2 (n3 - n1)``),
renormalised, and perturbed by the material's bump map or normal map if it has one.

Shadow rays leave the pixel's point, lifted past the terminator
(:func:`~raycast_shade.shading.surface._terminator_point`). Untextured frames without maps run
the batched kernel (:mod:`.phong_fast`), shadows or not. A textured or bump-mapped frame whose
lights cast shadows runs the packet kernel: it shades 4x4 tiles, first the tile's 16 shading
points (kept in the task's scratch) with their shadow rays asked for, then one
``rtcOccluded16`` per light for the tile, then the reflectance equation with those answers
(:mod:`.shadows`): the same rays, traced as coherent packets rather than one by one.

Speed notes. The kernels take the packed tuples of
:class:`~raycast_shade.shading.inputs.FrameInputs` and hand them whole to the
inlined helpers, which unpack them: the helpers are compiled without reference
counting (:data:`~raycast_shade.shading.jit.HELPER`). Unpacking a tuple of
arrays in the kernel's own loop would make Numba take and drop a reference on
every array for every pixel (atomic operations on counters that both threads
share), which cost more than the shading arithmetic (measured on a 1080p Phong
frame of an 81,920-triangle sphere on 2 cores: 36 ms with the unpacking in the
loop, 19 ms without, repeated squaring included).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import in_parts, share
from ..common.layout import MAT_REFLECTIVITY, METHOD_PHONG
from ..common.schedule import BLOCK_ROWS, spread_step
from .bump import _bump
from .illumination import _illuminate, _reflected, _request_shadows
from .normalmap import _normal_map
from .pixelstore import store_pixel
from .jit import HELPER, JIT, compile_variants
from .mirror_rays import hand_over
from .records import At, Hit
from ..visibility.secondary import ray_scratch, trace_occlusion
from .shadows import (LANES, _packets, clear_packets, store_coef, store_point, stored_coef, stored_material,
                      stored_point)
from .surface import _facing, _hit_point, _shading_normal, _terminator_point, _triangle, _view
from .texture import _point_coefficients, _row_coefficients

__all__ = []


@inline_jit(**HELPER)
def _surface(G, B, cam, at, use_dir, d):
    """The shading point of hit ``at`` (:class:`~raycast_shade.shading.records.At`).

    ``G`` and ``B`` are the geometry and height-map tuples of
    :class:`~raycast_shade.shading.inputs.FrameInputs`. The view vector is
    towards the eye, or ``-d`` for a secondary ray along ``d`` (``use_dir``).
    Returns a :class:`~raycast_shade.shading.records.Hit` with the oriented
    (and bumped) shading normal; its shadow origin is the point itself.
    """
    verts, normals, faces, fnormals = G
    f, gm, b1, b2 = at
    tri = _triangle(faces, f)
    p = _hit_point(verts, tri, b1, b2)
    if use_dir:
        v = (-d[0], -d[1], -d[2])
    else:
        v = _view(cam, p)
    g, sgn = _facing(fnormals, f, v)
    n = _shading_normal(normals, tri, b1, b2, g, sgn)
    n = _bump(n, B, at, tri, (sgn * g[0], sgn * g[1], sgn * g[2]))
    n = _normal_map(n, B, normals, at, tri, g, sgn, B.ext)
    return Hit(p, v, g, sgn, n, p)


@inline_jit(**HELPER)
def _shade_surface(G, B, L, S, materials, cam, at, use_dir, d, coef, spec_on, att_on):
    """Phong shading of hit ``at``: ``(rgb, hp)``, the colour and the shading point
    (:class:`~raycast_shade.shading.records.Hit`, for mirrors).

    ``G``, ``B``, ``L`` as in :class:`~raycast_shade.shading.inputs.FrameInputs`;
    ``S`` the shadow scratch; ``use_dir``, ``d`` as in :func:`_surface`; ``coef``:
    the point's nine ``ka, kd, ks`` (:mod:`.texture`)."""
    hp = _shading_point(G, B, L, cam, at, use_dir, d)
    return _illuminate(hp, coef, materials, at.gm, L, S, spec_on, att_on), hp


@inline_jit(**HELPER)
def _shading_point(G, B, L, cam, at, use_dir, d):
    """:func:`_surface`'s point with its shadow origin past the terminator when shadow rays will
    be traced (``L`` has a scene handle)."""
    return _lifted(G, L, at, _surface(G, B, cam, at, use_dir, d))


@inline_jit(**HELPER)
def _lifted(G, L, at, hp):
    """Shading point ``hp`` of hit ``at`` (:func:`_surface`'s) with its shadow origin past the
    terminator when shadow rays will be traced (``L`` has a scene handle)."""
    o = hp.p
    if L.handle != 0:  # shadow rays will be traced (a scene handle): start them past the terminator
        verts, normals, faces, _ = G
        o = _terminator_point(verts, normals, _triangle(faces, at.f), at.b1, at.b2, hp.p, hp.sgn)
    return Hit(hp.p, hp.v, hp.g, hp.sgn, hp.n, o)


def _make_phong(tex_on: bool = False):
    """The Phong pixel kernel for one variant (see :mod:`.jit`; ``tex_on``: textured coefficients)."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _shade_phong_kernel(hits, G, B, L, T, face_off, materials, cam, background, modes, outs, y0, part):
        """Phong: shade every pixel of the models whose method is METHOD_PHONG; array row ``r``
        is image row ``y0 + r`` (a band of the frame; textures need the image position).
        ``outs = (image, normal, rays)``: the (h, W, 3) float32 image, where to write each shaded
        pixel's shading normal (zero on the background; ``frame.normal``'s values, for the
        ``normal`` buffer), or a (0, 0, 3) array for none, and where to hand over the reflective
        pixels' mirror rays (:mod:`.mirror_rays`; ``NO_RAYS`` for none)."""
        prim, geom, u, v = hits  # the hit buffer's (h, W) arrays (once: not per pixel)
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        uvs = B.uvs
        image, normal, rays = outs
        want_n = normal.shape[0] != 0
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in range(*share(nblk, part)):  # this part's blocks of rows, in a balanced order
            blk = (it * step) % nblk
            for y in range(blk * BLOCK_ROWS, min(h, (blk + 1) * BLOCK_ROWS)):
                S = ray_scratch()
                for x in range(w):
                    p = prim[y, x]
                    if p < 0:
                        for c in range(3):
                            image[y, x, c] = background[c]
                            if want_n:
                                normal[y, x, c] = 0.0
                        continue
                    gm = geom[y, x]
                    if modes[gm] != METHOD_PHONG:
                        continue
                    at = At(face_off[gm] + p, gm, np.float64(u[y, x]), np.float64(v[y, x]))
                    if tex_on:
                        coef = _point_coefficients(G, uvs, at, cam, x, y0 + y, True, materials, T)
                    else:
                        coef = _row_coefficients(materials, gm)
                    rgb, hp = _shade_surface(G, B, L, S, materials, cam, at, np.bool_(False), (0.0, 0.0, 0.0), coef,
                                             spec_on, att_on)
                    store_pixel((image, normal), y, x, rgb, hp.n)
                    hand_over(rays, y, x, hp, materials[gm, MAT_REFLECTIVITY], L.unit)

    return _shade_phong_kernel


_PHONG = compile_variants(_make_phong)  # the family's registry (see .jit)

_TILE = 4  # a packet is a 4x4 tile of pixels (LANES); BLOCK_ROWS is a multiple of it


def _make_phong_packets(tex_on: bool = False):
    """The Phong pixel kernel with shadow packets, for one variant (see :mod:`.jit`)."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _shade_phong_packets_kernel(hits, G, B, L, T, face_off, materials, cam, background, modes, outs,
                                    y0, part):
        """:func:`_make_phong`'s kernel, its shadow rays traced per 4x4 tile of pixels as one
        16-ray packet per light: the same image (and shading normals and mirror rays in ``outs``),
        bit for bit."""
        prim, geom, u, v = hits  # the hit buffer's (h, W) arrays (once: not per pixel)
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        uvs = B.uvs
        image, normal, rays = outs
        want_n = normal.shape[0] != 0
        handle = L.handle
        h, w = prim.shape
        nblk = (h + BLOCK_ROWS - 1) // BLOCK_ROWS
        step = spread_step(nblk)
        for it in range(*share(nblk, part)):  # this part's blocks of rows, in a balanced order
            blk = (it * step) % nblk
            S = ray_scratch()  # a single ray, should a point ask for one its tile did not trace
            buf, ib, off, valid, voff, args, aoff, vis, points = _packets(L.lights.shape[0])
            P = (buf, ib, off, valid, voff)
            ye = min(h, (blk + 1) * BLOCK_ROWS)
            for ty in range(blk * BLOCK_ROWS, ye, _TILE):
                for tx in range(0, w, _TILE):
                    clear_packets(valid, voff, vis, points)
                    for k in range(LANES):  # the tile's points, and their shadow rays asked for
                        x = tx + k % _TILE
                        y = ty + k // _TILE
                        if x >= w or y >= ye:
                            continue
                        p = prim[y, x]
                        if p < 0:
                            for c in range(3):
                                image[y, x, c] = background[c]
                                if want_n:
                                    normal[y, x, c] = 0.0
                            continue
                        gm = geom[y, x]
                        if modes[gm] != METHOD_PHONG:
                            continue
                        at = At(face_off[gm] + p, gm, np.float64(u[y, x]), np.float64(v[y, x]))
                        if tex_on:
                            store_coef(points, k, _point_coefficients(G, uvs, at, cam, x, y0 + y, True, materials, T))
                        hp = _shading_point(G, B, L, cam, at, np.bool_(False), (0.0, 0.0, 0.0))
                        store_point(points, k, hp, gm)
                        hand_over(rays, y, x, hp, materials[gm, MAT_REFLECTIVITY], L.unit)
                        _request_shadows(P, k, hp, L)
                    trace_occlusion(handle, buf, off, valid, voff, args, aoff, vis)
                    for k in range(LANES):  # the tile's colours
                        gm = stored_material(points, k)
                        if gm < 0:  # background, another method's model, or outside the image
                            continue
                        pp, vv, gg, sg, nn, oo = stored_point(points, k)
                        coef = stored_coef(points, k) if tex_on else _row_coefficients(materials, gm)
                        rgb = _reflected(Hit(pp, vv, gg, sg, nn, oo), coef, materials, gm, L, S, vis, k,
                                         spec_on, att_on, None, 0, 0, L.ext)
                        store_pixel((image, normal), ty + k // _TILE, tx + k % _TILE, rgb, nn)

    return _shade_phong_packets_kernel


_PHONG_PACKETS = compile_variants(_make_phong_packets)  # the family's registry (see .jit)
