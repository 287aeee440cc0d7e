"""``shading="auto"``: the cheapest method whose predicted error is small enough.

Each model gets flat, Gouraud or Phong shading, whichever is cheapest (in
that order) while its *predicted* error stays under a tolerance, in linear
intensity (the image's units, max over channels). The predictions follow the
convergence orders measured in ``docs/accuracy.md``:

``Δ``
    the angular step of the model: the median angle between the vertex
    normals at the two ends of an edge (0 on a faceted mesh, where every edge
    is a crease), plus the angle a mean edge subtends at the nearest point
    light or perspective eye (how far ``s`` and ``v`` turn across a triangle);
``D``, ``S``
    the largest diffuse (``kd Ii att``) and specular (``Ks Ii att``)
    contributions the lights can make, attenuation taken at the model's
    centre.

=========  =============================================================
flat       ``D Δ/2 + S min(1, 0.6 sqrt(t) Δ/2)`` (first order: the
           normal is off by up to Δ/2; a highlight's slope is ~0.6 sqrt(t))
Gouraud    ``D Δ²/8 + S min(1, t Δ²/8)`` (linear interpolation of a
           function with second derivative D, or S t at a highlight's peak;
           a highlight narrower than a triangle is lost whole)
Phong      ``(D + 0.6 S sqrt(t)) Δn²/8`` with ``Δn`` the normal step alone:
           ``s`` and ``v`` are exact at every pixel, and the interpolated
           normal is off by O(Δn²)
=========  =============================================================

Overrides: a bump-mapped model needs per-pixel normals, so Phong; a model
whose triangles project to at most ``max_pixels`` pixels is Gouraud-shaded
(interpolation inside a pixel is invisible). Phong is the fallback when no
method meets the tolerance. The decision and its reason are reported per
model on the frame (``frame.decisions``); ``frame.method`` says per pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .lights import PointLight

__all__ = ["Decision", "choose_methods", "predicted_errors"]

_ORDER = ("flat", "gouraud", "phong")


@dataclass(frozen=True)
class Decision:
    """Why a model is shaded the way it is.

    Attributes
    ----------
    model : int
        Index in ``scene.models``.
    name : str
        The mesh's name.
    method : {"flat", "gouraud", "phong"}
    reason : str
    predicted : dict of str to float
        Predicted error of each method (linear intensity).
    step : float
        The angular step Δ (radians): normal step plus the turn of the
        light and view directions across a triangle.
    pixels : float
        Mean projected edge length in pixels.
    """

    model: int
    name: str
    method: str
    reason: str
    predicted: dict
    step: float
    pixels: float


def _normal_step(prep) -> float:
    """Median angle between vertex normals across edges (radians)."""
    f = prep.faces
    n = prep.normals
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    a, b = n[edges[:, 0]], n[edges[:, 1]]
    ok = (np.linalg.norm(a, axis=1) > 0) & (np.linalg.norm(b, axis=1) > 0)
    if not np.any(ok):
        return 0.0
    c = np.clip(np.einsum("ij,ij->i", a[ok], b[ok]), -1.0, 1.0)
    return float(np.median(np.arccos(c)))


def predicted_errors(normal_step: float, turn_step: float, diffuse: float, specular: float,
                     shininess: float) -> dict:
    """Predicted error of each method; see the module docstring.

    ``normal_step`` is the angle between neighbouring vertex normals,
    ``turn_step`` how far the light and view directions turn across a
    triangle (both radians); flat and Gouraud feel their sum, Phong only the
    first."""
    root_t = np.sqrt(shininess)
    step = normal_step + turn_step
    return {
        "flat": diffuse * step / 2 + specular * min(1.0, 0.6 * root_t * step / 2),
        "gouraud": diffuse * step**2 / 8 + specular * min(1.0, shininess * step**2 / 8),
        "phong": (diffuse + 0.6 * specular * root_t) * normal_step**2 / 8,
    }


def choose_methods(scene, camera, tolerance: float = 0.01, max_pixels: float = 2.0):
    """One :class:`Decision` per model.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    tolerance : float
        Largest acceptable predicted error, linear intensity (``> 0``).
    max_pixels : float
        Mean projected edge length at or below which Gouraud is chosen.

    Returns
    -------
    list of Decision
    """
    if not (isinstance(tolerance, (int, float)) and np.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance: must be a finite number > 0, got {tolerance!r}")
    if not (isinstance(max_pixels, (int, float)) and np.isfinite(max_pixels) and max_pixels >= 0):
        raise ValueError(f"max_pixels: must be a finite number >= 0, got {max_pixels!r}")
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    decisions = []
    for i, model in enumerate(scene.models):
        prep = model.mesh.prepared
        mat = model.material
        centre = 0.5 * (prep.vertices.min(axis=0) + prep.vertices.max(axis=0))
        e = prep.vertices[prep.faces]
        edge = float(np.mean(np.linalg.norm(e[:, 1] - e[:, 0], axis=1)))
        # Distance to the eye along the view axis, for the projected size.
        depth = max(float(np.dot(centre - camera.eye, fwd)), 1e-12)
        if camera.orthographic:
            pixels = edge / (2 * hh) * camera.height
            near = np.inf
        else:
            pixels = edge / (2 * hh * depth) * camera.height
            near = float(np.linalg.norm(centre - camera.eye))
        diffuse = specular = 0.0
        for light in scene.lights:
            att = 1.0
            if isinstance(light, PointLight):
                d = float(np.linalg.norm(light.position - centre))
                near = min(near, d)
                if light.attenuation == "inverse_square":
                    att = 1.0 / max(d, 1e-12) ** 2
                elif light.attenuation == "heuristic":
                    att = 1.0 / (d + light.k)
            diffuse += float(np.max(mat.kd * light.radiance)) * att
            specular += float(np.max(mat.ks * light.radiance)) * att
        normal_step = _normal_step(prep)
        turn_step = edge / near if np.isfinite(near) and near > 0 else 0.0
        step = normal_step + turn_step
        pred = predicted_errors(normal_step, turn_step, diffuse, specular, mat.shininess)
        if mat.bump is not None:
            method, reason = "phong", "bump map: needs a normal per pixel"
        elif pixels <= max_pixels:
            method, reason = "gouraud", f"triangles project to {pixels:.2g} px: interpolation is sub-pixel"
        else:
            method = next((m for m in _ORDER if pred[m] <= tolerance), "phong")
            if pred[method] > tolerance:
                reason = f"no method meets tolerance {tolerance:g} (Phong predicts {pred['phong']:.3g})"
            elif method == "flat":
                reason = "faceted mesh (every edge a crease)" if normal_step == 0.0 else "curvature small enough"
                reason += f": flat predicts {pred['flat']:.3g} <= {tolerance:g}"
            elif method == "gouraud":
                why = "no specular term" if specular == 0.0 else f"highlights wider than the triangles (t={mat.shininess:g})"
                reason = f"{why}: Gouraud predicts {pred['gouraud']:.3g} <= {tolerance:g}, flat {pred['flat']:.3g}"
            else:
                reason = (f"highlights narrower than the triangles (t={mat.shininess:g}, step {np.degrees(step):.2g} deg): "
                          f"Gouraud predicts {pred['gouraud']:.3g} > {tolerance:g}")
        decisions.append(Decision(i, model.mesh.name, method, reason, pred, step, pixels))
    return decisions
