"""The camera's 4x4-pixel tiles as 16-ray packets: rays written in, hits read out.

Helpers of :func:`.cast._cast_camera_kernel`, LLVM-inlined into it. Each ray is
:func:`.rays.pixel_ray`'s, operation for operation, so every ray and every hit is bit for
bit the single ray's. Written for LLVM's loop vectoriser, the only vectoriser Numba runs
(its SLP vectoriser is off): a loop over a packet's 16 lanes with a constant trip count is
fully unrolled into scalar code first, so the lane loops here run to ``valid.shape[0]``
(16, a runtime value) and read their inputs from arrays laid out lane by lane; each
packet's hit fields start as a miss's, so that unpacking is plain copies; and the hit
arrays are indexed with unsigned integers (a signed index costs a negative-index wrap per
access). Measured at 1920x1080 (81,920 triangles, 1 thread CPU time, load 4-5): ray
generation 10.0 -> 1.2 ms, unpacking 8.3 -> 3.3 ms (most of it now the 20 bytes a pixel
written to memory); the kernel 0.69x what it was (``benchmarks/bench_limits.py``,
``cast_kernel``).

Packet layout (:mod:`.embree`): slot ``s`` of lane ``k`` at ``s * 16 + k``; lane
``4 j + i`` is the tile's pixel in column ``i`` and row ``j``.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from ..common.inline import inline_jit

from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_RIGHT, CAM_UP, CAM_WIDTH
from . import embree

TILE_W = 4  # a 16-ray packet is a 4x4 tile (faster than 8x2 or 16x1: see embree's module docstring)
TILE_H = 4
LANES = TILE_W * TILE_H
RAY = embree.RAYHIT_SLOTS  # float32 slots in one RTCRayHit (96 bytes, room for instPrimID)

_INLINE = dict(cache=True, forceinline=True, _nrt=False)  # LLVM-inlined into the kernel, compiled once
_VECTOR = dict(_INLINE, error_model="numpy")  # no zero-division branch in a loop that vectorises


@inline_jit()  # called by kernels only: IR for them, no wrappers (common/inline.py)
def tile_columns(cam, ntx, ortho):
    """(ntx, 3 16) float64: for each column of tiles, lane ``k``'s ``forward + sx right``
    (orthographic: ``eye + sx right``) in component ``c`` at ``16 c + k``, with ``sx`` as
    :func:`.rays.pixel_ray` computes it for the tile's column ``k % 4`` (every column of
    whole tiles: dummy lanes read them too)."""
    base = CAM_EYE if ortho else CAM_FORWARD
    out = np.empty((ntx, 3 * LANES), np.float64)
    for tx in range(ntx):
        for i in range(TILE_W):
            a = 2.0 * (tx * TILE_W + i + 0.5) / cam[CAM_WIDTH] - 1.0
            for c in range(3):
                s = cam[base + c] + a * cam[CAM_RIGHT + c]
                for j in range(TILE_H):
                    out[tx, c * LANES + j * TILE_W + i] = s
    return out


@inline_jit(**_INLINE)
def row_terms(rt, cam, y):
    """``rt`` (3 16,) float64: lane ``k``'s ``sy up`` for the tile whose first row is image row
    ``y`` (its row ``k // 4``), component ``c`` at ``16 c + k``, as :func:`.rays.pixel_ray`."""
    for j in range(TILE_H):
        b = 1.0 - 2.0 * (y + j + 0.5) / cam[CAM_HEIGHT]
        for c in range(3):
            s = b * cam[CAM_UP + c]
            for i in range(TILE_W):
                rt[c * LANES + j * TILE_W + i] = s


@inline_jit(**_INLINE)
def fixed_slots(pk, pu, cam, ortho):
    """The slots of a packet's 16 rays that Embree never writes and no pixel changes (tnear, time,
    mask, id, flags; the eye as every origin, or orthographic, the forward axis as every direction),
    once per block of tiles; :func:`tile_rays` writes the rest per tile."""
    for k in range(LANES):
        for c in range(3):
            if ortho:
                pk[(embree.RAY_DIR + c) * LANES + k] = cam[CAM_FORWARD + c]
            else:
                pk[(embree.RAY_ORG + c) * LANES + k] = cam[CAM_EYE + c]
        pk[embree.RAY_TNEAR * LANES + k] = 0.0
        pk[embree.RAY_TIME * LANES + k] = 0.0
        pu[embree.RAY_MASK * LANES + k] = embree.INVALID_ID
        pu[embree.RAY_ID * LANES + k] = 0
        pu[embree.RAY_FLAGS * LANES + k] = 0


@inline_jit(**_INLINE)
def tile_valid(valid, nx, ny):
    """The valid mask of a tile of ``nx`` columns and ``ny`` rows: -1 for its pixels' lanes, 0 for the
    dummy rays beyond the image."""
    for k in range(LANES):
        valid[k] = -1 if k % TILE_W < nx and k // TILE_W < ny else 0


@inline_jit(**_VECTOR)
def tile_rays(pk, pu, valid, ct, tx, rt, ortho):
    """One tile's rays into the packet ``pk`` (float32, its uint32 view ``pu``): lane ``k`` is
    ``ct[tx, 16 c + k] + rt[16 c + k]`` in component ``c``, the origin (orthographic) or the
    direction, normalised (perspective); ``tfar`` infinite and the hit fields a miss's (what
    :func:`.embree.read_hit` returns for one, so that :func:`tile_hits` copies them). ``valid``
    (16,) int32 gives the lane count (see the module docstring)."""
    if ortho:
        for k in range(valid.shape[0]):
            pk[embree.RAY_ORG * LANES + k] = ct[tx, k] + rt[k]
            pk[(embree.RAY_ORG + 1) * LANES + k] = ct[tx, LANES + k] + rt[LANES + k]
            pk[(embree.RAY_ORG + 2) * LANES + k] = ct[tx, 2 * LANES + k] + rt[2 * LANES + k]
            pk[embree.RAY_TFAR * LANES + k] = np.inf
    else:
        for k in range(valid.shape[0]):
            x = ct[tx, k] + rt[k]
            y = ct[tx, LANES + k] + rt[LANES + k]
            z = ct[tx, 2 * LANES + k] + rt[2 * LANES + k]
            inv = 1.0 / np.sqrt(x * x + y * y + z * z)
            pk[embree.RAY_DIR * LANES + k] = x * inv
            pk[(embree.RAY_DIR + 1) * LANES + k] = y * inv
            pk[(embree.RAY_DIR + 2) * LANES + k] = z * inv
            pk[embree.RAY_TFAR * LANES + k] = np.inf
    for k in range(valid.shape[0]):  # a miss as read_hit returns it: Embree writes the hit only on a hit
        pu[embree.HIT_GEOM_ID * LANES + k] = embree.INVALID_ID
        pu[embree.HIT_PRIM_ID * LANES + k] = embree.INVALID_ID  # -1 as int32
        pk[embree.HIT_U * LANES + k] = 0.0
        pk[embree.HIT_V * LANES + k] = 0.0


@inline_jit(**_INLINE)
def _hits4(pk, pu, s, q, prim, geom, u, v, t):
    """Lanes ``s .. s + 4`` of the packet (a tile's row) into ``q .. q + 4`` of the flat hit arrays:
    copies, as :func:`tile_rays` left a miss's fields as :func:`.embree.read_hit` returns them."""
    q1, q2, q3 = q + np.uint64(1), q + np.uint64(2), q + np.uint64(3)
    a = embree.HIT_GEOM_ID * LANES + s
    geom[q], geom[q1], geom[q2], geom[q3] = np.int32(pu[a]), np.int32(pu[a + 1]), np.int32(pu[a + 2]), np.int32(pu[a + 3])
    a = embree.HIT_PRIM_ID * LANES + s
    prim[q], prim[q1], prim[q2], prim[q3] = np.int32(pu[a]), np.int32(pu[a + 1]), np.int32(pu[a + 2]), np.int32(pu[a + 3])
    a = embree.HIT_U * LANES + s
    u[q], u[q1], u[q2], u[q3] = pk[a], pk[a + 1], pk[a + 2], pk[a + 3]
    a = embree.HIT_V * LANES + s
    v[q], v[q1], v[q2], v[q3] = pk[a], pk[a + 1], pk[a + 2], pk[a + 3]
    a = embree.RAY_TFAR * LANES + s
    t[q], t[q1], t[q2], t[q3] = pk[a], pk[a + 1], pk[a + 2], pk[a + 3]


@inline_jit(**_INLINE)
def tile_hits(pk, pu, o, w, prim, geom, u, v, t):
    """Unpack a whole tile's hits into the flat (R W,) hit arrays: its pixel ``(j, i)`` at ``o + j w + i``."""
    # np.int64: a constant argument would be typed Literal[int] and compile _hits4 once per value.
    _hits4(pk, pu, np.int64(0), np.uint64(o), prim, geom, u, v, t)
    _hits4(pk, pu, np.int64(TILE_W), np.uint64(o + w), prim, geom, u, v, t)
    _hits4(pk, pu, 2 * TILE_W, np.uint64(o + 2 * w), prim, geom, u, v, t)
    _hits4(pk, pu, 3 * TILE_W, np.uint64(o + 3 * w), prim, geom, u, v, t)


@inline_jit(**_INLINE)
def edge_hits(pk, pu, x0, r, nx, ny, prim, geom, u, v, t):
    """Unpack a partial tile's hits: ``nx`` columns and ``ny`` rows of it, into rows ``r ..`` and
    columns ``x0 ..`` of the (R, W) hit arrays."""
    for j in range(ny):
        for i in range(nx):
            g, p, hu, hv, ht = embree.read_hit(pk, pu, j * TILE_W + i, np.int64(LANES))
            geom[r + j, x0 + i], prim[r + j, x0 + i] = g, p
            u[r + j, x0 + i], v[r + j, x0 + i], t[r + j, x0 + i] = hu, hv, ht
