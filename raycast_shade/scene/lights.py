"""Light sources: point lights with the lecture's attenuation laws, and lights at infinity."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common.choices import ATTENUATIONS
from ..common.validate import MAX_RADIANCE, as_choice, as_rgb, as_scalar, as_vec3, pow2_scaled

__all__ = ["PointLight", "DirectionalLight", "ATTENUATIONS"]



def _as_bool(value, name):
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False, got {type(value).__name__}")
    return bool(value)


@dataclass(frozen=True, eq=False)
class PointLight:
    """A point source at ``position``.

    The intensity reaching a point at distance ``d`` is ``Ii`` (``"none"``),
    ``Ii / d**2`` (``"inverse_square"``) or ``Ii / (d + k)`` (``"heuristic"``,
    ``k > 0``).

    A light exactly on a surface (``d = 0``) has no direction to that point:
    it contributes nothing there. Just off it, the inverse-square law is
    evaluated with ``d`` clamped below at ``1e-6`` of the scene's size, so the
    output stays finite.

    Parameters
    ----------
    position : (3,) float
    intensity : float
        ``Ii >= 0``.
    color : float or (3,) float
        Per-channel factor on ``Ii``.
    attenuation : {"none", "inverse_square", "heuristic"}
    k : float
        Heuristic constant, used by ``"heuristic"`` only; must be ``> 0``.
    shadows : bool
        Trace a shadow ray from every shaded point to this light.
    """

    position: np.ndarray
    intensity: float = 1.0
    color: object = 1.0
    attenuation: str = "none"
    k: float = 1.0
    shadows: bool = False
    name: str = "point_light"

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "position", as_vec3(self.position, f"{self.name}.position"))
        set_(self, "intensity", as_scalar(self.intensity, f"{self.name}.intensity", minimum=0.0, maximum=MAX_RADIANCE))
        set_(self, "color", as_rgb(self.color, f"{self.name}.color"))
        set_(self, "attenuation", as_choice(self.attenuation, f"{self.name}.attenuation", ATTENUATIONS))
        k = as_scalar(self.k, f"{self.name}.k")
        if self.attenuation == "heuristic" and not k > 0:
            raise ValueError(f"{self.name}.k: heuristic attenuation needs k > 0, got {k}")
        set_(self, "k", k)
        set_(self, "shadows", _as_bool(self.shadows, f"{self.name}.shadows"))

    @property
    def radiance(self) -> np.ndarray:
        """(3,) float64 ``Ii * color``."""
        return self.intensity * self.color


@dataclass(frozen=True, eq=False)
class DirectionalLight:
    """A light at infinity shining along ``direction`` (from the light to the scene).

    Parameters
    ----------
    direction : (3,) float
        Non-zero, any finite magnitude; normalised on construction.
    intensity : float
    color : float or (3,) float
    shadows : bool
        Trace a shadow ray from every shaded point towards the light.
    """

    direction: np.ndarray
    intensity: float = 1.0
    color: object = 1.0
    shadows: bool = False
    name: str = "directional_light"

    def __post_init__(self):
        set_ = object.__setattr__
        d = pow2_scaled(as_vec3(self.direction, f"{self.name}.direction", nonzero=True))
        d = d / np.linalg.norm(d)  # scaled first: (1e308, 1e308, 0) and (1e-200, 1e-200, 0) stay directions
        d.setflags(write=False)
        set_(self, "direction", d)
        set_(self, "intensity", as_scalar(self.intensity, f"{self.name}.intensity", minimum=0.0, maximum=MAX_RADIANCE))
        set_(self, "color", as_rgb(self.color, f"{self.name}.color"))
        set_(self, "shadows", _as_bool(self.shadows, f"{self.name}.shadows"))

    @property
    def radiance(self) -> np.ndarray:
        return self.intensity * self.color
