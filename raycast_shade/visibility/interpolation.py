"""How a hit's barycentrics interpolate vertex data: the lecture's "2D or 3D".

A hit buffer carries the *perspective-correct* barycentrics ``(1 - u - v, u,
v)`` of the 3D point seen at each pixel (what Embree reports, and what
:func:`raycast_shade.visibility.raster.rasterize` reproduces). Two other conventions of
the interpolation-based pipeline are remaps of those weights, so that the
same shading kernels render them:

screen (2D, GLSL ``noperspective``)
    :func:`to_screen_space`. Classic scanline Gouraud interpolates linearly
    along the projected edges and spans, i.e. with weights *affine in screen
    space*. For a triangle whose vertices have clip-space depth ``w_i`` (the
    camera-space depth along the view axis), screen weights and 3D weights
    are related by ``lambda_i = (lambda'_i / w_i) / sum_j (lambda'_j / w_j)``,
    so, inverted, ``lambda'_i = lambda_i w_i / sum_j lambda_j w_j``. With an
    orthographic camera the two coincide. A triangle with a vertex at or
    behind the eye plane (``w_i <= 0``) has no proper projection; the classic
    pipeline clips it first, and here it keeps its 3D weights.
flat, provoking vertex (GLSL ``flat``)
    :func:`provoking_vertex`. OpenGL's flat shading gives the whole triangle
    the colour computed *at one vertex* (with that vertex's normal), the
    "provoking" one: the last of the triangle by default
    (``GL_LAST_VERTEX_CONVENTION``), the first under Direct3D's convention.
    Weights ``(0, 0, 1)`` (or ``(1, 0, 0)``) followed by Gouraud shading give
    exactly that; :func:`shade_flat` wraps it. The lecture's flat shading, one
    shade at the polygon's centre with its true normal, stays the default.

Every function returns a new :class:`~raycast_shade.visibility.hits.HitBuffer` (``prim``,
``geom`` and ``t`` shared, not copied) and leaves its input untouched.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.parallel import KERNEL, in_parts, share
from .hits import HitBuffer, check_hits

__all__ = ["to_screen_space", "provoking_vertex", "vertex_depths"]


@in_parts
@njit(**KERNEL)
def _screen_kernel(prim, geom, u, v, faces, face_off, w, uo, vo, part):
    h, wd = prim.shape
    for y in range(*share(h, part)):  # this part's share (common.parallel)
        for x in range(wd):
            p = prim[y, x]
            b1 = np.float64(u[y, x])
            b2 = np.float64(v[y, x])
            if p >= 0:
                f = face_off[geom[y, x]] + p
                w0 = w[faces[f, 0]]
                w1 = w[faces[f, 1]]
                w2 = w[faces[f, 2]]
                if w0 > 0.0 and w1 > 0.0 and w2 > 0.0:
                    a1 = b1 * w1
                    a2 = b2 * w2
                    den = (1.0 - b1 - b2) * w0 + a1 + a2
                    if den > 0.0:
                        b1 = a1 / den
                        b2 = a2 / den
            uo[y, x] = b1
            vo[y, x] = b2


def vertex_depths(geometry, camera) -> np.ndarray:
    """Clip-space ``w`` of every vertex: its depth along the view axis.

    Parameters
    ----------
    geometry : SceneGeometry
    camera : Camera

    Returns
    -------
    (V,) float64
        ``(p - eye) . forward`` in the scene's re-centred frame.
    """
    _, _, fwd = camera.basis
    return (geometry.vertices - (camera.eye - geometry.origin)) @ fwd


def to_screen_space(hits, geometry, camera) -> HitBuffer:
    """Perspective-correct barycentrics to screen-space (affine) weights.

    ``lambda'_i = lambda_i w_i / sum_j lambda_j w_j`` with ``w`` the vertex
    depths along the view axis (:func:`vertex_depths`); the identity for an
    orthographic camera and for triangles with a vertex at or behind the
    eye plane.

    Parameters
    ----------
    hits : HitBuffer
        Perspective-correct barycentrics (from the ray caster or the
        rasterizer).
    geometry : SceneGeometry
    camera : Camera
        The camera ``hits`` was made with.

    Returns
    -------
    HitBuffer
        New ``u, v`` (float32); ``prim``, ``geom`` and ``t`` are the input's.

    Raises
    ------
    TypeError, ValueError
        For a bad argument (the message names it).
    """
    geometry = check_hits(hits, geometry, camera)
    if camera.orthographic:
        return HitBuffer(prim=hits.prim, geom=hits.geom, u=hits.u.copy(), v=hits.v.copy(), t=hits.t)
    w = vertex_depths(geometry, camera)
    u = np.empty(hits.shape, np.float32)
    v = np.empty(hits.shape, np.float32)
    _screen_kernel(np.ascontiguousarray(hits.prim), np.ascontiguousarray(hits.geom), np.ascontiguousarray(hits.u),
                   np.ascontiguousarray(hits.v), np.ascontiguousarray(geometry.faces, dtype=np.int64),
                   np.ascontiguousarray(geometry.face_offsets, dtype=np.int64), w, u, v)
    return HitBuffer(prim=hits.prim, geom=hits.geom, u=u, v=v, t=hits.t)


def provoking_vertex(hits, vertex: str = "last") -> HitBuffer:
    """Barycentrics snapped to one vertex of each triangle (GLSL ``flat``).

    Parameters
    ----------
    hits : HitBuffer
    vertex : {"last", "first"}
        OpenGL's default provoking vertex is the last (vertex 2),
        Direct3D's the first (vertex 0).

    Returns
    -------
    HitBuffer
        ``u, v`` = ``(0, 1)`` ("last") or ``(0, 0)`` ("first") on every hit
        pixel, zero elsewhere; ``prim``, ``geom``, ``t`` are the input's.
    """
    if not isinstance(hits, HitBuffer):
        raise TypeError(f"hits: expected a HitBuffer, got {type(hits).__name__}")
    if vertex not in ("first", "last"):
        raise ValueError(f"vertex: expected 'first' or 'last', got {vertex!r}")
    u = np.zeros(hits.shape, np.float32)
    v = np.zeros(hits.shape, np.float32)
    if vertex == "last":
        v[hits.prim >= 0] = 1.0
    return HitBuffer(prim=hits.prim, geom=hits.geom, u=u, v=v, t=hits.t)
