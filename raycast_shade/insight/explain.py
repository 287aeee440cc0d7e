"""A pixel explained: the reflectance equation at one pixel, with its numbers.

:func:`explain` follows what the kernels do for that pixel, step by step, in
float64 NumPy: where the method evaluates the equation (the face centre for
flat, the three vertices for Gouraud, the pixel's point for Phong), the
normal it uses (the face's; the vertex's; interpolated, renormalised and
bumped or normal-mapped), and per light the direction ``s``, the distance ``d`` and the
attenuation, the shadow ray's answer (traced with Embree from the same
offset origin as the kernels), a spot light's cone factor, ``n.s``, ``r`` or
``h`` and the specular cosine, and the diffuse and specular terms; mirrors
add the reflected part, bounce by bounce. The coefficients ``ka, kd, Ks`` are
the point's, as the kernels take them (:mod:`raycast_shade.shading.texture`):
kd the mesh's vertex colours (interpolated) or face colour, each coefficient
times its map's texel, filtered by the pixel's footprint (flat: the face's
own footprint at its centre; mirror bounces: level 0). Gouraud on a model
with maps or face colours ("modulate") lights the vertices and takes the
pixel's coefficients: explained as the three vertex shades evaluated with
the pixel's ``ka, kd, Ks``, the same sum since the weights add up to 1. The
total equals ``frame.image[y, x]`` to float32 rounding.

The pixel's hit is the frame's: from its hit buffer, or, for a frame shaded
band by band (which keeps no buffer), cast for that pixel alone
(:meth:`~raycast_shade.output.frame.Frame.hit`,
:func:`~raycast_shade.visibility.pixel.cast_pixel`: its packet rows and the
neighbours the vertex repair reads, a few hundred microseconds at 1080p
rather than the whole frame). The camera row, the shadow BVH and the ray
offsets are the frame's own kernel inputs (``frame.inputs``).

The geometry helpers are those of the plain-NumPy twin
(:mod:`raycast_shade.study.reference`); shadow rays, bump maps and mirror
rays, which the twin leaves out, are followed here for one pixel.
``str()`` of the result prints the lecture's formula with the numbers
filled in (:mod:`raycast_shade.insight.explain_text`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..common.layout import (CAM_EYE, CAM_FORWARD, CAM_ORTHO, MAT_BLINN, MAT_KA, MAT_KD, MAT_KE, MAT_KS,
                             MAT_REFLECTIVITY, MAT_SHININESS)
from ..common.validate import as_int
from ..scene.lights import AreaLight, DirectionalLight, SpotLight
from ..shading.inputs import prepare
from ..shading.shade import resolve_methods
from ..visibility.accel import embree_accel
from ..visibility.cast import cast_rays_kernel
from ..visibility.secondary import occluded_ray
from .explain_coef import (_bumped, _coefficients, _convex_weights, _face_footprint, _footprint, _modulated, _short,
                           _spot_factor, _terminator)
from .explain_records import Bounce, Explanation, LightTerm, PointShade
from ..study.reference import facing as _facing, interpolated_normal as _interpolated_normal, normal_mapped
from ..study.reference import view_vectors as _view

__all__ = ["explain", "Explanation", "PointShade", "LightTerm", "Bounce"]

_METHOD_NAMES = ("flat", "gouraud", "phong")
_SHADOW_TFAR = 1.0 - 1e-5  # as the kernels' point-light shadow rays: stop just short of the light
_MIN_WEIGHT = 2.0 ** -24  # as trace_mirrors: a ray that can no longer change a float32 pixel stops


# -- the kernels' geometry, for one point -------------------------------------------------------------------

@dataclass(frozen=True)
class _Context:
    """What every evaluation of a frame reads."""

    geo: object
    scene: object
    cam: np.ndarray
    eye: np.ndarray
    fwd: np.ndarray
    ortho: bool
    dmin: float
    unit: float
    shadow_handle: int
    spec_on: bool


def _context(frame) -> _Context:
    """The frame's own kernel inputs (:attr:`Frame.inputs`: camera row, shadow BVH, offsets),
    packed here only for a frame that does not keep them."""
    scene, camera = frame.scene, frame.camera
    geo = scene.geometry
    k = frame.inputs if getattr(frame, "inputs", None) is not None else prepare(scene, camera)
    cam = k.cam
    dmin, handle, unit = k.lighting.dmin, k.lighting.handle, k.lighting.unit
    return _Context(geo=geo, scene=scene, cam=cam, eye=cam[CAM_EYE:CAM_EYE + 3], fwd=cam[CAM_FORWARD:CAM_FORWARD + 3],
                    ortho=cam[CAM_ORTHO] != 0.0, dmin=float(dmin), unit=float(unit), shadow_handle=int(handle),
                    spec_on=bool(k.spec_on))


def _pixel_hit(frame, x, y):
    """``(prim, geom, u, v)`` of pixel ``(x, y)``: :meth:`Frame.hit` (a banded frame casts that
    pixel's rays alone, not the frame), or the hit buffer of a frame made by hand."""
    hit = frame.hit(x, y) if callable(getattr(frame, "hit", None)) else \
        type(frame.hits)(*(a[y:y + 1, x:x + 1] for a in frame.hits))
    return int(hit.prim[0, 0]), int(hit.geom[0, 0]), float(hit.u[0, 0]), float(hit.v[0, 0])


def _unit_view(ctx, p):
    return _view(ctx.eye, ctx.fwd, ctx.ortho, p[None])[0]


def _oriented(ctx, f, v):
    """The face's geometric normal turned to ``v``, and the sign that turned it."""
    g, sgn = _facing(ctx.geo.face_normals[f][None], v[None])
    return g[0], float(sgn[0])


def _nudge(p, n, unit):
    """The kernels' shadow/mirror ray origin offset, one coordinate (shading.shadows)."""
    if abs(p) < unit * (1.0 / 32.0):
        return p + n * (unit * (1.0 / 65536.0))
    _, e = math.frexp(p)
    return p + n * math.ldexp(256.0, e - 24)


def _occluded(ctx, o, g, s, target, is_point) -> bool:
    """The kernels' shadow ray, traced with rtcOccluded1 from the same float32 ray."""
    side = 1.0 if float(g @ s) >= 0.0 else -1.0
    origin = np.array([_nudge(o[k], side * g[k], ctx.unit) for k in range(3)])
    direction, tfar = (target - origin, _SHADOW_TFAR) if is_point else (s, np.inf)
    return occluded_ray(ctx.shadow_handle, origin, direction, tfar)


def _light_terms(ctx, i, p, n, v, row, o, g, kd, ks) -> tuple:
    """Light ``i``'s terms at ``p``: one, or one per sample of an area light (as the kernels
    evaluate it: each sample a point light with ``1/N`` of the intensity)."""
    light = ctx.scene.lights[i]
    if not isinstance(light, AreaLight):
        return (_light_term(ctx, i, p, n, v, row, o, g, kd, ks),)
    n_s = light.samples
    return tuple(_light_term(ctx, i, p, n, v, row, o, g, kd, ks, (q, j, n_s))
                 for j, q in enumerate(light.sample_points()))


def _light_term(ctx, i, p, n, v, row, o, g, kd, ks, sample=None) -> LightTerm:
    """Light ``i`` at point ``p`` as :func:`raycast_shade.shading.illumination._illuminate_py` sees it,
    with the point's own ``kd, ks`` (3,); ``sample``: ``(position, j, N)`` of an area light's sample."""
    light = ctx.scene.lights[i]
    radiance = np.asarray(light.radiance, np.float64)
    directional = isinstance(light, DirectionalLight)
    law = "none" if directional else light.attenuation
    k = 1.0 if directional else float(light.k)
    blinn = row[MAT_BLINN] != 0.0
    zero = np.zeros(3)
    base = dict(index=i, directional=directional, law=law, k=k, radiance=radiance,
                specular_model="blinn" if blinn else "phong")
    world, share = light.position if not directional else None, 1.0
    if sample is not None:
        world, share = sample[0], 1.0 / sample[2]
        base.update(sample=sample[1], samples=sample[2])
    if directional:
        target, d, att, s = None, None, 1.0, -np.asarray(light.direction, np.float64)
    else:
        target = world - ctx.geo.origin
        dv = target - p
        d = float(np.sqrt(dv @ dv))
        if d == 0.0:  # the light on the point: no direction, no light
            return LightTerm(position=world, d=d, att=1.0, s=None, ndots=None, shadow="not traced",
                             rh=None, cos=None, spec=0.0, diffuse=zero, specular=zero, **base)
        s = dv / d
        att = {"none": 1.0, "inverse_square": 1.0 / max(d, ctx.dmin) ** 2, "heuristic": 1.0 / (d + k)}[law] * share
    position = world
    spot = None
    if isinstance(light, SpotLight):
        spot = _spot_factor(light, s)
        base["spot"] = spot
        if spot == 0.0:  # outside the cone: no light, no shadow ray (the kernels skip the light)
            return LightTerm(position=position, d=d, att=0.0, s=s, ndots=float(n @ s), shadow="not traced", rh=None,
                             cos=None, spec=0.0, diffuse=zero, specular=zero, **base)
        att *= spot
    ndots = float(n @ s)
    if ndots <= 0.0:
        return LightTerm(position=position, d=d, att=att, s=s, ndots=ndots, shadow="not traced", rh=None, cos=None,
                         spec=0.0, diffuse=zero, specular=zero, **base)
    shadow = "no shadows"
    if light.shadows and ctx.shadow_handle:
        shadow = "blocked" if _occluded(ctx, o, g, s, target, not directional) else "lit"
    cn = min(ndots, 1.0)
    rh, cos, spec = None, None, 0.0
    if ctx.spec_on and np.any(row[MAT_KS:MAT_KS + 3] > 0.0):  # the row's Ks decides, as in the kernels
        if blinn:
            hv = s + v
            hl = float(np.sqrt(hv @ hv))
            rh = hv / hl if hl > 0.0 else hv
            cos = float(n @ hv) / hl if hl > 0.0 else 0.0
        else:
            rh = 2.0 * cn * n - s
            cos = float(rh @ v)
        spec = min(cos, 1.0) ** row[MAT_SHININESS] if cos > 0.0 else 0.0
    if shadow == "blocked":
        diffuse, specular = zero, zero
    else:
        diffuse, specular = att * radiance * kd * cn, att * radiance * ks * spec
    return LightTerm(position=position, d=d, att=att, s=s, ndots=ndots, shadow=shadow, rh=rh, cos=cos, spec=spec,
                     diffuse=diffuse, specular=specular, **base)


def _evaluate(ctx, where, p, n, v, model, o, g, note="", coef=None) -> PointShade:
    """The reflectance equation at ``p`` (re-centred) with shadow rays from ``o`` offset along ``g``;
    ``coef``: the point's ``(ka, kd, ks, ke, note)`` (:func:`_coefficients`), else the material row's."""
    row = ctx.geo.materials[model]
    if coef is None:
        coef = (row[MAT_KA:MAT_KA + 3], row[MAT_KD:MAT_KD + 3], row[MAT_KS:MAT_KS + 3], row[MAT_KE:MAT_KE + 3], "")
    ka, kd, ks, ke, coef_note = coef
    ia = np.asarray(ctx.scene.ambient, np.float64)
    lights = tuple(t for i in range(len(ctx.scene.lights)) for t in _light_terms(ctx, i, p, n, v, row, o, g, kd, ks))
    return PointShade(where=where, p=p + ctx.geo.origin, n=n, v=v, model=int(model), ka=ka, kd=kd, ks=ks,
                      shininess=float(row[MAT_SHININESS]), ia=ia, ambient=ia * ka, lights=lights, normal_note=note,
                      coef_note=coef_note, ke=np.asarray(ke, np.float64))


def _surface(ctx, f, model, b1, b2, v=None):
    """Point, view, oriented geometric normal and sign, shading normal (interpolated,
    renormalised, bumped) and a note on it: the Phong kernels' ``_surface``."""
    geo = ctx.geo
    tri = geo.faces[f]
    bary = np.array([1.0 - b1 - b2, b1, b2])
    p = bary @ geo.vertices[tri]
    v = _unit_view(ctx, p) if v is None else v
    g, sgn = _oriented(ctx, f, v)
    n = _interpolated_normal(geo.normals, tri[None], bary[None], g[None], np.array([sgn]))[0]
    a = bary @ geo.normals[tri]
    note = f"a = sum mu_k n_k = {_short(a)}, |a| = {np.linalg.norm(a):.4g}, n = a / |a|"
    bumped = _bumped(geo, n, f, model, tri, bary, sgn * g)
    if bumped is not n:
        note += f"; bumped (Blinn) from {_short(n)}"
    mapped = normal_mapped(ctx.scene, bumped[None], g[None], np.array([sgn]), tri[None], bary[None], np.array([model]))[0]
    if geo.nmap_index[model] >= 0:
        note += f"; normal map n' = normalize(T x s + B y s + N z) = {_short(mapped)} from {_short(bumped)}"
    return p, v, g, sgn, mapped, tri, bary, note


# -- the three methods ---------------------------------------------------------------------------------------

def _flat(ctx, f, model):
    third = 1.0 / 3.0
    tri = ctx.geo.faces[f]
    bary = np.array([1.0 - third - third, third, third])
    p = bary @ ctx.geo.vertices[tri]
    v = _unit_view(ctx, p)
    g, _ = _oriented(ctx, f, v)
    coef = _coefficients(ctx, f, model, bary, _face_footprint(ctx.geo, f))
    return (_evaluate(ctx, "face centre", p, g, v, model, p, g, "the face's normal, turned to the viewer", coef),), \
        np.ones(1)


def _gouraud(ctx, f, model, b1, b2, x, y):
    geo = ctx.geo
    tri = geo.faces[f]
    p = np.array([1.0 - b1 - b2, b1, b2]) @ geo.vertices[tri]
    g, sgn = _oriented(ctx, f, _unit_view(ctx, p))
    pixel = None
    if _modulated(ctx, model):  # the vertices' light times the pixel's own coefficients
        ka, kd, ks, ke, note = _coefficients(ctx, f, model, np.array([1.0 - b1 - b2, b1, b2]),
                                             _footprint(ctx, f, p, x, y))
        pixel = (ka, kd, ks, ke, "modulate: the pixel's coefficients" + (f" ({note})" if note else ""))
    sg = 1.0 if sgn > 0.0 else -1.0  # the side the pixel sees: front (vertex normal) or back (negated)
    shades = []
    for i in tri:
        q = geo.vertices[i]
        n = sg * geo.normals[i]
        c = float(n @ g)
        if not np.any(n != 0.0):
            n, gs, note = g, g, "the vertex has no normal: the face's"
        elif c < 0.0:
            n, gs, note = n - 2.0 * c * g, g, "the vertex normal, reflected into the face's hemisphere"
        else:
            gs, note = n, "the vertex's averaged normal" + (" (negated: back side)" if sg < 0 else "")
        coef = pixel if pixel is not None else _coefficients(ctx, f, model, None, None, vertex=int(i))
        shades.append(_evaluate(ctx, f"vertex {int(i)}", q, n, _unit_view(ctx, q), model, q, gs, note, coef))
    return tuple(shades), _convex_weights(b1, b2)


def _phong(ctx, f, model, b1, b2, where="pixel", v=None, pixel=None):
    """Phong at a hit; ``pixel`` (x, y) filters maps by its footprint, ``None`` (a bounce) takes level 0."""
    p, v, g, sgn, n, tri, bary, note = _surface(ctx, f, model, b1, b2, v)
    o = _terminator(ctx.geo, tri, bary, p, sgn) if ctx.shadow_handle else p
    duv = _footprint(ctx, f, p, *pixel) if pixel is not None else None
    return _evaluate(ctx, where, p, n, v, model, o, g, note, _coefficients(ctx, f, model, bary, duv))


def _mirror_ray(ctx, p, v, g, n):
    """Reflect ``-v`` about ``n``, kept above the surface, from an origin pushed off along ``g``."""
    dn = -float(v @ n)
    r = -v - 2.0 * dn * n
    c = float(r @ g)
    if c < 0.0:
        r = r - 2.0 * c * g
    return np.array([_nudge(p[k], g[k], ctx.unit) for k in range(3)]), r


def _bounces(ctx, f, model, b1, b2, max_depth):
    """The mirror path of one pixel (:func:`raycast_shade.shading.mirrors.trace_mirrors`, one ray)."""
    geo = ctx.geo
    p, v, g, _, n, _, _, _ = _surface(ctx, f, model, b1, b2)
    origin, direction = _mirror_ray(ctx, p, v, g, n)
    weight = float(geo.materials[model, MAT_REFLECTIVITY])
    handle = embree_accel(geo).handle
    out = []
    for depth in range(1, max_depth + 1):
        prim, gm = np.empty(1, np.int32), np.empty(1, np.int32)
        u, w, t = np.empty(1, np.float32), np.empty(1, np.float32), np.empty(1, np.float32)
        cast_rays_kernel(handle, origin[None], direction[None], np.zeros(1), np.full(1, np.inf), prim, gm, u, w, t)
        if prim[0] < 0:
            bg = np.asarray(ctx.scene.background, np.float64)
            out.append(Bounce(depth, origin + geo.origin, direction, weight, -1, -1, None, 1.0, bg))
            break
        m = int(gm[0])
        f2 = int(geo.face_offsets[m] + prim[0])
        shade = _phong(ctx, f2, m, float(u[0]), float(w[0]), where=f"bounce {depth}", v=-direction)
        rho = float(geo.materials[m, MAT_REFLECTIVITY])
        more = rho > 0.0 and depth < max_depth
        keep = 1.0 - rho if more else 1.0
        out.append(Bounce(depth, origin + geo.origin, direction, weight, m, int(prim[0]), shade, keep,
                          keep * shade.total))
        if not more:
            break
        p2, v2, g2, _, n2, _, _, _ = _surface(ctx, f2, m, float(u[0]), float(w[0]), -direction)
        origin, direction = _mirror_ray(ctx, p2, v2, g2, n2)
        weight *= rho
        if weight < _MIN_WEIGHT:
            break
    return tuple(out)


def explain(frame, x, y) -> Explanation:
    """The reflectance equation at pixel ``(x, y)`` of a rendered frame, with its numbers.

    Parameters
    ----------
    frame : Frame
        From :func:`raycast_shade.render` (its scene, camera, hit buffer or its recipe,
        shading and kernel inputs). A banded frame's hit buffer is not cast: only the
        pixel's rays are.
    x, y : int
        Column and row, ``0 <= x < width``, ``0 <= y < height``.

    Returns
    -------
    Explanation
        ``.total`` equals ``frame.image[y, x]`` to float32 rounding;
        ``print()`` it for the formula with the numbers.

    Raises
    ------
    TypeError, ValueError
        For a pixel outside the image or a frame without its scene; ValueError for a pixel of a
        ``specular="ggx"`` material (its terms are glTF's, not the lecture's).
    """
    if getattr(frame, "scene", None) is None or getattr(frame, "image", None) is None:  # not .hits: a recipe runs
        raise TypeError(f"frame: expected a Frame from raycast_shade.render, got {type(frame).__name__}")
    if getattr(frame.camera, "distorted", False):  # its rays are the lens's, not the pinhole's it re-casts
        raise ValueError("explain: the frame's camera has lens distortion; explain() follows pinhole rays: "
                         "render the frame with distortion=None to explain a pixel")
    h, w = frame.image.shape[:2]
    x = as_int(x, "x", minimum=0, maximum=w - 1)
    y = as_int(y, "y", minimum=0, maximum=h - 1)
    ctx = _context(frame)
    geo = ctx.geo
    image = np.asarray(frame.image[y, x], np.float32).copy()
    prim, model, b1, b2 = _pixel_hit(frame, x, y)
    zero = np.zeros(3)
    if prim < 0:
        bg = np.asarray(frame.scene.background, np.float64)
        return Explanation(x, y, None, -1, "", -1, (), zero, (), np.zeros(0), zero, zero, zero, zero, zero, 0.0, (),
                           zero,
                           bg, image)
    if frame.scene.models[model].material.specular == "ggx":  # its terms are not the lecture's (kd n.s, ks c^t)
        raise ValueError(f"explain: pixel ({x}, {y}) shows material {frame.scene.models[model].material.name!r}, "
                         "specular='ggx' (glTF's BRDF): explain() writes out the lecture's Phong/Blinn terms only")
    method = _METHOD_NAMES[int(resolve_methods(frame.scene, frame.shading)[model])]
    f = int(geo.face_offsets[model] + prim)
    if method == "flat":
        shades, weights = _flat(ctx, f, model)
    elif method == "gouraud":
        shades, weights = _gouraud(ctx, f, model, b1, b2, x, y)
    else:
        shades, weights = (_phong(ctx, f, model, b1, b2, pixel=(x, y)),), np.ones(1)
    terms = [sum((wk * getattr(s, name) for wk, s in zip(weights, shades)), np.zeros(3))
             for name in ("ambient", "diffuse", "specular", "emissive")]
    local = sum((wk * s.total for wk, s in zip(weights, shades)), np.zeros(3))
    rho = float(geo.materials[model, MAT_REFLECTIVITY])
    depth = frame.max_depth if frame.max_depth is not None else 0
    bounces = _bounces(ctx, f, model, b1, b2, depth) if rho > 0.0 and depth > 0 else ()
    reflected = sum((b.weight * b.colour for b in bounces), np.zeros(3))
    total = (1.0 - rho) * local + reflected if bounces else local
    name = frame.scene.models[model].mesh.name
    return Explanation(x, y, method, model, name, prim, tuple(int(i) for i in geo.faces[f]),
                       np.array([1.0 - b1 - b2, b1, b2]), shades, weights, *terms, local, rho if bounces else 0.0,
                       bounces, reflected, total, image)
