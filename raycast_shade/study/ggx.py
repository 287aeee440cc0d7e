"""Plain-NumPy float64 twin of the GGX reflectance model (glTF 2.0 metallic-roughness).

Written from the glTF 2.0 specification's Appendix B, not from the kernel
(:mod:`raycast_shade.shading.reflectance`): for unit ``n``, ``s`` (to the light), ``v`` (to the
viewer), base colour ``b``, metallic ``m`` and roughness ``r`` (``alpha = r^2``)::

    f_diffuse  = (1 - F) (1 - m) b / pi
    f_specular = F D V
    F = F0 + (1 - F0) (1 - |v.h|)^5,   F0 = mix(0.04, b, m)
    D = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)
    V = 0.5 / ((n.s) sqrt((n.v)^2 (1 - alpha^2) + alpha^2) + (n.v) sqrt((n.s)^2 (1 - alpha^2) + alpha^2))

and the radiance per unit light intensity ``Ii`` is ``(f_diffuse + f_specular) E (n.s)`` with the
irradiance ``E = pi Ii`` (the library's units: a white Lambertian surface shows ``Ii (n.s)``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["ggx_terms_numpy", "ggx_parts_numpy", "MIN_ROUGHNESS", "DIELECTRIC_F0"]

MIN_ROUGHNESS = 0.045  # the kernel's floor (shading.reflectance.MIN_ROUGHNESS)
DIELECTRIC_F0 = 0.04


def _dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def ggx_parts_numpy(n, s, v, roughness):
    """The spec's scalar factors at N points.

    Parameters
    ----------
    n, s, v : (N, 3) float64
        Unit normal, direction to the light and to the viewer.
    roughness : (N,) float64
        Clamped to ``[MIN_ROUGHNESS, 1]``.

    Returns
    -------
    D, V, vdoth : (N,) float64
        Trowbridge-Reitz distribution, height-correlated Smith visibility (``G / (4 n.s n.v)``) and
        ``v.h`` in [0, 1] (0 where ``s + v`` vanishes, as ``n.h``).
    """
    r = np.clip(roughness, MIN_ROUGHNESS, 1.0)
    a2 = r ** 4
    h = s + v
    hl = np.linalg.norm(h, axis=1)
    safe = np.where(hl > 0, hl, 1.0)[:, None]
    ndoth = np.where(hl > 0, np.maximum(_dot(n, h / safe), 0.0), 0.0)
    vdoth = np.where(hl > 0, np.clip(_dot(v, h / safe), 0.0, 1.0), 0.0)
    nl = np.clip(_dot(n, s), 0.0, 1.0)
    nv = np.clip(_dot(n, v), 0.0, 1.0)
    D = a2 / (np.pi * (ndoth ** 2 * (a2 - 1.0) + 1.0) ** 2)
    V = 0.5 / (nl * np.sqrt(nv ** 2 * (1.0 - a2) + a2) + nv * np.sqrt(nl ** 2 * (1.0 - a2) + a2))
    return D, V, vdoth


def ggx_terms_numpy(n, s, v, base, metallic, roughness):
    """The diffuse and specular radiance per unit light intensity (``E = pi Ii``) at N points.

    Parameters
    ----------
    n, s, v : (N, 3) float64
        Unit vectors; ``n.s > 0`` (the caller's test: no light otherwise).
    base : (N, 3) float64
        Base colour (linear).
    metallic, roughness : (N,) float64
        In [0, 1] (metallic clamped to it; roughness to ``[MIN_ROUGHNESS, 1]``).

    Returns
    -------
    diffuse, specular : (N, 3) float64
        ``pi f_diffuse (n.s)`` and ``pi f_specular (n.s)``.
    """
    m = np.clip(metallic, 0.0, 1.0)[:, None]
    D, V, vdoth = ggx_parts_numpy(n, s, v, roughness)
    f0 = DIELECTRIC_F0 * (1.0 - m) + base * m
    F = f0 + (1.0 - f0) * ((1.0 - vdoth) ** 5)[:, None]
    nl = np.clip(_dot(n, s), 0.0, 1.0)[:, None]
    diffuse = (1.0 - F) * (1.0 - m) * base / np.pi
    specular = F * (D * V)[:, None]
    return np.pi * diffuse * nl, np.pi * specular * nl
