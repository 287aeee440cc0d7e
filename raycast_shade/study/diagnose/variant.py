"""A variant shader: our reflectance equation with each common mistake a switch.

:func:`shade_variant` shades a hit buffer in plain NumPy float64 exactly as
:func:`raycast_shade.shade` does (ambient, Lambert, Phong or Blinn-Phong,
the attenuation laws, Warn's spot cone; flat, Gouraud and Phong shading),
unless a field of its :class:`Mistake` says otherwise. With ``Mistake()`` it
reproduces ``rs.render(scene, method).image`` to float32 precision
(``tests/study/test_diagnose.py``), which is what makes every candidate of the
catalogue a variant of *our* renderer rather than a hand-made image.

The emission ``ke`` is added last, as the kernels add it, and no slip of the
catalogue touches it. Scope: colour and emission textures, mesh colours,
bump and normal maps, shadow rays and mirrors are not modelled;
:func:`check_scene` refuses scenes that use them, naming the feature.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np
from numba import njit

from ...common.parallel import KERNEL, in_parts, share
from ...scene.lights import AreaLight, DirectionalLight, SpotLight
from ...scene.material import MAP_FIELDS
from ...scene.normals import vertex_normals
from ...visibility.interpolation import to_screen_space
from ..reference import _dot, _facing, _unit, _warn_factor
from ..reference import gather_hits as gather  # per hit pixel: mask, face, corners, barycentrics, point

__all__ = ["Mistake", "shade_variant", "gather", "encode", "decode", "check_scene", "LAWS", "ENCODINGS"]

LAWS = ("scene", "none", "inverse", "inverse_square", "heuristic")
ENCODINGS = ("srgb", "linear", "double")
_METHODS = ("flat", "gouraud", "phong")
_CANCEL = 1e-6  # |interpolated normal| below this falls back to the face normal, as the kernels do


@dataclass(frozen=True)
class Mistake:
    """One configuration of the variant shader; the defaults are our renderer.

    Attributes
    ----------
    method : {"", "flat", "gouraud", "phong"}
        ``""``: the method asked for; otherwise the method actually used.
    screen : bool
        Interpolate with weights affine in screen space (2D) instead of the
        3D barycentrics.
    normals : {"mesh", "face", "uniform", "area", "angle"}
        The vertex normals: the mesh's, the face normal at every vertex, or
        averages of the face normals with those weights.
    no_ambient, no_diffuse, no_specular : bool
        Leave the term out.
    ungated : bool
        Add the specular term where ``n.s <= 0`` too.
    unclamped : bool
        ``n.s`` not clamped at 0: the diffuse term goes negative behind.
    raw_n, raw_s, raw_v : bool
        The interpolated normal, the light vector ``L - p`` or the view
        vector ``e - p`` used without dividing by its length.
    raw_n_in_r : bool
        ``r = 2 (n.s) n - s`` with the interpolated normal before
        normalisation (the diffuse term uses the unit one).
    r_sign : bool
        ``r = s - 2 (n.s) n``.
    specular : {"", "swap"}
        ``"swap"``: Blinn's halfway vector where the material says Phong's
        ``r``, and ``r`` where it says Blinn.
    linear_shininess : bool
        ``t * cos`` instead of ``cos^t``.
    law : {"scene", "none", "inverse", "inverse_square", "heuristic"}
        The attenuation law of every point light (``"scene"``: its own;
        ``"inverse"`` is ``1/d``; ``"heuristic"`` uses the light's ``k``).
    eye_distance : bool
        ``d`` measured from the viewpoint instead of from the light.
    light_in_camera : bool
        Light positions and directions read as camera coordinates (x right,
        y up, looking down -z) rather than world ones.
    light_reversed : bool
        The direction of directional and spot lights used the wrong way
        round: ``s = d`` instead of ``-d`` (the spot's cone turned away).
    light_object : bool
        Point and spot light positions read in each model's object frame
        (origin at its bounding-box centre) instead of world coordinates.
    kd_specular : bool
        The specular term multiplied by ``kd`` too (a highlight the colour
        of the surface).
    light : int
        ``-1``: every light; ``i``: only ``scene.lights[i]`` (not a slip:
        the footprint of one light, for :mod:`.holds`).
    encoding : {"srgb", "linear", "double"}
        How the linear image became 8-bit values: the sRGB curve once (ours),
        not at all, or twice.
    flip : bool
        Rows upside down.
    half_pixel : bool
        Rays through pixel corners ``(x, y)`` rather than centres
        ``(x + 0.5, y + 0.5)``.
    bgr : bool
        Red and blue channels swapped.
    """

    method: str = ""
    screen: bool = False
    normals: str = "mesh"
    no_ambient: bool = False
    no_diffuse: bool = False
    no_specular: bool = False
    ungated: bool = False
    unclamped: bool = False
    raw_n: bool = False
    raw_s: bool = False
    raw_v: bool = False
    raw_n_in_r: bool = False
    r_sign: bool = False
    specular: str = ""
    linear_shininess: bool = False
    law: str = "scene"
    eye_distance: bool = False
    light_in_camera: bool = False
    light_reversed: bool = False
    light_object: bool = False
    kd_specular: bool = False
    light: int = -1
    encoding: str = "srgb"
    flip: bool = False
    half_pixel: bool = False
    bgr: bool = False

    def __post_init__(self):
        for name, allowed in (("method", ("",) + _METHODS), ("normals", ("mesh", "face", "uniform", "area", "angle")),
                              ("specular", ("", "swap")), ("law", LAWS), ("encoding", ENCODINGS)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"Mistake.{name}: expected one of {list(allowed)}, got {getattr(self, name)!r}")
        if isinstance(self.light, bool) or not isinstance(self.light, (int, np.integer)) or self.light < -1:
            raise ValueError(f"Mistake.light: expected -1 (every light) or a light's index, got {self.light!r}")

    def changes(self) -> dict:
        """The fields that differ from ``Mistake()``, by name."""
        base = Mistake()
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) != getattr(base, f.name)}

    def combine(self, other: "Mistake") -> "Mistake":
        """This mistake with ``other``'s changes on top."""
        return replace(self, **other.changes())


def check_scene(scene) -> None:
    """Raise ValueError naming the first feature the variant shader does not model.

    Refused: colour maps and mesh colours, bump and normal maps, mirrors,
    lights that cast shadows. (Each would otherwise be left out of every
    candidate, and the library's own correct image named a mistake.)
    """
    for i, light in enumerate(scene.lights):
        if getattr(light, "shadows", False):
            raise ValueError(f"scene.lights[{i}].shadows: diagnose does not model shadow rays; "
                             "render the student's scene without shadows")
    for i, model in enumerate(scene.models):
        mat = model.material
        if getattr(mat, "bump", None) is not None:
            raise ValueError(f"scene.models[{i}].material.bump: diagnose does not model bump maps")
        if getattr(mat, "normal_map", None) is not None:
            raise ValueError(f"scene.models[{i}].material.normal_map: diagnose does not model normal maps "
                             "(the bent normals of Phong shading); diagnose the scene without it")
        used = [f for f, t in zip(MAP_FIELDS, mat.maps) if t is not None]
        if used:
            raise ValueError(f"scene.models[{i}].material.{used[0]}: diagnose does not model colour maps "
                             "(kd_map, ka_map, ks_map, ke_map, ao_map)")
        if getattr(mat, "reflectivity", 0.0) and np.any(np.asarray(mat.reflectivity) > 0):
            raise ValueError(f"scene.models[{i}].material.reflectivity: diagnose does not model mirrors")
        if model.mesh.prepared.color_mode is not None:
            raise ValueError(f"scene.models[{i}].mesh.colors: diagnose does not model mesh colours")


# -- small helpers ------------------------------------------------------------------------------------
def _camera_axes(camera):
    """Unit right, up and backward axes of the camera (3, 3), rows."""
    fwd = camera.target - camera.eye
    fwd = fwd / np.linalg.norm(fwd)
    right = np.cross(fwd, camera.up)
    right = right / np.linalg.norm(right)
    up = np.cross(right, fwd)
    return np.stack([right, up, -fwd])


def _lights(scene, camera, origin, mistake):
    """The lights as ``(directional, vec, radiance, law, k, cone)`` with the mistake's law and space."""
    axes = _camera_axes(camera)
    out = []
    for index, light in enumerate(scene.lights):
        if mistake.light not in (-1, index):
            continue
        radiance = light.intensity * np.asarray(light.color, np.float64)
        if isinstance(light, DirectionalLight):
            d = np.asarray(light.direction, np.float64)
            if mistake.light_in_camera:
                d = d @ axes  # camera coordinates -> world
            if mistake.light_reversed:
                d = -d
            out.append((True, -d, radiance, "none", 1.0, None))
            continue
        law = light.attenuation if mistake.law == "scene" else mistake.law
        if isinstance(light, AreaLight):  # its samples, each 1/N of it (as the kernels)
            for q in light.sample_points():
                q = camera.eye + q @ axes if mistake.light_in_camera else q
                out.append((False, q - origin, radiance / light.samples, law, light.k, None))
            continue
        pos = np.asarray(light.position, np.float64)
        cone = None
        if isinstance(light, SpotLight):
            axis = np.asarray(light.direction, np.float64)
            if mistake.light_in_camera:
                axis = axis @ axes
            if mistake.light_reversed:
                axis = -axis
            cone = (axis, light.cos_inner, light.cos_outer, light.exponent)
        if mistake.light_in_camera:
            pos = camera.eye + pos @ axes
        out.append((False, pos - origin, radiance, law, light.k, cone))
    return out


class _Ctx:
    """What every evaluation needs: materials, lights, eye, the mistake."""

    def __init__(self, scene, camera, mistake):
        geo = scene.geometry
        self.geo = geo
        self.m = mistake
        mats = [mod.material for mod in scene.models]
        self.ka = np.array([x.ka for x in mats], np.float64)
        self.kd = np.array([x.kd for x in mats], np.float64)
        self.ks = np.array([x.ks for x in mats], np.float64)
        self.shin = np.array([x.shininess for x in mats], np.float64)
        self.ke = np.array([x.ke for x in mats], np.float64)
        blinn = np.array([x.specular == "blinn" for x in mats], bool)
        self.blinn = ~blinn if mistake.specular == "swap" else blinn
        self.lights = _lights(scene, camera, geo.origin, mistake)
        # light_object: each model's frame is its box centre (world = object + centre)
        self.centre = np.array([np.mean(mod.mesh.bounds, axis=0) for mod in scene.models], np.float64)
        self.ambient = np.asarray(scene.ambient, np.float64) * np.ones(3)
        self.dmin = 1e-6 * geo.scale
        self.eye = camera.eye - geo.origin
        fwd = camera.target - camera.eye
        self.fwd = fwd / np.linalg.norm(fwd)
        self.ortho = camera.orthographic

    def view(self, p):
        """Unit vectors to the eye (N, 3) and the unnormalised ones."""
        if self.ortho:
            v = np.broadcast_to(-self.fwd, p.shape).copy()
            return v, v
        raw = self.eye - p
        v, length = _unit(raw)
        v[length == 0] = -self.fwd
        return v, raw


def _light_vectors(ctx, light, p, model):
    """Direction ``s`` (unit, or raw with ``raw_s``), the unit one, attenuation and presence."""
    directional, vec, _, law, k, cone = light
    n = len(p)
    if directional:
        s = np.broadcast_to(vec, p.shape)
        return s, s, np.ones(n), np.ones(n, bool)
    raw = (vec + ctx.centre[model] if ctx.m.light_object else vec[None, :]) - p
    s, d = _unit(raw)
    dist = np.linalg.norm(ctx.eye - p, axis=1) if ctx.m.eye_distance else d
    with np.errstate(divide="ignore"):
        if law == "inverse_square":
            att = 1.0 / np.maximum(dist, ctx.dmin) ** 2
        elif law == "inverse":
            att = 1.0 / np.maximum(dist, ctx.dmin)
        elif law == "heuristic":
            att = 1.0 / (dist + k)
        else:
            att = np.ones(n)
    if cone is not None:
        att = att * _warn_factor(cone, s)
    return (raw if ctx.m.raw_s else s), s, att, d > 0.0


def illuminate(ctx, p, n, model, n_raw=None):
    """The reflectance equation (plus ``ke``) at points ``p`` (N, 3) with unit normals ``n`` (N, 3), under the mistake.

    ``n_raw`` (N, 3): the normal before normalisation (Phong shading's
    interpolated ``a``), used by ``raw_n`` and ``raw_n_in_r``.

    Returns
    -------
    (N, 3) float64
        Linear RGB.
    """
    m = ctx.m
    if n_raw is None:
        n_raw = n
    n_used = n_raw if m.raw_n else n
    v, v_raw = ctx.view(p)
    v_used = v_raw if m.raw_v else v
    ka, kd, ks = ctx.ka[model], ctx.kd[model], ctx.ks[model]
    shin, blinn = ctx.shin[model], ctx.blinn[model]
    has_spec = np.any(ks > 0, axis=1)
    out = np.zeros((len(p), 3)) if m.no_ambient else ctx.ambient[None, :] * ka
    for light in ctx.lights:
        s, s_unit, att, present = _light_vectors(ctx, light, p, model)
        ndots_raw = _dot(n_used, s)
        lit = present & (ndots_raw > 0.0)
        exact = not (m.raw_n or m.raw_s)
        ndots = np.clip(ndots_raw, 0.0, 1.0) if exact else np.maximum(ndots_raw, 0.0)
        diffuse = np.where(present, ndots_raw, 0.0) if m.unclamped else np.where(lit, ndots, 0.0)
        nr = n_raw if m.raw_n_in_r else n_used
        h, hl = _unit(s + v_used)
        c_blinn = np.where(hl > 0.0, _dot(n_used, h), 0.0)
        r = 2.0 * (ndots_raw if m.ungated else ndots)[:, None] * nr - s
        if m.r_sign:
            r = -r
        c = np.where(blinn, c_blinn, _dot(r, v_used))
        c = np.maximum(c, 0.0) if (m.raw_s or m.raw_v or m.raw_n or m.raw_n_in_r) else np.clip(c, 0.0, 1.0)
        with np.errstate(over="ignore"):
            spec = shin * c if m.linear_shininess else c ** shin
        spec = np.where((c > 0.0) & has_spec, spec, 0.0)
        if not m.ungated:
            spec = np.where(lit, spec, 0.0)
        spec = np.where(present, spec, 0.0)
        kd_term = 0.0 if m.no_diffuse else kd * diffuse[:, None]
        ks_term = 0.0 if m.no_specular else ks * spec[:, None] * (kd if m.kd_specular else 1.0)
        out = out + att[:, None] * light[2][None, :] * (kd_term + ks_term)
    return out + ctx.ke[model]  # the emission, last as the kernels add it (a zero ke adds exactly nothing)


def _vertex_normals(ctx):
    """(V, 3) vertex normals under ``mistake.normals`` (``"face"`` handled by the callers)."""
    geo, how = ctx.geo, ctx.m.normals
    if how in ("mesh", "face"):
        return geo.normals
    return geo.memo(f"diagnose-normals-{how}", lambda g: vertex_normals(g.vertices, g.faces, weighting=how)[2])


def _corner_normals(ctx, face, tri, g, sgn):
    """(N, 3, 3): the normal at each corner of each pixel's face, as the kernels orient it."""
    if ctx.m.normals == "face":
        return np.repeat(g[:, None, :], 3, axis=1)
    nv = _vertex_normals(ctx)[tri] * sgn[:, None, None]
    missing = ~np.any(nv != 0.0, axis=2)
    nv = np.where(missing[:, :, None], g[:, None, :], nv)
    c = np.minimum(np.einsum("nkj,nj->nk", nv, g), 0.0)
    return nv - 2.0 * c[:, :, None] * g[:, None, :]


def _flat(ctx, face):
    geo = ctx.geo
    faces, inverse = np.unique(face, return_inverse=True)
    centre = geo.vertices[geo.faces[faces]].sum(axis=1) / 3.0
    v, _ = ctx.view(centre)
    g, _ = _facing(geo.face_normals[faces], v)
    colour = illuminate(ctx, centre, g, geo.face_model[faces])
    return colour[inverse.ravel()]


def _phong(ctx, face, tri, bary, p):
    geo = ctx.geo
    v, _ = ctx.view(p)
    g, sgn = _facing(geo.face_normals[face], v)
    if ctx.m.normals == "face":
        return illuminate(ctx, p, g, geo.face_model[face])
    a = np.einsum("nk,nkc->nc", bary, _vertex_normals(ctx)[tri])
    n, length = _unit(a)
    n *= sgn[:, None]
    a = a * sgn[:, None]
    c = _dot(n, g)
    flip = (c < 0.0)[:, None]
    n = np.where(flip, n - 2.0 * c[:, None] * g, n)
    a = np.where(flip, a - 2.0 * (c * length)[:, None] * g, a)
    cancelled = ~(length >= _CANCEL)
    n[cancelled] = g[cancelled]
    a[cancelled] = g[cancelled]
    return illuminate(ctx, p, n, geo.face_model[face], n_raw=a)


def _gouraud(ctx, face, tri, bary, p):
    """Vertex shades interpolated; each (face, side) pair's three corners are shaded once."""
    geo = ctx.geo
    v, _ = ctx.view(p)
    g, sgn = _facing(geo.face_normals[face], v)
    key = face * 2 + (sgn > 0)
    uniq, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    ftri, fg, fsgn = tri[first], g[first], sgn[first]
    normals = _corner_normals(ctx, face[first], ftri, fg, fsgn)
    model = geo.face_model[face[first]]
    acc = np.zeros((len(p), 3))
    for k in range(3):
        colour = illuminate(ctx, geo.vertices[ftri[:, k]], normals[:, k], model)
        acc += bary[:, k, None] * colour[inverse]
    return acc


def shade_variant(scene, camera, hits, method: str, mistake: Mistake = Mistake(), gathered=None) -> np.ndarray:
    """Shade a hit buffer as a renderer with ``mistake`` would.

    Parameters
    ----------
    scene : Scene
        Checked with :func:`check_scene`.
    camera : Camera
    hits : HitBuffer
        (H, W) buffers from ``camera`` (with ``mistake.half_pixel`` the
        caller casts them through the pixel corners).
    method : {"flat", "gouraud", "phong"}
        The method asked for (``mistake.method`` overrides it).
    mistake : Mistake
    gathered : tuple, optional
        The per-pixel data of ``hits`` from an earlier call (:func:`gather`),
        to share it between the candidates of one frame; ignored for 2D
        interpolation, whose weights differ.

    Returns
    -------
    (H, W, 3) float64
        Linear RGB before encoding, flipping and channel order
        (:func:`encode` applies those); ``scene.background`` off the mesh.
    """
    if method not in _METHODS:
        raise ValueError(f"method: expected one of {list(_METHODS)}, got {method!r}")
    method = mistake.method or method
    geo = scene.geometry
    if mistake.screen and method != "flat":
        hits = to_screen_space(hits, geo, camera)
        gathered = None
    ctx = _Ctx(scene, camera, mistake)
    if gathered is None:
        gathered = gather(geo, hits)
    mask, face, tri, bary, p = gathered
    image = np.empty(hits.shape + (3,), np.float64)
    image[~mask] = np.asarray(getattr(scene, "background", 0.0), np.float64) * np.ones(3)
    if not mask.any():
        return image
    with np.errstate(divide="ignore", invalid="ignore"):
        if method == "flat":
            image[mask] = _flat(ctx, face)
        elif method == "phong":
            image[mask] = _phong(ctx, face, tri, bary, p)
        else:
            image[mask] = _gouraud(ctx, face, tri, bary, p)
    return image


@in_parts
@njit(**KERNEL)
def _srgb_kernel(x, out, part):
    """The sRGB curve of ``x`` (N,) in [0, 1] into ``out`` (N,): as to_uint8's, before rounding."""
    for i in range(*share(x.shape[0], part)):  # this part's share (common.parallel)
        v = x[i]
        out[i] = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1.0 / 2.4) - 0.055


def _srgb(x):
    out = np.empty_like(x)
    _srgb_kernel(x.reshape(-1), out.reshape(-1))
    return out


def encode(image, mistake: Mistake = Mistake()) -> np.ndarray:
    """Display values in [0, 1] of a linear image, as the mistaken renderer wrote them.

    Clipped to [0, 1], then the sRGB curve once (``"srgb"``), not at all
    (``"linear"``) or twice (``"double"``); then flipped and channel-swapped
    as the mistake says.

    Parameters
    ----------
    image : (H, W, 3) float
    mistake : Mistake

    Returns
    -------
    (H, W, 3) float64
        Not quantised (the scorer compares with 8-bit values itself).
    """
    x = np.clip(np.asarray(image, np.float64), 0.0, 1.0)  # NaN stays NaN: no image of ours holds one
    if mistake.encoding != "linear":
        x = _srgb(x)
    if mistake.encoding == "double":
        x = _srgb(x)
    if mistake.flip:
        x = x[::-1]
    if mistake.bgr:
        x = x[..., ::-1]
    return np.ascontiguousarray(x)


def _srgb_inverse(x):
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def decode(levels, mistake: Mistake = Mistake()) -> np.ndarray:
    """Linear values read back from 8-bit levels through the mistake's encoding and channel order.

    The inverse of :func:`encode` for one pixel or an image (without the
    flip, which moves pixels): what the renderer computed before writing,
    up to quantisation and clipping at 1.

    Parameters
    ----------
    levels : (..., 3) float
        0..255.
    mistake : Mistake

    Returns
    -------
    (..., 3) float64
    """
    x = np.clip(np.asarray(levels, np.float64) / 255.0, 0.0, 1.0)
    if mistake.bgr:
        x = x[..., ::-1]
    if mistake.encoding == "double":
        x = _srgb_inverse(x)
    if mistake.encoding != "linear":
        x = _srgb_inverse(x)
    return x
