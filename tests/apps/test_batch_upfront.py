"""A batch whose third camera cannot be rendered is refused before the first frame is written."""

import os

import pytest

import raycast_shade as rs
from raycast_shade.apps.batch import render_batch


def test_a_huge_third_camera_is_refused_before_any_frame_is_written(tmp_path):
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=[rs.PointLight((2.0, 2.0, 2.0))],
                     camera=rs.Camera(eye=(0, 0, 4), width=8, height=6))
    cams = [scene.camera, scene.camera, rs.Camera(eye=(0, 0, 4), width=10**6, height=10**6)]
    with pytest.raises(ValueError, match=r"cameras\[2\]: camera.width x camera.height"):
        render_batch(scene, cams, out_dir=str(tmp_path))
    assert os.listdir(tmp_path) == []
