"""Input checks shared by every public constructor.

Each helper names the offending field in its message, and all of them run
before any kernel sees the data: Embree silently ignores non-finite triangles
and out-of-range indices, so nothing of that kind may reach it.
"""

from __future__ import annotations

import numbers

import numpy as np

# Intensities, colours, coefficients, ambient and background are bounded so that their
# products (times attenuation, summed over lights) stay finite in float64; the kernels then
# saturate at float32's maximum when storing, so no input makes the image inf or NaN.
MAX_RADIANCE = 1e30

__all__ = [
    "MAX_RADIANCE",
    "as_array",
    "as_vec3",
    "as_rgb",
    "as_scalar",
    "as_choice",
    "as_int",
]


def as_array(value, name: str, *, dtype, ndim: int | None = None, shape=None, finite: bool = True):
    """Convert ``value`` to a C-contiguous array of ``dtype`` or raise naming ``name``.

    Parameters
    ----------
    value : array_like
    name : str
        Field name used in error messages.
    dtype : numpy dtype
        Target dtype (``np.float64`` or ``np.int64``).
    ndim : int, optional
        Required number of dimensions.
    shape : tuple, optional
        Required shape; ``None`` entries match any length.
    finite : bool
        For float arrays, reject NaN and inf.
    """
    if value is None:
        raise TypeError(f"{name}: expected an array, got None")
    try:
        raw = np.asarray(value)
    except Exception as exc:  # ragged lists and the like
        raise TypeError(f"{name}: cannot be converted to an array ({exc})") from None
    if raw.dtype == object or raw.dtype.kind not in "biuf":
        raise TypeError(f"{name}: expected numbers, got dtype {raw.dtype}")
    target = np.dtype(dtype)
    if target.kind in "iu":
        if raw.dtype.kind == "f":
            if not np.all(np.isfinite(raw)) or np.any(raw != np.round(raw)):
                raise TypeError(f"{name}: expected integers, got non-integral floats")
        elif raw.dtype.kind == "b":
            raise TypeError(f"{name}: expected integers, got booleans")
    arr = np.ascontiguousarray(raw, dtype=target)
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name}: expected {ndim}-D array, got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name}: expected shape {want}, got {arr.shape}")
    if finite and target.kind == "f" and arr.size and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name}: non-finite value at index {tuple(int(i) for i in bad)}")
    return arr


def as_vec3(value, name: str, *, nonzero: bool = False) -> np.ndarray:
    """A finite (3,) float64 vector; ``nonzero`` rejects the zero vector."""
    v = as_array(value, name, dtype=np.float64, shape=(3,))
    if nonzero and not np.any(v):
        raise ValueError(f"{name}: must not be the zero vector")
    v.setflags(write=False)
    return v


def as_rgb(value, name: str, *, nonnegative: bool = True) -> np.ndarray:
    """An RGB triple from a scalar or a length-3 sequence, as (3,) float64."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        v = np.full(3, float(value))
    else:
        v = as_array(value, name, dtype=np.float64)
        if v.shape == ():
            v = np.full(3, float(v))
        elif v.shape != (3,):
            raise ValueError(f"{name}: expected a scalar or 3 values (RGB), got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: must be finite, got {v.tolist()}")
    if nonnegative and np.any(v < 0):
        raise ValueError(f"{name}: must be >= 0, got {v.tolist()}")
    if np.any(np.abs(v) > MAX_RADIANCE):
        raise ValueError(f"{name}: must be <= {MAX_RADIANCE:g}, got {v.tolist()}")
    v.setflags(write=False)
    return v


def as_scalar(value, name: str, *, minimum=None, exclusive: bool = False, maximum=None) -> float:
    """A finite real number, optionally bounded below (``> minimum`` if ``exclusive``)."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise TypeError(f"{name}: expected a number, got {type(value).__name__}")
    x = float(value)
    if not np.isfinite(x):
        raise ValueError(f"{name}: must be finite, got {x}")
    if minimum is not None:
        if exclusive and not x > minimum:
            raise ValueError(f"{name}: must be > {minimum}, got {x}")
        if not exclusive and not x >= minimum:
            raise ValueError(f"{name}: must be >= {minimum}, got {x}")
    if maximum is not None and x > maximum:
        raise ValueError(f"{name}: must be <= {maximum}, got {x}")
    return x


def as_int(value, name: str, *, minimum: int | None = None) -> int:
    """An integer (not a bool, not a float), optionally ``>= minimum``."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, np.integer)):
        raise TypeError(f"{name}: expected an integer, got {type(value).__name__}")
    x = int(value)
    if minimum is not None and x < minimum:
        raise ValueError(f"{name}: must be >= {minimum}, got {x}")
    return x


def as_choice(value, name: str, choices) -> str:
    """One of ``choices`` (strings), case-insensitive."""
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected one of {sorted(choices)}, got {type(value).__name__}")
    v = value.lower()
    if v not in choices:
        raise ValueError(f"{name}: expected one of {sorted(choices)}, got {value!r}")
    return v
