"""The 8-bit tone mapping by table (output/quantize.py) gives to_uint8's bytes, everywhere."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from raycast_shade.output.imagefile import write_image
from raycast_shade.output.quantize import _curve_uint8 as to_uint8  # the curve itself: the table's oracle
from raycast_shade.output.quantize import _quantize_kernel, _tables, thresholds, to_uint8_table
from raycast_shade.output import tonemap

TONES = [{}, {"exposure": 2.5}, {"exposure": 1e-3, "gamma": 0.5}, {"tonemap": "reinhard"},
         {"tonemap": "exponential", "gamma": 2.2}, {"gamma": 1}, {"exposure": 300.0, "tonemap": "reinhard", "gamma": 3}]
SPECIALS = np.array([np.nan, -np.nan, np.inf, -np.inf, -0.0, 0.0, -1.0, 1e-45, 1.2e-38, 3.4e38, 1.0, 0.5, 1e-6],
                    np.float32)


def _values(rng, n=200_000):
    """Log-uniform magnitudes over float32's range, a few negatives, and the specials."""
    x = np.exp(rng.uniform(np.log(1e-40), np.log(1e38), n)).astype(np.float32)
    x[: n // 10] *= -1
    x[n // 10: n // 2] = rng.uniform(0, 1.2, n // 2 - n // 10)  # where the codes change
    return np.concatenate([SPECIALS, x])


@pytest.mark.parametrize("tone", TONES, ids=str)
def test_table_equals_the_curve_on_random_values_and_at_every_threshold(tone):
    x = _values(np.random.default_rng(5))
    assert np.array_equal(to_uint8_table(x, **tone), to_uint8(x, **tone))
    t, inf_code = thresholds(**tone)
    # Each threshold and its neighbours, 4 patterns either side: where a wrong table would show.
    near = (t[1:, None].astype(np.int64) + np.arange(-4, 5)).clip(0, 0x7F800000).astype(np.int32).view(np.float32)
    near = near.ravel()
    assert np.array_equal(to_uint8_table(near, **tone), to_uint8(near, **tone))
    assert inf_code == to_uint8(np.array([np.inf], np.float32), **tone)[0]


@pytest.mark.parametrize("tone", TONES[:4], ids=str)
def test_thresholds_are_the_first_value_of_each_code(tone):
    t, _ = thresholds(**tone)
    assert t[0] == 0 and np.all(np.diff(t) >= 0)
    reached = t[1:] < 0x7F800000
    first = t[1:][reached].view(np.float32)
    before = (t[1:][reached] - 1).view(np.float32)
    codes = np.arange(1, 256)[reached]
    assert np.all(to_uint8(first, **tone) >= codes)  # the threshold reaches its code ...
    assert np.all(to_uint8(before, **tone) < codes)  # ... and the float32 below it does not


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(width=32, allow_nan=True, allow_infinity=True), min_size=1, max_size=40),
       st.floats(1e-3, 1e3), st.sampled_from(["clamp", "reinhard", "exponential"]),
       st.sampled_from(["srgb", 1.0, 1.8, 2.2]))
def test_table_equals_the_curve_for_any_values_and_setting(values, exposure, tonemap, gamma):
    x = np.resize(np.array(values, np.float32), 300)  # repeated to the table's minimum size (256)
    assert np.array_equal(to_uint8_table(x, exposure, tonemap, gamma), to_uint8(x, exposure, tonemap, gamma))


def test_table_falls_back_to_the_curve_and_checks_the_settings():
    x64 = np.linspace(0, 1, 300)
    assert np.array_equal(to_uint8_table(x64), to_uint8(x64))  # float64: the curve itself
    with pytest.raises(ValueError, match="tonemap"):
        to_uint8_table(np.zeros(300, np.float32), tonemap="filmic")
    with pytest.raises(ValueError, match="exposure"):
        to_uint8_table(np.zeros(300, np.float32), exposure=-1)


def test_kept_tables_are_read_only_and_checked_again_for_every_setting():
    x = _values(np.random.default_rng(8), 5_000)
    first = to_uint8_table(x, 2.0, "reinhard", 2.2)
    walk, bucket, _ = _tables(2.0, "reinhard", 2.2)
    assert _tables(2.0, "reinhard", 2.2)[0] is walk  # kept, not bisected again
    assert not walk.flags.writeable and not bucket.flags.writeable
    assert np.array_equal(to_uint8_table(x, 2.0, "reinhard", 2.2), first)
    assert np.array_equal(first, to_uint8(x, 2.0, "reinhard", 2.2))
    to_uint8_table(x, exposure=1)  # a kept setting of 1 does not admit True, which to_uint8 refuses
    with pytest.raises((TypeError, ValueError), match="exposure"):
        to_uint8(x, exposure=True)
    with pytest.raises((TypeError, ValueError), match="exposure"):
        to_uint8_table(x, exposure=True)
    gamma = np.array(2.2)  # unhashable: not kept, still mapped
    assert np.array_equal(to_uint8_table(x, gamma=gamma), to_uint8(x, gamma=gamma))


def test_png_file_holds_the_curves_pixels(tmp_path):
    rng = np.random.default_rng(3)
    img = rng.uniform(0, 1.3, (37, 53, 3)).astype(np.float32)
    img[0, 0] = [np.nan, np.inf, -1]
    for fast in (False, True):
        write_image(tmp_path / "a.png", img, fast=fast, exposure=1.5)
        assert np.array_equal(iio.imread(tmp_path / "a.png"), to_uint8(img, exposure=1.5))


def test_the_default_table_equals_the_curve_on_every_float32_between_its_thresholds():
    """Exhaustive for the default setting (clamp, sRGB): every float32 from one pattern below the
    first threshold to the pattern of 1.0 (about 110 million values: each code's whole interval),
    by the curve and by the table; below, the codes are 0 and above 1 they are 255 (clamp)."""
    t, _ = thresholds()
    walk, bucket, inf_code = _tables(1.0, "clamp", "srgb")
    top = int(np.float32(1.0).view(np.int32))
    step = 1 << 23
    for lo in range(int(t[1]) - 1, top + 1, step):
        bits = np.arange(lo, min(lo + step, top + 1), dtype=np.int32)
        got = np.empty(bits.shape[0], np.uint8)
        assert _quantize_kernel(bits, walk, bucket, 13, np.uint8(inf_code), got) == 0
        assert np.array_equal(got, to_uint8(bits.view(np.float32)))
    assert to_uint8(np.float32(1.0)) == 255 and to_uint8(t[1:2].view(np.float32) * np.float32(0.999)) == 0


@pytest.mark.parametrize("tone", TONES[:3], ids=str)
def test_to_uint8_takes_the_table_for_large_float32_images(tone, monkeypatch):
    """``tonemap.to_uint8`` goes by the table at 2^18 values and more, by the curve below and for
    other dtypes: the same bytes (the twin of the curve, study.twins, checks it independently)."""
    from raycast_shade.output import quantize

    calls = []
    real = quantize._quantize_kernel
    monkeypatch.setattr(quantize, "_quantize_kernel", lambda *a: calls.append(1) or real(*a))
    big = _values(np.random.default_rng(11), n=quantize._TABLE_VALUES)
    assert np.array_equal(tonemap.to_uint8(big, **tone), to_uint8(big, **tone)) and calls == [1]
    small = big[: quantize._TABLE_VALUES - 1]
    assert np.array_equal(tonemap.to_uint8(small, **tone), to_uint8(small, **tone)) and calls == [1]
    assert np.array_equal(tonemap.to_uint8(big.astype(np.float64), **tone), to_uint8(big, **tone)) and calls == [1]
