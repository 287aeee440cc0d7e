"""Writing and reading a frame's buffers: NumPy ``.npz``, multi-channel EXR, 16-bit depth PNG.

* ``.npz``: every buffer under its name (and the linear ``image`` and the
  camera's ``K``, ``R``, ``t`` when given), dtypes kept.
* ``.exr``: float32 channels, stored uncompressed unless a compression is
  asked for (:data:`EXR_COMPRESSIONS`): uncompressed, ZIPS and ZIP laid out
  with NumPy and deflated on threads (:mod:`~raycast_shade.output.exrwrite`),
  the others and the reader through the ``openexr`` package (extra ``vision``). The image is ``R, G, B``; a scalar buffer is the channel
  ``name``; a 3-vector buffer ``name.X, name.Y, name.Z``; ids are ``UINT``
  channels holding ``id + 1`` (0 on the background), the mask a ``UINT``
  0/1 channel. :func:`read_exr` undoes all of it.
* depth PNG: one 16-bit grey channel in millimetres (``scale`` units per
  metre-like world unit, default 1000), 0 where nothing was hit or the depth
  is out of range, as TUM RGB-D, ScanNet and NYU store it.

Every writer checks its input before it opens a file: names (``np.savez``'s
own arguments ``file`` and ``allow_pickle`` and the names the writer adds
itself are refused), shapes (every buffer ``(H, W)`` or ``(H, W, 3)`` of one
size), values the format cannot hold (EXR ids outside ``[-1, 2**31 - 1]``,
floats beyond float32) and the file's extension; a ValueError or TypeError
names the buffer.

Every writer takes ``atomic=True`` (through
:func:`~raycast_shade.output.imagefile.atomic_target`): the file is whole or
absent, never partial.
"""

from __future__ import annotations

import contextlib
import os

import numpy as np
from numba import njit

from ..common.validate import as_bool, as_int, as_scalar

from .imagefile import atomic_target, png_file, write_bytes

__all__ = ["EXR_COMPRESSIONS", "npz_level", "save_npz", "npz_into", "load_npz", "write_exr", "exr_into", "read_exr",
           "write_depth_png", "depth_png_bytes", "read_depth_png"]

_ID_BUFFERS = ("model_id", "triangle_id", "instance_id", "semantic_id")
_MASKS = ("mask",)
_AXES = ("X", "Y", "Z")
# np.savez(file, *args, allow_pickle=True, **kwds): a buffer under one of these names would be
# taken as the argument itself.
NPZ_RESERVED = ("file", "allow_pickle")
_ID_RANGE = (-1, 2**31 - 1)  # stored as uint32 id + 1, read back as int32
#: write_exr's compressions (OpenEXR's names, lower case): "none", "zips" and "zip" written here with
#: NumPy (blocks deflated on threads), the others by OpenEXR; "zstd" gives the smallest files (OpenEXR
#: >= 3.4 reads them), "zip" the most widely read.
EXR_COMPRESSIONS = ("none", "rle", "zips", "zip", "piz", "zstd")


def _check_path(path, ext: str, field: str = "path") -> str:
    if path is None or isinstance(path, bool) or not isinstance(path, (str, bytes, os.PathLike)):
        raise TypeError(f"{field}: expected a file path, got {type(path).__name__}")
    path = os.fspath(path)
    if isinstance(path, bytes):
        path = os.fsdecode(path)
    if not path.lower().endswith(ext):
        raise ValueError(f"{field}: {path!r}: expected a {ext} file")
    return path


def _existing(path, ext: str, field: str = "path") -> str:
    """A file to read: its path checked as :func:`_check_path` does, and present."""
    path = _check_path(path, ext, field)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"{field}: no file {path!r}")
    return path


def _check_buffers(buffers, image, reserved=(), field="buffers") -> tuple:
    """``(arrays, size)``: the buffers as arrays by name, all ``(H, W)`` or ``(H, W, 3)`` of one ``(H, W)``.

    Refuses (naming the buffer) non-string or empty names, ``reserved`` names, arrays that are not
    numbers or booleans (object arrays would be pickled), other shapes, and an image of another size.
    """
    if not isinstance(buffers, dict):
        raise TypeError(f"{field}: expected a dict of name to array, got {type(buffers).__name__}")
    arrays = {}
    size = None
    for name, value in buffers.items():
        if not isinstance(name, str) or not name.strip():
            raise TypeError(f"{field}: expected non-empty str names, got {name!r}")
        if name in reserved:
            raise ValueError(f"{field}: the name {name!r} is taken by the writer itself "
                             f"(reserved: {', '.join(reserved)}); rename the buffer")
        if value is None:
            raise TypeError(f"{field}[{name!r}]: expected an array, got None")
        a = np.asarray(value)
        if a.dtype.kind not in "biuf":
            raise TypeError(f"{field}[{name!r}]: expected numbers or booleans, got dtype {a.dtype}")
        if not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] == 3)) or 0 in a.shape:
            raise ValueError(f"{field}[{name!r}]: expected shape (H, W) or (H, W, 3), got {a.shape}")
        if size is None:
            size = a.shape[:2]
        elif a.shape[:2] != size:
            raise ValueError(f"{field}[{name!r}]: shape {a.shape} does not match the other buffers' {size}")
        arrays[name] = a
    if image is not None:
        img = np.asarray(image)
        if img.dtype.kind not in "uif":
            raise TypeError(f"image: expected numbers, got dtype {img.dtype}")
        if img.ndim != 3 or img.shape[2] != 3 or (size is not None and img.shape[:2] != size):
            want = "(H, W, 3)" if size is None else f"({size[0]}, {size[1]}, 3), the buffers' size"
            raise ValueError(f"image: expected shape {want}, got {img.shape}")
    return arrays, size


@contextlib.contextmanager
def _target(path, atomic):
    path = os.fspath(path)
    if atomic:
        with atomic_target(path) as tmp:
            yield tmp
    else:
        yield path


def save_npz(path, buffers: dict, *, image=None, camera=None, compressed: bool | int = False,
             threads: int | None = None, atomic: bool = False) -> str:
    """Write buffers (and optionally the image and the camera's K, R, t) to one ``.npz``.

    The arrays' CRCs and deflate run on threads while the file is written
    (:mod:`~raycast_shade.output.npzwrite`); the file is what ``np.savez``
    (``np.savez_compressed``) writes, read by ``np.load``.

    Parameters
    ----------
    path : str or path-like
        Ends in ``.npz``.
    buffers : dict of str to ndarray
        Each ``(H, W)`` or ``(H, W, 3)``, one size; not named ``file`` or
        ``allow_pickle`` (``np.savez``'s arguments), nor ``image`` (``K``,
        ``R``, ``t``) when ``image`` (``camera``) is given.
    image : (H, W, 3) float32, optional
    camera : Camera, optional
    compressed : bool or int
        ``False`` (the default): stored, the fastest (see
        ``docs/performance.md``); ``True``: deflated at level 1; an int
        ``0 <= level <= 9``: deflated at that level. Levels 1-3 use ISA-L
        (the ``isal`` package, extra ``vision``) when installed, several
        times zlib's speed for a slightly larger file; the others zlib.
    threads : int, optional
        Workers for the CRCs and deflate (0 or 1: none); default: one per CPU.
    atomic : bool
        Write a temporary beside ``path`` and move it there once whole.

    Returns
    -------
    str
        ``path``.

    Raises
    ------
    TypeError, ValueError
        Naming the buffer or argument at fault, before the file is opened.
    """
    path = _check_path(path, ".npz")
    atomic = as_bool(atomic, "atomic")
    level = npz_level(compressed)
    threads = _threads(threads)
    arrays = _npz_arrays(buffers, image, camera)
    with _target(path, atomic) as target, open(target, "wb") as fh:
        _write_npz(fh, arrays, level, threads)
    return path


def _npz_arrays(buffers, image, camera) -> dict:
    """The checked arrays of an npz, by member name (:func:`save_npz`'s rules)."""
    reserved = NPZ_RESERVED + (("image",) if image is not None else ()) + (("K", "R", "t") if camera is not None else ())
    arrays, _ = _check_buffers(buffers, image, reserved)
    if image is not None:
        arrays["image"] = np.asarray(image, np.float32)
    if camera is not None:
        if not hasattr(camera, "to_opencv"):
            raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
        arrays["K"], arrays["R"], arrays["t"] = camera.to_opencv()
    return arrays


def _write_npz(fh, arrays, level, threads) -> None:
    from .npzwrite import write_npz

    write_npz(fh, arrays, level, threads=threads)


def npz_into(fh, buffers: dict, *, image=None, camera=None, compressed: bool | int = False,
             threads: int | None = None) -> None:
    """:func:`save_npz`'s bytes into the open binary file ``fh``, written front to back (no seek).

    Parameters
    ----------
    fh : binary file
        For instance an :class:`~raycast_shade.output.imagefile.HashingWriter`.
    buffers, image, camera, compressed, threads
        As :func:`save_npz` (checked before anything is written).
    """
    level = npz_level(compressed)
    threads = _threads(threads)
    _write_npz(fh, _npz_arrays(buffers, image, camera), level, threads)


def _threads(threads, field: str = "threads") -> int:
    if threads is None:
        return os.cpu_count() or 1
    return as_int(threads, field, minimum=0)


def npz_level(compressed, field: str = "compressed"):
    """The deflate level of ``compressed`` (``None``: stored; ``True``: 1); TypeError/ValueError naming ``field``."""
    if isinstance(compressed, (bool, np.bool_)):
        return 1 if compressed else None
    if not isinstance(compressed, (int, np.integer)):
        raise TypeError(f"{field}: expected a bool or a deflate level 0-9, got {type(compressed).__name__}")
    if not 0 <= int(compressed) <= 9:
        raise ValueError(f"{field}: expected a deflate level 0-9, got {compressed}")
    return int(compressed)


def load_npz(path) -> dict:
    """Every array of a :func:`save_npz` file, by name."""
    with np.load(_existing(path, ".npz"), allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def _exr_channels(buffers, image, contiguous: bool = True):
    """EXR channels of checked buffers; refuses what EXR (as written here) cannot give back.

    ``contiguous=False``: a 3-vector's channels are strided views of it, not copies."""
    from ..common.validate import as_array

    arrays, _ = _check_buffers(buffers, image, ("R", "G", "B"))
    channels = {}
    if image is not None:
        img = as_array(image, "image", dtype=np.float32, finite=False)
        channels.update(zip("RGB", _planes(img, contiguous)))
    for name, buf in arrays.items():
        field = f"buffers[{name!r}]"
        if "." in name:
            raise ValueError(f"{field}: EXR names a 3-vector's channels name.X, name.Y, name.Z; "
                             f"a name with a dot would be read back as one")
        if name in _ID_BUFFERS:
            ids = buf if buf.dtype == np.int32 else as_array(buf, field, dtype=np.int64, ndim=2)
            if ids.ndim != 2:
                raise ValueError(f"{field}: expected shape (H, W), got {ids.shape}")
            lo, hi = _ID_RANGE
            if ids.size and (ids.min() < lo or ids.max() > hi):
                bad = ids.min() if ids.min() < lo else ids.max()
                raise ValueError(f"{field}: id {int(bad)} outside the range EXR holds here, [{lo}, {hi}] "
                                 f"(stored as uint32 id + 1)")
            channels[name] = ids.astype(np.uint32) + np.uint32(1)  # -1 wraps to 2**32 - 1, + 1 to 0
        elif name in _MASKS:
            if buf.dtype != np.bool_ or buf.ndim != 2:
                raise TypeError(f"{field}: expected an (H, W) bool mask, got {buf.dtype} {buf.shape}")
            channels[name] = buf.astype(np.uint32)
        elif buf.dtype.kind != "f":
            raise TypeError(f"{field}: EXR holds integer and bool buffers only under the names "
                            f"{', '.join(_ID_BUFFERS + _MASKS)} (read back as such); got dtype {buf.dtype}. "
                            "Store it as float or in an .npz file")
        else:
            buf = as_array(buf, field, dtype=np.float32, finite=False)
            if buf.ndim == 3:
                channels.update((f"{name}.{axis}", plane) for axis, plane in zip(_AXES, _planes(buf, contiguous)))
            else:
                channels[name] = buf
    if not channels:
        raise ValueError("buffers: nothing to write (no buffers and no image)")
    return channels


def _planes(a: np.ndarray, contiguous: bool = True) -> np.ndarray:
    """(3, H, W) of an (H, W, 3) array: a contiguous copy (one transposing copy, about 2x three
    strided per-channel copies), or with ``contiguous=False`` a view."""
    planes = np.moveaxis(a, 2, 0)
    return planes.copy() if contiguous else planes


def write_exr(path, buffers: dict, *, image=None, compression: str = "none", threads: int | None = None,
              atomic: bool = False) -> str:
    """Write buffers (and optionally the linear image) as one multi-channel EXR.

    Parameters
    ----------
    path : str or path-like
        Ends in ``.exr``.
    buffers : dict of str to ndarray
        Float buffers ``(H, W)`` or ``(H, W, 3)``; integer ids only under
        the id names (``model_id``, ``triangle_id``, ``instance_id``,
        ``semantic_id``), ``-1 <= id <= 2**31 - 1`` (int32); bool only ``mask``.
        No name ``R``, ``G``, ``B`` (the image) or with a dot.
    image : (H, W, 3) float, optional
    compression : str
        One of :data:`EXR_COMPRESSIONS`; ``"none"`` (the default) is the
        fastest (see ``docs/performance.md`` for times and sizes). ``"none"``,
        ``"zips"`` and ``"zip"`` are laid out here with NumPy, the blocks
        deflated on threads (:mod:`~raycast_shade.output.exrwrite`); the
        others by the ``openexr`` package.
    threads : int, optional
        Worker threads deflating the blocks (OpenEXR's, for its
        compressions; its process-wide count is put back afterwards);
        default: one per CPU.
    atomic : bool
        Write a temporary beside ``path`` and move it there once whole.

    Raises
    ------
    ImportError
        ``"rle"``, ``"piz"`` or ``"zstd"`` without the ``openexr`` package
        (``pip install raycast_shade[vision]``).
    TypeError, ValueError
        Naming the buffer or argument at fault, before the file is opened.
    """
    from ..common.validate import as_choice
    from .exrwrite import LINES_PER_BLOCK, write_exr_numpy

    path = _check_path(path, ".exr")
    atomic = as_bool(atomic, "atomic")
    compression = as_choice(compression, "compression", EXR_COMPRESSIONS)
    threads = _threads(threads)
    if compression in LINES_PER_BLOCK:  # laid out with NumPy, blocks deflated on our threads
        channels = _exr_channels(buffers, image, contiguous=False)
        with _target(path, atomic) as target, open(target, "wb") as fh:
            write_exr_numpy(fh, channels, compression, threads=threads)
        return path
    try:
        import OpenEXR
    except ImportError as exc:
        raise ImportError("write_exr: needs the openexr package (pip install 'raycast_shade[vision]')") from exc
    codec = getattr(OpenEXR, compression.upper() + "_COMPRESSION", None)
    if codec is None:  # ZSTD came with OpenEXR 3.4
        raise ValueError(f"compression: {compression!r} needs a newer openexr package than the one installed")
    channels = _exr_channels(buffers, image)
    header = {"compression": codec, "type": OpenEXR.scanlineimage}
    before = OpenEXR.global_thread_count()
    OpenEXR.set_global_thread_count(int(threads))
    try:
        with _target(path, atomic) as target, OpenEXR.File(header, channels) as f:
            f.write(target)
    finally:
        OpenEXR.set_global_thread_count(before)
    return path


def exr_into(fh, buffers: dict, *, image=None, compression: str = "none", threads: int | None = None) -> None:
    """:func:`write_exr`'s bytes into the open binary file ``fh``, front to back (no seek), for the
    compressions laid out here with NumPy (``"none"``, ``"zips"``, ``"zip"``).

    Parameters
    ----------
    fh : binary file
        For instance an :class:`~raycast_shade.output.imagefile.HashingWriter`.
    buffers, image, threads
        As :func:`write_exr` (checked before anything is written).
    compression : {"none", "zips", "zip"}
    """
    from ..common.validate import as_choice
    from .exrwrite import LINES_PER_BLOCK, write_exr_numpy

    compression = as_choice(compression, "compression", tuple(LINES_PER_BLOCK))
    threads = _threads(threads)
    write_exr_numpy(fh, _exr_channels(buffers, image, contiguous=False), compression, threads=threads)


def read_exr(path) -> dict:
    """The buffers (and ``image``) of a :func:`write_exr` file, with their written dtypes and shapes."""
    import OpenEXR

    with OpenEXR.File(_existing(path, ".exr"), separate_channels=True) as f:
        ch = {k: v.pixels for k, v in f.channels().items()}
    out = {}
    if all(c in ch for c in "RGB"):
        out["image"] = np.stack([ch.pop(c) for c in "RGB"], axis=-1)
    vectors = sorted({k.rsplit(".", 1)[0] for k in ch if k.endswith((".X", ".Y", ".Z"))})
    for name in vectors:
        out[name] = np.stack([ch.pop(f"{name}.{a}") for a in _AXES], axis=-1)
    for name, px in ch.items():
        if name in _ID_BUFFERS:
            out[name] = (px.astype(np.int64) - 1).astype(np.int32)
        elif name in _MASKS:
            out[name] = px.astype(bool)
        else:
            out[name] = px
    return out


@njit(cache=True, nogil=True)  # on a view set's writer thread: the next render's thread runs on
def _depth_rows(d, scale, raw):
    """PNG rows of ``round(d * scale)`` as 16-bit big-endian samples into ``raw`` (H, 2W + 1) uint8
    (filter byte 0): 0 where ``d`` is 0, not finite or rounds above 65535, the arithmetic in float64
    as NumPy's ``rint(d.astype(float64) * scale)``. Returns the first negative value's flat index
    (row-major), or -1 (``raw`` then written whole)."""
    h, w = d.shape
    for i in range(h):
        raw[i, 0] = 0
        for j in range(w):
            v = np.float64(d[i, j])
            if v < 0.0:
                return i * w + j
            q = 0
            if np.isfinite(v) and v > 0.0:
                r = np.rint(v * scale)
                if r <= 65535.0:
                    q = np.int64(r)
            raw[i, 1 + 2 * j] = q >> 8
            raw[i, 2 + 2 * j] = q & 255
    return -1


def write_depth_png(path, depth, *, scale: float = 1000.0, fast: bool = False, atomic: bool = False) -> str:
    """Write depth as a 16-bit grey PNG of ``round(depth * scale)``.

    Parameters
    ----------
    path : str or path-like
        Ends in ``.png`` (a ``.jpg`` would lose the 16 bits).
    depth : (H, W) float
        Depth in world units, ``>= 0``; 0 (or not finite) where there is none.
    scale : float
        Stored units per world unit (1000: millimetres from metres).
    fast : bool
        Deflate for speed, not size
        (:func:`~raycast_shade.output.imagefile.png_deflate`).
    atomic : bool
        Write a temporary beside ``path`` and move it there once whole.

    Notes
    -----
    Values that round to more than 65535 are stored as 0 (no depth), not
    clamped, so a reader never mistakes them for a surface.
    """
    path = _check_path(path, ".png")
    atomic = as_bool(atomic, "atomic")
    return write_bytes(path, depth_png_bytes(depth, scale=scale, fast=fast), atomic=atomic)  # a bad value: no file


def depth_png_bytes(depth, *, scale: float = 1000.0, fast: bool = False) -> bytes:
    """The bytes of :func:`write_depth_png`'s file (arguments as there).

    The samples are quantised straight into PNG rows (:func:`_depth_rows`: no
    uint16 image in between); the file is what
    :func:`~raycast_shade.output.imagefile.png_bytes` makes of that uint16 image.
    """
    from ..common.validate import as_array, as_bool

    fast = as_bool(fast, "fast")
    raw_depth = np.asarray(depth) if isinstance(depth, np.ndarray) else None
    wide = np.float32 if raw_depth is not None and raw_depth.dtype == np.float32 else np.float64
    d = as_array(depth, "depth", dtype=wide, ndim=2, finite=False)  # float32 read as it is: no float64 copy
    if 0 in d.shape:
        raise ValueError(f"depth: expected a non-empty (H, W) array, got shape {d.shape}")
    scale = as_scalar(scale, "scale", minimum=0.0, exclusive=True)
    h, w = d.shape
    raw = np.empty((h, 2 * w + 1), np.uint8)  # filter type 0 on every row, then big-endian samples
    bad = _depth_rows(d, float(scale), raw)
    if bad >= 0:
        bad = divmod(int(bad), w)
        raise ValueError(f"depth: negative value {float(d[bad]):g} at (row, column) {bad}; depth is >= 0 (0: none)")
    return png_file(raw, w, h, bits=16, channels=1, fast=fast)


def read_depth_png(path, *, scale: float = 1000.0) -> np.ndarray:
    """(H, W) float32 depth of a :func:`write_depth_png` file (0: none)."""
    import imageio.v3 as iio

    path = _existing(path, ".png")
    scale = as_scalar(scale, "scale", minimum=0.0, exclusive=True)
    return (iio.imread(path).astype(np.float64) / scale).astype(np.float32)
