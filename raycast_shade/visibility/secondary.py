"""Secondary rays: the occlusion and closest-hit queries the shading stage asks of Embree.

A shading kernel says which rays it wants (origin, direction, end) and reads back an answer
(blocked or not; the closest hit's model, triangle and barycentrics). This module alone lays
those rays out in Embree's structs and calls Embree, so no shading module writes a struct slot:

================================  ==================================================================
query                             functions
================================  ==================================================================
one occlusion ray                 :func:`ray_scratch`, :func:`occluded` (from Python:
                                  :func:`occluded_ray`)
occlusion packets (16 lanes,      :func:`occlusion_packets`, :func:`clear_occlusion`,
one packet per group, e.g. a      :func:`set_occlusion_ray` (or :func:`set_occlusion_lane` in a
light)                            loop that vectorises), :func:`trace_occlusion`
closest-hit packets (16 lanes)    :func:`closest_packet`, :func:`set_closest_rays`,
                                  :func:`trace_closest`, :func:`closest_hit`
================================  ==================================================================

The scratch buffers are allocated once per kernel task and reused for every query. Embree reads
a ray through a raw address: each address is computed from its live array in the very expression
that calls Embree, and the array is read again after the call, so it is alive while Embree uses
it whatever Numba's liveness analysis does with locals. The helpers are LLVM-inlined into the
kernels (``forceinline``, no reference counting), so a query costs what the struct writes cost.
"""

from __future__ import annotations

import numpy as np
from ..common.inline import inline_jit

from . import embree
from .hits import convex_uv

__all__ = ["LANES", "UNTRACED", "ray_scratch", "occluded", "occluded_ray", "occlusion_packets", "clear_occlusion",
           "set_occlusion_ray", "set_occlusion_lane", "trace_occlusion", "closest_packet",
           "set_closest_rays", "trace_closest", "closest_hit"]

LANES = 16  # rays a packet: the pixels of a 4x4 tile
UNTRACED = -1  # an occlusion answer no ray was asked for
_RAYHIT16 = LANES * embree.RAYHIT_SLOTS  # float32 slots of one RTCRayHit16 (1536 bytes: 64-byte aligned)
# Slots from one occlusion packet to the next: a whole RTCRayHit16, not an RTCRay16. Without 16-wide
# kernels (an AVX2 CPU), rtcOccluded16 traces the lanes one by one, copying each lane to an RTCRayHit
# and back into the packet as an RTCRayHit16: it reads and rewrites the hit fields past the
# RTCRay16 (Embree 4.4, measured: a second thread's increments there are lost). Past a packet's end
# those bytes must be its own, or the rewrite undoes another thread's writes to the heap.
_STRIDE = _RAYHIT16
_INLINE = dict(cache=True, forceinline=True, _nrt=False)  # LLVM-inlined: no references, no allocation
_ALLOC = dict(cache=True, forceinline=False, _nrt=True)  # allocates: NRT on, a call


# -- one occlusion ray ----------------------------------------------------------------------------


@inline_jit(**_ALLOC)
def ray_scratch():
    """A per-task ``RTCRay`` for :func:`occluded`.

    Returns
    -------
    buf, ib : (24,) float32, (24,) uint32
        Two views of one buffer.
    off : int
        The 16-byte aligned slot the ray starts at.
    """
    buf = np.empty(2 * embree.RAY_SLOTS, np.float32)
    base = buf.ctypes.data
    off = ((16 - base % 16) % 16) // 4
    return buf, buf.view(np.uint32), off


@inline_jit(**_INLINE)
def occluded(handle, S, org, d, tfar):
    """True if the scene blocks the ray ``org + t d``, ``0 <= t <= tfar`` (``rtcOccluded1``).

    Parameters
    ----------
    handle : uintp
        The Embree scene.
    S : tuple
        :func:`ray_scratch`'s buffer.
    org, d : 3-tuples of float
    tfar : float
    """
    buf, ib, off = S
    embree.write_ray(buf, ib, off, np.int64(1), org, d, 0.0, tfar)
    embree.occluded1(handle, buf.ctypes.data + off * 4, 0)  # the address taken from the live array, here
    return buf[off + embree.RAY_TFAR] < 0.0  # Embree sets tfar to -inf on a hit


def occluded_ray(handle, org, d, tfar) -> bool:
    """:func:`occluded` for a Python caller (``explain``): the same float32 ray, one
    ``rtcOccluded1``.

    Parameters
    ----------
    handle : int
        The Embree scene.
    org, d : (3,) float
    tfar : float
    """
    buf = np.zeros(2 * embree.RAY_SLOTS, np.float32)
    off = ((16 - buf.ctypes.data % 16) % 16) // 4
    ray = buf[off:off + embree.RAY_SLOTS]
    embree.write_ray(ray, ray.view(np.uint32), 0, 1, tuple(map(float, org)), tuple(map(float, d)), 0.0, float(tfar))
    embree.occluded1_ray(np.uintp(handle), ray)
    return bool(ray[embree.RAY_TFAR] < 0.0)


# -- occlusion packets: groups of 16 lanes, one rtcOccluded16 per group ---------------------------


@inline_jit(**_ALLOC)
def occlusion_packets(ngroups):
    """A per-task scratch for ``ngroups`` occlusion packets of :data:`LANES` rays each.

    Returns
    -------
    buf, ib : (N,) float32, (N,) uint32
        Two views of one buffer: ``ngroups`` ``RTCRay16`` one after another from slot ``off``
        (64-byte aligned), group ``i``'s at ``off + i * _STRIDE`` (a whole ``RTCRayHit16`` each: see ``_STRIDE``).
    off : int
    valid : (M,) int32
        The packets' valid masks, group ``i``'s lanes from ``voff + 16 i`` (64-byte aligned).
    voff : int
    args : (K,) uint32
        ``RTCOccludedArguments`` from ``aoff`` (8-byte aligned): every feature, coherent rays.
    aoff : int
    vis : (ngroups, LANES) int8
        Per group and lane: 1 blocked, 0 not, :data:`UNTRACED` not asked (:func:`trace_occlusion`).
    """
    n = max(ngroups, 1)
    buf = np.empty(n * _STRIDE + 16, np.float32)
    off = ((64 - buf.ctypes.data % 64) % 64) // 4
    # Zeroed by assignment (np.zeros would build two more of Numba's overloads at a cold start).
    valid = np.empty(n * LANES + 16, np.int32)
    valid[:] = 0
    voff = ((64 - valid.ctypes.data % 64) % 64) // 4
    args = np.empty(embree.ARGS_SLOTS + 2, np.uint32)
    args[:] = 0
    aoff = ((8 - args.ctypes.data % 8) % 8) // 4
    args[aoff] = embree.RAY_QUERY_FLAG_COHERENT  # neighbours' rays to one light: 1.9x faster than without
    args[aoff + 1] = embree.FEATURE_FLAG_ALL
    vis = np.empty((n, LANES), np.int8)
    vis[:] = UNTRACED
    ib = buf.view(np.uint32)
    for i in range(n):  # the slots no ray changes and Embree never writes, once
        for k in range(LANES):
            b = off + i * _STRIDE + k
            buf[b + embree.RAY_TNEAR * LANES] = 0.0
            buf[b + embree.RAY_TIME * LANES] = 0.0
            ib[b + embree.RAY_MASK * LANES] = embree.INVALID_ID  # every mask bit, as write_ray
            ib[b + embree.RAY_ID * LANES] = 0
            ib[b + embree.RAY_FLAGS * LANES] = 0
    return buf, ib, off, valid, voff, args, aoff, vis


@inline_jit(**_INLINE)
def clear_occlusion(valid, voff, vis):
    """No ray asked for in any group: every lane off, every answer :data:`UNTRACED`."""
    for i in range(vis.shape[0]):
        for k in range(LANES):
            valid[voff + i * LANES + k] = 0
            vis[i, k] = UNTRACED


@inline_jit(**_INLINE)
def set_occlusion_ray(P, i, k, org, d, tfar):
    """Ask for the ray ``org + t d``, ``0 <= t <= tfar``, in lane ``k`` of group ``i`` of the
    packets ``P = (buf, ib, off, valid, voff)`` (:func:`occlusion_packets`)."""
    buf, ib, off, valid, voff = P
    b = off + i * _STRIDE + k  # tnear 0, time 0, every mask bit, id and flags 0: set once
    for c in range(3):
        buf[b + (embree.RAY_ORG + c) * LANES] = org[c]
        buf[b + (embree.RAY_DIR + c) * LANES] = d[c]
    buf[b + embree.RAY_TFAR * LANES] = tfar
    valid[voff + i * LANES + k] = -1


@inline_jit(**_INLINE)
def set_occlusion_lane(buf, ub, j, q, org, d, tfar):
    """Write the ray of lane ``q`` of packet ``j`` from slot ``ub`` (uint64) without touching its
    valid mask: for a loop over every lane that sets the masks itself and vectorises (unsigned
    offsets: no wrap-around test per store)."""
    for c in range(3):
        buf[ub + np.uint64(j * _STRIDE + (embree.RAY_ORG + c) * LANES + q)] = org[c]
        buf[ub + np.uint64(j * _STRIDE + (embree.RAY_DIR + c) * LANES + q)] = d[c]
    buf[ub + np.uint64(j * _STRIDE + embree.RAY_TFAR * LANES + q)] = tfar


@inline_jit(**_INLINE)
def trace_occlusion(handle, buf, off, valid, voff, args, aoff, vis):
    """Trace each group's packet that has an active lane (``rtcOccluded16``) and write ``vis``
    (1 blocked, 0 not) for its active lanes.

    Compiled without reference counting, this helper cannot release an array, and its caller
    holds them all (slicing them for :func:`~raycast_shade.visibility.embree.occluded16_packet`
    would cost two atomic reference counts per slice per tile)."""
    for i in range(vis.shape[0]):
        v0 = voff + i * LANES
        any_on = False
        for k in range(LANES):
            any_on = any_on or valid[v0 + k] != 0
        if not any_on:
            continue
        b0 = off + i * _STRIDE
        embree.occluded16(valid.ctypes.data + v0 * 4, handle, buf.ctypes.data + b0 * 4, args.ctypes.data + aoff * 4)
        for k in range(LANES):
            if valid[v0 + k] != 0:
                vis[i, k] = 1 if buf[b0 + embree.RAY_TFAR * LANES + k] < 0.0 else 0


# -- closest-hit packets ----------------------------------------------------------------------------


@inline_jit(**_ALLOC)
def closest_packet(flags):
    """A per-task ``RTCRayHit16`` for closest-hit queries of up to :data:`LANES` rays.

    Parameters
    ----------
    flags : uint32
        ``RTCRayQueryFlags`` of the packets (e.g. coherent).

    Returns
    -------
    (buf, ib, off, vbuf, voff, abuf, aoff)
        The struct's two views and 64-byte aligned slot, its valid mask and slot, the
        ``RTCIntersectArguments`` and slot.
    """
    buf = np.empty(_RAYHIT16 + 16, np.float32)
    off = ((64 - buf.ctypes.data % 64) % 64) // 4
    ib = buf.view(np.uint32)
    vbuf = np.empty(2 * LANES, np.int32)
    voff = ((64 - vbuf.ctypes.data % 64) % 64) // 4
    abuf = np.empty(embree.ARGS_SLOTS + 2, np.uint32)
    abuf[:] = 0  # (np.zeros would build two more of Numba's overloads at a cold start)
    aoff = ((8 - abuf.ctypes.data % 8) % 8) // 4
    abuf[aoff] = flags
    abuf[aoff + 1] = embree.FEATURE_FLAG_ALL
    for k in range(LANES):  # tnear 0, time 0, every mask bit, id and flags 0: the same for every query
        embree.write_ray(buf, ib, off + k, np.int64(LANES), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.0, np.inf)
    return buf, ib, off, vbuf, voff, abuf, aoff


@inline_jit(**_INLINE)
def set_closest_rays(Q, org, dr, act, n):
    """Ask for the closest hits of the active lanes' rays ``org + t dr``, ``t >= 0``.

    Parameters
    ----------
    Q : tuple
        :func:`closest_packet`'s scratch.
    org, dr : (3, LANES) float64
    act : (LANES,) bool
        The lanes asked for; at least one of the first ``n``.
    n : int
        Lanes ``n ..`` are unused.

    Inactive lanes carry the first active lane's ray (a valid dummy, masked off)."""
    buf, ib, off, vbuf, voff, abuf, aoff = Q
    first = 0
    while not act[first]:
        first += 1
    for k in range(LANES):
        on = k < n and act[k]
        j = k if on else first
        for c in range(3):
            buf[off + k + (embree.RAY_ORG + c) * LANES] = org[c, j]
            buf[off + k + (embree.RAY_DIR + c) * LANES] = dr[c, j]
        buf[off + k + embree.RAY_TFAR * LANES] = np.inf
        embree.reset_hit(ib, off + k, np.int64(LANES))
        vbuf[voff + k] = -1 if on else 0


@inline_jit(**_INLINE)
def trace_closest(handle, Q):
    """Trace the packet :func:`set_closest_rays` filled (``rtcIntersect16``); the caller reads
    the answers with :func:`closest_hit` and holds ``Q`` meanwhile."""
    buf, ib, off, vbuf, voff, abuf, aoff = Q
    embree.intersect16(vbuf.ctypes.data + voff * 4, handle, buf.ctypes.data + off * 4, abuf.ctypes.data + aoff * 4)


@inline_jit(**_INLINE)
def closest_hit(Q, k):
    """Lane ``k``'s closest hit after :func:`trace_closest`: ``(geom, prim, u, v, t)``
    (:func:`~raycast_shade.visibility.embree.read_hit`; ``prim`` -1 for a miss), its ``(u, v)`` inside
    the triangle (:func:`~raycast_shade.visibility.hits.convex_uv`, as the camera's hits)."""
    buf, ib, off, vbuf, voff, abuf, aoff = Q
    g, p, u, v, t = embree.read_hit(buf, ib, off + k, np.int64(LANES))
    u, v = convex_uv(u, v)
    return g, p, u, v, t
