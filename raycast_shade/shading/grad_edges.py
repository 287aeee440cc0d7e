"""Edge sampling (Li, Aittala, Durand and Lehtinen 2018): the gradient of the box-filtered image
where what a pixel sees changes, with respect to vertex positions and the camera pose.

A pixel of the anti-aliased image is the mean of the shade ``f`` over its square (1 by 1 in pixel
units). Where ``f`` jumps along a screen edge, moving the edge by ``dn`` along its unit normal ``n``
changes the pixel by ``(f(x - eps n) - f(x + eps n)) dn dl`` (Reynolds' transport theorem), whatever
side ``n`` points to. The edges that may carry a jump are sampled along their screen projection:

- silhouettes (one adjacent face towards the eye, one away) and boundary edges (one face);
- every edge of a flat-shaded model (faces are shaded apart), and edges where the mesh was split
  (crease splitting: the two faces share positions, not vertices) or where two models meet.

Edges are found on the positions (vertices welded where coordinates are equal). The samples are
stratified along each edge's projection, ``density`` per pixel of its length, each with a fixed
jitter from a seeded generator: the same samples on every call. At each sample two rays are cast
through ``x -/+ eps n`` (Embree, :func:`~raycast_shade.visibility.cast.cast_rays`) and shaded by
the frame's own kernels; an occluded edge sees the occluder on both sides and adds nothing. The
screen point ``x = (1 - s) A + s B`` of the projected endpoints ``A``, ``B`` moves along the normal
at ``(1 - s) n.dA + s n.dB``: :func:`edges_scatter` turns that into ``dL/dvertex`` (onto the edge's
vertices of the first face listing it) and ``dL/dcamera``, serially in sample order.

Not modelled: edges with an endpoint behind the eye (skipped), lens distortion, shadow edges
(:mod:`.grad_shadow_edges`' term, added beside this one), mirror images, and the folds where the face beside the silhouette
on screen is not the edge's own (self-intersections, grazing folds): the difference is still taken
across the sample, but the motion is the edge's.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..common.layout import CAM_EYE, CAM_FORWARD, CAM_HEIGHT, CAM_ORTHO, CAM_RIGHT, CAM_UP, CAM_WIDTH, METHOD_FLAT
from .jit import HELPER, JIT

__all__ = ["edge_candidates", "edge_topology", "edge_samples", "edges_scatter", "screen_points"]

EPS = 1e-3  # pixels either side of an edge where its two shades are taken


def _facing_signs(geo_verts, faces, fnormals, cam) -> np.ndarray:
    """+1 where a face turns to the eye, -1 away (perspective: from its centre), 0 degenerate."""
    if cam[CAM_ORTHO] != 0.0:
        towards = -cam[CAM_FORWARD:CAM_FORWARD + 3][None, :]
    else:
        towards = cam[CAM_EYE:CAM_EYE + 3][None, :] - geo_verts[faces].mean(axis=1)
    return np.sign(np.einsum("ij,ij->i", fnormals, towards))


def edge_topology(verts, faces) -> tuple:
    """The mesh's edges on its positions (vertices welded where coordinates are equal): every
    half-edge ``half`` (3F, 2) as packed vertex pairs, and per edge the first and second half-edge
    listing it (``-1``: a boundary edge's second) and how many list it. Depends on the geometry
    only (memoised on it by :func:`edge_vjp`)."""
    _, canon = np.unique(verts, axis=0, return_inverse=True)
    canon = canon.ravel()
    half = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1).reshape(-1, 2).astype(np.int64)
    key = np.sort(canon[half], axis=1)
    _, group, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    order = np.argsort(group.ravel(), kind="stable")
    starts = np.concatenate([[0], np.cumsum(count)[:-1]])
    first = order[starts]
    second = np.full(count.shape[0], -1, np.int64)
    two = count >= 2
    second[two] = order[starts[two] + 1]
    return half, first, second, count


def edge_candidates(verts, faces, fnormals, face_model, modes, cam, topology=None) -> tuple:
    """The edges that may carry a jump of the shade (the module's list), as packed vertex pairs.

    Parameters
    ----------
    verts : (V, 3) float64
    faces : (F, 3) int
    fnormals : (F, 3) float64
    face_model : (F,) int
    modes : (G,) int8
        Each model's method code.
    cam : (CAM_SIZE,) float64
    topology : tuple, optional
        :func:`edge_topology` of ``verts, faces`` when at hand.

    Returns
    -------
    edges : (E, 2) int64
        Each edge once, as the vertex indices of the first face listing it.
    sides : (E, 2) int64
        The faces listing it (the first two; ``-1`` for a boundary edge's second).
    """
    if faces.shape[0] == 0:
        return np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64)
    half, first, second, count = edge_topology(verts, faces) if topology is None else topology
    two = second >= 0
    other = np.where(two, second, first)
    fa, fb = first // 3, other // 3
    sign = _facing_signs(verts, faces, fnormals, cam)
    keep = count != 2
    keep |= sign[fa] != sign[fb]
    keep |= modes[face_model[fa]] == METHOD_FLAT
    keep |= face_model[fa] != face_model[fb]
    keep |= np.any(np.sort(half[first], axis=1) != np.sort(half[other], axis=1), axis=1)  # split: other vertices
    sides = np.stack([fa, np.where(two, fb, -1)], axis=1)
    return half[first[keep]], sides[keep]


def screen_points(cam, points) -> tuple:
    """Image coordinates ``(X, Y)`` (pixel units, pixel ``(x, y)`` covering ``[x, x + 1)``) and the
    depth along the forward axis of each row of ``points`` (N, 3), re-centred like ``cam``."""
    R, U, F = cam[CAM_RIGHT:CAM_RIGHT + 3], cam[CAM_UP:CAM_UP + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    q = points - cam[CAM_EYE:CAM_EYE + 3]
    fwd = F if cam[CAM_ORTHO] != 0.0 else F - (F @ R) / (R @ R) * R - (F @ U) / (U @ U) * U
    c = q @ fwd
    if cam[CAM_ORTHO] != 0.0:
        sx, sy = (q @ R) / (R @ R), (q @ U) / (U @ U)
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            sx = ((q @ R) / c - F @ R) / (R @ R)
            sy = ((q @ U) / c - F @ U) / (U @ U)
    return (sx + 1.0) * 0.5 * cam[CAM_WIDTH], (1.0 - sy) * 0.5 * cam[CAM_HEIGHT], c


def edge_samples(verts, edges, sides, cam, density: float, seed: int) -> dict:
    """Stratified, jittered samples along the edges' projections, inside the image.

    Returns
    -------
    dict
        ``edge`` (N, 2) int64 vertex pairs, ``faces`` (N, 2) their faces (:func:`edge_candidates`), ``s`` (N,) the screen parameter, ``normal`` (N, 2) the
        unit screen normal, ``weight`` (N,) its share of the edge's length in pixels, ``pixel`` (N, 2)
        int64 ``(x, y)``, ``point`` (N, 2) the image coordinates.
    """
    w, h = int(cam[CAM_WIDTH]), int(cam[CAM_HEIGHT])
    ends = verts[edges.reshape(-1)]
    X, Y, depth = screen_points(cam, ends)
    X, Y, depth = X.reshape(-1, 2), Y.reshape(-1, 2), depth.reshape(-1, 2)
    ortho = cam[CAM_ORTHO] != 0.0
    ok = np.all(np.isfinite(X) & np.isfinite(Y), axis=1) & (ortho | np.all(depth > 0.0, axis=1))
    dx, dy = X[:, 1] - X[:, 0], Y[:, 1] - Y[:, 0]
    length = np.hypot(dx, dy)
    # an edge far outside the image gets no samples (its box misses the image)
    inside = (np.minimum(X[:, 0], X[:, 1]) < w) & (np.maximum(X[:, 0], X[:, 1]) > 0) & \
             (np.minimum(Y[:, 0], Y[:, 1]) < h) & (np.maximum(Y[:, 0], Y[:, 1]) > 0)
    ok &= inside & (length > 0.0)
    idx = np.flatnonzero(ok)
    n = np.ceil(length[idx] * density).astype(np.int64)
    n = np.maximum(n, 1)
    e = np.repeat(idx, n)
    j = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    jitter = np.random.default_rng(seed).random(e.shape[0])
    s = (j + jitter) / np.repeat(n, n)
    px = X[e, 0] + s * dx[e]
    py = Y[e, 0] + s * dy[e]
    normal = np.stack([-dy[e], dx[e]], axis=1) / length[e][:, None]
    weight = length[e] / np.repeat(n, n)
    pix = np.stack([np.floor(px), np.floor(py)], axis=1)
    seen = (pix[:, 0] >= 0) & (pix[:, 0] < w) & (pix[:, 1] >= 0) & (pix[:, 1] < h)
    return {"edge": edges[e[seen]], "faces": sides[e[seen]], "s": s[seen], "normal": normal[seen], "weight": weight[seen],
            "pixel": pix[seen].astype(np.int64), "point": np.stack([px, py], axis=1)[seen]}


def side_rays(cam, origin, point, normal) -> tuple:
    """World rays through image points ``point -/+ EPS normal`` (2N rays: the minus sides first)."""
    pts = np.concatenate([point - EPS * normal, point + EPS * normal])
    sx = 2.0 * pts[:, 0] / cam[CAM_WIDTH] - 1.0
    sy = 1.0 - 2.0 * pts[:, 1] / cam[CAM_HEIGHT]
    R, U, F = cam[CAM_RIGHT:CAM_RIGHT + 3], cam[CAM_UP:CAM_UP + 3], cam[CAM_FORWARD:CAM_FORWARD + 3]
    eye = cam[CAM_EYE:CAM_EYE + 3] + origin
    if cam[CAM_ORTHO] != 0.0:
        return eye + sx[:, None] * R + sy[:, None] * U, np.broadcast_to(F, pts.shape[:1] + (3,)).copy()
    d = F + sx[:, None] * R + sy[:, None] * U
    return np.broadcast_to(eye, d.shape).copy(), d / np.linalg.norm(d, axis=1, keepdims=True)


@njit(**HELPER)
def _screen_jacobian(cam, q):
    """``dX/dq`` and ``dY/dq`` (3-tuples) of the image coordinates of ``eye + q``."""
    R = (cam[CAM_RIGHT + 0], cam[CAM_RIGHT + 1], cam[CAM_RIGHT + 2])
    U = (cam[CAM_UP + 0], cam[CAM_UP + 1], cam[CAM_UP + 2])
    F = (cam[CAM_FORWARD + 0], cam[CAM_FORWARD + 1], cam[CAM_FORWARD + 2])
    rr = R[0] * R[0] + R[1] * R[1] + R[2] * R[2]
    uu = U[0] * U[0] + U[1] * U[1] + U[2] * U[2]
    kx = 0.5 * cam[CAM_WIDTH] / rr
    ky = -0.5 * cam[CAM_HEIGHT] / uu
    if cam[CAM_ORTHO] != 0.0:
        return (kx * R[0], kx * R[1], kx * R[2]), (ky * U[0], ky * U[1], ky * U[2])
    fr = (F[0] * R[0] + F[1] * R[1] + F[2] * R[2]) / rr
    fu = (F[0] * U[0] + F[1] * U[1] + F[2] * U[2]) / uu
    f = (F[0] - fr * R[0] - fu * U[0], F[1] - fr * R[1] - fu * U[1], F[2] - fr * R[2] - fu * U[2])
    c = q[0] * f[0] + q[1] * f[1] + q[2] * f[2]
    a = q[0] * R[0] + q[1] * R[1] + q[2] * R[2]
    b = q[0] * U[0] + q[1] * U[1] + q[2] * U[2]
    ax, bx = kx / c, kx * a / (c * c)
    ay, by = ky / c, ky * b / (c * c)
    return ((ax * R[0] - bx * f[0], ax * R[1] - bx * f[1], ax * R[2] - bx * f[2]),
            (ay * U[0] - by * f[0], ay * U[1] - by * f[1], ay * U[2] - by * f[2]))


@njit(**JIT)
def edges_scatter(cam, verts, edge, s, normal, coef, gverts, gcam):
    """Serially, in sample order: sample ``k``'s ``coef[k] = weight gI . (f- - f+)`` times the
    normal motion ``(1 - s) n.dA + s n.dB`` of its edge's projected endpoints, onto the endpoints'
    vertices and the camera (eye, left rotation: ``dL/dw = dL/dq x q`` for ``q = P - eye``)."""
    for k in range(edge.shape[0]):
        if coef[k] == 0.0:
            continue
        for end in range(2):
            i = edge[k, end]
            wk = coef[k] * (s[k] if end == 1 else 1.0 - s[k])
            q = (verts[i, 0] - cam[CAM_EYE + 0], verts[i, 1] - cam[CAM_EYE + 1], verts[i, 2] - cam[CAM_EYE + 2])
            jx, jy = _screen_jacobian(cam, q)
            g = (wk * (normal[k, 0] * jx[0] + normal[k, 1] * jy[0]), wk * (normal[k, 0] * jx[1] + normal[k, 1] * jy[1]),
                 wk * (normal[k, 0] * jx[2] + normal[k, 1] * jy[2]))
            for c in range(3):
                gverts[i, c] += g[c]
                gcam[c] -= g[c]
            gcam[3] += g[1] * q[2] - g[2] * q[1]
            gcam[4] += g[2] * q[0] - g[0] * q[2]
            gcam[5] += g[0] * q[1] - g[1] * q[0]


def edge_vjp(scene, camera, inputs, modes, gimg, shading, density: float = 4.0, seed: int = 0):
    """The edge term of ``dL/dvertices`` (V, 3) and ``dL/dcamera`` (6,) for ``gimg = dL/dI`` (H, W, 3)
    of the box-filtered image: samples, their side shades (cast and shaded by the library's
    kernels), and :func:`edges_scatter`. Also returns the number of samples."""
    from ..visibility.cast import cast_rays
    from ..visibility.hits import HitBuffer
    from .shade import SampleShading

    G, cam, geo = inputs.geometry, inputs.cam, scene.geometry
    gverts = np.zeros(G.verts.shape)
    gcam = np.zeros(6)
    topology = geo.memo("grad_edges.topology", lambda g: edge_topology(g.vertices, g.faces))
    edges, sides = edge_candidates(G.verts, G.faces, G.face_normals, geo.face_model, modes, cam, topology)
    smp = edge_samples(G.verts, edges, sides, cam, density, seed)
    n = smp["s"].shape[0]
    if n == 0:
        return gverts, gcam, 0
    gI = gimg[smp["pixel"][:, 1], smp["pixel"][:, 0]]
    live = np.any(gI != 0.0, axis=1)
    if not np.any(live):  # dL/dI is 0 wherever an edge is
        return gverts, gcam, n
    o, d = side_rays(cam, geo.origin, smp["point"][live], smp["normal"][live])
    hits = cast_rays(geo, o, d)
    hits2 = HitBuffer(*(a.reshape(1, -1) for a in hits))
    f = SampleShading(scene, camera, shading, inputs=inputs).shade(hits2)[0].astype(np.float64)
    m = int(live.sum())
    # the edge is what the sample sees only if one side shows one of its faces (else it is hidden)
    face = np.where(hits.prim >= 0, geo.face_offsets[np.maximum(hits.geom, 0)] + hits.prim, -2)
    own = smp["faces"][live]
    visible = np.any(face[:m, None] == own, axis=1) | np.any(face[m:, None] == own, axis=1)
    coef = np.zeros(n)
    coef[live] = np.where(visible, smp["weight"][live] * np.einsum("ij,ij->i", gI[live], f[:m] - f[m:]), 0.0)
    edges_scatter(cam, G.verts, smp["edge"], smp["s"], smp["normal"], coef, gverts, gcam)
    return gverts, gcam, n
