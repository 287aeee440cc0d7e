"""The reflectance equation, evaluated at one point.

Per channel::

    I = Ia ka + sum_i vis_i att_i(d) Ii (kd max(n.s, 0) + Ks max(r.v, 0)^t) + ke

with ``r = 2 (n.s) n - s`` (or Blinn-Phong ``(n.h)^t``), no specular term
where ``n.s <= 0``, ``att`` one of ``1``, ``1/d^2``, ``1/(d + k)``, and
``vis`` 0 or 1 from a shadow ray (:mod:`.shadows`) for lights that cast
shadows. A spot light is a point light whose ``att`` also carries Warn's
factor ``cos^n(a) smoothstep(cos outer, cos inner, cos a)``, ``a`` the angle
between its axis and the direction from the light to the point
(:class:`raycast_shade.scene.lights.SpotLight`); outside its outer cone it
contributes nothing and traces no shadow ray. The viewer's distance never enters: only the direction ``v`` to the
eye does. Integer shininess, the usual case, is raised by repeated squaring
rather than ``pow``. The emission ``ke`` is added last, after the lights'
sum (a zero ``ke`` adds exactly nothing: the images of surfaces without
emission are bit for bit those before it).

The material and light rows are read through the named slots of
:mod:`raycast_shade.common.layout`. Every light kind is read in one place,
:func:`_light_at` (direction, distance, attenuation and cone at a point); the
specular lobe is the material's reflectance model (:mod:`.reflectance`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import (ATT_HEURISTIC, ATT_INVERSE_SQUARE, LIGHT_ATT, LIGHT_AXIS, LIGHT_COS_INNER,
                             LIGHT_COS_OUTER, LIGHT_DIRECTIONAL, LIGHT_EXPONENT, LIGHT_K, LIGHT_KIND,
                             LIGHT_RADIANCE, LIGHT_SHADOWS, LIGHT_SPOT, LIGHT_VEC, MAT_KS, MAT_MODEL,
                             MAT_SHININESS)
from .jit import CALLED, HELPER
from .records import dot
from .reflectance import _specular_cosine
from .shadows import _occluded, request_ray

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
def _spot_factor(lights, i, s):
    """Warn's factor of spot light ``i`` for the unit direction ``s`` from the
    point towards the light: ``cos^n a`` times the smooth step from the outer
    cone (0) to the inner one (1), with ``cos a = -s . axis``; 0 outside."""
    c = -(s[0] * lights[i, LIGHT_AXIS + 0] + s[1] * lights[i, LIGHT_AXIS + 1] + s[2] * lights[i, LIGHT_AXIS + 2])
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


@njit(**HELPER)
def _light_at(lights, i, p, dmin, att_on):
    """Light ``i`` (a row of ``lights``, any kind) seen from point ``p``.

    Returns
    -------
    s : 3-tuple of float
        Unit direction from ``p`` towards the light.
    d : float
        Distance to the light: ``inf`` for a light at infinity, 0 for a light on
        the point (which then has no direction and gives no light).
    att : float
        The distance law (1 without ``att_on``; callers pass an ``np.bool_``, so that this compiles
        once, and LLVM folds the branch where it inlines this into a variant's kernel; see :mod:`.jit`).
    cone : float
        The emission factor towards ``p``: Warn's for a spot light (0 outside its
        cone), 1 otherwise.
    """
    if lights[i, LIGHT_KIND] == LIGHT_DIRECTIONAL:
        return (lights[i, LIGHT_VEC + 0], lights[i, LIGHT_VEC + 1], lights[i, LIGHT_VEC + 2]), np.inf, 1.0, 1.0
    dx = lights[i, LIGHT_VEC + 0] - p[0]
    dy = lights[i, LIGHT_VEC + 1] - p[1]
    dz = lights[i, LIGHT_VEC + 2] - p[2]
    d = np.sqrt(dx * dx + dy * dy + dz * dz)
    if d == 0.0:
        return (0.0, 0.0, 0.0), 0.0, 1.0, 0.0
    s = (dx / d, dy / d, dz / d)
    att = 1.0
    if att_on:
        if lights[i, LIGHT_ATT] == ATT_INVERSE_SQUARE:
            dd = max(d, dmin)
            att = 1.0 / (dd * dd)
        elif lights[i, LIGHT_ATT] == ATT_HEURISTIC:
            att = 1.0 / (d + lights[i, LIGHT_K])
    cone = 1.0
    if lights[i, LIGHT_KIND] == LIGHT_SPOT:  # a point light with a cone
        cone = _spot_factor(lights, i, s)
    return s, d, att, cone


_NO_VIS = np.zeros((1, 1), np.int8)  # no packet visibility: every shadow ray is traced on its own


def _illuminate_py(hp, coef, mats, mi, L, S, spec_on, att_on):
    """RGB reflected towards ``hp.v`` at the shading point ``hp``, each shadow ray traced on its own
    (:func:`~raycast_shade.shading.shadows._occluded`).

    Parameters
    ----------
    hp : Hit
        The point, view, normals and shadow origin (:mod:`.records`); shadow rays
        start at ``hp.o`` pushed off along ``hp.g``.
    coef : 12-tuple of float
        The point's own ``ka, kd, ks, ke``: the material row's, or textured and
        coloured ones (:mod:`.texture`).
    mats : (G, MAT_SIZE) float64
        Material rows; row ``mi`` (indexed, not sliced: a slice per pixel would
        cost an atomic reference count shared by all threads) gives the
        shininess, the reflectance model and whether there is a specular term.
    L : tuple
        ``(ambient, lights, dmin, handle, unit)`` of
        :class:`~raycast_shade.shading.inputs.FrameInputs`.
    S : tuple
        The shadow-ray scratch (:func:`~raycast_shade.shading.shadows._scratch`).
    spec_on, att_on : bool
        Compile-time constants (see :mod:`.jit`): a scene with no specular
        material or no attenuating light compiles without that arithmetic.
    """
    return _reflected(hp, coef, mats, mi, L, S, _NO_VIS, -1, spec_on, att_on)


@njit(**HELPER)
def _reflected(hp, coef, mats, mi, L, S, vis, lane, spec_on, att_on):
    """:func:`_illuminate_py` with the answers of traced shadow packets: ``vis[i, lane]`` is light
    ``i``'s for this point (1 blocked, 0 lit, -1 not traced), from
    :func:`~raycast_shade.shading.shadows.trace_packets` after :func:`_request_shadows`; a ray
    not traced there (``lane`` -1: no packets) is traced on its own."""
    ambient, lights, dmin, handle, unit = L
    kar, kag, kab, kdr, kdg, kdb, ksr, ksg, ksb, ker, keg, keb = coef
    n = hp.n
    r = ambient[0] * kar
    g = ambient[1] * kag
    b = ambient[2] * kab
    shin = mats[mi, MAT_SHININESS]
    model = mats[mi, MAT_MODEL]
    has_spec = mats[mi, MAT_KS + 0] > 0.0 or mats[mi, MAT_KS + 1] > 0.0 or mats[mi, MAT_KS + 2] > 0.0
    for i in range(lights.shape[0]):
        s, d, att, cone = _light_at(lights, i, hp.p, dmin, np.bool_(att_on))
        if d == 0.0 or cone == 0.0:
            continue  # on the point (no direction), or outside a spot's cone: no light, no shadow ray
        att *= cone
        ndots = dot(n, s)
        if ndots <= 0.0:
            continue
        if ndots > 1.0:
            ndots = 1.0
        if lights[i, LIGHT_SHADOWS] != 0.0 and handle != 0:
            seen = vis[i, lane] if lane >= 0 else -1
            if seen < 0:  # not in a packet
                target = (lights[i, LIGHT_VEC + 0], lights[i, LIGHT_VEC + 1], lights[i, LIGHT_VEC + 2])
                seen = 1 if _occluded(handle, S, hp.o, hp.g, s, target, d < np.inf, unit) else 0
            if seen != 0:
                continue
        spec = 0.0
        if spec_on and has_spec:
            c = _specular_cosine(model, n, s, hp.v, ndots)
            if c > 0.0:
                spec = _power(min(c, 1.0), shin)
        r += att * lights[i, LIGHT_RADIANCE + 0] * (kdr * ndots + ksr * spec)
        g += att * lights[i, LIGHT_RADIANCE + 1] * (kdg * ndots + ksg * spec)
        b += att * lights[i, LIGHT_RADIANCE + 2] * (kdb * ndots + ksb * spec)
    return r + ker, g + keg, b + keb


_illuminate = njit(**HELPER)(_illuminate_py)


@njit(**HELPER)
def _request_shadows(P, k, hp, L):
    """Ask for lane ``k``'s shadow rays in the packets ``P = (buf, ib, off, valid, voff)``
    (:mod:`.shadows`): one per light that :func:`_reflected` would trace a ray for at ``hp``
    (casting shadows, in its cone, not on the point, ``n.s > 0``), the same ray."""
    lights, dmin, handle, unit = L[1], L[2], L[3], L[4]
    if handle == 0:
        return
    for i in range(lights.shape[0]):
        if lights[i, LIGHT_SHADOWS] == 0.0:
            continue
        s, d, _, cone = _light_at(lights, i, hp.p, dmin, np.bool_(False))
        if d == 0.0 or cone == 0.0 or dot(hp.n, s) <= 0.0:
            continue
        target = (lights[i, LIGHT_VEC + 0], lights[i, LIGHT_VEC + 1], lights[i, LIGHT_VEC + 2])
        request_ray(P, i, k, hp.o, hp.g, s, target, d < np.inf, unit)


@njit(**CALLED)
def _illuminate_call(hp, coef, mats, mi, L, S, spec_on, att_on):
    """:func:`_illuminate` as a call, for rare fallback branches: inlining it there would
    multiply the hot loop's code. (A function of its own: two dispatchers of one Python
    function would share one entry of Numba's disk cache, and load each other's code.)"""
    return _illuminate(hp, coef, mats, mi, L, S, spec_on, att_on)
