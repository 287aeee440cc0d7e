"""Shadow rays: the offset origin, the ray towards a light, and its packets of 16 lanes.

Shadow rays start at the shading point pushed off the surface along the
geometric normal by a few hundred float32 ulps of its coordinates (Wachter
and Binder, Ray Tracing Gems ch. 6), and near zero by a fixed fraction of the
scene's size (their absolute constants, in units of the scene), so the offset
scales with the scene; point-light rays stop just short of the light. Mirror
rays start from the same kind of offset point (:mod:`.mirrors`).

The rays go to Embree through :mod:`raycast_shade.visibility.secondary`, the
visibility stage's query for secondary rays: this module says which ray, that
one lays it out and traces it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import intrinsic

from ..common.inline import inline_jit
from ..common.prefetch import prefetch
from ..visibility.secondary import LANES, clear_occlusion, occluded, occlusion_packets, set_occlusion_ray
from .jit import CALLED, HELPER
from .pixelstore import store_background

__all__ = []

_SHADOW_TFAR = 1.0 - 1e-5  # point-light shadow rays stop just short of the light


@intrinsic
def _as_bits(typingctx, x):
    """The IEEE-754 bits of a float64 as an int64 (a register move, no call)."""
    if not isinstance(x, types.Float) or x.bitwidth != 64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.int64))

    return types.int64(x), codegen


@intrinsic
def _from_bits(typingctx, b):
    """The float64 whose IEEE-754 bits are the int64 ``b``."""
    if not isinstance(b, types.Integer) or b.bitwidth != 64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float64))

    return types.float64(b), codegen


@inline_jit(**HELPER)
def _nudge(p, n, unit):
    """Move coordinate ``p`` by 256 float32 ulps along normal component ``n``.

    Near zero, where ulps vanish but the triangles around the point still
    carry the float32 error of their (larger) vertex coordinates, the move is
    ``unit / 65536`` instead: Wachter and Binder's constants (1/32, 1/65536)
    measured in ``unit``, the scene's size (bounding-box diagonal), rather
    than in absolute units, so that a scene at scale 1e5 is as safe as one
    at scale 1.

    256 float32 ulps of ``p`` are ``ldexp(256, e - 24) = 2**(e - 16)`` with ``e`` the exponent
    ``math.frexp`` gives (``p = m 2**e``, ``0.5 <= |m| < 1``), read off the float64 bits here:
    two library calls per coordinate cost as much as the packet traversal's share of a shadow ray.
    Every ``p`` that reaches this branch is normal (``unit >= 1e-18``, the smallest Embree scene,
    so ``|p| >= 3e-20``), or infinite or NaN, which stay so."""
    e = ((_as_bits(p) >> 52) & 0x7FF) - 1022  # frexp's exponent
    step = unit * (1.0 / 65536.0) if abs(p) < unit * (1.0 / 32.0) else _from_bits((e - 16 + 1023) << 52)
    return p + n * step  # one expression for both cases, without a branch: loops of rays vectorise


@inline_jit(**HELPER)
def _shadow_ray(o, g, s, target, is_point, unit):
    """The shadow ray from shading point ``o`` towards the light: ``(origin, direction, tfar)``.

    The origin is ``o`` pushed off the surface along its geometric normal ``g`` (on the side
    of the unit direction ``s`` to the light); a point light's ray ends just short of
    ``target``, its position, a light at infinity's (``is_point`` False) goes on along ``s``.
    One function for the single rays and the packets: both trace the same ray."""
    px, py, pz = o
    gx, gy, gz = g
    sx, sy, sz = s
    side = 1.0 if gx * sx + gy * sy + gz * sz >= 0.0 else -1.0
    ox = _nudge(px, side * gx, unit)
    oy = _nudge(py, side * gy, unit)
    oz = _nudge(pz, side * gz, unit)
    if is_point:
        return (ox, oy, oz), (target[0] - ox, target[1] - oy, target[2] - oz), _SHADOW_TFAR
    return (ox, oy, oz), (sx, sy, sz), np.inf


@inline_jit(**HELPER)
def _occluded(handle, S, o, g, s, target, is_point, unit):
    """True if the scene blocks the way from ``o`` towards the light (one ray).

    ``o``, ``g``, ``s``, ``target``, ``is_point`` as in :func:`_shadow_ray`. ``S`` is the
    scratch from :func:`~raycast_shade.visibility.secondary.ray_scratch`. Single shadow rays
    are the rare path (Gouraud's and flat's, terms', mirrors')."""
    org, d, tfar = _shadow_ray(o, g, s, target, is_point, unit)
    return occluded(handle, S, org, d, tfar)


# -- packets: the shadow rays of 16 neighbouring points per light, one rtcOccluded16 each ----------------

LANE_SLOTS = 32  # float64 slots per lane of a packet task's stored points (:func:`store_point`, :func:`store_coef`)


@inline_jit(**CALLED)  # allocates: NRT on
def _packets(nlights):
    """A per-task scratch for the shadow packets of ``nlights`` lights: one occlusion packet per
    light (:func:`~raycast_shade.visibility.secondary.occlusion_packets`: ``buf, ib, off, valid,
    voff, args, aoff, vis``), then ``points``, (LANES, LANE_SLOTS) float64, the lanes' shading
    points, kept between the request and the shading (:func:`store_point`)."""
    buf, ib, off, valid, voff, args, aoff, vis = occlusion_packets(nlights)
    points = np.empty((LANES, LANE_SLOTS), np.float64)
    points[:] = 0.0  # (np.zeros would build two more of Numba's overloads at a cold start)
    return buf, ib, off, valid, voff, args, aoff, vis, points


@inline_jit(**HELPER)
def clear_packets(valid, voff, vis, points):
    """Start a packet task's tile: no ray asked for, no point stored."""
    clear_occlusion(valid, voff, vis)
    for k in range(LANES):
        points[k, 0] = -1.0


@inline_jit(**HELPER)
def request_ray(P, i, k, o, g, s, target, is_point, unit):
    """Ask for light ``i``'s shadow ray of lane ``k`` (:func:`_shadow_ray`'s ray) in the packets of
    ``P = (buf, ib, off, valid, voff)``."""
    org, d, tfar = _shadow_ray(o, g, s, target, is_point, unit)
    set_occlusion_ray(P, i, k, org, d, tfar)


@inline_jit(**HELPER)
def _put3(points, k, j, a):
    points[k, j] = a[0]
    points[k, j + 1] = a[1]
    points[k, j + 2] = a[2]


@inline_jit(**HELPER)
def _get3(points, k, j):
    return points[k, j], points[k, j + 1], points[k, j + 2]


@inline_jit(**HELPER)
def store_point(points, k, hp, mi):
    """Keep lane ``k``'s shading point ``hp`` (:class:`~raycast_shade.shading.records.Hit`) and its
    material row ``mi`` until its packets are traced (float64: exact)."""
    # np.int64 offsets: a constant argument is typed Literal[int], one compile of _put3 per value.
    _put3(points, k, np.int64(1), hp.p)
    _put3(points, k, np.int64(4), hp.v)
    _put3(points, k, np.int64(7), hp.g)
    _put3(points, k, np.int64(10), hp.n)
    _put3(points, k, np.int64(13), hp.o)
    points[k, 16] = hp.sgn
    points[k, 0] = mi


@inline_jit(**HELPER)
def stored_material(points, k):
    """Lane ``k``'s material row as :func:`store_point` kept it; -1: no point in this lane."""
    return np.int32(points[k, 0])  # int32, as a hit's geometry id: the shading helpers compile once


@inline_jit(**HELPER)
def stored_point(points, k):
    """Lane ``k``'s ``(p, v, g, sgn, n, o)`` as :func:`store_point` kept them."""
    return (_get3(points, k, np.int64(1)), _get3(points, k, np.int64(4)), _get3(points, k, np.int64(7)),
            points[k, 16], _get3(points, k, np.int64(10)), _get3(points, k, np.int64(13)))  # see store_point


@inline_jit(**HELPER)
def store_coef(points, k, coef):
    """Keep lane ``k``'s 12 coefficients (a textured point's: costly to look up twice)."""
    for j in range(12):
        points[k, 17 + j] = coef[j]


@inline_jit(**HELPER)
def stored_coef(points, k):
    """Lane ``k``'s 12 coefficients as :func:`store_coef` kept them."""
    return (points[k, 17], points[k, 18], points[k, 19], points[k, 20], points[k, 21], points[k, 22],
            points[k, 23], points[k, 24], points[k, 25], points[k, 26], points[k, 27], points[k, 28])


# -- a strip of 4x4 tiles' background, row by row ------------------------------------------------------------

_GROUP = 16  # strip_background's columns per group: one 64-byte line of the int32 and float32 hit arrays


@inline_jit(**HELPER)
def _strip_background(H, outs, bg, y0, y1):
    """Rows ``y0`` to ``y1 - 1`` (a strip of tiles) in row order: the background's pixels written
    (colour ``bg``; a zero normal when ``outs``' normal array is not the empty stand-in), and for
    each group of :data:`_GROUP` columns with a hit, its lines of ``geom``, ``u``, ``v`` and the
    image asked for (:func:`prefetch`), which the tile order then reads and writes four rows at a
    time. Queued by 4x4 tiles with the background written and the hit rows read in that order, the
    shading (shadow rays aside) took 1.2-1.5x the row order's at 1080p; after this pass, 0.95-1.2x."""
    prim, geom, u, v = H
    image = outs[0]
    w = prim.shape[1]
    for y in range(y0, y1):
        for x0 in range(0, w, _GROUP):
            hit = False
            for x in range(x0, min(x0 + _GROUP, w)):
                if prim[y, x] < 0:
                    store_background(outs, y, x, bg)
                else:
                    hit = True
            if hit:  # rows borrowed without reference counts (a helper compiled without NRT)
                prefetch(geom[y], x0)
                prefetch(u[y], x0)
                prefetch(v[y], x0)
                for c in range(0, _GROUP, 6):  # 16 pixels of 12 bytes: three lines
                    prefetch(image[y], min(x0 + c, w - 1))
