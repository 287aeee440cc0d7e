"""The reflectance equation, evaluated at one point.

Per channel::

    I = Ia ka + sum_i vis_i att_i(d) Ii (kd max(n.s, 0) + Ks max(r.v, 0)^t)

with ``r = 2 (n.s) n - s`` (or Blinn-Phong ``(n.h)^t``), no specular term
where ``n.s <= 0``, ``att`` one of ``1``, ``1/d^2``, ``1/(d + k)``, and
``vis`` 0 or 1 from a shadow ray (:mod:`.shadows`) for lights that cast
shadows. A spot light is a point light whose ``att`` also carries Warn's
factor ``cos^n(a) smoothstep(cos outer, cos inner, cos a)``, ``a`` the angle
between its axis and the direction from the light to the point
(:class:`raycast_shade.scene.lights.SpotLight`); outside its outer cone it
contributes nothing and traces no shadow ray. The viewer's distance never enters: only the direction ``v`` to the
eye does. Integer shininess, the usual case, is raised by repeated squaring
rather than ``pow``.

The material and light rows are read through the named slots of
:mod:`raycast_shade.common.layout`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import (ATT_HEURISTIC, ATT_INVERSE_SQUARE, LIGHT_ATT, LIGHT_AXIS, LIGHT_COS_INNER,
                             LIGHT_COS_OUTER, LIGHT_DIRECTIONAL, LIGHT_EXPONENT, LIGHT_K, LIGHT_KIND,
                             LIGHT_RADIANCE, LIGHT_SHADOWS, LIGHT_SPOT, LIGHT_VEC, MAT_BLINN, MAT_KA, MAT_KD, MAT_KS,
                             MAT_SHININESS)
from .jit import CALLED, HELPER
from .shadows import _occluded

__all__ = []


@njit(**HELPER)
def _power(c, t):
    """``c ** t`` for ``0 <= c <= 1``: repeated squaring when ``t`` is a whole
    number up to 4096 (a few multiplications, within a few ulps of ``pow``,
    which costs several times more), ``pow`` otherwise."""
    n = int(t)
    if n != t or n > 4096:
        return c ** t
    r = 1.0
    while n > 0:
        if n & 1:
            r *= c
        c *= c
        n >>= 1
    return r


@njit(**HELPER)
def _spot_factor(lights, i, sx, sy, sz):
    """Warn's factor of spot light ``i`` for the unit direction ``s`` from the
    point towards the light: ``cos^n a`` times the smooth step from the outer
    cone (0) to the inner one (1), with ``cos a = -s . axis``; 0 outside."""
    c = -(sx * lights[i, LIGHT_AXIS + 0] + sy * lights[i, LIGHT_AXIS + 1] + sz * lights[i, LIGHT_AXIS + 2])
    co = lights[i, LIGHT_COS_OUTER]
    if not c > co:
        return 0.0
    if c > 1.0:
        c = 1.0
    ci = lights[i, LIGHT_COS_INNER]
    f = _power(c, lights[i, LIGHT_EXPONENT])
    if c < ci:  # between the cones (never with inner == outer)
        t = (c - co) / (ci - co)
        f *= t * t * (3.0 - 2.0 * t)
    return f


def _illuminate_py(px, py, pz, nx, ny, nz, vx, vy, vz, mats, mi, coef, ambient, lights, dmin, handle, unit, S,
                   ox, oy, oz, gx, gy, gz, spec_on, att_on):
    """RGB reflected towards unit ``v`` at point ``p`` with unit normal ``n``.

    ``mats[mi]`` is the material row (indexed, not sliced: a slice per pixel
    would cost an atomic reference count shared by all threads); its
    shininess, Blinn flag and whether it has a specular term apply. The
    point's own ``ka, kd, ks`` come in ``coef``, a tuple of nine floats: the
    row's, or textured and coloured ones (:mod:`.texture`). (One tuple, not
    nine arguments: CPython passes a call of more than 30 arguments as
    ``*args``, which Numba cannot inline.)
    ``ambient`` (3,), ``lights`` (L, LIGHT_SIZE), ``dmin``, ``handle`` and
    ``unit`` are the unpacked ``L`` of
    :func:`~raycast_shade.shading.inputs.kernel_inputs`; ``S`` is the
    shadow-ray scratch; shadow rays start at ``o`` pushed off along ``g``.
    ``spec_on`` and ``att_on`` are compile-time constants (see
    :mod:`.jit`): a scene with no specular material or no attenuating light
    compiles without that arithmetic.
    """
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb = coef
    r = ambient[0] * kar
    g = ambient[1] * kag
    b = ambient[2] * kab
    shin = mats[mi, MAT_SHININESS]
    blinn = mats[mi, MAT_BLINN] != 0.0
    has_spec = mats[mi, MAT_KS + 0] > 0.0 or mats[mi, MAT_KS + 1] > 0.0 or mats[mi, MAT_KS + 2] > 0.0
    for i in range(lights.shape[0]):
        is_point = lights[i, LIGHT_KIND] != LIGHT_DIRECTIONAL  # spot lights are point lights with a cone
        if not is_point:
            sx = lights[i, LIGHT_VEC + 0]
            sy = lights[i, LIGHT_VEC + 1]
            sz = lights[i, LIGHT_VEC + 2]
            att = 1.0
        else:
            dx = lights[i, LIGHT_VEC + 0] - px
            dy = lights[i, LIGHT_VEC + 1] - py
            dz = lights[i, LIGHT_VEC + 2] - pz
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            if d == 0.0:
                continue  # light on the surface point: no direction, no light
            sx = dx / d
            sy = dy / d
            sz = dz / d
            att = 1.0
            if att_on:
                if lights[i, LIGHT_ATT] == ATT_INVERSE_SQUARE:
                    dd = max(d, dmin)
                    att = 1.0 / (dd * dd)
                elif lights[i, LIGHT_ATT] == ATT_HEURISTIC:
                    att = 1.0 / (d + lights[i, LIGHT_K])
            if lights[i, LIGHT_KIND] == LIGHT_SPOT:
                spot = _spot_factor(lights, i, sx, sy, sz)
                if spot == 0.0:
                    continue  # outside the cone: no light, no shadow ray
                att *= spot
        ndots = nx * sx + ny * sy + nz * sz
        if ndots <= 0.0:
            continue
        if ndots > 1.0:
            ndots = 1.0
        if lights[i, LIGHT_SHADOWS] != 0.0 and handle != 0:
            if _occluded(handle, S, ox, oy, oz, gx, gy, gz, sx, sy, sz,
                         lights[i, LIGHT_VEC + 0], lights[i, LIGHT_VEC + 1], lights[i, LIGHT_VEC + 2], is_point, unit):
                continue
        spec = 0.0
        if spec_on and has_spec:
            if blinn:
                hx = sx + vx
                hy = sy + vy
                hz = sz + vz
                hl = np.sqrt(hx * hx + hy * hy + hz * hz)
                c = (nx * hx + ny * hy + nz * hz) / hl if hl > 0.0 else 0.0
            else:
                rx = 2.0 * ndots * nx - sx
                ry = 2.0 * ndots * ny - sy
                rz = 2.0 * ndots * nz - sz
                c = rx * vx + ry * vy + rz * vz
            if c > 0.0:
                spec = _power(min(c, 1.0), shin)
        r += att * lights[i, LIGHT_RADIANCE + 0] * (kdr * ndots + ksr * spec)
        g += att * lights[i, LIGHT_RADIANCE + 1] * (kdg * ndots + ksg * spec)
        b += att * lights[i, LIGHT_RADIANCE + 2] * (kdb * ndots + ksb * spec)
    return r, g, b


_illuminate = njit(**HELPER)(_illuminate_py)


@njit(**CALLED)
def _illuminate_call(px, py, pz, nx, ny, nz, vx, vy, vz, mats, mi, coef, ambient, lights, dmin, handle, unit, S,
                     ox, oy, oz, gx, gy, gz, spec_on, att_on):
    """:func:`_illuminate` as a call, for rare fallback branches: inlining it there would
    multiply the hot loop's code. (A function of its own: two dispatchers of one Python
    function would share one entry of Numba's disk cache, and load each other's code.)"""
    return _illuminate(px, py, pz, nx, ny, nz, vx, vy, vz, mats, mi, coef, ambient, lights, dmin, handle, unit, S,
                       ox, oy, oz, gx, gy, gz, spec_on, att_on)
