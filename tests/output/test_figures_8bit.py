"""rs.figures with 8-bit pictures (issue 46: ``montage([rs.to_uint8(img)])`` drew a white blob, each level
0-255 taken as a linear value): uint8 is decoded from sRGB to linear, with a note on the figure; other
integer arrays, whose scale is unknown, and 8-bit term images are refused naming the field."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import raycast_shade as rs
from raycast_shade.output.figures import DECODED_NOTE
from raycast_shade.scene.texture import srgb_to_linear

pytest.importorskip("matplotlib")


def _srgb_decoded(u8):
    """The plain-NumPy decode: the IEC 61966-2-1 curve, written out here."""
    c = u8.astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def test_every_8_bit_level_survives_decoding_and_encoding_again():
    levels = np.arange(256, dtype=np.uint8).reshape(16, 16)[..., None].repeat(3, axis=2)
    np.testing.assert_array_equal(rs.to_uint8(srgb_to_linear(levels / 255.0)), levels)


@settings(max_examples=25, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 9), st.integers(1, 9), st.just(3))))
def test_montage_shows_an_8_bit_picture_as_given_with_a_note(u8):
    fig = rs.figures.montage([u8], ["student"])
    np.testing.assert_array_equal(fig.axes[0].images[0].get_array(), u8)  # not a white blob
    assert DECODED_NOTE in fig.get_supxlabel() and "frames_or_images[0]" in fig.get_supxlabel()


def test_montage_of_to_uint8_matches_the_montage_of_the_float_image():
    img = np.random.default_rng(3).uniform(0.0, 1.2, (12, 16, 3))
    a = rs.figures.montage([img]).axes[0].images[0].get_array()
    b = rs.figures.montage([rs.to_uint8(img)]).axes[0].images[0].get_array()
    np.testing.assert_array_equal(a, b)
    assert rs.figures.montage([img]).get_supxlabel() == ""  # float input: no note


def test_profile_and_difference_decode_8_bit_pictures_and_say_so():
    u8 = np.random.default_rng(4).integers(0, 256, (10, 14, 3), dtype=np.uint8)
    (ax,) = rs.figures.profile(u8, 3).axes
    for c, line in enumerate(ax.lines):
        np.testing.assert_allclose(line.get_ydata(), _srgb_decoded(u8)[3, :, c], rtol=1e-12)
    assert DECODED_NOTE in ax.get_ylabel()
    fig = rs.figures.difference(u8, np.zeros((10, 14, 3)))
    im = fig.axes[0].images[0]
    np.testing.assert_allclose(im.get_array(), _srgb_decoded(u8) @ rs.figures.LUMINANCE, rtol=1e-12)
    assert DECODED_NOTE in im.colorbar.ax.get_ylabel() and "a" in im.colorbar.ax.get_ylabel()
    assert DECODED_NOTE not in rs.figures.difference(np.ones((4, 4, 3)), np.zeros((4, 4, 3))).axes[1].get_ylabel()


def test_sixteen_bit_pictures_decode_on_their_own_scale():
    u16 = np.full((4, 4, 3), 65535, np.uint16)
    (ax,) = rs.figures.profile(u16, 0).axes
    np.testing.assert_allclose(ax.lines[0].get_ydata(), 1.0)


@pytest.mark.parametrize("dtype", [np.int64, np.int32, np.int16, np.uint32])
def test_integer_pixels_of_unknown_scale_are_refused_naming_the_field(dtype):
    img = np.full((4, 4, 3), 200, dtype)
    with pytest.raises(TypeError, match=r"frames_or_images\[1\]: .* no known scale"):
        rs.figures.montage([np.zeros((4, 4, 3)), img])
    with pytest.raises(TypeError, match=r"^b: "):
        rs.figures.difference(np.zeros((4, 4, 3)), img)
    with pytest.raises(TypeError, match=r"^frame: "):
        rs.figures.profile(img, 0)


def test_terms_refuse_8_bit_term_images():
    with pytest.raises(TypeError, match=r"terms\['diffuse'\]: uint8 is an 8-bit picture"):
        rs.figures.montage({"diffuse": np.zeros((4, 4, 3), np.uint8)})
