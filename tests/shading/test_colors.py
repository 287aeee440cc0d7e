"""Vertex and face colours: Mesh(colors=...) used as kd, exact at the vertices, one per
face, and against the NumPy reference in every mode."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.reference import shade_reference

# Orthographic, 8 x 8 pixels over [-1, 1]^2: pixel centres at x = -7/8, -5/8, ..., 7/8.
ORTHO = rs.Camera(eye=(0, 0, 3), target=(0, 0, 0), width=8, height=8, projection="orthographic", ortho_height=2.0)
CORNERS = np.array([[-7 / 8, -7 / 8, 0.0], [7 / 8, -7 / 8, 0.0], [-7 / 8, 7 / 8, 0.0]])
RGB = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def _lit(mesh, material=None, camera=ORTHO):
    """Lit head on (n.s = 1), no ambient: a pixel's colour is its kd."""
    return rs.Scene([rs.Model(mesh, material or rs.Material())], lights=[rs.DirectionalLight((0, 0, -1))],
                    ambient=0.0, camera=camera)


@pytest.mark.parametrize("shading", ["gouraud", "phong"])
def test_vertex_colours_are_exact_at_the_vertices(shading):
    """The triangle's corners sit on pixel centres: those pixels show the corners' colours
    (the material's own kd, 0.8, plays no part), and the rest interpolate."""
    mesh = rs.Mesh(CORNERS, [[0, 1, 2]], colors=RGB)
    assert mesh.color_mode == "vertex"
    scene = _lit(mesh)
    frame = rs.render(scene, shading=shading)
    for (x, y), rgb in zip([(0, 7), (7, 7), (0, 0)], RGB):  # image rows run downwards
        np.testing.assert_allclose(frame.image[y, x], rgb, atol=1e-6)
    inside = frame.image[frame.hits.prim >= 0]
    np.testing.assert_allclose(inside.sum(axis=1), 1.0, atol=1e-6)  # barycentric weights sum to 1
    np.testing.assert_allclose(frame.image, shade_reference(scene, ORTHO, frame.hits, shading), atol=1e-6)


def test_flat_shading_takes_the_centre_colour():
    frame = rs.render(_lit(rs.Mesh(CORNERS, [[0, 1, 2]], colors=RGB)), shading="flat")
    np.testing.assert_allclose(frame.image[frame.hits.prim >= 0], 1.0 / 3.0, atol=1e-7)


@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong"])
def test_face_colours_stay_on_their_faces(shading):
    """Two faces sharing an edge, one red and one blue: in every mode each face shows its own
    colour (Gouraud modulates interpolated light by the face's colour, so nothing bleeds)."""
    quad = rs.shapes.plane(size=2.0)
    colours = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    mesh = rs.Mesh(quad.vertices, quad.faces, normals=quad.normals, uvs=quad.uvs, colors=colours, color_mode="face")
    frame = rs.render(_lit(mesh, camera=ORTHO.replace(ortho_height=2.5)), shading=shading)
    for f in (0, 1):
        pixels = frame.image[frame.hits.prim == f]
        assert len(pixels) > 5
        np.testing.assert_allclose(pixels, np.tile(colours[f], (len(pixels), 1)), atol=1e-6)


def test_coloured_sphere_matches_the_reference():
    mesh = rs.shapes.icosphere(2)
    rng = np.random.default_rng(0)
    per_vertex = rs.Mesh(mesh.vertices, mesh.faces, normals=mesh.normals, colors=rng.random((len(mesh.vertices), 3)))
    per_face = rs.Mesh(mesh.vertices + [2.5, 0, 0], mesh.faces, normals=mesh.normals,
                       colors=rng.random((len(mesh.faces), 3)))
    scene = rs.Scene([rs.Model(per_vertex, rs.Material(ks=0.3)), rs.Model(per_face, rs.Material(ks=0.3))],
                     lights=[rs.PointLight((1, 3, 4), intensity=20, attenuation="inverse_square")], ambient=0.1,
                     camera=rs.Camera(eye=(1.25, 0.5, 5), target=(1.25, 0, 0), width=80, height=48))
    for shading in ("flat", "gouraud", "phong"):
        frame = rs.render(scene, shading=shading)
        ref = shade_reference(scene, scene.camera, frame.hits, shading)
        np.testing.assert_allclose(frame.image, ref, rtol=1e-5, atol=1e-6, err_msg=shading)


def test_colours_follow_split_vertices():
    """A crease angle splits the cube's corners; each copy keeps its corner's colour."""
    cube = rs.shapes.cube(crease_angle=None)
    colours = np.random.default_rng(1).random((8, 3))
    mesh = rs.Mesh(cube.vertices, cube.faces, colors=colours, crease_angle=30)
    prep = mesh.prepared
    assert len(prep.vertices) == 24 and prep.color_mode == "vertex"
    src = [int(np.flatnonzero((cube.vertices == v).all(axis=1))[0]) for v in prep.vertices]
    np.testing.assert_array_equal(prep.colors, colours[src])


def test_colour_arguments_are_checked():
    tri = dict(vertices=CORNERS, faces=[[0, 1, 2]], name="tri")
    with pytest.raises(ValueError, match=r"tri.colors: expected one row per vertex \(3\) or per face \(1\), got 2"):
        rs.Mesh(**tri, colors=np.ones((2, 3)))
    with pytest.raises(ValueError, match="tri.colors: must be >= 0"):
        rs.Mesh(**tri, colors=-np.ones((3, 3)))
    with pytest.raises(ValueError, match="tri.color_mode"):
        rs.Mesh(**tri, colors=np.ones((3, 3)), color_mode="corner")
    three = rs.shapes.plane(subdivisions=1)
    # 4 vertices, 2 faces: 'auto' tells them apart; a mesh with V == F needs color_mode.
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    faces = [[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]]
    with pytest.raises(ValueError, match="as many vertices as faces"):
        rs.Mesh(square, faces, colors=np.ones((4, 3)))
    assert rs.Mesh(square, faces, colors=np.ones((4, 3)), color_mode="face").color_mode == "face"
    assert rs.Mesh(three.vertices, three.faces).color_mode is None
    with pytest.warns(rs.ColourRangeWarning, match="0-255"):
        rs.Mesh(**tri, colors=np.full((3, 3), 200.0))
