"""An 8-bit PNG of a linear image, tone-mapped and deflated band by band.

:meth:`~raycast_shade.output.frame.Frame.save` writes its PNGs here. The
whole-image route (:func:`~raycast_shade.output.imagefile.write_image`) holds
the 8-bit image and its filtered rows at once beside the linear one: 2 x 100 MB
at 7680 x 4320, the peak of an 8K frame's life (0.92 GB resident with the
82k-triangle icosphere, against 0.71 GB for the render; 0.70 GB saved here). Here a band of
:data:`BAND_ROWS` rows is tone-mapped
(:func:`~raycast_shade.output.quantize.to_uint8_table`, a per-value map: a band's
bytes are the whole image's), filtered "Sub" into one reused row buffer and fed
to one zlib stream, so the extra memory is two bands (about 12 MB at 8K) and the
compressed file. The file is byte for byte the whole-image encoder's
(:func:`~raycast_shade.output.imagefile.png_bytes`): zlib's deflate emits the
same stream whether its input comes at once or in pieces without a flush
(``tests/output/test_pngbands.py``).
"""

from __future__ import annotations

import os
import struct
import zlib

import numpy as np

from .imagefile import write_bytes
from .quantize import to_uint8_table

__all__ = ["png_bands", "write_png_bands", "BAND_ROWS"]

BAND_ROWS = 256  # 5.9 MB of 8-bit rows at 7680 pixels a row: two such buffers live at once
_LEVEL = 6  # png_deflate's level (fast=False)


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))


def png_bands(image, *, rows: int = BAND_ROWS, **tone) -> bytes:
    """The 8-bit RGB PNG file of a linear image, encoded ``rows`` rows at a time.

    Parameters
    ----------
    image : (H, W, 3) float
        Linear RGB (as :func:`~raycast_shade.output.tonemap.to_uint8` takes it).
    rows : int
        Rows a band (positive); changes the memory only, never a byte of the file.
    **tone
        ``exposure``, ``tonemap``, ``gamma`` of :func:`~raycast_shade.output.tonemap.to_uint8`.

    Returns
    -------
    bytes
        The PNG file: byte for byte ``png_bytes(to_uint8(image, **tone))``.

    Raises
    ------
    TypeError, ValueError
        Naming ``image`` (not an (H, W, 3) array with pixels) or ``rows``; the tone options'
        errors are :func:`~raycast_shade.output.tonemap.to_uint8`'s, from the first band.
    """
    from ..common.validate import as_int

    rows = as_int(rows, "rows", minimum=1)
    if not isinstance(image, np.ndarray):
        raise TypeError(f"image: expected a NumPy array, got {type(image).__name__}")
    if image.ndim != 3 or image.shape[2] != 3 or 0 in image.shape:
        raise ValueError(f"image: expected a non-empty (H, W, 3) array, got shape {image.shape}")
    h, w = image.shape[:2]
    stream = zlib.compressobj(_LEVEL)  # zlib.compress(raw, 6)'s settings: the same stream
    pieces = []
    raw = np.empty((min(rows, h), 3 * w + 1), np.uint8)
    raw[:, 0] = 1  # filter type Sub
    for y in range(0, h, rows):
        band = to_uint8_table(image[y:y + rows], **tone).reshape(-1, 3 * w)
        r = band.shape[0]
        raw[:r, 1:4] = band[:, :3]
        np.subtract(band[:, 3:], band[:, :-3], out=raw[:r, 4:])  # uint8 arithmetic wraps, as PNG wants
        del band  # before the next band's
        pieces.append(stream.compress(memoryview(raw[:r]).cast("B")))
    pieces.append(stream.flush())
    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)  # 8-bit RGB, no interlace
    return b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", header) + _chunk(b"IDAT", b"".join(pieces)) + _chunk(b"IEND", b"")


def write_png_bands(path, image, *, atomic: bool = False, **tone) -> str:
    """Write :func:`png_bands` of ``image`` to ``path`` (encoded first: no truncated file).

    Parameters
    ----------
    path : str or path-like
        Ending in ``.png``.
    image : (H, W, 3) float
        Linear RGB.
    atomic : bool
        As :func:`~raycast_shade.output.imagefile.write_bytes`.
    **tone
        ``exposure``, ``tonemap``, ``gamma``.

    Returns
    -------
    str
        ``path``.
    """
    if not isinstance(path, (str, os.PathLike)) or not os.fspath(path).lower().endswith(".png"):
        raise ValueError(f"path: a PNG file's name ends in .png, got {path!r:.60}")
    return write_bytes(path, png_bands(image, **tone), atomic=atomic)
