"""Everything that reads a model's place in the world reads it posed: a model with a pose and the
same mesh moved into the world by hand give the same camera fit, pitfall warnings, auto choice
and animation centre (the BOP writer's ``Model.pose``, docs/vision.md)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.animate import _scene_center
from raycast_shade.common.warnings import LightInsideWarning
from raycast_shade.scene.pitfalls import warn_render


def _pose(deg=35.0, t=(2.0, -1.0, 0.5)):
    a = np.radians(deg)
    P = np.eye(4)
    P[:3, :3] = [[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]]
    P[:3, 3] = t
    return P


def _pair():
    """(posed model, the same mesh moved by hand): a box longer in x, so a rotation shows."""
    mesh = rs.Mesh.from_trimesh(__import__("trimesh").creation.box(extents=(2.0, 0.5, 0.5)))
    P = _pose()
    moved = rs.Mesh(mesh.vertices @ P[:3, :3].T + P[:3, 3], mesh.faces)
    return rs.Model(mesh, pose=P), rs.Model(moved)


def test_camera_fit_frames_the_posed_model_where_it_stands():
    posed, moved = _pair()
    a = rs.Camera.fit(posed, direction=(0.2, -0.3, -1.0), width=64, height=48)
    b = rs.Camera.fit(moved, direction=(0.2, -0.3, -1.0), width=64, height=48)
    np.testing.assert_allclose(a.eye, b.eye, atol=1e-9)
    np.testing.assert_allclose(a.target, b.target, atol=1e-9)


def test_a_light_inside_the_posed_closed_mesh_is_found_and_one_outside_is_not():
    posed, moved = _pair()
    inside = rs.PointLight(position=_pose()[:3, 3] + _pose()[:3, :3] @ [0.8, 0.0, 0.0])  # in the long box's end
    outside = rs.PointLight(position=_pose()[:3, 3] + _pose()[:3, :3] @ [0.0, 0.0, 0.8])  # beside it
    cam = rs.Camera.fit(moved, direction=(0.0, 0.0, -1.0), width=32, height=24)
    for model in (posed, moved):
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            warn_render(rs.Scene([model], [inside], cam), "phong")
        assert any(issubclass(w.category, LightInsideWarning) for w in got)
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            warn_render(rs.Scene([model], [outside], cam), "phong")
        assert not any(issubclass(w.category, LightInsideWarning) for w in got)


def test_auto_and_the_animation_centre_see_the_posed_model_where_it_stands():
    posed, moved = _pair()
    light = rs.PointLight(position=(2.0, 3.0, 4.0))
    cam = rs.Camera.fit(moved, direction=(0.0, 0.0, -1.0), width=32, height=24)
    sa, sb = rs.Scene([posed], [light], cam), rs.Scene([moved], [light], cam)
    np.testing.assert_allclose(_scene_center(sa), _scene_center(sb), atol=1e-12)
    from raycast_shade.insight.auto import choose_methods

    assert [d.method for d in choose_methods(sa, cam)] == [d.method for d in choose_methods(sb, cam)]
