"""Fresh buffer outputs (raycast_shade.output.bufferpages): one block split into each buffer's own
C-contiguous array of its shape and dtype; the caller's arrays stay theirs."""

from __future__ import annotations

import numpy as np

import raycast_shade as rs
from raycast_shade.common.bufferspec import BUFFERS, KERNEL_BUFFERS
from raycast_shade.output.bufferpages import PAGE, one_block
from raycast_shade.output.buffers import FrameBuffers


def test_one_block_gives_each_buffer_its_own_c_contiguous_array():
    specs = [b for b in KERNEL_BUFFERS]
    block, arrays = one_block(specs, 37, 53)
    assert list(arrays) == [b.name for b in specs]
    spans = []
    for b in specs:
        a = arrays[b.name]
        assert a.shape == b.shape(37, 53) and a.dtype == np.dtype(b.dtype)
        assert a.flags.c_contiguous and a.flags.writeable
        start = a.ctypes.data - block.ctypes.data
        assert start % PAGE == 0  # each starts on a page of the block's own
        spans.append((start, start + a.nbytes))
    spans.sort()
    assert all(e <= s for (_, e), (s, _) in zip(spans, spans[1:]))  # disjoint
    assert spans[-1][1] <= block.nbytes
    for name, a in arrays.items():  # written through one, the others unchanged
        a[...] = 1
        for other, b in arrays.items():
            if other != name:
                b[...] = 0
        assert np.all(a == 1)


def test_frame_buffers_fresh_outputs_share_one_block_and_caller_arrays_stay_theirs():
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1))], camera=rs.Camera(eye=(0, 0, 3), width=40, height=30))
    mine = np.full((30, 40), 5.0, np.float32)
    fb = FrameBuffers(scene, scene.camera, ("zdepth", "position", "mask", "depth"), out={"depth": mine})
    assert fb.full["depth"] is mine
    for name in ("zdepth", "position", "mask"):
        a = fb.full[name]
        assert a.base is not None and np.shares_memory(a, fb._block)
        assert a.shape == BUFFERS[name].shape(30, 40) and a.flags.c_contiguous
    assert not np.shares_memory(mine, fb._block)
