"""Buffer files refuse what they cannot hold (issue 23, item 5): names that collide with the
writer's own arguments or channels, values outside a format's range, wrong shapes, wrong
extensions; and OpenCV camera arguments as OpenCV gives them (``t`` as a (3, 1) column), strings
never numbers. Every refusal names the field and happens before a file is created."""

from __future__ import annotations

import hashlib
import os

import cv2
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.output.bufferfile import load_npz, read_exr, save_npz, write_depth_png, write_exr
from raycast_shade.output.imagefile import write_hashed, write_image, write_png

H, W = 4, 5
Z = np.ones((H, W), np.float32)


def _nothing_written(folder):
    assert os.listdir(folder) == []


@pytest.mark.parametrize("name", ["file", "allow_pickle"])
def test_npz_refuses_the_names_of_savez_arguments(tmp_path, name):
    with pytest.raises(ValueError, match=f"buffers: the name '{name}' is taken by the writer"):
        save_npz(tmp_path / "a.npz", {name: Z})
    _nothing_written(tmp_path)


def test_npz_refuses_names_it_adds_itself_only_when_it_adds_them(tmp_path):
    cam = rs.Camera(eye=(0, 0, 3), width=W, height=H)
    with pytest.raises(ValueError, match="'image' is taken"):
        save_npz(tmp_path / "a.npz", {"image": Z}, image=np.zeros((H, W, 3)))
    with pytest.raises(ValueError, match="'t' is taken"):
        save_npz(tmp_path / "a.npz", {"t": Z}, camera=cam)
    _nothing_written(tmp_path)
    save_npz(tmp_path / "a.npz", {"t": Z})  # no camera: the name is the caller's
    assert np.array_equal(load_npz(tmp_path / "a.npz")["t"], Z)


@pytest.mark.parametrize("buffers, image, match", [
    ({"a": np.array([["x"] * W] * H, dtype=object)}, None, "buffers\\['a'\\]: expected numbers or booleans"),
    ({"a": Z, "b": np.ones((H + 1, W))}, None, "buffers\\['b'\\]: shape \\(5, 5\\) does not match"),
    ({"a": np.ones((H, W, 4))}, None, "buffers\\['a'\\]: expected shape \\(H, W\\) or \\(H, W, 3\\)"),
    ({"a": np.ones(W)}, None, "buffers\\['a'\\]: expected shape"),
    ({"a": Z}, np.zeros((H, W + 1, 3)), "image: expected shape \\(4, 5, 3\\)"),
    ({1: Z}, None, "buffers: expected non-empty str names"),
])
def test_npz_and_exr_check_shapes_and_types(tmp_path, buffers, image, match):
    for writer, ext in ((save_npz, ".npz"), (write_exr, ".exr")):
        with pytest.raises((TypeError, ValueError), match=match):
            writer(tmp_path / ("a" + ext), buffers, image=image)
    _nothing_written(tmp_path)


@pytest.mark.parametrize("ids, bad", [(np.full((H, W), -2), -2), (np.full((H, W), 2**40), 2**40),
                                      (np.full((H, W), 2**31), 2**31)])
def test_exr_refuses_ids_it_cannot_hold_with_the_range(tmp_path, ids, bad):
    with pytest.raises(ValueError, match=f"buffers\\['model_id'\\]: id {bad} outside .*\\[-1, 2147483647\\]"):
        write_exr(tmp_path / "a.exr", {"model_id": ids})
    _nothing_written(tmp_path)


def test_exr_holds_ids_at_both_ends_of_its_range(tmp_path):
    ids = np.array([[-1, 0, 1, 2**31 - 1]], np.int64)
    write_exr(tmp_path / "a.exr", {"triangle_id": ids, "zdepth": np.ones((1, 4), np.float32)})
    back = read_exr(tmp_path / "a.exr")
    assert back["triangle_id"].dtype == np.int32 and np.array_equal(back["triangle_id"], ids)


@pytest.mark.parametrize("buffers, match", [
    ({"label": np.zeros((H, W), np.int32)}, "EXR holds integer and bool buffers only under the names"),
    ({"valid": np.zeros((H, W), bool)}, "EXR holds integer and bool buffers only"),
    ({"n.X": Z}, "a name with a dot"),
    ({"R": Z}, "'R' is taken by the writer"),
    ({"mask": np.zeros((H, W), np.int32)}, "expected an \\(H, W\\) bool mask"),
    ({"z": np.full((H, W), 1e300)}, "beyond the float32 range"),
    ({}, "nothing to write"),
])
def test_exr_refuses_what_it_would_not_give_back(tmp_path, buffers, match):
    with pytest.raises((TypeError, ValueError), match=match):
        write_exr(tmp_path / "a.exr", buffers)
    _nothing_written(tmp_path)


@pytest.mark.parametrize("writer, args", [(save_npz, ({"a": Z},)), (write_exr, ({"a": Z},)),
                                          (write_depth_png, (Z,))])
def test_writers_check_the_extension(tmp_path, writer, args):
    with pytest.raises(ValueError, match="path: .*a.jpg'?: expected a \\.(npz|exr|png) file"):
        writer(tmp_path / "a.jpg", *args)
    _nothing_written(tmp_path)


@pytest.mark.parametrize("depth, scale, match", [
    (-Z, 1000.0, "depth: negative value -1 at \\(row, column\\) \\(0, 0\\)"),
    (np.array([["a"] * W] * H), 1000.0, "depth: expected numbers"),
    (Z, True, "scale: expected a number, got bool"),
    (Z, float("nan"), "scale: must be finite"),
    (np.ones((H, W, 3)), 1000.0, "depth: expected 2-D array"),
])
def test_depth_png_checks_its_input(tmp_path, depth, scale, match):
    with pytest.raises((TypeError, ValueError), match=match):
        write_depth_png(tmp_path / "d.png", depth, scale=scale)
    _nothing_written(tmp_path)


def test_opencv_t_as_a_column_is_taken_as_solvepnp_returns_it():
    rng = np.random.default_rng(3)
    pts = rng.uniform(-1, 1, (12, 3))
    K = np.array([[80.0, 0, 31.5], [0, 80.0, 23.5], [0, 0, 1]])
    rvec, tvec = np.array([0.1, -0.2, 0.05]), np.array([0.2, -0.1, 5.0])
    img, _ = cv2.projectPoints(pts, rvec, tvec, K, None)
    ok, rvec2, tvec2 = cv2.solvePnP(pts, img, K, None, flags=cv2.SOLVEPNP_ITERATIVE)
    assert ok and tvec2.shape == (3, 1)
    R, _ = cv2.Rodrigues(rvec2)
    cam = rs.Camera.from_opencv(K, R, tvec2, 64, 48)
    flat = rs.Camera.from_opencv(K, R, tvec2.ravel(), 64, 48)
    assert np.array_equal(cam.eye, flat.eye) and np.array_equal(cam.to_opencv()[2], flat.to_opencv()[2])
    assert np.allclose(cam.to_opencv()[2], tvec.ravel(), atol=1e-6)


@pytest.mark.parametrize("K", ["abc", [["80", "0", "31.5"], ["0", "80", "23.5"], ["0", "0", "1"]],
                               np.array([[80.0, 0, 31.5], [0, 80.0, 23.5], [0, 0, 1]]).astype(str)])
def test_strings_are_never_taken_as_k(K):
    with pytest.raises(TypeError, match="K: expected numbers"):
        rs.Camera.from_opencv(K, np.eye(3), np.zeros(3), 64, 48)


def test_booleans_are_never_taken_as_t():
    with pytest.raises(TypeError, match="t: expected numbers, got booleans"):
        rs.Camera.from_opencv(np.array([[80.0, 0, 31.5], [0, 80.0, 23.5], [0, 0, 1]]), np.eye(3),
                              [True, False, True], 64, 48)


@pytest.mark.parametrize("value", ["no", "False", None, 0, 1, np.int64(1), [True]])
@pytest.mark.parametrize("writer, name", [
    (lambda p, v: save_npz(p / "a.npz", {"zdepth": Z}, atomic=v), "a.npz"),
    (lambda p, v: write_exr(p / "a.exr", {"zdepth": Z}, atomic=v), "a.exr"),
    (lambda p, v: write_depth_png(p / "a.png", Z, atomic=v), "a.png"),
    (lambda p, v: write_image(p / "a.png", np.zeros((H, W, 3)), atomic=v), "a.png"),
    (lambda p, v: write_png(p / "a.png", np.zeros((H, W), np.uint8), atomic=v), "a.png"),
    (lambda p, v: write_hashed(p / "a.bin", lambda fh: fh.write(b"x"), hashlib.sha256(),
                                                  atomic=v), "a.bin"),
])
def test_atomic_must_be_a_bool_not_a_truthy_value(tmp_path, writer, name, value):
    with pytest.raises(TypeError, match="atomic: expected True or False"):
        writer(tmp_path, value)
    _nothing_written(tmp_path)
    writer(tmp_path, np.True_)  # NumPy's bool is a bool
    assert os.listdir(tmp_path) == [name]
