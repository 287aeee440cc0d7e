"""Input checks shared by every public constructor.

Each helper names the offending field in its message, and all of them run
before any kernel sees the data: Embree silently ignores non-finite triangles
and out-of-range indices, so nothing of that kind may reach it.
"""

from __future__ import annotations

import collections.abc as abc
import numbers
import os

import numpy as np

# Intensities, colours, coefficients, ambient and background are bounded so that their
# products (times attenuation, summed over lights) stay finite in float64; the kernels then
# saturate at float32's maximum when storing, so no input makes the image inf or NaN.
MAX_RADIANCE = 1e30

__all__ = [
    "MAX_RADIANCE",
    "memory_limit",
    "check_memory",
    "pow2_scaled",
    "as_array",
    "as_vec3",
    "as_rgb",
    "as_scalar",
    "as_choice",
    "as_int",
    "as_count",
    "as_name",
    "as_names",
    "as_instance",
    "as_bool",
]


def _has_bool(value) -> bool:
    """True if a (nested) list or tuple holds a bool anywhere: NumPy would quietly
    turn ``[True, 0.5, 1]`` into floats. Arrays inside are judged by their dtype."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, (bool, np.bool_)):
            return True
        if isinstance(item, np.ndarray):
            if item.dtype.kind == "b" or (item.dtype == object and _has_bool(item.tolist())):
                return True
        elif isinstance(item, (list, tuple)):
            stack.extend(item)
    return False


def _has_huge_int(value) -> bool:
    """True if a (nested) sequence holds a Python int beyond 64 bits (NumPy makes it dtype object)."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, numbers.Integral) and not isinstance(item, bool) and not -2**63 <= item < 2**64:
            return True
        if isinstance(item, np.ndarray):
            stack.extend(item.ravel().tolist())
        elif isinstance(item, (list, tuple)):
            stack.extend(item)
    return False


def as_array(value, name: str, *, dtype, ndim: int | None = None, shape=None, finite: bool = True,
             copy: bool = False):
    """Convert ``value`` to a C-contiguous array of ``dtype`` or raise naming ``name``.

    Booleans are refused for every dtype (``True`` is not a coordinate, a colour
    or an index), floats must be integral and every value within range for an
    integer dtype, and values beyond a float dtype's range are refused rather
    than turned into inf.

    Parameters
    ----------
    value : array_like
    name : str
        Field name used in error messages.
    dtype : numpy dtype
        Target dtype (``np.float64``, ``np.float32`` or ``np.int64``).
    ndim : int, optional
        Required number of dimensions.
    shape : tuple, optional
        Required shape; ``None`` entries match any length.
    finite : bool
        For float arrays, reject NaN and inf.
    copy : bool
        Always return a new array, so that a class keeping it does not share
        memory with the caller's (frozen classes pass True).
    """
    if value is None:
        raise TypeError(f"{name}: expected an array, got None")
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected numbers, got a boolean")
    try:
        raw = np.asarray(value)
    except Exception as exc:  # ragged lists and the like
        raise TypeError(f"{name}: cannot be converted to an array ({exc})") from None
    if raw.dtype == object and _has_huge_int(value):
        raise ValueError(f"{name}: an integer beyond the 64-bit range")
    if raw.dtype == object or raw.dtype.kind not in "biuf":
        raise TypeError(f"{name}: expected numbers, got dtype {raw.dtype}")
    target = np.dtype(dtype)
    if raw.dtype.kind == "b" or (isinstance(value, (list, tuple)) and _has_bool(value)):
        raise TypeError(f"{name}: expected {'integers' if target.kind in 'iu' else 'numbers'}, got booleans")
    if target.kind in "iu":
        info = np.iinfo(target)
        if raw.dtype.kind == "f":
            if not np.all(np.isfinite(raw)) or np.any(raw != np.round(raw)):
                raise TypeError(f"{name}: expected integers, got non-integral floats")
        if raw.size and raw.dtype != target:
            # The cast would wrap (uint64 2**64-1 becomes -1) or be undefined (float 1e20).
            lo, hi = raw.min(), raw.max()
            if raw.dtype.kind == "f":  # compare as floats: float(2**63 - 1) rounds up to 2**63
                too_low, too_high = lo < float(info.min), hi >= float(info.max) + 1.0
            else:
                too_low, too_high = lo < info.min, hi > info.max
            if too_low or too_high:
                bad = hi if too_high else lo
                shown = f"{bad:.17g}" if raw.dtype.kind == "f" else str(int(bad))
                raise ValueError(f"{name}: value {shown} is beyond the {target} range "
                                 f"[{info.min}, {info.max}]")
    elif target.kind == "f" and raw.dtype.kind == "f" and raw.dtype.itemsize > target.itemsize and raw.size:
        top = np.abs(raw[np.isfinite(raw)]).max(initial=0.0)
        if top > np.finfo(target).max:
            raise ValueError(f"{name}: value {top:.6g} is beyond the {target} range (+-{np.finfo(target).max:.6g})")
    arr = np.array(raw, dtype=target, order="C", copy=True) if copy else np.ascontiguousarray(raw, dtype=target)
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
    """A finite (3,) float64 vector of its own, read-only; ``nonzero`` rejects the zero vector.

    A column (3, 1) or row (1, 3), as OpenCV and matrix code return vectors, is the same vector."""
    if isinstance(value, np.ndarray) and value.shape in ((3, 1), (1, 3)):
        value = value.reshape(3)
    v = as_array(value, name, dtype=np.float64, shape=(3,), copy=True)
    if nonzero and not np.any(v):
        raise ValueError(f"{name}: must not be the zero vector")
    v.setflags(write=False)
    return v


def pow2_scaled(v) -> np.ndarray:
    """``v`` times the power of two that brings its largest ``|component|`` into [0.5, 1).

    Normalising this instead of ``v`` neither overflows (1e308) nor underflows
    (1e-200: the squares would be 0) in the norm, and since scaling by a power
    of two is exact, ``s / |s|`` has the same bits as ``v / |v|`` wherever the
    latter was computable. The zero vector stays zero.

    Parameters
    ----------
    v : (..., 3) float64
        Scaled per row (along the last axis).
    """
    v = np.asarray(v, np.float64)
    top = np.abs(v).max(axis=-1, keepdims=True)
    _, exponent = np.frexp(top)
    return np.ldexp(v, -exponent)


def as_rgb(value, name: str, *, nonnegative: bool = True) -> np.ndarray:
    """An RGB triple from a scalar (Python, NumPy or 0-d array) or 3 values, as (3,) float64."""
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        v = np.full(3, _float(value, name))
    elif isinstance(value, np.ndarray) and value.shape in ((3, 1), (1, 3)):  # a column or row: the same triple
        v = as_array(value.reshape(3), name, dtype=np.float64, copy=True)
    else:
        v = as_array(value, name, dtype=np.float64, copy=True)
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


def _float(value, name: str) -> float:
    try:
        return float(value)
    except OverflowError:  # a Python int beyond float64, 10**400 say
        raise ValueError(f"{name}: must be finite, got an integer of {len(str(abs(int(value))))} digits") from None


def _zero_d(value):
    """A 0-d numeric (not boolean) array as its NumPy scalar; anything else unchanged."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf":
        return value[()]
    return value


def as_scalar(value, name: str, *, minimum=None, exclusive: bool = False, maximum=None) -> float:
    """A finite real number, optionally bounded below (``> minimum`` if ``exclusive``).

    NumPy scalars and 0-d arrays are numbers; booleans and strings are not.
    """
    value = _zero_d(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise TypeError(f"{name}: expected a number, got {type(value).__name__}")
    x = _float(value, name)
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


def as_int(value, name: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """An integer (Python, NumPy or 0-d array; not a bool, not a float), within bounds.

    Floats are refused even when integral, so that ``2.7`` is never truncated
    and ``1e12`` never taken for a count.
    """
    value = _zero_d(value)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        kind = type(value).__name__
        whole = isinstance(value, (float, np.floating)) and np.isfinite(value) and value == np.round(value)
        hint = f" ({value!r}; write it without a fraction)" if whole else ""
        raise TypeError(f"{name}: expected an integer, got {kind}{hint}")
    x = int(value)
    if minimum is not None and x < minimum:
        raise ValueError(f"{name}: must be >= {minimum}, got {x}")
    if maximum is not None and x > maximum:
        raise ValueError(f"{name}: must be <= {maximum}, got {x}")
    return x


def as_count(value, name: str, *, minimum: int = 1, optional: bool = False):
    """A count: an integer (Python or NumPy, a 0-d array too; not a bool, not a float) ``>= minimum``, or None
    if ``optional``.

    Unlike :func:`as_int`, every refusal is a ValueError (worker and retry
    counts have always been refused so), with the same message.

    Raises
    ------
    ValueError
        ``"<name>: expected an integer >= <minimum>[ or None], got <value!r>"``.
    """
    if optional and value is None:
        return None
    number = _zero_d(value)  # a 0-d integer array is its scalar, as for as_int
    if isinstance(number, (bool, np.bool_)) or not isinstance(number, (numbers.Integral, np.integer)) \
            or number < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}{' or None' if optional else ''}, got {value!r}")
    return int(number)


def as_name(value, name: str) -> str:
    """A name: a string (NumPy's included), never a number, None or an array."""
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected a string, got {type(value).__name__}")
    return str(value)


def as_names(value, name: str, choices, *, item: str | None = None) -> tuple:
    """Some of ``choices`` (strings, case-insensitive): a sequence of names or one comma-separated string.

    Parameters
    ----------
    value : str, sequence of str or None
        ``None`` and ``""`` are none; repeats are dropped, the first order kept. A NumPy
        array or a mapping is refused (it iterates, but not as a list of names).
    name : str
        Field name used in error messages.
    choices : sequence of str
        Lower-case; listed in the messages in this order.
    item : str, optional
        What one name is, in the messages ("unknown format 'tiff'"); default
        ``name`` less a trailing "s".

    Returns
    -------
    tuple of str
        Lower-cased, stripped.

    Raises
    ------
    TypeError
        For a non-sequence (an array and a mapping included) or a name that is not a string.
    ValueError
        For a name not in ``choices``.
    """
    item = item or (name[:-1] if name.endswith("s") else name)
    if value is None:
        return ()
    if isinstance(value, str):
        value = [v for v in value.split(",") if v.strip()]
    elif isinstance(value, (bytes, np.ndarray, abc.Mapping)) or not hasattr(value, "__iter__"):
        # an array or a mapping iterates, but nobody means its items (or keys) as names
        raise TypeError(f"{name}: expected a sequence of {item} names, got {type(value).__name__}")
    out = []
    for v in value:
        if not isinstance(v, str):
            raise TypeError(f"{name}: expected {item} names (str), got {type(v).__name__}")
        key = v.strip().lower()
        if key not in choices:
            raise ValueError(f"{name}: unknown {item} {v!r}; expected some of {', '.join(choices)}")
        out.append(key)
    return tuple(dict.fromkeys(out))


def as_bool(value, name: str) -> bool:
    """A flag: ``True`` or ``False`` (NumPy's included), never 0, 1, None or a string."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False, got {type(value).__name__}")
    return bool(value)


def as_instance(value, name: str, cls, what: str | None = None):
    """``value`` itself if it is a ``cls`` (a class or tuple of classes), else a TypeError
    naming the argument, before anything reads an attribute of it."""
    if not isinstance(value, cls):
        if what is None:
            what = " or ".join(c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,)))
        raise TypeError(f"{name}: expected a {what}, got {type(value).__name__}")
    return value


def as_sequence(value, name: str) -> list:
    """A list of ``value``'s items: a list, tuple or other iterable, never a string, a mapping, a
    NumPy array or a scalar (each of which iterates, or fails, in ways nobody means)."""
    import collections.abc as abc

    if isinstance(value, (str, bytes, np.ndarray, abc.Mapping)) or not isinstance(value, abc.Iterable):
        raise TypeError(f"{name}: expected a sequence, got {type(value).__name__}")
    return list(value)


def as_path(value, name: str) -> str:
    """A file-system path as ``str``: str or path-like, never a number, a boolean or None."""
    import os

    if isinstance(value, bool) or not isinstance(value, (str, bytes, os.PathLike)):
        raise TypeError(f"{name}: expected a path, got {type(value).__name__}")
    path = os.fsdecode(os.fspath(value))
    if not path:
        raise ValueError(f"{name}: an empty path")
    return path


def as_choice(value, name: str, choices) -> str:
    """One of ``choices`` (strings), case-insensitive."""
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected one of {sorted(choices)}, got {type(value).__name__}")
    v = value.lower()
    if v not in choices:
        raise ValueError(f"{name}: expected one of {sorted(choices)}, got {value!r}")
    return v


def memory_limit() -> int:
    """Bytes one allocation plan (a frame, a shape, a height map) may need: half
    the physical memory (``os.sysconf``), or 16 GiB where that is unknown.

    Plans beyond it are refused with the figure before anything is allocated,
    instead of ending in NumPy's MemoryError (or the machine swapping) later.
    """
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        total = 0
    return total // 2 if total > 0 else 16 << 30


def _bytes(n: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} bytes"


def check_memory(nbytes: float, what: str, purpose: str) -> None:
    """Refuse a plan needing more than :func:`memory_limit` bytes.

    Parameters
    ----------
    nbytes : float
        The estimate (a float: it may exceed any integer type).
    what : str
        The fields and their values, e.g. ``"camera.width x camera.height: 10 x 10 pixels"``.
    purpose : str
        What the memory is for, e.g. ``"a frame"``.

    Raises
    ------
    ValueError
        ``"<what> need about 47 TB for a frame; the limit is ..."``.
    """
    limit = memory_limit()
    if nbytes > limit:
        raise ValueError(f"{what} need about {_bytes(nbytes)} for {purpose}; the limit is {_bytes(limit)} "
                         "(half the physical memory)")
