"""render_views' file options: the float image only when asked, compression a choice."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.views import render_views
from raycast_shade.output.bufferfile import load_npz, read_exr


@pytest.fixture(scope="module")
def scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(2))], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=48, height=36))


def _members(path):
    with zipfile.ZipFile(path) as zf:
        return {i.filename: i.compress_type for i in zf.infolist()}


def test_float_image_and_zip_compression_when_asked(scene, tmp_path):
    cam = orbit_cameras(scene.camera, 1)
    render_views(scene, cam, tmp_path / "a", buffers=["zdepth", "id"], formats=["npz", "exr"], image=None)
    render_views(scene, cam, tmp_path / "b", buffers=["zdepth", "id"], formats=["npz", "exr"], image=None,
                 float_image=True, compression="zip")
    plain, zipped = _members(tmp_path / "a" / "view_00000.npz"), _members(tmp_path / "b" / "view_00000.npz")
    assert "image.npy" not in plain and set(plain.values()) == {zipfile.ZIP_STORED}
    assert "image.npy" in zipped and set(zipped.values()) == {zipfile.ZIP_DEFLATED}
    frame = rs.render(scene, camera=cam[0], buffers=("zdepth", "id"))
    a, b = load_npz(tmp_path / "a" / "view_00000.npz"), load_npz(tmp_path / "b" / "view_00000.npz")
    ea, eb = read_exr(tmp_path / "a" / "view_00000.exr"), read_exr(tmp_path / "b" / "view_00000.exr")
    assert "image" not in ea and np.array_equal(eb["image"], frame.image) and np.array_equal(b["image"], frame.image)
    for name, buf in frame.buffers.items():
        assert np.array_equal(a[name], buf) and np.array_equal(b[name], buf) and np.array_equal(eb[name], buf)


def test_bad_file_options_are_refused_before_anything_is_written(scene, tmp_path):
    cam = orbit_cameras(scene.camera, 1)
    with pytest.raises(ValueError, match="compression: expected one of.*'zstd'"):
        render_views(scene, cam, tmp_path / "x", compression="zstd")
    with pytest.raises(TypeError, match="float_image: expected True or False"):
        render_views(scene, cam, tmp_path / "x", float_image="yes")
    assert not (tmp_path / "x").exists()
