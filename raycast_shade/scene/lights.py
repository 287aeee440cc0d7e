"""Light sources: point lights with the lecture's attenuation laws, Warn's spot lights, lights at
infinity, and area lights (rectangles and discs) that cast soft shadows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..common.choices import ATTENUATIONS
from ..common.layout import (AREA_DISC, AREA_RECTANGLE, ATT_CODE, LIGHT_AREA, LIGHT_ATT, LIGHT_AXIS,
                             LIGHT_COS_INNER, LIGHT_COS_OUTER, LIGHT_DIRECTIONAL, LIGHT_EDGE_U, LIGHT_EDGE_V,
                             LIGHT_EXPONENT, LIGHT_K, LIGHT_KIND, LIGHT_POINT, LIGHT_RADIANCE, LIGHT_SAMPLES,
                             LIGHT_SHADOWS, LIGHT_SHAPE, LIGHT_SIZE, LIGHT_SPOT, LIGHT_VEC)
from ..common.validate import (MAX_RADIANCE, as_array, as_bool, as_choice, as_int, as_name, as_rgb, as_scalar, as_vec3,
                               pow2_scaled)

__all__ = ["Light", "PointLight", "SpotLight", "DirectionalLight", "AreaLight", "ATTENUATIONS", "MAX_SPOT_EXPONENT",
           "MAX_AREA_SAMPLES", "MAX_AREA_EXTENT", "AREA_SHAPES"]

MAX_SPOT_EXPONENT = 1e4  # cos^n: beyond this the beam is a few hundredths of a degree wide
MAX_AREA_SAMPLES = 4096  # shadow rays per area light and shaded point: bounded work
MAX_AREA_EXTENT = 1e18  # an emitter's radius or edge: beyond this a scene refuses it anyway (Embree's float32)
AREA_SHAPES = {"rectangle": AREA_RECTANGLE, "disc": AREA_DISC}  # LIGHT_SHAPE codes
_GOLDEN = 0.6180339887498949  # the sample lattice's second axis (shading.illumination.GOLDEN)

class Light:
    """What every light kind has: a radiance, whether it casts shadows, and a row for the kernels.

    A new kind subclasses this (a frozen dataclass), packs itself in :meth:`pack` under a new
    ``LIGHT_KIND`` code of :mod:`raycast_shade.common.layout`, and the kernels read it in one
    place, :func:`raycast_shade.shading.illumination._light_at` (with ``_light_point``, where its
    samples are). The batched Phong kernel shades only the kinds it declares
    (``raycast_shade.shading.phong_fast.HANDLES``); frames with a new kind take the general kernel.
    """

    kind = None  # the LIGHT_KIND code of the rows this class packs

    def pack(self, origin) -> np.ndarray:
        """This light's kernel row.

        Parameters
        ----------
        origin : (3,) float64
            The scene's centre (the ``origin`` of :class:`raycast_shade.scene.scene.SceneGeometry`): positions are re-centred on it
            like the geometry.

        Returns
        -------
        (LIGHT_SIZE,) = (16,) float64
            Slots named in :mod:`raycast_shade.common.layout`: kind, position or direction
            towards the light, radiance, attenuation code, ``k`` (1 where unused), casts
            shadows; the spot slots zero unless the kind uses them.
        """
        row = np.zeros(LIGHT_SIZE)
        row[LIGHT_KIND] = self.kind
        row[LIGHT_RADIANCE:LIGHT_RADIANCE + 3] = self.radiance
        row[LIGHT_SHADOWS] = int(self.shadows)
        row[LIGHT_K] = 1.0
        row[LIGHT_SAMPLES] = 1.0
        return row


@dataclass(frozen=True, eq=False)
class PointLight(Light):
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
        set_(self, "name", as_name(self.name, f"{type(self).__name__}.name"))  # first: every message uses it
        set_(self, "position", as_vec3(self.position, f"{self.name}.position"))
        set_(self, "intensity", as_scalar(self.intensity, f"{self.name}.intensity", minimum=0.0, maximum=MAX_RADIANCE))
        set_(self, "color", as_rgb(self.color, f"{self.name}.color"))
        set_(self, "attenuation", as_choice(self.attenuation, f"{self.name}.attenuation", ATTENUATIONS))
        k = as_scalar(self.k, f"{self.name}.k")
        if self.attenuation == "heuristic" and not k > 0:
            raise ValueError(f"{self.name}.k: heuristic attenuation needs k > 0, got {k}")
        if k < 0:  # read by the heuristic law only, but never kept: 1/(d + k) divides by zero at d = -k
            raise ValueError(f"{self.name}.k: must be >= 0, got {k}")
        set_(self, "k", k)
        set_(self, "shadows", as_bool(self.shadows, f"{self.name}.shadows"))

    kind = LIGHT_POINT

    @property
    def radiance(self) -> np.ndarray:
        """(3,) float64 ``Ii * color``."""
        return self.intensity * self.color

    def pack(self, origin) -> np.ndarray:
        row = super().pack(origin)
        row[LIGHT_VEC:LIGHT_VEC + 3] = self.position - origin
        row[LIGHT_ATT] = ATT_CODE[self.attenuation]
        row[LIGHT_K] = self.k
        return row


@dataclass(frozen=True, eq=False)
class DirectionalLight(Light):
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
        set_(self, "name", as_name(self.name, f"{type(self).__name__}.name"))  # first: every message uses it
        d = pow2_scaled(as_vec3(self.direction, f"{self.name}.direction", nonzero=True))
        d = d / np.linalg.norm(d)  # scaled first: (1e308, 1e308, 0) and (1e-200, 1e-200, 0) stay directions
        d.setflags(write=False)
        set_(self, "direction", d)
        set_(self, "intensity", as_scalar(self.intensity, f"{self.name}.intensity", minimum=0.0, maximum=MAX_RADIANCE))
        set_(self, "color", as_rgb(self.color, f"{self.name}.color"))
        set_(self, "shadows", as_bool(self.shadows, f"{self.name}.shadows"))

    kind = LIGHT_DIRECTIONAL

    @property
    def radiance(self) -> np.ndarray:
        return self.intensity * self.color

    def pack(self, origin) -> np.ndarray:
        row = super().pack(origin)
        row[LIGHT_VEC:LIGHT_VEC + 3] = -self.direction  # towards the light
        return row


@dataclass(frozen=True, eq=False)
class SpotLight(PointLight):
    """Warn's spot light: a point light whose intensity depends on the angle to its axis.

    A point at angle ``a`` from the axis (seen from the light) receives::

        Ii * cos(a)**n * smoothstep(cos(outer), cos(inner), cos(a)) * att(d)

    so ``Ii cos^n a`` inside the inner cone, nothing outside the outer cone,
    and between them the smooth Hermite step ``3 t^2 - 2 t^3`` of
    ``t = (cos a - cos outer) / (cos inner - cos outer)`` (``inner_angle ==
    outer_angle``: a hard edge, the light reaching exactly the points with
    ``cos a > cos outer``). Attenuation, colour and shadows are those of a
    :class:`PointLight` (it is one: ``isinstance(spot, PointLight)`` holds).

    Parameters
    ----------
    position : (3,) float
    direction : (3,) float
        The axis, from the light into its cone; non-zero, normalised on
        construction.
    intensity, color, attenuation, k, shadows
        As for :class:`PointLight`.
    exponent : float
        Warn's ``n``, ``0 <= n <= MAX_SPOT_EXPONENT`` (0: a uniform cone).
    inner_angle, outer_angle : float
        Cone half-angles in degrees, ``0 <= inner_angle <= outer_angle <= 90``
        and ``outer_angle > 0`` (a cone of half-angle 0 lights no point).
    """

    direction: np.ndarray = (0.0, 0.0, -1.0)
    exponent: float = 1.0
    inner_angle: float = 30.0
    outer_angle: float = 40.0
    name: str = "spot_light"

    def __init__(self, position, direction=(0.0, 0.0, -1.0), intensity=1.0, color=1.0, attenuation="none", k=1.0,
                 shadows=False, exponent=1.0, inner_angle=30.0, outer_angle=40.0, name="spot_light"):
        # Spelled out for the argument order (position, direction, ...): a dataclass
        # subclass would put its own fields after PointLight's.
        set_ = object.__setattr__
        for key, value in (("position", position), ("direction", direction), ("intensity", intensity),
                           ("color", color), ("attenuation", attenuation), ("k", k), ("shadows", shadows),
                           ("exponent", exponent), ("inner_angle", inner_angle), ("outer_angle", outer_angle),
                           ("name", name)):
            set_(self, key, value)
        self.__post_init__()

    def __post_init__(self):
        super().__post_init__()
        set_ = object.__setattr__
        d = pow2_scaled(as_vec3(self.direction, f"{self.name}.direction", nonzero=True))
        d = d / np.linalg.norm(d)
        d.setflags(write=False)
        set_(self, "direction", d)
        set_(self, "exponent", as_scalar(self.exponent, f"{self.name}.exponent", minimum=0.0,
                                         maximum=MAX_SPOT_EXPONENT))
        inner = as_scalar(self.inner_angle, f"{self.name}.inner_angle", minimum=0.0, maximum=90.0)
        outer = as_scalar(self.outer_angle, f"{self.name}.outer_angle", minimum=0.0, maximum=90.0)
        if inner > outer:
            raise ValueError(f"{self.name}.inner_angle: must be <= outer_angle ({outer}), got {inner}")
        if outer == 0.0:  # the light reaches the points with cos a > cos(outer) = 1: none
            raise ValueError(f"{self.name}.outer_angle: must be > 0, got inner_angle {inner:g} and outer_angle "
                             f"{outer:g}: a cone of half-angle 0 lights no point (a point light lights every "
                             "direction)")
        set_(self, "inner_angle", inner)
        set_(self, "outer_angle", outer)

    kind = LIGHT_SPOT

    def pack(self, origin) -> np.ndarray:
        row = super().pack(origin)
        row[LIGHT_AXIS:LIGHT_AXIS + 3] = self.direction
        row[LIGHT_COS_INNER] = self.cos_inner
        row[LIGHT_COS_OUTER] = self.cos_outer
        row[LIGHT_EXPONENT] = self.exponent
        return row

    @property
    def cos_inner(self) -> float:
        return float(np.cos(np.radians(self.inner_angle)))

    @property
    def cos_outer(self) -> float:
        return float(np.cos(np.radians(self.outer_angle)))

    def falloff(self, cos_angle):
        """Warn's factor ``cos^n * smoothstep`` for cosines of the angle to the axis (NumPy, any shape)."""
        # as_array is at least 1-D (ascontiguousarray): keep a scalar a scalar.
        c = as_array(cos_angle, "cos_angle", dtype=np.float64).reshape(np.shape(cos_angle))
        if c.size and np.abs(c).max() > 1.0:
            raise ValueError(f"cos_angle: cosines lie in [-1, 1], got {np.abs(c).max():.6g}")
        ci, co = self.cos_inner, self.cos_outer
        if ci > co:
            t = np.clip((c - co) / (ci - co), 0.0, 1.0)
            edge = t * t * (3.0 - 2.0 * t)
        else:
            edge = (c > co).astype(np.float64)
        return np.where(c > co, np.maximum(c, 0.0) ** self.exponent * edge, 0.0)


@dataclass(frozen=True, eq=False)
class AreaLight(PointLight):
    """A rectangle or a disc that emits light, casting soft shadows.

    The emitter is evaluated at ``samples`` points spread over it, each a point light of
    ``intensity / samples`` with the light's attenuation law, colour and shadow rays (so a
    point in the penumbra sees the fraction of the samples that no surface blocks). The
    samples are a stratified rank-1 lattice, ``((j + 1/2) / N, frac(j phi + 1/2))`` over the unit
    square (``phi`` the golden ratio's fraction), mapped onto the rectangle, or onto the disc by
    Shirley and Chiu's concentric map; the same points at every shaded point, so the image
    has no noise, and its one point (``samples=1``) is the centre: one sample renders exactly as
    a :class:`PointLight` at ``position``, bit for bit. Each sample emits alike in every
    direction, as the lecture's point lights do (no cosine of the emitter's own normal): the
    light is a patch of point lights, both faces alight.

    Parameters
    ----------
    position : (3,) float
        The centre.
    u, v : (3,) float
        ``"rectangle"``: its two edges (corners at ``position +- u/2 +- v/2``); ``"disc"``: its two
        radii (``position + a u + b v``, ``a^2 + b^2 <= 1``: a disc when they are as long, an
        ellipse otherwise). Non-zero and perpendicular (to 1e-6 of their lengths' product).
    shape : {"rectangle", "disc"}
    samples : int
        ``1 <= N <= MAX_AREA_SAMPLES``: shadow rays per shaded point, and the smoothness of the
        penumbra (its steps are ``1/N`` of the light).
    intensity, color, attenuation, k, shadows
        As for :class:`PointLight`: ``intensity`` is the whole emitter's.

    See Also
    --------
    AreaLight.disc : a disc from its normal and radius.
    """

    u: np.ndarray = (1.0, 0.0, 0.0)
    v: np.ndarray = (0.0, 1.0, 0.0)
    shape: str = "rectangle"
    samples: int = 16
    name: str = "area_light"

    def __init__(self, position, u=(1.0, 0.0, 0.0), v=(0.0, 1.0, 0.0), shape="rectangle", samples=16, intensity=1.0,
                 color=1.0, attenuation="none", k=1.0, shadows=False, name="area_light"):
        # Spelled out for the argument order (position, u, v, ...), as SpotLight's.
        set_ = object.__setattr__
        for key, value in (("position", position), ("u", u), ("v", v), ("shape", shape), ("samples", samples),
                           ("intensity", intensity), ("color", color), ("attenuation", attenuation), ("k", k),
                           ("shadows", shadows), ("name", name)):
            set_(self, key, value)
        self.__post_init__()

    def __post_init__(self):
        super().__post_init__()
        set_ = object.__setattr__
        u = as_vec3(self.u, f"{self.name}.u", nonzero=True)
        v = as_vec3(self.v, f"{self.name}.v", nonzero=True)
        lu, lv = float(np.linalg.norm(u)), float(np.linalg.norm(v))
        for key, length in (("u", lu), ("v", lv)):
            if not length <= MAX_AREA_EXTENT:
                raise ValueError(f"{self.name}.{key}: the emitter's size must be <= {MAX_AREA_EXTENT:g}, "
                                 f"got {length:.6g}")
        if abs(float(u @ v)) > 1e-6 * lu * lv:
            raise ValueError(f"{self.name}.u, {self.name}.v: the emitter's edges (or radii) must be perpendicular, "
                             f"got u.v = {float(u @ v):.6g} for |u| |v| = {lu * lv:.6g}")
        for key, value in (("u", u), ("v", v)):
            value.setflags(write=False)
            set_(self, key, value)
        set_(self, "shape", as_choice(self.shape, f"{self.name}.shape", tuple(AREA_SHAPES)))
        set_(self, "samples", as_int(self.samples, f"{self.name}.samples", minimum=1, maximum=MAX_AREA_SAMPLES))

    kind = LIGHT_AREA

    @classmethod
    def disc(cls, position, normal, radius, **kw) -> "AreaLight":
        """A disc of ``radius`` centred on ``position``, facing ``normal`` (its axes: any two
        perpendicular radii in its plane); ``kw`` as for :class:`AreaLight`."""
        name = kw.get("name", "area_light")
        n = as_vec3(normal, f"{name}.normal", nonzero=True)
        n = n / np.linalg.norm(n)
        r = as_scalar(radius, f"{name}.radius", minimum=0.0, exclusive=True, maximum=MAX_AREA_EXTENT)
        a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = np.cross(n, a)
        u /= np.linalg.norm(u)
        return cls(position, u * r, np.cross(n, u) * r, shape="disc", **kw)

    @property
    def area(self) -> float:
        """The emitter's area: ``|u x v|`` for a rectangle, ``pi |u| |v|`` for a disc."""
        if self.shape == "disc":
            return float(np.pi * np.linalg.norm(self.u) * np.linalg.norm(self.v))
        return float(np.linalg.norm(np.cross(self.u, self.v)))

    def _half_axes(self):
        """The packed axes: half-edges of a rectangle, radii of a disc."""
        return (self.u / 2.0, self.v / 2.0) if self.shape == "rectangle" else (self.u, self.v)

    def sample_points(self) -> np.ndarray:
        """(N, 3) float64: where the kernels evaluate the light (world coordinates), in order."""
        j = np.arange(self.samples, dtype=np.float64)
        a = 2.0 * ((j + 0.5) / self.samples) - 1.0
        t = j * _GOLDEN + 0.5
        b = 2.0 * (t - np.floor(t)) - 1.0
        if self.shape == "disc":
            a, b = _concentric(a, b)
        eu, ev = self._half_axes()
        return self.position + a[:, None] * eu + b[:, None] * ev

    def pack(self, origin) -> np.ndarray:
        row = super().pack(origin)
        eu, ev = self._half_axes()
        row[LIGHT_EDGE_U:LIGHT_EDGE_U + 3] = eu
        row[LIGHT_EDGE_V:LIGHT_EDGE_V + 3] = ev
        row[LIGHT_SHAPE] = AREA_SHAPES[self.shape]
        row[LIGHT_SAMPLES] = self.samples
        return row


def _concentric(a, b):
    """Shirley and Chiu's concentric map of the square ``[-1, 1]^2`` onto the unit disc (arrays),
    the kernels' arithmetic (``shading.illumination._light_point``)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    x, y = np.zeros_like(a), np.zeros_like(b)
    for i in range(a.size):  # a few samples: per element, as the kernel branches
        ai, bi = a.flat[i], b.flat[i]
        if ai == 0.0 and bi == 0.0:
            continue
        if abs(ai) > abs(bi):
            rad, phi = ai, (np.pi / 4.0) * (bi / ai)
        else:
            rad, phi = bi, np.pi / 2.0 - (np.pi / 4.0) * (ai / bi)
        x.flat[i], y.flat[i] = rad * np.cos(phi), rad * np.sin(phi)
    return x, y
