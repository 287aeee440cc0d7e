"""Checks for silent pitfalls: scenes that render, but not as meant.

Each check is cheap next to a frame, and each warning (see
:mod:`raycast_shade.common.warnings`) names its remedy:

* :func:`sharp_edges`: averaged vertex normals across edges sharper than
  about 60 degrees round a box into a blob (:class:`CreaseWarning`, from
  :class:`~raycast_shade.scene.mesh.Mesh`);
* :func:`closed`, :func:`winding_number`: a point light inside a closed mesh
  lights only its inside (:class:`LightInsideWarning`);
* :func:`warn_render`: at :func:`raycast_shade.render`, no lights, a point
  light inside a closed mesh, a bump map the shading method ignores, or a
  camera that sees nothing (:func:`outside_view`: every model's bounding box
  wholly behind the camera or beyond one side of its view).

Only consistently wound, closed meshes (every edge traversed once each way)
are tested for a light inside: the winding number then is exactly 0 outside
and +-1 inside. A light outside a model's bounding box is outside without
further work.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit

from ..common.parallel import KERNEL, in_parts, launch, parts, share
from ..common.warnings import BumpIgnoredWarning, EmptyViewWarning, LightInsideWarning, NoLightsWarning
from .normals import _corners_by_vertex

__all__ = ["SHARP_DEGREES", "sharp_edges", "closed", "winding_number", "warn_render", "outside_view"]

# Faces whose normals differ by more than this are a crease, not a curve:
# averaging across them rounds the edge off.
SHARP_DEGREES = 60.0


@njit(cache=True)
def _half_edges(order, starts, dest, lo, hi, b):
    """How many corners among ``order[lo:hi]`` go on to vertex ``b``, and the face of the last."""
    n = 0
    face = -1
    for i in range(lo, hi):
        if dest[i] == b:
            n += 1
            face = order[i] // 3
    return n, face


@njit(cache=True)
def _third(faces, f, a, b):
    """The vertex of face ``f`` other than ``a`` and ``b``."""
    for k in range(3):
        if faces[f, k] != a and faces[f, k] != b:
            return faces[f, k]
    return -1


def _sharp_edges_kernel(faces, order, starts, dest, fnormals, cos_limit):
    """The number of :func:`_sharp_edges_parts`' edges (an int), counted in parts and added."""
    n = parts()
    counts = np.zeros(n, np.int64)
    launch(_sharp_edges_parts.kernel, faces, order, starts, dest, fnormals, cos_limit, counts, parts=n)
    return int(counts.sum())


@in_parts
@njit(**KERNEL)
def _sharp_edges_parts(faces, order, starts, dest, fnormals, cos_limit, counts, part):
    """Count manifold edges (one face each way) whose face normals meet at cosine < ``cos_limit``.

    Each edge is counted once, from its half-edge ``a -> b`` with ``a < b``;
    edges with zero-area faces, three or more faces, or a winding conflict
    are left out, and so are a face and its own reverse (a double-sided
    sheet's rim: no crease that a crease angle would keep).
    """
    count = 0
    a0, a1 = share(starts.shape[0] - 1, part)
    for a in range(a0, a1):
        for i in range(starts[a], starts[a + 1]):
            b = dest[i]
            if b < a:
                continue
            n_ab, fa = _half_edges(order, starts, dest, starts[a], starts[a + 1], b)
            n_ba, fb = _half_edges(order, starts, dest, starts[b], starts[b + 1], a)
            if n_ab != 1 or n_ba != 1 or _third(faces, fa, a, b) == _third(faces, fb, a, b):
                continue
            la = fnormals[fa, 0] ** 2 + fnormals[fa, 1] ** 2 + fnormals[fa, 2] ** 2
            lb = fnormals[fb, 0] ** 2 + fnormals[fb, 1] ** 2 + fnormals[fb, 2] ** 2
            if la == 0.0 or lb == 0.0:
                continue
            c = fnormals[fa, 0] * fnormals[fb, 0] + fnormals[fa, 1] * fnormals[fb, 1] + fnormals[fa, 2] * fnormals[fb, 2]
            if c < cos_limit:
                count += 1
    counts[part[0]] = count  # this part's count, into its own slot


@njit(cache=True)
def _closed_kernel(order, starts, dest):
    """True when every half-edge ``a -> b`` is unique and has exactly one ``b -> a``."""
    for a in range(starts.shape[0] - 1):
        for i in range(starts[a], starts[a + 1]):
            b = dest[i]
            n_ab, _ = _half_edges(order, starts, dest, starts[a], starts[a + 1], b)
            n_ba, _ = _half_edges(order, starts, dest, starts[b], starts[b + 1], a)
            if n_ab != 1 or n_ba != 1:
                return False
    return True


def sharp_edges(vertices: np.ndarray, faces: np.ndarray, fnormals: np.ndarray,
                degrees: float = SHARP_DEGREES) -> int:
    """Number of edges where the two faces' normals differ by more than ``degrees``.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    fnormals : (F, 3) float64
        Unit face normals, zero for degenerate faces.
    degrees : float

    Returns
    -------
    int
        Counted over manifold, consistently wound edges only.
    """
    faces = np.asarray(faces, np.int64)
    order, starts, dest, _ = _corners_by_vertex(faces, vertices.shape[0])
    return int(_sharp_edges_kernel(faces, order, starts, dest, fnormals, math.cos(math.radians(degrees))))


def closed(faces: np.ndarray, n_vertices: int) -> bool:
    """True for a closed, consistently wound surface: each edge once each way.

    Parameters
    ----------
    faces : (F, 3) int64
    n_vertices : int
    """
    order, starts, dest, _ = _corners_by_vertex(np.asarray(faces, np.int64), int(n_vertices))
    return bool(_closed_kernel(order, starts, dest))


def winding_number(vertices: np.ndarray, faces: np.ndarray, point) -> float:
    """Generalised winding number of ``point`` for a triangle mesh.

    The sum of the solid angles the faces subtend at the point (Van Oosterom
    and Strackee's formula), over 4 pi: for a closed mesh, 0 outside and 1
    inside (-1 if it is wound inside out).

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    point : (3,) float

    Returns
    -------
    float
    """
    p = vertices[faces] - np.asarray(point, np.float64)  # (F, 3 corners, 3)
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    num = np.einsum("ij,ij->i", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", a, c) * lb
           + np.einsum("ij,ij->i", b, c) * la)
    return float(np.sum(2.0 * np.arctan2(num, den)) / (4.0 * np.pi))


def _lights_inside(scene):
    """(light name, model index, mesh name) for each point light inside a closed model."""
    found = []
    points = [(light.name, light.position) for light in scene.lights if hasattr(light, "position")]
    if not points:
        return found
    for g, model in enumerate(scene.models):
        mesh = model.mesh
        lo, hi = mesh.bounds
        if model.pose is not None:  # the lights into the mesh's own frame: x = R^T (p - t)
            R, t = model.pose[:3, :3], model.pose[:3, 3]
            points_g = [(n, (np.asarray(p, np.float64) - t) @ R) for n, p in points]
        else:
            points_g = points
        candidates = [(n, p) for n, p in points_g if np.all(p > lo) and np.all(p < hi)]
        if not candidates:
            continue
        is_closed = scene.geometry.memo(f"pitfalls.closed.{g}", lambda _, m=mesh: closed(m.faces, len(m.vertices)))
        if not is_closed:
            continue
        for name, p in candidates:
            if abs(winding_number(mesh.vertices, mesh.faces, p)) > 0.5:
                found.append((name, g, mesh.name))
    return found


def outside_view(camera, bounds) -> bool:
    """True when the box ``bounds`` (2, 3) lies wholly outside the camera's view.

    The box's eight corners in camera axes ``(x, y, z)`` (``z`` forward) are
    tested against the view's four side planes (``|x| <= hx z``, ``|y| <=
    hy z`` for a perspective camera, ``|x| <= hx``, ``|y| <= hy`` for an
    orthographic one, widened by the principal point's offset) and the eye's
    plane ``z > 0``: the box is outside when all eight corners are beyond
    one of them. A box that straddles them may still show nothing (it is a
    bound), never the other way round.
    """
    lo, hi = np.asarray(bounds, np.float64)
    corners = np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]]
                        for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    r, u, f = camera.basis
    q = corners - camera.eye
    x, y, z = q @ r, q @ u, q @ f
    hx, hy = camera.half_extents()
    ox, oy = camera.principal_offset()
    if camera.orthographic:
        x, y = x - ox, y - oy
        outside = (x > hx).all() or (x < -hx).all() or (y > hy).all() or (y < -hy).all()
        return bool(outside or (z <= 0).all())
    x, y = x - ox * z, y - oy * z
    return bool((z <= 0).all() or (x > hx * z).all() or (x < -hx * z).all()
                or (y > hy * z).all() or (y < -hy * z).all())


def warn_render(scene, methods, stacklevel: int = 3) -> None:
    """Warn about the pitfalls of rendering ``scene`` with ``methods``.

    Parameters
    ----------
    scene : Scene
    methods : str or sequence of str
        One of ``"flat"``, ``"gouraud"``, ``"phong"`` for every model, or one per model.
    stacklevel : int
        Passed to :func:`warnings.warn`; 3 points at the caller of the function that calls this.
    """
    if not scene.lights:
        warnings.warn(
            "the scene has no lights, so only the ambient term (Ia ka) shows, one flat colour per "
            "material: add a PointLight or DirectionalLight to scene.lights",
            NoLightsWarning, stacklevel=stacklevel)
    for light, g, name in _lights_inside(scene):
        warnings.warn(
            f"{light} is inside the closed mesh scene.models[{g}] ({name}), so it lights only the inside "
            "(and the mesh shadows everything else from it): move the light outside the mesh",
            LightInsideWarning, stacklevel=stacklevel)
    if scene.camera is not None and scene.models and all(
            outside_view(scene.camera, m.bounds) for m in scene.models):
        lo = np.min([m.bounds[0] for m in scene.models], axis=0)
        hi = np.max([m.bounds[1] for m in scene.models], axis=0)
        warnings.warn(
            f"the camera (eye {np.round(scene.camera.eye, 4).tolist()}, target "
            f"{np.round(scene.camera.target, 4).tolist()}) sees none of the scene (bounds "
            f"{np.round(lo, 4).tolist()} to {np.round(hi, 4).tolist()}): the image will be empty; aim it with "
            "Camera.fit(scene, direction=...) (or fit = true in a scene file's [camera])",
            EmptyViewWarning, stacklevel=stacklevel)
    per_model = [methods] * len(scene.models) if isinstance(methods, str) else list(methods)
    ignored = [(g, m.mesh.name, method) for g, (m, method) in enumerate(zip(scene.models, per_model))
               if (m.material.bump is not None or m.material.normal_map is not None) and method in ("flat", "gouraud")]
    if ignored:
        which = ", ".join(f"scene.models[{g}] ({name}, {method})" for g, name, method in ignored)
        warnings.warn(
            f"{which}: the bump or normal map shows only in Phong shading (flat and Gouraud shading have no normal "
            "per pixel to perturb): render with shading='phong' or 'auto', or, to show this on purpose, "
            "ignore raycast_shade.BumpIgnoredWarning in warnings.catch_warnings()",
            BumpIgnoredWarning, stacklevel=stacklevel)
