"""Back faces of single-sided models in view (visibility/facing.py): the share is exact on scenes
whose answer is known in closed form, and glTF's doubleSided reaches the material."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

import raycast_shade as rs
from raycast_shade.visibility.facing import back_face_shares


def _quad_scene(eye, double_sided=False):
    quad = rs.shapes.plane(2.0, normal="+z")  # faces +z
    models = [rs.Model(quad, rs.Material(kd=0.7, double_sided=double_sided))]
    cam = rs.Camera(eye=eye, target=(0.0, 0.0, 0.0), width=80, height=60, fov=40.0)
    return rs.Scene(models, lights=[rs.DirectionalLight((0.0, 0.0, -1.0))], camera=cam)


def test_a_single_sided_quad_seen_from_behind_is_all_back_faces_and_warns():
    scene = _quad_scene((0.3, 0.2, -3.0))
    assert back_face_shares(scene, scene.camera) == {0: 1.0}
    with pytest.warns(rs.SingleSidedWarning, match=r"scene.models\[0\].*100.0% of what the camera sees"):
        rs.render(scene)


def test_seen_from_the_front_or_double_sided_nothing_is_said():
    front = _quad_scene((0.3, 0.2, 3.0))
    assert back_face_shares(front, front.camera) == {0: 0.0}
    both = _quad_scene((0.3, 0.2, -3.0), double_sided=True)
    assert back_face_shares(both, both.camera) == {}  # a double-sided model is not probed at all
    for scene in (front, both):
        with warnings.catch_warnings():
            warnings.simplefilter("error", rs.SingleSidedWarning)
            rs.render(scene)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_a_closed_single_sided_mesh_seen_from_outside_shows_no_back_face(projection):
    sphere = rs.shapes.icosphere(3)
    cam = rs.Camera(eye=(0.5, 1.0, 4.0), target=(0.0, 0.0, 0.0), width=64, height=48, projection=projection)
    scene = rs.Scene([rs.Model(sphere, rs.Material(double_sided=False))], lights=[rs.DirectionalLight((0, 0, -1))],
                     camera=cam)
    assert back_face_shares(scene, cam) == {0: 0.0}
    inside = scene.replace(camera=rs.Camera(eye=(0.1, 0.0, 0.2), target=(0.0, 0.0, -1.0), width=64, height=48))
    assert back_face_shares(inside, inside.camera) == {0: 1.0}  # from inside, every hit is a back face


def test_double_sided_is_a_checked_flag():
    assert rs.Material().double_sided is True
    with pytest.raises(TypeError, match="double_sided"):
        rs.Material(double_sided="no")


@pytest.mark.parametrize("double_sided", [False, True])
def test_gltf_double_sided_reaches_the_material(tmp_path, double_sided):
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=[200, 100, 50, 255], doubleSided=double_sided))
    box.export(tmp_path / "box.glb")
    (model,) = rs.load_models(tmp_path / "box.glb")
    assert model.material.double_sided is double_sided
