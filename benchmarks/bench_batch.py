"""Batch benchmark: serial against the process pool and Dask workers on this machine, and the cost model.

Run ``python -m benchmarks.bench_batch [--quick] [--only pool]``. A turntable of an
icosphere (20,480 triangles, two lights, Phong) is rendered into a list of
images, and every number is steady state (JIT cache loaded and BVH built on
every worker by a warm-up batch; cluster start-up and that first batch are
reported apart, as ``startup`` rows). The machine is shared: each Dask
timing is interleaved with a serial one in the same repeat, and
``speedup`` is the median over the repeats of ``t_serial / t_dask``.

* **pool**: per size (160x120 to 1920x1080), this process against 2
  single-threaded workers of a :class:`ProcessPool` (started once, and
  started by each batch: ``render_batch(workers=2)``) and of a Dask
  LocalCluster, interleaved; start-up and first batch apart; CPU per frame
  of every process (``--only pool`` runs just this, into ``batch_pool.csv``);
* **throughput**: per size, this process (Numba on every core) against 2
  single-threaded workers as they were (``transfer="dask"``,
  ``frames_per_task=1``) and as they are by default (images through a
  temporary folder, ``frames_per_task=None``), and each change alone;
* **scaling**: 1 to 4 workers (3 and 4 oversubscribe 2 cores), one Numba
  thread each, and 2 workers with 2 threads each (4 threads on 2 cores);
* **cost**: per-task overhead (tiny 16x12 frames, 1 worker, one Numba thread
  on both sides: ``(t_dask - t_serial) / frames``, and the CPU time of the
  client + scheduler process and of the worker per task); the CPU cost of a
  returned image per MB (``transfer="dask"`` against ``"disk"``); the bytes
  moved: the scene once per worker, a frame's job, its image.

Results: ``benchmarks/results/batch.csv`` (or ``batch_pool.csv``), ``docs/images/batch_scaling.png``
and ``docs/images/batch_pool.png``
(``out/quick/results/``, ``out/quick/images/`` in quick mode).
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import tempfile
import time

from benchmarks.outputs import ROOT, images_dir, results_file, write_csv

FIELDS = ["benchmark", "mode", "workers", "numba_threads", "frames_per_task", "transfer", "width", "height",
          "frames", "seconds", "fps", "ms_per_frame", "speedup", "value", "unit", "load", "note"]


def _scene(width: int, height: int):
    import raycast_shade as rs

    return rs.Scene(
        [rs.Model(rs.shapes.icosphere(5), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
        lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square"),
                rs.DirectionalLight((-1, -0.5, -1), intensity=0.3)],
        camera=rs.Camera(eye=(0.0, 0.6, 3.2), width=width, height=height),
    )


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def _row(mode, workers, threads, w, h, frames, times, speedup="", note="", per_task="", transfer="", load=""):
    seconds = statistics.median(times)
    return dict(benchmark="batch", mode=mode, workers=workers, numba_threads=threads, frames_per_task=per_task,
                transfer=transfer, width=w, height=h, frames=frames, seconds=round(seconds, 4),
                fps=round(frames / seconds, 2), ms_per_frame=round(1e3 * seconds / frames, 3),
                speedup=speedup, load=load, note=note)


def _interleaved(serial, variants: dict, repeats: int):
    """Median times of ``serial`` and of each variant, and each variant's median of per-repeat ratios."""
    times = {"serial": []} | {name: [] for name in variants}
    for _ in range(repeats):
        times["serial"].append(_timed(serial))
        for name, fn in variants.items():
            times[name].append(_timed(fn))
    ratios = {name: round(statistics.median(s / t for s, t in zip(times["serial"], times[name])), 2)
              for name in variants}
    return times, ratios


# The Dask variants of bench_throughput: (label, frames_per_task, transfer).
VARIANTS = [("before: 1 frame/task, images via Dask", 1, "dask"),
            ("auto frames/task, images via Dask", None, "dask"),
            ("1 frame/task, images via disk", 1, "disk"),
            ("default: auto frames/task, images via disk", None, "auto")]


def bench_throughput(cases, frames: int, repeats: int):
    """Serial against 2 single-threaded workers, before and after, interleaved; one cluster for all cases."""
    import numba

    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.batch import RunOptions, local_cluster, render_batch
    from raycast_shade.apps.batch.dask_driver import auto_frames_per_task
    from raycast_shade.apps.batch.plan import plan_batch

    rows = []
    t0 = time.perf_counter()
    with local_cluster(2, numba_threads=1) as client:
        startup = time.perf_counter() - t0
        rows.append(dict(benchmark="startup", mode="dask", workers=2, numba_threads=1, seconds=round(startup, 3),
                         load=_load(), note="LocalCluster(2 processes) + Client"))
        for w, h in cases:
            scene = _scene(w, h)
            cams = orbit_cameras(scene.camera, frames)
            render_batch(scene, cams[:2], run=RunOptions(progress=False))  # JIT + BVH here
            first = _timed(lambda: render_batch(scene, cams[:4], run=RunOptions(scheduler=client,
                                                                                    progress=False)))
            rows.append(dict(benchmark="startup", mode="dask", workers=2, numba_threads=1, width=w, height=h,
                             frames=4, seconds=round(first, 3), load=_load(),
                             note="first batch of 4 frames: Numba cache loaded, BVH built on each worker"))
            auto = auto_frames_per_task(plan_batch(scene, cams)[1], 2)
            variants = {label: (lambda k=k, tr=tr: render_batch(scene, cams, run=RunOptions(
                                    scheduler=client, progress=False, per_task=k, transfer=tr)))
                        for label, k, tr in VARIANTS}
            load = _load()
            times, ratios = _interleaved(lambda: render_batch(scene, cams, run=RunOptions(progress=False)), variants,
                                         repeats)
            rows.append(_row("serial", 0, numba.get_num_threads(), w, h, frames, times["serial"], 1.0,
                             "this process", load=load))
            for label, k, tr in VARIANTS:
                rows.append(_row("dask", 2, 1, w, h, frames, times[label], ratios[label], label,
                                 auto if k is None else k, tr, load))
    return rows


def _pool_cpu(pool) -> float:
    import psutil

    total = 0.0
    for pid in pool.pids:
        t = psutil.Process(pid).cpu_times()
        total += t.user + t.system
    return total


# Sizes of the pool benchmark and their frame counts: a serial repeat of 1-3 s each.
POOL_CASES = [((160, 120), 384), ((640, 480), 96), ((1280, 720), 48), ((1920, 1080), 32)]


def bench_pool(cases, repeats: int):
    """Serial against the process pool and a Dask LocalCluster, 2 single-threaded workers each, interleaved.

    The pool and the cluster are started once (``startup`` rows) and warmed
    by a first batch of 4 frames per size (``startup`` rows too); the
    ``batch`` rows are steady state. ``processes, new pool`` is
    ``render_batch(workers=2)`` as a user calls it once: start-up included.
    The ``cpu`` rows are CPU seconds per frame of one batch, all processes
    counted (client, scheduler, workers).
    """
    import numba

    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.batch import ProcessPool, RunOptions, local_cluster, render_batch

    rows = []
    t0 = time.perf_counter()
    pool = ProcessPool(2, numba_threads=1).start()
    rows.append(dict(benchmark="startup", mode="processes", workers=2, numba_threads=1,
                     seconds=round(time.perf_counter() - t0, 3), load=_load(),
                     note="ProcessPool(2): 2 interpreters import raycast_shade"))
    t0 = time.perf_counter()
    with pool, local_cluster(2, numba_threads=1) as client:
        rows.append(dict(benchmark="startup", mode="dask", workers=2, numba_threads=1,
                         seconds=round(time.perf_counter() - t0, 3), load=_load(),
                         note="LocalCluster(2 processes) + Client"))
        for (w, h), frames in cases:
            scene = _scene(w, h)
            cams = orbit_cameras(scene.camera, frames)
            render_batch(scene, cams[:2], run=RunOptions(progress=False))  # JIT + BVH here
            for mode, run in (("processes", RunOptions(executor=pool, progress=False)),
                              ("dask", RunOptions(scheduler=client, progress=False))):
                first = _timed(lambda: render_batch(scene, cams[:4], run=run))
                rows.append(dict(benchmark="startup", mode=mode, workers=2, numba_threads=1, width=w, height=h,
                                 frames=4, seconds=round(first, 3), load=_load(),
                                 note="first batch of 4 frames: Numba cache loaded, BVH built on each worker"))
            variants = {"processes": lambda: render_batch(scene, cams, run=RunOptions(executor=pool, progress=False)),
                        "dask": lambda: render_batch(scene, cams, run=RunOptions(scheduler=client, progress=False)),
                        "processes, new pool": lambda: render_batch(scene, cams,
                                                                    run=RunOptions(workers=2, progress=False))}
            load = _load()
            times, ratios = _interleaved(lambda: render_batch(scene, cams, run=RunOptions(progress=False)), variants,
                                         repeats)
            load = f"{load}-{_load()}"
            rows.append(_row("serial", 0, numba.get_num_threads(), w, h, frames, times["serial"], 1.0,
                             "pool: this process", load=load))
            for name in variants:
                note = "pool: start-up included" if name.endswith("new pool") else "pool: steady state"
                rows.append(_row(name, 2, 1, w, h, frames, times[name], ratios[name], note, load=load))
            # The frames written as PNG files (an animation's batch): the pool's workers encode and
            # write in parallel, the serial batch in turn with its rendering.
            def written(run=RunOptions(progress=False)):
                with tempfile.TemporaryDirectory() as out:
                    render_batch(scene, cams, out_dir=out, run=run)

            load = _load()
            times, ratios = _interleaved(written, {"processes": lambda: written(RunOptions(executor=pool,
                                                                                           progress=False))}, repeats)
            load = f"{load}-{_load()}"
            rows.append(_row("serial, PNG files", 0, numba.get_num_threads(), w, h, frames, times["serial"], 1.0,
                             "pool: this process, out_dir", load=load))
            rows.append(_row("processes, PNG files", 2, 1, w, h, frames, times["processes"], ratios["processes"],
                             "pool: steady state, out_dir (written by the workers)", load=load))
            cpu = {}
            c0 = _cpu()
            render_batch(scene, cams, run=RunOptions(progress=False))
            cpu["serial"] = _cpu() - c0
            c0, p0 = _cpu(), _pool_cpu(pool)
            render_batch(scene, cams, run=RunOptions(executor=pool, progress=False))
            cpu["processes"] = _cpu() - c0 + _pool_cpu(pool) - p0
            c0, d0 = _cpu(), _worker_cpu(client)
            render_batch(scene, cams, run=RunOptions(scheduler=client, progress=False))
            cpu["dask"] = _cpu() - c0 + _worker_cpu(client) - d0
            for name, c in cpu.items():
                rows.append(dict(benchmark="cpu", mode=name, workers=0 if name == "serial" else 2, width=w, height=h,
                                 frames=frames, value=round(1e3 * c / frames, 3), unit="ms/frame", load=_load(),
                                 note="CPU per frame, every process of the batch"))
    return rows


def chart_pool(rows, path):
    """Speed-up over serial against frame size: the pool (steady, and with start-up) and Dask."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pool_rows = [r for r in rows if r["benchmark"] == "batch" and str(r.get("note", "")).startswith("pool:")
                 and r["mode"] != "serial"]
    if not pool_rows:
        return None
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=100)
    labels = {"processes": "process pool (steady state)", "processes, new pool": "process pool, start-up included",
              "dask": "Dask LocalCluster (steady state)",
              "processes, PNG files": "process pool writing PNG files (against serial writing them)"}
    sizes = sorted({(r["width"], r["height"]) for r in pool_rows})
    for i, (mode, label) in enumerate(labels.items()):
        pts = [next(r["speedup"] for r in pool_rows if r["mode"] == mode and (r["width"], r["height"]) == s)
               for s in sizes]
        ax.plot(range(len(sizes)), pts, "o-", color=f"C{i}", label=label)
        for x, y in enumerate(pts):
            ax.annotate(f"{y}x", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.axhline(1.0, color="0.5", lw=1, ls="--", label="this process, 2 Numba threads")
    ax.set_xticks(range(len(sizes)), [f"{w}x{h}" for w, h in sizes])
    ax.set_xlabel("frame size")
    ax.set_ylabel("speed-up over this process")
    loads = [r["load"] for r in pool_rows]
    ax.set_title(f"2 single-threaded workers on 2 cores, load {loads[0].split('-')[0]}-{loads[-1].split('-')[-1]}")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def bench_scaling(size, frames: int, repeats: int, counts):
    """Frames/s for 1..4 single-threaded workers, and 2 workers x 2 threads, each against serial."""
    import numba

    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.batch import RunOptions, local_cluster, render_batch

    w, h = size
    scene = _scene(w, h)
    cams = orbit_cameras(scene.camera, frames)
    render_batch(scene, cams[:2], run=RunOptions(progress=False))
    rows = []
    for n, threads in [(n, 1) for n in counts] + [(2, 2)]:
        with local_cluster(n, numba_threads=threads) as client:
            render_batch(scene, cams[:2 * n], run=RunOptions(scheduler=client, progress=False))  # warm every worker
            load = _load()
            times, ratios = _interleaved(lambda: render_batch(scene, cams, run=RunOptions(progress=False)),
                                         {"dask": lambda: render_batch(scene, cams, run=RunOptions(scheduler=client,
                                                                                                   progress=False))},
                                         repeats)
        over = " (oversubscribed)" if n * threads > len(os.sched_getaffinity(0)) else ""
        rows.append(_row("serial", 0, numba.get_num_threads(), w, h, frames, times["serial"], 1.0,
                         f"this process, next to {n}x{threads}", load=load))
        rows.append(_row("dask", n, threads, w, h, frames, times["dask"], ratios["dask"],
                         f"scaling: {n} workers x {threads} Numba threads{over}", "auto", "auto", load))
    return rows


def _cpu() -> float:
    t = os.times()
    return t.user + t.system


def _worker_cpu(client) -> float:
    return sum(client.run(_cpu).values())


def bench_cost(frames: int, repeats: int, size):
    """Per-task overhead, the CPU cost of a returned image per MB, and the bytes moved."""
    import numba

    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.batch import RunOptions, local_cluster, render_batch
    from raycast_shade.apps.batch.plan import plan_batch

    rows = []
    w, h = 16, 12
    scene = _scene(w, h)
    cams = orbit_cameras(scene.camera, frames)
    # One Numba thread on both sides: a parallel launch on a busy shared core stalls at its barrier,
    # which would be noise here, not Dask's cost.
    saved = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        render_batch(scene, cams[:2], run=RunOptions(progress=False))
        with local_cluster(1, numba_threads=1) as client:
            render_batch(scene, cams, run=RunOptions(scheduler=client, progress=False))
            for per_task in (1, 8):
                def dask_run(k=per_task):
                    return render_batch(scene, cams, run=RunOptions(scheduler=client, progress=False, per_task=k))

                c_client, c_worker = _cpu(), _worker_cpu(client)
                times, ratios = _interleaved(lambda: render_batch(scene, cams, run=RunOptions(progress=False)),
                                             {"dask": dask_run}, repeats)
                c_client, c_worker = _cpu() - c_client, _worker_cpu(client) - c_worker
                t_s, t_d = statistics.median(times["serial"]), statistics.median(times["dask"])
                tasks = repeats * frames / per_task
                if per_task == 1:
                    rows.append(_row("serial", 0, 1, w, h, frames, times["serial"], note="tiny frames"))
                rows.append(_row("dask", 1, 1, w, h, frames, times["dask"], ratios["dask"], "tiny frames",
                                 per_task, "auto", _load()))
                rows.append(dict(benchmark="overhead", mode="dask", workers=1, numba_threads=1,
                                 frames_per_task=per_task, width=w, height=h, frames=frames,
                                 ms_per_frame=round(1e3 * (t_d - t_s) / frames, 3), load=_load(),
                                 note="wall: (t_dask - t_serial) / frames"))
                # The client's CPU includes its serial repeats: subtract them (one thread, so CPU ~ wall).
                serial_cpu = sum(times["serial"])
                rows.append(dict(benchmark="overhead", mode="cpu client+scheduler", workers=1, frames_per_task=per_task,
                                 value=round(1e3 * (c_client - serial_cpu) / tasks, 3), unit="ms/task", load=_load(),
                                 note="CPU of this process (client and LocalCluster scheduler) per task"))
                rows.append(dict(benchmark="overhead", mode="cpu worker", workers=1, frames_per_task=per_task,
                                 value=round(1e3 * c_worker / tasks, 3),
                                 unit="ms/task", load=_load(),
                                 note="CPU of the worker process per task, rendering included (0.4 ms a frame)"))
    finally:
        numba.set_num_threads(saved)

    # A returned image's cost: the same frames through Dask's comms and through the folder.
    w, h = size
    scene = _scene(w, h)
    cams = orbit_cameras(scene.camera, max(8, frames // 16))
    n = len(cams)
    mb = w * h * 12 / 1e6
    with local_cluster(2, numba_threads=1) as client:
        render_batch(scene, cams[:4], run=RunOptions(scheduler=client, progress=False))
        cpu = {}
        for tr in ("dask", "disk"):
            c0, w0 = _cpu(), _worker_cpu(client)
            for _ in range(repeats):
                render_batch(scene, cams, run=RunOptions(scheduler=client, progress=False, transfer=tr))
            cpu[tr] = (_cpu() - c0, _worker_cpu(client) - w0)
        frames_done = repeats * n
        for side, i in (("client", 0), ("workers", 1)):
            for tr in ("dask", "disk"):
                rows.append(dict(benchmark="transfer", mode=f"cpu {side}", workers=2, transfer=tr, width=w, height=h,
                                 value=round(1e3 * cpu[tr][i] / frames_done, 3), unit="ms/frame", load=_load(),
                                 note=f"CPU per frame ({side}), rendering included on the workers"))
        extra = sum(cpu["dask"]) - sum(cpu["disk"])
        rows.append(dict(benchmark="transfer", mode="cpu per MB", workers=2, transfer="dask - disk", width=w,
                         height=h, value=round(1e3 * extra / frames_done / mb, 3), unit="ms/MB", load=_load(),
                         note=f"extra CPU of returning {mb:.2f} MB images through Dask rather than the folder"))

    # Bytes moved.
    bases, jobs = plan_batch(scene, cams)
    base = next(iter(bases.values()))
    rows += [dict(benchmark="bytes", mode="scene", value=len(pickle.dumps(base, protocol=5)), unit="B",
                  note="base scene, once per worker and mesh set (20,480 triangles, no geometry)"),
             dict(benchmark="bytes", mode="job", value=len(pickle.dumps(jobs[0], protocol=5)), unit="B",
                  note="one frame's job: camera, lights, colours"),
             dict(benchmark="bytes", mode="image", width=w, height=h, value=w * h * 12, unit="B",
                  note="float32 image back per frame (through Dask, or the folder on this machine)")]
    return rows


def chart(rows, path):
    """Frames/s against workers at the scaling size, serial as a band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scal = [r for r in rows if r["benchmark"] == "batch" and str(r.get("note", "")).startswith("scaling")]
    serial = [r["fps"] for r in rows if r["benchmark"] == "batch" and r["mode"] == "serial"
              and "next to" in str(r.get("note", ""))]
    if not scal:
        return None
    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=100)
    one = [r for r in scal if r["numba_threads"] == 1]
    ax.plot([r["workers"] for r in one], [r["fps"] for r in one], "o-", label="Dask workers x 1 Numba thread")
    for r in scal:
        if r["numba_threads"] == 2:
            ax.plot([r["workers"]], [r["fps"]], "s", color="C3", label="2 workers x 2 Numba threads")
    ax.axhspan(min(serial), max(serial), color="0.8", label="this process, 2 Numba threads (range)")
    for r in one:
        ax.annotate(f"{r['speedup']}x", (r["workers"], r["fps"]), textcoords="offset points", xytext=(4, -12))
    ax.set_xlabel("workers (2 cores: 3 and 4 oversubscribe)")
    ax.set_ylabel("frames/s")
    ax.set_xticks([r["workers"] for r in one])
    ax.set_ylim(bottom=0)
    ax.set_title(f"Batch of {one[0]['frames']} frames at {one[0]['width']}x{one[0]['height']}, load "
                 f"{min(r['load'] for r in scal)}-{max(r['load'] for r in scal)}")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def run(quick: bool = False, only: str | None = None):
    """Run the benchmark.

    Parameters
    ----------
    quick : bool
        Fewer and smaller frames, fewer repeats (about a minute on 2 cores).

    Returns
    -------
    list of dict
        One row per measurement (see ``FIELDS``).
    """
    if quick:
        cases, frames, repeats, tiny, scale = [(160, 120), (640, 480)], 24, 3, 96, [1, 2, 3]
        pool_cases = [((160, 120), 48), ((640, 480), 16)]
    else:
        cases, frames, repeats, tiny, scale = [(320, 240), (640, 480), (1280, 720)], 96, 5, 384, [1, 2, 3, 4]
        pool_cases = POOL_CASES
    if only == "pool":
        return bench_pool(pool_cases, repeats)
    return (bench_pool(pool_cases, repeats)
            + bench_throughput(cases, frames, repeats)
            + bench_scaling((640, 480), frames // 2 if not quick else frames, repeats, scale)
            + bench_cost(tiny, repeats, (640, 480)))


def outputs(quick: bool) -> list[str]:
    """The CSV and chart :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("batch.csv", quick), os.path.join(images_dir(quick), "batch_scaling.png"),
            os.path.join(images_dir(quick), "batch_pool.png"), results_file("batch_pool.csv", quick)]


def main(argv=None):
    """Command line: ``python -m benchmarks.bench_batch [--quick]``; returns the rows."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer, smaller frames and repeats")
    ap.add_argument("--only", choices=["pool"], help="only serial against the process pool and Dask "
                                                      "(writes batch_pool.csv)")
    args = ap.parse_args(argv)
    rows = run(args.quick, args.only)
    path, png, pool_png, pool_csv = outputs(args.quick)
    if args.only:
        path = pool_csv
    write_csv(path, rows, FIELDS)
    if not args.only:
        chart(rows, png)
    chart_pool(rows, pool_png)
    png = pool_png if args.only else png
    for r in rows:
        size = f"{r.get('width', '')}x{r.get('height', '')}" if r.get("width") else ""
        print(f"{r['benchmark']:9} {r['mode']:20} w={r.get('workers', '')!s:2} t={r.get('numba_threads', '')!s:2} "
              f"k={r.get('frames_per_task', '')!s:>4} {r.get('transfer', '')!s:6} {size:>9} "
              f"fps={r.get('fps', '')!s:>8} ms/f={r.get('ms_per_frame', '')!s:>7} x{r.get('speedup', '')!s:5} "
              f"{r.get('value', '')!s:>8} {r.get('unit', '')!s:7} load={r.get('load', '')} {r.get('note', '')}")
    print(f"wrote {os.path.relpath(path, ROOT)}, {os.path.relpath(png, ROOT)}")
    return rows


if __name__ == "__main__":
    main()
