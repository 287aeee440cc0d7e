"""The one PNG encoder (8/16-bit, grey/RGB) and the depth PNG made with it, checked by real readers
(imageio's Pillow, OpenCV); fast=True gives the same pixels as the default."""

from __future__ import annotations

import sys

import imageio.v3 as iio
import numpy as np
import pytest

from raycast_shade.output.bufferfile import read_depth_png, write_depth_png
from raycast_shade.output.imagefile import png_bytes, write_png


def _rgb():
    rng = np.random.default_rng(7)
    base = np.linspace(0, 255, 37 * 3).reshape(1, 37, 3)
    return np.clip(base + rng.integers(-3, 4, (29, 37, 3)), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("isal", [True, False])
def test_fast_png_has_the_pixels_of_the_default(tmp_path, monkeypatch, isal):
    if isal:
        pytest.importorskip("isal")
    else:
        monkeypatch.setitem(sys.modules, "isal", None)  # import isal fails: the zlib fallback
    rgb = _rgb()
    write_png(tmp_path / "fast.png", rgb, fast=True)
    assert np.array_equal(iio.imread(tmp_path / "fast.png"), rgb)
    assert np.array_equal(iio.imread(png_bytes(rgb)), rgb)


@pytest.mark.parametrize("isal", [True, False])
def test_fast_depth_png_reads_back_as_the_default(tmp_path, monkeypatch, isal):
    if not isal:
        monkeypatch.setitem(sys.modules, "isal", None)
    rng = np.random.default_rng(8)
    depth = rng.uniform(0.5, 9.0, (21, 33))
    depth[3, 4] = 0.0
    write_depth_png(tmp_path / "a.png", depth)
    write_depth_png(tmp_path / "b.png", depth, fast=True)
    a, b = read_depth_png(tmp_path / "a.png"), read_depth_png(tmp_path / "b.png")
    assert np.array_equal(a, b) and b[3, 4] == 0.0
    assert np.abs(b[depth > 0] - depth[depth > 0]).max() <= 0.5e-3 + 1e-6


def test_fast_must_be_a_flag(tmp_path):
    from raycast_shade.output.imagefile import write_image

    with pytest.raises(TypeError, match="fast: expected True or False"):
        write_depth_png(tmp_path / "a.png", np.ones((2, 2)), fast="yes")
    with pytest.raises(TypeError, match="fast: expected True or False"):
        write_image(tmp_path / "b.png", np.ones((2, 2, 3), np.float32), fast=1)
    assert not list(tmp_path.iterdir())


def _depth_reference(depth, scale):
    """The 16-bit samples in plain NumPy: round(depth * scale) in float64; 0 where none or past 16 bits."""
    d = np.asarray(depth, np.float64)
    q = np.where(np.isfinite(d) & (d > 0), np.rint(d * scale), 0.0)
    return np.where(q <= 65535, q, 0.0).astype(np.uint16)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("scale", [1000.0, 1.0, 0.37])
def test_depth_png_samples_equal_the_numpy_formula(tmp_path, dtype, scale):
    rng = np.random.default_rng(11)
    depth = rng.uniform(0, 80.0, (23, 31)).astype(dtype)
    depth[0, :8] = [0.0, np.nan, np.inf, 65535.5 / scale, 65534.5 / scale, 0.5 / scale, 1.5 / scale, 2.5 / scale]
    depth[1, :3] = [-0.0, 1e300 if dtype == np.float64 else 3e38, 65536.0 / scale]
    write_depth_png(tmp_path / "d.png", depth, scale=scale, fast=True)
    got = iio.imread(tmp_path / "d.png")
    assert got.dtype == np.uint16
    assert np.array_equal(got, _depth_reference(depth, scale))


def test_depth_png_names_the_first_negative_value(tmp_path):
    depth = np.ones((4, 5), np.float32)
    depth[2, 3], depth[3, 0] = -0.25, -1.0
    with pytest.raises(ValueError, match=r"negative value -0.25 at \(row, column\) \(2, 3\)"):
        write_depth_png(tmp_path / "d.png", depth)
    assert not (tmp_path / "d.png").exists()


def _images():
    """8- and 16-bit, grey and RGB, with every byte value and the wrap-around of the Sub filter."""
    rng = np.random.default_rng(12)
    return {
        "grey8": rng.integers(0, 256, (19, 23), dtype=np.uint8),
        "rgb8": rng.integers(0, 256, (19, 23, 3), dtype=np.uint8),
        "grey16": rng.integers(0, 65536, (19, 23), dtype=np.uint16),
        "rgb16": rng.integers(0, 65536, (19, 23, 3), dtype=np.uint16),
        "grey16_edges": np.array([[0, 1, 255, 256, 65534, 65535]], np.uint16),
        "rgb8_strided": rng.integers(0, 256, (10, 30, 3), dtype=np.uint8)[:, ::3],
    }


@pytest.mark.parametrize("name", list(_images()))
@pytest.mark.parametrize("fast", [False, True])
def test_png_bytes_decode_to_the_image_in_two_readers(tmp_path, name, fast):
    """OpenCV (libpng) reads back every sample at the written bit depth, Pillow (through imageio) too
    except for 16-bit RGB, which Pillow has no mode for: it gives each sample's high byte."""
    cv2 = pytest.importorskip("cv2")
    img = _images()[name]
    data = png_bytes(img, fast=fast)
    got = iio.imread(data)
    if name == "rgb16":
        assert got.dtype == np.uint8 and np.array_equal(got, (img >> 8).astype(np.uint8))
    else:
        assert got.dtype == img.dtype and np.array_equal(got, img)
    (tmp_path / "a.png").write_bytes(data)
    got = cv2.imread(str(tmp_path / "a.png"), cv2.IMREAD_UNCHANGED)
    want = img if img.ndim == 2 else img[:, :, ::-1]  # OpenCV reads BGR
    assert got.dtype == img.dtype and np.array_equal(got, want)


def test_depth_png_is_png_bytes_of_its_samples():
    """One encoder: the depth file is the generic 16-bit grey PNG of round(depth * scale)."""
    from raycast_shade.output.bufferfile import depth_png_bytes

    depth = np.random.default_rng(13).uniform(0, 70.0, (17, 21))
    depth[0, :3] = [0.0, np.nan, 66.0]  # none, none, past 16 bits: 0
    for fast in (False, True):
        assert depth_png_bytes(depth, fast=fast) == png_bytes(_depth_reference(depth, 1000.0), fast=fast)


def test_png_header_says_bits_and_colour():
    """IHDR: width, height, bit depth, colour type (0 grey, 2 RGB), as the PNG specification lays it out."""
    import struct

    for img, bits, colour in [(np.zeros((2, 5), np.uint8), 8, 0), (np.zeros((2, 5, 3), np.uint8), 8, 2),
                              (np.zeros((2, 5), np.uint16), 16, 0), (np.zeros((2, 5, 3), np.uint16), 16, 2)]:
        data = png_bytes(img)
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
        assert struct.unpack(">IIBBBBB", data[16:29]) == (5, 2, bits, colour, 0, 0, 0)


def test_png_bytes_refuse_what_they_cannot_store(tmp_path):
    with pytest.raises(TypeError, match="image: expected uint8 or uint16 pixels, got dtype float32"):
        png_bytes(np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ValueError, match=r"image: expected a non-empty \(H, W\) or \(H, W, 3\) array"):
        png_bytes(np.zeros((2, 2, 4), np.uint8))
    with pytest.raises(ValueError, match="image: expected a non-empty"):
        png_bytes(np.zeros((0, 2), np.uint8))
    with pytest.raises(TypeError, match="fast: expected True or False"):
        png_bytes(np.zeros((2, 2), np.uint8), fast=1)
    with pytest.raises(TypeError, match="image"):
        write_png(tmp_path / "a.png", np.zeros((2, 2), np.int64))
    assert not list(tmp_path.iterdir())  # encoded before the file is opened


def test_write_png_atomic_replaces_the_file_whole(tmp_path, monkeypatch):
    import os

    path = tmp_path / "a.png"
    old = png_bytes(np.zeros((3, 4), np.uint8))
    path.write_bytes(old)
    new = np.full((3, 4, 3), 200, np.uint8)

    def fail(*args):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="disk full"):
        write_png(path, new, atomic=True)
    assert path.read_bytes() == old and sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]
    monkeypatch.undo()
    assert write_png(path, new, atomic=True) == str(path)
    assert path.read_bytes() == png_bytes(new) and sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]
