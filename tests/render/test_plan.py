"""render()'s plan checks every argument before any kernel runs: the scene is not even packed
(``scene.has_geometry`` stays False) when an argument is refused, and the messages are the
checks' own (the rasterizer's camera check, ``terms``)."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.visibility.raster import rasterize
from tests.conftest import small_scene

render_module = importlib.import_module("raycast_shade.render")  # rs.render is the function

K = np.array([[40.0, 0.0, 16.0], [0.0, 40.0, 12.0], [0.0, 0.0, 1.0]])


def _distorted():
    return rs.Camera.from_opencv(K, np.eye(3), [0.0, 0.0, 3.0], 32, 24, dist=[0.1, 0.0, 0.0, 0.0])


def test_the_rasterizer_camera_is_refused_before_the_scene_is_packed():
    scene = small_scene()
    with pytest.raises(ValueError) as planned:
        rs.render(scene, camera=_distorted(), backend="raster")
    assert not scene.has_geometry
    with pytest.raises(ValueError) as direct:  # the rasterizer's own message, unchanged
        rasterize(scene.geometry, _distorted())
    assert str(planned.value) == str(direct.value) == (
        "camera.distortion: the rasterizer draws pinhole cameras only; use backend='raycast'")


@pytest.mark.parametrize("terms, samples, exc, match", [
    ("diffuse", 1, ValueError, r"terms: expected True, False or options from \['per_light'\], got 'diffuse'"),
    (3.5, 1, TypeError, r"terms: expected True, False or options from \['per_light'\], got float"),
    (True, 4, ValueError, r"terms: the terms are those of one ray per pixel; with samples=4"),
])
def test_terms_are_checked_in_the_plan(terms, samples, exc, match):
    scene = small_scene()
    with pytest.raises(exc, match=match):
        rs.render(scene, terms=terms, samples=samples)
    assert not scene.has_geometry


def test_the_plan_carries_the_checked_terms():
    scene = small_scene()
    args = ("phong", None, "raycast", "perspective", "auto", 0, 0.01, ())
    assert render_module._plan(scene, *args).terms is None
    assert render_module._plan(scene, *args, terms=True).terms == ()
    assert render_module._plan(scene, *args, terms="PER_LIGHT").terms == ("per_light",)
    assert not scene.has_geometry
