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

Scope: local illumination only. Shadow rays and bump maps need Embree and
texture lookups and have no twin here; :func:`shade_reference` refuses scenes
that use them rather than answer differently. Mirror reflections are added
by :func:`raycast_shade.render` after shading and do not concern it.
"""

from __future__ import annotations

import numpy as np

from ..scene.lights import DirectionalLight, SpotLight

__all__ = ["shade_reference", "shading_normals_reference", "hit_points", "illuminate_reference", "spot_cone"]

_MODES = ("flat", "gouraud", "phong")
_CANCEL = 1e-6  # |interpolated normal| below this falls back to the geometric normal


# -- small vector helpers ---------------------------------------------------------------------------
def _dot(a, b):
    """Row-wise dot product of two (N, 3) arrays -> (N,)."""
    return np.einsum("ij,ij->i", a, b)


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
    """Per-model material arrays: ka, kd, ks (G, 3), shininess (G,), blinn (G,) bool."""
    mats = [m.material for m in scene.models]
    return (
        np.array([m.ka for m in mats], np.float64),
        np.array([m.kd for m in mats], np.float64),
        np.array([m.ks for m in mats], np.float64),
        np.array([m.shininess for m in mats], np.float64),
        np.array([m.specular == "blinn" for m in mats], bool),
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
    re-centred position; ``cone`` is :func:`spot_cone`'s (``None`` but for spots).
    """
    out = []
    for light in scene.lights:
        if isinstance(light, DirectionalLight):
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
    geo = scene.geometry
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
def illuminate_reference(p, n, v, model, materials, lights, ambient, dmin):
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
        ``(ka, kd, ks, shininess, blinn)`` with shapes ``(G, 3) x 3, (G,), (G,)``.
    lights : list of tuple
        ``(directional, vec, radiance (3,), attenuation, k)``, optionally
        followed by a spot light's cone (:func:`spot_cone`); see :func:`_lights`.
    ambient : (3,) float64
        Scene ambient intensity ``Ia``.
    dmin : float
        Lower clamp of ``d`` in the inverse-square law.

    Returns
    -------
    (N, 3) float64
        Reflected RGB intensity.
    """
    ka, kd, ks, shin, blinn = materials
    ka, kd, ks, shin, blinn = ka[model], kd[model], ks[model], shin[model], blinn[model]
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
        spec = np.where(c > 0.0, c ** shin, 0.0)
        term = att[:, None] * radiance[None, :] * (kd * ndots[:, None] + ks * spec[:, None])
        out = out + np.where(lit[:, None], term, 0.0)
    return out


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
            colour = illuminate_reference(centre, g, v, geo.face_model[faces], mats, lights, ambient, dmin)
            image[mask] = colour[inverse.ravel()]
        elif shading == "phong":
            v = _view(eye, fwd, ortho, p)
            g, sgn = _facing(geo.face_normals[face], v)
            n = _interpolated_normal(geo.normals, tri, bary, g, sgn)
            image[mask] = illuminate_reference(p, n, v, model, mats, lights, ambient, dmin)
        else:
            v = _view(eye, fwd, ortho, p)
            g, sgn = _facing(geo.face_normals[face], v)
            acc = np.zeros((len(p), 3))
            for k in range(3):
                idx = tri[:, k]
                q = geo.vertices[idx]
                nv = geo.normals[idx]
                missing = ~np.any(nv != 0.0, axis=1)
                n = np.where(missing[:, None], g, sgn[:, None] * nv)
                # A normal on the far side of the face is reflected into its hemisphere.
                c = np.minimum(np.einsum("ij,ij->i", n, g), 0.0)
                n = n - 2.0 * c[:, None] * g
                colour = illuminate_reference(q, n, _view(eye, fwd, ortho, q), model, mats, lights, ambient, dmin)
                acc += bary[:, k, None] * colour
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
        out[mask] = g if shading == "flat" else _interpolated_normal(geo.normals, tri, bary, g, sgn)
    return out
