"""Plain-NumPy twins of the shading kernels.

Slow but short, vectorised over the hit pixels and written straight from the
rules in :mod:`raycast_shade.shading` (no Numba, no packed kernel arrays: the
materials, lights and camera are read from the scene's own objects). The test
suite checks the kernels against these functions; they also serve as
executable documentation of the model::

    I = Ia ka + sum_i att_i(d) Ii (kd max(n.s, 0) + Ks max(c, 0)^t)

with ``c = r.v``, ``r = 2 (n.s) n - s`` (Phong) or ``c = n.h``,
``h = (s + v) / |s + v|`` (Blinn-Phong), ``n.s`` and ``c`` clamped to
``[0, 1]``, no specular term where ``n.s <= 0``, and ``att`` one of ``1``,
``1 / max(d, dmin)^2`` or ``1 / (d + k)`` with ``dmin = 1e-6 * scale``,
times Warn's cone factor for a spot light (:func:`spot_cone`).

Everything is computed in float64 in the scene's re-centred frame (world
minus ``scene.geometry.origin``), as the kernels do.

Colour textures and mesh colours are modelled (:func:`coefficients_reference`,
:func:`sample_reference`, :func:`footprint_reference`): per point, kd is the
mesh's colour (or the material's), each coefficient times its map's texel,
mip-filtered by the pixel's footprint; Gouraud shades models with maps or
face colours the "modulate" way (see :mod:`raycast_shade.shading.gouraud`).

Scope: local illumination only. Shadow rays and bump maps need Embree and
height lookups and have no twin here; :func:`shade_reference` refuses scenes
that use them rather than answer differently. Mirror reflections are added
by :func:`raycast_shade.render` after shading and do not concern it.
"""

from __future__ import annotations

import numpy as np

from ..scene.lights import AreaLight, DirectionalLight, SpotLight
from .ggx import ggx_terms_numpy
from .reference_maps import _bilinear_level, _dot, normal_mapped

__all__ = ["view_vectors", "facing", "interpolated_normal", "footprint_rho", "shade_reference", "shading_normals_reference", "hit_points", "illuminate_reference", "spot_cone",
           "coefficients_reference", "sample_reference", "footprint_reference"]

_MODES = ("flat", "gouraud", "phong")
_CANCEL = 1e-6  # |interpolated normal| below this falls back to the geometric normal


# -- small vector helpers ---------------------------------------------------------------------------
def _unit(a):
    """Rows of ``a`` divided by their length, and the lengths (zero rows stay zero)."""
    length = np.linalg.norm(a, axis=1)
    out = np.zeros_like(a)
    ok = length > 0
    out[ok] = a[ok] / length[ok, None]
    return out, length


# -- inputs ------------------------------------------------------------------------------------------
def _check_scope(scene, shadows=True):
    """Refuse what the reference does not model (shadows, bump maps)."""
    for i, light in enumerate(scene.lights):
        if shadows and getattr(light, "shadows", False):
            raise NotImplementedError(f"scene.lights[{i}]: the NumPy reference has no shadow rays")
    for i, model in enumerate(scene.models):
        if getattr(model.material, "bump", None) is not None:
            raise NotImplementedError(f"scene.models[{i}]: the NumPy reference has no bump mapping")


def _background(scene):
    """(3,) float64 colour where nothing is hit (zero for scenes without one)."""
    return np.asarray(getattr(scene, "background", 0.0), np.float64) * np.ones(3)


def _camera(camera, origin):
    """Re-centred eye (3,), unit forward (3,) and the orthographic flag."""
    fwd = camera.target - camera.eye
    fwd = fwd / np.linalg.norm(fwd)
    return camera.eye - origin, fwd, camera.orthographic


def _materials(scene):
    """Per-model material arrays: ka, kd, ks (G, 3), shininess (G,), blinn (G,) bool, ke (G, 3),
    then the GGX model's: metallic, roughness (G,), ggx (G,) bool."""
    mats = [m.material for m in scene.models]
    return (
        np.array([m.ka for m in mats], np.float64),
        np.array([m.kd for m in mats], np.float64),
        np.array([m.ks for m in mats], np.float64),
        np.array([m.shininess for m in mats], np.float64),
        np.array([m.specular == "blinn" for m in mats], bool),
        np.array([m.ke for m in mats], np.float64),
        np.array([m.metallic for m in mats], np.float64),
        np.array([m.roughness for m in mats], np.float64),
        np.array([m.specular == "ggx" for m in mats], bool),
    )


def spot_cone(light):
    """A spot light's cone as the optional sixth entry of a reference light tuple.

    Returns
    -------
    tuple or None
        ``(axis (3,), cos_inner, cos_outer, exponent)`` for a
        :class:`~raycast_shade.scene.lights.SpotLight`, ``None`` for any other light.
    """
    if not isinstance(light, SpotLight):
        return None
    return (np.asarray(light.direction, np.float64), light.cos_inner, light.cos_outer, light.exponent)


def _lights(scene, origin):
    """The scene's lights as plain tuples ``(directional, vec, radiance, attenuation, k, cone)``.

    ``vec`` is the unit vector towards a directional light, or a point light's
    re-centred position; ``cone`` is :func:`spot_cone`'s (``None`` but for spots). An area light
    is its samples, each a point light with ``1/N`` of its radiance (as the kernels evaluate it).
    """
    out = []
    for light in scene.lights:
        if isinstance(light, AreaLight):
            share = light.intensity * light.color / light.samples
            out.extend((False, q - origin, share, light.attenuation, light.k, None) for q in light.sample_points())
        elif isinstance(light, DirectionalLight):
            out.append((True, -np.asarray(light.direction, np.float64), light.intensity * light.color, "none", 1.0,
                        None))
        else:
            out.append((False, light.position - origin, light.intensity * light.color, light.attenuation, light.k,
                        spot_cone(light)))
    return out


def _warn_factor(cone, s):
    """Warn's factor (N,) for unit directions ``s`` (N, 3) from the points to the light:
    ``cos^n a * smoothstep(cos outer, cos inner, cos a)``, ``cos a = -s . axis``; 0 outside."""
    axis, ci, co, n = cone
    c = np.minimum(-(s @ axis), 1.0)
    t = np.clip((c - co) / (ci - co), 0.0, 1.0) if ci > co else np.ones_like(c)
    return np.where(c > co, np.maximum(c, 0.0) ** n * t * t * (3.0 - 2.0 * t), 0.0)


def _view(eye, fwd, ortho, p):
    """(N, 3) unit vectors from points ``p`` (N, 3) to the eye; ``-fwd`` for
    an orthographic camera or a point at the eye itself."""
    if ortho:
        return np.broadcast_to(-fwd, p.shape).copy()
    v, length = _unit(eye - p)
    v[length == 0] = -fwd
    return v


def _facing(fn, v):
    """Geometric normals (N, 3) turned to the viewer, and the sign (N,) that
    turned them; a zero (degenerate) normal is replaced by ``v``."""
    zero = ~np.any(fn != 0.0, axis=1)
    sgn = np.where(_dot(fn, v) < 0.0, -1.0, 1.0)
    sgn[zero] = 1.0
    g = fn * sgn[:, None]
    g[zero] = v[zero]
    return g, sgn


def _hits(scene, hits):
    """Gather per-hit-pixel data.

    Returns
    -------
    mask : (H, W) bool
    face : (N,) int64
        Global face index of each hit pixel (row-major order of ``mask``).
    tri : (N, 3) int64
        Its global vertex indices.
    bary : (N, 3) float64
        ``(1 - u - v, u, v)``.
    p : (N, 3) float64
        Re-centred hit points.
    """
    return gather_hits(scene.geometry, hits)


def gather_hits(geo, hits):
    """:func:`_hits` of a scene's packed geometry (``scene.geometry``); the same five arrays."""
    mask = hits.prim >= 0
    face = geo.face_offsets[hits.geom[mask]] + hits.prim[mask].astype(np.int64)
    tri = geo.faces[face]
    b1 = hits.u[mask].astype(np.float64)
    b2 = hits.v[mask].astype(np.float64)
    bary = np.stack([1.0 - b1 - b2, b1, b2], axis=1)
    p = np.einsum("nk,nkc->nc", bary, geo.vertices[tri])
    return mask, face, tri, bary, p


def _interpolated_normal(normals, tri, bary, g, sgn):
    """The Phong shading normal: ``a = sum b_k n_k``, renormalised, negated
    with the face when seen from the back, reflected across the tangent plane
    into the viewer's hemisphere if still facing away; ``g`` where ``|a|``
    cancels."""
    a = np.einsum("nk,nkc->nc", bary, normals[tri])
    n, length = _unit(a)
    n *= sgn[:, None]
    c = _dot(n, g)
    n = np.where((c < 0.0)[:, None], n - 2.0 * c[:, None] * g, n)
    cancelled = ~(length >= _CANCEL)
    n[cancelled] = g[cancelled]
    return n


# -- the reflectance equation ------------------------------------------------------------------------
def illuminate_reference(p, n, v, model, materials, lights, ambient, dmin, coef=None):
    """Evaluate the reflectance equation at many points.

    Parameters
    ----------
    p : (N, 3) float64
        Surface points (re-centred).
    n : (N, 3) float64
        Unit shading normals.
    v : (N, 3) float64
        Unit vectors towards the viewer.
    model : (N,) int
        Material (model) index of each point.
    materials : tuple
        ``(ka, kd, ks, shininess, blinn[, ke[, metallic, roughness, ggx]])`` with shapes ``(G, 3) x 3,
        (G,), (G,)[, (G, 3)[, (G,) x 3]]`` (no ``ke``: no emission; no ``ggx``: no GGX material, whose
        terms are :func:`~raycast_shade.study.ggx.ggx_terms_numpy`'s, metallic and roughness times
        the point's ks blue and green).
    lights : list of tuple
        ``(directional, vec, radiance (3,), attenuation, k)``, optionally
        followed by a spot light's cone (:func:`spot_cone`); see :func:`_lights`.
    ambient : (3,) float64
        Scene ambient intensity ``Ia``.
    dmin : float
        Lower clamp of ``d`` in the inverse-square law.
    coef : tuple of three or four (N, 3) float64, optional
        Per-point ``ka, kd, ks[, ke]`` in place of the materials' (textures and
        colours, :func:`coefficients_reference`).

    Returns
    -------
    (N, 3) float64
        Reflected RGB intensity.
    """
    ka, kd, ks, shin, blinn = materials[:5]
    has_spec = np.any(ks[model] > 0, axis=1)  # the material's: a map cannot switch the term on
    ka, kd, ks, shin, blinn = ka[model], kd[model], ks[model], shin[model], blinn[model]
    ke = materials[5][model] if len(materials) > 5 else np.zeros_like(ka)
    metal, rough, ggx = ((a[model] for a in materials[6:9]) if len(materials) > 8
                         else (None, None, np.zeros(len(p), bool)))
    if coef is not None:
        ka, kd, ks = coef[:3]
        ke = coef[3] if len(coef) > 3 else ke
    out = ambient[None, :] * ka
    npts = len(p)
    for light in lights:
        directional, vec, radiance, attenuation, k = light[:5]
        cone = light[5] if len(light) > 5 else None
        if directional:
            s = np.broadcast_to(vec, p.shape)
            att = np.ones(npts)
            present = np.ones(npts, bool)
        else:
            s, d = _unit(vec[None, :] - p)
            present = d > 0.0  # a light on the point itself has no direction: no light
            if attenuation == "inverse_square":
                att = 1.0 / np.maximum(d, dmin) ** 2
            elif attenuation == "heuristic":
                att = 1.0 / (d + k)
            else:
                att = np.ones(npts)
            if cone is not None:
                att = att * _warn_factor(cone, s)
        ndots = _dot(n, s)
        lit = present & (ndots > 0.0)
        ndots = np.clip(ndots, 0.0, 1.0)
        # Specular cosine: Blinn-Phong n.h, or Phong r.v with r the mirror of s about n.
        h, hl = _unit(s + v)
        c_blinn = np.where(hl > 0.0, _dot(n, h), 0.0)
        r = 2.0 * ndots[:, None] * n - s
        c_phong = _dot(r, v)
        c = np.clip(np.where(blinn, c_blinn, c_phong), 0.0, 1.0)
        spec = np.where((c > 0.0) & has_spec, c ** shin, 0.0)
        fd, fs = kd * ndots[:, None], ks * spec[:, None]
        if ggx.any():
            gd, gs = ggx_terms_numpy(n, s, v, kd, metal * ks[:, 2], rough * ks[:, 1])
            fd, fs = np.where(ggx[:, None], gd, fd), np.where((ggx & has_spec)[:, None], gs, fs)
        term = att[:, None] * radiance[None, :] * (fd + fs)
        out = out + np.where(lit[:, None], term, 0.0)
    return out + ke  # emission, added last as the kernels do


# -- textures and colours --------------------------------------------------------------------------
def sample_reference(texture, u, v, rho=None):
    """A :class:`~raycast_shade.Texture` at UVs (N,), trilinear at level ``log2 rho``.

    ``rho`` (N,): footprint in level-0 texels (None or <= 1: level 0); ignored
    for ``filter="bilinear"``. Returns (N, 3) float64.
    """
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    pyr = texture.pyramid
    out = _bilinear_level(pyr[0], texture.wrap, texture.tiling, u, v)
    if rho is None or texture.filter != "mipmap":
        return out
    rho = np.asarray(rho, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        lod = np.minimum(np.log2(np.where(rho > 1.0, rho, 1.0)), len(pyr) - 1.0)
    lod = np.where(rho > 1.0, lod, 0.0)
    l0 = np.floor(lod).astype(np.int64)
    frac = (lod - l0)[:, None]
    for k in np.unique(l0):
        sel = l0 == k
        if k == 0 and not np.any(frac[sel] > 0):
            continue
        a = _bilinear_level(pyr[k], texture.wrap, texture.tiling, u[sel], v[sel])
        b = _bilinear_level(pyr[min(k + 1, len(pyr) - 1)], texture.wrap, texture.tiling, u[sel], v[sel])
        out[sel] = a + frac[sel] * (b - a)
    return out


def _cam_row(camera, origin):
    from ..visibility.rays import camera_frame  # the packed row: same pixel spacing as the casters

    return camera_frame(camera, origin)


def footprint_reference(scene, camera, hits):
    """Per hit pixel (row-major over ``hits.prim >= 0``): ``d(u, v)/dx`` and
    ``d(u, v)/dy`` from the camera's ray differentials on the face's plane.

    Returns
    -------
    (N, 2, 2) float64
        ``[:, 0] = (du/dx, dv/dx)``, ``[:, 1] = (du/dy, dv/dy)``.
    """
    from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_UP, CAM_WIDTH

    geo = scene.geometry
    cam = _cam_row(camera, geo.origin)
    mask, face, tri, bary, p = _hits(scene, hits)
    ys, xs = np.nonzero(mask)
    w, h = cam[CAM_WIDTH], cam[CAM_HEIGHT]
    right, up, fwd = cam[CAM_RIGHT:CAM_RIGHT + 3], cam[CAM_UP:CAM_UP + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    sx = (2.0 * (xs + 0.5) / w - 1.0)[:, None]
    sy = (1.0 - 2.0 * (ys + 0.5) / h)[:, None]
    n = geo.face_normals[face]
    ortho = cam[CAM_ORTHO] != 0.0
    d = np.broadcast_to(fwd, p.shape) if ortho else fwd + sx * right + sy * up
    dn = _dot(d, n)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.ones(len(p)) if ortho else _dot(p - cam[CAM_EYE:CAM_EYE + 3], n) / dn
        e1 = geo.vertices[tri[:, 1]] - geo.vertices[tri[:, 0]]
        e2 = geo.vertices[tri[:, 2]] - geo.vertices[tri[:, 0]]
        m = np.cross(e1, e2)
        mm = _dot(m, m)[:, None]
        g1, g2 = np.cross(e2, m) / mm, np.cross(m, e1) / mm
        d1 = geo.uvs[tri[:, 1]] - geo.uvs[tri[:, 0]]
        d2 = geo.uvs[tri[:, 2]] - geo.uvs[tri[:, 0]]
        out = np.empty((len(p), 2, 2))
        for k, step in enumerate((2.0 * right / w, -2.0 * up / h)):
            a = t[:, None] * step
            dp = a - d * (_dot(a, n) / dn)[:, None]
            out[:, k] = d1 * _dot(g1, dp)[:, None] + d2 * _dot(g2, dp)[:, None]
    return out


def _rho(texture, duv):
    """Footprint in level-0 texels from (N, 2, 2) UV derivatives (OpenGL's larger axis)."""
    s = np.array([texture.shape[1] * texture.tiling[0], texture.shape[0] * texture.tiling[1]])
    scaled = duv * s[None, None, :]
    rho = np.max(np.linalg.norm(scaled, axis=2), axis=1)
    return np.where(np.isfinite(rho), rho, np.inf)


def coefficients_reference(scene, face, bary, duv=None):
    """``ka, kd, ks, ke`` (each (N, 3) float64) at points given by face (N,) and
    barycentrics (N, 3): the material's, kd the mesh's colour where it has
    colours (ka times it where the material's ``ka_colors`` is set; ka times the occlusion), each times its map's texel (filtered by ``duv``, (N, 2, 2), or
    level 0 without it)."""
    geo = scene.geometry
    model = geo.face_model[face]
    tri = geo.faces[face]
    mats = [m.material for m in scene.models]
    ka = np.array([m.ka for m in mats], np.float64)[model]
    kd = np.array([m.kd for m in mats], np.float64)[model]
    ks = np.array([m.ks for m in mats], np.float64)[model]
    ke = np.array([m.ke for m in mats], np.float64)[model]
    for g, mdl in enumerate(scene.models):
        sel = model == g
        prep = mdl.mesh.prepared
        if prep.color_mode == "vertex":
            kd[sel] = np.einsum("nk,nkc->nc", bary[sel], geo.vertex_colors[tri[sel]])
        elif prep.color_mode == "face":
            kd[sel] = geo.face_colors[face[sel]]
        if prep.color_mode is not None and mdl.material.ka_colors:  # ambient follows the colours
            ka[sel] *= kd[sel]
        if not any(t is not None for t in mdl.material.maps):
            continue
        uv = np.einsum("nk,nkc->nc", bary[sel], geo.uvs[tri[sel]])
        for target, tex in zip((ka, kd, ks, ke), mdl.material.maps):
            if tex is not None:
                rho = None if duv is None else _rho(tex, duv[sel])
                target[sel] *= sample_reference(tex, uv[:, 0], uv[:, 1], rho)
        ao = mdl.material.ao_map
        if ao is not None:  # occlusion: its red channel scales ka
            rho = None if duv is None else _rho(ao, duv[sel])
            occ = 1.0 + mdl.material.ao_strength * (sample_reference(ao, uv[:, 0], uv[:, 1], rho)[:, 0] - 1.0)
            ka[sel] *= occ[:, None]
    return ka, kd, ks, ke


def _face_duv(geo, faces):
    """A flat face's footprint: the UV square as large as its UV triangle, as (F, 2, 2) derivatives."""
    t = geo.uvs[geo.faces[faces]]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    side = np.sqrt(0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]))
    out = np.zeros((len(faces), 2, 2))
    out[:, 0, 0] = side
    out[:, 1, 1] = side
    return out


def _modulated(scene):
    """(G,) bool: models Gouraud shades the modulate way (a map or face colours)."""
    return np.array([any(t is not None for t in m.material.maps) or m.mesh.prepared.color_mode == "face"
                     for m in scene.models])


# -- the three modes ----------------------------------------------------------------------------------
def hit_points(scene, hits):
    """World-space hit points from a hit buffer.

    Returns
    -------
    (H, W, 3) float64
        ``(1 - u - v) p0 + u p1 + v p2`` plus the scene origin; NaN on the background.
    """
    mask, _, _, _, p = _hits(scene, hits)
    out = np.full(hits.shape + (3,), np.nan)
    out[mask] = p + scene.geometry.origin
    return out


def shade_reference(scene, camera, hits, shading: str = "phong") -> np.ndarray:
    """NumPy twin of :func:`raycast_shade.shade`.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    hits : HitBuffer
        (H, W) buffers.
    shading : {"flat", "gouraud", "phong"}

    Returns
    -------
    (H, W, 3) float64
        Linear RGB; ``scene.background`` where nothing was hit.

    Raises
    ------
    ValueError
        For an unknown shading name.
    NotImplementedError
        For lights that cast shadows and bump-mapped materials.

    Notes
    -----
    flat
        One shade per face, at its centroid, with its geometric normal turned
        to the viewer (seen from the centroid).
    gouraud
        The shade at each corner vertex from its normal, ``+n`` when the pixel
        sees the triangle's front and ``-n`` when it sees the back (a vertex
        with a zero normal uses the face's normal turned to the viewer; one
        pointing to the far side of the face is reflected across its plane),
        interpolated with the barycentrics.
    phong
        The shade at the hit point with the interpolated shading normal.
    """
    if shading not in _MODES:
        raise ValueError(f"shading: expected one of {list(_MODES)}, got {shading!r}")
    _check_scope(scene)
    geo = scene.geometry
    eye, fwd, ortho = _camera(camera, geo.origin)
    mats = _materials(scene)
    lights = _lights(scene, geo.origin)
    ambient = np.asarray(scene.ambient, np.float64)
    dmin = 1e-6 * geo.scale
    mask, face, tri, bary, p = _hits(scene, hits)
    model = geo.face_model[face]
    image = np.empty(hits.shape + (3,), np.float64)
    image[~mask] = _background(scene)
    if not mask.any():
        return image
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if shading == "flat":
            faces, inverse = np.unique(face, return_inverse=True)
            centre = geo.vertices[geo.faces[faces]].sum(axis=1) / 3.0
            v = _view(eye, fwd, ortho, centre)
            g, _ = _facing(geo.face_normals[faces], v)
            coef = None
            if geo.textured:
                coef = coefficients_reference(scene, faces, np.full((len(faces), 3), 1.0 / 3.0), _face_duv(geo, faces))
            colour = illuminate_reference(centre, g, v, geo.face_model[faces], mats, lights, ambient, dmin, coef)
            image[mask] = colour[inverse.ravel()]
        elif shading == "phong":
            v = _view(eye, fwd, ortho, p)
            g, sgn = _facing(geo.face_normals[face], v)
            n = normal_mapped(scene, _interpolated_normal(geo.normals, tri, bary, g, sgn), g, sgn, tri, bary, model)
            coef = coefficients_reference(scene, face, bary, footprint_reference(scene, camera, hits)) \
                if geo.textured else None
            image[mask] = illuminate_reference(p, n, v, model, mats, lights, ambient, dmin, coef)
        else:
            v = _view(eye, fwd, ortho, p)
            g, sgn = _facing(geo.face_normals[face], v)
            acc = np.zeros((len(p), 3))
            mod = _modulated(scene)[model] if geo.textured else np.zeros(len(p), bool)
            vcolour = np.array([m.mesh.prepared.color_mode == "vertex" for m in scene.models])[model]
            kacol = np.array([m.material.ka_colors for m in scene.models])[model]
            diffuse, specular = np.zeros((len(p), 3)), np.zeros((len(p), 3))
            for k in range(3):
                idx = tri[:, k]
                q = geo.vertices[idx]
                nv = geo.normals[idx]
                missing = ~np.any(nv != 0.0, axis=1)
                n = np.where(missing[:, None], g, sgn[:, None] * nv)
                # A normal on the far side of the face is reflected into its hemisphere.
                c = np.minimum(np.einsum("ij,ij->i", n, g), 0.0)
                n = n - 2.0 * c[:, None] * g
                vq = _view(eye, fwd, ortho, q)
                kd, ka = mats[1][model].copy(), mats[0][model].copy()
                if vcolour.any():
                    kd[vcolour] = geo.vertex_colors[idx[vcolour]]
                    follow = vcolour & kacol
                    ka[follow] *= kd[follow]  # ambient follows the colours
                colour = illuminate_reference(q, n, vq, model, mats, lights, ambient, dmin,
                                              (ka, kd, mats[2][model], mats[5][model]))
                acc += bary[:, k, None] * colour
                if mod.any():
                    z, one = np.zeros((len(p), 3)), np.ones((len(p), 3))
                    diffuse += bary[:, k, None] * illuminate_reference(q, n, vq, model, mats, lights, 0 * ambient,
                                                                       dmin, (z, one, z, z))
                    specular += bary[:, k, None] * illuminate_reference(q, n, vq, model, mats, lights,
                                                                        0 * ambient, dmin, (z, z, one, z))
            if mod.any():
                ka, kd, ks, ke = coefficients_reference(scene, face, bary, footprint_reference(scene, camera, hits))
                acc[mod] = (ambient * ka + diffuse * kd + specular * ks + ke)[mod]
            image[mask] = acc
    return image


def shading_normals_reference(scene, camera, hits, shading: str = "phong") -> np.ndarray:
    """NumPy twin of :func:`raycast_shade.shading_normals`.

    Returns
    -------
    (H, W, 3) float64
        The unit normal each pixel is shaded with (flat: the geometric normal;
        otherwise the interpolated one), turned to the viewer; zero on the
        background.
    """
    if shading not in _MODES:
        raise ValueError(f"shading: expected one of {list(_MODES)}, got {shading!r}")
    if shading == "phong":
        _check_scope(scene, shadows=False)  # bump maps perturb the Phong normal
    geo = scene.geometry
    eye, fwd, ortho = _camera(camera, geo.origin)
    mask, face, tri, bary, p = _hits(scene, hits)
    out = np.zeros(hits.shape + (3,), np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = _view(eye, fwd, ortho, p)
        g, sgn = _facing(geo.face_normals[face], v)
        n = _interpolated_normal(geo.normals, tri, bary, g, sgn)
        if shading == "phong":  # normal maps bend the Phong normal only
            n = normal_mapped(scene, n, g, sgn, tri, bary, geo.face_model[face])
        out[mask] = g if shading == "flat" else n
    return out


# The float64 geometry that raycast_shade.insight.explain follows too, under public names.
view_vectors, facing, interpolated_normal, footprint_rho = _view, _facing, _interpolated_normal, _rho
