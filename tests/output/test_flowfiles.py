"""Flow files: Middlebury .flo and KITTI 16-bit PNGs read back by our readers and OpenCV, and the colour wheel."""

from __future__ import annotations

import struct

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.output.flowfiles import KITTI_MAX, UNKNOWN_FLOW, FlowRangeWarning, color_wheel


def _flow(seed, h=5, w=7, scale=40.0):
    return np.random.default_rng(seed).normal(scale=scale, size=(h, w, 2))


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(1, 9), st.integers(1, 9))
def test_flo_files_read_back_bit_exact_by_us_and_opencv(tmp_path_factory, seed, h, w):
    path = str(tmp_path_factory.mktemp("flo") / "a.flo")
    flow = _flow(seed, h, w)
    valid = np.random.default_rng(seed + 1).random((h, w)) < 0.7
    rs.write_flo(path, flow, valid)
    raw = open(path, "rb").read()
    assert raw[:4] == b"PIEH" and struct.unpack("<f", raw[:4])[0] == 202021.25
    assert struct.unpack("<ii", raw[4:12]) == (w, h) and len(raw) == 12 + 8 * h * w
    ours, theirs = rs.read_flo(path), cv2.readOpticalFlow(path)
    assert ours.dtype == np.float32 and np.array_equal(ours.view(np.uint32), theirs.view(np.uint32))
    expect = np.where(valid[..., None], flow, UNKNOWN_FLOW).astype(np.float32)
    assert np.array_equal(ours, expect)


def test_opencv_written_flo_files_read_back_by_ours(tmp_path):
    flow = _flow(3).astype(np.float32)
    path = str(tmp_path / "cv.flo")
    assert cv2.writeOpticalFlow(path, flow)
    assert np.array_equal(rs.read_flo(path), flow)


def test_kitti_pngs_hold_u_v_in_64ths_and_the_valid_mask(tmp_path):
    flow = _flow(5, 6, 9, scale=100.0)
    valid = np.ones((6, 9), bool)
    valid[2, 3] = False
    path = str(tmp_path / "f.png")
    rs.write_flow_png(path, flow, valid)
    raw = cv2.imread(path, cv2.IMREAD_UNCHANGED)[..., ::-1]  # a 16-bit RGB PNG, read by OpenCV as BGR
    assert raw.dtype == np.uint16
    assert np.array_equal(raw[..., 0][valid], np.rint(flow[..., 0] * 64 + 2**15)[valid])
    assert np.array_equal(raw[..., 1][valid], np.rint(flow[..., 1] * 64 + 2**15)[valid])
    assert np.array_equal(raw[..., 2], valid.astype(np.uint16)) and raw[2, 3, 0] == 2**15
    back, ok = rs.read_flow_png(path)
    assert np.array_equal(ok, valid) and np.abs(back - flow)[valid].max() <= 1 / 128 + 1e-12


def test_a_flow_beyond_kitti_range_is_clamped_marked_invalid_and_warned(tmp_path):
    flow = np.zeros((2, 2, 2))
    flow[0, 1, 0] = 600.0
    with pytest.warns(FlowRangeWarning, match="1 pixels' flow exceeds"):
        rs.write_flow_png(str(tmp_path / "f.png"), flow)
    back, ok = rs.read_flow_png(str(tmp_path / "f.png"))
    assert ok.tolist() == [[True, False], [True, True]] and back[0, 1, 0] == KITTI_MAX


def test_flow_files_refuse_bad_input_naming_it(tmp_path):
    with pytest.raises(ValueError, match=r"flow: expected an \(H, W, 2\)"):
        rs.write_flo(str(tmp_path / "a.flo"), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="path: .*expected a .flo file"):
        rs.write_flo(str(tmp_path / "a.png"), np.zeros((3, 3, 2)))
    with pytest.raises(ValueError, match="flow: holds NaN"):
        rs.write_flow_png(str(tmp_path / "a.png"), np.full((3, 3, 2), np.nan))
    with pytest.raises(ValueError, match=r"valid: expected an \(3, 3\) bool"):
        rs.write_flo(str(tmp_path / "a.flo"), np.zeros((3, 3, 2)), np.ones((2, 2), bool))
    (tmp_path / "b.flo").write_bytes(b"PIEH" + struct.pack("<ii", 4, 4) + b"\0" * 8)
    with pytest.raises(ValueError, match="b.flo: header says 4x4"):
        rs.read_flo(str(tmp_path / "b.flo"))
    (tmp_path / "c.flo").write_bytes(b"\0" * 20)
    with pytest.raises(ValueError, match="c.flo: not a .flo file"):
        rs.read_flo(str(tmp_path / "c.flo"))
    cv2.imwrite(str(tmp_path / "g.png"), np.zeros((3, 3), np.uint16))
    with pytest.raises(ValueError, match="g.png: expected a 16-bit RGB PNG"):
        rs.read_flow_png(str(tmp_path / "g.png"))


def test_the_colour_wheel_is_middleburys():
    wheel = color_wheel()
    assert wheel.shape == (55, 3)
    # Segment starts: red, yellow, green, cyan, blue, magenta.
    for k, rgb in zip(np.cumsum([0, 15, 6, 4, 11, 13]), [(255, 0, 0), (255, 255, 0), (0, 255, 0), (0, 255, 255),
                                                         (0, 0, 255), (255, 0, 255)]):
        assert tuple(wheel[k]) == rgb
    flow = np.array([[[1.0, 0.0], [0.0, 0.0], [-1.0, 0.0], [0.5, 0.0], [2.0, 0.0]]])
    valid = np.array([[True, True, True, True, False]])
    img = rs.flow_colors(flow, valid, background=(7, 7, 7))
    assert tuple(img[0, 0]) == (255, 0, 0)  # right, full length: red
    assert tuple(img[0, 1]) == (255, 255, 255)  # no motion: white
    assert img[0, 2, 0] == 0 and img[0, 2, 1] > 200 and img[0, 2, 2] > 200  # left: cyan
    assert tuple(img[0, 3]) == (255, 127, 127)  # half length: half saturated
    assert tuple(img[0, 4]) == (7, 7, 7)
    darker = rs.flow_colors(flow[:, :1] * 2, max_flow=1.0)
    assert tuple(darker[0, 0]) == (191, 0, 0)  # beyond max_flow: a quarter darker
