"""Give the C heap's free pages back to the system after a large, short-lived working set.

Packing a large mesh (its normals, winding and crease checks, trimesh's subdivision)
allocates and frees hundreds of megabytes of arrays of a few to a few tens of MB. glibc
serves those from its heap once its mmap threshold has risen past them (it rises to the
size of each large block freed, up to 32 MB), and keeps the freed pages resident: 0.15 GB
after making the 1.31M-triangle sphere of the benchmarks (``benchmarks/bench_limits.py``),
and packing it grew the resident size by 0.19 GB for 0.1 GB of arrays, beside the 8K frame
that comes next (its image is mapped afresh: it cannot reuse them). :func:`release_free_heap` asks glibc to return them (``malloc_trim``); elsewhere
(musl, macOS, Windows) it does nothing. It frees only memory nothing holds: no value changes.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools

__all__ = ["release_free_heap"]


@functools.lru_cache(maxsize=1)
def _malloc_trim():
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        trim = getattr(libc, "malloc_trim", None)
    except OSError:
        return None
    if trim is not None:
        trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def release_free_heap() -> bool:
    """Return the C heap's free pages to the system (glibc's ``malloc_trim(0)``).

    Returns
    -------
    bool
        Whether the C library has the call (False: nothing was done).
    """
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True
