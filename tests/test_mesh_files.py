"""Meshes from files: every format the issue names, the file's own normals, and scenes."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

import raycast_shade as rs
from raycast_shade.scene.normals import face_normals


def _triangles(vertices, faces):
    """Each face as a sorted tuple of rounded corner positions: independent of vertex order."""
    corners = np.round(np.asarray(vertices)[np.asarray(faces)], 5)
    return sorted(tuple(sorted(map(tuple, tri))) for tri in corners)


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "off", "glb"])
def test_every_named_format_loads_the_same_triangles(tmp_path, ext):
    src = trimesh.creation.icosphere(subdivisions=2)
    path = tmp_path / f"ico.{ext}"
    src.export(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. trimesh's deprecated Scene.dump(concatenate=True)
        mesh = rs.Mesh.load(path)
    assert mesh.name == f"ico.{ext}"
    assert len(mesh.faces) == len(src.faces) == 320
    assert len(mesh.vertices) == 162  # STL stores a triangle soup: trimesh welds it on load
    assert _triangles(mesh.vertices, mesh.faces) == _triangles(src.vertices, src.faces)
    # Wound as in the source: every face normal points out of the sphere.
    fn, _ = face_normals(mesh.vertices, mesh.faces)
    centres = mesh.vertices[mesh.faces].mean(axis=1)
    assert (np.einsum("ij,ij->i", fn, centres) > 0).all()


# A square made of two triangles, with normals the faces do not have (tilted towards +x).
SQUARE_OBJ = """\
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vn 0.6 0 0.8
vn 0.6 0 0.8
vn 0.6 0 0.8
vn 0.6 0 0.8
f 1//1 2//2 3//3
f 1//1 3//3 4//4
"""


def test_normals_stored_in_an_obj_are_kept(tmp_path):
    (tmp_path / "sq.obj").write_text(SQUARE_OBJ)
    mesh = rs.Mesh.load(tmp_path / "sq.obj")
    assert mesh.normals is not None
    np.testing.assert_allclose(mesh.normals, np.tile([0.6, 0.0, 0.8], (4, 1)), atol=1e-12)
    np.testing.assert_allclose(mesh.prepared.normals, mesh.normals, atol=1e-12)  # not recomputed to +z
    assert rs.Mesh.load(tmp_path / "sq.obj", use_normals=False).normals is None
    bare = SQUARE_OBJ.replace("//1", "").replace("//2", "").replace("//3", "").replace("//4", "")
    (tmp_path / "bare.obj").write_text("\n".join(line for line in bare.splitlines() if not line.startswith("vn")))
    assert rs.Mesh.load(tmp_path / "bare.obj").normals is None
    forced = rs.Mesh.load(tmp_path / "bare.obj", use_normals=True)  # trimesh's own average
    np.testing.assert_allclose(forced.normals, np.tile([0.0, 0.0, 1.0], (4, 1)), atol=1e-12)


@pytest.mark.parametrize("ext", ["ply", "glb"])
def test_normals_stored_in_ply_and_gltf_are_kept(tmp_path, ext):
    src = trimesh.creation.icosphere(subdivisions=1)
    rng = np.random.default_rng(0)
    custom = src.vertices + 0.3 * rng.normal(size=src.vertices.shape)  # not what any average gives
    custom /= np.linalg.norm(custom, axis=1, keepdims=True)
    src.vertex_normals = custom
    path = tmp_path / f"n.{ext}"
    src.export(path, include_normals=True) if ext == "glb" else src.export(path, vertex_normal=True)
    mesh = rs.Mesh.load(path)
    assert mesh.normals is not None
    # Match vertices by position (a format may reorder them), then compare the normals.
    order = np.lexsort(np.round(mesh.vertices, 5).T)
    ref = np.lexsort(np.round(src.vertices, 5).T)
    np.testing.assert_allclose(mesh.vertices[order], src.vertices[ref], atol=1e-6)
    np.testing.assert_allclose(mesh.normals[order], custom[ref], atol=1e-6)


def test_a_scene_file_is_flattened_with_its_transforms(tmp_path):
    """Two instances of one sphere: one moved, one mirrored in x. Vertices follow
    the node transforms, normals the inverse transpose, and the mirrored faces
    are turned over so that they still face out."""
    ball = trimesh.creation.icosphere(subdivisions=1)
    ball.vertex_normals = ball.vertices / np.linalg.norm(ball.vertices, axis=1, keepdims=True)
    scene = trimesh.Scene()
    move = trimesh.transformations.translation_matrix([3.0, 0.0, 0.0])
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0]) @ trimesh.transformations.translation_matrix([3.0, 0.0, 0.0])
    scene.add_geometry(ball, node_name="moved", geom_name="ball", transform=move)
    scene.add_geometry(ball, node_name="mirrored", geom_name="ball", transform=mirror)
    path = tmp_path / "two.glb"
    scene.export(path, include_normals=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mesh = rs.Mesh.load(path)
    assert len(mesh.faces) == 2 * len(ball.faces)
    centres_x = sorted(np.round([mesh.vertices[mesh.faces[:80]].mean(axis=(0, 1))[0],
                                 mesh.vertices[mesh.faces[80:]].mean(axis=(0, 1))[0]], 6))
    assert centres_x == [-3.0, 3.0]
    # Exact sphere normals: unit, radial about each instance's centre.
    assert mesh.normals is not None
    centre = np.where(mesh.vertices[:, :1] > 0, [3.0, 0.0, 0.0], [-3.0, 0.0, 0.0])
    radial = mesh.vertices - centre
    np.testing.assert_allclose(mesh.normals, radial / np.linalg.norm(radial, axis=1, keepdims=True), atol=1e-6)
    # Faces wound outwards in both instances, and consistently.
    fn, _ = face_normals(mesh.vertices, mesh.faces)
    out = mesh.vertices[mesh.faces].mean(axis=1) - centre[mesh.faces[:, 0]]
    assert (np.einsum("ij,ij->i", fn, out) > 0).all()
    assert rs.winding_conflicts(mesh.vertices, mesh.faces) == 0


def test_a_file_without_triangles_is_refused(tmp_path):
    (tmp_path / "points.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(ValueError, match="holds no triangles"):
        rs.Mesh.load(tmp_path / "points.obj")
    (tmp_path / "junk.ply").write_bytes(b"this is not a ply file")
    with pytest.raises(ValueError, match="junk.ply"):
        rs.Mesh.load(tmp_path / "junk.ply")
    with pytest.raises(TypeError, match="trimesh.Trimesh or trimesh.Scene"):
        rs.Mesh.from_trimesh(np.zeros((3, 3)))
