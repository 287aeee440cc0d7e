"""Ray casting against z-buffer rasterization, same Phong shading.

A rasterizer's cost grows with the triangles (every one is projected, set up
and binned), a ray caster's with the pixels (one BVH descent each); this
script measures where they cross over.

For each icosphere (subdivisions 3..8: 1,280 to 1,310,720 triangles) and each
resolution (640x480, 1920x1080) it times, as the median of ``--repeats``
runs after a JIT warm-up:

* ``visibility``: ``cast_camera`` (Embree) or ``rasterize`` (the hit buffer);
* ``shade``: Phong shading of that hit buffer (the same kernel for both);
* ``build``: the Embree BVH build, once per mesh (the rasterizer needs none),
  which a one-shot frame pays and an animation amortises.

JIT compilation is timed apart: from scratch in a fresh interpreter with an
empty, temporary Numba cache (the project's cache is not touched), and the
first calls of this process (cache loads) before any timing. Results go to a
CSV and a two-panel log-log chart (visibility alone; the whole frame).

``--crossover`` measures instead where ``backend="auto"`` should switch: for
each resolution and two camera distances (the sphere filling much or little of
the frame), the triangle count where the rasterizer's hit buffer stops being
faster than Embree's (interleaved medians, the BVH built beforehand), divided
by the pixels the scene's bounding box covers
(:func:`raycast_shade.visibility.raster.covered_pixels`). A least-squares fit
(non-negative, relative error) of the crossovers to ``alpha * image pixels +
beta * covered pixels`` gives ``AUTO_FACES_PER_PIXEL = (alpha, beta)``; the cases go to
``raster_crossover.csv`` and to the table of ``docs/raster.md`` between its
``crossover`` markers (quick: under ``out/quick/``, no tracked file touched).

Usage::

    python benchmarks/bench_raster.py              # the full run (minutes)
    python benchmarks/bench_raster.py --quick      # small sizes, a smoke test
    python benchmarks/bench_raster.py --crossover  # backend="auto"'s threshold
    python benchmarks/bench_raster.py --stages     # the 82k-face frame's stages beside llvmpipe
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import raycast_shade as rs  # noqa: E402
from raycast_shade.visibility.accel import embree_accel  # noqa: E402
from raycast_shade.visibility.raster import rasterize  # noqa: E402
from raycast_shade.shading.shade import shade  # noqa: E402

from benchmarks.outputs import image_file, results_file  # noqa: E402

FULL_SUBDIVISIONS = (3, 4, 5, 6, 7, 8)
FULL_RESOLUTIONS = ((640, 480), (1920, 1080))
QUICK_SUBDIVISIONS = (2, 3, 4)
QUICK_RESOLUTIONS = ((160, 120), (320, 240))

FIELDS = ["subdivisions", "triangles", "width", "height", "method", "visibility_s", "shade_s", "frame_s",
          "build_s", "frame_with_build_s", "repeats", "threads", "compile_s", "shade_compile_s"]


def make_scene(subdivisions):
    mesh = rs.shapes.icosphere(subdivisions)
    material = rs.Material(kd=(0.8, 0.4, 0.2), ks=0.5, shininess=40.0)
    light = rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square")
    return rs.Scene([rs.Model(mesh, material)], lights=[light], ambient=0.05)


def make_camera(width, height):
    return rs.Camera(eye=(0.3, 0.5, 3.0), target=(0.0, 0.0, 0.0), width=width, height=height, fov=45.0)


def median_time(fn, repeats):
    times = []
    out = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def warm_up():
    """First calls on a tiny scene: JIT compilation or cache load, timed apart."""
    scene = make_scene(1)
    camera = make_camera(32, 24)
    geo = scene.geometry
    embree_accel(geo)  # Embree itself is not JIT-compiled
    first = {}
    for name, fn in (("raycast", lambda: rs.cast_camera(geo, camera)), ("raster", lambda: rasterize(geo, camera))):
        t0 = time.perf_counter()
        hits = fn()
        first[name] = time.perf_counter() - t0
        t0 = time.perf_counter()
        fn()
        first[name] -= time.perf_counter() - t0
    t0 = time.perf_counter()
    shade(scene, camera, hits, "phong")
    first["shade"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    shade(scene, camera, hits, "phong")
    first["shade"] -= time.perf_counter() - t0
    return first


_COLD = """
import json, sys, time
sys.path.insert(0, {root!r})
t0 = time.perf_counter()
import raycast_shade as rs
from raycast_shade.visibility.raster import rasterize
from raycast_shade.shading.shade import shade
out = {{"import": time.perf_counter() - t0}}
scene = rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=[rs.PointLight((2.0, 3.0, 4.0))])
camera = rs.Camera(eye=(0.3, 0.5, 3.0), width=32, height=24)
embree_accel(scene.geometry)
for name, fn in (("raycast", lambda: rs.cast_camera(scene.geometry, camera)),
                 ("raster", lambda: rasterize(scene.geometry, camera))):
    t0 = time.perf_counter()
    hits = fn()
    out[name] = time.perf_counter() - t0
t0 = time.perf_counter()
shade(scene, camera, hits, "phong")
out["shade"] = time.perf_counter() - t0
print(json.dumps(out))
"""


def cold_compile():
    """JIT compile times from scratch: a fresh interpreter with an empty,
    temporary Numba cache (the project's cache is left alone)."""
    import json
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
        res = subprocess.run([sys.executable, "-c", _COLD.format(root=str(ROOT))], env=env, capture_output=True,
                             text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def run(subdivisions, resolutions, repeats, log=print):
    import numba

    threads = numba.get_num_threads()
    rows = []
    for sub in subdivisions:
        scene = make_scene(sub)
        geo = scene.geometry
        t0 = time.perf_counter()
        embree_accel(geo)  # the BVH, built once per mesh
        build = time.perf_counter() - t0
        ntri = len(geo.faces)
        for width, height in resolutions:
            camera = make_camera(width, height)
            for method, fn in (("raycast", lambda: rs.cast_camera(geo, camera)),
                               ("raster", lambda: rasterize(geo, camera))):
                fn()  # first call at this size: page in the buffers
                vis, hits = median_time(fn, repeats)
                sh, _ = median_time(lambda: shade(scene, camera, hits, "phong"), repeats)
                b = build if method == "raycast" else 0.0
                rows.append(dict(subdivisions=sub, triangles=ntri, width=width, height=height, method=method,
                                 visibility_s=vis, shade_s=sh, frame_s=vis + sh, build_s=b,
                                 frame_with_build_s=vis + sh + b, repeats=repeats, threads=threads))
                log(f"  {ntri:>9,d} tris {width}x{height} {method:8s} visibility {vis * 1e3:8.2f} ms"
                    f"  shade {sh * 1e3:7.2f} ms  build {b * 1e3:7.2f} ms")
    return rows


def crossovers(rows, key="frame_s"):
    """Triangle counts where the rasterizer stops winning, per resolution
    (log-log interpolation between the measured sizes); None if it never
    crosses in the range."""
    out = {}
    for res in sorted({(r["width"], r["height"]) for r in rows}):
        sel = [r for r in rows if (r["width"], r["height"]) == res]
        tris = sorted({r["triangles"] for r in sel})
        ratio = []
        for n in tris:
            rc = next(r[key] for r in sel if r["triangles"] == n and r["method"] == "raycast")
            ra = next(r[key] for r in sel if r["triangles"] == n and r["method"] == "raster")
            ratio.append(np.log(ra / rc))
        out[res] = None
        for i in range(len(tris) - 1):
            if ratio[i] < 0 <= ratio[i + 1]:
                a, b = np.log(tris[i]), np.log(tris[i + 1])
                out[res] = float(np.exp(a + (b - a) * (-ratio[i]) / (ratio[i + 1] - ratio[i])))
                break
    return out


def write_csv(rows, path):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS, restval="")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def plot(rows, path, first_calls=None, title_note=""):
    """Two log-log panels: visibility alone, and the whole frame."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 2, figsize=(12.0, 5.2), dpi=110)
    colours = {"raycast": "tab:blue", "raster": "tab:red"}
    styles = ["-", "--", ":", "-."]
    resolutions = sorted({(r["width"], r["height"]) for r in rows}, key=lambda wh: wh[0] * wh[1])
    for ax, key, label in ((axes[0], "visibility_s", "visibility only (hit buffer), ms"),
                           (axes[1], "frame_s", "frame: visibility + Phong shading, ms")):
        for k, res in enumerate(resolutions):
            ls = styles[k % len(styles)]
            for method in ("raycast", "raster"):
                sel = sorted((r for r in rows if (r["width"], r["height"]) == res and r["method"] == method),
                             key=lambda r: r["triangles"])
                x = [r["triangles"] for r in sel]
                ax.plot(x, [r[key] * 1e3 for r in sel], ls, marker="o", ms=4, color=colours[method],
                        label=f"{method} {res[0]}x{res[1]}")
                if method == "raycast":
                    ax.plot(x, [(r[key] + r["build_s"]) * 1e3 for r in sel], ls, color=colours[method],
                            alpha=0.35, lw=1, label=f"raycast + BVH build {res[0]}x{res[1]}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        fmt = FuncFormatter(lambda v, _: f"{v:g}")
        ax.yaxis.set_major_formatter(fmt)
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:,.0f}"))
        bottom = ax.get_ylim()[0]
        cross = crossovers(rows, key)
        for k, res in enumerate(resolutions):
            if cross.get(res):
                ax.axvline(cross[res], color="grey", ls=styles[k % len(styles)], lw=0.8)
                ax.annotate(f"crossover {res[0]}x{res[1]}\n~{cross[res]:,.0f} triangles", (cross[res], bottom),
                            xytext=(4, 8 + 26 * k), textcoords="offset points", fontsize=7, color="dimgrey")
        ax.set_xlabel("triangles (icosphere)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7, ncol=2)
    note = ""
    if first_calls:
        note = "; JIT compile apart: " + ", ".join(f"{k} {v:.1f} s" for k, v in first_calls.items())
    threads = rows[0]["threads"] if rows else "?"
    fig.suptitle(f"Ray casting (Embree) vs z-buffer rasterization{title_note}: median of repeats after warm-up, "
                 f"{threads} threads{note}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def outputs(quick: bool) -> list[str]:
    """The CSV and the chart :func:`main` writes by default (see :mod:`benchmarks.outputs`)."""
    return [results_file("raster_vs_raycast.csv", quick), image_file("raster_vs_raycast.png", quick)]


STAGE_CASES = ((6, 640, 480), (6, 1920, 1080))  # icosphere(6): 81,920 faces, the frame
QUICK_STAGE_CASES = ((4, 320, 240),)
STAGE_FIELDS = ["triangles", "width", "height", "stage", "median_ms", "over_llvmpipe", "repeats", "threads", "load1"]


def stage_rows(cases, repeats, log=print):
    """Where the rasterized Phong frame's time goes, beside Mesa's llvmpipe frame of the same scene
    (``bench_peers``' pipeline: draw plus read-back of the linear image), all timed interleaved in
    this process: medians of ``repeats`` after two warm-up rounds, and each over llvmpipe's.

    Stages: ``project``, ``setup``, ``bin``, ``scan_resolve`` (``rasterize``'s own clock:
    :func:`raycast_shade.visibility.raster._run`'s ``stages``); ``resolve_alone``, the resolve re-run
    serially on the frame's winners (one thread: its share of ``scan_resolve`` is about half of
    it on two); ``raster``, the whole hit buffer; ``shade`` (Phong, the kernels both back ends share);
    ``store_srgb``, ``rs.to_uint8`` of the image (``frame.save``'s, not in llvmpipe's frame);
    ``frame_raster`` and ``frame_raycast``, ``rs.render(scene, "phong", backend=...)``; ``llvmpipe``.
    """
    import numba

    from benchmarks import bench_peers
    from raycast_shade.visibility import raster as raster_mod
    from raycast_shade.visibility.raster_band import _resolve_rows

    ctx = bench_peers.llvmpipe_context()
    rows = []
    for sub, width, height in cases:
        load = os.getloadavg()[0]
        scene = bench_peers.make_scene(bench_peers.make_mesh("icosphere", sub), width, height)
        geo, camera = scene.geometry, scene.camera
        embree_accel(geo)
        near = raster_mod.NEAR_FRACTION * geo.scale
        hits = rasterize(geo, camera)
        image = rs.render(scene, "phong", backend="raster").image
        fid = np.where(hits.prim >= 0, geo.face_offsets[np.maximum(hits.geom, 0)] + hits.prim, -1).astype(np.int32)
        right, up, fwd = camera.basis
        hw, hh = camera.half_extents()
        cs = (geo.vertices - (camera.eye - geo.origin)) @ np.stack([right, up, fwd]).T
        out = tuple(np.empty((height, width), dt) for dt in (np.int32, np.int32, np.float32, np.float32, np.float32))
        screen = (False, float(width), float(height), hw, hh)
        band = (fid, np.full((height, width), np.inf), *_columns(width, hw))
        faces = np.ascontiguousarray(geo.faces, np.int64)
        model = np.ascontiguousarray(geo.face_model, np.int32)
        offsets = np.ascontiguousarray(geo.face_offsets, np.int64)
        stages = {}
        fns = {"raster": lambda: raster_mod._run(geo, camera, near, False, None, stages),
               "resolve_alone": lambda: _resolve_rows((fid.copy(), *band[1:]), 0, faces, cs, model, offsets, screen,
                                                      (0.0, 0.0), out),
               "shade": lambda: shade(scene, camera, hits, "phong"),
               "store_srgb": lambda: rs.to_uint8(image),
               "frame_raster": lambda: rs.render(scene, "phong", backend="raster"),
               "frame_raycast": lambda: rs.render(scene, "phong")}
        if not isinstance(ctx, str):
            fns["llvmpipe"] = bench_peers.llvmpipe_pipeline(ctx, scene, camera)[1]
        else:
            log(f"  llvmpipe skipped: {ctx}")
        for _ in range(2):
            for fn in fns.values():
                fn()
        times = {k: [] for k in (*fns, "project", "setup", "bin", "scan_resolve")}
        names = list(fns)
        for r in range(repeats):
            for name in names[r % len(names):] + names[:r % len(names)]:
                t0 = time.perf_counter()
                fns[name]()
                times[name].append(time.perf_counter() - t0)
                if name == "raster":
                    for k, key in (("project", "project"), ("setup", "setup"), ("bin", "bin"),
                                   ("scan_resolve", "scan")):
                        times[k].append(stages[key])
        load = f"{load:.1f}-{os.getloadavg()[0]:.1f}"
        med = {k: 1e3 * float(np.median(v)) for k, v in times.items()}
        gl = med.get("llvmpipe", math.nan)
        for name, ms in med.items():
            rows.append(dict(triangles=len(geo.faces), width=width, height=height, stage=name, median_ms=round(ms, 3),
                             over_llvmpipe=round(ms / gl, 3), repeats=repeats, threads=numba.get_num_threads(),
                             load1=load))
        log(f"  {len(geo.faces):,d} faces {width}x{height} (load {load}): "
            + ", ".join(f"{k} {v:.1f} ms ({v / gl:.2f}x)" for k, v in med.items()))
    return rows


def _columns(width, hw):
    """The resolve's per-column ray terms (raster_band._columns), without intrinsics."""
    from raycast_shade.visibility.raster_band import _columns as columns

    return columns(float(width), hw, 0.0)


CROSS_SUBDIVISIONS = (3, 4, 5, 6, 7, 8)
CROSS_RESOLUTIONS = ((640, 480), (1920, 1080))
CROSS_DISTANCES = (3.0, 9.0)  # eye distance from the unit sphere's centre: it fills much, or little
QUICK_CROSS_SUBDIVISIONS = (2, 3, 4, 5)
QUICK_CROSS_RESOLUTIONS = ((160, 120), (320, 240))
CROSS_FIELDS = ["width", "height", "distance", "covered_pixels", "triangles", "raycast_s", "raster_s", "repeats",
                "crossover_triangles", "load1"]
CROSS_BEGIN, CROSS_END = "<!-- crossover table: begin (bench_raster.py --crossover) -->", "<!-- crossover table: end -->"


def crossover_rows(subdivisions, resolutions, repeats, log=print):
    """One row per (resolution, distance, mesh): both hit buffers' medians, timed interleaved,
    and per (resolution, distance) the crossover (on every row of the case)."""
    from raycast_shade.visibility.raster import covered_pixels

    scenes = [make_scene(sub) for sub in subdivisions]
    for sc in scenes:
        embree_accel(sc.geometry)  # built beforehand: an animation's frames reuse it
    rows = []
    for width, height in resolutions:
        for dist in CROSS_DISTANCES:
            eye = np.array([0.3, 0.5, 3.0]) * dist / np.linalg.norm([0.3, 0.5, 3.0])
            camera = rs.Camera(eye=eye, target=(0.0, 0.0, 0.0), width=width, height=height, fov=45.0)
            case = []
            for sc in scenes:
                geo = sc.geometry
                fns = {"raycast": lambda: rs.cast_camera(geo, camera), "raster": lambda: rasterize(geo, camera)}
                times = {k: [] for k in fns}
                for fn in fns.values():
                    fn()
                for r in range(repeats):
                    for k in (("raycast", "raster") if r % 2 == 0 else ("raster", "raycast")):
                        t0 = time.perf_counter()
                        fns[k]()
                        times[k].append(time.perf_counter() - t0)
                row = dict(width=width, height=height, distance=dist, covered_pixels=covered_pixels(geo, camera),
                           triangles=len(geo.faces), raycast_s=float(np.median(times["raycast"])),
                           raster_s=float(np.median(times["raster"])), repeats=repeats,
                           load1=round(os.getloadavg()[0], 2))
                log(f"  {width}x{height} d={dist:g} {row['triangles']:>9,d} tris: raycast {row['raycast_s'] * 1e3:8.2f}"
                    f" ms, raster {row['raster_s'] * 1e3:8.2f} ms (covered {row['covered_pixels']:,d} px)")
                case.append(row)
            cross = _crossing([r["triangles"] for r in case], [np.log(r["raster_s"] / r["raycast_s"]) for r in case])
            for r in case:
                r["crossover_triangles"] = cross
            rows += case
    return rows


def _crossing(tris, log_ratio):
    """The triangle count where ``log_ratio`` (raster over raycast) first turns >= 0, by log-log
    interpolation; None when the rasterizer wins (or loses) everywhere measured."""
    for i in range(len(tris) - 1):
        if log_ratio[i] < 0 <= log_ratio[i + 1]:
            a, b = np.log(tris[i]), np.log(tris[i + 1])
            return float(np.exp(a + (b - a) * (-log_ratio[i]) / (log_ratio[i + 1] - log_ratio[i])))
    return None


def fitted_faces_per_pixel(rows):
    """``(alpha, beta)``, 2 significant digits each: the non-negative least-squares fit (relative
    error) of the cases' crossovers to ``alpha * width * height + beta * covered_pixels``; None
    when no case crosses within its meshes."""
    from scipy.optimize import nnls

    cases = {(r["width"], r["height"], r["distance"]): r for r in rows if r["crossover_triangles"]}
    if not cases:
        return None
    a = np.array([[r["width"] * r["height"], r["covered_pixels"]] for r in cases.values()], float)
    f = np.array([r["crossover_triangles"] for r in cases.values()])
    coef, _ = nnls(a / f[:, None], np.ones(len(f)))
    return tuple(float(f"{c:.2g}") for c in coef)


def crossover_table(rows):
    """The markdown table of the cases (written between docs/raster.md's crossover markers)."""
    fit = fitted_faces_per_pixel(rows)
    lines = ["| image | eye distance | covered pixels | crossover (faces) | the fit's threshold | load |",
             "|---|---|---|---|---|---|"]
    seen = set()
    for r in rows:
        key = (r["width"], r["height"], r["distance"])
        if key in seen:
            continue
        seen.add(key)
        cross = f"{r['crossover_triangles']:,.0f}" if r["crossover_triangles"] else "not in the measured range"
        fpp = f"{fit[0] * r['width'] * r['height'] + fit[1] * r['covered_pixels']:,.0f}" if fit else "-"
        loads = [x["load1"] for x in rows if (x["width"], x["height"], x["distance"]) == key]
        lines.append(f"| {r['width']}x{r['height']} | {r['distance']:g} | {r['covered_pixels']:,d} | {cross} | {fpp} "
                     f"| {min(loads):.1f}-{max(loads):.1f} |")
    lines.append("")
    lines.append(f"Fit: rasterize while faces <= **{fit[0] if fit else '-'}** x image pixels + **{fit[1] if fit else '-'}"
                 f"** x covered pixels (`AUTO_FACES_PER_PIXEL`); meshes of "
                 f"{min(r['triangles'] for r in rows):,d} to {max(r['triangles'] for r in rows):,d} triangles, "
                 f"{rows[0]['repeats']} interleaved repeats, load average as in the last column (2 cores).")
    return "\n".join(lines) + "\n"


def write_crossover(rows, quick):
    """CSV and the docs table; quick mode writes both under out/quick/ only."""
    from benchmarks.outputs import page_file

    csv_path = Path(results_file("raster_crossover.csv", quick))
    csv_path.parent.mkdir(parents=True, exist_ok=True)
    with open(csv_path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=CROSS_FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else ("" if v is None else v)) for k, v in r.items()})
    page = Path(page_file("raster.md", quick))
    table = crossover_table(rows)
    if quick:
        page.parent.mkdir(parents=True, exist_ok=True)
        page.write_text(table, encoding="utf-8")
    else:
        text = page.read_text(encoding="utf-8")
        start, stop = text.index(CROSS_BEGIN) + len(CROSS_BEGIN), text.index(CROSS_END)
        page.write_text(text[:start] + "\n" + table + text[stop:], encoding="utf-8")
    return csv_path, page


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small meshes and images only (a smoke test)")
    ap.add_argument("--compile", action="store_true", help="measure cold JIT compile times in --quick mode too")
    ap.add_argument("--no-compile", action="store_true", help="skip the cold JIT compile measurement")
    ap.add_argument("--repeats", type=int, default=None, help="timed runs per point (default 7, quick 3)")
    ap.add_argument("--csv", default=None, help="output CSV (default benchmarks/results/[quick/]raster_vs_raycast.csv)")
    ap.add_argument("--png", default=None, help="output chart (default docs/images/[quick/]raster_vs_raycast.png)")
    ap.add_argument("--crossover", action="store_true", help="measure backend='auto''s threshold instead")
    ap.add_argument("--stages", action="store_true",
                    help="where the rasterized frame's time goes at 82k faces, beside llvmpipe, instead")
    args = ap.parse_args(argv)
    if args.stages:
        warm_up()
        rows = stage_rows(QUICK_STAGE_CASES if args.quick else STAGE_CASES, args.repeats or (3 if args.quick else 9))
        path = Path(results_file("raster_stages.csv", args.quick))
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=STAGE_FIELDS)
            w.writeheader()
            w.writerows(rows)
        print(f"wrote {os.path.relpath(path)}")
        return
    if args.crossover:
        warm_up()
        rows = crossover_rows(QUICK_CROSS_SUBDIVISIONS if args.quick else CROSS_SUBDIVISIONS,
                              QUICK_CROSS_RESOLUTIONS if args.quick else CROSS_RESOLUTIONS,
                              args.repeats or (3 if args.quick else 7))
        paths = write_crossover(rows, args.quick)
        print(f"AUTO_FACES_PER_PIXEL (image, covered) fitted: {fitted_faces_per_pixel(rows)}; wrote "
              + " and ".join(os.path.relpath(p) for p in paths))
        return
    default_csv, default_png = outputs(args.quick)
    csv_path = Path(args.csv or default_csv)
    png_path = Path(args.png or default_png)
    repeats = args.repeats or (3 if args.quick else 7)
    if repeats < 1:
        ap.error("--repeats: must be >= 1")
    subs = QUICK_SUBDIVISIONS if args.quick else FULL_SUBDIVISIONS
    resolutions = QUICK_RESOLUTIONS if args.quick else FULL_RESOLUTIONS
    if args.compile or (not args.quick and not args.no_compile):
        cold = cold_compile()
        print("JIT compile from scratch (fresh process, empty cache): "
              + ", ".join(f"{k} {v:.1f} s" for k, v in cold.items() if k != "import"))
    else:
        cold = None
    warm = warm_up()
    print("first calls in this process (cache load), apart from the timings: "
          + ", ".join(f"{k} {v:.2f} s" for k, v in warm.items()))
    first = {k: v for k, v in cold.items() if k != "import"} if cold else None
    rows = run(subs, resolutions, repeats)
    if cold:
        for r in rows:
            r["compile_s"] = cold[r["method"]]
            r["shade_compile_s"] = cold["shade"]
    write_csv(rows, csv_path)
    plot(rows, png_path, first, " (quick)" if args.quick else "")
    for res, n in crossovers(rows).items():
        where = f"~{n:,.0f} triangles" if n else "not within the measured range"
        print(f"crossover at {res[0]}x{res[1]}: {where}")
    print(f"wrote {os.path.relpath(csv_path)} and {os.path.relpath(png_path)}")


if __name__ == "__main__":
    main()
