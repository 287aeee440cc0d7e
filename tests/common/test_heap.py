"""common/heap.py: the C heap's free pages given back (glibc's malloc_trim), nothing else touched."""

import platform

import numpy as np
import pytest

from raycast_shade.common.heap import release_free_heap

GLIBC = platform.system() == "Linux" and platform.libc_ver()[0] == "glibc"


def _resident():
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith("VmRSS:"))


@pytest.mark.skipif(not GLIBC, reason="malloc_trim is glibc's")
def test_freed_heap_blocks_leave_the_resident_set():
    """64 KB blocks come from the heap (below glibc's mmap threshold); freed, they stay resident
    until the trim returns them, and live arrays keep their values."""
    keep = np.arange(1000.0)
    blocks = [np.ones(8192) for _ in range(2000)]  # 2000 x 64 KB = 131 MB, every page written
    top = np.zeros(8192)  # live, above them: the heap cannot shrink from its top past it on its own
    del blocks
    before = _resident()
    assert release_free_heap() is True
    after = _resident()
    assert before - after > 50e6, (before, after)
    assert np.array_equal(keep, np.arange(1000.0)) and top[0] == 0.0


def test_it_says_whether_it_could():
    assert release_free_heap() in (True, False)
    assert release_free_heap() is GLIBC or not GLIBC
