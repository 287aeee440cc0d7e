"""Alpha masks (glTF ``MASK``): rays pass through the texels whose coverage is below the cutoff.

A model whose material has an ``alpha_cutoff`` (:class:`~raycast_shade.Material`) gets Embree
*geometry* filter functions, for intersection and occlusion queries alike: every candidate hit
on its triangles is looked up in its alpha map at the hit's UV (the triangle's corner UVs
weighted by Embree's barycentrics, sampled bilinearly at level 0 with the map's wrap and
tiling, as the colour maps are) and rejected where ``alpha < cutoff``, so Embree carries on to
what lies behind. Camera rays, :func:`~raycast_shade.cast_rays`, shadow rays and mirror rays
all go through the same filters; a hit buffer therefore never holds a masked point, and
everything that reads it (shading, ``explain``, the buffers) sees what lies behind.

Only masked geometries get a filter: a scene without masks is built exactly as before, and
its traversal never calls back into Python-compiled code.

The filter is one Numba ``cfunc`` for every masked geometry; what differs per geometry is
its *user data*, one float32 array (:func:`mask_data`) whose address Embree keeps. The array
is held by the :class:`~raycast_shade.visibility.embree.EmbreeAccel` that installed it, for
as long as its scene exists (see ``EmbreeAccel.mask_data``).

Layout of the user data, float32 slots: ``[height, width, clamp, tile_u, tile_v, cutoff,
n_faces, 0]`` then the corner UVs ``(n_faces, 3, 2)`` then the alpha texels ``(height,
width)`` (row 0 at v = 0). Whole numbers below 2**24 are exact in float32.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import carray, cfunc, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["mask_data", "mask_filter", "filter_address", "masked_geometries", "masked_hits", "alpha_at", "HEADER"]

HEADER = 8
_H, _W, _CLAMP, _TU, _TV, _CUTOFF, _NF = range(7)


def masked_geometries(geometry) -> tuple:
    """The indices of the models whose material masks (has an ``alpha_cutoff``)."""
    return tuple(g for g, m in enumerate(getattr(geometry, "alpha_masks", ())) if m is not None)


def mask_data(alpha_map, cutoff: float, uvs, faces) -> np.ndarray:
    """The filter's user data for one masked model.

    Parameters
    ----------
    alpha_map : Texture
        Its first channel of level 0 is the coverage.
    cutoff : float
    uvs : (V, 2) float64
        The model's vertex UVs.
    faces : (F, 3) int
        The model's triangles, indices into ``uvs``.

    Returns
    -------
    (HEADER + 6 F + h w,) float32
        C-contiguous, owning its memory (see the module docstring for the layout).
    """
    a = np.asarray(alpha_map.texels, np.float32)[..., 0]
    h, w = a.shape
    if max(h, w, len(faces)) >= 1 << 24:
        raise ValueError(f"{alpha_map.name}: alpha masks take at most 2**24 - 1 texels a side and faces a model")
    head = np.zeros(HEADER, np.float32)
    head[[_H, _W, _CLAMP, _TU, _TV, _CUTOFF, _NF]] = (h, w, alpha_map.wrap == "clamp", alpha_map.tiling[0],
                                                     alpha_map.tiling[1], cutoff, len(faces))
    corner = np.asarray(uvs, np.float32)[np.asarray(faces, np.int64)].reshape(-1)
    return np.ascontiguousarray(np.concatenate([head, corner, a.reshape(-1)]), np.float32)


@njit(cache=True, _nrt=False)
def _wrap(i, n, clamp):
    if clamp:
        return min(max(i, 0), n - 1)
    return i % n


@njit(cache=True, _nrt=False)
def alpha_at(data, prim, b1, b2):
    """The coverage of face ``prim`` at barycentrics ``(b1, b2)`` of its corners 1 and 2.

    Parameters
    ----------
    data : (N,) float32
        :func:`mask_data`'s array (or a view of the same memory).
    prim : int
    b1, b2 : float

    Returns
    -------
    float
        Bilinear at level 0; NaN UVs (never from a valid hit) read texel (0, 0).
    """
    h = int(data[_H])
    w = int(data[_W])
    clamp = data[_CLAMP] != 0.0
    c = HEADER + 6 * prim
    b0 = 1.0 - b1 - b2
    u = b0 * data[c] + b1 * data[c + 2] + b2 * data[c + 4]
    v = b0 * data[c + 1] + b1 * data[c + 3] + b2 * data[c + 5]
    x = u * data[_TU] * w - 0.5
    y = v * data[_TV] * h - 0.5
    if not abs(x) < 4194304.0:  # far outside (or NaN): the texel a repeat or clamp would reach is immaterial
        x = 0.0
    if not abs(y) < 4194304.0:
        y = 0.0
    j0 = math.floor(x)
    i0 = math.floor(y)
    tx = x - j0
    ty = y - i0
    j0 = int(j0)
    i0 = int(i0)
    j1 = _wrap(j0 + 1, w, clamp)
    i1 = _wrap(i0 + 1, h, clamp)
    j0 = _wrap(j0, w, clamp)
    i0 = _wrap(i0, h, clamp)
    t = HEADER + 6 * int(data[_NF])
    return ((1.0 - tx) * (1.0 - ty) * data[t + i0 * w + j0] + tx * (1.0 - ty) * data[t + i0 * w + j1]
            + (1.0 - tx) * ty * data[t + i1 * w + j0] + tx * ty * data[t + i1 * w + j1])


@intrinsic
def _pointer(typingctx, address):
    """A ``void*`` from an integer address (Embree's struct fields, read as uint64)."""
    sig = types.voidptr(address)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return sig, codegen


def mask_filter(args):
    """``RTCFilterFunctionN`` for intersection and occlusion queries alike (compiled as a ``cfunc`` by
    :func:`filter_address`).

    ``args`` is an ``RTCFilterFunctionNArguments`` (``rtcore_geometry.h``): ``valid`` (int*),
    ``geometryUserPtr``, ``context``, ``ray`` (``RTCRayN``), ``hit`` (``RTCHitN``), ``N``:
    five pointers and an unsigned int. ``RTCHitN`` is SOA: slot ``s`` of lane ``i`` at
    ``s * N + i`` with the slots of ``RTCHit`` (u = 3, v = 4, primID = 5). Writing 0 to
    ``valid[i]`` rejects the candidate hit of lane ``i``; nothing else is written."""
    a = carray(args, 6, np.uint64)
    n = int(a[5] & np.uint64(0xFFFFFFFF))
    valid = carray(_pointer(a[0]), n, np.int32)
    head = carray(_pointer(a[1]), HEADER, np.float32)
    size = HEADER + 6 * int(head[_NF]) + int(head[_H]) * int(head[_W])
    data = carray(_pointer(a[1]), size, np.float32)
    hit_f = carray(_pointer(a[4]), 6 * n, np.float32)
    hit_u = carray(_pointer(a[4]), 6 * n, np.uint32)
    cutoff = data[_CUTOFF]
    for i in range(n):
        if valid[i] == 0:
            continue
        if alpha_at(data, int(hit_u[5 * n + i]), hit_f[3 * n + i], hit_f[4 * n + i]) < cutoff:
            valid[i] = 0


@functools.lru_cache(maxsize=1)
def _compiled():
    # Compiled (or loaded from the cache) on the first masked scene, not at import: a process that
    # never masks never builds it.
    return cfunc(types.void(types.voidptr), cache=True)(mask_filter)


def filter_address() -> int:
    """The address of the compiled :func:`mask_filter`, an ``RTCFilterFunctionN``; the compiled
    function is held by this module for the life of the process."""
    return _compiled().address


def masked_hits(mask_data: dict, geom, prim, u, v) -> np.ndarray:
    """Which hits land on masked points (for exact re-tests made outside Embree).

    Parameters
    ----------
    mask_data : dict of int to (N,) float32
        ``EmbreeAccel.mask_data``: :func:`mask_data` of each masked model.
    geom, prim : (N,) int32
        Model and face (local to the model) of each hit, -1 for a miss.
    u, v : (N,) float32
        Barycentrics of corners 1 and 2.

    Returns
    -------
    (N,) bool
    """
    out = np.zeros(len(geom), np.bool_)
    for g, data in mask_data.items():
        for k in np.flatnonzero(np.asarray(geom) == g):
            out[k] = alpha_at(data, int(prim[k]), float(u[k]), float(v[k])) < data[_CUTOFF]
    return out
