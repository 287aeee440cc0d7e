"""The 8-bit tone mapping of a float32 image by table: :func:`to_uint8_table`, equal to the curve.

``_curve_uint8`` evaluates the tone curve (exposure, range, sRGB or gamma)
in float64 for every value: a ``pow`` per value, about 45 ms for a 1080p
image on one core (a view set's writer thread) or 30 ms on two. For float32
input the mapping is a non-decreasing step function of the value, so it is
fixed by 255 thresholds: ``t[k]``, the smallest float32 that maps to ``k``
or more. They are found by bisection over the float32 bit patterns,
evaluating ``_curve_uint8`` itself (31 calls on 255 values, about 3 ms
whatever the image's size), so no second copy of the curve exists; the
tables of the last 16 settings are kept, so the frames of a view set or an
animation pay that once. A value's code is then the number of thresholds at
or below it: a table indexed by the top 19 bits of its pattern (sign,
exponent, 10 mantissa bits; 256 KiB) gives the code at the start of its
bucket of 8,192 patterns, and a short walk over the next thresholds
finishes it. On one core this is several times faster than the curve
(about 6 ms for a rendered 1080p frame, quiet; 15-20 ms loaded; a copy of
the image takes 8), and it runs on the calling thread only and without the
GIL, so a view set's writer thread neither takes the cores from the next
render nor holds its Python thread. :func:`~raycast_shade.output.tonemap.to_uint8`
takes it for float32 images of at least ``_TABLE_VALUES`` values.

Non-negative float32 patterns order as their values, and the curve is
non-decreasing in float64 with errors of an ulp of float64, far below the
gap between two float32 inputs, so the codes equal ``_curve_uint8``'s bit
for bit (``tests/output/test_quantize.py`` checks every setting on random
values and on each threshold's neighbours, and the default setting on every
float32 between its first and last threshold). NaN maps to 0 as there;
``+inf`` to what the curve gives it (255); values with the sign bit set
(negatives, ``-0``) are handed to the curve itself, rare in a rendered image.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit

from ..common.choices import TONEMAPS
from ..common.parallel import in_parts, share
from ..common.validate import as_scalar

__all__ = ["to_uint8_table", "thresholds"]

# tonemap.to_uint8 takes the table for float32 images of at least this many values: below, the
# bisection of a setting not yet kept (about 3 ms) costs more than the curve of the whole image.
_TABLE_VALUES = 1 << 18

_CHUNK = 1 << 16  # values per parallel work item


@in_parts
@njit(nogil=True, cache=True, error_model="numpy", no_cfunc_wrapper=True)
def _to_uint8_kernel(x, exposure, curve, inv_gamma, out, part):
    """Tone-map ``x`` (N,) float32/float64 into ``out`` (N,) uint8.

    ``curve``: 0 clamp, 1 reinhard, 2 exponential; ``inv_gamma`` 0 selects
    sRGB. Negatives and NaN map to 0 under every curve (NumPy's cast of NaN
    to uint8 is undefined); ``+inf`` maps to 255 under every curve.
    """
    n = x.shape[0]
    for c in range(*share((n + _CHUNK - 1) // _CHUNK, part)):  # this part's share (common.parallel)
        for i in range(c * _CHUNK, min(n, (c + 1) * _CHUNK)):
            v = np.float64(x[i]) * exposure
            if not v > 0.0:  # negatives, -0 and NaN, before the curve: x / (1 + x) is large below -1
                v = 0.0
            elif curve == 1:
                v = v / (1.0 + v) if v < math.inf else 1.0  # the limit, not inf / inf
            elif curve == 2:
                v = -math.expm1(-v)
            if v > 1.0:
                v = 1.0
            if inv_gamma == 0.0:
                v = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1.0 / 2.4) - 0.055
            elif inv_gamma != 1.0:
                v = v ** inv_gamma
            out[i] = np.uint8(np.rint(v * 255.0))


def _curve_uint8(image, exposure: float = 1.0, tonemap: str = "clamp", gamma="srgb") -> np.ndarray:
    """:func:`~raycast_shade.output.tonemap.to_uint8` by its curve: every value through the formula in
    float64 (one parallel Numba pass; the settings and the image checked here).

    Parameters
    ----------
    image : (H, W, 3) float
        Linear, non-negative (negatives and NaN give 0). Any shape works.
    exposure : float
    tonemap : {"clamp", "reinhard", "exponential"}
    gamma : "srgb" or float

    Returns
    -------
    (H, W, 3) uint8
    """
    if not isinstance(tonemap, str) or tonemap not in TONEMAPS:
        raise ValueError(f"tonemap: expected one of {list(TONEMAPS)}, got {tonemap!r}")
    try:  # TypeError for strings, booleans, None; one message for every bad number
        exposure = as_scalar(exposure, "exposure", minimum=0.0, exclusive=True)
    except ValueError:
        raise ValueError(f"exposure: must be a finite number > 0, got {exposure}") from None
    inv_gamma = _check_gamma(gamma)
    img = np.asarray(image) if not isinstance(image, (bool, np.bool_, str)) else None
    if img is None or img.dtype.kind not in "iuf":  # None, strings, booleans: not an image
        raise TypeError(f"image: expected an array of numbers, got {type(image).__name__}"
                        + (f" of dtype {img.dtype}" if img is not None else ""))
    if img.dtype != np.float32:
        img = img.astype(np.float64, copy=False)
    flat = np.ascontiguousarray(img).reshape(-1)
    out = np.empty(flat.shape[0], np.uint8)
    _to_uint8_kernel(flat, float(exposure), TONEMAPS.index(tonemap), inv_gamma, out)
    return out.reshape(img.shape)


def _check_gamma(gamma) -> float:
    """``1 / gamma``, or 0.0 for sRGB."""
    if isinstance(gamma, str):
        if gamma != "srgb":
            raise ValueError(f"gamma: expected 'srgb' or a number, got {gamma!r}")
        return 0.0
    return 1.0 / as_scalar(gamma, "gamma", minimum=0.0, exclusive=True)


_INF = 0x7F800000  # +inf's pattern; finite non-negatives lie below it
_SHIFT = 13  # bucket = pattern >> 13: 262,145 buckets up to +inf (256 KiB)


def thresholds(exposure: float = 1.0, tonemap: str = "clamp", gamma="srgb") -> tuple:
    """``(t, inf_code)``: (256,) int32 patterns, ``t[k]`` the smallest finite non-negative float32
    (as its bit pattern) that ``_curve_uint8`` maps to ``k`` or more (``t[0] = 0``; ``0x7F800000``
    where no finite value reaches ``k``), and the code of ``+inf``."""
    codes = np.arange(1, 256)
    lo = np.zeros(255, np.int64)
    hi = np.full(255, _INF, np.int64)  # exclusive: "no finite value reaches k" ends at _INF
    while np.any(lo < hi):
        mid = (lo + hi) // 2
        got = _curve_uint8(mid.astype(np.int32).view(np.float32), exposure, tonemap, gamma)
        reach = got >= codes
        hi = np.where(reach, mid, hi)
        lo = np.where(reach, lo, mid + 1)
    t = np.concatenate([[0], hi]).astype(np.int32)
    inf_code = int(_curve_uint8(np.array([np.inf], np.float32), exposure, tonemap, gamma)[0])
    return t, inf_code


@njit(cache=True, nogil=True, no_cfunc_wrapper=True)  # (nothing takes its address)
def _bucket_codes(t, shift):
    """(0x7F800000 >> shift + 1,) uint8: the code of each bucket's first pattern (``j << shift``)."""
    n = (_INF >> shift) + 1
    out = np.empty(n, np.uint8)
    k = 0
    for j in range(n):
        start = j << shift
        while k < 255 and t[k + 1] <= start:
            k += 1
        out[j] = k
    return out


@njit(cache=True, nogil=True, no_cfunc_wrapper=True)  # (nothing takes its address)
def _quantize_kernel(bits, t, bucket, shift, inf_code, out):
    """``out[i]``: the code of pattern ``bits[i]`` (N,) int32 under thresholds ``t`` (257,) int32
    (``t[256]``: a sentinel above every finite pattern, so the walk needs no bound); returns how many
    patterns have the sign bit set (left 0 here, for the caller to map)."""
    n = bits.shape[0]
    signed = 0
    for i in range(n):
        b = bits[i]
        if b < 0 or b >= _INF:  # sign bit set (negatives, -0, negative NaN); +inf; positive NaN
            out[i] = inf_code if b == _INF else 0
            signed += b < 0
            continue
        k = np.intp(bucket[b >> shift])
        while t[k + 1] <= b:
            k += 1
        out[i] = k
    return signed


def _make_tables(exposure, tonemap, gamma) -> tuple:
    """``(walk, bucket, inf_code)`` of one setting, read-only: the thresholds with the sentinel, the
    bucket codes and the code of ``+inf``."""
    t, inf_code = thresholds(exposure, tonemap, gamma)
    walk = np.append(t, np.int32(0x7FFFFFFF))
    bucket = _bucket_codes(t, _SHIFT)
    walk.setflags(write=False)
    bucket.setflags(write=False)
    return walk, bucket, inf_code


# The bisection takes about 3 ms whatever the image's size (a fifth of a 640x480 frame), and a
# view set or an animation writes every frame with the same setting: a few settings are kept.
_cached_tables = functools.lru_cache(maxsize=16, typed=True)(_make_tables)  # typed: True is not 1 here


def _tables(exposure, tonemap, gamma) -> tuple:
    try:
        hash((exposure, tonemap, gamma))
    except TypeError:  # an unhashable setting (a 0-d array, say): computed, not kept
        return _make_tables(exposure, tonemap, gamma)
    return _cached_tables(exposure, tonemap, gamma)


def to_uint8_table(image, exposure: float = 1.0, tonemap: str = "clamp", gamma="srgb") -> np.ndarray:
    """:func:`~raycast_shade.output.tonemap.to_uint8` of ``image``, by table for float32 input.

    Parameters
    ----------
    image : (H, W, 3) float32
        Linear (any shape; other dtypes go to ``_curve_uint8``).
    exposure, tonemap, gamma
        As :func:`~raycast_shade.output.tonemap.to_uint8` (checked by ``_curve_uint8``).

    Returns
    -------
    (H, W, 3) uint8
        Bit for bit what ``_curve_uint8`` returns.
    """
    img = np.asarray(image) if isinstance(image, np.ndarray) else None
    if img is None or img.dtype != np.float32 or img.size < 256:
        return _curve_uint8(image, exposure, tonemap, gamma)  # small or not float32: the curve itself
    walk, bucket, inf_code = _tables(exposure, tonemap, gamma)  # checks the settings (_curve_uint8 raises)
    flat = np.ascontiguousarray(img).reshape(-1)
    out = np.empty(flat.shape[0], np.uint8)
    bits = flat.view(np.int32)
    if _quantize_kernel(bits, walk, bucket, _SHIFT, np.uint8(inf_code), out):
        signed = np.flatnonzero(bits < 0)  # rare in a rendered image: the curve itself
        out[signed] = _curve_uint8(flat[signed], exposure, tonemap, gamma)
    return out.reshape(img.shape)
