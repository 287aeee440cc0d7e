"""Core benchmark: one Phong frame, stage by stage, against the baselines.

Run ``python -m benchmarks.bench_core [--quick]``. For each mesh (icosphere
with 81,920 and 1,310,720 triangles) and resolution (640x480, 1920x1080):

* ours: ray generation (stand-alone kernel; in the renderer it is fused into
  the cast), cast (rays + Embree packets + hit unpacking), shading, total;
* embreex ``run`` on one thread and on two Python threads over chunks, the
  cast alone (rays given);
* the naive pipeline: NumPy rays + embreex ``run`` (one thread) + NumPy
  shading (:mod:`raycast_shade.study.reference`);
* scene build: ours (shared buffers + BVH) against Embree's own BVH build
  (``rtcCommitScene``) and against embreex's ``TriangleMesh`` + commit.

Times are medians of repeats after a warm-up; JIT compile time and the start
of a fresh process with a warm cache are measured apart, in subprocesses.
Results: ``benchmarks/results/core.csv`` and ``docs/images/core_benchmark.png`` (in
``quick/`` subfolders with ``--quick``: :mod:`benchmarks.outputs`).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from benchmarks.outputs import image_file, results_file, write_csv


def _median_ms(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def _scene(subdivisions: int, width: int, height: int):
    import raycast_shade as rs

    return rs.Scene(
        [rs.Model(rs.shapes.icosphere(subdivisions), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
        lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")],
        camera=rs.Camera(eye=(0, 0, 3), width=width, height=height),
    )


def bench_frame(subdivisions: int, width: int, height: int, repeats: int, naive: bool):
    """Stage medians (ms) for one mesh and resolution."""
    import raycast_shade as rs
    from raycast_shade.shading.shade import shade
    from raycast_shade.study.twins import generate_rays_numpy
    from raycast_shade.visibility.accel import embreex_scene
    from raycast_shade.visibility.cast import cast_camera, run_embreex
    from raycast_shade.visibility.rays import generate_rays

    scene = _scene(subdivisions, width, height)
    geo = scene.geometry
    cam = scene.camera
    tri = len(geo.faces)
    rows = []

    def row(pipeline, stage, ms):
        rows.append(dict(benchmark="frame", mesh=f"icosphere{subdivisions}", triangles=tri, width=width,
                         height=height, pipeline=pipeline, stage=stage, median_ms=round(ms, 3)))

    rs.render(scene)  # warm-up: JIT, BVH
    rs.render(scene)
    row("raycast_shade", "raygen", _median_ms(lambda: generate_rays(cam, geo.origin), repeats))
    hits = cast_camera(geo, cam)
    row("raycast_shade", "cast", _median_ms(lambda: cast_camera(geo, cam), repeats))
    row("raycast_shade", "shade", _median_ms(lambda: shade(scene, cam, hits, "phong"), repeats))
    row("raycast_shade", "total", _median_ms(lambda: rs.render(scene), repeats))
    for mode in ("flat", "gouraud"):
        row("raycast_shade", f"total_{mode}", _median_ms(lambda: rs.render(scene, mode), repeats))

    origins, directions = generate_rays(cam, geo.origin)
    ex = embreex_scene(geo)
    run_embreex(ex, origins[:16], directions[:16], 1)  # commit outside the timing
    row("embreex", "cast_1thread", _median_ms(lambda: run_embreex(ex, origins, directions, 1), repeats))
    row("embreex", "cast_2threads", _median_ms(lambda: run_embreex(ex, origins, directions, 2), repeats))

    if naive:
        from raycast_shade.study.reference import shade_reference

        def naive_frame():
            o, d = generate_rays_numpy(cam, geo.origin)
            res = ex.run(o.astype(np.float32), d.astype(np.float32), output=1)
            miss = res["geomID"] < 0
            h = rs.HitBuffer(
                prim=np.where(miss, -1, res["primID"]).astype(np.int32).reshape(height, width),
                geom=np.where(miss, -1, res["geomID"]).astype(np.int32).reshape(height, width),
                u=np.where(miss, 0, res["u"]).astype(np.float32).reshape(height, width),
                v=np.where(miss, 0, res["v"]).astype(np.float32).reshape(height, width),
                t=np.where(miss, np.inf, res["tfar"]).astype(np.float32).reshape(height, width),
            )
            return shade_reference(scene, cam, h, "phong")

        row("naive", "total", _median_ms(naive_frame, max(2, repeats // 3)))
    return rows


def bench_build(subdivisions: int, repeats: int):
    """Scene build (ms): ours vs Embree's BVH build alone vs embreex's copy-in + commit."""
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    import raycast_shade as rs
    from raycast_shade.scene.scene import SceneGeometry
    from raycast_shade.visibility.accel import embree_accel

    mesh = rs.shapes.icosphere(subdivisions)
    model = rs.Model(mesh)
    mesh.prepared  # noqa: B018 - normals are the mesh's, not the build's
    tri = len(mesh.faces)
    ours, bvh = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        geo = SceneGeometry([model])
        acc = embree_accel(geo)
        ours.append(time.perf_counter() - t0)
        bvh.append(acc.build_seconds)
        del acc, geo
    ex = []
    v32 = mesh.vertices.astype(np.float32)
    f32 = mesh.faces.astype(np.int32)
    o = np.zeros((1, 3), np.float32)
    d = np.array([[0, 0, 1]], np.float32)
    for _ in range(max(1, repeats // 2)):
        t0 = time.perf_counter()
        sc = rtcore_scene.EmbreeScene()
        TriangleMesh(sc, v32, f32)
        sc.run(o, d)  # embreex commits lazily on the first run
        ex.append(time.perf_counter() - t0)
    base = dict(benchmark="build", mesh=f"icosphere{subdivisions}", triangles=tri, width=0, height=0)
    return [
        dict(base, pipeline="raycast_shade", stage="build_total", median_ms=round(1e3 * np.median(ours), 3)),
        dict(base, pipeline="embree", stage="bvh_build", median_ms=round(1e3 * np.median(bvh), 3)),
        dict(base, pipeline="embreex", stage="build_total", median_ms=round(1e3 * np.median(ex), 3)),
    ]


_CHILD = """
import time
t0 = time.perf_counter()
import raycast_shade as rs
from raycast_shade.visibility.accel import embree_accel, embreex_scene
t1 = time.perf_counter()
s = rs.Scene([rs.Model(rs.shapes.icosphere(3), rs.Material(ks=0.5))], lights=[rs.PointLight((2, 3, 4))],
             camera=rs.Camera(eye=(0, 0, 3), width=64, height=48))
for mode in ("flat", "gouraud", "phong"):
    rs.render(s, mode)
t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def bench_startup():
    """JIT compile time (cold cache) and the start of a fresh process (warm cache)."""
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold_cache", "warm_cache"):
            t0 = time.perf_counter()
            out = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, check=True)
            wall = time.perf_counter() - t0
            imp, first = (float(x) for x in out.stdout.split())
            base = dict(benchmark="startup", mesh="icosphere3", triangles=1280, width=64, height=48, pipeline=label)
            rows += [
                dict(base, stage="import_ms", median_ms=round(1e3 * imp, 1)),
                dict(base, stage="first_frames_3_modes_ms", median_ms=round(1e3 * first, 1)),
                dict(base, stage="process_wall_ms", median_ms=round(1e3 * wall, 1)),
            ]
    # The CLI demo as a user runs it (warm cache: run once, time the second).
    exe = os.path.join(os.path.dirname(sys.executable), "raycast-shade")
    if os.path.exists(exe):
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "demo.png")
            subprocess.run([exe, "demo", "-o", out], capture_output=True, check=True)
            times = []
            for _ in range(3):
                t0 = time.perf_counter()
                subprocess.run([exe, "demo", "-o", out], capture_output=True, check=True)
                times.append(time.perf_counter() - t0)
        rows.append(dict(benchmark="startup", mesh="demo", triangles=0, width=0, height=0, pipeline="cli",
                         stage="demo_warm_cache_ms", median_ms=round(1e3 * float(np.median(times)), 1)))
    return rows


def summarize(rows):
    """Ratios against the issue's targets, as extra rows."""
    out = []
    def get(**kw):
        for r in rows:
            if all(r.get(k) == v for k, v in kw.items()):
                return r["median_ms"]
        return None

    for r in rows:
        if r["benchmark"] == "frame" and r["pipeline"] == "raycast_shade" and r["stage"] == "total":
            key = dict(benchmark="frame", mesh=r["mesh"], width=r["width"], height=r["height"])
            two = get(**key, pipeline="embreex", stage="cast_2threads")
            naive = get(**key, pipeline="naive", stage="total")
            base = dict(r, pipeline="ratio")
            if two:
                out.append(dict(base, stage="total_over_embreex_2threads_cast", median_ms=round(r["median_ms"] / two, 3)))
            if naive:
                out.append(dict(base, stage="naive_over_total", median_ms=round(naive / r["median_ms"], 3)))
    for r in rows:
        if r["benchmark"] == "build" and r["pipeline"] == "raycast_shade":
            bvh = get(benchmark="build", mesh=r["mesh"], pipeline="embree", stage="bvh_build")
            ex = get(benchmark="build", mesh=r["mesh"], pipeline="embreex", stage="build_total")
            out.append(dict(r, pipeline="ratio", stage="build_over_bvh", median_ms=round(r["median_ms"] / bvh, 3)))
            out.append(dict(r, pipeline="ratio", stage="embreex_build_over_ours", median_ms=round(ex / r["median_ms"], 3)))
    return out


def chart(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frames = [r for r in rows if r["benchmark"] == "frame"]
    cases = sorted({(r["triangles"], r["width"], r["height"]) for r in frames})
    bars = [("raycast_shade", "total", "ours: Phong frame"), ("embreex", "cast_2threads", "embreex cast, 2 threads"),
            ("embreex", "cast_1thread", "embreex cast, 1 thread"), ("naive", "total", "naive NumPy+embreex frame")]
    fig, ax = plt.subplots(figsize=(9, 4.5))
    width = 0.8 / len(bars)
    for k, (pipe, stage, label) in enumerate(bars):
        vals = []
        for tri, w, h in cases:
            m = [r["median_ms"] for r in frames if (r["triangles"], r["width"], r["height"]) == (tri, w, h)
                 and r["pipeline"] == pipe and r["stage"] == stage]
            vals.append(m[0] if m else np.nan)
        ax.bar(np.arange(len(cases)) + k * width, vals, width, label=label)
    ax.set_xticks(np.arange(len(cases)) + 0.4 - width / 2)
    ax.set_xticklabels([f"{tri:,} tris\n{w}x{h}" for tri, w, h in cases])
    ax.set_ylabel("median ms per frame (log)")
    ax.set_yscale("log")
    ax.set_title("One Phong frame on 2 cores: ours (total) vs the cast alone of the baselines")
    ax.legend(fontsize=8)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(quick: bool = False):
    rows = []
    cases = [(6, 640, 480), (6, 1920, 1080), (8, 640, 480), (8, 1920, 1080)]
    if quick:
        cases = [(4, 320, 240), (6, 640, 480)]
    repeats = 5 if quick else 15
    for sub, w, h in cases:
        rows += bench_frame(sub, w, h, repeats, naive=True)
    rows += bench_build(5 if quick else 8, 3 if quick else 7)
    rows += bench_startup()
    rows += summarize(rows)
    return rows


KEYS = ["benchmark", "mesh", "triangles", "width", "height", "pipeline", "stage", "median_ms"]


def outputs(quick: bool) -> list[str]:
    """The CSV and the chart :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("core.csv", quick), image_file("core_benchmark.png", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes, few repeats")
    args = ap.parse_args(argv)
    rows = run(args.quick)
    csv_path, png_path = outputs(args.quick)
    write_csv(csv_path, rows, KEYS)
    chart(rows, png_path)
    for r in rows:
        print(f"{r['benchmark']:8} {r['mesh']:11} {r['width']:>5}x{r['height']:<5} {r['pipeline']:14} {r['stage']:34} {r['median_ms']:>10}")
    return rows


if __name__ == "__main__":
    main()
