"""Scanline EXR files written with NumPy: uncompressed, ZIPS and ZIP, the blocks deflated on threads.

The ``openexr`` package's writer copies every channel line by line and, for
ZIP, compresses with zlib; at 1080p with 27 channels it takes several frames.
This writer lays the file out with whole-array NumPy copies and deflates the
line blocks on a thread pool (ISA-L's deflate when the ``isal`` package is
installed, else zlib; both release the GIL). The file is what OpenEXR's
format defines for a single-part scanline image:

* the magic number and version 2; the header's attributes ``channels``
  (sorted by name, ``UINT`` or ``FLOAT``, sampling 1), ``compression``,
  ``dataWindow`` and ``displayWindow`` ``(0, 0)-(W - 1, H - 1)``,
  ``lineOrder`` increasing y, ``pixelAspectRatio`` 1,
  ``screenWindowCenter`` (0, 0), ``screenWindowWidth`` 1;
* the offset table, one uint64 per line block (1 line uncompressed and in
  ZIPS, 16 in ZIP), then each block: its first line (int32), its byte count
  (int32) and its lines, each line the channels' pixels in the channels' order;
* ZIP and ZIPS: a block's bytes split into the even-indexed then the
  odd-indexed ones, each byte replaced by its difference to the previous one
  plus 128 (modulo 256), then deflated in zlib's format; a block that would
  not shrink is stored as it is (the reader tells by its byte count).

Everything little-endian. OpenEXR reads the files (the tests check it bit for bit).
"""

from __future__ import annotations

import struct
import zlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np

__all__ = ["LINES_PER_BLOCK", "write_exr_numpy"]

#: Scanlines per block of each compression this writer handles (OpenEXR's values).
LINES_PER_BLOCK = {"none": 1, "zips": 1, "zip": 16}
_CODE = {"none": 0, "zips": 2, "zip": 3}
_PIXEL = {np.dtype(np.uint32): 0, np.dtype(np.float32): 2}


def _attr(name: str, kind: str, value: bytes) -> bytes:
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def _header(names, dtypes, width: int, height: int, compression: str) -> bytes:
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", _PIXEL[d], 0, 1, 1) for n, d in zip(names, dtypes))
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    return (struct.pack("<ii", 20000630, 2)
            + _attr("channels", "chlist", chlist + b"\0")
            + _attr("compression", "compression", bytes([_CODE[compression]]))
            + _attr("dataWindow", "box2i", box) + _attr("displayWindow", "box2i", box)
            + _attr("lineOrder", "lineOrder", b"\0")
            + _attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
            + _attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
            + _attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")


def _deflater(level: int):
    try:
        from isal import isal_zlib

        return lambda data: isal_zlib.compress(data, min(level, 3))
    except ImportError:
        return lambda data: zlib.compress(data, level)


def _zip_block(block: np.ndarray, deflate) -> bytes:
    """One ZIP/ZIPS block's stored bytes: reordered, predicted, deflated (or as they are if no smaller)."""
    flat = block.reshape(-1)  # a whole number of 4-byte pixels: an even count
    t = flat.reshape(-1, 2).T.reshape(-1)  # one transposing copy: the even bytes, then the odd ones
    d = np.empty_like(t)
    d[0] = t[0]
    np.subtract(t[1:], t[:-1], out=d[1:])
    d[1:] += np.uint8(128)  # uint8 arithmetic wraps, as the format's modulo 256 wants
    packed = deflate(d)
    return packed if len(packed) < flat.size else flat.tobytes()


def write_exr_numpy(fh, channels: dict, compression: str = "none", *, threads: int = 2, level: int = 1) -> None:
    """Write ``channels`` as a scanline EXR into the open binary file ``fh``.

    Parameters
    ----------
    fh : binary file
    channels : dict of str to (H, W) uint32 or float32
        One size; written in sorted name order (the format's).
    compression : {"none", "zips", "zip"}
    threads : int
        Workers deflating blocks (0 or 1: the calling thread).
    level : int
        Deflate level (ISA-L's levels stop at 3).
    """
    names = sorted(channels)
    arrays = [np.ascontiguousarray(channels[n]) for n in names]
    height, width = arrays[0].shape
    per = LINES_PER_BLOCK[compression]
    offsets = np.cumsum([0] + [4 * width for _ in arrays])  # each channel's byte offset within a line
    pad = 8 if compression == "none" else 0  # uncompressed: each block's (y, size) ahead of its line
    lines = np.empty((height, pad + offsets[-1]), np.uint8)
    for a, start, stop in zip(arrays, offsets[:-1], offsets[1:]):
        lines[:, pad + start:pad + stop] = a.view(np.uint8).reshape(height, 4 * width)
    head = _header(names, [a.dtype for a in arrays], width, height, compression)
    nblocks = -(-height // per)
    table_at = len(head)
    first = table_at + 8 * nblocks
    if compression == "none":
        prefix = lines[:, :8].view("<i4")
        prefix[:, 0] = np.arange(height)
        prefix[:, 1] = offsets[-1]
        table = first + np.arange(height, dtype="<u8") * lines.shape[1]
        fh.write(head + table.astype("<u8").tobytes())
        fh.write(lines)
        return
    deflate = _deflater(level)
    blocks = [lines[y:y + per] for y in range(0, height, per)]
    if threads > 1:
        with ThreadPoolExecutor(threads) as pool:
            packed = list(pool.map(lambda b: _zip_block(b, deflate), blocks))
    else:
        packed = [_zip_block(b, deflate) for b in blocks]
    sizes = np.array([8 + len(p) for p in packed], np.uint64)
    table = first + np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.uint64)
    fh.write(head + table.astype("<u8").tobytes())
    for k, p in enumerate(packed):
        fh.write(struct.pack("<ii", k * per, len(p)))
        fh.write(p)
