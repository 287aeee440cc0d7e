"""Gouraud's vertex sides and face states: each visible vertex is shaded from the sides its faces
are seen from, and a face of certain side interpolates its corners' stored shades at once; neither
changes a pixel."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.shading.gouraud_sides import _face_sides_kernel, face_planes
from raycast_shade.shading.inputs import prepare
from raycast_shade.shading.shade import SampleShading
from raycast_shade.study.reference import shade_reference
from raycast_shade.visibility.cast import cast_camera

from tests.conftest import RTOL32, hit_buffer, lit_scene
from tests.shading.test_shading_modes import SCENES

LIGHT = rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square")


def _sphere(eye, target=(0.0, 0.0, 0.0), fov=50.0):
    cam = rs.Camera(eye=eye, target=target, width=64, height=48, fov=fov)
    return lit_scene(rs.shapes.icosphere(3), rs.Material(kd=0.7, ks=0.5, shininess=20), [LIGHT], cam, 0.1)


def _seen(scene):
    """The frame's Gouraud shader after shading its hit buffer, and the image."""
    shader = SampleShading(scene, scene.camera, "gouraud")
    return shader, shader.shade(cast_camera(scene.geometry, scene.camera))


def test_a_closed_mesh_seen_from_outside_is_shaded_from_the_front_only():
    shader, _ = _seen(_sphere((0.0, 0.0, 3.0)))
    done = shader.seen.vertex_done
    assert done[:, 0].sum() > 100
    assert done[:, 1].sum() == 0
    assert (shader.seen.state[shader.seen.gouraud_done == 1] == 1).mean() > 0.95  # front, stored shades


def test_a_closed_mesh_seen_from_inside_is_shaded_from_the_back_only():
    shader, _ = _seen(_sphere((0.0, 0.0, 0.2), target=(0.0, 0.0, -1.0), fov=100.0))
    done = shader.seen.vertex_done
    assert done[:, 1].sum() > 100
    assert done[:, 0].sum() == 0


@pytest.mark.parametrize("name", sorted(SCENES))
def test_face_states_change_no_pixel(name):
    """Every pixel through the general path (the states cleared) gives the image bit for bit;
    the scenes' mixes of sides, orthographic views and flipped or missing normals included."""
    scene = SCENES[name]
    shader, image = _seen(scene)
    state = shader.seen.state
    assert state.max() > 0  # some faces take the stored shades at once
    state[:] = 0
    again = shader.shade(cast_camera(scene.geometry, scene.camera))
    assert np.array_equal(image.view(np.uint32), again.view(np.uint32))
    assert np.array_equal(image, rs.shade(scene, scene.camera, cast_camera(scene.geometry, scene.camera), "gouraud"))


def _one_face(eye, projection="perspective"):
    verts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    mesh = rs.Mesh(verts, [[0, 1, 2]], normals=np.tile([0.0, 0.0, 1.0], (3, 1)))
    cam = rs.Camera(eye=eye, target=(0.3, 0.3, 0.0), width=4, height=3, projection=projection)
    return lit_scene(mesh, rs.Material(kd=0.7, ks=0.5, shininess=10), [LIGHT], cam, 0.1)


@pytest.mark.parametrize("eye, projection, state, sides", [
    ((0.2, 0.2, 3.0), "perspective", 1, (1, 0)),  # in front: the stored front shades
    ((0.2, 0.2, -3.0), "perspective", 2, (0, 1)),  # behind
    ((0.2, 0.2, -3.0), "orthographic", 2, (0, 1)),
    ((3.0, 0.2, 0.0), "perspective", 0, (1, 1)),  # in the face's plane: either side, per pixel
])
def test_face_side_is_certain_or_both_sides_are_shaded(eye, projection, state, sides):
    scene = _one_face(eye, projection)
    k = prepare(scene, scene.camera)
    out = np.full(1, 9, np.uint8)
    flags = np.zeros((3, 2), np.uint8)
    _face_sides_kernel(np.ones(1, np.uint8), k["G"], k["cam"], face_planes(scene.geometry), out, flags)
    assert out[0] == state
    np.testing.assert_array_equal(flags, np.tile(sides, (3, 1)))


def test_weights_off_the_triangle_shade_both_sides_and_match_the_reference():
    """A pixel whose weights leave the triangle (a hand-made buffer) may see the face from
    either side: its corners get both shades, and its colour is the reference's at the
    weights clamped onto the triangle (as the kernel interpolates)."""
    scene = _one_face((0.2, 0.2, 3.0))
    hits = hit_buffer([[0.2, -0.01], [0.3, 0.5]], [[0.2, 0.3], [0.3, 0.51]])
    shader = SampleShading(scene, scene.camera, "gouraud")
    img = shader.shade(hits)
    np.testing.assert_array_equal(shader.seen.vertex_done, np.ones((3, 2), np.uint8))
    clamped = hit_buffer([[0.2, 0.0], [0.3, 0.5 / 1.01]], [[0.2, 0.3], [0.3, 0.51 / 1.01]])
    np.testing.assert_allclose(img, shade_reference(scene, scene.camera, clamped, "gouraud"), rtol=1e-5)
