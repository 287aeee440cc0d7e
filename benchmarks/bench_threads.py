"""Threads that never hurt: the Phong frame on 1 and 2 threads, quiet and with a busy core.

Run ``python -m benchmarks.bench_threads [--quick] [--repeats N]``.

The plain Phong frame of :mod:`benchmarks.bench_peers` (the 82k-triangle
icosphere) at 640x480 and 320x240, with 1 and 2 Numba threads
(``numba.set_num_threads``, the ``numba_threads`` run option) and, for the
kernels in parts (:mod:`raycast_shade.common.parallel`), one part a thread
(the launch before issue 41) against :data:`~raycast_shade.common.parallel.PARTS_PER_THREAD`
parts a thread handed out as the threads ask. Three conditions, each in the
same process, the four variants interleaved (rotating order) so that the
machine's drifting load falls on all alike:

* ``quiet``: the machine as it is (say its load: other processes may share it);
* ``busy_cpu0``: a second process spinning in a Python loop, pinned to CPU 0
  (``os.sched_setaffinity``, as ``taskset -c 0``);
* ``busy_free``: the same spinner, placed by the scheduler;
* ``half_speed_pool``: no spinner, but every part a pool thread runs is followed
  by a sleep as long as the part took: the pool's thread works at half the
  caller's rate, a model of a core shared half and half with another process
  that the machine's other load does not blur (the caller's parts run as they are).

``--nice N`` runs the benchmark (its threads and the spinner alike) at niceness
``-N`` (root only): on a machine that other processes load, the frame and the
spinner then take the cores from them, and the spinner still halves the core it
shares with a render thread, the condition of the issue.

Reported: the median wall time of each variant after a warm-up (JIT and the
BVH), its minimum, and the ratio two threads over one for each parts setting
(the issue's aim: no more than 1 with a core busy). Every row carries the
1-minute load average. Results: ``benchmarks/results/threads.csv``;
``--quick`` (the small frame, few repeats) writes only under ``out/quick/``.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import subprocess
import sys
import time

import numpy as np

from benchmarks.outputs import results_file, write_csv

KEYS = ["niceness", "condition", "width", "height", "threads", "parts_per_thread", "metric", "value", "unit", "load1"]
CASES = [(640, 480), (320, 240)]
QUICK_CASES = [(160, 120)]
CONDITIONS = ("quiet", "busy_cpu0", "busy_free", "half_speed_pool")


@contextlib.contextmanager
def spinner(cpu: int | None):
    """A busy process for the block's duration, pinned to ``cpu`` (or anywhere: ``None``)."""
    if cpu is None:
        yield None
        return
    proc = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        if cpu >= 0:
            os.sched_setaffinity(proc.pid, {cpu})
        time.sleep(0.3)  # running before the first frame
        yield proc
    finally:
        proc.kill()
        proc.wait()


@contextlib.contextmanager
def half_speed_pool():
    """Every part run by a thread other than the caller's is followed by a sleep as long as it took."""
    import threading

    from raycast_shade.common import parallel

    caller = threading.get_ident()
    plain = parallel._Parts

    def slowed(kernel):
        def run(*args):
            t0 = time.perf_counter()
            kernel(*args)
            if threading.get_ident() != caller:
                time.sleep(time.perf_counter() - t0)
        return run

    class Slowed(plain):
        __slots__ = ()

        def __init__(self, kernel, args, n):
            super().__init__(slowed(kernel), args, n)

    parallel._Parts = Slowed
    try:
        yield
    finally:
        parallel._Parts = plain


def _load():
    return round(os.getloadavg()[0], 2)


def measure(scene, repeats):
    """Median and minimum seconds of ``rs.render(scene, "phong")`` per (threads, parts a thread),
    the variants interleaved in a rotating order."""
    import numba

    import raycast_shade as rs
    from raycast_shade.common import parallel

    variants = [(t, p) for p in (1, parallel.PARTS_PER_THREAD) for t in (1, 2)]
    saved = numba.get_num_threads(), parallel.PARTS_PER_THREAD
    times = {v: [] for v in variants}
    try:
        for r in range(repeats + 1):  # the first round warms up
            for t, p in variants[r % 4:] + variants[:r % 4]:
                numba.set_num_threads(t)
                parallel.PARTS_PER_THREAD = p
                t0 = time.perf_counter()
                rs.render(scene, "phong")
                if r:
                    times[(t, p)].append(time.perf_counter() - t0)
    finally:
        numba.set_num_threads(saved[0])
        parallel.PARTS_PER_THREAD = saved[1]
    return {v: (float(np.median(x)), float(np.min(x))) for v, x in times.items()}


def run(quick=False, repeats=None):
    import numba

    from raycast_shade.common import parallel
    from .bench_peers import make_mesh, make_scene

    if numba.config.NUMBA_NUM_THREADS < 2 or len(os.sched_getaffinity(0)) < 2:
        raise RuntimeError("bench_threads needs 2 CPUs and NUMBA_NUM_THREADS >= 2")
    repeats = repeats or (5 if quick else 15)
    rows = []
    for w, h in QUICK_CASES if quick else CASES:
        scene = make_scene(make_mesh("icosphere", 4 if quick else 6), w, h)
        for cond in CONDITIONS:
            load0 = _load()
            with spinner({"busy_cpu0": 0, "busy_free": -1}.get(cond)), \
                    (half_speed_pool() if cond == "half_speed_pool" else contextlib.nullcontext()):
                res = measure(scene, repeats)
            load = f"{load0}-{_load()}"
            base = dict(niceness=os.getpriority(os.PRIO_PROCESS, 0), condition=cond, width=w, height=h, load1=load)
            for (t, p), (med, lo) in res.items():
                rows.append(dict(base, threads=t, parts_per_thread=p, metric="median_ms", value=round(1e3 * med, 3),
                                 unit="ms"))
                rows.append(dict(base, threads=t, parts_per_thread=p, metric="min_ms", value=round(1e3 * lo, 3),
                                 unit="ms"))
            for p in (1, parallel.PARTS_PER_THREAD):
                ratio = res[(2, p)][0] / res[(1, p)][0]
                rows.append(dict(base, threads="2/1", parts_per_thread=p, metric="2threads_over_1", value=round(ratio, 3),
                                 unit="x"))
                print(f"threads: {w}x{h} {cond:9} {p} part(s)/thread: 1 thread {1e3 * res[(1, p)][0]:.2f} ms, "
                      f"2 threads {1e3 * res[(2, p)][0]:.2f} ms, ratio {ratio:.3f} (load {load})", file=sys.stderr)
    return rows


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("threads.csv", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a small frame, 5 repeats; untracked output")
    ap.add_argument("--repeats", type=int, default=None)
    ap.add_argument("--nice", type=int, default=0, help="run at niceness -N (root; before any thread starts)")
    args = ap.parse_args(argv)
    if args.nice:  # this thread's; the pool's threads and the spinner, started later, inherit it
        os.setpriority(os.PRIO_PROCESS, 0, -args.nice)
    rows = run(args.quick, args.repeats)
    path, = outputs(args.quick)
    write_csv(path, rows, KEYS)
    return rows


if __name__ == "__main__":
    main()
