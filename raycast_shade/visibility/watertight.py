"""Exact re-tests of rays that may have slipped through a shared vertex.

Embree's robust mode is watertight across shared edges but not at shared
vertices: a ray that passes (to float32 rounding) through a vertex meets
edge functions near zero on every spoke of the vertex's fan, each rounded
on its own, and when they all round the same way the ray slips between all
the triangles and reports what lies behind, or nothing (measured on
icosphere(5), rays from outside aimed at its vertices: 0.9% slip).

The repair needs a *candidate*: any triangle near the point where the ray
slipped. A second ray, nudged off the first by far more than float32
rounding and far less than a triangle, meets that triangle (or one sharing
a vertex with it); the callers find it (:func:`nudged_rays`, or the
camera's jittered pixel rays). :func:`refine` then tests the *original*
ray exactly against every triangle that shares a vertex with the candidate,
with the watertight test of Woop, Benthin and Wald (JCGT 2013) in float64 on
the float32 vertices Embree holds. That test is watertight at vertices too:
each vertex is moved into the ray's frame once, whatever triangle uses it,
and each edge function ``a * b - c * d`` rounds to its exact sign or to
zero (rounding is monotone), never to the opposite sign; zero counts as
inside. So the ray, moved by nothing, gets its own hit: triangle,
barycentrics and distance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..common.inline import inline_jit
from ..common.parallel import KERNEL, in_parts, share
from .accel import embree_accel
from .alpha import masked_geometries, masked_hits
from .hits import HitBuffer

__all__ = ["VertexFans", "vertex_fans", "refine", "nudged_rays", "NUDGE", "MARGIN"]

_FANS = "vertex_fans"
# The nudge, relative to the scene's reach plus the origin's distance from the scene's centre.
# Rays nudged by 1e-7 of it still slipped now and then (icosphere(5), eyes at 4 radii), by 1e-6
# never; larger nudges push near-tangent rays off the mesh (1e-5: 4 of 29,759 rays aimed at
# vertices from 100 radii found no candidate, 2e-6: none).
NUDGE = 2e-6
# A re-tested hit replaces Embree's only when nearer by this fraction of Embree's distance: a
# slipped ray's hit lies a surface behind; the same surface re-tested differs by rounding.
MARGIN = 1e-4


@dataclass(frozen=True, eq=False)
class VertexFans:
    """The triangles around each vertex, over the positions Embree holds.

    Attributes
    ----------
    vertices : (V, 3) float64
        Re-centred positions rounded to float32, as Embree sees them.
    faces : (F, 3) int64
        Scene-wide vertex indices.
    points : (V,) int64
        The distinct position of each vertex (vertices at one float32 position share it).
    face_model : (F,) int32
        The model (Embree geometry) of each face.
    face_offsets : (G + 1,) int64
        First face of each model: ``prim = face - face_offsets[g]``.
    start : (P + 1,) int64
        ``around[start[p]:start[p + 1]]`` are the faces with a corner at position ``p``.
    around : (3 F,) int64
    """

    vertices: np.ndarray
    faces: np.ndarray
    points: np.ndarray
    face_model: np.ndarray
    face_offsets: np.ndarray
    start: np.ndarray
    around: np.ndarray


def _build_fans(geo) -> VertexFans:
    v32 = geo.vertices.astype(np.float32)
    # Fans join the vertices at one float32 position, whatever their index: a seam, a pole or a
    # hard crease duplicates vertices, and a ray slips between the copies' triangles just the same.
    _, point = np.unique(v32, axis=0, return_inverse=True)
    point = point.ravel().astype(np.int64)
    faces = np.ascontiguousarray(geo.faces, dtype=np.int64)
    corner = point[faces.ravel()]
    around = (np.argsort(corner, kind="stable") // 3).astype(np.int64)
    start = np.zeros(int(point.max(initial=-1)) + 2, np.int64)
    np.cumsum(np.bincount(corner, minlength=len(start) - 1), out=start[1:])
    return VertexFans(vertices=v32.astype(np.float64), faces=faces, points=point,
                      face_model=np.ascontiguousarray(geo.face_model, dtype=np.int32),
                      face_offsets=np.ascontiguousarray(geo.face_offsets, dtype=np.int64), start=start, around=around)


def vertex_fans(geometry) -> VertexFans:
    """The geometry's :class:`VertexFans` (built on first use, then kept with it)."""
    return geometry.memo(_FANS, _build_fans)


@inline_jit()  # called by kernels only: IR for them, no wrappers (common/inline.py)
def _sheared(p, o, kx, ky, kz, sx, sy, sz):
    """A vertex in the ray's frame: the ray becomes the +z axis through (0, 0).
    The same vertex always gives the same three numbers, whatever triangle asks."""
    az = p[kz] - o[kz]
    return (p[kx] - o[kx]) - sx * az, (p[ky] - o[ky]) - sy * az, sz * az


@inline_jit()  # called by kernels only: IR for them, no wrappers (common/inline.py)
def _exact_hit(verts, face, o, kx, ky, kz, sx, sy, sz):
    """Woop-Benthin-Wald watertight test of one triangle: (t, u, v), ``t = inf`` on a miss."""
    ax, ay, az = _sheared(verts[face[0]], o, kx, ky, kz, sx, sy, sz)
    bx, by, bz = _sheared(verts[face[1]], o, kx, ky, kz, sx, sy, sz)
    cx, cy, cz = _sheared(verts[face[2]], o, kx, ky, kz, sx, sy, sz)
    e0 = cx * by - cy * bx  # opposite vertex 0; exactly minus itself in the neighbour across the edge
    e1 = ax * cy - ay * cx
    e2 = bx * ay - by * ax
    if (e0 < 0.0 or e1 < 0.0 or e2 < 0.0) and (e0 > 0.0 or e1 > 0.0 or e2 > 0.0):
        return np.inf, 0.0, 0.0
    det = e0 + e1 + e2
    if det == 0.0:  # degenerate, or seen edge-on
        return np.inf, 0.0, 0.0
    return (e0 * az + e1 * bz + e2 * cz) / det, e1 / det, e2 / det


@in_parts
@njit(**KERNEL)
def _refine_kernel(fans, rays, candidates, hits, part):
    """Each ray's exact nearest hit among the triangles around its candidate.

    ``fans`` = (verts, faces, points, face_model, face_offsets, start, around) of
    :func:`vertex_fans`; ``rays`` = (origins, directions, tnear, tlimit);
    ``candidates`` = (geom, prim); ``hits`` = the (N,) ``(prim, geom, u, v, t)`` to fill."""
    verts, faces, points, face_model, face_offsets, start, around = fans
    origins, directions, tnear, tlimit = rays
    cand_geom, cand_prim = candidates
    prim, geom, u, v, t = hits
    n = origins.shape[0]
    for i in range(*share(n, part)):  # this part's share (common.parallel)
        prim[i] = -1
        geom[i] = -1
        u[i] = 0.0
        v[i] = 0.0
        t[i] = np.inf
        if cand_geom[i] < 0:
            continue
        o = origins[i]
        d = directions[i]
        kz = 0
        if abs(d[1]) > abs(d[kz]):
            kz = 1
        if abs(d[2]) > abs(d[kz]):
            kz = 2
        kx = (kz + 1) % 3  # no culling, so no winding-preserving swap of kx and ky
        ky = (kx + 1) % 3
        sx = d[kx] / d[kz]
        sy = d[ky] / d[kz]
        sz = 1.0 / d[kz]
        f0 = face_offsets[cand_geom[i]] + cand_prim[i]
        best = tlimit[i]
        for c in range(3):
            pi = points[faces[f0, c]]
            for j in range(start[pi], start[pi + 1]):
                f = around[j]
                th, uh, vh = _exact_hit(verts, faces[f], o, kx, ky, kz, sx, sy, sz)
                if tnear[i] <= th < best:
                    best = th
                    g = face_model[f]
                    geom[i] = g
                    prim[i] = np.int32(f - face_offsets[g])
                    u[i] = uh
                    v[i] = vh
                    t[i] = th


def refine(geometry, origins, directions, tnear, tlimit, candidates) -> HitBuffer:
    """The exact nearest hit of each ray among the triangles around its candidate.

    Parameters
    ----------
    geometry : SceneGeometry
    origins, directions : (N, 3) float64
        Re-centred rays (as Embree's kernels take them).
    tnear, tlimit : (N,) float64
        Only hits with ``tnear <= t < tlimit`` count.
    candidates : HitBuffer of (N,) arrays
        A hit of a nearby ray (``geom = -1``: no candidate, no re-test); the
        re-test covers every triangle sharing a vertex with it.

    Returns
    -------
    HitBuffer
        (N,) arrays: the original rays' exact hits; misses where none.
    """
    fans = vertex_fans(geometry)
    n = len(origins)
    out = HitBuffer(prim=np.empty(n, np.int32), geom=np.empty(n, np.int32), u=np.empty(n, np.float32),
                    v=np.empty(n, np.float32), t=np.empty(n, np.float32))
    if n:
        _refine_kernel((fans.vertices, fans.faces, fans.points, fans.face_model, fans.face_offsets, fans.start,
                        fans.around),
                       (np.ascontiguousarray(origins, np.float64), np.ascontiguousarray(directions, np.float64),
                        np.ascontiguousarray(tnear, np.float64), np.ascontiguousarray(tlimit, np.float64)),
                       (candidates.geom, candidates.prim), tuple(out))
        masked = (masked_hits(embree_accel(geometry).mask_data, out.geom, out.prim, out.u, out.v)
                  if masked_geometries(geometry) else np.zeros(n, np.bool_))  # Embree's filters, honoured here too
        if masked.any():
            out.prim[masked] = out.geom[masked] = -1
            out.u[masked] = out.v[masked] = 0.0
            out.t[masked] = np.inf
    return out


@in_parts
@njit(**KERNEL)
def _nudge_kernel(origins, directions, tnear, tfar, geom, t, reach, nudge, margin, out_origins, out_limit, part):
    for i in range(*share(origins.shape[0], part)):  # this part's share (common.parallel)
        o = origins[i]
        d = directions[i]
        # p = d x e_k, e_k the axis of d's smallest component: never parallel to d.
        k = 0
        if abs(d[1]) < abs(d[k]):
            k = 1
        if abs(d[2]) < abs(d[k]):
            k = 2
        if k == 0:
            px, py, pz = 0.0, d[2], -d[1]
        elif k == 1:
            px, py, pz = -d[2], 0.0, d[0]
        else:
            px, py, pz = d[1], -d[0], 0.0
        step = nudge * (reach + max(abs(o[0]), abs(o[1]), abs(o[2]))) / np.sqrt(px * px + py * py + pz * pz)
        out_origins[i, 0] = o[0] + step * px
        out_origins[i, 1] = o[1] + step * py
        out_origins[i, 2] = o[2] + step * pz
        limit = t[i] * (1.0 - margin) if geom[i] >= 0 else tfar[i]
        out_limit[i] = max(limit, tnear[i])


def nudged_rays(geometry, origins, directions, tnear, tfar, hits):
    """The second rays of the vertex repair: origins moved sideways, ``tfar`` short of the first hit.

    Parameters
    ----------
    geometry : SceneGeometry
    origins, directions : (N, 3) float64
        Re-centred rays.
    tnear, tfar : (N,) float64
    hits : HitBuffer of (N,) arrays
        The rays' first hits.

    Returns
    -------
    origins : (N, 3) float64
        ``origins + NUDGE * (reach + |origin|_inf) * p``, ``p`` a unit vector
        perpendicular to the direction (deterministic): far beyond float32
        rounding anywhere in the scene, far below its triangles.
    limit : (N,) float64
        ``t (1 - MARGIN)`` for a hit, ``tfar`` for a miss, at least ``tnear``:
        only a surface nearer than the first hit is of interest.
    """
    n = len(origins)
    out_o = np.empty((n, 3))
    limit = np.empty(n)
    _nudge_kernel(origins, directions, tnear, tfar, hits.geom, hits.t, float(geometry.reach), NUDGE, MARGIN,
                  out_o, limit)
    return out_o, limit
