"""optical_flow(hits=...): a buffer that does not fit view A is refused naming ``hits`` before any ray
is cast (issue 45), through the shared validator (visibility.hits.check_hits)."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.output.flow import optical_flow
from raycast_shade.visibility.cast import cast_camera

W, H = 40, 30


@pytest.fixture(scope="module")
def views():
    two = rs.Scene([rs.Model(rs.shapes.plane(size=6.0, subdivisions=4)),
                    rs.Model(rs.shapes.icosphere(2, center=(0, 0, 0.5), radius=0.5))],
                   lights=[rs.PointLight((0, 0, 5))], camera=rs.Camera(eye=(0, 0, 5), width=W, height=H))
    one = two.replace(models=[rs.Model(rs.shapes.plane(size=6.0, subdivisions=1))])
    cam_b = rs.Camera(eye=(0.3, 0, 5), width=W, height=H)
    return two, one, cam_b


@pytest.fixture()
def no_cast(monkeypatch):
    def boom(*args, **kwargs):
        raise AssertionError("a ray was cast before hits was refused")

    monkeypatch.setattr("raycast_shade.visibility.cast.cast_rays", boom)
    monkeypatch.setattr("raycast_shade.visibility.cast.cast_camera", boom)


def test_bare_array_is_refused(views, no_cast):
    two, _, cam_b = views
    with pytest.raises(TypeError, match=r"^hits: expected a HitBuffer, got ndarray"):
        optical_flow(two, two.camera, camera_b=cam_b, hits=np.zeros((H, W), np.int32))


def test_hits_of_another_camera_size_are_refused(views, no_cast):
    two, _, cam_b = views
    small = rs.Camera(eye=(0, 0, 5), width=W // 2, height=H // 2)
    hits = rs.render(two, "flat", camera=small).hits
    with pytest.raises(ValueError, match=r"^hits: shape \(15, 20\) does not match the camera's 30x40 image"):
        optical_flow(two, two.camera, camera_b=cam_b, hits=hits)


def test_hits_of_a_scene_with_more_models_are_refused(views, no_cast):
    two, one, cam_b = views
    hits = rs.render(two, "flat").hits
    assert (hits.geom == 1).any()
    with pytest.raises(ValueError, match=r"^hits\.geom: \d+ hit pixel\(s\) name a model outside 0\.\.0"):
        optical_flow(one, one.camera, camera_b=cam_b, hits=hits)


def test_hits_of_a_scene_with_more_faces_are_refused(views, no_cast):
    two, one, cam_b = views
    fine = two.replace(models=[two.models[0]])  # the plane of 4x4 squares against one of 1x1
    hits = rs.render(fine, "flat").hits
    assert hits.prim.max() >= 2
    with pytest.raises(ValueError, match=r"^hits\.prim: \d+ hit pixel\(s\) name a triangle beyond"):
        optical_flow(one, one.camera, camera_b=cam_b, hits=hits)


def test_own_hits_give_the_cast_flow(views):
    two, _, cam_b = views
    ours = optical_flow(two, two.camera, camera_b=cam_b, hits=cast_camera(two.geometry, two.camera))
    cast = optical_flow(two, two.camera, camera_b=cam_b)
    for key in ("flow", "scene_flow", "mask", "occluded", "outside"):
        np.testing.assert_array_equal(ours[key], cast[key])


def test_hits_of_a_smaller_scene_or_another_camera_are_refused(views, no_cast):
    # A buffer whose indices fit this scene passes check_hits: its rays must meet the triangles it names.
    two, one, cam_b = views
    plane = two.models[0]
    small = two.replace(models=[rs.Model(rs.shapes.plane(size=3.0, subdivisions=2))])  # fewer faces than `plane`
    hits = rs.render(small, "flat").hits
    assert hits.prim.max() < len(plane.mesh.faces) and (hits.prim >= 0).sum() > 100
    with pytest.raises(ValueError, match=r"^hits: not this scene's and camera's hit buffer: at \d+ of \d+ hit pixels"):
        optical_flow(two.replace(models=[plane]), two.camera, camera_b=cam_b, hits=hits)
    moved = rs.Camera(eye=(0.7, 0.2, 4.5), width=W, height=H)
    with pytest.raises(ValueError, match=r"^hits: not this scene's and camera's hit buffer"):
        optical_flow(two, two.camera, camera_b=cam_b, hits=rs.render(two, "flat", camera=moved).hits)
