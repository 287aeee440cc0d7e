"""The reflectance equation, evaluated at one point: the one evaluator every shading path calls.

Per channel::

    I = Ia ka + sum_i sum_j vis_ij att_ij(d) Ii/N_i (kd max(n.s, 0) + Ks max(r.v, 0)^t) + ke

with ``r = 2 (n.s) n - s`` (or Blinn-Phong ``(n.h)^t``; or, in place of the bracket, the glTF
metallic-roughness terms of :mod:`.reflectance`'s GGX model), no specular term
where ``n.s <= 0``, ``att`` one of ``1``, ``1/d^2``, ``1/(d + k)``, and
``vis`` 0 or 1 from a shadow ray (:mod:`.shadows`) for lights that cast
shadows. A light is evaluated at its ``N_i`` point samples ``j`` (one, but for an
area light: :class:`raycast_shade.scene.lights.AreaLight`), each carrying ``1/N_i`` of its
intensity. A spot light is a point light whose ``att`` also carries Warn's
factor ``cos^n(a) smoothstep(cos outer, cos inner, cos a)``, ``a`` the angle
between its axis and the direction from the light to the point
(:class:`raycast_shade.scene.lights.SpotLight`); outside its outer cone it
contributes nothing and traces no shadow ray. The viewer's distance never enters: only the direction ``v`` to the
eye does. Integer shininess, the usual case, is raised by repeated squaring
rather than ``pow``. The emission ``ke`` is added last, after the lights'
sum (a zero ``ke`` adds exactly nothing: the images of surfaces without
emission are bit for bit those before it).

:func:`_reflected` is the equation, once: the general Phong kernels, flat's faces, Gouraud's
vertices, the mirrors' bounces and the one-pass terms (:mod:`.terms_kernel`, with a terms
record ``R``: the parts stored apart, the same sum) all call it. The material and light rows
are read through the named slots of :mod:`raycast_shade.common.layout`. Every light kind is
read in one place, :func:`_light_at` (direction, distance, attenuation and cone of sample
``j`` at a point) with :func:`_light_point` (where sample ``j`` is, the shadow ray's target);
the specular lobe is the material's reflectance model (:mod:`.reflectance`). The batched
kernel (:mod:`.phong_fast`) evaluates the same equation lane-parallel for the light kinds,
laws and models it declares (``phong_fast.HANDLES``); every other frame comes here.

The evaluator models no more than a frame needs: :data:`LEAN` declares the lecture's part (point
lights and lights at infinity, Phong and Blinn-Phong). A frame within it, without normal maps or
textures, carries ``L.ext = None`` (:func:`~raycast_shade.shading.inputs.extensions`), and every helper
that holds an extension's branch (:func:`_light_at`, :func:`_light_point`, :func:`_samples`, the
models' ``_diffuse`` and ``_specular``, ``normalmap._normal_map``) takes it as its argument ``ext``,
so Numba prunes the spot and area lights, the GGX model and normal maps before typing them: the
lean build's kernels compile in about 7% less CPU (the whole demo from an empty cache; see the
CHANGELOG) and shade the lean frames bit for bit as the full build does.
"""

from __future__ import annotations

import numpy as np
from ..common.inline import inline_jit

from ..common.layout import (AREA_DISC, ATT_HEURISTIC, ATT_INVERSE_SQUARE, LIGHT_AREA, LIGHT_ATT, LIGHT_AXIS,
                             LIGHT_COS_INNER, LIGHT_COS_OUTER, LIGHT_DIRECTIONAL, LIGHT_EDGE_U, LIGHT_EDGE_V,
                             LIGHT_EXPONENT, LIGHT_K, LIGHT_KIND, LIGHT_RADIANCE, LIGHT_SAMPLES, LIGHT_SHADOWS,
                             LIGHT_SHAPE, LIGHT_SPOT, LIGHT_VEC, MAT_KS, MAT_METALLIC, MAT_MODEL, MAT_ROUGHNESS,
                             MAT_SHININESS, LIGHT_POINT, MODEL_BLINN, MODEL_PHONG)
from .jit import CALLED, HELPER
from .records import (TERM_AMBIENT, TERM_DIFFUSE, TERM_EMISSIVE, TERM_SPECULAR, TERMS_EACH, TERMS_EMIT_ON,
                      TERMS_SHADOW, dot, store3)
from .reflectance import _diffuse, _power, _specular  # noqa: F401 (_power: the spot factor's, and callers')
from .shadows import _occluded, request_ray

__all__ = ["GOLDEN", "LEAN"]

GOLDEN = 0.6180339887498949  # the golden ratio's fractional part: the sample lattice's second axis

# What the lean build implements (layout codes): the light kinds and reflectance models of the lecture.
# A frame with anything else, or with a normal map or a texture, takes the full build (L.ext True;
# inputs.extensions decides).
LEAN = dict(light_kinds=frozenset({LIGHT_POINT, LIGHT_DIRECTIONAL}), models=frozenset({MODEL_PHONG, MODEL_BLINN}))


@inline_jit(**HELPER)
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


@inline_jit(**HELPER)
def _samples(lights, i, ext):
    """How many point samples light ``i`` is evaluated at (1 but for an area light's N; 1 in the lean
    build, ``ext`` None: see :data:`LEAN`)."""
    if ext is None:
        return 1
    return max(1, int(lights[i, LIGHT_SAMPLES]))


@inline_jit(**HELPER)
def _light_point(lights, i, j, ext):
    """Where sample ``j`` of light ``i`` is: its position, or for an area light the ``j``-th point
    of a rank-1 lattice over the emitter (``((j + 1/2) / N, frac(j phi + 1/2))`` in the unit
    square, mapped onto the rectangle's half-edges or, by Shirley and Chiu's concentric map, the
    disc's axes). The lattice is stratified in both axes, and its one point (``N = 1``) is the centre
    exactly. (A light at infinity: its unit direction, not a point.) ``ext`` as for :func:`_light_at`."""
    cx = lights[i, LIGHT_VEC + 0]
    cy = lights[i, LIGHT_VEC + 1]
    cz = lights[i, LIGHT_VEC + 2]
    if ext is None or lights[i, LIGHT_KIND] != LIGHT_AREA:
        return cx, cy, cz
    ns = _samples(lights, i, ext)
    a = 2.0 * ((j + 0.5) / ns) - 1.0
    t = j * GOLDEN + 0.5
    b = 2.0 * (t - np.floor(t)) - 1.0
    if lights[i, LIGHT_SHAPE] == AREA_DISC and (a != 0.0 or b != 0.0):  # concentric: squares to rings
        if abs(a) > abs(b):
            rad, phi = a, (np.pi / 4.0) * (b / a)
        else:
            rad, phi = b, np.pi / 2.0 - (np.pi / 4.0) * (a / b)
        a, b = rad * np.cos(phi), rad * np.sin(phi)
    return (cx + a * lights[i, LIGHT_EDGE_U + 0] + b * lights[i, LIGHT_EDGE_V + 0],
            cy + a * lights[i, LIGHT_EDGE_U + 1] + b * lights[i, LIGHT_EDGE_V + 1],
            cz + a * lights[i, LIGHT_EDGE_U + 2] + b * lights[i, LIGHT_EDGE_V + 2])


@inline_jit(**HELPER)
def _light_at(lights, i, j, p, dmin, att_on, ext):
    """Sample ``j`` of light ``i`` (a row of ``lights``, any kind) seen from point ``p``.

    Returns
    -------
    s : 3-tuple of float
        Unit direction from ``p`` towards the light.
    d : float
        Distance to the light: ``inf`` for a light at infinity, 0 for a light on
        the point (which then has no direction and gives no light).
    att : float
        The distance law (1 without ``att_on``; callers pass an ``np.bool_``, so that this compiles
        once, and LLVM folds the branch where it inlines this with a constant).
    cone : float
        The emission factor towards ``p``: Warn's for a spot light (0 outside its
        cone), the sample's share ``1/N`` of an area light's intensity, 1 otherwise.

    ``ext`` is the frame's ``L.ext``: None for the lean build (:data:`LEAN`: Numba prunes the spot
    and area branches before typing them), True otherwise.
    """
    if lights[i, LIGHT_KIND] == LIGHT_DIRECTIONAL:
        return (lights[i, LIGHT_VEC + 0], lights[i, LIGHT_VEC + 1], lights[i, LIGHT_VEC + 2]), np.inf, 1.0, 1.0
    q = _light_point(lights, i, j, ext)
    dx = q[0] - p[0]
    dy = q[1] - p[1]
    dz = q[2] - p[2]
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
    if ext is None:  # the lean build: point lights and lights at infinity only
        return s, d, att, cone
    if lights[i, LIGHT_KIND] == LIGHT_SPOT:  # a point light with a cone
        cone = _spot_factor(lights, i, s)
    elif lights[i, LIGHT_KIND] == LIGHT_AREA:
        cone = 1.0 / _samples(lights, i, ext)
    return s, d, att, cone


def _illuminate_py(hp, coef, mats, mi, L, S, spec_on, att_on):
    """RGB reflected towards ``hp.v`` at the shading point ``hp``, each shadow ray traced on its own
    (:func:`~raycast_shade.shading.shadows._occluded`): :func:`_reflected` without packets or terms.

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
    L : Lighting
        The frame's lights (:class:`~raycast_shade.shading.records.Lighting`).
    S : tuple
        The shadow-ray scratch (:func:`~raycast_shade.visibility.secondary.ray_scratch`).
    spec_on, att_on : bool
        The frame's flags (``L.spec_on``, ``L.att_on``; Gouraud's diffuse-only pass turns
        ``spec_on`` off): a scene with no specular material or no attenuating light skips
        that arithmetic.
    """
    return _reflected(hp, coef, mats, mi, L, S, L.no_vis, np.int64(-1), spec_on, att_on, None, 0, 0, L.ext)


@inline_jit(**HELPER)
def _reflected(hp, coef, mats, mi, L, S, vis, lane, spec_on, att_on, R, y, x, ext):
    """The reflectance equation at ``hp`` (see the module docstring): the RGB reflected towards
    ``hp.v`` plus the emission.

    ``vis[i, lane]`` is light ``i``'s answer from traced shadow packets (1 blocked, 0 lit, -1 not
    traced: :func:`~raycast_shade.visibility.secondary.trace_occlusion` after :func:`_request_shadows`);
    a ray not traced there (``lane`` -1: no packets; an area light's samples) is traced on its own.

    ``R``: None, or a terms record (:mod:`.records`, ``TERM_*``) that also receives the point's
    parts at ``(y, x)``: ambient, emission, the summed diffuse and specular parts, each light's
    (with per-light terms) and its shadow mask (the fraction of its samples not blocked where a
    unit light would reach the point). ``R is None`` prunes every store at compile time, and the
    returned sum is formed by the same operations in the same order either way: the image of a
    terms pass is the plain frame's, bit for bit.

    ``ext``: the frame's ``L.ext``, passed on as an argument so that Numba prunes, at compile time,
    what the lean build leaves out (:data:`LEAN`)."""
    ambient, lights, dmin, handle, unit = L.ambient, L.lights, L.dmin, L.handle, L.unit
    kar, kag, kab, ker, keg, keb = coef[0], coef[1], coef[2], coef[9], coef[10], coef[11]
    n = hp.n
    r = ambient[0] * kar
    g = ambient[1] * kag
    b = ambient[2] * kab
    if R is not None:
        store3(R[TERM_AMBIENT], y, x, r, g, b)
        if R[TERMS_EMIT_ON]:
            store3(R[TERM_EMISSIVE], y, x, ker, keg, keb)
    dr = dg = db = sr = sg = sb = 0.0
    prm = (mats[mi, MAT_SHININESS], mats[mi, MAT_METALLIC], mats[mi, MAT_ROUGHNESS])
    model = mats[mi, MAT_MODEL]
    has_spec = mats[mi, MAT_KS + 0] > 0.0 or mats[mi, MAT_KS + 1] > 0.0 or mats[mi, MAT_KS + 2] > 0.0
    for i in range(lights.shape[0]):
        ns = _samples(lights, i, ext)
        ldr = ldg = ldb = lsr = lsg = lsb = 0.0
        blocked = 0
        for j in range(ns):
            s, d, att, cone = _light_at(lights, i, j, hp.p, dmin, np.bool_(att_on), ext)
            if d == 0.0 or cone == 0.0:
                continue  # on the point (no direction), or outside a spot's cone: no light, no shadow ray
            att *= cone
            ndots = dot(n, s)
            if ndots <= 0.0:
                continue
            if ndots > 1.0:
                ndots = 1.0
            if lights[i, LIGHT_SHADOWS] != 0.0 and handle != 0:
                seen = vis[i, lane] if lane >= 0 and ns == 1 else -1
                if seen < 0:  # not in a packet
                    seen = 1 if _occluded(handle, S, hp.o, hp.g, s, _light_point(lights, i, j, ext),
                                          d < np.inf, unit) else 0
                if seen != 0:
                    if np.float32(cone * ndots) > 0.0:  # blocked where a unit light would have reached it
                        blocked += 1
                    continue
            fr, fg, fb = _diffuse(model, n, s, hp.v, ndots, coef, prm, ext)
            tr = tg = tb = 0.0
            if spec_on and has_spec:
                tr, tg, tb = _specular(model, n, s, hp.v, ndots, coef, prm, ext)
            ar = att * lights[i, LIGHT_RADIANCE + 0]
            ag = att * lights[i, LIGHT_RADIANCE + 1]
            ab = att * lights[i, LIGHT_RADIANCE + 2]
            r += ar * (fr + tr)
            g += ag * (fg + tg)
            b += ab * (fb + tb)
            if R is not None:  # the parts, formed apart from the sum (it is not their sum, bit for bit)
                pdr, pdg, pdb = ar * fr, ag * fg, ab * fb
                psr, psg, psb = ar * tr, ag * tg, ab * tb
                dr += pdr
                dg += pdg
                db += pdb
                sr += psr
                sg += psg
                sb += psb
                ldr += pdr
                ldg += pdg
                ldb += pdb
                lsr += psr
                lsg += psg
                lsb += psb
        if R is not None:
            R[TERMS_SHADOW][i, y, x] = 1.0 - blocked / ns
            if R[TERMS_EACH].shape[1] > 0:
                store3(R[TERMS_EACH][0, i], y, x, ldr, ldg, ldb)
                store3(R[TERMS_EACH][1, i], y, x, lsr, lsg, lsb)
    if R is not None:
        store3(R[TERM_DIFFUSE], y, x, dr, dg, db)
        store3(R[TERM_SPECULAR], y, x, sr, sg, sb)
    return r + ker, g + keg, b + keb


_illuminate = inline_jit(**HELPER)(_illuminate_py)


@inline_jit(**HELPER)
def _request_shadows(P, k, hp, L):
    """Ask for lane ``k``'s shadow rays in the packets ``P = (buf, ib, off, valid, voff)``
    (:mod:`.shadows`): one per light that :func:`_reflected` would trace a ray for at ``hp``
    (casting shadows, in its cone, not on the point, ``n.s > 0``; one sample: an area light's
    samples are traced by :func:`_reflected` itself), the same ray."""
    lights, dmin, handle, unit, ext = L.lights, L.dmin, L.handle, L.unit, L.ext
    if handle == 0:
        return
    for i in range(lights.shape[0]):
        if lights[i, LIGHT_SHADOWS] == 0.0 or _samples(lights, i, ext) != 1:
            continue
        j = np.int64(0)  # typed as _reflected's loop index: one compile of each helper, not a literal's too
        s, d, _, cone = _light_at(lights, i, j, hp.p, dmin, np.bool_(False), ext)
        if d == 0.0 or cone == 0.0 or dot(hp.n, s) <= 0.0:
            continue
        request_ray(P, i, k, hp.o, hp.g, s, _light_point(lights, i, j, ext), d < np.inf, unit)


@inline_jit(**CALLED)
def _illuminate_call(hp, coef, mats, mi, L, S, spec_on, att_on):
    """:func:`_illuminate` as a call, for rare fallback branches: inlining it there would
    multiply the hot loop's code. (A function of its own: two dispatchers of one Python
    function would share one entry of Numba's disk cache, and load each other's code.)"""
    return _illuminate(hp, coef, mats, mi, L, S, spec_on, att_on)
