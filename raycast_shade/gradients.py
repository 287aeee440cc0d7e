"""Gradients of a rendered image with respect to the lecture's parameters: :func:`grad`.

``rs.grad(scene, dL_dimage, wrt=...)`` is the vector-Jacobian product of the **linear** image
``frame.image`` (what :func:`raycast_shade.render` returns, before any tone map): given
``dL/dI`` (H, W, 3) it returns ``dL/dparameter`` for each name asked for, as NumPy arrays:

=====================  ===========  ==========================================================
name                   shape        the parameter
=====================  ===========  ==========================================================
``"ka"``, ``"kd"``,    (G, 3)       each model's material coefficients, RGB
``"ks"``
``"shininess"``        (G,)         each model's exponent ``t``
``"metallic"``,        (G,)         each ``specular="ggx"`` model's ``metallic`` and ``roughness``
``"roughness"``                     (0 for other models; see below for their clamps)
``"reflectivity"``     (G,)         each model's ``reflectivity`` (mirrors: one bounce, below)
``"ambient"``          (3,)         the scene's ambient intensity ``Ia``, RGB
``"light_position"``   (L, 3)       each point or spot light's position (0 for other kinds)
``"light_direction"``  (L, 3)       each directional light's ``direction`` (0 for other kinds),
                                    tangent to the unit sphere: the direction is normalised
``"light_radiance"``   (L, 3)       each light's ``intensity * color``
``"light_intensity"``  (L,)         each light's ``intensity`` (its colour held)
``"light_k"``          (L,)         the heuristic law's ``k`` (0 for the other laws)
``"light_spot"``       (L, 2)       each spot light's ``(inner_angle, outer_angle)``, per degree
                                    (0 for other kinds; see below for the cone's edges)
``"light_u"``,         (L, 3)       each area light's edges (rectangle) or radii (disc) ``u``,
``"light_v"``                       ``v``, per component (0 for other kinds)
``"vertex_colors"``    (V, 3)       the packed mesh vertex colours ``scene.geometry.vertex_colors``
                                    (kd's, and ka's factor with ``ka_colors``; 0 rows without)
``"face_colors"``      (F, 3)       the packed face colours ``scene.geometry.face_colors``
``"kd_map"``,          tuple        per model, its map's (h, w, 3) texels (rows as its
``"ks_map"``,                       ``Texture.texels``: row 0 is ``v = 0``), or None;
``"ka_map"``,                       ``ao_map``: the red channel's (the one the occlusion
``"ke_map"``,                       reads), green and blue 0
``"ao_map"``
``"bump_map"``         tuple        per model, its height map's (rows, cols) ``heights``, or None
``"normal_map"``       tuple        per model, its normal map's (h, w, 3) texels (level 0), or None
``"normals"``          (V, 3)       the packed vertex normals ``scene.geometry.normals`` (rows
                                    model by model, ``scene.geometry.vertex_offsets``)
``"vertices"``         (V, 3)       the packed vertex positions (rows as for ``normals``)
``"camera_eye"``       (3,)         the camera's eye
``"camera_rotation"``  (3,)         a small rotation ``w`` of the camera about its eye, applied
                                    on the left (every camera axis ``b`` becomes ``b + w x b``;
                                    :func:`rotate_camera` applies a finite one)
=====================  ===========  ==========================================================

``light_spot``: Warn's factor is C1 in the cone angles (its smooth step's slope is 0 at both
edges); a hard-edged spot (``inner_angle == outer_angle``) gets 0, the derivative almost everywhere.

GGX (:mod:`raycast_shade.shading.grad_ggx`): ``kd`` is the base colour; ``metallic`` and
``roughness`` pass their clamps only inside them (one-sided into [0, 1] at the bounds; 0 below the
roughness floor). Area lights: each sample is a point light at a fixed offset ``a u/2 + b v/2``
(disc: ``a u + b v``) from ``light_position``, its shadow ray held; ``light_u`` and ``light_v``
are the unconstrained per-component gradients (an ``AreaLight`` keeps ``u`` and ``v`` perpendicular:
project a step). Mirrors (:mod:`raycast_shade.shading.grad_mirror`): a reflective pixel is
``(1 - rho) local + rho R``; ``R``, the colour one mirror ray meets, is differentiated with respect to
the materials and lights it shows and, through both hits (each on its held triangle) and the
reflection about the mirror's interpolated normal, to the vertices, the camera and the vertex
normals; a mirror ray meeting another mirror is refused unless the frame was rendered with
``max_depth=1``.

The geometry (``vertices``, ``camera_*``) is differentiated through the interior of each
triangle: the pixel's triangle is held, its hit point and barycentrics move with the vertices
and the ray (:mod:`raycast_shade.shading.grad_geometry`); ``edges=True`` adds the silhouettes'
term for the box-filtered (anti-aliased) image by edge sampling
(:mod:`raycast_shade.shading.grad_edges`).

The hit buffer's triangles are held (the frame's own, or one cast for the call): the gradients are
those of the shading and of each hit moving on its triangle, exact wherever the image is
differentiable in the parameters; where a pixel's triangle changes, ``edges=True`` adds the
box-filtered image's edge term. Shadows count with the frame's visibility (a blocked
light stays blocked) in the interior; ``edges=True`` adds the hard shadows' outlines (point, spot
and directional lights) for the geometry, ``light_position`` and ``light_direction``
(:mod:`raycast_shade.shading.grad_shadow_edges`). Flat shading lights a face with its true normal: the
flat gradient of a vertex normal is exactly 0. Mesh colours and the colour maps' texels (:data:`MAPS`,
not among the defaults) are :mod:`raycast_shade.shading.grad_maps`'; the height and normal maps' texels
(Phong's bent normal; flat and Gouraud ignore both maps) and the vertex normals through them
:mod:`raycast_shade.shading.grad_bump`'s. On a scene with colours or maps the other families use each
point's own coefficients (:mod:`raycast_shade.shading.grad_textured`), and ``ka``, ``kd``, ``ks`` are the
material's scalar factors: the point's kd is ``kd * kd_map(uv)`` (a mesh colour replaces ``kd``, whose
gradient is then 0), ka ``ka * [colour] * ka_map(uv) * occlusion``, ks ``ks * ks_map(uv)``. GGX
materials, area lights and one mirror bounce are :mod:`raycast_shade.shading.grad_ggx`',
:mod:`raycast_shade.shading.grad_terms`' and :mod:`raycast_shade.shading.grad_mirror`'s. Not
differentiated yet (refused with a ValueError naming what): geometry through lens distortion; the
geometry on a scene with bump or normal maps (on a scene with colours or colour maps it is given: the
coefficients move with each hit's barycentrics, :mod:`raycast_shade.shading.grad_geotex`, a mip-mapped
map's level held); GGX materials, mirrors and area
lights on a scene with colours or maps, and with the colour or texel families; more than one mirror
bounce. The kernels are
:mod:`raycast_shade.shading.grad_terms` and
:mod:`raycast_shade.shading.grad_frame`; :func:`raycast_shade.fit` fits parameters with them.
"""

from __future__ import annotations

import warnings

import numpy as np

from .common.samples import check_samples, sample_offsets
from .common.layout import (CAM_EYE, ATT_HEURISTIC, LIGHT_ATT, LIGHT_COS_INNER, LIGHT_COS_OUTER, LIGHT_DIRECTIONAL,
                            LIGHT_KIND, LIGHT_SPOT, LIGHT_VEC)
from .common.layout import AREA_RECTANGLE, LIGHT_AREA, LIGHT_SHAPE
from .common.stack import user_stacklevel
from .common.validate import as_array, as_bool, as_int, as_names, as_scalar, as_vec3
from .output.frame import Frame
from .render import render
from .scene.camera import Camera
from .scene.scene import Scene
from .shading.grad_bump import BUMPS, bump_gradients, one_bent_pass
from .shading.grad_edges import edge_vjp
from .shading.grad_shadow_edges import shadow_edge_vjp
from .visibility.cast import cast_camera
from .visibility.rays import subpixel_camera
from .shading.grad_geometry import rotate_vectors
from .shading.grad_frame import frame_vjp, unsupported
from .shading.grad_maps import MAPS, maps_gradients
from .shading.grad_textured import textured_vjp
from .shading.grad_terms import GL_COS_INNER, GL_COS_OUTER, GL_K, GL_RAD, GL_SIZE, GL_VEC, GM_KA, GM_KD, GM_KS, GM_SIZE, GM_T, layout
from .shading.grad_terms import GL_EDGE_U, GL_EDGE_V, GM_METALLIC, GM_REFLECTIVITY, GM_ROUGHNESS
from .shading.grad_frame import PARTS
from .shading.grad_mirror import mirror_vjp
from .shading.shade import shade
from .visibility.accel import embree_accel
from .shading.inputs import prepare
from .shading.shade import resolve_methods

__all__ = ["grad", "rotate_camera", "WRT", "DEFAULT_WRT", "GEOMETRY", "MAPS", "BUMPS", "MAX_DENSITY"]

WRT = ("ka", "kd", "ks", "shininess", "metallic", "roughness", "reflectivity", "ambient", "light_position",
       "light_direction", "light_radiance", "light_intensity", "light_k", "light_spot", "light_u", "light_v",
       "vertex_colors", "face_colors", "kd_map", "ks_map", "ka_map", "ke_map", "ao_map", "bump_map", "normal_map",
       "normals", "vertices", "camera_eye", "camera_rotation")
"""Every name :func:`grad` differentiates with respect to."""
GEOMETRY = ("vertices", "camera_eye", "camera_rotation")
"""The names that move what each pixel sees (the interior and, with ``edges=True``, the edges)."""
SHADOW_MOVERS = GEOMETRY + ("light_position", "light_direction")
"""The names that move hard shadows' outlines (their edge term with ``edges=True``)."""
DEFAULT_WRT = tuple(n for n in WRT if n != "normals" and n not in GEOMETRY and n not in MAPS and n not in BUMPS)
"""What ``wrt=None`` asks for: every parameter but the vertex normals, the geometry, the mesh
colours and texels (:data:`~raycast_shade.shading.grad_maps.MAPS`) and the height and normal maps'
texels (:data:`~raycast_shade.shading.grad_bump.BUMPS`)."""

MAX_DENSITY = 1024.0
"""The most edge samples per pixel of edge length ``grad(edges=True)`` takes (a bound on the work)."""

_MATERIAL_SLOTS = {"ka": GM_KA, "kd": GM_KD, "ks": GM_KS}


def _wrt(wrt) -> tuple:
    """The names asked for, checked against :data:`WRT`."""
    if wrt is None:
        return DEFAULT_WRT
    if isinstance(wrt, str):
        wrt = (wrt,)
    return as_names(wrt, "wrt", WRT, item="parameter")


def check_scene(scene, inputs, names=(), mirrors_ok: bool = False) -> None:
    """Raise a ValueError naming every part of ``scene`` the gradient kernels do not differentiate
    for the parameters ``names`` (``mirrors_ok``: the caller adds the mirror bounce, :func:`_vjp`)."""
    problems = unsupported(inputs, [m.material.name for m in scene.models], [light.name for light in scene.lights],
                           maps_asked=any(n in MAPS or n in BUMPS for n in names),
                           geometry_asked=any(n in GEOMETRY for n in names), mirrors_ok=mirrors_ok)
    if problems:
        raise ValueError("scene: no gradients for this scene yet: " + "; ".join(problems))


def check_gradient(dL_dimage, camera) -> np.ndarray:
    """``dL_dimage`` as a float64 (H, W, 3) array of the camera's size, finite, or a clear error."""
    shape = (camera.height, camera.width, 3)
    if not isinstance(dL_dimage, np.ndarray):
        raise TypeError(f"dL_dimage: expected a NumPy array of shape {shape}, got {type(dL_dimage).__name__}")
    if dL_dimage.dtype.kind != "f":
        raise TypeError(f"dL_dimage: expected a float array, got dtype {dL_dimage.dtype}")
    return as_array(dL_dimage, "dL_dimage", dtype=np.float64, shape=shape)


def named(params, extra, scene, inputs, names) -> dict:
    """The flat gradient vector of :func:`~raycast_shade.shading.grad_frame.frame_vjp` as
    :func:`grad`'s named arrays (``names`` a subset of :data:`WRT`); ``extra`` maps ``normals``,
    ``vertices`` and ``camera`` to their arrays (``camera``: eye, then rotation)."""
    n_models, lights = len(scene.models), inputs.lighting.lights
    amb, lb, _ = layout(n_models, lights.shape[0])
    per_model = params[:amb].reshape(n_models, GM_SIZE)
    per_light = params[lb:].reshape(lights.shape[0], GL_SIZE)
    directional = lights[:, LIGHT_KIND] == LIGHT_DIRECTIONAL
    out = {}
    for name in names:
        if name in _MATERIAL_SLOTS:
            k = _MATERIAL_SLOTS[name]
            out[name] = per_model[:, k:k + 3].copy()
        elif name == "shininess":
            out[name] = per_model[:, GM_T].copy()
        elif name in ("metallic", "roughness", "reflectivity"):
            out[name] = per_model[:, {"metallic": GM_METALLIC, "roughness": GM_ROUGHNESS,
                                      "reflectivity": GM_REFLECTIVITY}[name]].copy()
        elif name == "ambient":
            out[name] = params[amb:amb + 3].copy()
        elif name == "light_position":
            out[name] = np.where(directional[:, None], 0.0, per_light[:, GL_VEC:GL_VEC + 3])
        elif name == "light_direction":
            out[name] = _direction_gradient(per_light[:, GL_VEC:GL_VEC + 3], lights, directional)
        elif name == "light_radiance":
            out[name] = per_light[:, GL_RAD:GL_RAD + 3].copy()
        elif name == "light_intensity":
            colors = np.array([np.broadcast_to(light.color, 3) for light in scene.lights]).reshape(-1, 3)
            out[name] = np.einsum("ij,ij->i", per_light[:, GL_RAD:GL_RAD + 3], colors)
        elif name == "light_k":
            out[name] = np.where(lights[:, LIGHT_ATT] == ATT_HEURISTIC, per_light[:, GL_K], 0.0)
        elif name == "light_spot":
            out[name] = _spot_gradient(per_light, lights)
        elif name in ("light_u", "light_v"):
            out[name] = _axis_gradient(per_light, lights, GL_EDGE_U if name == "light_u" else GL_EDGE_V)
        elif name in ("normals", "vertices"):
            out[name] = extra[name]
        elif name == "camera_eye":
            out[name] = extra["camera"][:3].copy()
        elif name == "camera_rotation":
            out[name] = extra["camera"][3:].copy()
    return out


def _spot_gradient(per_light, lights) -> np.ndarray:
    """``dL/d(inner_angle, outer_angle)`` per degree from the rows' cone cosines' gradients:
    ``d cos(a)/d a = -sin(a) pi/180``, the angle recovered from the row's cosine (0 for other kinds)."""
    spot = lights[:, LIGHT_KIND] == LIGHT_SPOT
    out = np.zeros((lights.shape[0], 2))
    for col, (slot, row) in enumerate(((GL_COS_INNER, LIGHT_COS_INNER), (GL_COS_OUTER, LIGHT_COS_OUTER))):
        sin = np.sqrt(np.maximum(0.0, 1.0 - np.clip(lights[:, row], -1.0, 1.0) ** 2))
        out[:, col] = np.where(spot, -per_light[:, slot] * sin * (np.pi / 180.0), 0.0)
    return out


def _axis_gradient(per_light, lights, slot) -> np.ndarray:
    """``dL/du`` (or ``dL/dv``) of the area lights from the packed half-axes' gradients: a rectangle
    packs ``u/2`` (its samples at ``centre + a u/2 + b v/2``), a disc ``u`` itself (0 for other kinds)."""
    area = lights[:, LIGHT_KIND] == LIGHT_AREA
    half = np.where(lights[:, LIGHT_SHAPE] == AREA_RECTANGLE, 0.5, 1.0)
    return np.where(area[:, None], per_light[:, slot:slot + 3] * half[:, None], 0.0)


def _direction_gradient(gvec, lights, directional) -> np.ndarray:
    """``dL/d direction`` of the directional lights: the row holds ``-direction`` (unit), and a
    direction is normalised on construction, so the gradient is the tangent part of ``-dL/d row``."""
    d = -lights[:, LIGHT_VEC:LIGHT_VEC + 3]
    g = -gvec
    g = g - np.einsum("ij,ij->i", g, d)[:, None] * d
    return np.where(directional[:, None], g, 0.0)


@one_bent_pass  # the texels' and the normals' gradients share the bent normal's pass
def grad(scene: Scene, dL_dimage, wrt=None, *, shading="phong", frame: Frame | None = None, edges: bool = False,
         edge_density: float = 4.0, seed: int = 0, samples: int = 1) -> dict:
    """``dL/dparameter`` for ``dL/dI`` given on the linear image of ``render(scene, shading)``.

    Parameters
    ----------
    scene : Scene
    dL_dimage : (H, W, 3) float ndarray
        The loss's gradient with respect to ``frame.image`` (the linear float image, not a
        tone-mapped one), of the camera's size; finite.
    wrt : str or sequence of str, optional
        Names of :data:`WRT`; every one but ``"normals"`` by default (:data:`DEFAULT_WRT`).
    shading : {"flat", "gouraud", "phong"} or sequence
        As for :func:`raycast_shade.render` (one per model allowed; not ``"auto"``).
    frame : Frame, optional
        ``render(scene, shading)``'s frame, whose hit buffer is reused (no cast); cast afresh
        by default (with ``samples > 1``, the frame is checked, and its samples cast again).
    edges : bool
        Add the silhouettes' (and other visibility edges') term by edge sampling to the geometry
        gradients, and the hard shadows' outlines' to the geometry's, ``light_position``'s and
        ``light_direction``'s: the gradient of the box-filtered (anti-aliased) image, whose
        interior part is taken at the pixel centres. Off by default: the gradient of the one-ray image over its
        hit buffer.
    edge_density : float
        Edge samples per pixel of projected edge length (``> 0``, at most :data:`MAX_DENSITY`).
    seed : int
        The edge samples' jitter (the same samples for the same seed).
    samples : int
        As for :func:`raycast_shade.render`: the gradient of the mean of ``samples`` rays per
        pixel (the same sub-pixel offsets), each sample's hit buffer cast and differentiated, its
        terms added in sample order. ``frame`` (optional) must have been rendered with them.

    Returns
    -------
    dict of str to ndarray
        One float64 array per name asked for (shapes in the module's table).

    Raises
    ------
    ValueError
        An unknown name in ``wrt`` (the valid ones listed), a ``dL_dimage`` of the wrong shape
        or not finite, a scene with parts not differentiated yet (named), or a ``frame`` of
        another scene, another shading or another number of samples.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    names = _wrt(wrt)
    edges = as_bool(edges, "edges")
    edge_density = as_scalar(edge_density, "edge_density", minimum=0.0, exclusive=True, maximum=MAX_DENSITY)
    seed = as_int(seed, "seed", minimum=0)
    samples = check_samples(samples)
    gimg = check_gradient(dL_dimage, scene.camera)
    modes = resolve_methods(scene, shading)
    if frame is not None:
        if not isinstance(frame, Frame):
            raise TypeError(f"frame: expected a Frame, got {type(frame).__name__}")
        if frame.scene is not scene:
            raise ValueError("frame: rendered from another scene (pass the scene it was rendered of)")
        if ("average" in frame.timings) != (samples > 1):
            raise ValueError("frame: rendered with samples > 1 (pass the same samples=)" if samples == 1 else
                             f"frame: rendered with one ray per pixel, not samples={samples}")
        if not np.array_equal(resolve_methods(scene, frame.shading), modes):
            raise ValueError(f"frame: shaded with {frame.shading!r}, not shading={shading!r}")
        if frame.image.shape != gimg.shape:
            raise ValueError(f"frame: its image is {frame.image.shape}, dL_dimage {gimg.shape}")
    inputs = frame.inputs if frame is not None and frame.inputs is not None else prepare(scene, scene.camera)
    check_scene(scene, inputs, names, mirrors_ok=True)
    depth = 3 if frame is None or frame.max_depth is None else frame.max_depth  # render()'s default bounces
    if frame is None and samples == 1:
        frame = render(scene, shading)
    geometry = any(n in GEOMETRY for n in names)
    shadow_moved = any(n in SHADOW_MOVERS for n in names)
    if edges and not shadow_moved:
        warnings.warn(f"edges=True: the edge term moves only the geometry and the lights ({', '.join(SHADOW_MOVERS)}), "
                      "and wrt asks for none of it; the gradients are those of edges=False", UserWarning,
                      stacklevel=user_stacklevel())
    if geometry and scene.camera.distorted:
        raise ValueError("scene.camera: no geometry gradients through lens distortion yet (a pinhole camera has)")
    maps = tuple(n for n in names if n in MAPS)
    if maps and not inputs.tex_on:  # no colours, no maps: nothing to differentiate (and no kernel to run)
        maps = _zero_maps(scene, maps)
    elif maps:  # the colours and texels (check_scene refuses the geometry on such a scene)
        if samples == 1:
            maps = maps_gradients(frame.hits, inputs, modes, gimg, scene.geometry, names)
        else:
            maps = _sampled_maps(scene, inputs, modes, gimg, samples, names)
    maps = maps if maps else {}
    bumps = tuple(n for n in names if n in BUMPS)
    if bumps:
        maps = {**maps, **_bump_gradients(scene, inputs, modes, gimg, samples, frame, bumps)}
    if len(maps) == len(names):
        return {n: maps[n] for n in names}
    if samples == 1:
        params, gnormals, gverts, gcam = _vjp(scene, scene.camera, frame.hits, inputs, modes, gimg, (shading, depth),
                                              "normals" in names, geometry)
        if geometry:
            _about_eye(gcam, inputs.cam, scene)
    else:
        params, gnormals, gverts, gcam = _sampled_vjp(scene, inputs, modes, gimg, samples, "normals" in names, geometry,
                                                      (shading, depth))
    glight = None
    if edges and shadow_moved:
        glight = _edge_terms(scene, inputs, modes, gimg, shading, (edge_density, seed), geometry, gverts, gcam)
    out = named(params, {"normals": gnormals, "vertices": gverts, "camera": gcam}, scene, inputs, names)
    if glight is not None:
        _add_light_edges(out, glight, inputs.lighting.lights)
    return {n: maps[n] if n in maps else out[n] for n in names}


def _bump_gradients(scene, inputs, modes, gimg, samples, frame, names) -> dict:
    """:func:`~raycast_shade.shading.grad_bump.bump_gradients` of the frame, or of the mean of
    ``samples`` sub-pixel images (one cast each, ``dL/dI / samples``, added in sample order)."""
    B = inputs.bumps
    if not (np.any(B.bump_index >= 0) or np.any(B.nmap_index >= 0)):
        return {n: (None,) * len(scene.models) for n in names}
    if samples == 1:
        return bump_gradients(frame.hits, inputs, modes, gimg, names)
    total = None
    for dx, dy in sample_offsets(samples):
        sub = subpixel_camera(scene.camera, dx, dy)
        out = bump_gradients(cast_camera(scene.geometry, sub), inputs, modes, gimg / samples, names)
        total = out if total is None else {
            n: tuple(None if t is None else t + v for t, v in zip(total[n], out[n])) for n in out}
    return total


def _zero_maps(scene, maps) -> dict:
    """The colour and texel gradients of a scene without colours or maps: zeros (None per model)."""
    g = scene.geometry
    out = {}
    for name in maps:
        if name == "vertex_colors":
            out[name] = np.zeros((g.vertices.shape[0], 3))
        elif name == "face_colors":
            out[name] = np.zeros((g.faces.shape[0], 3))
        else:
            out[name] = (None,) * len(scene.models)
    return out


def _frame_vjp(hits, inputs, modes, gimg, geo, want_normals, want_geometry):
    """:func:`~raycast_shade.shading.grad_frame.frame_vjp`, or on a frame with colours or maps
    :func:`~raycast_shade.shading.grad_textured.textured_vjp`."""
    if inputs.tex_on:
        return textured_vjp(hits, inputs, modes, gimg, geo, want_normals, want_geometry)
    return frame_vjp(hits, inputs, modes, gimg, geo, want_normals, want_geometry)


def _edge_terms(scene, inputs, modes, gimg, shading, sampling, geometry, gverts, gcam) -> np.ndarray:
    """The edge terms, a run-time branch (NumPy and the frame's kernels): the hard shadows'
    outlines and, for the geometry, the silhouettes, added into ``gverts`` and ``gcam``; returns
    the outlines' ``dL/d(light row vector)`` (L, 3). ``sampling``: ``(edge_density, seed)``."""
    sv, sc, glight, _ = shadow_edge_vjp(scene, scene.camera, inputs, gimg, shading, *sampling)
    if geometry:
        ev, ec, _ = edge_vjp(scene, scene.camera, inputs, modes, gimg, shading, *sampling)
        ec += sc
        _about_eye(ec, inputs.cam, scene)
        gverts += sv + ev
        gcam += ec
    return glight


def _add_light_edges(out, glight, lights) -> None:
    """Add the shadow outlines' ``dL/d(light row vector)`` (L, 3) into ``out``'s light names."""
    directional = lights[:, LIGHT_KIND] == LIGHT_DIRECTIONAL
    if "light_position" in out:
        out["light_position"] += np.where(directional[:, None], 0.0, glight)
    if "light_direction" in out:
        out["light_direction"] += _direction_gradient(glight, lights, directional)


def _about_eye(gcam, cam, scene) -> None:
    """Turn ``gcam``'s rotation part (taken about the camera row's eye) to the rotation about the
    camera's eye: an orthographic row's eye carries the principal point's shift ``e``, and a turn
    ``w`` about the true eye moves it by ``w x e``, so ``dL/dw += e x dL/deye``. Perspective: 0."""
    shift = cam[CAM_EYE:CAM_EYE + 3] - (np.asarray(scene.camera.eye, np.float64) - scene.geometry.origin)
    gcam[3:] += np.cross(shift, gcam[:3])


def _vjp(scene, camera, hits, inputs, modes, gimg, mirrors, want_normals, want_geometry):
    """:func:`frame_vjp`, plus the mirror bounce on a scene with mirrors (:func:`mirror_vjp`; ``mirrors``
    = ``(shading, max_depth)`` of the frame): the local shade's VJP takes ``(1 - rho) dL/dI``, the
    bounces' gradients are added. A mirror ray meeting another mirror is refused with more than one
    bounce (the last bounce shows its local shade: with one, it is the same evaluator)."""
    shading, depth = mirrors
    if depth == 0 or not scene.geometry.reflective:
        return _frame_vjp(hits, inputs, modes, gimg, scene.geometry, want_normals, want_geometry)
    amb, lb, size = layout(len(scene.models), inputs.lighting.lights.shape[0])
    local = shade(scene, camera, hits, shading)
    g_local, bounce, nested, _, extra = mirror_vjp(hits, inputs, gimg, local, (np.int64(amb), np.int64(lb)), size,
                                                int(embree_accel(scene.geometry).handle), float(scene.geometry.scale),
                                                PARTS, want=(want_geometry, want_normals))
    if depth > 1 and np.any(nested):
        raise ValueError(f"scene: a mirror ray meets another reflective surface at {int(np.count_nonzero(nested))} "
                         "pixels: one mirror bounce is differentiated, not more (render with max_depth=1)")
    params, gnormals, gverts, gcam = _frame_vjp(hits, inputs, modes, g_local, scene.geometry, want_normals,
                                                want_geometry)
    if want_geometry:  # the bounces' geometry: both hits and the reflection (grad_mirror.mirror_scatter)
        gverts += extra[0]
        gcam += extra[1]
    if want_normals:
        gnormals += extra[2]
    return params + bounce, gnormals, gverts, gcam


def _sampled_vjp(scene, centre, modes, gimg, samples, want_normals, want_geometry, mirrors):
    """:func:`frame_vjp` of the mean of ``samples`` sub-pixel images: one cast and one VJP per
    sample with ``dL/dI / samples``, added in sample order. An orthographic sub-pixel camera's
    eye carries the sample's shift: its rotation gradient is turned back to the true eye's.
    Without the geometry each sample is shaded with the frame's own inputs ``centre`` (the centre
    camera's row), as ``render`` shades every sample: the texture footprints are the pixel's."""
    total = None
    part = gimg / samples
    for dx, dy in sample_offsets(samples):
        sub = subpixel_camera(scene.camera, dx, dy)
        inputs = prepare(scene, sub) if want_geometry else centre
        out = list(_vjp(scene, sub, cast_camera(scene.geometry, sub), inputs, modes, part, mirrors, want_normals,
                        want_geometry))
        if want_geometry:
            _about_eye(out[3], inputs.cam, scene)
        total = out if total is None else [t if t is None else t + o for t, o in zip(total, out)]
    return tuple(total)


def _sampled_maps(scene, centre, modes, gimg, samples, names) -> dict:
    """:func:`maps_gradients` of the mean of ``samples`` sub-pixel images (as :func:`_sampled_vjp`):
    one cast per sample with ``dL/dI / samples``, added in sample order (per model for the maps),
    each shaded with the frame's inputs ``centre`` as ``render`` shades it."""
    total = None
    for dx, dy in sample_offsets(samples):
        sub = subpixel_camera(scene.camera, dx, dy)
        out = maps_gradients(cast_camera(scene.geometry, sub), centre, modes, gimg / samples,
                             scene.geometry, names)
        if total is None:
            total = out
            continue
        for name, value in out.items():
            total[name] = (tuple(None if t is None else t + v for t, v in zip(total[name], value))
                           if isinstance(value, tuple) else total[name] + value)
    return total


def rotate_camera(camera, rotation):
    """``camera`` turned about its eye by the rotation vector ``rotation`` (axis times angle in
    radians), applied on the left: the finite step of :func:`grad`'s ``camera_rotation``.

    Parameters
    ----------
    camera : Camera
    rotation : (3,) float
        World coordinates; ``|rotation|`` the angle in radians.

    Returns
    -------
    Camera
        The same eye and intrinsics; its target and up turned (so its right, up and forward
        axes are ``exp([rotation]x)`` times the old ones).
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    w = as_vec3(rotation, "rotation")
    eye = np.asarray(camera.eye, np.float64)
    turned = rotate_vectors(w, np.stack([np.asarray(camera.target, np.float64) - eye,
                                         np.asarray(camera.up, np.float64)]))
    return camera.replace(target=tuple(eye + turned[0]), up=tuple(turned[1]))
