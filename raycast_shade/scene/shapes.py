"""Procedural meshes, built here so that no scene needs a download.

Curved shapes come with their *exact* vertex normals (the analytic normal of
the surface at each vertex) and UVs, so that the only error left in an image
is the shading method's, not the normal estimate's.
"""

from __future__ import annotations

import numpy as np

from ..common.validate import as_int, as_scalar, as_vec3, check_memory
from .mesh import Mesh

__all__ = ["icosphere", "uv_sphere", "torus", "plane", "cube", "cylinder", "SHAPES", "make"]


def _orient_outward(vertices, faces, outward):
    """Flip the winding if faces point against ``outward`` (V, 3) on average."""
    v0 = vertices[faces[:, 0]]
    n = np.cross(vertices[faces[:, 1]] - v0, vertices[faces[:, 2]] - v0)
    d = np.einsum("ij,ij->i", n, outward[faces].mean(axis=1))
    return faces[:, ::-1].copy() if d.sum() < 0 else faces


def _positive(name: str, value) -> float:
    """``value`` as a float: a TypeError naming ``name`` for a non-number (a string,
    a bool), a ValueError unless finite and > 0."""
    return as_scalar(value, name, minimum=0.0, exclusive=True)


# Peak bytes per vertex and per face while a shape is built (grids, temporaries), plus the
# mesh's own copies and its packed rows in a scene, rounded up; a shape needing more than
# common.validate.memory_limit() is refused with the figure before anything is allocated.
_BYTES_PER_VERTEX = 256
_BYTES_PER_FACE = 320


def _check_size(what: str, vertices: float, faces: float) -> None:
    check_memory(vertices * _BYTES_PER_VERTEX + faces * _BYTES_PER_FACE, f"{what} ({faces:.3g} faces)", "the mesh")


def _center(value) -> np.ndarray:
    return as_vec3(value, "center")


def _grid_faces(rows: int, cols: int) -> np.ndarray:
    """Two triangles per cell of a (rows+1) x (cols+1) vertex grid."""
    i, j = np.mgrid[0:rows, 0:cols]
    a = (i * (cols + 1) + j).ravel()
    b = a + cols + 1
    return np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)])


def icosphere(subdivisions: int = 3, radius: float = 1.0, center=(0.0, 0.0, 0.0), **kwargs) -> Mesh:
    """Subdivided icosahedron, 20 * 4**subdivisions faces, exact normals.

    UVs are the spherical mapping ``(atan2(x, z) / 2pi + 1/2, 1 - acos(y) / pi)``:
    an image reads upright and unmirrored from outside, its top row at the
    north pole (+y) (discontinuous at the seam; use :func:`uv_sphere` where
    that matters).
    """
    import trimesh

    subdivisions = as_int(subdivisions, "subdivisions")
    if not 0 <= subdivisions <= 9:  # 20 * 4**9 = 5.2 M faces
        raise ValueError(f"subdivisions: expected an integer in 0..9, got {subdivisions}")
    radius = _positive("radius", radius)
    center = _center(center)
    tm = trimesh.creation.icosphere(subdivisions=int(subdivisions), radius=1.0)
    unit = tm.vertices / np.linalg.norm(tm.vertices, axis=1, keepdims=True)
    faces = _orient_outward(unit, np.asarray(tm.faces, np.int64), unit)
    uvs = np.stack([np.arctan2(unit[:, 0], unit[:, 2]) / (2 * np.pi) + 0.5, 1.0 - np.arccos(np.clip(unit[:, 1], -1, 1)) / np.pi], 1)
    kwargs.setdefault("name", f"icosphere{subdivisions}")
    return Mesh(unit * radius + center, faces, normals=unit, uvs=uvs, **kwargs)


def uv_sphere(rings: int = 16, segments: int = 32, radius: float = 1.0, center=(0.0, 0.0, 0.0), **kwargs) -> Mesh:
    """Latitude-longitude sphere with exact normals and UVs in [0, 1]^2.

    ``u`` runs eastwards (from +z towards +x), ``v`` from the south pole (0)
    to the north pole (+y, 1): an image reads upright and unmirrored from
    outside, as on a globe.

    The seam column is duplicated (distinct UVs); pole triangles that would
    have zero area are left out.
    """
    rings = as_int(rings, "rings", minimum=2)
    segments = as_int(segments, "segments", minimum=3)
    radius = _positive("radius", radius)
    center = _center(center)
    _check_size(f"rings x segments: {rings} x {segments}", float(rings + 1) * (segments + 1), 2.0 * rings * segments)
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2 * np.pi, segments + 1)
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    unit = np.stack([np.sin(th) * np.sin(ph), np.cos(th), np.sin(th) * np.cos(ph)], -1).reshape(-1, 3)
    # Exact poles (sin(pi) is not 0 in floating point).
    unit[: segments + 1] = (0.0, 1.0, 0.0)
    unit[-(segments + 1):] = (0.0, -1.0, 0.0)
    uvs = np.stack([ph / (2 * np.pi), 1.0 - th / np.pi], -1).reshape(-1, 2)
    faces = _grid_faces(rings, segments)
    p = unit[faces]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    faces = faces[area > 1e-12]
    faces = _orient_outward(unit, faces, unit)
    kwargs.setdefault("name", f"uv_sphere{rings}x{segments}")
    return Mesh(unit * radius + center, faces, normals=unit, uvs=uvs, **kwargs)


def torus(major_radius: float = 1.0, minor_radius: float = 0.35, major_segments: int = 48, minor_segments: int = 24,
          center=(0.0, 0.0, 0.0), **kwargs) -> Mesh:
    """Torus around the y axis with exact normals and UVs (seams duplicated).

    ``u`` runs around the y axis, ``v`` around the tube (upwards on the
    outside): an image reads upright and unmirrored from outside.
    """
    major_radius = _positive("major_radius", major_radius)
    minor_radius = _positive("minor_radius", minor_radius)
    if not major_radius > minor_radius:
        raise ValueError(f"major_radius: must be > minor_radius, got {major_radius}, {minor_radius}")
    major_segments = as_int(major_segments, "major_segments", minimum=3)
    minor_segments = as_int(minor_segments, "minor_segments", minimum=3)
    center = _center(center)
    _check_size(f"major_segments x minor_segments: {major_segments} x {minor_segments}",
                float(major_segments + 1) * (minor_segments + 1), 2.0 * major_segments * minor_segments)
    a = np.linspace(0.0, 2 * np.pi, major_segments + 1)
    b = np.linspace(0.0, 2 * np.pi, minor_segments + 1)
    aa, bb = np.meshgrid(a, b, indexing="ij")
    ring = np.stack([np.cos(aa), np.zeros_like(aa), np.sin(aa)], -1)
    normal = np.cos(bb)[..., None] * ring + np.sin(bb)[..., None] * np.array([0.0, 1.0, 0.0])
    verts = (major_radius * ring + minor_radius * normal).reshape(-1, 3)
    normal = normal.reshape(-1, 3)
    uvs = np.stack([1.0 - aa / (2 * np.pi), bb / (2 * np.pi)], -1).reshape(-1, 2)
    faces = _orient_outward(verts, _grid_faces(major_segments, minor_segments), normal)
    kwargs.setdefault("name", f"torus{major_segments}x{minor_segments}")
    return Mesh(verts + center, faces, normals=normal, uvs=uvs, **kwargs)


def plane(size: float = 2.0, subdivisions: int = 1, center=(0.0, 0.0, 0.0), normal: str = "+z", **kwargs) -> Mesh:
    """A square facing ``normal`` (one of ``+x -x +y -y +z -z``), UVs in [0, 1]^2.

    Seen from the side it faces, an image reads unmirrored on every one of
    the six (for ``-x``, ``-y``, ``-z`` the ``u`` axis runs the other way
    than on ``+x``, ``+y``, ``+z``, as seen from the opposite side).
    """
    axes = {"x": 0, "y": 1, "z": 2}
    if not isinstance(normal, str):
        raise TypeError(f"normal: expected one of +x -x +y -y +z -z, got {type(normal).__name__}")
    if normal not in {f"{s}{a}" for s in "+-" for a in "xyz"}:
        raise ValueError(f"normal: expected one of +x -x +y -y +z -z, got {normal!r}")
    n = as_int(subdivisions, "subdivisions", minimum=1)
    size = _positive("size", size)
    center = _center(center)
    _check_size(f"subdivisions: {n} x {n}", float(n + 1) ** 2, 2.0 * n * n)
    s = np.linspace(-size / 2, size / 2, n + 1)
    uu, vv = np.meshgrid(s, s, indexing="ij")
    local = np.stack([uu.ravel(), vv.ravel(), np.zeros(uu.size)], 1)  # in xy, facing +z
    k = axes[normal[1]]
    perm = {2: [0, 1, 2], 0: [2, 0, 1], 1: [1, 2, 0]}[k]
    verts = local[:, perm]
    nvec = np.zeros(3)
    nvec[k] = 1.0 if normal[0] == "+" else -1.0
    normals = np.tile(nvec, (len(verts), 1))
    uvs = np.stack([(uu.ravel() + size / 2) / size, (vv.ravel() + size / 2) / size], 1)
    if normal[0] == "-":
        uvs[:, 0] = 1.0 - uvs[:, 0]  # seen from the other side: u runs the other way
    faces = _orient_outward(verts, _grid_faces(n, n), normals)
    kwargs.setdefault("name", f"plane{normal}")
    return Mesh(verts + center, faces, normals=normals, uvs=uvs, **kwargs)


def cube(size: float = 1.0, center=(0.0, 0.0, 0.0), crease_angle: float | None = 30.0, **kwargs) -> Mesh:
    """An axis-aligned cube: 8 shared vertices, 12 faces.

    Normals are averaged from the faces; the default 30 degree crease keeps
    its edges hard (``crease_angle=None`` rounds it into a blob).
    """
    import trimesh

    size = _positive("size", size)
    center = _center(center)
    tm = trimesh.creation.box(extents=(size, size, size))
    verts = np.asarray(tm.vertices, float)
    faces = _orient_outward(verts, np.asarray(tm.faces, np.int64), verts)
    kwargs.setdefault("name", "cube")
    return Mesh(verts + center, faces, crease_angle=crease_angle, **kwargs)


def cylinder(radius: float = 0.5, height: float = 1.0, segments: int = 32, center=(0.0, 0.0, 0.0),
             crease_angle: float | None = 60.0, **kwargs) -> Mesh:
    """A capped cylinder along y; the crease keeps the rims sharp and the side smooth."""
    import trimesh

    radius = _positive("radius", radius)
    height = _positive("height", height)
    segments = as_int(segments, "segments", minimum=3)
    center = _center(center)
    _check_size(f"segments: {segments}", 4.0 * segments + 2, 4.0 * segments)
    tm = trimesh.creation.cylinder(radius=radius, height=height, sections=segments)
    verts = np.asarray(tm.vertices, float)[:, [0, 2, 1]]  # trimesh's axis is z
    faces = _orient_outward(verts, np.asarray(tm.faces, np.int64)[:, ::-1], verts)
    kwargs.setdefault("name", "cylinder")
    return Mesh(verts + center, faces, crease_angle=crease_angle, **kwargs)


SHAPES = {
    "icosphere": icosphere,
    "uv_sphere": uv_sphere,
    "torus": torus,
    "plane": plane,
    "cube": cube,
    "cylinder": cylinder,
}


def make(shape: str, **params) -> Mesh:
    """Build a named procedural shape (for scene files)."""
    if not isinstance(shape, str) or shape not in SHAPES:
        raise ValueError(f"shape: expected one of {sorted(SHAPES)}, got {shape!r}")
    try:
        return SHAPES[shape](**params)
    except TypeError as exc:
        raise ValueError(f"shape {shape!r}: {exc}") from None
