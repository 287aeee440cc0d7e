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
_BAND_BYTES = 4 << 20  # uncompressed lines assembled per write


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


def _fill(out: np.ndarray, arrays, offsets, y0: int, pad: int) -> None:
    """Lines ``y0 .. y0 + len(out)`` into ``out`` (lines, ``pad`` + bytes): each channel's rows at its
    offset; a channel may be a strided view (a 3-vector's component): read in place, never copied whole."""
    rows = out.shape[0]
    for a, start, stop in zip(arrays, offsets[:-1], offsets[1:]):
        out[:, pad + start:pad + stop].view(a.dtype)[...] = a[y0:y0 + rows]


def write_exr_numpy(fh, channels: dict, compression: str = "none", *, threads: int = 2, level: int = 1) -> None:
    """Write ``channels`` as a scanline EXR into the open binary file ``fh``.

    The lines are assembled band by band (a few MiB at a time: no copy of
    the whole image); ZIP and ZIPS blocks are each assembled, reordered,
    predicted and deflated by one job on the thread pool.

    Parameters
    ----------
    fh : binary file
    channels : dict of str to (H, W) uint32 or float32
        One size, any strides; written in sorted name order (the format's).
    compression : {"none", "zips", "zip"}
    threads : int
        Workers for the ZIP/ZIPS blocks (0 or 1: the calling thread).
    level : int
        Deflate level (ISA-L's levels stop at 3).
    """
    names = sorted(channels)
    arrays = [np.asarray(channels[n]) for n in names]
    arrays = [a if a.dtype.isnative else a.astype(a.dtype.newbyteorder("=")) for a in arrays]
    height, width = arrays[0].shape
    per = LINES_PER_BLOCK[compression]
    offsets = np.cumsum([0] + [4 * width for _ in arrays])  # each channel's byte offset within a line
    head = _header(names, [a.dtype for a in arrays], width, height, compression)
    nblocks = -(-height // per)
    first = len(head) + 8 * nblocks
    if compression == "none":  # one line a block: (y, byte count, the line)
        line = 8 + int(offsets[-1])
        table = first + np.arange(height, dtype="<u8") * line
        fh.write(head + table.tobytes())
        band = max(1, _BAND_BYTES // line)
        buf = np.empty((band, line), np.uint8)
        for y0 in range(0, height, band):
            out = buf[:min(band, height - y0)]
            prefix = out[:, :8].view("<i4")
            prefix[:, 0] = np.arange(y0, y0 + len(out))
            prefix[:, 1] = offsets[-1]
            _fill(out, arrays, offsets, y0, 8)
            fh.write(out)
        return
    deflate = _deflater(level)

    def block(y0: int) -> bytes:
        lines = np.empty((min(per, height - y0), int(offsets[-1])), np.uint8)
        _fill(lines, arrays, offsets, y0, 0)
        return _zip_block(lines, deflate)

    starts = range(0, height, per)
    if threads > 1:
        with ThreadPoolExecutor(threads) as pool:
            packed = list(pool.map(block, starts))
    else:
        packed = [block(y0) for y0 in starts]
    sizes = np.array([8 + len(p) for p in packed], np.uint64)
    table = first + np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.uint64)
    fh.write(head + table.astype("<u8").tobytes())
    for k, p in enumerate(packed):
        fh.write(struct.pack("<ii", k * per, len(p)))
        fh.write(p)
