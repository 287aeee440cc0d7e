"""Pose tracks (keyframes, orbits, the check) and the scene file's [[motion]] tables."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

import raycast_shade as rs
from raycast_shade.scene.motionfile import motion_from_dict
from raycast_shade.scene.posetrack import check_pose_track
from raycast_shade.scene.scenefile import SceneFileError, scene_from_dict


def _poses(rotations, translations):
    P = np.zeros((len(translations), 4, 4))
    P[:, :3, :3] = rotations.as_matrix()
    P[:, :3, 3] = translations
    P[:, 3, 3] = 1.0
    return P


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.lists(st.integers(1, 6), min_size=1, max_size=4))
def test_keyframes_slerp_like_scipy_and_move_linearly_between_keys(seed, gaps):
    rng = np.random.default_rng(seed)
    keys = np.cumsum([rng.integers(0, 3)] + gaps)
    rot = Rotation.random(len(keys), random_state=seed)
    trans = rng.normal(size=(len(keys), 3))
    n = int(keys[-1]) + 3
    track = rs.keyframes(keys, _poses(rot, trans), n)
    inner = np.arange(keys[0], keys[-1] + 1)
    ref = Slerp(keys, rot)(inner).as_matrix()
    assert np.abs(track[inner, :3, :3] - ref).max() < 1e-12
    lerp = np.stack([np.interp(inner, keys, trans[:, k]) for k in range(3)], axis=-1)
    assert np.abs(track[inner, :3, 3] - lerp).max() < 1e-12
    assert np.array_equal(track[keys], _poses(rot, trans))  # a key's pose bit for bit
    assert (track[:keys[0]] == track[keys[0]]).all() and (track[keys[-1]:] == track[keys[-1]]).all()  # held
    check_pose_track(track, "track", n)  # rigid


def test_keyframes_take_the_shorter_arc():
    half = np.eye(4)
    half[:3, :3] = Rotation.from_euler("z", 270, degrees=True).as_matrix()  # = -90: the short way is negative
    mid = rs.keyframes([0, 2], [np.eye(4), half], 3)[1]
    assert np.allclose(mid[:3, :3], Rotation.from_euler("z", -45, degrees=True).as_matrix(), atol=1e-12)


def test_orbit_poses_turn_about_an_axis_through_the_centre():
    c = np.array([1.0, 2.0, -0.5])
    P = rs.orbit_poses(8, axis=(0, 0, 2), degrees=180, center=c)
    assert P.shape == (8, 4, 4) and np.array_equal(P[0], np.eye(4))
    for i, M in enumerate(P):
        assert np.allclose(M[:3, :3] @ c + M[:3, 3], c, atol=1e-12)  # the centre stays
        assert np.allclose(M[:3, :3], Rotation.from_euler("z", 180 * i / 8, degrees=True).as_matrix(), atol=1e-12)
    start = rs.keyframes([0], [_poses(Rotation.from_euler("x", [30], degrees=True), [[0.0, 1.0, 0.0]])[0]], 1)[0]
    Q = rs.orbit_poses(4, axis=(0, 1, 0), start=start)
    assert np.allclose(Q[0], start) and np.allclose(Q[2, :3, 3], [0.0, 1.0, 0.0])  # on the axis: it stays


@pytest.mark.parametrize("value, message", [
    (np.zeros((3, 4)), r"track: expected a \(V, 4, 4\)"),
    (np.tile(np.eye(4), (2, 1, 1)), r"track: expected one pose per view \(3\), got 2"),
    (np.tile(np.diag([2.0, 1, 1, 1]), (3, 1, 1)), r"track\[0\]: its 3x3 part must be a rotation"),
    (np.tile(np.diag([-1.0, 1, 1, 1]), (3, 1, 1)), r"track\[0\]: .*determinant -1"),
])
def test_a_pose_track_is_checked_with_its_name_and_view(value, message):
    with pytest.raises(ValueError, match=message):
        check_pose_track(value, "track", 3)
    bad = np.tile(np.eye(4), (3, 1, 1))
    bad[2, 3, 0] = 1.0
    with pytest.raises(ValueError, match=r"track\[2\]: last row"):
        check_pose_track(bad, "track", 3)
    with pytest.raises(ValueError, match="views: expected strictly increasing"):
        rs.keyframes([2, 1], np.tile(np.eye(4), (2, 1, 1)), 4)


_FILE = {"camera": {"eye": [0.0, 0.0, 4.0], "width": 16, "height": 12},
         "object": [{"shape": "cube", "name": "box", "translate": [1.0, 0.0, 0.0]}, {"shape": "icosphere"}]}


def _scene(motion):
    data = {**_FILE, "motion": motion}
    return data, scene_from_dict(data)[0]


def test_motion_tables_give_orbits_and_keyframes_per_model():
    data, scene = _scene([{"model": "box", "pivot": [1.0, 0.0, 0.0], "orbit": {"axis": [0, 1, 0], "degrees": 90}},
                          {"model": 1, "keyframes": [{"view": 0}, {"view": 2, "rotate": [0, 0, 90],
                                                                   "translate": [0, 1, 0]}]}])
    tracks = motion_from_dict(data, scene, 3)
    assert sorted(tracks) == [0, 1]
    assert np.allclose(tracks[0], rs.orbit_poses(3, (0, 1, 0), 90, center=(1, 0, 0)), atol=1e-15)
    assert np.allclose(tracks[1][2][:3, :3], Rotation.from_euler("z", 90, degrees=True).as_matrix(), atol=1e-12)
    assert np.allclose(tracks[1][2][:3, 3], [0, 1, 0]) and np.allclose(tracks[1][1][:3, 3], [0, 0.5, 0])


@pytest.mark.parametrize("motion, message", [
    ([{"model": "lid", "orbit": {}}], r"motion\[0\].model: no model is named 'lid'"),
    ([{"model": 5, "orbit": {}}], r"motion\[0\].model"),
    ([{"model": 0}], r"motion\[0\]: needs exactly one of 'orbit' or 'keyframes'"),
    ([{"model": 0, "orbit": {"axis": [0, 1, 0], "speed": 2}}], r"motion\[0\].orbit: unknown key 'speed'"),
    ([{"model": 0, "keyframes": [{"view": 3}, {"view": 1}]}], r"motion\[0\].keyframes: the views must increase"),
    ([{"model": 0, "keyframes": [{"rotate": [0, 0, 0]}]}], r"motion\[0\].keyframes\[0\]: missing 'view'"),
    ([{"model": 0, "orbit": {}}, {"model": "box", "orbit": {}}], r"motion\[1\].model: model 0 \('box'\) is moved"),
    ([{"orbit": {}}], r"motion\[0\]: missing 'model'"),
])
def test_bad_motion_tables_name_the_file_table_and_key(motion, message):
    data, scene = _scene(motion)
    with pytest.raises(SceneFileError, match=r"^shapes.toml: " + message):
        motion_from_dict(data, scene, 4, source="shapes.toml")
