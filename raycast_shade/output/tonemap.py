"""From linear radiance to 8-bit pixels, and lossless float output.

The 8-bit mapping, in order:

1. exposure: multiply by ``exposure`` (default 1);
2. range: ``"clamp"`` cuts at 1 (default; values up to 1 are untouched, so
   intensities read back exactly), ``"reinhard"`` maps ``x / (1 + x)``, and
   ``"exponential"`` maps ``1 - exp(-x)``;
3. encoding: ``gamma="srgb"`` (default, the IEC 61966-2-1 curve), a number
   ``g`` for ``x ** (1/g)``, or ``1`` for linear;
4. round to nearest of 0..255.

:func:`to_uint8` runs the mapping in one parallel Numba pass, in float64 as
its plain-NumPy twin :func:`raycast_shade.study.twins.to_uint8_numpy` does
(tested equal): NumPy's ``power`` over a 960 x 844 image took 100-180 ms, a
tenth of ``raycast-shade demo``.
"""

from __future__ import annotations

import math
import os

import numpy as np
from numba import njit

from ..common.parallel import in_parts, share

__all__ = ["to_uint8", "write_pfm", "read_pfm", "TONEMAPS"]

from ..common.choices import TONEMAPS
from ..common.validate import as_array, as_scalar
_CHUNK = 1 << 16  # values per parallel work item


@in_parts
@njit(nogil=True, cache=True, error_model="numpy")
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


def to_uint8(image, exposure: float = 1.0, tonemap: str = "clamp", gamma="srgb") -> np.ndarray:
    """Tone-map a linear image.

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


def write_pfm(path, image) -> None:
    """Write a float32 RGB image as PFM (lossless, little-endian, bottom row first)."""
    if not isinstance(path, (str, os.PathLike)) or not os.fspath(path).lower().endswith(".pfm"):
        raise ValueError(f"path: a PFM file's name ends in .pfm, got {path!r:.60}")
    img = as_array(image, "image", dtype=np.float32, finite=False)  # NaN and inf are legal PFM values
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"image: expected (H, W, 3), got {img.shape}")
    h, w, _ = img.shape
    with open(os.fspath(path), "wb") as fh:
        fh.write(f"PF\n{w} {h}\n-1.0\n".encode("ascii"))
        fh.write(np.ascontiguousarray(img[::-1]).astype("<f4").tobytes())


def read_pfm(path) -> np.ndarray:
    """Read a PFM written by :func:`write_pfm` (or any colour PFM)."""
    with open(os.fspath(path), "rb") as fh:
        if fh.readline().strip() != b"PF":
            raise ValueError(f"{path}: not a colour PFM file")
        w, h = (int(t) for t in fh.readline().split())
        scale = float(fh.readline())
        dtype = "<f4" if scale < 0 else ">f4"
        data = np.frombuffer(fh.read(w * h * 12), dtype=dtype)
    return data.reshape(h, w, 3)[::-1].astype(np.float32)
