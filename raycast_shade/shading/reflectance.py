"""The reflectance models: a diffuse and a specular function each, and the registry the
kernels dispatch on.

A model is a pair of functions of the unit shading normal ``n``, the unit direction ``s`` to
the light, the unit direction ``v`` to the viewer, ``n . s`` (already known to be in (0, 1]),
the point's coefficients ``c`` (the 12-tuple ``ka, kd, ks, ke`` per channel, textured where
maps are) and the material's parameters ``p = (shininess, metallic, roughness)``. Each returns
its term itself, RGB, per unit of light (:func:`~raycast_shade.shading.illumination._reflected`
multiplies by ``att Ii`` and sums over the lights)::

    model          diffuse term                    specular term
    Phong          kd (n . s)                      ks max(r . v, 0)^t,  r = 2 (n . s) n - s
    Blinn-Phong    kd (n . s)                      ks max(n . h, 0)^t,  h = (s + v) / |s + v|
    GGX            (1 - F) (1 - m) kd (n . s)      pi F D V (n . s)

GGX is the glTF 2.0 metallic-roughness BRDF (the spec's Appendix B) times ``pi``: base colour
``kd``, metallic ``m`` and roughness ``r`` (the row's ``MAT_METALLIC`` and ``MAT_ROUGHNESS``
times the point's ks blue and green: the metallicRoughness map rides in the ks column, whose
row value a GGX material packs as 1), ``alpha = r^2``,
``F = F0 + (1 - F0) (1 - v . h)^5`` with ``F0 = mix(0.04, kd, m)`` (Schlick), the
Trowbridge-Reitz distribution ``D = alpha^2 / (pi ((n . h)^2 (alpha^2 - 1) + 1)^2)`` and the
height-correlated Smith visibility ``V = 0.5 / ((n . s) sqrt((n . v)^2 (1 - alpha^2) + alpha^2)
+ (n . v) sqrt((n . s)^2 (1 - alpha^2) + alpha^2))``. The factor ``pi`` is the units: glTF's
radiance is ``f E (n . s)``, and a light of intensity ``Ii`` here gives ``E = pi Ii``, so that a
white Lambertian surface shows ``Ii (n . s)`` as the lecture's ``kd (n . s)`` with ``kd = 1``.
Roughness below :data:`MIN_ROUGHNESS` is shaded at it (a point light's mirror lobe would be a
delta: no highlight at all).

The material row carries the model's code (``MAT_MODEL``, codes ``MODEL_*`` in
:mod:`raycast_shade.common.layout`). Adding a model: a code in ``layout.py``, its function pair
here, its entry in :data:`MODELS` and its branch in :func:`_diffuse` and :func:`_specular` (a
Numba kernel cannot call through a dict; ``tests/shading/test_light_interface.py`` checks the
branches against the registry), and the name in ``Material``'s ``specular`` choices. The batched
kernel (:mod:`.phong_fast`) implements the models its ``HANDLES`` lists; a frame with any other
goes to the general kernel by itself.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from ..common.inline import inline_jit

from ..common.layout import MODEL_BLINN, MODEL_GGX, MODEL_PHONG
from .jit import CALLED, HELPER
from .records import dot

__all__ = ["MODELS", "Reflectance", "MIN_ROUGHNESS", "DIELECTRIC_F0"]

Reflectance = namedtuple("Reflectance", ["diffuse", "specular"])
"""A model's two functions, ``f(n, s, v, ndots, c, p)`` each: the diffuse and the specular term,
RGB per unit light (see the module docstring)."""

MIN_ROUGHNESS = 0.045  # GGX roughness floor: alpha >= 0.002, a highlight a point light still shows
DIELECTRIC_F0 = 0.04  # glTF's Fresnel reflectance at normal incidence of a dielectric (ior 1.5)


@inline_jit(**HELPER)
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


@inline_jit(**HELPER)
def _phong_cosine(n, s, v, ndots):
    """Phong: ``r . v`` with ``r`` the mirror direction of ``s`` about ``n``."""
    r = (2.0 * ndots * n[0] - s[0], 2.0 * ndots * n[1] - s[1], 2.0 * ndots * n[2] - s[2])
    return dot(r, v)


@inline_jit(**HELPER)
def _blinn_cosine(n, s, v, ndots):
    """Blinn-Phong: ``n . h / |h|`` with the half vector ``h = s + v`` (0 where ``h`` vanishes)."""
    h = (s[0] + v[0], s[1] + v[1], s[2] + v[2])
    hl = np.sqrt(dot(h, h))
    return dot(n, h) / hl if hl > 0.0 else 0.0


@inline_jit(**HELPER)
def _lambert(n, s, v, ndots, c, p):
    """Lambert: ``kd (n . s)``, whatever the viewer."""
    return c[3] * ndots, c[4] * ndots, c[5] * ndots


@inline_jit(**HELPER)
def _lobe(cos, c, p):
    """``ks max(cos, 0)^t``: the lecture's lobe of a cosine (the product last, as the kernels
    always formed it: the images stay those of the code before models returned terms)."""
    spec = 0.0
    if cos > 0.0:
        spec = _power(min(cos, 1.0), p[0])
    return c[6] * spec, c[7] * spec, c[8] * spec


@inline_jit(**HELPER)
def _phong(n, s, v, ndots, c, p):
    """Phong's specular term ``ks max(r . v, 0)^t``."""
    return _lobe(_phong_cosine(n, s, v, ndots), c, p)


@inline_jit(**HELPER)
def _blinn(n, s, v, ndots, c, p):
    """Blinn-Phong's specular term ``ks max(n . h, 0)^t``."""
    return _lobe(_blinn_cosine(n, s, v, ndots), c, p)


@inline_jit(**HELPER)
def _ggx_setup(n, s, v, c, p):
    """The GGX quantities both terms use: metallic ``m``, ``alpha``, ``n . h``, ``n . v`` and
    Schlick's ``F`` per channel (``v . h`` and ``n . v`` clamped to [0, 1]; ``h`` where it
    vanishes, ``v = -s``, taken as grazing: ``n . h = v . h = 0``)."""
    m = min(max(p[1] * c[8], 0.0), 1.0)
    r = min(max(p[2] * c[7], MIN_ROUGHNESS), 1.0)
    h = (s[0] + v[0], s[1] + v[1], s[2] + v[2])
    hl = np.sqrt(dot(h, h))
    ndoth = vdoth = 0.0
    if hl > 0.0:
        ndoth = max(dot(n, h) / hl, 0.0)
        vdoth = min(max(dot(v, h) / hl, 0.0), 1.0)
    ndotv = min(max(dot(n, v), 0.0), 1.0)
    w = 1.0 - vdoth
    w5 = (w * w) * (w * w) * w
    f0r = DIELECTRIC_F0 + m * (c[3] - DIELECTRIC_F0)
    f0g = DIELECTRIC_F0 + m * (c[4] - DIELECTRIC_F0)
    f0b = DIELECTRIC_F0 + m * (c[5] - DIELECTRIC_F0)
    F = (f0r + (1.0 - f0r) * w5, f0g + (1.0 - f0g) * w5, f0b + (1.0 - f0b) * w5)
    return m, r * r, ndoth, ndotv, F


@inline_jit(**CALLED)  # a call, not inlined: every kernel that inlines _reflected would compile its own copy
def _ggx_diffuse(n, s, v, ndots, c, p):
    """glTF's diffuse term times ``pi``: ``(1 - F) (1 - m) kd (n . s)``."""
    m, _, _, _, F = _ggx_setup(n, s, v, c, p)
    k = (1.0 - m) * ndots
    return (1.0 - F[0]) * c[3] * k, (1.0 - F[1]) * c[4] * k, (1.0 - F[2]) * c[5] * k


@inline_jit(**CALLED)
def _ggx_specular(n, s, v, ndots, c, p):
    """glTF's specular term times ``pi``: ``pi F D V (n . s)`` (Trowbridge-Reitz ``D``,
    height-correlated Smith ``V``)."""
    _, a, ndoth, ndotv, F = _ggx_setup(n, s, v, c, p)
    a2 = a * a
    q = ndoth * ndoth * (a2 - 1.0) + 1.0
    d_pi = a2 / (q * q)  # pi D
    vis = 0.5 / (ndots * np.sqrt(ndotv * ndotv * (1.0 - a2) + a2) + ndotv * np.sqrt(ndots * ndots * (1.0 - a2) + a2))
    k = d_pi * vis * ndots
    return F[0] * k, F[1] * k, F[2] * k


MODELS = {MODEL_PHONG: Reflectance(_lambert, _phong), MODEL_BLINN: Reflectance(_lambert, _blinn),
          MODEL_GGX: Reflectance(_ggx_diffuse, _ggx_specular)}


@inline_jit(**HELPER)
def _diffuse(model, n, s, v, ndots, c, p, ext):
    """The diffuse term of :data:`MODELS` ``[model]``; unknown codes are Lambert's. ``ext``: the
    frame's ``L.ext`` (None: the lean build, Phong and Blinn only, GGX pruned at compile time)."""
    if ext is not None and model == MODEL_GGX:
        return _ggx_diffuse(n, s, v, ndots, c, p)
    return _lambert(n, s, v, ndots, c, p)


@inline_jit(**HELPER)
def _specular(model, n, s, v, ndots, c, p, ext):
    """The specular term of :data:`MODELS` ``[model]``; unknown codes are Phong's. ``ext`` as for
    :func:`_diffuse`."""
    if ext is not None and model == MODEL_GGX:
        return _ggx_specular(n, s, v, ndots, c, p)
    if model == MODEL_BLINN:
        return _blinn(n, s, v, ndots, c, p)
    return _phong(n, s, v, ndots, c, p)
