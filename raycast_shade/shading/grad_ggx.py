"""Reverse-mode derivatives of the GGX (glTF metallic-roughness) model's terms, beside the forward's.

:mod:`.reflectance` gives the model as a function pair, :func:`~.reflectance._ggx_diffuse` and
:func:`~.reflectance._ggx_specular` (both from :func:`~.reflectance._ggx_setup`); :func:`_ggx_vjp`
is their sum's vector-Jacobian product, written term by term in the forward's order (per channel,
per unit of light)::

    m = clamp(metallic kb, 0, 1)         r = clamp(roughness kg, MIN_ROUGHNESS, 1),  a2 = r^4
    h = s + v,  nh = max(n.h/|h|, 0),    vh = clamp(v.h/|h|, 0, 1),  nv = clamp(n.v, 0, 1)
    F0 = 0.04 + m (kd - 0.04)            F = F0 + (1 - F0) (1 - vh)^5
    diffuse  = (1 - F) kd (1 - m) (n.s)
    specular = F D V (n.s),   D = a2 / q^2,  q = nh^2 (a2 - 1) + 1
               V = 0.5 / ((n.s) A + nv B),  A = sqrt(nv^2 (1 - a2) + a2),  B = sqrt((n.s)^2 (1 - a2) + a2)

(``kg``, ``kb``: the point's ks green and blue, 1 without a metallicRoughness map.) The clamps are
the forward's kinks: a derivative passes a clamp only inside it, and at its bound only from the
side of the material's valid range (``metallic`` in [0, 1], ``roughness`` in [0, 1]: the one-sided
derivative a fit starting at metallic 0 or roughness 1 needs); roughness below ``MIN_ROUGHNESS``
is shaded at it and gets 0. ``n.h``, ``v.h`` and ``n.v`` pass only where they are not clamped
(``v.h`` reaches 1 only where ``s = v``; ``n.v`` is 0 only at grazing view).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .jit import CALLED, HELPER
from .records import dot
from .reflectance import DIELECTRIC_F0, MIN_ROUGHNESS

__all__ = []


@njit(**HELPER)
def _channel(kd, m, kdiff, K, w5, gw):
    """One channel of :func:`_ggx_vjp`: ``diffuse + specular`` and its adjoints (``dL/dkd`` and the
    channel's shares of ``dL/dK``, ``dL/d((1 - m) n.s)``, ``dL/d(1 - v.h)^5``, ``dL/dm``)."""
    f0 = DIELECTRIC_F0 + m * (kd - DIELECTRIC_F0)
    F = f0 + (1.0 - f0) * w5
    gF = gw * (K - kd * kdiff)
    gf0 = gF * (1.0 - w5)
    return ((1.0 - F) * kd * kdiff + F * K, gw * (1.0 - F) * kdiff + gf0 * m, gw * F, gw * (1.0 - F) * kd,
            gF * (1.0 - f0), gf0 * (kd - DIELECTRIC_F0))


@njit(**CALLED)  # a call, as the forward's GGX terms: the gradient kernels that inline _reflected_vjp share it
def _ggx_vjp(n, s, v, ndots, c, p, gw):
    """The GGX terms at one point and their vector-Jacobian product.

    Parameters
    ----------
    n, s, v : 3-tuple of float
        Unit shading normal, direction to the light, direction to the viewer.
    ndots : float
        ``n . s`` in (0, 1] (the forward's clamped value).
    c : 12-tuple of float
        The point's coefficients (``ka, kd, ks, ke``; ``kd`` the base colour).
    p : 3-tuple of float
        ``(shininess, metallic, roughness)``: the material row's.
    gw : 3-tuple of float
        ``dL/d(diffuse + specular)`` per channel (``dL/dI att Ii`` for one light sample).

    Returns
    -------
    value : 3-tuple
        ``diffuse + specular`` per channel.
    gkd : 3-tuple
        ``dL/dkd``.
    gmetallic, groughness : float
        ``dL/dmetallic``, ``dL/droughness`` (the material row's factors).
    gn, gs, gv, gndots : 3-tuple, 3-tuple, 3-tuple, float
        ``dL/dn``, ``dL/ds``, ``dL/dv`` through ``n.h``, ``v.h`` and ``n.v``, and ``dL/d(n.s)``
        (the caller's to pass on to ``n`` and ``s``).
    """
    kg, kb = c[7], c[8]
    m_raw = p[1] * kb
    m = min(max(m_raw, 0.0), 1.0)
    r_raw = p[2] * kg
    r = min(max(r_raw, MIN_ROUGHNESS), 1.0)
    a2 = (r * r) * (r * r)
    h = (s[0] + v[0], s[1] + v[1], s[2] + v[2])
    hl = np.sqrt(dot(h, h))
    nh_raw = vh_raw = ndoth = vdoth = 0.0
    if hl > 0.0:
        nh_raw = dot(n, h) / hl
        vh_raw = dot(v, h) / hl
        ndoth = max(nh_raw, 0.0)
        vdoth = min(max(vh_raw, 0.0), 1.0)
    nv_raw = dot(n, v)
    ndotv = min(max(nv_raw, 0.0), 1.0)
    w = 1.0 - vdoth
    w5 = (w * w) * (w * w) * w
    kd = (c[3], c[4], c[5])
    kdiff = (1.0 - m) * ndots
    q = ndoth * ndoth * (a2 - 1.0) + 1.0
    d_pi = a2 / (q * q)
    A = np.sqrt(ndotv * ndotv * (1.0 - a2) + a2)
    B = np.sqrt(ndots * ndots * (1.0 - a2) + a2)
    den = ndots * A + ndotv * B
    vis = 0.5 / den
    K = d_pi * vis * ndots
    v0, gkd0, gK0, gkdiff0, gw50, gm0 = _channel(kd[0], m, kdiff, K, w5, gw[0])
    v1, gkd1, gK1, gkdiff1, gw51, gm1 = _channel(kd[1], m, kdiff, K, w5, gw[1])
    v2, gkd2, gK2, gkdiff2, gw52, gm2 = _channel(kd[2], m, kdiff, K, w5, gw[2])
    gK = gK0 + gK1 + gK2
    gkdiff = gkdiff0 + gkdiff1 + gkdiff2
    gw5 = gw50 + gw51 + gw52
    gm = gm0 + gm1 + gm2
    gm -= gkdiff * ndots
    gnd = gkdiff * (1.0 - m) + gK * d_pi * vis
    g_dpi = gK * vis * ndots
    g_den = -gK * d_pi * ndots * vis / den
    gnd += g_den * A
    gA = g_den * ndots
    gnv = g_den * B
    gB = g_den * ndotv
    gX = gA / (2.0 * A)
    gY = gB / (2.0 * B)
    gnv += gX * 2.0 * ndotv * (1.0 - a2)
    gnd += gY * 2.0 * ndots * (1.0 - a2)
    ga2 = gX * (1.0 - ndotv * ndotv) + gY * (1.0 - ndots * ndots) + g_dpi / (q * q)
    gq = -2.0 * g_dpi * a2 / (q * q * q)
    ga2 += gq * ndoth * ndoth
    gnh = gq * 2.0 * ndoth * (a2 - 1.0)
    gvh = -gw5 * 5.0 * (w * w) * (w * w)
    gr = ga2 * 4.0 * r * (r * r)
    grough = gr * kg if MIN_ROUGHNESS <= r_raw <= 1.0 else 0.0
    gmet = gm * kb if 0.0 <= m_raw <= 1.0 else 0.0
    if not nh_raw > 0.0:
        gnh = 0.0
    if not (0.0 < vh_raw < 1.0):
        gvh = 0.0
    if not (0.0 < nv_raw < 1.0):
        gnv = 0.0
    u = (0.0, 0.0, 0.0)
    gh = (0.0, 0.0, 0.0)
    if hl > 0.0:
        u = (h[0] / hl, h[1] / hl, h[2] / hl)
        gh = ((gnh * (n[0] - nh_raw * u[0]) + gvh * (v[0] - vh_raw * u[0])) / hl,
              (gnh * (n[1] - nh_raw * u[1]) + gvh * (v[1] - vh_raw * u[1])) / hl,
              (gnh * (n[2] - nh_raw * u[2]) + gvh * (v[2] - vh_raw * u[2])) / hl)
    gn = (gnh * u[0] + gnv * v[0], gnh * u[1] + gnv * v[1], gnh * u[2] + gnv * v[2])
    gv = (gh[0] + gvh * u[0] + gnv * n[0], gh[1] + gvh * u[1] + gnv * n[1], gh[2] + gvh * u[2] + gnv * n[2])
    return (v0, v1, v2), (gkd0, gkd1, gkd2), gmet, grough, gn, gh, gv, gnd
