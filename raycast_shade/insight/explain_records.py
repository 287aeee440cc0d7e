"""The records of an explained pixel: :class:`Explanation`, its :class:`PointShade` per point
where the method evaluates the equation, a :class:`LightTerm` per light there, and a
:class:`Bounce` per mirror bounce (built by :func:`raycast_shade.insight.explain.explain`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .explain_text import format_explanation

__all__ = ["Explanation", "PointShade", "LightTerm", "Bounce"]


@dataclass(frozen=True)
class LightTerm:
    """One light's contribution at one point.

    Attributes
    ----------
    index : int
        The light's index in ``scene.lights``.
    directional : bool
    position : (3,) float64 or None
        World position of a point light.
    d : float or None
        Distance to a point light.
    law : str
        Attenuation law (``"none"`` for directional lights).
    att : float
        Attenuation factor: 1, ``1/max(d, dmin)^2`` or ``1/(d + k)``.
    radiance : (3,) float64
        ``Ii * color``.
    s : (3,) float64 or None
        Unit vector towards the light (``None`` for a light on the point).
    ndots : float or None
        ``n.s`` before clamping.
    shadow : str
        ``"lit"`` (the shadow ray got through), ``"blocked"``, ``"no shadows"``
        (the light casts none) or ``"not traced"`` (the light does not reach
        the point anyway).
    specular_model : str
        ``"phong"`` (``r.v``) or ``"blinn"`` (``n.h``).
    rh : (3,) float64 or None
        ``r = 2 (n.s) n - s`` or ``h = (s + v) / |s + v|``.
    cos : float or None
        ``r.v`` or ``n.h`` before clamping.
    spec : float
        ``min(cos, 1)^t``, 0 where ``cos <= 0``.
    diffuse, specular : (3,) float64
        ``att Ii kd (n.s)`` and ``att Ii Ks spec`` (zero where the light does not arrive).
    spot : float or None
        A spot light's cone factor ``cos^n(a) smoothstep(cos outer, cos inner, cos a)``,
        already in ``att`` (0: outside the cone, no light, no shadow ray); ``None``
        for other lights.
    sample, samples : int
        Which of the light's point samples this is, of how many: an area light is one term per
        sample (``position`` the sample's, its share ``1/samples`` of the intensity in ``att``),
        every other light one term (0 of 1).
    """

    index: int
    directional: bool
    position: object
    d: object
    law: str
    k: float
    att: float
    radiance: np.ndarray
    s: object
    ndots: object
    shadow: str
    specular_model: str
    rh: object
    cos: object
    spec: float
    diffuse: np.ndarray
    specular: np.ndarray
    spot: object = None
    sample: int = 0
    samples: int = 1

    @property
    def arrives(self) -> bool:
        """True where the light lights the point (it faces the light, no shadow)."""
        return self.shadow in ("lit", "no shadows")


@dataclass(frozen=True)
class PointShade:
    """The reflectance equation evaluated at one point.

    Attributes
    ----------
    where : str
        ``"pixel"``, ``"face centre"``, ``"vertex 17"``, ``"bounce 1"``.
    p : (3,) float64
        The point, world coordinates.
    n, v : (3,) float64
        Unit normal used, unit vector towards the viewer.
    model : int
    ka, kd, ks : (3,) float64
    shininess : float
    ambient : (3,) float64
        ``Ia ka``.
    lights : tuple of LightTerm
    normal_note : str
        How ``n`` was obtained.
    coef_note : str
        Where ``ka, kd, ks`` come from when not the material's own (colours, maps).
    ke : (3,) float64
        The emission added (the point's ``ke``; zero without one).
    """

    where: str
    p: np.ndarray
    n: np.ndarray
    v: np.ndarray
    model: int
    ka: np.ndarray
    kd: np.ndarray
    ks: np.ndarray
    shininess: float
    ia: np.ndarray
    ambient: np.ndarray
    lights: tuple
    normal_note: str = ""
    coef_note: str = ""
    ke: np.ndarray = field(default_factory=lambda: np.zeros(3))

    @property
    def emissive(self) -> np.ndarray:
        """(3,) the emission term ``ke``."""
        return self.ke

    @property
    def diffuse(self) -> np.ndarray:
        return sum((t.diffuse for t in self.lights), np.zeros(3))

    @property
    def specular(self) -> np.ndarray:
        return sum((t.specular for t in self.lights), np.zeros(3))

    @property
    def total(self) -> np.ndarray:
        """(3,) ``ambient + diffuse + specular + emissive``."""
        return self.ambient + self.diffuse + self.specular + self.ke


@dataclass(frozen=True)
class Bounce:
    """One mirror bounce: the ray, what it hit, and what it adds.

    ``colour`` is ``keep`` times the local shade of what the ray sees (or the
    background on a miss); the pixel gains ``weight * colour``."""

    depth: int
    origin: np.ndarray
    direction: np.ndarray
    weight: float
    model: int
    triangle: int
    shade: object
    keep: float
    colour: np.ndarray


@dataclass(frozen=True)
class Explanation:
    """The model at one pixel with its numbers; ``str()`` prints them as a formula.

    Attributes
    ----------
    x, y : int
    method : str or None
        ``"flat"``, ``"gouraud"``, ``"phong"``; ``None`` on the background.
    model : int
        Model index (-1 on the background); ``model_name`` its mesh's name.
    triangle : int
        Triangle index within the model; ``vertex_ids`` its (global) vertices.
    barycentrics : (3,) float64
        ``(1 - u - v, u, v)`` from the hit buffer.
    shades : tuple of PointShade
        Where the equation was evaluated: one (flat, Phong) or three (Gouraud).
    weights : (k,) float64
        The weights that combine ``shades``: (1,) or Gouraud's (3,) clamped
        barycentrics.
    ambient, diffuse, specular, emissive, local : (3,) float64
        The weighted terms, and their sum.
    rho : float
        Reflectivity of the surface (0: no mirror part).
    bounces : tuple of Bounce
    reflected : (3,) float64
        ``sum weight * colour`` over the bounces.
    total : (3,) float64
        ``(1 - rho) local + reflected`` (mirrors), ``local`` otherwise, the
        background colour where nothing is hit.
    image : (3,) float32
        ``frame.image[y, x]``, for comparison.
    """

    x: int
    y: int
    method: object
    model: int
    model_name: str
    triangle: int
    vertex_ids: tuple
    barycentrics: np.ndarray
    shades: tuple
    weights: np.ndarray
    ambient: np.ndarray
    diffuse: np.ndarray
    specular: np.ndarray
    emissive: np.ndarray
    local: np.ndarray
    rho: float
    bounces: tuple
    reflected: np.ndarray
    total: np.ndarray
    image: np.ndarray

    def __str__(self) -> str:
        return format_explanation(self)

    def _repr_pretty_(self, p, cycle):  # IPython prints the formula, not the field dump
        p.text(str(self))
