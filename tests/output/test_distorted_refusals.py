"""Frames of a distorted camera: explain() and the overlays refuse them (they follow pinhole rays)."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs


@pytest.fixture(scope="module")
def frame():
    K = np.array([[40.0, 0.0, 20.0], [0.0, 40.0, 15.0], [0.0, 0.0, 1.0]])
    cam = rs.Camera.from_opencv(K, np.eye(3), np.array([0.0, 0.0, 3.0]), 40, 30, dist=(0.1, -0.02, 0.0, 0.0, 0.0))
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(2))], lights=[rs.PointLight((2, 3, 4), intensity=20)], camera=cam)
    return rs.render(scene)


def test_explain_refuses_a_distorted_frame(frame):
    assert frame.mask[15, 20]
    with pytest.raises(ValueError, match="explain: the frame's camera has lens distortion"):
        frame.explain(20, 15)


@pytest.mark.parametrize("call", [lambda f: f.overlay(), lambda f: rs.overlays.distances(f),
                                  lambda f: rs.overlays.normal_glyphs(f)])
def test_overlays_refuse_a_distorted_frame(frame, call):
    with pytest.raises(ValueError, match="overlays draw a pinhole projection.*lens distortion"):
        call(frame)


def test_a_pinhole_frame_still_explains_and_overlays(frame):
    plain = rs.render(frame.scene, camera=frame.camera.replace(distortion=None))
    assert plain.explain(20, 15).total.shape == (3,)
    assert plain.overlay().shape == (30, 40, 3)
