"""PNG and depth PNG written for speed (fast=True): the same pixels as the default, read by imageio."""

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
