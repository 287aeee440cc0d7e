"""The PNG written band by band (output/pngbands.py): the whole-image encoder's bytes, in bounded memory."""

import io
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from PIL import Image

import raycast_shade as rs
from raycast_shade.output.imagefile import png_bytes, write_image
from raycast_shade.output.pngbands import png_bands, write_png_bands
from raycast_shade.output.tonemap import to_uint8

TONES = [{}, dict(exposure=2.5), dict(tonemap="reinhard", gamma=2.2), dict(tonemap="exponential", gamma=1)]


def _image(rng, h, w, dtype=np.float32):
    """Linear values across every branch of the tone map: negatives, NaN, inf, over 1, denormals."""
    x = rng.uniform(-0.3, 1.6, (h, w, 3))
    pick = rng.uniform(size=(h, w, 3))
    x[pick < 0.03] = np.nan
    x[(pick >= 0.03) & (pick < 0.05)] = np.inf
    x[(pick >= 0.05) & (pick < 0.07)] = 1e-42
    return x.astype(dtype)


@given(h=st.integers(1, 40), w=st.integers(1, 40), rows=st.integers(1, 50), tone=st.sampled_from(TONES),
       seed=st.integers(0, 2 ** 31), f64=st.booleans())
@settings(max_examples=60, deadline=None)
def test_the_bands_give_the_whole_image_encoders_bytes(h, w, rows, tone, seed, f64):
    image = _image(np.random.default_rng(seed), h, w, np.float64 if f64 else np.float32)
    assert png_bands(image, rows=rows, **tone) == png_bytes(to_uint8(image, **tone))


@pytest.mark.parametrize("tone", TONES)
def test_pillow_reads_back_to_uint8(tone):
    """A real decoder as the oracle: the pixels are to_uint8's (a large image: the table route)."""
    image = _image(np.random.default_rng(3), 301, 517)  # 2^18+ values: to_uint8 goes by its table
    data = png_bands(image, rows=64, **tone)
    with Image.open(io.BytesIO(data)) as im:
        assert im.mode == "RGB" and im.size == (517, 301)
        got = np.asarray(im)
    assert np.array_equal(got, to_uint8(image, **tone))


def test_frame_save_writes_the_bytes_write_image_wrote(tmp_path):
    """``Frame.save`` now goes band by band: the file is the one the whole-image route wrote,
    with the frame's own tone options and the call's over them."""
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=0.6, ks=0.4))],
                     lights=[rs.PointLight((2.0, 3.0, 4.0))], camera=rs.Camera(eye=(0.0, 0.0, 3.0), width=64, height=48))
    frame = rs.render(scene, "phong").with_tone(dict(exposure=3.0))
    frame.save(tmp_path / "bands.png", gamma=2.2)
    write_image(tmp_path / "whole.png", frame.image, exposure=3.0, gamma=2.2)
    assert (tmp_path / "bands.png").read_bytes() == (tmp_path / "whole.png").read_bytes()
    assert frame.to_uint8(gamma=2.2).any()  # not a black picture


def test_the_extra_memory_is_two_bands_not_the_image():
    """NumPy's allocations (tracemalloc sees them) while encoding: the 8-bit bands, reused,
    and the compressed stream; the whole-image encoder holds two 8-bit copies of the image."""
    h, w, rows = 2048, 512, 32
    image = np.zeros((h, w, 3), np.float32)
    image[:, :, 1] = np.linspace(0.0, 1.0, w, dtype=np.float32)  # compresses well: the stream stays small
    eight_bit = h * w * 3
    png_bands(image[:rows], rows=rows)  # imports and tables outside the measure
    tracemalloc.start()
    try:
        data = png_bands(image, rows=rows)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        whole = png_bytes(to_uint8(image))
        peak_whole = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert data == whole
    zlib_state = 2 ** 19  # deflate's window and hash tables at level 6: 256 KB, through PyMem
    assert peak < 4 * rows * (3 * w + 1) + 3 * len(data) + zlib_state < eight_bit / 2
    assert peak_whole > 2 * eight_bit  # what the bands avoid


@pytest.mark.parametrize("bad, kind, field", [
    (dict(rows=0), ValueError, "rows"), (dict(rows=1.5), TypeError, "rows"),
    (dict(image=np.zeros((4, 4))), ValueError, "image"), (dict(image=np.zeros((4, 0, 3))), ValueError, "image"),
    (dict(image=[[[0.0, 0.0, 0.0]]]), TypeError, "image"), (dict(tonemap="filmic"), ValueError, "tonemap"),
])
def test_bad_input_is_refused_by_name_before_any_file(tmp_path, bad, kind, field):
    args = {"image": np.zeros((4, 4, 3), np.float32), **bad}
    path = tmp_path / "x.png"
    with pytest.raises(kind, match=field):
        write_png_bands(path, args.pop("image"), **args)
    assert not path.exists()


def test_a_path_not_ending_in_png_is_refused(tmp_path):
    with pytest.raises(ValueError, match="path"):
        write_png_bands(tmp_path / "x.jpg", np.zeros((2, 2, 3), np.float32))
    assert not (tmp_path / "x.jpg").exists()


@pytest.mark.parametrize("fast", [False, True])
def test_the_container_takes_bands_as_it_takes_the_rows_at_once(fast):
    """imagefile.png_file over bands of filtered rows: the pixels Pillow reads are the image's, and
    without ``fast`` the bytes are those of the rows given at once."""
    import io

    from PIL import Image

    from raycast_shade.output.imagefile import png_file, sub_filtered

    img = np.random.default_rng(3).integers(0, 256, (37, 23, 3), dtype=np.uint8)
    raw = sub_filtered(img.reshape(37, 69), 3)
    whole = png_file(raw, 23, 37, bits=8, channels=3, fast=fast)
    banded = png_file(iter([raw[:10], raw[10:11], raw[11:]]), 23, 37, bits=8, channels=3, fast=fast)
    np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(banded))), img)
    if not fast:
        assert banded == whole
