"""Fresh buffer outputs: one allocation for a frame's buffers, paged in a band at a time.

A frame's new buffers are views of one block (:func:`one_block`), paged in by
:func:`touch_pages` just before the kernels write each band: one huge-page region
per thread, so the kernels' threads never fault (and zero) the same huge page at
once. Used by :class:`~raycast_shade.output.buffers.FrameBuffers`.
"""

from __future__ import annotations

import mmap

import numpy as np
from numba import njit, prange

__all__ = ["one_block", "touch_pages", "PAGE", "HUGE_PAGE"]

PAGE = mmap.PAGESIZE


def one_block(specs, h: int, w: int):
    """New (H, W, ...) outputs of ``specs`` (buffer specs) as views of one allocation, each its own
    C-contiguous array of its shape and dtype starting a page after the previous one ends.
    One allocation is one mapping of the operating system whatever the allocator's state
    (glibc serves blocks under its moving mmap threshold, up to 32 MiB, from its heap),
    advised as huge pages by numpy when 4 MiB or more, so a frame's fresh buffers fault in
    the same way every time. The pages are not touched here (:func:`touch_pages`, a band
    at a time). The block is freed when the last of its buffers is.

    Returns
    -------
    block : (N,) uint8
    arrays : dict of str to ndarray
    """
    page = PAGE
    sizes = [int(np.prod(b.shape(h, w))) * np.dtype(b.dtype).itemsize for b in specs]
    starts = np.concatenate([[0], np.cumsum([-(-n // page) * page for n in sizes])]).astype(np.int64)
    block = np.empty(int(starts[-1]), np.uint8)
    return block, {b.name: block[s:s + n].view(b.dtype).reshape(b.shape(h, w))
                   for b, s, n in zip(specs, starts, sizes)}


HUGE_PAGE = 1 << 21  # what one fault zeroes under transparent huge pages (x86-64; arm64 with 4 KiB pages)


@njit(cache=True, parallel=True)
def touch_pages(block, ranges, base, page, huge):
    """Write a zero at the start of every page of the byte ranges of ``block``, one
    ``huge``-byte region of addresses per task: each region is paged in by one thread, so no
    two threads fault (and zero) the same huge page at once.

    Parameters
    ----------
    block : (N,) uint8
    ranges : (K, 2) int64
        Byte offsets ``[start, stop)`` into ``block``.
    base : int
        The address of ``block[0]``.
    page, huge : int
        The page size and the huge-page size, in bytes.
    """
    if ranges.shape[0] == 0:
        return
    r0 = (base + ranges[:, 0].min()) // huge
    r1 = (base + ranges[:, 1].max() - 1) // huge
    for r in prange(r0, r1 + 1):
        a = r * huge - base
        for i in range(ranges.shape[0]):
            p = max(ranges[i, 0], a)
            e = min(ranges[i, 1], a + huge)
            while p < e:
                block[p] = 0
                p = ((base + p) // page + 1) * page - base
