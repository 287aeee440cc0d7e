"""Face normals and averaged vertex normals, with a crease angle.

The lecture's Gouraud normal is "the average of the normals of the polygons
that meet at a vertex". Three weightings are offered (uniform, area, angle);
zero-area faces carry no direction and are left out of every average, so a
sliver cannot poison its neighbours. With a crease angle, each face corner
averages only the faces within that angle of its own face, and vertices are
split where their corners disagree: a cube with a 30 degree crease stays a cube.

Right-hand face normals only average well when neighbouring faces are wound
the same way; :func:`winding_conflicts` counts the edges where they are not,
so that :class:`~raycast_shade.scene.mesh.Mesh` can warn instead of rendering
cancelled normals without a word.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..common.inline import inline_jit
from ..common.parallel import KERNEL, in_parts, share

__all__ = ["face_normals", "vertex_normals", "winding_conflicts", "reversed_duplicates", "WindingWarning", "WEIGHTINGS"]

from ..common.choices import WEIGHTINGS
from ..common.validate import as_array
from ..common.warnings import ShadingWarning
_WEIGHT_CODE = {"uniform": 0, "area": 1, "angle": 2}


@inline_jit()  # called by kernels only: IR for them, no wrappers (common/inline.py)
def _corner(vertices, p, q, r):
    """At corner ``p`` of triangle (p, q, r), with a = q - p and b = r - p:
    a x b (3 floats), |a|^2, |b|^2 and a.b."""
    a0 = vertices[q, 0] - vertices[p, 0]
    a1 = vertices[q, 1] - vertices[p, 1]
    a2 = vertices[q, 2] - vertices[p, 2]
    b0 = vertices[r, 0] - vertices[p, 0]
    b1 = vertices[r, 1] - vertices[p, 1]
    b2 = vertices[r, 2] - vertices[p, 2]
    return (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0,
            a0 * a0 + a1 * a1 + a2 * a2, b0 * b0 + b1 * b1 + b2 * b2, a0 * b0 + a1 * b1 + a2 * b2)


def _faces_kernel(vertices, faces, weighting):
    """Face normals, areas and corner weights in one pass over the faces.

    ``weighting``: 0 uniform, 1 area, 2 angle (see the twin
    :func:`raycast_shade.study.twins.corner_weights_numpy`, whose arithmetic this follows).
    A degenerate face keeps zero normal, area and weights.
    """
    nf = faces.shape[0]
    normals = np.zeros((nf, 3), np.float64)
    areas = np.zeros(nf, np.float64)
    weights = np.zeros((nf, 3), np.float64)
    _faces_parts(vertices, faces, weighting, normals, areas, weights)
    return normals, areas, weights


@in_parts
@njit(**KERNEL)
def _faces_parts(vertices, faces, weighting, normals, areas, weights, part):
    """:func:`_faces_kernel`'s pass over this part's faces, into the zeroed outputs."""
    f0, f1 = share(faces.shape[0], part)
    for f in range(f0, f1):
        c0, c1, c2, ea, eb, dot = _corner(vertices, faces[f, 0], faces[f, 1], faces[f, 2])
        length = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        # Relative threshold: degenerate when the cross product is tiny next
        # to the edge lengths (float64 rounding of collinear points).
        scale = max(ea, eb)
        if not length > 1e-14 * scale:
            continue  # zero normal, area and weights
        normals[f, 0] = c0 / length
        normals[f, 1] = c1 / length
        normals[f, 2] = c2 / length
        areas[f] = 0.5 * length
        for k in range(3):
            if weighting == 0:
                weights[f, k] = 1.0
            elif weighting == 1:
                weights[f, k] = 0.5 * length
            else:  # the angle at corner k, robust form atan2(|a x b|, a.b)
                x0, x1, x2, _, _, dot = _corner(vertices, faces[f, k], faces[f, (k + 1) % 3], faces[f, (k + 2) % 3])
                weights[f, k] = math.atan2(math.sqrt(x0 * x0 + x1 * x1 + x2 * x2), dot)


def face_normals(vertices: np.ndarray, faces: np.ndarray):
    """Unit face normals by the right-hand rule, and face areas.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int

    Returns
    -------
    normals : (F, 3) float64
        Unit normals; exactly zero for zero-area faces.
    areas : (F,) float64
    """
    normals, areas, _ = _faces_kernel(np.asarray(vertices, np.float64), np.asarray(faces, np.int64), 0)
    return normals, areas


@njit(cache=True)
def _corners_by_vertex(faces, nv):
    """Corners grouped by vertex: a stable counting sort, O(F).

    Returns ``order`` (3F,), corner ids ``3 f + k`` equal to
    ``np.argsort(faces.ravel(), kind="stable")``; ``starts`` (V + 1,), so that
    vertex v's corners are ``order[starts[v]:starts[v + 1]]``; and, in the same
    order, each corner's ``dest`` (the next vertex around its face: the corner
    is the directed edge v -> dest) and ``third`` vertex (3F,), written here
    from face order because gathering them afterwards costs twice as much.
    """
    nf = faces.shape[0]
    starts = np.zeros(nv + 1, np.int64)
    for f in range(nf):
        for k in range(3):
            starts[faces[f, k] + 1] += 1
    for v in range(nv):
        starts[v + 1] += starts[v]
    fill = starts[:-1].copy()
    order = np.empty(3 * nf, np.int64)
    dest = np.empty(3 * nf, np.int64)
    third = np.empty(3 * nf, np.int64)
    for f in range(nf):
        for k in range(3):
            i = fill[faces[f, k]]
            order[i] = 3 * f + k
            dest[i] = faces[f, (k + 1) % 3]
            third[i] = faces[f, (k + 2) % 3]
            fill[faces[f, k]] = i + 1
    return order, starts, dest, third


@njit(cache=True)
def _accumulate_kernel(faces, fnormals, weights, nv):
    """(V, 3) sum of weighted face normals at each vertex.

    Summed corner slot by corner slot, each in face order, as
    ``np.bincount`` over ``faces[:, k]`` does (the twin in the tests).
    """
    acc = np.zeros((nv, 3), np.float64)
    part = np.empty((nv, 3), np.float64)
    for k in range(3):
        part[:] = 0.0
        for f in range(faces.shape[0]):
            v = faces[f, k]
            for c in range(3):
                part[v, c] += fnormals[f, c] * weights[f, k]
        for v in range(nv):
            for c in range(3):
                acc[v, c] += part[v, c]
    return acc


@njit(cache=True)
def _corner_normals_kernel(faces, fnormals, weights, order, starts, cos_crease):
    """Sum, for each corner, the weighted normals of the faces at its vertex
    that lie within the crease angle of the corner's own face."""
    nf = faces.shape[0]
    out = np.zeros((nf * 3, 3), np.float64)
    nv = starts.shape[0] - 1
    for v in range(nv):
        lo = starts[v]
        hi = starts[v + 1]
        for a in range(lo, hi):
            ca = order[a]
            fa = ca // 3
            na0 = fnormals[fa, 0]
            na1 = fnormals[fa, 1]
            na2 = fnormals[fa, 2]
            own_zero = na0 == 0.0 and na1 == 0.0 and na2 == 0.0
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for b in range(lo, hi):
                cb = order[b]
                fb = cb // 3
                w = weights[fb, cb % 3]
                if w == 0.0:
                    continue
                # A zero-area face has no direction of its own: it takes the
                # plain average of its neighbours.
                if not own_zero:
                    c = na0 * fnormals[fb, 0] + na1 * fnormals[fb, 1] + na2 * fnormals[fb, 2]
                    if c < cos_crease:
                        continue
                s0 += w * fnormals[fb, 0]
                s1 += w * fnormals[fb, 1]
                s2 += w * fnormals[fb, 2]
            out[ca, 0] = s0
            out[ca, 1] = s1
            out[ca, 2] = s2
    return out


@njit(cache=True)
def _split_kernel(corner_normals, order, starts):
    """Give every (vertex, distinct corner normal) pair its own new vertex.

    Returns the new vertex index of each corner and, for each new vertex, the
    original vertex it copies.
    """
    nc = corner_normals.shape[0]
    new_index = np.empty(nc, np.int64)
    source = np.empty(nc + starts.shape[0], np.int64)
    count = 0
    nv = starts.shape[0] - 1
    for v in range(nv):
        lo = starts[v]
        hi = starts[v + 1]
        for a in range(lo, hi):
            ca = order[a]
            found = -1
            for b in range(lo, a):
                cb = order[b]
                if (
                    corner_normals[cb, 0] == corner_normals[ca, 0]
                    and corner_normals[cb, 1] == corner_normals[ca, 1]
                    and corner_normals[cb, 2] == corner_normals[ca, 2]
                ):
                    found = new_index[cb]
                    break
            if found >= 0:
                new_index[ca] = found
            else:
                new_index[ca] = count
                source[count] = v
                count += 1
        if hi == lo:  # unreferenced vertex: keep it so indices stay meaningful
            source[count] = v
            count += 1
    return new_index, source[:count]


class WindingWarning(ShadingWarning):
    """Computed vertex normals meet faces wound in opposite directions (a
    :class:`UserWarning`, like every :class:`ShadingWarning`)."""


@njit(cache=True)
def _winding_conflicts_kernel(order, starts, dest, third, valid):
    """Count edges that exactly two distinct valid faces traverse, both a -> b.

    The corners come grouped by vertex a (:func:`_corners_by_vertex`); a vertex
    has few, so they are compared directly. Repeats of a face (same third
    vertex) count once. Edges with three or more faces (non-manifold: fins,
    internal walls) are left out: no winding makes them consistent, and
    fixing the winding would not help.
    """
    conflicts = 0
    for a in range(starts.shape[0] - 1):
        for i in range(starts[a], starts[a + 1]):
            if not valid[order[i] // 3]:
                continue
            b = dest[i]
            first = True  # count each directed edge once, at its first valid corner
            for j in range(starts[a], i):
                if valid[order[j] // 3] and dest[j] == b:
                    first = False
                    break
            if first and _distinct_faces(order, dest, third, valid, starts[a], starts[a + 1], b) == 2 \
                    and _distinct_faces(order, dest, third, valid, starts[b], starts[b + 1], a) == 0:
                conflicts += 1
    return conflicts


@njit(cache=True)
def _distinct_faces(order, dest, third, valid, lo, hi, b):
    """How many distinct valid faces (by third vertex) among corners ``lo:hi`` go on to ``b``."""
    n = 0
    for i in range(lo, hi):
        if dest[i] != b or not valid[order[i] // 3]:
            continue
        new = True
        for j in range(lo, i):
            if dest[j] == b and third[j] == third[i] and valid[order[j] // 3]:
                new = False
                break
        if new:
            n += 1
    return n


def winding_conflicts(vertices, faces, fnormals=None) -> int:
    """Number of edges two faces traverse in the same direction.

    On a consistently wound (orientable) surface every interior edge is
    traversed once each way; an edge that its two faces both traverse the
    same way joins faces whose right-hand normals point to opposite sides,
    and averaged vertex normals cancel there. Zero-area faces carry no
    normal and are ignored; so are exact duplicates of a face, and edges
    with three or more faces (non-manifold), which no winding fixes.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    fnormals : (F, 3) float64, optional
        :func:`face_normals` of the mesh, when already at hand.

    Returns
    -------
    int
        0 for a consistently wound mesh.
    """
    vertices = as_array(vertices, "vertices", dtype=np.float64, shape=(None, 3))
    faces = as_array(faces, "faces", dtype=np.int64, shape=(None, 3))
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):  # the kernel indexes without checks
        bad = int(faces.min() if faces.min() < 0 else faces.max())
        raise ValueError(f"faces: vertex index {bad} outside [0, {len(vertices)})")
    if fnormals is not None:
        fnormals = as_array(fnormals, "fnormals", dtype=np.float64, shape=(len(faces), 3))
    fn = face_normals(vertices, faces)[0] if fnormals is None else fnormals
    valid = np.any(fn != 0.0, axis=1)
    order, starts, dest, third = _corners_by_vertex(faces, vertices.shape[0])
    return int(_winding_conflicts_kernel(order, starts, dest, third, valid))


def reversed_duplicates(faces, vertices=None) -> np.ndarray:
    """Faces that repeat an earlier face with the opposite winding.

    The same triangle twice, once each way (a two-sided sheet, as in
    chair_model.obj's seat), traverses each of its edges once each way, so
    :func:`winding_conflicts` cannot see it; but its two right-hand normals
    are opposite and cancel in every vertex average around it.

    Parameters
    ----------
    faces : (F, 3) int
    vertices : (V, 3) float, optional
        When given, vertices at the same position count as one (files often
        give each copy of the sheet vertices of its own).

    Returns
    -------
    (F,) bool
        True for the later face of each such pair (the first one is kept); a
        face repeated with the same winding is not marked.
    """
    f = np.asarray(faces, np.int64)
    out = np.zeros(len(f), bool)
    if len(f) < 2:
        return out
    if vertices is not None:
        f = _weld(np.asarray(vertices, np.float64))[f]
    # A triangle's rotation with its smallest index first: (a, b, c) and (a, c, b) share the sorted
    # corners and differ in their cyclic order.
    k = np.argmin(f, axis=1)
    rows = np.arange(len(f))
    rot = np.stack([f[rows, k], f[rows, (k + 1) % 3], f[rows, (k + 2) % 3]], axis=1)
    rev = rot[:, [0, 2, 1]]
    # Only faces whose corner set occurs twice or more can pair up: found at NumPy speed first (this
    # runs on every mesh whose normals are computed, so a 1-D key where the indices allow one).
    seen = {}
    for i in _repeated_corner_sets(np.sort(f, axis=1)):
        a, b = tuple(rot[i].tolist()), tuple(rev[i].tolist())
        if a[0] == a[1] or a[1] == a[2]:
            continue  # a degenerate index triple has no winding
        if seen.get(b, 0) > 0:
            seen[b] -= 1
            out[i] = True
            continue
        seen[a] = seen.get(a, 0) + 1
    return out


def _weld(vertices: np.ndarray) -> np.ndarray:
    """(V,) int64: one id per distinct position (exact equality), as ``np.unique(axis=0)``'s inverse
    but by one lexicographic sort (about 3x faster at 655k vertices)."""
    order = np.lexsort(vertices.T[::-1])
    s = vertices[order]
    new = np.ones(len(s), bool)
    new[1:] = np.any(s[1:] != s[:-1], axis=1)
    ids = np.empty(len(s), np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids


def _repeated_corner_sets(corners: np.ndarray) -> np.ndarray:
    """Indices (ascending) of the rows of ``corners`` (F, 3) int64, each row sorted, that occur twice or more."""
    n = int(corners.max()) + 1 if len(corners) else 1
    if n < 2**21:  # n**3 fits int64: one key per row, a 1-D sort
        key = (corners[:, 0] * n + corners[:, 1]) * n + corners[:, 2]
    else:
        _, key = np.unique(corners, axis=0, return_inverse=True)
        key = key.ravel()
    order = np.argsort(key, kind="stable")
    k = key[order]
    same = np.zeros(len(k), bool)
    same[1:] = k[1:] == k[:-1]
    same[:-1] |= same[1:]
    return np.sort(order[same])


def _normalize_rows(n: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(n, axis=1)
    out = np.zeros_like(n)
    ok = length > 0
    out[ok] = n[ok] / length[ok, None]
    return out


def vertex_normals(vertices, faces, weighting: str = "angle", crease_angle: float | None = None):
    """Averaged vertex normals, optionally split at creases.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    weighting : {"uniform", "area", "angle"}
        How each face's normal is weighted in the average at a vertex.
    crease_angle : float, optional
        Degrees. Faces whose normals differ by more than this do not share a
        normal: the vertex is split. ``None`` averages every face at a vertex.

    Returns
    -------
    vertices : (V', 3) float64
        ``V' >= V``; equal to the input when nothing was split.
    faces : (F, 3) int64
        Re-indexed into the split vertices.
    normals : (V', 3) float64
        Unit normals; zero where no face with an area meets a vertex (the
        shading kernels then fall back to the geometric normal).
    source : (V',) int64
        The input vertex each output vertex copies.
    """
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    fn, _, w = _faces_kernel(vertices, faces, _WEIGHT_CODE[weighting])
    nv = vertices.shape[0]
    if crease_angle is None:
        return vertices, faces, _normalize_rows(_accumulate_kernel(faces, fn, w, nv)), np.arange(nv)
    order, starts, _, _ = _corners_by_vertex(faces, nv)
    # "Differ by more than the crease angle" splits; a tolerance of 1e-12 in
    # the cosine keeps faces at exactly the angle (a cube at 90 degrees, where
    # cos rounds to 6e-17 > 0) and coplanar neighbours (cos = 1 - rounding)
    # together.
    cos_crease = float(np.cos(np.radians(crease_angle))) - 1e-12
    corner = _corner_normals_kernel(faces, fn, w, order, starts, cos_crease)
    new_index, source = _split_kernel(corner, order, starts)
    new_faces = new_index.reshape(-1, 3)
    normals = np.zeros((source.shape[0], 3))
    normals[new_index] = corner
    return vertices[source], new_faces, _normalize_rows(normals), source
