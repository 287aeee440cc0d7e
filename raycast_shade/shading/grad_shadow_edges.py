"""Edge sampling at hard shadows' outlines: the gradient of the box-filtered image where a
pixel's point crosses from lit to shadowed, with respect to vertex positions, the camera pose and
the lights' positions (or directions).

A point, spot or directional light's shadow is bounded on a receiver by the shadow of the
occluders' silhouettes **as seen from the light** (edges between a face towards the light and
one away, and boundary edges). For one such edge ``P0 P1`` and a parameter ``s``, the light's
ray through ``Q = (1 - s) P0 + s P1`` hits the receiver at ``R = O + t D`` (point light:
``O = L``, ``D = Q - L``; directional: ``O = Q``, ``D`` the light's direction), with ``t`` from
the receiver triangle's plane ``(V0, V1, V2)``. ``R``'s screen image ``X(s)`` is a curve along
which the shade jumps, and moving it by ``dn`` along its screen normal ``n`` changes a pixel by
``(f(x - eps n) - f(x + eps n)) dn dl`` (as :mod:`.grad_edges`, in the image plane: a point
light has no integral over its surface, so Li et al. 2018's secondary edges reduce to the
primary integral's boundary). The integral over the curve is sampled in ``s``, stratified with
a seeded jitter, each sample weighted by ``|dX/ds| / n``: unbiased whatever ``n`` per edge,
which is chosen from a coarse polyline of the curve (``density`` per pixel of its length).

At each sample two camera rays through ``x -/+ eps n`` are cast and shaded by the frame's own
kernels (shadow rays included): an outline hidden from the camera (the sides see another face
than the receiver's), one in another shadow or outside a spot's cone (no jump) adds nothing.
``n.dX`` is chained back through the projection (camera eye and rotation), the plane
intersection (the receiver's three vertices), the light ray (the light's position or direction)
and ``Q`` (the edge's endpoints), in NumPy, summed in sample order (``np.add.at``: the same sums
on every run and any number of threads).

Not modelled: area lights (soft shadows; ignored with a warning), shadows seen in mirrors (a
mirror's reflected image gets no edge term), the endpoints where an outline changes edges (a set of measure zero, but where an
occluder touches its receiver the outline's samples fall on the contact and the term is
unreliable), receivers lit at grazing angles (self-shadowing at the terminator, where ``t`` and
``|dX/ds|`` blow up), and outlines whose receiver changes within one light ray (the plane is the
hit triangle's, its neighbours' motion is not chained).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..common.layout import (CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_UP, CAM_WIDTH, LIGHT_AREA,
                             LIGHT_DIRECTIONAL, LIGHT_KIND, LIGHT_POINT, LIGHT_SAMPLES, LIGHT_SHADOWS, LIGHT_SPOT,
                             LIGHT_VEC)
from ..common.stack import user_stacklevel
from .grad_edges import edge_topology, screen_points, side_rays

__all__ = ["light_silhouettes", "screen_jacobians", "plane_hit_vjp", "shadow_edge_vjp", "COARSE"]

COARSE = 8
"""Segments of the coarse polyline along each outline that chooses its number of samples."""

_NEAR = 1e-6  # of the scene's diagonal: where a light ray past the edge starts (skips the edge's faces)


def light_silhouettes(verts, faces, topology, light_row) -> tuple:
    """The edges of ``faces`` that bound the shadow of ``light_row``'s light: one adjacent face
    towards the light and one away (from its centre for a point or spot light), boundary and
    non-manifold edges.

    Parameters
    ----------
    verts : (V, 3) float64
        Re-centred positions.
    faces : (F, 3) int
    topology : tuple
        :func:`~raycast_shade.shading.grad_edges.edge_topology` of ``verts, faces``.
    light_row : (LIGHT_SIZE,) float64

    Returns
    -------
    edges : (E, 2) int64
        Vertex pairs, as the first face listing each edge.
    """
    half, first, second, count = topology
    p = verts[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    vec = light_row[LIGHT_VEC:LIGHT_VEC + 3]
    towards = vec[None, :] if light_row[LIGHT_KIND] == LIGHT_DIRECTIONAL else vec[None, :] - p.mean(axis=1)
    sign = np.sign(np.einsum("ij,ij->i", normal, towards))
    other = np.where(second >= 0, second, first)
    keep = (count != 2) | (sign[first // 3] != sign[other // 3])
    return half[first[keep]]


def screen_jacobians(cam, q) -> np.ndarray:
    """``dX/dq`` and ``dY/dq`` of the image coordinates of ``eye + q`` for each row of ``q``.

    Parameters
    ----------
    cam : (CAM_SIZE,) float64
    q : (N, 3) float64

    Returns
    -------
    (N, 2, 3) float64
        Row 0 ``dX/dq``, row 1 ``dY/dq`` (pixel units per world unit).
    """
    R, U, F = cam[CAM_RIGHT:CAM_RIGHT + 3], cam[CAM_UP:CAM_UP + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    rr, uu = R @ R, U @ U
    kx, ky = 0.5 * cam[CAM_WIDTH] / rr, -0.5 * cam[CAM_HEIGHT] / uu
    out = np.empty((q.shape[0], 2, 3))
    if cam[CAM_ORTHO] != 0.0:
        out[:, 0] = kx * R
        out[:, 1] = ky * U
        return out
    f = F - (F @ R) / rr * R - (F @ U) / uu * U
    c, a, b = q @ f, q @ R, q @ U
    out[:, 0] = (kx / c)[:, None] * R - (kx * a / (c * c))[:, None] * f
    out[:, 1] = (ky / c)[:, None] * U - (ky * b / (c * c))[:, None] * f
    return out


def plane_hit_vjp(g, O, D, V0, V1, V2) -> tuple:
    """Back through ``R = O + t D`` on the plane of ``(V0, V1, V2)``: given ``g = dL/dR``, the
    gradients with respect to ``O``, ``D`` and the three vertices (all (N, 3) arrays).

    ``t = ((V0 - O).N) / (D.N)`` with ``N = (V1 - V0) x (V2 - V0)``; with ``c = (g.D) / (D.N)``
    and ``h = g - c N``: ``dL/dO = h``, ``dL/dD = t h``, and the plane's normal and offset take
    ``m = c (V0 - R)`` through ``N`` and ``c N`` onto ``V0``.
    """
    e1, e2 = V1 - V0, V2 - V0
    N = np.cross(e1, e2)
    b = np.einsum("ij,ij->i", D, N)
    t = np.einsum("ij,ij->i", V0 - O, N) / b
    R = O + t[:, None] * D
    c = np.einsum("ij,ij->i", g, D) / b
    h = g - c[:, None] * N
    m = c[:, None] * (V0 - R)
    g1, g2 = np.cross(e2, m), np.cross(m, e1)
    return h, t[:, None] * h, c[:, None] * N - g1 - g2, g1, g2


def _light_rays(row, Q):
    """Origins and unit directions of ``row``'s light rays through the points ``Q`` (N, 3)."""
    if row[LIGHT_KIND] == LIGHT_DIRECTIONAL:
        d = -row[LIGHT_VEC:LIGHT_VEC + 3]
        return Q, np.broadcast_to(d / np.linalg.norm(d), Q.shape)
    D = Q - row[LIGHT_VEC:LIGHT_VEC + 3]
    return Q, D / np.linalg.norm(D, axis=1, keepdims=True)


def _receivers(geo, G, row, P0, P1, s):
    """Where ``row``'s light rays through ``(1 - s) P0 + s P1`` land past the edge: the receiver
    face (``-1``: nothing) and the point ``R`` on its plane, in float64 (re-centred)."""
    from ..visibility.cast import cast_rays

    Q = (1.0 - s)[:, None] * P0 + s[:, None] * P1
    o, d = _light_rays(row, Q)
    hits = cast_rays(geo, o + geo.origin, np.ascontiguousarray(d), tnear=_NEAR * geo.scale)
    face = np.where(hits.prim >= 0, geo.face_offsets[np.maximum(hits.geom, 0)] + hits.prim, -1)
    V = G.verts[G.faces[np.maximum(face, 0)]]
    N = np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", V[:, 0] - o, N) / np.einsum("ij,ij->i", d, N)
    face = np.where(np.isfinite(t), face, -1)
    return face, o + np.where(np.isfinite(t), t, 0.0)[:, None] * d


def _in_image(cam, X, Y, margin=1.0):
    return (X > -margin) & (X < cam[CAM_WIDTH] + margin) & (Y > -margin) & (Y < cam[CAM_HEIGHT] + margin)


def _outline_samples(geo, G, cam, row, edges, density, rng):
    """The light's outlines on their receivers, sampled: per sample the edge, ``s``, the receiver
    face and ``R`` (after a coarse pass of ``COARSE`` segments per edge choosing the counts)."""
    E = edges.shape[0]
    sc = np.tile(np.linspace(0.0, 1.0, COARSE + 1), E)
    ec = np.repeat(np.arange(E), COARSE + 1)
    face, R = _receivers(geo, G, row, G.verts[edges[ec, 0]], G.verts[edges[ec, 1]], sc)
    X, Y, depth = screen_points(cam, R)
    ok = (face >= 0) & np.isfinite(X) & np.isfinite(Y) & ((cam[CAM_ORTHO] != 0.0) | (depth > 0.0))
    inside = ok & _in_image(cam, X, Y)
    ok, inside = ok.reshape(E, -1), inside.reshape(E, -1)
    X, Y = X.reshape(E, -1), Y.reshape(E, -1)
    seg = np.where(ok[:, 1:] & ok[:, :-1] & (inside[:, 1:] | inside[:, :-1]),
                   np.hypot(np.diff(X, axis=1), np.diff(Y, axis=1)), 0.0)
    seen = np.any(inside, axis=1)
    n = np.where(seen, np.maximum(np.ceil(np.nan_to_num(seg.sum(axis=1)) * density), 1.0), 0.0).astype(np.int64)
    e = np.repeat(np.arange(E), n)
    j = np.arange(e.shape[0]) - np.repeat(np.cumsum(n) - n, n)
    s = (j + rng.random(e.shape[0])) / n[e]
    face, R = _receivers(geo, G, row, G.verts[edges[e, 0]], G.verts[edges[e, 1]], s)
    return e, s, n[e], face, R


def _warn_area(scene, lights) -> None:
    names = [light.name for i, light in enumerate(scene.lights)
             if lights[i, LIGHT_SHADOWS] != 0 and (lights[i, LIGHT_KIND] == LIGHT_AREA or lights[i, LIGHT_SAMPLES] > 1)]
    if names:
        warnings.warn(f"edges=True: the soft shadows of area light(s) {', '.join(map(repr, names))} have no edge "
                      "term (only point, spot and directional lights' hard shadows are sampled)", UserWarning,
                      stacklevel=user_stacklevel())


def shadow_edge_vjp(scene, camera, inputs, gimg, shading, density: float = 4.0, seed: int = 0):
    """The shadow outlines' term of ``dL/dvertices`` (V, 3), ``dL/dcamera`` (6,: eye, rotation about
    the camera row's eye) and ``dL/d(light row vector)`` (L, 3: a point or spot light's position, a
    directional light's ``-direction``) for ``gimg = dL/dI`` (H, W, 3) of the box-filtered image,
    over every light that casts shadows (area lights warned of and skipped). Also returns the
    number of samples."""
    from ..visibility.cast import cast_rays
    from ..visibility.hits import HitBuffer
    from .shade import SampleShading

    G, cam, geo = inputs.geometry, inputs.cam, scene.geometry
    lights = inputs.lighting.lights
    gverts, gcam, glight = np.zeros(G.verts.shape), np.zeros(6), np.zeros((lights.shape[0], 3))
    _warn_area(scene, lights)
    hard = [i for i in range(lights.shape[0]) if lights[i, LIGHT_SHADOWS] != 0 and lights[i, LIGHT_SAMPLES] == 1
            and lights[i, LIGHT_KIND] in (LIGHT_POINT, LIGHT_SPOT, LIGHT_DIRECTIONAL)]
    if not hard or G.faces.shape[0] == 0:
        return gverts, gcam, glight, 0
    if camera.distorted:
        raise ValueError("scene.camera: no shadow-edge gradients through lens distortion yet (a pinhole camera has)")
    topology = geo.memo("grad_edges.topology", lambda g: edge_topology(g.vertices, g.faces))
    rng = np.random.default_rng(seed)
    shader = SampleShading(scene, camera, shading, inputs=inputs)
    total = 0
    for li in hard:  # light by light, in order: the sums' order is fixed
        row = lights[li]
        edges = light_silhouettes(G.verts, G.faces, topology, row)
        if edges.shape[0] == 0:
            continue
        e, s, n, face, R = _outline_samples(geo, G, cam, row, edges, density, rng)
        total += e.shape[0]
        X, Y, depth = screen_points(cam, R)
        pix = np.stack([np.floor(X), np.floor(Y)], axis=1)
        keep = (face >= 0) & np.all(np.isfinite(pix), axis=1) & ((cam[CAM_ORTHO] != 0.0) | (depth > 0.0))
        keep &= (pix[:, 0] >= 0) & (pix[:, 0] < cam[CAM_WIDTH]) & (pix[:, 1] >= 0) & (pix[:, 1] < cam[CAM_HEIGHT])
        idx = np.flatnonzero(keep)
        if idx.shape[0] == 0:
            continue
        pix = pix[idx].astype(np.int64)
        gI = gimg[pix[:, 1], pix[:, 0]]
        live = np.any(gI != 0.0, axis=1)
        idx, pix, gI = idx[live], pix[live], gI[live]
        if idx.shape[0] == 0:
            continue
        P0, P1 = G.verts[edges[e[idx], 0]], G.verts[edges[e[idx], 1]]
        si, Ri, fi = s[idx], R[idx], face[idx]
        V = G.verts[G.faces[fi]]
        Q = (1.0 - si)[:, None] * P0 + si[:, None] * P1
        point = row[LIGHT_KIND] != LIGHT_DIRECTIONAL
        O = np.broadcast_to(row[LIGHT_VEC:LIGHT_VEC + 3], Q.shape) if point else Q
        D = Q - O if point else np.broadcast_to(-row[LIGHT_VEC:LIGHT_VEC + 3], Q.shape)
        N = np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0])
        b = np.einsum("ij,ij->i", D, N)
        t = np.einsum("ij,ij->i", V[:, 0] - O, N) / b
        Edir = P1 - P0
        dRds = (t[:, None] if point else 1.0) * (Edir - D * (np.einsum("ij,ij->i", Edir, N) / b)[:, None])
        q = Ri - cam[CAM_EYE:CAM_EYE + 3]
        J = screen_jacobians(cam, q)
        T = np.einsum("nij,nj->ni", J, dRds)
        length = np.hypot(T[:, 0], T[:, 1])
        good = np.isfinite(length) & (length > 0.0)
        normal = np.stack([-T[:, 1], T[:, 0]], axis=1) / np.where(good, length, 1.0)[:, None]
        point_xy = np.stack([X[idx], Y[idx]], axis=1)
        o, d = side_rays(cam, geo.origin, point_xy, normal)
        hits = cast_rays(geo, o, d)
        f = shader.shade(HitBuffer(*(a.reshape(1, -1) for a in hits)))[0].astype(np.float64)
        m = idx.shape[0]
        seen = np.where(hits.prim >= 0, geo.face_offsets[np.maximum(hits.geom, 0)] + hits.prim, -2)
        visible = (seen[:m] == fi) | (seen[m:] == fi)  # the outline is what the sample sees
        coef = np.where(good & visible, length / n[idx] * np.einsum("ij,ij->i", gI, f[:m] - f[m:]), 0.0)
        g = coef[:, None] * np.einsum("ni,nij->nj", normal, J)  # dL/dR, the camera held
        gcam[:3] -= g.sum(axis=0)
        gcam[3:] += np.cross(g, q).sum(axis=0)
        gO, gD, g0, g1, g2 = plane_hit_vjp(g, O, D, V[:, 0], V[:, 1], V[:, 2])
        if point:  # O = L, D = Q - L
            gQ = gD
            glight[li] += (gO - gD).sum(axis=0)
        else:  # O = Q, D = -(row vector)
            gQ = gO
            glight[li] -= gD.sum(axis=0)
        tri = G.faces[fi]
        for k, gk in enumerate((g0, g1, g2)):
            np.add.at(gverts, tri[:, k], gk)
        np.add.at(gverts, edges[e[idx], 0], (1.0 - si)[:, None] * gQ)
        np.add.at(gverts, edges[e[idx], 1], si[:, None] * gQ)
    return gverts, gcam, glight, total
