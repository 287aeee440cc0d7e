"""Per-vertex tangent frames for normal maps, computed from the UVs the standard way.

Each triangle's tangent ``T = dP/du`` and bitangent ``B = dP/dv`` follow from its
edges and UV differences (the derivatives Blinn's bump maps use,
:func:`~raycast_shade.scene.heightmap.tangent_frames`, without their fallback);
every vertex sums those of its triangles (so larger triangles weigh more, as in
Lengyel's method that MikkTSpace refines), then the sum is made orthogonal to
the vertex normal (Gram-Schmidt) and unit, and the handedness ``w`` is the sign
of ``(n x t) . B``: +1 where the UV map is right-handed seen from the normal's
side, -1 where it is mirrored. The result has glTF ``TANGENT``'s layout.
"""

from __future__ import annotations

import numpy as np

__all__ = ["vertex_tangents", "face_edges", "degenerate_tangents", "check_tangents", "MIN_TANGENT"]

# The normal-map kernel leaves the normal unbent where the tangent, made orthogonal to the normal, is
# no longer than this (shading.normalmap): at a vertex whose own tangent is, the map cannot be oriented.
MIN_TANGENT = 1e-12


def degenerate_tangents(tangents, normals=None):
    """Vertices whose tangent cannot orient a normal map.

    Parameters
    ----------
    tangents : (V, 4) float64
    normals : (V, 3) float64, optional
        Vertex normals of any length; zero rows are skipped.

    Returns
    -------
    zero, along : (K,) int64, (L,) int64
        Vertices whose tangent ``xyz`` is no longer than :data:`MIN_TANGENT`, and the others
        whose part across the (unit) normal is no longer than it: a tangent along the normal.
    """
    t = np.asarray(tangents, np.float64)[:, :3]
    length = np.linalg.norm(t, axis=1)
    zero = ~(length > MIN_TANGENT)
    along = np.zeros_like(zero)
    if normals is not None:
        n = _unit(np.asarray(normals, np.float64))
        across = np.linalg.norm(t - n * np.sum(n * t, axis=1, keepdims=True), axis=1)
        along = ~zero & n.any(axis=1) & ~(across > MIN_TANGENT)
    return np.flatnonzero(zero), np.flatnonzero(along)


def check_tangents(tangents, normals, name: str) -> None:
    """Refuse (ValueError naming ``name`` and the first vertex) tangents that cannot orient a normal
    map: zero, or along their vertex's normal (see :func:`degenerate_tangents`)."""
    zero, along = degenerate_tangents(tangents, normals)
    if len(zero):
        raise ValueError(f"{name}: {len(zero)} tangent(s) of length <= {MIN_TANGENT:g} (zero), first at vertex "
                         f"{int(zero[0])}: a normal map cannot be oriented there (its normal would stay unbent)")
    if len(along):
        i = int(along[0])
        raise ValueError(f"{name}: {len(along)} tangent(s) along the vertex normal, first at vertex {i} (tangent "
                         f"{np.round(tangents[i, :3], 6).tolist()}, normal {np.round(normals[i], 6).tolist()}): a "
                         "tangent lies across the normal (glTF TANGENT: along increasing u); a normal map cannot "
                         "be oriented there")


def face_edges(vertices, faces, uvs):
    """Each triangle's edges from its first corner, in space and in UV, and the UV determinant.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    uvs : (V, 2) float64

    Returns
    -------
    e1, e2 : (F, 3) float64
        ``p1 - p0`` and ``p2 - p0``.
    d1, d2 : (F, 2) float64
        ``uv1 - uv0`` and ``uv2 - uv0``.
    det : (F,) float64
        ``d1 x d2``: zero where the UVs are degenerate; its sign, the UV map's handedness.
    """
    p0 = vertices[faces[:, 0]]
    t0 = uvs[faces[:, 0]]
    d1 = uvs[faces[:, 1]] - t0
    d2 = uvs[faces[:, 2]] - t0
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    return vertices[faces[:, 1]] - p0, vertices[faces[:, 2]] - p0, d1, d2, det


def vertex_tangents(vertices, faces, uvs, normals) -> np.ndarray:
    """Per-vertex tangents (xyz, handedness w) from the UVs.

    Parameters
    ----------
    vertices : (V, 3) float64
    faces : (F, 3) int64
    uvs : (V, 2) float64
    normals : (V, 3) float64
        Unit vertex normals (zero rows allowed).

    Returns
    -------
    (V, 4) float64
        Unit tangent orthogonal to the normal, and ``w`` in {-1, +1}. A vertex
        whose triangles have degenerate UVs (or whose summed tangent is parallel
        to its normal) gets any unit vector orthogonal to its normal, ``w = +1``.
    """
    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    uvs = np.asarray(uvs, np.float64)
    normals = np.asarray(normals, np.float64)
    e1, e2, d1, d2, det = face_edges(vertices, faces, uvs)
    ok = det != 0.0
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    # dP/du and dP/dv of each triangle, scaled by its UV area's sign only through inv.
    tu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * inv
    tv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * inv
    # Weight each triangle's (unit-direction) derivatives by its 3D area, as the
    # accumulated sums of a mesh's triangles are meant: a sliver counts little.
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)[:, None]
    tu = _unit(tu) * area
    tv = _unit(tv) * area
    tu[~np.all(np.isfinite(tu), axis=1)] = 0.0
    tv[~np.all(np.isfinite(tv), axis=1)] = 0.0
    T = np.zeros_like(vertices)
    Bs = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(T, faces[:, k], tu)
        np.add.at(Bs, faces[:, k], tv)
    t = T - normals * np.sum(normals * T, axis=1, keepdims=True)
    length = np.linalg.norm(t, axis=1, keepdims=True)
    bad = ~(length[:, 0] > 1e-12 * np.maximum(np.linalg.norm(T, axis=1), 1e-300))
    t = np.divide(t, length, out=np.zeros_like(t), where=length > 0)
    if np.any(bad):
        n = normals[bad]
        helper = np.where(np.abs(n[:, 0:1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
        h = helper - n * np.sum(n * helper, axis=1, keepdims=True)
        t[bad] = _unit(h)
    w = np.where(np.sum(np.cross(normals, t) * Bs, axis=1) < 0.0, -1.0, 1.0)
    return np.concatenate([t, w[:, None]], axis=1)


def _unit(a: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(a, axis=1, keepdims=True)
    return np.divide(a, length, out=np.zeros_like(a), where=length > 0)


def pack_normal_maps(models, preps) -> tuple:
    """The scene's normal maps for the kernels (:class:`~raycast_shade.scene.scene.SceneGeometry`).

    Returns
    -------
    tuple
        ``(index (G,) int32`` row of each model's map in ``info`` or -1, ``texels (T,) float32``,
        ``info (K, TEX_SIZE) float64`` (:meth:`raycast_shade.Texture.packed_info`), ``scale (G,)
        float64``, ``tangents (V, 4) float64`` per scene vertex (the mesh's own, else computed
        from its UVs; zeros for models without a map), or ``(1, 4)`` zeros when no model has a map).
    """
    from ..common.layout import TEX_SIZE

    index = np.full(len(models), -1, np.int32)
    scale = np.zeros(len(models))
    texels, info, seen, offset, frames = [], [], {}, 0, []
    for g, (m, p) in enumerate(zip(models, preps)):
        tex = m.material.normal_map
        if tex is None:
            frames.append(np.zeros((len(p.vertices), 4)))
            continue
        if p.uvs is None:
            raise ValueError(f"scene.models[{g}] ({m.mesh.name}): material {m.material.name!r} has a normal_map "
                             "but the mesh has no UVs (see raycast_shade.bump.planar_uvs and friends)")
        if id(tex) not in seen:
            seen[id(tex)] = len(info)
            texels.append(tex.packed_texels())
            info.append(tex.packed_info(offset))
            offset += texels[-1].size
        index[g] = seen[id(tex)]
        scale[g] = m.material.normal_scale
        if p.tangents is not None:  # against the normals as prepared (computed ones too), before any kernel
            check_tangents(p.tangents, p.normals, f"scene.models[{g}] ({m.mesh.name}).tangents")
        frames.append(p.tangents if p.tangents is not None else
                      vertex_tangents(p.vertices, p.faces, p.uvs, p.normals))
    if not info:
        return index, np.zeros(3, np.float32), np.zeros((1, TEX_SIZE)), scale, np.zeros((1, 4))
    return (index, np.concatenate(texels).astype(np.float32), np.stack(info), scale,
            np.ascontiguousarray(np.concatenate(frames), np.float64))
