"""A mirror ray from a shading point, and the rays the Phong kernels hand over to the mirror kernel.

:func:`_mirror_ray` makes a reflective pixel's first bounce ray from its shading point. The Phong
kernels (:mod:`.phong`, :mod:`.phong_fast`) hold each pixel's point, view vector and normals as they
shade it; for a frame with mirrors they write each reflective pixel's ray with
:func:`store_ray` (:func:`hand_over_buffers`), and the mirror kernel (:mod:`.mirrors`) reads it
instead of gathering the pixel's face and vertices and computing its point a second time.
A module of its own so that the Phong kernels and the mirror kernel all import it without
importing each other.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from ..common.inline import inline_jit
from ..common.layout import MAT_REFLECTIVITY
from .jit import HELPER
from .lanes import _A, _FN, _G, _N, _P, _V, LANES
from .records import reflect_into
from .shadows import _nudge

__all__ = ["NO_RAYS", "hand_over_buffers", "hand_over", "hand_over_lanes", "store_ray"]

# The kernels' ``rays`` when nothing is handed over: (0, 0, 3) stand-ins, never indexed.
NO_RAYS = (np.empty((0, 0, 3), np.float32), np.empty((0, 0, 3), np.float64))


@intrinsic
def _bits(typingctx, x):
    """The IEEE-754 bits of a float64, as an int64."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _from_bits(typingctx, b):
    """The float64 whose IEEE-754 bits are the int64 ``b``."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@intrinsic
def _fused(typingctx, a, b, c):
    """``a * b + c`` rounded once (``llvm.fma``), whatever the optimiser makes of the code around it.

    The origins' ``p + n * step`` are contracted under the kernels' ``contract`` flag only where
    the multiply and the add end up in one basic block, which depends on how the code around them
    was optimised: :func:`_mirror_ray` and :func:`lane_rays` must round alike (bit for bit), so
    both fuse explicitly, as their contracted form did."""
    def codegen(context, builder, signature, args):
        f64 = ir.DoubleType()
        fma = builder.module.declare_intrinsic("llvm.fma", [f64], ir.FunctionType(f64, [f64, f64, f64]))
        return builder.call(fma, args)

    return types.float64(types.float64, types.float64, types.float64), codegen


@inline_jit(**HELPER)
def _odd(p):
    """Whether :func:`_offset` leaves coordinate ``p`` to ``_nudge`` (exponent bits of a subnormal
    step, inf or NaN), given that ``p`` is not near zero (shared by :func:`lane_rays`' redo)."""
    e = (_bits(p) >> 52) & 0x7FF
    return e < 16 or e == 0x7FF


@inline_jit(**HELPER)
def _offset(p, n, unit):
    """:func:`~raycast_shade.shading.shadows._nudge`, bit for bit, with its step read off
    ``p``'s exponent bits instead of ``frexp`` and ``ldexp`` (two library calls a coordinate,
    a third of the cost of a mirror ray's origin): for a normal ``p`` of biased exponent ``E``,
    ``frexp`` gives ``E - 1022`` and the step ``ldexp(256, E - 1022 - 24)`` is ``2**(E - 1038)``,
    the float64 of biased exponent ``E - 15``. A subnormal step, inf and NaN take ``_nudge``
    itself."""
    if abs(p) < unit * (1.0 / 32.0):
        step = unit * (1.0 / 65536.0)
    elif _odd(p):
        return _nudge(p, n, unit)
    else:
        step = _from_bits((((_bits(p) >> 52) & 0x7FF) - 15) << 52)
    return _fused(n, step, p)  # one expression for both steps, fused as _nudge's is contracted


@inline_jit(**HELPER)
def _mirror_ray(hp, unit):
    """The mirror ray of shading point ``hp`` (:class:`~raycast_shade.shading.records.Hit`):
    the incoming direction ``d = -v`` reflected about ``n``, ``r = d - 2 (d.n) n``, kept above
    the geometric surface, from an origin pushed off along ``g``. Returns ``(origin, r)``."""
    vx, vy, vz = hp.v
    nx, ny, nz = hp.n
    dn = -(vx * nx + vy * ny + vz * nz)
    r = (-vx - 2.0 * dn * nx, -vy - 2.0 * dn * ny, -vz - 2.0 * dn * nz)
    r = reflect_into(r, hp.g)  # a bent shading normal sent it below the surface
    p, g = hp.p, hp.g
    return (_offset(p[0], g[0], unit), _offset(p[1], g[1], unit), _offset(p[2], g[2], unit)), r


@inline_jit(**HELPER)
def store_ray(rays, y, x, ray):
    """Hand over pixel ``(y, x)``'s mirror ray ``ray = (origin, direction)`` in ``rays = (org, dr)``
    ((R, W, 3) float32 and float64). The origin goes to Embree as float32 anyway (rounded once, here
    rather than in the packet); the direction stays float64: a bounce that meets a surface is shaded
    seen along it."""
    org, dr = rays
    o, r = ray
    for c in range(3):
        org[y, x, c] = o[c]
        dr[y, x, c] = r[c]


@inline_jit(**HELPER)
def hand_over(rays, y, x, hp, rho, unit):
    """In a general Phong kernel: pixel ``(y, x)``'s mirror ray from its shading point ``hp`` into
    ``rays`` when its surface reflects (``rho > 0``) and the frame hands rays over (``rays`` is not
    :data:`NO_RAYS`)."""
    if rays[0].shape[0] != 0 and rho > 0.0:
        store_ray(rays, y, x, _mirror_ray(hp, unit))


@inline_jit(**HELPER)
def lane_rays(S, n, unit):
    """The first ``n`` lanes' :func:`_mirror_ray` from the batched Phong kernel's scratch ``S``
    (:mod:`.lanes`, once :func:`.phong_fast._geometry` has run): each origin into field ``_A``, each
    direction into ``_FN`` (both free by then). Passes without branches (selects), which
    vectorise, over every lane: the same operations in the same order as the scalar helpers, bit
    for bit; then the coordinates whose step :func:`_offset` takes from ``_nudge`` (rare: the step
    of a subnormal, inf or NaN) are redone by :func:`_offset` itself."""
    for k in range(LANES):
        vx, vy, vz = S[(_V + 0) * LANES + k], S[(_V + 1) * LANES + k], S[(_V + 2) * LANES + k]
        nx, ny, nz = S[(_N + 0) * LANES + k], S[(_N + 1) * LANES + k], S[(_N + 2) * LANES + k]
        gx, gy, gz = S[(_G + 0) * LANES + k], S[(_G + 1) * LANES + k], S[(_G + 2) * LANES + k]
        dn = -(vx * nx + vy * ny + vz * nz)
        rx = -vx - 2.0 * dn * nx
        ry = -vy - 2.0 * dn * ny
        rz = -vz - 2.0 * dn * nz
        c = rx * gx + ry * gy + rz * gz  # records.reflect_into, as a select
        below = c < 0.0
        S[(_FN + 0) * LANES + k] = rx - 2.0 * c * gx if below else rx
        S[(_FN + 1) * LANES + k] = ry - 2.0 * c * gy if below else ry
        S[(_FN + 2) * LANES + k] = rz - 2.0 * c * gz if below else rz
    for j in range(3):
        for k in range(LANES):  # _offset, its two steps as a select
            p = S[(_P + j) * LANES + k]
            e = (_bits(p) >> 52) & 0x7FF
            step = unit * (1.0 / 65536.0) if abs(p) < unit * (1.0 / 32.0) else _from_bits((e - 15) << 52)
            S[(_A + j) * LANES + k] = _fused(S[(_G + j) * LANES + k], step, p)
    for k in range(n):
        for j in range(3):
            p = S[(_P + j) * LANES + k]
            if not abs(p) < unit * (1.0 / 32.0) and _odd(p):
                S[(_A + j) * LANES + k] = _offset(p, S[(_G + j) * LANES + k], unit)


@inline_jit(**HELPER)
def hand_over_lanes(S, XY, n, materials, unit, rays):
    """In the batched Phong kernel, once a batch is shaded: the mirror rays (:func:`lane_rays`) of
    its first ``n`` lanes whose surface reflects (lane ``k``: pixel ``(XY[k], XY[LANES + k])``,
    model ``XY[2 LANES + k]``) into ``rays``, unless it is :data:`NO_RAYS`."""
    if rays[0].shape[0] == 0:
        return
    lane_rays(S, n, unit)
    for k in range(n):
        if materials[XY[2 * LANES + k], MAT_REFLECTIVITY] > 0.0:
            store_ray(rays, XY[k], XY[LANES + k], (
                (S[(_A + 0) * LANES + k], S[(_A + 1) * LANES + k], S[(_A + 2) * LANES + k]),
                (S[(_FN + 0) * LANES + k], S[(_FN + 1) * LANES + k], S[(_FN + 2) * LANES + k])))


def hand_over_buffers(rows: int, width: int) -> tuple:
    """The ``rays`` a Phong kernel writes a frame's (or band's) mirror rays into: 36 bytes a pixel,
    written only at the reflective pixels (the others' pages are never touched).

    Returns
    -------
    org : (rows, width, 3) float32
    dr : (rows, width, 3) float64
    """
    return np.empty((rows, width, 3), np.float32), np.empty((rows, width, 3), np.float64)
