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
flat       ``D Δ/√3 + S min(1, 0.6 k sqrt(t) Δ/√3)`` (first order: the
           normal is off by up to a circumradius, Δ/√3; a highlight's slope is ~0.6 sqrt(t)
           per radian of lobe angle, and the lobe turns ``k`` times as fast
           as the normal: ``k = 2`` for Phong's ``r.v``, 1 for Blinn's ``n.h``)
Gouraud    ``D max(Δ/4, Δ²/8) + S min(1, t k² Δ²/8)`` (linear
           interpolation across the terminator's kink in ``max(0, n.s)``
           is off by D Δ/4; a function with second derivative D by D Δ²/8;
           S t k² at a highlight's peak; a highlight narrower than a
           triangle is lost whole)
Phong      ``(D/3 + 0.6 k S sqrt(t)/8) Δn²`` with ``Δn`` the normal step
           alone: ``s`` and ``v`` are exact at every pixel, and the
           interpolated normal is off by O(Δn²) (D/3 rather than D/8: the
           ray meets the chord, not the surface)
=========  =============================================================

``Δ`` includes the turn of the view direction only where there is a
specular term, and of the light direction only for point lights: a faceted,
diffuse-only model under directional light is exact with flat shading.
(Constants revised against the analytic ground truth; see ``docs/auto.md``.)

Overrides: a bump-mapped model needs per-pixel normals, so Phong; a model
whose triangles project to at most ``max_pixels`` pixels is Gouraud-shaded
when Gouraud's predicted error meets the tolerance (a highlight narrower
than a triangle is lost however small the triangle is on screen) and flat's
does not (flat is cheaper still). Phong is the fallback when no
method meets the tolerance. The decision and its reason are reported per
model on the frame (``frame.decisions``); ``frame.method`` says per pixel.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from ..common.validate import as_instance, as_scalar
from ..scene.lights import PointLight

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


# Per-mesh geometry summaries (centre, mean edge, normal step): a mesh and its
# prepared arrays never change, and on an 80k-triangle mesh the normal step
# alone costs ~70 ms, several times a 320x240 frame (benchmarks/bench_auto.py).
_GEOMETRY: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _geometry(mesh):
    """(centre, mean edge length, normal step) of a mesh, computed once."""
    try:
        return _GEOMETRY[mesh]
    except (KeyError, TypeError):
        pass
    prep = mesh.prepared
    centre = 0.5 * (prep.vertices.min(axis=0) + prep.vertices.max(axis=0))
    e = prep.vertices[prep.faces]
    edge = float(np.mean(np.linalg.norm(e[:, 1] - e[:, 0], axis=1)))
    out = (centre, edge, _normal_step(prep))
    try:
        _GEOMETRY[mesh] = out
    except TypeError:  # not weak-referenceable: no cache
        pass
    return out


def predicted_errors(normal_step: float, turn_step: float, diffuse: float, specular: float,
                     shininess: float, lobe: float = 2.0) -> dict:
    """Predicted error of each method; see the module docstring.

    ``normal_step`` is the angle between neighbouring vertex normals,
    ``turn_step`` how far the light and view directions turn across a
    triangle (both radians); flat and Gouraud feel their sum, Phong only the
    first. ``lobe`` is how fast the specular lobe's angle moves with the
    normal: 2 for Phong's ``r.v`` (turning ``n`` by δ turns ``r`` by 2δ),
    1 for Blinn's ``n.h``."""
    root_t = np.sqrt(shininess)
    step = normal_step + turn_step
    return {
        # Δ/√3, not Δ/2: the face normal belongs to the centroid, and a
        # corner is a circumradius (Δ/√3 on an equilateral triangle) away
        # (measured: 1.02-1.07 x Δ/2 on icospheres).
        "flat": diffuse * step / np.sqrt(3) + specular * min(1.0, 0.6 * root_t * lobe * step / np.sqrt(3)),
        # The diffuse term is first order at the terminator: max(0, n.s) has
        # a kink of slope D there, and linear interpolation across it is off
        # by up to D Δ/4 (measured: 0.020 at Δ = 0.14 rad, D = 0.7).
        "gouraud": diffuse * max(step / 4, step**2 / 8)
        + specular * min(1.0, shininess * lobe**2 * step**2 / 8),
        # Δn²/3 rather than /8: the ray meets the chord, not the surface, so
        # the interpolated normal is also off by the sagitta's sideways shift
        # (~Δ²/6 tan of the view angle); calibrated on the interior (2-px rim)
        # maximum error of icospheres at 160x120.
        "phong": (diffuse / 3 + 0.6 * lobe * specular * root_t / 8) * normal_step**2,
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
    from ..scene.camera import Camera
    from ..scene.scene import Scene

    as_instance(scene, "scene", Scene)
    as_instance(camera, "camera", Camera)
    tolerance = as_scalar(tolerance, "tolerance", minimum=0.0, exclusive=True)
    max_pixels = as_scalar(max_pixels, "max_pixels", minimum=0.0)
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    decisions = []
    for i, model in enumerate(scene.models):
        mat = model.material
        centre, edge, normal_step = _geometry(model.mesh)  # edge and normal step: the same in any pose
        if model.pose is not None:
            centre = model.pose[:3, :3] @ centre + model.pose[:3, 3]
        # Distance to the eye along the view axis, for the projected size.
        depth = max(float(np.dot(centre - camera.eye, fwd)), 1e-12)
        if camera.orthographic:
            pixels = edge / (2 * hh) * camera.height
            near = np.inf
        else:
            pixels = edge / (2 * hh * depth) * camera.height
            near = float(np.linalg.norm(centre - camera.eye))
        diffuse = specular = 0.0
        near_light = np.inf
        for light in scene.lights:
            att = 1.0
            if isinstance(light, PointLight):
                d = float(np.linalg.norm(light.position - centre))
                near_light = min(near_light, d)
                if light.attenuation == "inverse_square":
                    att = 1.0 / max(d, 1e-12) ** 2
                elif light.attenuation == "heuristic":
                    att = 1.0 / (d + light.k)
            diffuse += float(np.max(mat.kd * light.radiance)) * att
            specular += float(np.max(mat.ks * light.radiance)) * att
        # Only a point light's direction turns across a triangle; the view
        # direction matters only to the specular term.
        if specular == 0.0:
            near = np.inf
        near = min(near, near_light)
        turn_step = edge / near if np.isfinite(near) and near > 0 else 0.0
        step = normal_step + turn_step
        pred = predicted_errors(normal_step, turn_step, diffuse, specular, mat.shininess,
                                1.0 if mat.specular == "blinn" else 2.0)
        if mat.bump is not None:
            method, reason = "phong", "bump map: needs a normal per pixel"
        elif pixels <= max_pixels and pred["gouraud"] <= tolerance < pred["flat"]:
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
            elif specular == 0.0:  # no highlight to lose: the diffuse term's curvature decides
                reason = (f"diffuse shading turns too fast for the triangles (step {np.degrees(step):.2g} deg, "
                          f"no specular term): Gouraud predicts {pred['gouraud']:.3g} > {tolerance:g}")
            else:
                reason = (f"highlights narrower than the triangles (t={mat.shininess:g}, step {np.degrees(step):.2g} deg): "
                          f"Gouraud predicts {pred['gouraud']:.3g} > {tolerance:g}")
        decisions.append(Decision(i, model.mesh.name, method, reason, pred, step, pixels))
    return decisions
