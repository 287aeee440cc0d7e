"""Fresh buffer outputs: one allocation for all of a frame's new buffers.

A frame's new buffers are views of one block (:func:`one_block`), each its own
C-contiguous array; the kernels fault its pages in as they write each band. Used
by :class:`~raycast_shade.output.buffers.FrameBuffers`.
"""

from __future__ import annotations

import mmap

import numpy as np

__all__ = ["one_block", "PAGE"]

PAGE = mmap.PAGESIZE


def one_block(specs, h: int, w: int):
    """New (H, W, ...) outputs of ``specs`` (buffer specs) as views of one allocation, each its own
    C-contiguous array of its shape and dtype starting a page after the previous one ends.
    One allocation is one mapping of the operating system whatever the allocator's state
    (glibc serves blocks under its moving mmap threshold, up to 32 MiB, from its heap),
    advised as huge pages by numpy when 4 MiB or more, so a frame's fresh buffers fault in
    the same way every time (a few hundred huge-page faults for the 12 buffers at 1080p,
    where separate arrays took thousands). The pages are not touched here: the kernels
    fault them in as they write. The block is freed when the last of its buffers is.

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
