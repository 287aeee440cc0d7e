"""Batch benchmark: frames per second in this process against Dask workers.

Run ``python -m benchmarks.bench_batch [--quick]``. A turntable of an
icosphere (20,480 triangles, two lights, Phong) is rendered

* serially, in this process (Numba on every core, one BVH for all frames);
* on a local Dask cluster of 2 single-threaded worker processes, each with
  one Numba thread (``raycast_shade.apps.batch.local_cluster(2)``);

at a small and a medium resolution. Both are timed after a warm-up batch
(JIT cache loaded, BVH built, on every worker), so the numbers are steady
state; the cluster's start-up and its first batch are reported apart.

The overhead per frame of going through Dask is measured on tiny frames
(16x12, where rendering costs almost nothing) with one worker, one Numba
thread on both sides: ``(t_dask - t_serial) / frames``. It is
what each frame pays for scheduling, pickling its job and its image, and the
round trips to the scheduler; ``frames_per_task`` > 1 spreads it over
several frames.

Results: ``benchmarks/results/batch.csv`` (``results/quick/batch.csv`` in quick mode).
"""

from __future__ import annotations

import argparse
import csv
import os
import time

from benchmarks.outputs import ROOT, results_file

FIELDS = ["benchmark", "mode", "workers", "numba_threads", "frames_per_task", "width", "height", "frames", "seconds",
          "fps", "ms_per_frame", "speedup", "note"]


def _scene(width: int, height: int):
    import raycast_shade as rs

    return rs.Scene(
        [rs.Model(rs.shapes.icosphere(5), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
        lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square"),
                rs.DirectionalLight((-1, -0.5, -1), intensity=0.3)],
        camera=rs.Camera(eye=(0.0, 0.6, 3.2), width=width, height=height),
    )


def _best_time(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _row(mode, workers, threads, w, h, frames, seconds, speedup="", note="", per_task=""):
    return dict(benchmark="batch", mode=mode, workers=workers, numba_threads=threads, frames_per_task=per_task,
                width=w, height=h,
                frames=frames, seconds=round(seconds, 4), fps=round(frames / seconds, 2),
                ms_per_frame=round(1e3 * seconds / frames, 3), speedup=speedup, note=note)


def bench_throughput(cases, frames: int, repeats: int):
    """Serial against 2 workers; one cluster for all cases."""
    import numba

    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.batch import local_cluster, render_batch

    rows = []
    jobs = []
    for w, h in cases:
        scene = _scene(w, h)
        cams = orbit_cameras(scene.camera, frames)
        render_batch(scene, cams[:2], progress=False)  # JIT + BVH
        t = _best_time(lambda: render_batch(scene, cams, progress=False), repeats)
        rows.append(_row("serial", 0, numba.get_num_threads(), w, h, frames, t, 1.0, "this process"))
        jobs.append((scene, cams, t))
    t0 = time.perf_counter()
    with local_cluster(2, numba_threads=1) as client:
        startup = time.perf_counter() - t0
        for (scene, cams, t_serial), (w, h) in zip(jobs, cases):
            t1 = time.perf_counter()
            render_batch(scene, cams, scheduler=client, progress=False)  # JIT cache + BVH on each worker
            first = time.perf_counter() - t1
            for per_task in (1, 4):
                t = _best_time(lambda: render_batch(scene, cams, scheduler=client, progress=False,
                                                    frames_per_task=per_task), repeats)
                note = f"first batch {first:.2f} s" if per_task == 1 else ""
                rows.append(_row("dask", 2, 1, w, h, frames, t, round(t_serial / t, 2), note, per_task))
    rows.append(dict(benchmark="startup", mode="dask", workers=2, numba_threads=1, seconds=round(startup, 3),
                     note="LocalCluster(2 processes) + Client"))
    return rows


def bench_overhead(frames: int, repeats: int):
    """Per-frame cost of Dask on frames that cost almost nothing to render."""
    import numba

    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.batch import local_cluster, render_batch

    w, h = 16, 12
    scene = _scene(w, h)
    cams = orbit_cameras(scene.camera, frames)
    # One Numba thread on both sides: a parallel launch on a busy shared core stalls at its barrier,
    # which would be noise here, not Dask's cost.
    threads = 1
    saved = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        render_batch(scene, cams[:2], progress=False)
        t_serial = _best_time(lambda: render_batch(scene, cams, progress=False), repeats)
    finally:
        numba.set_num_threads(saved)
    rows = [_row("serial", 0, threads, w, h, frames, t_serial, note="tiny frames")]
    with local_cluster(1, numba_threads=threads) as client:
        render_batch(scene, cams, scheduler=client, progress=False)
        for per_task in (1, 8):
            t_dask = _best_time(lambda: render_batch(scene, cams, scheduler=client, progress=False,
                                                     frames_per_task=per_task), repeats)
            rows.append(_row("dask", 1, threads, w, h, frames, t_dask, round(t_serial / t_dask, 2), "tiny frames",
                             per_task))
            rows.append(dict(benchmark="overhead", mode="dask", workers=1, numba_threads=threads,
                             frames_per_task=per_task, width=w, height=h, frames=frames,
                             ms_per_frame=round(1e3 * (t_dask - t_serial) / frames, 3),
                             note="(t_dask - t_serial) / frames"))
    return rows


def run(quick: bool = False):
    """Run the benchmark.

    Parameters
    ----------
    quick : bool
        Fewer and smaller frames, fewer repeats (about 20 s on 2 cores).

    Returns
    -------
    list of dict
        One row per measurement (see ``FIELDS``).
    """
    # Best of several repeats: the machine is shared, and a slow repeat measures the neighbours.
    if quick:
        cases, frames, repeats, tiny = [(96, 72), (320, 240)], 24, 3, 96
    else:
        cases, frames, repeats, tiny = [(96, 72), (320, 240), (640, 480)], 96, 5, 384
    return bench_throughput(cases, frames, repeats) + bench_overhead(tiny, repeats + 2)


def write(rows, path):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=FIELDS)
        wr.writeheader()
        wr.writerows(rows)


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("batch.csv", quick)]


def main(argv=None):
    """Command line: ``python -m benchmarks.bench_batch [--quick]``; returns the rows."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer, smaller frames and repeats")
    args = ap.parse_args(argv)
    rows = run(args.quick)
    path, = outputs(args.quick)
    write(rows, path)
    for r in rows:
        size = f"{r.get('width', '')}x{r.get('height', '')}" if r.get("width") else ""
        print(f"{r['benchmark']:9} {r['mode']:7} workers={r['workers']} threads={r['numba_threads']} "
              f"per_task={r.get('frames_per_task', '')!s:>2} {size:>8} "
              f"fps={r.get('fps', '')!s:>8} ms/frame={r.get('ms_per_frame', '')!s:>8} "
              f"speedup={r.get('speedup', '')!s:>5} {r.get('note', '')}")
    print(f"wrote {os.path.relpath(path, ROOT)}")
    return rows


if __name__ == "__main__":
    main()
