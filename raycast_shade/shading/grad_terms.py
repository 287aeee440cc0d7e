"""Reverse-mode derivatives of the reflectance equation at one point, beside its terms.

:func:`_reflected_vjp` is the vector-Jacobian product of
:func:`~raycast_shade.shading.illumination._reflected` for the models and lights that have
hand derivatives here: given ``gI = dL/dI`` (RGB) at a shading point, it adds ``dL/dparameter``
into one row of an accumulator and returns ``dL/dn``, the derivative with respect to the unit
shading normal. It calls the forward terms themselves (:func:`_light_at`, the lobe cosines of
:mod:`.reflectance`, :func:`_power`, the shadow query) for the values, and differentiates each
term beside it::

    I      = Ia ka + sum_i vis_i att_i Ii (kd (n.s) + ks c^t) + ke
    att_i  = law(d) cone(s)          law: 1, 1/max(d, dmin)^2, 1/(d + k)
    c      = r.v = 2 (n.s)(n.v) - s.v        (Phong)
           = n.h / |h|,  h = s + v           (Blinn-Phong)
    s      = (q - p) / d,  d = |q - p|       (point, spot; q the light's position)
           = the light's unit vector         (directional)

so that ``dc/dn = 2 ((n.v) s + (n.s) v)``, ``dc/ds = 2 (n.v) n - v`` (Phong) or ``dc/dn = h/|h|``,
``dc/ds = (n - c h/|h|) / |h|`` (Blinn), ``d(c^t)/dc = t c^(t-1)``, ``d(c^t)/dt = c^t ln c``
(both 0 where ``c`` is clamped at 0 or 1), ``ds/dq = (I - s s^T) / d``, ``dd/dq = s``.
Shadow visibility ``vis`` is held fixed: the same shadow ray as the forward pass is traced,
and a blocked light contributes nothing (its gradient is 0 almost everywhere). Where the
specular coefficient is 0 (the forward pass skips the lobe) ``dI/dks`` is still the lobe
``c^t``: the one-sided derivative a fit starting from ``ks = 0`` needs.

The accumulator row's slots (per-model block, then the ambient, then per-light blocks) are
named by ``GM_*`` and ``GL_*``; :func:`layout` gives a frame's offsets.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import (ATT_HEURISTIC, ATT_INVERSE_SQUARE, LIGHT_AREA, LIGHT_ATT, LIGHT_AXIS, LIGHT_COS_INNER,
                             LIGHT_COS_OUTER, LIGHT_DIRECTIONAL, LIGHT_EDGE_U, LIGHT_EDGE_V, LIGHT_EXPONENT,
                             LIGHT_KIND, LIGHT_RADIANCE, LIGHT_SAMPLES, LIGHT_SHADOWS, LIGHT_SPOT, LIGHT_VEC, MAT_METALLIC,
                             MAT_MODEL, MAT_ROUGHNESS, MAT_SHININESS, MODEL_BLINN, MODEL_GGX)
from .grad_ggx import _ggx_vjp
from .illumination import _light_at, _light_point, _samples
from .jit import HELPER
from .records import dot
from .reflectance import _blinn_cosine, _phong_cosine, _power
from .shadows import _occluded

__all__ = ["GM_KA", "GM_KD", "GM_KS", "GM_T", "GM_METALLIC", "GM_ROUGHNESS", "GM_REFLECTIVITY", "GM_SIZE", "GL_VEC", "GL_RAD", "GL_K",
           "GL_COS_INNER", "GL_COS_OUTER", "GL_EDGE_U", "GL_EDGE_V", "GL_SIZE", "layout"]

# A model's block of the accumulator row: d/dka (3), d/dkd (3), d/dks (3), d/dshininess, the GGX
# model's d/dmetallic, d/droughness (:mod:`.grad_ggx`), and d/dreflectivity (:mod:`.grad_mirror`).
GM_KA, GM_KD, GM_KS, GM_T, GM_METALLIC, GM_ROUGHNESS, GM_REFLECTIVITY, GM_SIZE = 0, 3, 6, 9, 10, 11, 12, 13
# A light's block: d/d(its row's vector: position re-centred, or the unit vector towards it) (3),
# d/d(radiance Ii * colour) (3), d/dk (the heuristic law's constant), d/d(cos inner), d/d(cos outer)
# (a spot light's cone cosines), d/d an area light's packed half-axes (3 each: its samples sit at
# ``centre + a eu + b ev``, fixed ``(a, b)``).
GL_VEC, GL_RAD, GL_K, GL_COS_INNER, GL_COS_OUTER, GL_EDGE_U, GL_EDGE_V, GL_SIZE = 0, 3, 6, 7, 8, 9, 12, 15


def layout(n_models: int, n_lights: int) -> tuple:
    """``(ambient offset, first light's offset, row length)`` of the accumulator row for a frame
    of ``n_models`` models and ``n_lights`` lights (the models' blocks come first, at 0)."""
    amb = n_models * GM_SIZE
    return amb, amb + 3, amb + 3 + n_lights * GL_SIZE


@njit(**HELPER)
def _cosine_vjp(model, n, s, v, ndots):
    """The lobe's cosine ``c`` (:func:`_phong_cosine` or :func:`_blinn_cosine`) with ``dc/dn``,
    ``dc/ds`` and ``dc/dv`` (3-tuples; zero where Blinn's half vector vanishes). Phong's
    ``c = 2 (n.s)(n.v) - s.v`` is symmetric in ``s`` and ``v``; Blinn's depends on ``h = s + v``,
    so ``dc/dv = dc/ds``."""
    if model == MODEL_BLINN:
        c = _blinn_cosine(n, s, v, ndots)
        h = (s[0] + v[0], s[1] + v[1], s[2] + v[2])
        hl = np.sqrt(dot(h, h))
        if not hl > 0.0:
            return c, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        u = (h[0] / hl, h[1] / hl, h[2] / hl)
        dh = ((n[0] - c * u[0]) / hl, (n[1] - c * u[1]) / hl, (n[2] - c * u[2]) / hl)
        return c, u, dh, dh
    c = _phong_cosine(n, s, v, ndots)
    nv = dot(n, v)
    return (c, (2.0 * (nv * s[0] + ndots * v[0]), 2.0 * (nv * s[1] + ndots * v[1]), 2.0 * (nv * s[2] + ndots * v[2])),
            (2.0 * nv * n[0] - v[0], 2.0 * nv * n[1] - v[1], 2.0 * nv * n[2] - v[2]),
            (2.0 * ndots * n[0] - s[0], 2.0 * ndots * n[1] - s[1], 2.0 * ndots * n[2] - s[2]))


@njit(**HELPER)
def _lobe_vjp(c, t):
    """``(c^t, d(c^t)/dc, d(c^t)/dt)`` of :func:`~raycast_shade.shading.reflectance._lobe`'s
    clamped cosine (derivatives 0 where ``c <= 0`` or ``c >= 1``, the clamps)."""
    if not c > 0.0:
        return 0.0, 0.0, 0.0
    cc = min(c, 1.0)
    spec = _power(cc, t)
    if cc < 1.0:
        return spec, t * spec / cc, spec * np.log(cc)
    return spec, 0.0, 0.0


@njit(**HELPER)
def _spot_slope(lights, i, s):
    """Warn's factor (:func:`~raycast_shade.shading.illumination._spot_factor`) at the unit direction
    ``s`` towards the light, differentiated: ``(d cone/d cos a, d cone/d cos inner, d cone/d cos outer)``.
    All 0 outside the outer cone and where ``cos a`` is clamped at 1; the cone cosines' only between
    the cones, where the smooth step ``t^2 (3 - 2t)``, ``t = (cos a - cos outer)/(cos inner - cos outer)``
    depends on them (its slope ``6 t (1 - t)`` is 0 at both edges: the factor is C1 in the angles there)."""
    c = -(s[0] * lights[i, LIGHT_AXIS + 0] + s[1] * lights[i, LIGHT_AXIS + 1] + s[2] * lights[i, LIGHT_AXIS + 2])
    co = lights[i, LIGHT_COS_OUTER]
    if not c > co or not c < 1.0 or not c > 0.0:
        return 0.0, 0.0, 0.0
    e = lights[i, LIGHT_EXPONENT]
    f = _power(c, e)
    df = e * f / c
    ci = lights[i, LIGHT_COS_INNER]
    if c < ci:
        span = ci - co
        t = (c - co) / span
        sm = t * t * (3.0 - 2.0 * t)
        dsm = f * 6.0 * t * (1.0 - t) / span  # f d(smooth step)/dt / span
        return df * sm + dsm, -t * dsm, (t - 1.0) * dsm
    return df, 0.0, 0.0


@njit(**HELPER)
def _light_vjp(lights, i, s, d, law, cone, dmin, att_on, g_att, gs):
    """Back through :func:`~raycast_shade.shading.illumination._light_at`: given ``dL/d att``
    (``att = law cone``) and ``dL/ds``, returns ``dL/d`` the light row's vector (position, or for a
    light at infinity its unit vector towards the light), ``dL/dk`` and ``dL/d`` a spot light's
    cone cosines (inner, outer)."""
    kind = lights[i, LIGHT_KIND]
    if kind == LIGHT_DIRECTIONAL:
        return gs, 0.0, (0.0, 0.0)
    gx, gy, gz = gs
    g_cones = (0.0, 0.0)
    if kind == LIGHT_SPOT:  # cos a = -s . axis
        dc, dci, dco = _spot_slope(lights, i, s)
        w = g_att * law * dc
        g_cones = (g_att * law * dci, g_att * law * dco)
        gx -= w * lights[i, LIGHT_AXIS + 0]
        gy -= w * lights[i, LIGHT_AXIS + 1]
        gz -= w * lights[i, LIGHT_AXIS + 2]
    g_law = g_att * cone
    g_d = 0.0
    g_k = 0.0
    if att_on:
        if lights[i, LIGHT_ATT] == ATT_INVERSE_SQUARE:
            if d > dmin:  # clamped at dmin: constant
                g_d = -2.0 * g_law * law / d
        elif lights[i, LIGHT_ATT] == ATT_HEURISTIC:
            g_d = -g_law * law * law
            g_k = g_d
    sg = gx * s[0] + gy * s[1] + gz * s[2]
    return (((gx - sg * s[0]) / d + g_d * s[0], (gy - sg * s[1]) / d + g_d * s[1],
             (gz - sg * s[2]) / d + g_d * s[2]), g_k, g_cones)


@njit(**HELPER)
def _axes_vjp(lights, i, j, gq, acc, row, ob, ext):
    """``acc[row]`` += ``dL/d`` area light ``i``'s packed half-axes ``eu``, ``ev`` from ``gq = dL/dq`` of
    its sample ``j`` at ``q = centre + a eu + b ev``: ``a gq`` and ``b gq``, with ``(a, b)`` (fixed by
    the lattice, not by the axes) read back from ``q`` (the axes are perpendicular)."""
    q = _light_point(lights, i, j, ext)
    a = b = uu = vv = 0.0
    for c in range(3):
        e = q[c] - lights[i, LIGHT_VEC + c]
        a += e * lights[i, LIGHT_EDGE_U + c]
        b += e * lights[i, LIGHT_EDGE_V + c]
        uu += lights[i, LIGHT_EDGE_U + c] * lights[i, LIGHT_EDGE_U + c]
        vv += lights[i, LIGHT_EDGE_V + c] * lights[i, LIGHT_EDGE_V + c]
    a /= uu
    b /= vv
    for c in range(3):
        acc[row, ob + GL_EDGE_U + c] += a * gq[c]
        acc[row, ob + GL_EDGE_V + c] += b * gq[c]


def _rich(materials, lights) -> bool:
    """Whether a frame needs :func:`_reflected_vjp` rather than :func:`_plain_vjp`: a GGX material,
    or a light of more than one sample (an area light)."""
    return bool(np.any(materials[:, MAT_MODEL] == MODEL_GGX) or np.any(lights[:, LIGHT_KIND] == LIGHT_AREA)
                or np.any(lights[:, LIGHT_SAMPLES] > 1))


def _make_reflected_vjp(rich: bool):
    """:func:`_reflected_vjp` (``rich``: every light sample, the GGX model) or :func:`_plain_vjp` (one
    sample a light, Phong and Blinn-Phong only). ``rich`` is a closure constant, its branches dropped
    before typing: the GGX branch and the samples' loop, present though not taken, slowed the plain
    Phong gradient by a quarter and added 2-3 s to its compile (see the CHANGELOG)."""

    @njit(**HELPER)
    def reflected_vjp(hp, coef, mats, mi, L, S, gI, acc, row, lay):
        """Add ``dL/dparameter`` of the reflectance equation at ``hp`` into ``acc[row]`` and return
        ``(dL/dn, dL/dp, dL/dv)`` (three 3-tuples: the unit shading normal, the shading point through
        the lights' directions and distances, the unit view vector), for ``gI = dL/dI`` (3-tuple).

        ``hp``, ``coef``, ``mats``, ``mi``, ``L``, ``S`` as for
        :func:`~raycast_shade.shading.illumination._reflected`; ``acc`` (P, R) float64 with the
        slots of :func:`layout`, ``lay = (ambient offset, first light's offset)``. Every light sample
        (an area light's, each a point light at a fixed offset, its shadow ray held as traced), models
        Phong, Blinn-Phong and GGX (:func:`~raycast_shade.shading.grad_ggx._ggx_vjp`)."""
        ambient, lights, dmin, handle, unit, att_on = L.ambient, L.lights, L.dmin, L.handle, L.unit, L.att_on
        ext = L.ext  # None: the lean build (illumination.LEAN), its branches pruned in the callees
        amb, lb = lay
        mb = mi * GM_SIZE
        for c in range(3):
            acc[row, mb + GM_KA + c] += gI[c] * ambient[c]
            acc[row, amb + c] += gI[c] * coef[c]
        n = hp.n
        t = mats[mi, MAT_SHININESS]
        model = mats[mi, MAT_MODEL]
        gnx = gny = gnz = 0.0
        gpx = gpy = gpz = 0.0
        gvx = gvy = gvz = 0.0
        prm = (t, mats[mi, MAT_METALLIC], mats[mi, MAT_ROUGHNESS])
        for i in range(lights.shape[0]):
            ob = lb + i * GL_SIZE
            ns = 1
            if rich:
                ns = _samples(lights, i, ext)
            for j in range(ns):  # an area light's samples: point lights at fixed offsets
                s, d, law, cone = _light_at(lights, i, j, hp.p, dmin, np.bool_(att_on), ext)
                if d == 0.0 or cone == 0.0:
                    continue
                att = law * cone
                ndots = dot(n, s)
                if ndots <= 0.0:
                    continue
                if ndots > 1.0:
                    ndots = 1.0
                if lights[i, LIGHT_SHADOWS] != 0.0 and handle != 0:  # visibility held fixed: the forward ray
                    if _occluded(handle, S, hp.o, hp.g, s, _light_point(lights, i, j, ext), d < np.inf, unit):
                        continue
                w_att = 0.0
                if rich and model == MODEL_GGX:
                    gw = (gI[0] * att * lights[i, LIGHT_RADIANCE + 0], gI[1] * att * lights[i, LIGHT_RADIANCE + 1],
                          gI[2] * att * lights[i, LIGHT_RADIANCE + 2])
                    val, gkd, gmet, grough, gm_n, gm_s, gm_v, gnd = _ggx_vjp(n, s, hp.v, ndots, coef, prm, gw)
                    for c in range(3):
                        acc[row, ob + GL_RAD + c] += gI[c] * att * val[c]
                        acc[row, mb + GM_KD + c] += gkd[c]
                        w_att += gI[c] * lights[i, LIGHT_RADIANCE + c] * val[c]
                    acc[row, mb + GM_METALLIC] += gmet
                    acc[row, mb + GM_ROUGHNESS] += grough
                    gnx += gnd * s[0] + gm_n[0]
                    gny += gnd * s[1] + gm_n[1]
                    gnz += gnd * s[2] + gm_n[2]
                    gs = (gnd * n[0] + gm_s[0], gnd * n[1] + gm_s[1], gnd * n[2] + gm_s[2])
                    gvx += gm_v[0]
                    gvy += gm_v[1]
                    gvz += gm_v[2]
                else:
                    cs, dcdn, dcds, dcdv = _cosine_vjp(model, n, s, hp.v, ndots)
                    spec, dspec, dspec_t = _lobe_vjp(cs, t)
                    w_nd = w_sp = 0.0
                    for c in range(3):
                        rc = lights[i, LIGHT_RADIANCE + c]
                        kd = coef[3 + c]
                        ks = coef[6 + c]
                        acc[row, ob + GL_RAD + c] += gI[c] * att * (kd * ndots + ks * spec)
                        acc[row, mb + GM_KD + c] += gI[c] * att * rc * ndots
                        acc[row, mb + GM_KS + c] += gI[c] * att * rc * spec
                        w_att += gI[c] * rc * (kd * ndots + ks * spec)
                        w_nd += gI[c] * att * rc * kd
                        w_sp += gI[c] * att * rc * ks
                    acc[row, mb + GM_T] += w_sp * dspec_t
                    g_c = w_sp * dspec
                    gnx += w_nd * s[0] + g_c * dcdn[0]
                    gny += w_nd * s[1] + g_c * dcdn[1]
                    gnz += w_nd * s[2] + g_c * dcdn[2]
                    gs = (w_nd * n[0] + g_c * dcds[0], w_nd * n[1] + g_c * dcds[1], w_nd * n[2] + g_c * dcds[2])
                    gvx += g_c * dcdv[0]
                    gvy += g_c * dcdv[1]
                    gvz += g_c * dcdv[2]
                gq, g_k, g_cones = _light_vjp(lights, i, s, d, law, cone, dmin, att_on, w_att, gs)
                for c in range(3):
                    acc[row, ob + GL_VEC + c] += gq[c]
                acc[row, ob + GL_K] += g_k
                acc[row, ob + GL_COS_INNER] += g_cones[0]
                acc[row, ob + GL_COS_OUTER] += g_cones[1]
                if rich and lights[i, LIGHT_KIND] == LIGHT_AREA:
                    _axes_vjp(lights, i, j, gq, acc, row, ob, ext)
                if lights[i, LIGHT_KIND] != LIGHT_DIRECTIONAL:  # s and d depend on q - p only
                    gpx -= gq[0]
                    gpy -= gq[1]
                    gpz -= gq[2]
        return (gnx, gny, gnz), (gpx, gpy, gpz), (gvx, gvy, gvz)

    return reflected_vjp


_reflected_vjp = _make_reflected_vjp(True)
_plain_vjp = _make_reflected_vjp(False)
