"""NumPy's ``.npz`` layout written on threads: CRC-32 and deflate in chunks, the disk write overlapped.

``np.savez`` writes through :mod:`zipfile` on one thread: each member's
CRC-32 and (``savez_compressed``) deflate run one after the other before or
while the bytes go to disk. Here every member's CRC-32 and every 4 MiB
chunk's deflate are jobs on a thread pool (zlib and ISA-L release the GIL),
and the calling thread writes the members in order as they finish, front
to back, so the disk write of one member overlaps the work on the next.

The file is an ordinary zip of ``name.npy`` members, as ``np.savez`` makes
(ZIP64 size fields on every member, as ``np.savez`` forces too), read by
``np.load`` and any zip reader:

* stored: each member's bytes as they are;
* deflated: each chunk compressed by a fresh compressor and ended with a
  sync flush (the last with the stream's end), so the chunks concatenate to
  one valid deflate stream (the method of ``pigz``); a chunk does not refer
  back into the previous one, which costs well under 1% of the size at 4 MiB.

Levels 1 to 3 use ISA-L's deflate (the ``isal`` package, extra ``vision``)
when it is installed: at level 1 about 8x zlib's speed for files 15-20%
larger than zlib's level 1; without it, and at the other levels, zlib.
Members carry a fixed date (1980-01-01), so the same arrays give the same bytes.
"""

from __future__ import annotations

import io
import struct
import zlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np

__all__ = ["CHUNK", "FAST_LEVELS", "write_npz", "deflate_backend"]

CHUNK = 4 << 20  # bytes per deflate job: large enough that a chunk's fresh start costs little
FAST_LEVELS = (1, 2, 3)  # the levels ISA-L serves
_DOS_DATE, _DOS_TIME = (0 << 9) | (1 << 5) | 1, 0  # 1980-01-01 00:00, the earliest a zip date holds
_VERSION = 45  # ZIP64
_MADE_BY = (3 << 8) | _VERSION  # Unix, as zipfile writes
_ATTR = 0o600 << 16
_FFFF32 = 0xFFFFFFFF


def deflate_backend(level: int | None, prefer_isal: bool = True) -> str:
    """``"stored"``, ``"isal"`` or ``"zlib"``: what :func:`write_npz` compresses ``level`` with."""
    if level is None:
        return "stored"
    if prefer_isal and level in FAST_LEVELS:
        try:
            import isal.isal_zlib  # noqa: F401
        except ImportError:
            return "zlib"
        return "isal"
    return "zlib"


def _crc32(prefer_isal: bool):
    if prefer_isal:
        try:
            from isal import isal_zlib

            return isal_zlib.crc32  # carry-less multiplication: about 6x zlib 1.2's CRC, the same values
        except ImportError:
            pass
    return zlib.crc32


def _compressor(backend: str, level: int):
    if backend == "isal":
        from isal import isal_zlib

        return lambda: isal_zlib.compressobj(level, isal_zlib.DEFLATED, -15), isal_zlib.Z_SYNC_FLUSH, isal_zlib.Z_FINISH
    return lambda: zlib.compressobj(level, zlib.DEFLATED, -15), zlib.Z_SYNC_FLUSH, zlib.Z_FINISH


def _npy_header(a: np.ndarray) -> bytes:
    """The ``.npy`` header ``np.save`` writes before ``a``'s C-ordered bytes."""
    d = np.lib.format.header_data_from_array_1_0(a)
    out = io.BytesIO()
    try:
        np.lib.format.write_array_header_1_0(out, d)
    except ValueError:  # a header over 64 KiB (a huge structured dtype): format 2.0
        out = io.BytesIO()
        np.lib.format.write_array_header_2_0(out, d)
    return out.getvalue()


def _local_header(name: bytes, flags: int, method: int, crc: int, csize: int, usize: int) -> bytes:
    extra = struct.pack("<HHQQ", 1, 16, usize, csize)  # ZIP64: sizes in the extra field
    return struct.pack("<IHHHHHIIIHH", 0x04034B50, _VERSION, flags, method, _DOS_TIME, _DOS_DATE, crc,
                       _FFFF32, _FFFF32, len(name), len(extra)) + name + extra


def _central_header(name: bytes, flags: int, method: int, crc: int, csize: int, usize: int, offset: int) -> bytes:
    extra = struct.pack("<HHQQQ", 1, 24, usize, csize, offset)
    return struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, _MADE_BY, _VERSION, flags, method, _DOS_TIME, _DOS_DATE,
                       crc, _FFFF32, _FFFF32, len(name), len(extra), 0, 0, 0, _ATTR, _FFFF32) + name + extra


def _end_records(count: int, cd_offset: int, cd_size: int) -> bytes:
    out = b""
    if count >= 0xFFFF or cd_offset >= _FFFF32 or cd_size >= _FFFF32:
        zip64_offset = cd_offset + cd_size
        out += struct.pack("<IQHHIIQQQQ", 0x06064B50, 44, _MADE_BY, _VERSION, 0, 0, count, count, cd_size, cd_offset)
        out += struct.pack("<IIQI", 0x07064B50, 0, zip64_offset, 1)
    return out + struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, min(count, 0xFFFF), min(count, 0xFFFF),
                             min(cd_size, _FFFF32), min(cd_offset, _FFFF32), 0)


def _members(arrays: dict):
    """``(name bytes, zip flags, header bytes, data bytes)`` per array; data a flat uint8 view, no copy
    unless the array is not C-contiguous."""
    for name, a in arrays.items():
        a = np.ascontiguousarray(a)
        entry = (name + ".npy").encode("utf-8")
        flags = 0 if entry.isascii() else 0x800  # bit 11: the name is UTF-8
        yield entry, flags, _npy_header(a), a.reshape(-1).view(np.uint8)


def _deflate(make, sync, finish, head: bytes, data, start: int, stop: int, last: bool) -> bytes:
    c = make()
    out = c.compress(head) if head else b""
    return out + c.compress(data[start:stop]) + c.flush(finish if last else sync)


def write_npz(fh, arrays: dict, level: int | None, *, threads: int = 2, prefer_isal: bool = True) -> None:
    """Write ``arrays`` as an ``.npz`` into the open, seekable binary file ``fh``.

    Parameters
    ----------
    fh : binary file
        Open for writing at its start; written front to back (no seek or
        tell: a pipe or a hashing wrapper will do), each member's header
        once its CRC and deflated chunks are done.
    arrays : dict of str to ndarray
        Written as ``name.npy`` members in the dict's order.
    level : int or None
        None: stored; ``0 <= level <= 9``: deflated (see the module docstring).
    threads : int
        Workers for the CRCs and deflate jobs; 0 or 1: all on the calling thread.
    prefer_isal : bool
        Use ISA-L at levels 1-3 when installed (False: zlib always).
    """
    backend = deflate_backend(level, prefer_isal)
    crc32 = _crc32(prefer_isal)
    members = list(_members(arrays))
    pool = ThreadPoolExecutor(threads) if threads > 1 else None
    run = (lambda fn, *args: pool.submit(fn, *args)) if pool else (lambda fn, *args: _Done(fn(*args)))
    try:
        # Every job is queued at once, in file order: the pool works ahead while the disk takes the first.
        crcs = [run(lambda h, d: crc32(d, crc32(h)), head, data) for _, _, head, data in members]
        pieces = []
        for _, _, head, data in members:
            if backend == "stored":
                pieces.append([_Done(head)] + [_Done(data[i:i + CHUNK]) for i in range(0, len(data), CHUNK)])
                continue
            make, sync, finish = _compressor(backend, level)
            bounds = list(range(0, len(data), CHUNK)) or [0]
            pieces.append([run(_deflate, make, sync, finish, head if k == 0 else b"", data, i, i + CHUNK,
                               k == len(bounds) - 1) for k, i in enumerate(bounds)])
        method = 0 if backend == "stored" else 8
        central = []
        offset = 0
        for (entry, flags, head, data), crc, parts in zip(members, crcs, pieces):
            # The member's sizes and CRC go into its header, so its chunks are awaited first: the file is
            # written front to back (no seek back; a hash of the stream is the file's), and while this
            # member's bytes go to disk the pool works on the next member's.
            chunks = [part.result() for part in parts]
            csize, usize, crc = sum(len(c) for c in chunks), len(head) + len(data), crc.result()
            local = _local_header(entry, flags, method, crc, csize, usize)
            fh.write(local)
            for chunk in chunks:
                fh.write(chunk)
            central.append(_central_header(entry, flags, method, crc, csize, usize, offset))
            offset += len(local) + csize
        cd = b"".join(central)
        fh.write(cd + _end_records(len(central), offset, len(cd)))
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)


class _Done:
    """A finished job's result, for the single-threaded path (the interface of a Future we use)."""

    __slots__ = ("value",)

    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value
