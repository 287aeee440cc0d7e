"""Writing a rendered image to a file, by its extension.

* ``.pfm`` and ``.npy``: the linear float32 image, losslessly;
* ``.png``: 8-bit RGB after :func:`~raycast_shade.output.tonemap.to_uint8` (for
  float32 images by its table, :func:`~raycast_shade.output.quantize.to_uint8_table`:
  the same bytes on one core), with this module's encoder (:func:`png_bytes`,
  the standard library's zlib: no imageio import on the demo's path), which
  also writes the 16-bit grey depth PNGs;
* ``.jpg``/``.jpeg``, ``.bmp``, ``.tif``/``.tiff``, ``.gif``, ``.webp``:
  8-bit, through imageio's Pillow plugin.

Anything else is refused before rendering: imageio falls back to TIFF for
extensions it has no writer for, so ``out.exr`` would otherwise be an 8-bit
TIFF under a float format's name.

``write_image(path, image, atomic=True)`` writes through a temporary file in
the destination folder (:func:`atomic_target`), so a reader, or a resumed
batch, sees the old file or the whole new one, never half a file.
"""

from __future__ import annotations

import contextlib
import os
import re
import uuid

import numpy as np

from ..common.choices import EIGHT_BIT_EXTS, LINEAR_EXTS

__all__ = ["LINEAR_EXTS", "EIGHT_BIT_EXTS", "check_image_path", "check_output_file", "check_output_folder",
           "write_image", "write_png", "write_bytes",
           "atomic_target", "remove_stale_temps", "png_bytes", "png_file", "png_deflate", "sub_filtered", "HashingWriter",
           "write_hashed"]

_FLOAT_FORMATS = (".exr", ".hdr", ".rgbe", ".fits", ".fit")
# What atomic_target names its temporaries: ".<name>.<12 hex digits>.tmp<ext>".
_TMP_RE = re.compile(r"^\.(?P<name>.+)\.[0-9a-f]{12}\.tmp(\.[^.]*)?$")


def check_image_path(path, field: str = "path", *, writable: bool = False) -> str:
    """The lower-case extension of ``path``, if it is one we write.

    Parameters
    ----------
    path : str or path-like
    field : str
        Named in the messages.
    writable : bool
        Also check, before any rendering, that the file can be written: the
        path is not a folder, its parent is an existing folder, and both allow
        writing (``os.access``; note that root passes that test everywhere
        except on read-only file systems).

    Raises
    ------
    ValueError
        Naming ``field``, for an empty path, a missing or unsupported
        extension, or (``writable``) a path that cannot be written.
    """
    name = os.fspath(path)
    if not isinstance(name, str):
        name = os.fsdecode(name)
    if not name:
        raise ValueError(f"{field}: expected a file name, got an empty path")
    ext = os.path.splitext(name)[1].lower()
    formats = ", ".join(EIGHT_BIT_EXTS + LINEAR_EXTS)
    if not ext:
        raise ValueError(f"{field}: {name!r} has no extension; use one of {formats}")
    if ext in _FLOAT_FORMATS:
        raise ValueError(f"{field}: {name!r}: {ext} is not written; use .pfm or .npy for the linear float "
                         "image, or an 8-bit format such as .png")
    if ext not in EIGHT_BIT_EXTS + LINEAR_EXTS:
        raise ValueError(f"{field}: {name!r}: unknown image format {ext!r}; expected one of {formats}")
    if writable:
        check_output_file(name, field)
    return ext


def _probe(folder: str, field: str, name: str) -> None:
    """Create and delete an empty file in ``folder``: the one test of writing that holds for root
    too (``os.access`` grants root everything, and ``/proc`` then refuses the file only when it is
    opened, after the rendering)."""
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"{field}: {name!r} cannot be written (no write permission in {folder})")
    probe = os.path.join(folder, f".raycast_shade-probe-{uuid.uuid4().hex[:12]}")
    try:
        fd = os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    except OSError as exc:
        raise ValueError(f"{field}: {name!r} cannot be written ({exc.strerror or exc} in {folder})") from None
    os.close(fd)
    os.unlink(probe)


def check_output_file(path, field: str = "path") -> str:
    """``path`` as ``str`` if a file can be written there, checked before any work.

    The path is not a folder, its parent is an existing folder in which a file
    can be created (tried with an empty file, deleted at once), and an existing
    file at ``path`` allows writing. The extension is the writer's to check
    (:func:`check_image_path` for images).

    Parameters
    ----------
    path : str or path-like
    field : str
        Named in the messages.

    Raises
    ------
    TypeError
        Naming ``field``, for a path that is not a string or path-like.
    ValueError
        Naming ``field``, for a path that cannot be written.
    """
    from ..common.validate import as_path

    name = as_path(path, field)
    folder = os.path.dirname(os.path.abspath(name))
    if os.path.isdir(name):
        raise ValueError(f"{field}: {name!r} is a folder, not a file")
    if not os.path.exists(folder):
        raise ValueError(f"{field}: {name!r}: folder {folder} does not exist")
    if not os.path.isdir(folder):
        raise ValueError(f"{field}: {name!r}: {folder} is not a folder")
    if os.path.exists(name) and not os.access(name, os.W_OK):
        raise ValueError(f"{field}: {name!r} cannot be written (a read-only file)")
    _probe(folder, field, name)
    return name


def check_output_folder(path, field: str = "folder") -> str:
    """``path`` as ``str`` if it is, or can be made, a folder that files can be written in.

    An existing ``path`` must be a folder; otherwise its nearest existing
    ancestor must be one (:func:`os.makedirs` makes the rest). Writing is
    tried in that folder with an empty file, deleted at once.

    Parameters
    ----------
    path : str or path-like
    field : str
        Named in the messages.

    Raises
    ------
    TypeError
        Naming ``field``, for a path that is not a string or path-like.
    ValueError
        Naming ``field``, for a file in the way or a folder that cannot be written.
    """
    from ..common.validate import as_path

    name = as_path(path, field)
    folder = os.path.abspath(name)
    while not os.path.isdir(folder):
        if os.path.lexists(folder):
            what = "is a file" if folder == os.path.abspath(name) else f"cannot be made: {folder} is a file"
            raise ValueError(f"{field}: {name!r} {what}, not a folder")
        folder = os.path.dirname(folder)
    _probe(folder, field, name)
    return name


@contextlib.contextmanager
def atomic_target(path):
    """A temporary path beside ``path``, moved onto it when the block succeeds.

    The temporary has the same extension (writers pick the format by it) and
    is flushed to disk before one :func:`os.replace`; on any error it is
    deleted and ``path`` is left as it was.

    Parameters
    ----------
    path : str or path-like
        The destination; its folder must exist.

    Yields
    ------
    str
        The temporary path to write.
    """
    folder, name = os.path.split(os.path.abspath(os.fspath(path)))
    tmp = os.path.join(folder, f".{name}.{uuid.uuid4().hex[:12]}.tmp{os.path.splitext(name)[1].lower()}")
    try:
        yield tmp
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


class HashingWriter:
    """A binary file that also feeds every byte written to a hash (``hashlib``'s interface) and counts
    them: a file's digest taken as it is written, not by reading it back.

    Parameters
    ----------
    fh : binary file
        Written front to back (no seek).
    hasher : hashlib hash object
    """

    def __init__(self, fh, hasher):
        self.fh, self.hasher, self.size = fh, hasher, 0

    def write(self, data) -> int:
        """Write ``data`` (bytes-like, C-contiguous) to the file and the hash."""
        view = memoryview(data)
        self.hasher.update(view)  # hashlib releases the GIL on large blocks
        self.size += view.nbytes
        return self.fh.write(view)


def write_hashed(path, fill, hasher, *, atomic: bool = True) -> tuple:
    """Write a file through ``fill(fh)`` (``fh`` a :class:`HashingWriter`), atomically by default.

    Parameters
    ----------
    path : str or path-like
    fill : callable
        Writes the file's bytes front to back into its one argument.
    hasher : hashlib hash object
        Fed every byte written.
    atomic : bool
        Through :func:`atomic_target`.

    Returns
    -------
    tuple
        ``(size in bytes, hasher.hexdigest())``: what :mod:`hashlib` gives over the whole file.
    """
    from ..common.validate import as_bool

    target = atomic_target(path) if as_bool(atomic, "atomic") else contextlib.nullcontext(os.fspath(path))
    with target as tmp, open(tmp, "wb") as fh:
        sink = HashingWriter(fh, hasher)
        fill(sink)
    return sink.size, hasher.hexdigest()


def remove_stale_temps(folder, names) -> int:
    """Delete the temporaries that a killed :func:`atomic_target` left for ``names``.

    Parameters
    ----------
    folder : str or path-like
    names : iterable of str
        Destination file names (without folder) whose temporaries go.

    Returns
    -------
    int
        Files removed.
    """
    names = set(names)
    removed = 0
    for entry in os.listdir(folder):
        m = _TMP_RE.match(entry)
        if m and m.group("name") in names:
            with contextlib.suppress(OSError):
                os.unlink(os.path.join(folder, entry))
                removed += 1
    return removed


def write_image(path, image, *, atomic: bool = False, fast: bool = False, **tone) -> str:
    """Write ``image`` to ``path`` in the format its extension names.

    Parameters
    ----------
    path : str or path-like
        See :func:`check_image_path` for the extensions.
    image : (H, W, 3) float
        Linear RGB.
    atomic : bool
        Write a temporary file in the same folder, then move it onto
        ``path`` (:func:`atomic_target`): never half a file at ``path``.
    fast : bool
        PNG only: deflate for speed, not size (:func:`png_deflate`).
    **tone
        ``exposure``, ``tonemap``, ``gamma`` of :func:`~raycast_shade.output.tonemap.to_uint8`
        (8-bit formats only).

    Returns
    -------
    str
        ``path``.
    """
    from ..common.validate import as_bool

    path = os.fspath(path)
    check_image_path(path)
    fast = as_bool(fast, "fast")
    if as_bool(atomic, "atomic"):
        with atomic_target(path) as tmp:
            _write(tmp, image, tone, fast)
    else:
        _write(path, image, tone, fast)
    return path


def _write(path: str, image, tone: dict, fast: bool = False) -> None:
    from .quantize import to_uint8_table as to_uint8  # to_uint8's bytes, by table for float32 images
    from .tonemap import write_pfm

    ext = check_image_path(path)
    if ext == ".pfm":
        write_pfm(path, image)
    elif ext == ".npy":
        with open(path, "wb") as fh:  # a file object: np.save would append .npy to other names
            np.save(fh, np.asarray(image, np.float32))
    elif ext == ".png":
        write_png(path, to_uint8(image, **tone), fast=fast)
    else:
        import imageio.v3 as iio

        iio.imwrite(path, to_uint8(image, **tone), plugin="pillow", extension=ext)


def write_png(path, image, *, fast: bool = False, atomic: bool = False) -> str:
    """Write an 8- or 16-bit grey or RGB image as PNG (:func:`png_bytes`).

    Importing imageio and Pillow and their adaptive filtering cost about
    0.2 s, a sixth of ``raycast-shade demo``; the "Sub" filter on every row
    followed by zlib level 6 is 4x faster and the file comes out no larger
    on rendered images.

    Parameters
    ----------
    path : str or path-like
    image : (H, W) or (H, W, 3) uint8 or uint16
    fast : bool
        Deflate for speed, not size (:func:`png_deflate`).
    atomic : bool
        Through :func:`atomic_target`: ``path`` is the old file or the whole new one.

    Returns
    -------
    str
        ``path``.
    """
    return write_bytes(path, png_bytes(image, fast=fast), atomic=atomic)  # encoded first: no truncated file


def write_bytes(path, data, *, atomic: bool = False) -> str:
    """Write the bytes ``data`` to ``path``, through :func:`atomic_target` if ``atomic``; returns ``path``."""
    from ..common.validate import as_bool

    path = os.fspath(path)
    target = atomic_target(path) if as_bool(atomic, "atomic") else contextlib.nullcontext(path)
    with target as tmp, open(tmp, "wb") as fh:
        fh.write(data)
    return path


def png_deflate(raw, fast: bool = False) -> bytes:
    """PNG's IDAT stream (zlib format) of ``raw`` (bytes-like), the filtered rows.

    ``fast=False``: zlib level 6. ``fast=True``: ISA-L's level 2 (the
    ``isal`` package) when installed, else zlib level 1. A rendered 1080p
    frame (``benchmarks/bench_views.py``'s ``png`` rows, loaded machine):
    ISA-L 1 and 2 about 4 ms for 0.33 MB, ISA-L 0 as fast for 0.44 MB,
    ISA-L 3 three times slower for 2% less, zlib 1 about 19 ms for 0.35 MB,
    zlib 6 about 77 ms for 0.19 MB; the view sets write their PNGs fast.
    """
    import zlib

    if fast:
        try:
            from isal import isal_zlib
        except ImportError:
            return zlib.compress(raw, 1)
        return isal_zlib.compress(raw, 2)
    return zlib.compress(raw, 6)


def png_file(raw, width: int, height: int, *, bits: int, channels: int, fast: bool = False) -> bytes:
    """The PNG file of already filtered rows: signature, IHDR, one IDAT (:func:`png_deflate`), IEND.

    The one place the PNG container is written; :func:`png_bytes`,
    :func:`~raycast_shade.output.bufferfile.depth_png_bytes` and
    :func:`~raycast_shade.output.pngbands.png_bands` make the rows.

    Parameters
    ----------
    raw : (height, 1 + width * channels * bits // 8) uint8, C-contiguous, or an iterator of such bands
        Each row's filter type byte, then its filtered samples (16-bit ones big-endian). Bands
        (consecutive rows, each consumed before the next is asked for) are deflated as one stream:
        with ``fast=False`` the file is byte for byte that of the rows at once.
    width, height : int
    bits : {8, 16}
        Bits per sample.
    channels : {1, 3}
        Grey or RGB (PNG colour types 0 and 2).
    fast : bool
        As :func:`png_deflate`.
    """
    import struct
    import zlib

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    colour = {1: 0, 3: 2}[channels]
    header = struct.pack(">IIBBBBB", width, height, bits, colour, 0, 0, 0)  # no interlace
    if isinstance(raw, np.ndarray):
        idat = png_deflate(memoryview(raw).cast("B"), fast)  # the rows in place: no bytes copy
    else:
        idat = _deflate_bands(raw, fast)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def _deflate_bands(bands, fast: bool) -> bytes:
    """:func:`png_deflate` of bands of rows fed one by one to one stream (zlib's deflate emits the
    same stream for its input at once or in pieces without a flush)."""
    import zlib

    stream = None
    if fast:
        try:
            from isal import isal_zlib

            stream = isal_zlib.compressobj(2)
        except ImportError:
            stream = zlib.compressobj(1)
    stream = stream or zlib.compressobj(6)
    pieces = [stream.compress(memoryview(band).cast("B")) for band in bands]
    pieces.append(stream.flush())
    return b"".join(pieces)


def sub_filtered(rows, channels: int, out=None):
    """8-bit rows filtered "Sub" (each byte minus the one a pixel to its left), each after its
    filter-type byte: PNG's raw rows.

    Parameters
    ----------
    rows : (R, W * channels) uint8
    channels : int
    out : (>= R, W * channels + 1) uint8, optional
        Filled in its first R rows (a reused band buffer); a new array by default.

    Returns
    -------
    (R, W * channels + 1) uint8
    """
    r, n = rows.shape
    raw = np.empty((r, n + 1), np.uint8) if out is None else out[:r]
    raw[:, 0] = 1  # filter type Sub
    raw[:, 1:channels + 1] = rows[:, :channels]
    np.subtract(rows[:, channels:], rows[:, :-channels], out=raw[:, channels + 1:])  # uint8 wraps, as PNG wants
    return raw


def png_bytes(image, *, fast: bool = False) -> bytes:
    """An 8- or 16-bit grey or RGB image encoded as a PNG file's bytes.

    8-bit rows are filtered "Sub" (each byte minus the one a pixel to its
    left: smaller files on rendered images, see :func:`write_png`); 16-bit
    rows are stored unfiltered, big-endian, as the depth PNGs always were.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8 or uint16
        Grey or RGB; the bit depth is the dtype's.
    fast : bool
        As :func:`png_deflate`.

    Raises
    ------
    TypeError, ValueError
        Naming ``image``, for another dtype or shape, or no pixels.
    """
    from ..common.validate import as_bool

    fast = as_bool(fast, "fast")
    a = np.asarray(image)
    if a.dtype not in (np.uint8, np.uint16):
        raise TypeError(f"image: expected uint8 or uint16 pixels, got dtype {a.dtype}")
    if not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] == 3)) or 0 in a.shape:
        raise ValueError(f"image: expected a non-empty (H, W) or (H, W, 3) array, got shape {a.shape}")
    h, w = a.shape[:2]
    c = 1 if a.ndim == 2 else 3
    if a.dtype == np.uint8:
        raw = sub_filtered(np.ascontiguousarray(a).reshape(h, c * w), c)
    else:
        raw = np.empty((h, 2 * c * w + 1), np.uint8)
        raw[:, 0] = 0  # filter type None
        raw[:, 1:] = a.astype(">u2").reshape(h, c * w).view(np.uint8)
    return png_file(raw, w, h, bits=8 * a.itemsize, channels=c, fast=fast)
