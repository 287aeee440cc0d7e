"""The reflectance models: a diffuse and a specular function each, and the registry the
kernels dispatch on.

A model is a pair of functions of the unit shading normal ``n``, the unit direction ``s`` to
the light, the unit direction ``v`` to the viewer and ``n . s`` (already known to be in
(0, 1]): the diffuse factor that ``kd`` scales, and the cosine the specular lobe raises to the
shininess ``t``::

    model          diffuse    specular cosine
    Phong          n . s      c = r . v,  r = 2 (n . s) n - s
    Blinn-Phong    n . s      c = n . h / |h|,  h = s + v

(:func:`~raycast_shade.shading.illumination._reflected` then sums
``Ii (kd f_d + ks max(c, 0)^t)`` over the lights.) The material row carries the model's code
(``MAT_MODEL``, codes ``MODEL_*`` in :mod:`raycast_shade.common.layout`). Adding a model: a code
in ``layout.py``, its function pair here, its entry in :data:`MODELS` and its branch in
:func:`_diffuse` and :func:`_specular_cosine` (a Numba kernel cannot call through a dict;
``tests/shading/test_light_interface.py`` checks the branches against the registry), and the name
in ``Material``'s ``specular`` choices. The batched kernel (:mod:`.phong_fast`) implements the
models its ``HANDLES`` lists; a frame with any other goes to the general kernel by itself.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..common.layout import MODEL_BLINN, MODEL_PHONG
from .jit import HELPER
from .records import dot

__all__ = ["MODELS", "Reflectance"]

Reflectance = namedtuple("Reflectance", ["diffuse", "specular"])
"""A model's two functions: ``diffuse(n, s, v, ndots)``, the factor ``kd`` scales, and
``specular(n, s, v, ndots)``, the cosine raised to the shininess."""


@njit(**HELPER)
def _lambert(n, s, v, ndots):
    """Lambert: the diffuse factor ``n . s``, whatever the viewer."""
    return ndots


@njit(**HELPER)
def _phong_cosine(n, s, v, ndots):
    """Phong: ``r . v`` with ``r`` the mirror direction of ``s`` about ``n``."""
    r = (2.0 * ndots * n[0] - s[0], 2.0 * ndots * n[1] - s[1], 2.0 * ndots * n[2] - s[2])
    return dot(r, v)


@njit(**HELPER)
def _blinn_cosine(n, s, v, ndots):
    """Blinn-Phong: ``n . h / |h|`` with the half vector ``h = s + v`` (0 where ``h`` vanishes)."""
    h = (s[0] + v[0], s[1] + v[1], s[2] + v[2])
    hl = np.sqrt(dot(h, h))
    return dot(n, h) / hl if hl > 0.0 else 0.0


MODELS = {MODEL_PHONG: Reflectance(_lambert, _phong_cosine), MODEL_BLINN: Reflectance(_lambert, _blinn_cosine)}


@njit(**HELPER)
def _diffuse(model, n, s, v, ndots):
    """The diffuse factor of :data:`MODELS` ``[model]``: Lambert's for every model so far."""
    return _lambert(n, s, v, ndots)


@njit(**HELPER)
def _specular_cosine(model, n, s, v, ndots):
    """The cosine of :data:`MODELS` ``[model]``; unknown codes are Phong's."""
    if model == MODEL_BLINN:
        return _blinn_cosine(n, s, v, ndots)
    return _phong_cosine(n, s, v, ndots)
