"""Kernels in parts (common/parallel.py): the shares and the launch."""

import threading

import numba
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from numba import njit

from raycast_shade.common.parallel import SERIAL, in_parts, launch, parts, share


@njit(nogil=True)
def _mark(out, seen, part):
    """Each iteration of this part's share: its part index; ``seen[k]``: the parts count."""
    i0, i1 = share(out.shape[0], part)
    for i in range(i0, i1):
        out[i] = part[0]
    seen[part[0]] = part[1]


@njit(nogil=True)
def _fail_in(k, part):
    if part[0] == k:
        raise ValueError("part failed")


@given(n=st.integers(0, 10 ** 7), m=st.integers(1, 64))
@settings(max_examples=300, deadline=None)
def test_the_shares_cover_the_loop_once_in_order(n, m):
    bounds = [share(n, (k, m)) for k in range(m)]
    assert bounds[0][0] == 0 and bounds[-1][1] == n
    assert all(a[1] == b[0] for a, b in zip(bounds, bounds[1:]))  # contiguous, in order
    sizes = [hi - lo for lo, hi in bounds]
    assert min(sizes) >= 0 and max(sizes) - min(sizes) <= 1


@pytest.mark.parametrize("m", [1, 2, 3, 5])
def test_launch_runs_every_part_once(m):
    out = np.full(1000, -1, np.int64)
    seen = np.zeros(m, np.int64)
    launch(_mark, out, seen, parts=m)
    want = np.concatenate([np.full(hi - lo, k) for k, (lo, hi) in enumerate(share(1000, (k, m)) for k in range(m))])
    assert np.array_equal(out, want)
    assert seen.tolist() == [m] * m


def test_the_default_parts_follow_numba_set_num_threads():
    seen = np.zeros(numba.config.NUMBA_NUM_THREADS, np.int64)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        assert parts() == 1
        launch(_mark, np.zeros(10, np.int64), seen)
        assert seen[0] == 1 and not seen[1:].any()
    finally:
        numba.set_num_threads(old)
    assert parts() == old


@pytest.mark.parametrize("k", [0, 1])
def test_an_error_in_any_part_is_raised_by_launch(k):
    with pytest.raises(ValueError, match="part failed"):
        launch(_fail_in, k, parts=2)


def test_in_parts_calls_every_part_and_serial_runs_one():
    kernel = in_parts(_mark)
    out, seen = np.full(64, -1, np.int64), np.zeros(numba.config.NUMBA_NUM_THREADS, np.int64)
    kernel.serial(out, seen)
    assert not out.any() and seen[0] == 1
    assert kernel.py_func is _mark.py_func and SERIAL == (0, 1)


def test_callers_in_several_threads_share_the_pool():
    """Four threads launching at once (a Dask worker's executor threads): every output whole."""
    outs = [np.full(5000, -1, np.int64) for _ in range(4)]
    errors = []

    def work(out):
        try:
            for _ in range(20):
                out[:] = -1
                launch(_mark, out, np.zeros(2, np.int64), parts=2)
                assert (out >= 0).all()
        except Exception as e:  # reported below: an assert in a thread would be lost
            errors.append(e)

    threads = [threading.Thread(target=work, args=(o,)) for o in outs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors


def test_an_interrupt_waits_for_every_part(monkeypatch):
    """Ctrl-C while the caller waits: ``launch`` waits for the running parts before it raises
    (they may read an Embree scene the caller frees next), and raises the interrupt."""
    from raycast_shade.common import parallel

    job = parallel._Parts(_mark, (np.zeros(4, np.int64), np.zeros(2, np.int64)), 2)
    calls = []

    def wait(timeout=None):
        calls.append(1)
        if len(calls) == 1:
            raise KeyboardInterrupt  # the first wait is interrupted
        return True

    monkeypatch.setattr(job.done, "wait", wait)
    with pytest.raises(KeyboardInterrupt):
        job.wait()
    assert len(calls) == 2  # it waited again after the interrupt


def test_the_caller_runs_the_parts_a_sleeping_runner_has_not_started(monkeypatch):
    """A busy core: the pool's thread does not start until the caller has returned. The caller
    runs every part itself and returns (the old launch waited for that thread); the runner,
    started late, finds no part left and touches nothing."""
    from raycast_shade.common import parallel

    gate = threading.Event()
    late = []

    class Stalled:  # a pool whose thread waits for the gate before running what it was handed
        def submit(self, fn):
            def go():
                gate.wait()
                late.append(fn())
            threading.Thread(target=go).start()

    monkeypatch.setattr(parallel, "_pool", lambda workers: Stalled())
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(2)
        out, seen = np.full(1000, -1, np.int64), np.zeros(4, np.int64)
        launch(_mark, out, seen, parts=4)  # returns without the stalled thread: no deadlock
        assert seen.tolist() == [4, 4, 4, 4]  # every part ran, once, in the caller
        want = np.concatenate([np.full(hi - lo, k) for k, (lo, hi) in enumerate(share(1000, (k, 4)) for k in range(4))])
        assert np.array_equal(out, want)
        assert late == []
        gate.set()
        for _ in range(500):
            if len(late) == 3:  # one runner a part but the caller's
                break
            threading.Event().wait(0.01)
        assert late == [None] * 3 and seen.tolist() == [4, 4, 4, 4]
    finally:
        numba.set_num_threads(old)


def test_an_abandoned_launch_starts_no_part_and_waits_for_the_running_one():
    """What ``launch`` does when Ctrl-C reaches the caller between its parts: ``abandon`` returns
    only once another thread's running part has finished, and no part starts after it."""
    from raycast_shade.common import parallel

    started, finished = threading.Event(), []

    def kernel(part):
        started.set()
        threading.Event().wait(0.2)  # still running when the caller abandons
        finished.append(part[0])

    job = parallel._Parts(kernel, (), 4)
    runner = threading.Thread(target=job.run)
    runner.start()
    assert started.wait(5)
    job.abandon()
    assert finished == [0]  # waited for the running part
    runner.join(5)
    assert finished == [0] and not runner.is_alive()  # and no part started after it


def test_a_thread_held_in_its_part_holds_back_only_that_part(monkeypatch):
    """A busy core: the pool's thread starts a part, then is descheduled (held here until the
    caller has run every other part). A default launch on 2 threads cuts the loop into
    ``PARTS_PER_THREAD`` parts a thread, so the caller runs all but the held one: the held
    thread delays 1/8 of the loop, not half of it (the launch before issue 41's item 4)."""
    from raycast_shade.common import parallel

    release = threading.Event()
    me = threading.get_ident()
    ran = {"caller": [], "pool": []}
    total = 2 * parallel.PARTS_PER_THREAD

    def kernel(out, part):
        if threading.get_ident() == me:
            ran["caller"].append(part)
            if len(ran["caller"]) == total - 1:  # every part but the held one: let the pool's go on
                release.set()
        else:
            ran["pool"].append(part)
            assert release.wait(10), "the caller did not run the other parts"
        out[slice(*share(out.shape[0], part))] = part[0]

    monkeypatch.setattr(parallel, "PARTS_PER_THREAD", 4)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(2)
        out = np.full(1000, -1, np.int64)
        # The caller waits for the pool's thread to take a part first (a thread that got its part,
        # then lost its core): hold the caller's first part until the pool has one.
        taken = threading.Event()

        def first(out, part):
            if threading.get_ident() != me:
                taken.set()
            elif not taken.is_set():
                taken.wait(10)
            kernel(out, part)

        launch(first, out)
    finally:
        numba.set_num_threads(old)
    assert len(ran["pool"]) == 1 and len(ran["caller"]) == total - 1
    assert sorted(k for k, _ in ran["caller"] + ran["pool"]) == list(range(8))
    assert {m for _, m in ran["caller"] + ran["pool"]} == {8}
    want = np.concatenate([np.full(hi - lo, k) for k, (lo, hi) in enumerate(share(1000, (k, 8)) for k in range(8))])
    assert np.array_equal(out, want)


def test_one_thread_runs_a_default_launch_whole_in_the_caller():
    """One thread: one call over the whole loop (no parts to hand out, no per-part calls)."""
    calls = []
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        launch(lambda part: calls.append((threading.get_ident(), part)))
    finally:
        numba.set_num_threads(old)
    assert calls == [(threading.get_ident(), SERIAL)]
