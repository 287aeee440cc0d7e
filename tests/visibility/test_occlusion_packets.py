"""Occlusion packets own every byte Embree touches, even the bytes it only rewrites.

Without 16-wide kernels (an AVX2 CPU), ``rtcOccluded16`` traces a packet's lanes one by one: it
copies each lane out as an ``RTCRayHit`` and back into the packet as an ``RTCRayHit16``, so it
reads and writes the hit fields *past* the ``RTCRay16`` it was given. Writing back what it read is
harmless to a buffer nobody else uses, and corrupts whatever another thread changed there in the
meantime (a heap chunk's header, a lock's semaphore: the suite's rare "cannot notify on
un-acquired lock" and glibc's "smallbin double linked list corrupted" under two render threads).
The packets of :func:`~raycast_shade.visibility.secondary.occlusion_packets` are therefore laid
out a whole ``RTCRayHit16`` apart, and these tests hold them to it.
"""

from __future__ import annotations

import threading

import numpy as np
from numba import njit

import raycast_shade as rs
from raycast_shade.visibility import embree, secondary
from raycast_shade.visibility.accel import embree_accel

_RAYHIT16 = secondary.LANES * embree.RAYHIT_SLOTS
_TIMES = 50000  # packets traced while the other thread writes


def test_each_packet_has_a_whole_rayhit16_inside_the_buffer():
    for groups in (1, 2, 4, 5):
        buf, ib, off, valid, voff, args, aoff, vis = secondary.occlusion_packets(groups)
        base = buf.ctypes.data + 4 * off
        assert base % 64 == 0 and (valid.ctypes.data + 4 * voff) % 64 == 0
        assert secondary._STRIDE >= _RAYHIT16 and (4 * secondary._STRIDE) % 64 == 0
        # the last packet's RTCRayHit16 ends inside the buffer
        assert off + (groups - 1) * secondary._STRIDE + _RAYHIT16 <= len(buf)
        assert vis.shape == (groups, secondary.LANES) and len(valid) >= voff + groups * secondary.LANES


@njit(nogil=True)
def _trace(handle, buf, ib, off, valid, voff, args, aoff, times):
    """``times`` packets of 16 shadow rays from under a plane through it (every lane active)."""
    for _ in range(times):
        for k in range(secondary.LANES):
            b = off + k
            buf[b + embree.RAY_ORG * 16] = -0.3 + 0.02 * (k % 4)
            buf[b + (embree.RAY_ORG + 1) * 16] = -1.0
            buf[b + (embree.RAY_ORG + 2) * 16] = -0.3 + 0.02 * (k // 4)
            buf[b + embree.RAY_DIR * 16] = 0.0
            buf[b + (embree.RAY_DIR + 1) * 16] = 1.0
            buf[b + (embree.RAY_DIR + 2) * 16] = 0.0
            buf[b + embree.RAY_TNEAR * 16] = 0.0
            buf[b + embree.RAY_TIME * 16] = 0.0
            buf[b + embree.RAY_TFAR * 16] = 10.0
            ib[b + embree.RAY_MASK * 16] = np.uint32(0xFFFFFFFF)
            ib[b + embree.RAY_ID * 16] = 0
            ib[b + embree.RAY_FLAGS * 16] = 0
            valid[voff + k] = -1
        secondary.trace_occlusion(handle, buf, off, valid, voff, args, aoff, np.zeros((1, 16), np.int8))


@njit(nogil=True)
def _bump(counts, times):
    for _ in range(times):
        for j in range(counts.shape[0]):
            counts[j] += 1


def test_embree_rewrites_nothing_past_a_packets_stride_while_another_thread_writes_there():
    """A thread increments the 256 slots right after a packet's stride while another traces the
    packet: every increment survives (Embree's rewrite of the hit fields stays inside the stride).
    With the old RTCRay16 stride (the slots right after the RTCRay16), 9 to 144 of them lost increments, up to
    358,748 of 800,000
    (2-core AVX2 machine, 2026-12-06)."""
    scene = rs.Scene([rs.Model(rs.shapes.plane(2.0, normal="+y"), rs.Material(kd=0.5))],
                     camera=rs.Camera(eye=(0.0, 3.0, 0.1), target=(0.0, 0.0, 0.0), width=8, height=8))
    handle = np.uintp(embree_accel(scene.geometry).handle)
    _, _, _, valid, voff, args, aoff, _ = secondary.occlusion_packets(1)
    # The packet inside a larger array, so that the slots after its stride exist and are ours.
    big = np.zeros(secondary._STRIDE + 16 + 512, np.float32)
    off = ((64 - big.ctypes.data % 64) % 64) // 4
    counts = big[off + secondary._STRIDE:off + secondary._STRIDE + 256].view(np.int32)
    counts[:] = 0
    times = _TIMES
    _trace(handle, big, big.view(np.uint32), off, valid, voff, args, aoff, 1)  # compiled before the race
    _bump(np.zeros(1, np.int32), 1)
    tracer = threading.Thread(target=_trace, args=(handle, big, big.view(np.uint32), off, valid, voff, args, aoff,
                                                   times))
    bumper = threading.Thread(target=_bump, args=(counts, 4 * times))
    tracer.start()
    bumper.start()
    tracer.join()
    bumper.join()
    np.testing.assert_array_equal(counts, np.full(256, 4 * times, np.int32))
    assert big[off + embree.RAY_TFAR * 16:off + embree.RAY_TFAR * 16 + 16].max() < 0.0  # the plane blocks all 16
