"""Parallel kernels without parfors: plain compiled loops, run in parts on threads.

A kernel that works in parallel is an ordinary ``@njit(nogil=True)`` function whose
last argument is ``part = (k, parts)``: it runs its share :func:`share` of its outer
loop and nothing else. :func:`launch` calls it once per part, the parts handed out in
order to the calling thread and the pool's threads, whichever asks first; the compiled
code releases the GIL, so the parts run at once. A woken thread that a busy core has not
started yet does not hold the call: the caller runs the part itself.

Why not ``parallel=True``. Numba compiles a ``prange`` loop's body a second time as
a gufunc, links the body's callees into it and optimises them again: measured on the
demo's first picture from an empty kernel cache, 84 s of CPU with the parfors, 53 s
with the same loops compiled serially (2026-12-05, 2-core AVX2 machine). A kernel in
parts compiles once, and its serial call (``part = (0, 1)``) is the same build: no
second "serial twin" for small inputs.

The parts are contiguous shares of the iterations, in order (the kernels walk blocks
in the balanced order of :mod:`.schedule`, so each share covers the whole image
evenly). The number of threads is :func:`numba.get_num_threads` of the calling
thread, so ``numba.set_num_threads`` (and the ``numba_threads`` run option) governs
these kernels as it governs parfors; with more than one, a call runs
:data:`PARTS_PER_THREAD` parts a thread, handed out as the threads ask: a thread that
a busy core slows down takes fewer, so two threads are not slower than one.
A part never waits on another, so any number of callers (a Dask worker's threads)
can share the pool.
"""

from __future__ import annotations

import itertools
import threading
from concurrent.futures import ThreadPoolExecutor

import numba
from numba import njit
from .inline import inline_jit

__all__ = ["share", "launch", "parts", "in_parts", "InParts", "SERIAL", "KERNEL"]

SERIAL = (0, 1)  # the whole loop in the calling thread
# The flags of a kernel in parts: its compiled code releases the GIL so that parts run at once; no
# C wrapper (nothing takes a kernel's address: Python calls it through its CPython wrapper).
KERNEL = dict(cache=True, nogil=True, no_cfunc_wrapper=True)
# Parts a thread of a default launch (more than one thread): with one part a thread, a thread
# that shares its core with another process finished its half at half speed while the caller
# waited (2 threads as slow as 1, or slower); with 4, the caller takes the parts that thread
# has not reached. Each extra part is one more kernel call (measured in benchmarks/bench_threads.py).
PARTS_PER_THREAD = 4

_lock = threading.Lock()
_pools: dict[int, ThreadPoolExecutor] = {}  # one pool per process, made on first use


@inline_jit(cache=True, forceinline=True, _nrt=False)
def share(n, part):
    """Iterations ``lo .. hi`` of ``0 .. n`` that ``part = (k, parts)`` runs.

    Contiguous shares in order whose sizes differ by at most one; together the
    parts cover ``0 .. n`` once.
    """
    k, parts = part
    return k * n // parts, (k + 1) * n // parts


def _pool(workers: int) -> ThreadPoolExecutor:
    # Threads outlive a call: starting two threads costs about as much as a small kernel.
    with _lock:
        pool = _pools.get(workers)
        if pool is None:
            pool = _pools[workers] = ThreadPoolExecutor(workers, thread_name_prefix="raycast_shade")
        return pool


def parts() -> int:
    """:func:`numba.get_num_threads` of the calling thread: the parts of a caller that gives
    each part a slot of its own and passes ``parts=`` to :func:`launch`."""
    return numba.get_num_threads()


def launch(kernel, *args, parts: int | None = None, dynamic: bool = False) -> None:
    """Run ``kernel(*args, (k, parts))`` for every part ``k``, at once, and wait.

    Parameters
    ----------
    kernel : numba dispatcher
        A kernel in parts (compiled with :data:`KERNEL`'s flags).
    *args
        Its arguments but the part.
    parts : int, optional
        How many parts. By default :data:`PARTS_PER_THREAD` times :func:`numba.get_num_threads`
        of the calling thread, run by that many runners (as ``dynamic``), or one part, whole,
        in the calling thread when that is one thread.
    dynamic : bool
        Wake at most :func:`numba.get_num_threads` runners for more parts than threads (parts
        of uneven cost), instead of one runner a part.

    Notes
    -----
    The parts are handed out one at a time, in order, to whichever runner asks first, the
    calling thread included (:class:`_Parts`): when a core is busy with another process and
    a woken thread has not started yet, the caller runs its part too instead of waiting for
    it, so two threads are never much slower than one. Which thread runs a part changes no
    result: a part never waits on another. An exception in any part is raised here, after
    every part has finished; so is a ``KeyboardInterrupt``: no part outlives the call.
    """
    threads = numba.get_num_threads()
    if parts is None:  # (the parameter hides parts())
        n, dynamic = (threads * PARTS_PER_THREAD, True) if threads > 1 else (1, False)
    else:
        n = int(parts)
    runners = min(threads, n) if dynamic else n
    if runners <= 1:
        for k in range(n) if dynamic else (0,):
            kernel(*args, (k, n) if dynamic else SERIAL)
        return
    job = _Parts(kernel, args, n)
    pool = _pool(numba.config.NUMBA_NUM_THREADS)
    for _ in range(1, runners):
        pool.submit(job.run)
    try:
        job.run()
    except BaseException:  # Ctrl-C between two of the caller's parts: the others' running parts first
        job.abandon()
        raise
    job.wait()


class _Parts:
    """The parts of one :func:`launch`, handed out one at a time to its runners.

    A runner takes the next part until none is left; one that starts after the last part
    was taken returns at once, touching nothing. :meth:`wait` returns once every part has
    finished (not every runner has started: the caller does not wait for a thread that a
    busy core has not scheduled yet) and raises the first part's error."""

    __slots__ = ("kernel", "args", "n", "next", "left", "running", "stop", "lock", "idle", "done", "errors")

    def __init__(self, kernel, args, n):
        self.kernel, self.args, self.n = kernel, args, n
        self.next = itertools.count()
        self.left = n  # parts not finished
        self.running: list = []  # the threads running a part, one entry a part
        self.stop = False  # abandoned: no part starts any more
        self.lock = threading.Lock()
        self.idle = threading.Condition(self.lock)  # notified when a part finishes
        self.done = threading.Event()
        self.errors: list = []

    def run(self) -> None:
        n = self.n
        while True:
            with self.lock:  # the part taken and counted as running at once
                k = n if self.stop else next(self.next)
                if k >= n:
                    return
                self.running.append(threading.get_ident())
            try:
                self.kernel(*self.args, (k, n))
            except BaseException as e:  # raised by wait(), after every part
                self.errors.append(e)
            finally:
                with self.lock:
                    self.running.remove(threading.get_ident())
                    self.left -= 1
                    self.idle.notify_all()
                    if self.left == 0:
                        self.done.set()
                        self.args = None  # a late runner holds no buffers

    def abandon(self) -> None:
        """No part starts any more; wait for the other threads' running parts (the caller was
        interrupted, perhaps inside its own part's bookkeeping: its own entries are not waited for)."""
        me = threading.get_ident()
        with self.lock:
            self.stop = True
            while any(t != me for t in self.running):
                self.idle.wait()

    def wait(self) -> None:
        """Wait for every part, even through Ctrl-C: a part still running reads buffers (an Embree
        scene, by its address) that the caller may free once :func:`launch` has returned or raised."""
        interrupted = None
        while True:
            try:
                self.done.wait()
                break
            except KeyboardInterrupt as e:  # wait on, then raise it
                interrupted = e
        if interrupted is not None:
            raise interrupted
        if self.errors:
            raise self.errors[0]


class InParts:
    """A kernel in parts, called as one: ``kernel(*args)`` runs every part (:func:`launch`).

    ``serial(*args)`` runs the whole loop in the calling thread (a handful of rays: no
    threads to wake); ``kernel`` is the compiled function itself, which takes the part.
    """

    __slots__ = ("kernel",)

    def __init__(self, kernel):
        self.kernel = kernel

    def __call__(self, *args) -> None:
        launch(self.kernel, *args)

    def serial(self, *args) -> None:
        """The whole loop in the calling thread: the same build, the same bits."""
        self.kernel(*args, SERIAL)

    @property
    def py_func(self):
        return self.kernel.py_func

    def __repr__(self) -> str:
        return f"InParts({self.kernel.py_func.__qualname__})"


def in_parts(kernel) -> InParts:
    """Decorate a compiled kernel in parts (its last parameter ``part``) so that a call runs
    every part at once: ``@in_parts`` above ``@njit(**KERNEL)``."""
    return InParts(kernel)
