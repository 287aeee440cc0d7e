"""From linear radiance to 8-bit pixels, and lossless float output.

The 8-bit mapping, in order:

1. exposure: multiply by ``exposure`` (default 1);
2. range: ``"clamp"`` cuts at 1 (default; values up to 1 are untouched, so
   intensities read back exactly), ``"reinhard"`` maps ``x / (1 + x)``, and
   ``"exponential"`` maps ``1 - exp(-x)``;
3. encoding: ``gamma="srgb"`` (default, the IEC 61966-2-1 curve), a number
   ``g`` for ``x ** (1/g)``, or ``1`` for linear;
4. round to nearest of 0..255.

:func:`to_uint8` gives the bytes of the mapping in float64, as its plain-NumPy
twin :func:`raycast_shade.study.twins.to_uint8_numpy` does (tested equal):
through the curve in one parallel Numba pass
(``quantize._curve_uint8``; NumPy's ``power`` over a
960 x 844 image took 100-180 ms, a tenth of ``raycast-shade demo``), or, for a
large float32 image, by the setting's exact threshold table
(:func:`~raycast_shade.output.quantize.to_uint8_table`, several times faster).
"""

from __future__ import annotations

import os

import numpy as np

from ..common.choices import TONEMAPS
from ..common.validate import as_array
from .quantize import _TABLE_VALUES, _curve_uint8, to_uint8_table

__all__ = ["to_uint8", "write_pfm", "read_pfm", "TONEMAPS"]


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

    Notes
    -----
    A float32 image of at least 2^18 values (``quantize._TABLE_VALUES``)
    goes by the setting's threshold table (:func:`~raycast_shade.output.quantize.to_uint8_table`),
    every other input through the curve itself (``quantize._curve_uint8``):
    the same bytes either way.
    """
    if isinstance(image, np.ndarray) and image.dtype == np.float32 and image.size >= _TABLE_VALUES:
        return to_uint8_table(image, exposure, tonemap, gamma)
    return _curve_uint8(image, exposure, tonemap, gamma)


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
