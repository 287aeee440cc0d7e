"""Mirror reflections: rays from reflective pixels, Phong-shaded at every bounce.

A reflective pixel becomes ``(1 - rho) local + rho reflected``. Mirror rays
start from the hit pushed off the surface as shadow rays do
(:func:`~raycast_shade.shading.shadows._nudge`). One kernel does it all: the
reflective pixels of a 4x4 tile become the lanes of one ``rtcIntersect16``
packet (neighbours on a smooth mirror reflect in nearly parallel directions,
so Embree traces them as one coherent packet, about 3x faster than one ray at
a time), each bounce is Phong-shaded and blended into its pixel as soon as it
returns, and the lanes that meet another mirror bounce on in the same packet. The gathers of the
tiles a few steps ahead are prefetched on a large mesh (there each pixel's face and vertices miss the
caches, and one pixel's arithmetic is too long for the processor to overlap the next one's misses).
When every reflective model is Phong-shaded, the Phong kernel that shaded the pixels has handed
each reflective pixel's first ray over (:mod:`.mirror_rays`) and the lanes start from those
(:func:`_take_handed`: no gather). Otherwise, without bump or normal maps, the lanes of four tiles
start together, their points and normals by the batched Phong kernel's vectorised passes
(:func:`_start_group`).
``render`` runs it band by band, after each band is shaded.
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.parallel import in_parts, share
from ..common.layout import MAT_REFLECTIVITY
from ..common.prefetch import beyond_caches, prefetch
from ..common.schedule import BLOCK_ROWS, spread_step
from ..visibility import embree
from ..visibility.accel import embree_accel
from ..visibility.secondary import closest_hit, closest_packet, ray_scratch, set_closest_rays, trace_closest
from .inputs import prepare
from .jit import FLT32_MAX, HELPER, JIT, compile_variants, variant
from .illumination import _illuminate
from .phong import _lifted, _surface
from .lanes import _A, _B1, _B2, _FIELDS, _FN, _KD, LANES as _BATCH
from .mirror_rays import NO_RAYS, _mirror_ray, lane_rays
from .phong_fast import _flat_mesh, _gather, _geometry
from .records import At
from .texture import _point_coefficients, _row_coefficients

__all__ = ["trace_mirrors", "MAX_MIRROR_DEPTH"]

# Bounces per primary ray. A camera inside a closed perfect mirror bounces every ray that many
# times; the bound keeps such a frame finite (64 bounces of a 1080p frame: seconds, not forever).
MAX_MIRROR_DEPTH = 64
# A reflected ray whose weight (the product of the reflectivities it met) is under float32's
# resolution changes its pixel by less than one part in 2**24 of its colour: it stops.
_MIN_WEIGHT = 2.0 ** -24
_LANES = 16  # rays a packet (rtcIntersect16): the mirror pixels of a 4x4 tile
_TILE = 4
assert BLOCK_ROWS % _TILE == 0
# RTCIntersectArguments flags of the mirror packets.
MIRROR_FLAGS = embree.RAY_QUERY_FLAG_COHERENT
# Tiles ahead of the one being started whose faces (then vertices) are prefetched: on a large
# mesh each reflective pixel's gathers miss the caches (measured, 1.31 M triangles at 640x480:
# starting the lanes took 32 ms, 16 ms with these distances, 18 ms with 2 and 1).
_AHEAD_FACES = 4
_AHEAD_VERTS = 2


@inline_jit(**HELPER)
def _prefetch_tile(prim, geom, G, face_off, ya, yb, x0, x1, deep):
    """Prefetch what the pixel-by-pixel start gathers (:func:`_pixel_at`, then ``_surface`` at the
    kernel's depth 0) for the hit pixels of rows ``ya .. yb`` and columns ``x0 .. x1``: their
    faces' rows, or (``deep``, once the faces have arrived) their vertices, vertex normals and face
    normals."""
    verts, normals, faces, fnormals = G
    for y in range(ya, yb):
        for x in range(x0, x1):
            p = prim[y, x]
            if p >= 0:
                f = face_off[geom[y, x]] + p
                if deep:
                    for c in range(3):
                        i = faces[f, c]
                        prefetch(verts, i)
                        prefetch(normals, i)
                    prefetch(fnormals, f)
                else:
                    prefetch(faces, f)


# The blends, in plain IEEE arithmetic (no fast-math, so no fused multiply-add even when LLVM
# inlines them into the fast-math packet kernel: an instruction keeps its own flags), the same
# operations as the NumPy expressions they once replaced.
_PLAIN = dict(cache=True, forceinline=True, _nrt=False)


@inline_jit(**_PLAIN)
def _keep_pixel(image, y, x, rho):
    """``image[y, x] *= float32(1 - rho)``: a mirror pixel keeps ``1 - rho`` of its local shade."""
    keep = np.float32(1.0 - rho)
    for c in range(3):
        image[y, x, c] = image[y, x, c] * keep


@inline_jit(**_PLAIN)
def _add_pixel(image, y, x, weight, c0, c1, c2):
    """``image[y, x] = float32(min(image[y, x] + weight colour, FLT32_MAX))``, in float64."""
    image[y, x, 0] = min(np.float64(image[y, x, 0]) + weight * c0, FLT32_MAX)
    image[y, x, 1] = min(np.float64(image[y, x, 1]) + weight * c1, FLT32_MAX)
    image[y, x, 2] = min(np.float64(image[y, x, 2]) + weight * c2, FLT32_MAX)


@inline_jit(**HELPER)
def _start_lane(hits, materials, image, y, x, lanes):
    """Pixel ``(y, x)`` of ``hits`` as the next lane of ``lanes`` = ``(n, ys, xs, weight, org, dr,
    act)`` when its surface reflects: weight ``rho``, its local shade scaled by ``1 - rho``; its
    mirror ray is made by the kernel's bounce loop at depth 0 (:func:`_lane_ray`). Returns the
    lanes now filled."""
    prim, geom, _, _ = hits
    n, ys, xs, weight, _, _, act = lanes
    p = prim[y, x]
    if p < 0 or materials[geom[y, x], MAT_REFLECTIVITY] <= 0.0:
        return n
    rho = materials[geom[y, x], MAT_REFLECTIVITY]
    _keep_pixel(image, y, x, rho)
    ys[n] = y
    xs[n] = x
    weight[n] = rho
    act[n] = True
    return n + 1


@inline_jit(**HELPER)
def _pixel_at(hits, face_off, y, x):
    """Where pixel ``(y, x)`` of ``hits`` lies (:class:`~raycast_shade.shading.records.At`)."""
    prim, geom, u, v = hits
    gm = geom[y, x]
    return At(face_off[gm] + prim[y, x], gm, np.float64(u[y, x]), np.float64(v[y, x]))


@inline_jit(**HELPER)
def _lane_ray(hp, unit, k, org, dr):
    """Lane ``k``'s mirror ray from its shading point ``hp``, into ``org`` and ``dr`` (3, 16)."""
    o, r = _mirror_ray(hp, unit)
    for c in range(3):
        org[c, k] = o[c]
        dr[c, k] = r[c]


@inline_jit(**HELPER)
def _add_lane(image, y, x, rho, ray, lanes):
    """Pixel ``(y, x)`` as lane ``n`` of ``lanes = (n, ys, xs, weight, org, dr, act)``: its mirror
    ``ray = (origin, direction)``, weight ``rho``, its local shade scaled by ``1 - rho``. Returns
    ``n + 1``."""
    n, ys, xs, weight, org, dr, act = lanes
    o, r = ray
    _keep_pixel(image, y, x, rho)
    ys[n] = y
    xs[n] = x
    weight[n] = rho
    act[n] = True
    for c in range(3):
        org[c, n] = o[c]
        dr[c, n] = r[c]
    return n + 1


_GROUP = _BATCH // _LANES  # tiles whose lanes _start_group starts together: one batch of the Phong passes


@inline_jit(**HELPER)
def _start_group(hits, GF, materials, face_off, cam, unit, image, box, F):
    """The reflective pixels of the :data:`_GROUP` tiles of rows ``box[0] .. box[1] - 1`` from column
    ``box[2]`` (to ``box[3]``), tile after tile, as the pixel-by-pixel start (:func:`_start_lane`, then
    the kernel's depth 0) starts them, bit for bit, for a frame without bump or normal maps: their points, view vectors and normals by the batched Phong
    kernel's passes (:func:`.phong_fast._gather`, :func:`.phong_fast._geometry`, which vectorise)
    over the scratch ``F = (S, XY)``, not pixel by pixel; ``GF``: the mesh's flat views
    (:func:`.phong_fast._flat_mesh`). Kept in ``F`` for :func:`_take_tile`: lane
    ``k``'s row and column in ``XY[k]``, ``XY[B + k]`` (``B`` lanes a field), tile ``j``'s lane count
    in ``XY[2 B + j]``, its weight in field ``_KD``, its ray's origin and direction in the fields
    ``_A`` and ``_FN`` (free once ``_geometry`` has run)."""
    prim, geom, u, v = hits
    S, XY = F
    n = np.int64(0)  # not the constant 0: type inference would first compile _gather for Literal[int](0)
    for j in range(_GROUP):
        n0 = n
        for y in range(box[0], box[1]):
            for x in range(min(box[2] + j * _TILE, box[3]), min(box[2] + (j + 1) * _TILE, box[3])):
                p = prim[y, x]
                if p < 0 or materials[geom[y, x], MAT_REFLECTIVITY] <= 0.0:
                    continue
                gm = geom[y, x]
                rho = materials[gm, MAT_REFLECTIVITY]
                _keep_pixel(image, y, x, rho)
                S[_B1 * _BATCH + n] = u[y, x]
                S[_B2 * _BATCH + n] = v[y, x]
                S[_KD * _BATCH + n] = rho
                XY[n] = y
                XY[_BATCH + n] = x
                XY[3 * _BATCH + n] = face_off[gm] + p
                n += 1
        XY[2 * _BATCH + j] = n - n0
    if n == 0:
        return
    _gather(S, XY, n, GF, False)
    _geometry(S, cam, (0.0, 0.0, 0.0))
    lane_rays(S, n, unit)


@inline_jit(**HELPER)
def _take_tile(F, j, lanes):
    """Tile ``j`` of the group :func:`_start_group` started, as the lanes of ``lanes = (n, ys, xs,
    weight, org, dr, act)`` from 0 (as the pixel-by-pixel start fills them). Returns the lanes filled."""
    _, ys, xs, weight, org, dr, act = lanes
    S, XY = F
    b = 0
    for i in range(j):
        b += XY[2 * _BATCH + i]
    n = XY[2 * _BATCH + j]
    for k in range(n):
        ys[k] = XY[b + k]
        xs[k] = XY[_BATCH + b + k]
        weight[k] = S[_KD * _BATCH + b + k]
        act[k] = True
        for c in range(3):
            org[c, k] = S[(_A + c) * _BATCH + b + k]
            dr[c, k] = S[(_FN + c) * _BATCH + b + k]
    return n


@inline_jit(**HELPER)
def _take_handed(hits, materials, image, rays, box, lanes):
    """The reflective pixels of rows ``box[0] .. box[1] - 1`` and columns ``box[2] .. box[3] - 1`` (a
    tile) as the lanes of ``lanes = (n, ys, xs, weight, org, dr, act)`` from 0, as the pixel-by-pixel
    start fills them, their rays read from ``rays`` (:mod:`.mirror_rays`: the Phong kernel handed them
    over as it shaded the pixels). Returns the lanes filled."""
    prim, geom, _, _ = hits
    given_org, given_dr = rays
    _, ys, xs, weight, org, dr, act = lanes
    n = np.int64(0)  # not 0: _add_lane would compile for Literal[int](0) first, then int64
    for y in range(box[0], box[1]):
        for x in range(box[2], box[3]):
            if prim[y, x] < 0:
                continue
            rho = materials[geom[y, x], MAT_REFLECTIVITY]
            if rho <= 0.0:
                continue
            ray = ((np.float64(given_org[y, x, 0]), np.float64(given_org[y, x, 1]), np.float64(given_org[y, x, 2])),
                   (given_dr[y, x, 0], given_dr[y, x, 1], given_dr[y, x, 2]))
            n = _add_lane(image, y, x, rho, ray, (n, ys, xs, weight, org, dr, act))
    return n


@inline_jit(**HELPER)
def _prefetch_ahead(prim, geom, G, face_off, rows, w, tx, batched):
    """Prefetch the gathers of the tiles ahead of tile ``tx`` (rows ``rows = (ya, yb)``) so that their
    cache misses overlap: faces :data:`_AHEAD_FACES` tiles ahead, then (``deep``) their vertices
    :data:`_AHEAD_VERTS` ahead; ``batched`` (:func:`_start_group`), a group's at its first tile: the
    group after next's faces and the next group's vertices."""
    ntx = (w + _TILE - 1) // _TILE
    ya, yb = rows
    shallow, deep = np.bool_(False), np.bool_(True)  # not the constants: one compile of _prefetch_tile, not two
    if batched:
        if tx % _GROUP != 0:
            return
        for j in range(_GROUP):
            t2 = tx + 2 * _GROUP + j
            if t2 < ntx:
                _prefetch_tile(prim, geom, G, face_off, ya, yb, t2 * _TILE, min(w, (t2 + 1) * _TILE), shallow)
            t1 = tx + _GROUP + j
            if t1 < ntx:
                _prefetch_tile(prim, geom, G, face_off, ya, yb, t1 * _TILE, min(w, (t1 + 1) * _TILE), deep)
        return
    t2 = tx + _AHEAD_FACES
    if t2 < ntx:
        _prefetch_tile(prim, geom, G, face_off, ya, yb, t2 * _TILE, min(w, (t2 + 1) * _TILE), shallow)
    t1 = tx + _AHEAD_VERTS
    if t1 < ntx:
        _prefetch_tile(prim, geom, G, face_off, ya, yb, t1 * _TILE, min(w, (t1 + 1) * _TILE), deep)


def _make_packets(tex_on: bool = False, batched: bool = False, ahead: bool = False):
    """The mirror kernel for one variant (see :mod:`.jit`; ``tex_on``: textured coefficients at the
    bounces, sampled at level 0: a bounced ray has no pixel footprint). ``batched``, a compile-time
    constant too (a frame compiles only the start it takes): the lanes start by :func:`_start_group`;
    else from the rays the Phong kernel handed over (:func:`_take_handed`) if any, else by
    :func:`_start_lane` (one build for both: the demo's Phong and flat or Gouraud mirrors).
    ``ahead``, compile-time as well: prefetch the gathers of the tiles ahead (a mesh beyond the
    caches, :data:`~raycast_shade.common.prefetch.PREFETCH_BYTES`; never with rays handed over,
    which gather nothing). The small meshes of the demo and the lecture compile no prefetching."""

    @in_parts
    @njit(nogil=True, **JIT)
    def _mirror_packets_kernel(hits, G, B, L, T, face_off, materials, cam, background, image, trace, rays, part):
        """Blend every reflective pixel of ``hits`` into ``image``, all bounces, in packets.

        ``hits`` = ``(prim, geom, u, v)`` (R, W) and ``image`` (R, W, 3) float32: rows
        ``y0 ..`` of the frame (a band, or all of it: a pixel's bounces read nothing but its
        own hit). ``trace`` = ``(scene handle, unit, max_depth, packet flags, y0)``;
        ``rays``: the first rays handed over (:func:`_take_handed`), or ``NO_RAYS``. The
        reflective pixels of each 4x4 tile of the image (on the frame's grid of tiles, cut by
        the rows given) go as one ``rtcIntersect16`` packet per bounce; a lane whose ray met a
        reflective surface (and whose weight can still change its pixel) bounces on in the
        same packet. Per pixel the arithmetic is :func:`_keep_pixel`, then per bounce the
        bounce's Phong-shaded colour (``1 - rho`` of it on a reflective surface, all of it at
        the last bounce; the background on a miss) added with :func:`_add_pixel`, weighted by
        the product of the reflectivities met before it."""
        spec_on, att_on = L.spec_on, L.att_on  # run-time flags of the frame (records.Lighting)
        prim = hits[0]
        handle, unit, max_depth, flags, y0 = trace
        handed = False if batched else rays[0].shape[0] != 0
        uvs = B.uvs
        h, w = prim.shape
        first = y0 // _TILE  # the frame's tile rows that meet rows y0 .. y0 + h
        ntr = (y0 + h + _TILE - 1) // _TILE - first
        ntx = (w + _TILE - 1) // _TILE
        per = BLOCK_ROWS // _TILE
        nblk = (ntr + per - 1) // per
        step = spread_step(nblk)
        GF = _flat_mesh(G) if batched else None  # (_start_group's; a compile-time branch)
        for it in range(*share(nblk, part)):  # this part's blocks of tile rows, in a balanced order
            blk = (it * step) % nblk
            S = ray_scratch()
            Q = closest_packet(flags)  # the task's closest-hit packet, reused by every tile and bounce
            ys = np.empty(_LANES, np.int64)
            xs = np.empty(_LANES, np.int64)
            weight = np.empty(_LANES, np.float64)
            org, dr = np.empty((3, _LANES), np.float64), np.empty((3, _LANES), np.float64)
            act = np.empty(_LANES, np.bool_)
            org[:], dr[:], act[:] = 0.0, 0.0, False  # (np.zeros: two more overload builds per kind, cold)
            F = (np.zeros(_FIELDS * _BATCH), np.zeros(7 * _BATCH, np.int64)) if batched else None  # _start_group's
            for tr in range(blk * per, min(ntr, (blk + 1) * per)):
                ya = max((first + tr) * _TILE - y0, 0)
                yb = min((first + tr + 1) * _TILE - y0, h)
                for tx in range(ntx):
                    if ahead and not handed:  # (handed: nothing is gathered)
                        _prefetch_ahead(prim, hits[1], G, face_off, (ya, yb), w, tx, batched)
                    n = np.int64(0)  # not 0: _start_lane would compile for Literal[int](0) first, then int64
                    started = not (handed or batched)  # the lanes' rays are made at depth 0
                    if handed:
                        n = _take_handed(hits, materials, image, rays, (ya, yb, tx * _TILE, min(w, (tx + 1) * _TILE)),
                                         (n, ys, xs, weight, org, dr, act))
                    elif batched:
                        if tx % _GROUP == 0:
                            _start_group(hits, GF, materials, face_off, cam, unit, image, (ya, yb, tx * _TILE, w), F)
                        n = _take_tile(F, tx % _GROUP, (n, ys, xs, weight, org, dr, act))
                    else:
                        for y in range(ya, yb):
                            for x in range(tx * _TILE, min(w, (tx + 1) * _TILE)):
                                n = _start_lane(hits, materials, image, y, x, (n, ys, xs, weight, org, dr, act))
                    # Depth 0 (lanes started by _start_lane): each lane's shading point and mirror ray,
                    # at the bounces' own call of _surface (one inlined copy of it in the kernel, not two).
                    for depth in range(0 if started else 1, max_depth + 1):
                        if n == 0:
                            break
                        if depth > 0:
                            set_closest_rays(Q, org, dr, act, n)
                            trace_closest(handle, Q)
                        more = 0
                        for k in range(n):
                            if not act[k]:
                                continue
                            if depth == 0:
                                at = _pixel_at(hits, face_off, ys[k], xs[k])
                            else:
                                gb, pb, ub, vb, _ = closest_hit(Q, k)
                                act[k] = False
                                if pb < 0:
                                    _add_pixel(image, ys[k], xs[k], weight[k], background[0], background[1],
                                               background[2])
                                    continue
                                at = At(face_off[gb] + pb, gb, np.float64(ub), np.float64(vb))
                            hp = _surface(G, B, cam, at, depth > 0, (dr[0, k], dr[1, k], dr[2, k]))
                            if depth == 0:
                                _lane_ray(hp, unit, k, org, dr)
                                more += 1
                                continue
                            if tex_on:
                                coef = _point_coefficients(G, uvs, at, cam, 0, 0, False, materials, T)
                            else:
                                coef = _row_coefficients(materials, at.gm)
                            rgb = _illuminate(_lifted(G, L, at, hp), coef, materials, at.gm, L, S, spec_on, att_on)
                            rho = materials[at.gm, MAT_REFLECTIVITY]
                            keep = 1.0
                            if rho > 0.0 and depth < max_depth:
                                keep = 1.0 - rho
                                _lane_ray(hp, unit, k, org, dr)
                                # A ray that can no longer change a float32 pixel of its own colour's size stops.
                                act[k] = weight[k] * rho >= _MIN_WEIGHT
                            _add_pixel(image, ys[k], xs[k], weight[k], keep * rgb[0], keep * rgb[1], keep * rgb[2])
                            if act[k]:
                                weight[k] = weight[k] * rho
                                more += 1
                        if more == 0:
                            break

    return _mirror_packets_kernel


# The family's registries (see .jit), one per start of the lanes (by :func:`_start_group`; else
# handed over by the Phong kernel or by :func:`_start_lane`): a frame compiles only the start it
# takes (the demo's frames compile neither _start_group nor the batched passes it inlines).
_PACKETS = compile_variants(_make_packets)
_PACKETS_BATCHED = compile_variants(functools.partial(_make_packets, batched=True))
# The same, prefetching (a mesh beyond the caches).
_PACKETS_AHEAD = compile_variants(functools.partial(_make_packets, ahead=True))
_PACKETS_BATCHED_AHEAD = compile_variants(functools.partial(_make_packets, batched=True, ahead=True))


def _batched_start(B) -> bool:
    """Whether the lanes start by :func:`_start_group`: no model has a bump or a normal map
    (``B``: the frame's height-map tuple; those bend the normal, which only ``_surface`` does)."""
    return not bool(np.any(B.bump_index >= 0)) and not bool(np.any(B.nmap_index >= 0))


def trace_mirrors(scene, camera, hits, image, max_depth: int = 3, inputs=None, y0: int = 0,
                  rays=None) -> np.ndarray:
    """Blend mirror reflections into a shaded image.

    Each reflective pixel becomes ``(1 - rho) local + rho reflected``, the
    reflected colour traced recursively (Phong-shaded at every bounce, seen
    along the bouncing ray) to ``max_depth`` bounces; the last bounce shows
    its local shade. ``max_depth=0`` is the same image as no mirror at all.

    The reflective pixels of each 4x4 tile of the frame trace their bounces
    together, as one 16-ray packet per bounce (:func:`_make_packets`), in
    one parallel kernel: no gather, no per-ray arrays.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    hits : HitBuffer
        (H, W) hits of the frame, or of ``H`` of its rows from ``y0`` on (a band).
    image : (H, W, 3) float32
        Local shading of ``hits``; updated in place and returned.
    max_depth : int
        Bounces, ``0 <= max_depth <= MAX_MIRROR_DEPTH``.
    inputs : FrameInputs, optional
        The frame's packed inputs (:func:`~raycast_shade.shading.inputs.prepare`), when the
        caller has them already; packed here otherwise.
    y0 : int
        The frame row of ``hits``' first row: its tiles are the frame's, so a band's pixels
        travel with the same neighbours as in the whole frame (except where a band's edge cuts a
        tile; a ray's hit does not depend on the packet it travels in).
    rays : tuple of (H, W, 3) float32 and float64 arrays, optional
        Every reflective pixel's first mirror ray, handed over by the Phong kernel that shaded
        ``image`` (:func:`~raycast_shade.shading.mirror_rays.hand_over_buffers`); computed here
        otherwise.
    """
    geo = scene.geometry
    if max_depth <= 0 or not geo.reflective:
        return image
    k = prepare(scene, camera) if inputs is None else inputs
    # The handle as the camera cast passes it (int64): the packets compile once.
    trace = (int(embree_accel(geo).handle), float(geo.scale), int(max_depth), np.uint32(MIRROR_FLAGS), int(y0))
    batched = rays is None and _batched_start(k["B"])
    if rays is None and beyond_caches(*k["G"]):
        family = _PACKETS_BATCHED_AHEAD if batched else _PACKETS_AHEAD
    else:
        family = _PACKETS_BATCHED if batched else _PACKETS
    variant(family, k)((hits.prim, hits.geom, hits.u, hits.v), k["G"], k["B"], k["L"], k["T"], k["face_off"],
                       k["materials"], k["cam"], k["background"], image, trace, NO_RAYS if rays is None else rays)
    return image
