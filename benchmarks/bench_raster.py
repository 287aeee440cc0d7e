"""Ray casting against z-buffer rasterization, beside Mesa's llvmpipe and Embree's packet floor.

A rasterizer's cost grows with the triangles (every one is projected, set up
and binned), a ray caster's with the pixels (one BVH descent each); this
script measures where they cross over, and where both stand against
llvmpipe and against the floor of any Embree-path frame.

The default run times, interleaved round by round in one process (medians
of ``--repeats`` rounds after two warm-up rounds), on ``bench_peers``'
icosphere Phong scene: the Embree frame (``rs.render(scene, "phong")``), the
raster frame (``backend="raster"``), the raw Embree 16-ray packets plus the
preallocated store (``bench_limits.packet_floor``: the floor of any
Embree-path frame), llvmpipe's frame of the same scene (``bench_peers``'
pipeline; skipped with a note without an EGL context), the two hit buffers
alone, and the BVH build once per case; (a) against triangles (icosphere
subdivisions 3..8 at 640x480 and 1920x1080) and (b) against pixels (81,920
triangles, 320x240 to 3840x2160). Open3D is never loaded here: its OpenMP
threads spin after each call and slow the next pipeline (``bench_limits``'
``openmp`` section). JIT compilation is timed apart, in a fresh interpreter
with an empty, temporary Numba cache. Results: ``raster_vs_raycast.csv``, a
two-panel log-log chart (frame time against triangles and against pixels),
the table between docs/raster.md's ``frame table`` markers and the floor's
verdicts on issue 41's targets between docs/performance.md's ``raster
floor`` markers. ``--replot`` redraws the chart and those blocks from the
CSV; ``--cases`` times the given cases only (a spot check, written where a
quick run writes).

``--crossover`` measures instead where ``backend="auto"`` should switch: for
each resolution and two camera distances (the sphere filling much or little of
the frame), the triangle count where the rasterized Phong frame stops being
faster than Embree's (``rs.render(..., backend=)``, interleaved medians, the
BVH built beforehand), and the pixels the scene's bounding box covers
(:func:`raycast_shade.visibility.raster.covered_pixels`). A least-squares fit
(non-negative, relative error) of the crossovers to ``alpha * image pixels +
beta * covered pixels`` gives ``AUTO_FACES_PER_PIXEL = (alpha, beta)`` (set in
the code by hand; a test holds the two equal); the cases go to
``raster_crossover.csv`` and to the table of ``docs/raster.md`` between its
``crossover`` markers (quick: under ``out/quick/``, no tracked file touched).

Usage::

    python benchmarks/bench_raster.py              # the full run (minutes)
    python benchmarks/bench_raster.py --quick      # small sizes, a smoke test
    python benchmarks/bench_raster.py --cases 6:1920x1080   # a spot check, into out/quick/
    python benchmarks/bench_raster.py --replot     # chart and docs' blocks from the CSV
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

# (a) frame time against triangles: icospheres at two image sizes; (b) against pixels: 81,920 faces.
FULL_SUBDIVISIONS = (3, 4, 5, 6, 7, 8)
FULL_RESOLUTIONS = ((640, 480), (1920, 1080))
FULL_PIXEL_SUBDIVISION = 6
FULL_PIXEL_RESOLUTIONS = ((320, 240), (640, 480), (1280, 720), (1920, 1080), (2560, 1440), (3840, 2160))
QUICK_SUBDIVISIONS = (2, 3, 4)
QUICK_RESOLUTIONS = ((160, 120), (320, 240))
QUICK_PIXEL_SUBDIVISION = 3
QUICK_PIXEL_RESOLUTIONS = ((80, 60), (160, 120), (320, 240))

# Timed interleaved, round by round: the two visibility paths' frames, Embree's floor, llvmpipe's
# frame, and the two hit buffers alone. ``bvh_build`` is timed once per case, apart.
METHODS = ("frame_embree", "frame_raster", "packets_floor", "llvmpipe", "visibility_embree", "visibility_raster")
LABELS = {"frame_embree": "Embree frame", "frame_raster": "raster frame",
          "packets_floor": "Embree packets + store (floor)", "llvmpipe": "Mesa llvmpipe frame"}
COLOURS = {"frame_embree": "tab:blue", "frame_raster": "tab:red", "packets_floor": "dimgrey", "llvmpipe": "tab:orange"}
FIELDS = ["subdivisions", "triangles", "width", "height", "pixels", "sweep", "method", "median_ms", "min_ms",
          "over_llvmpipe", "repeats", "threads", "load1", "utc", "machine", "compile_s", "note"]
# Issue 41, item 2: the Embree frame over llvmpipe's, at most (the icosphere cases of these sizes).
TARGETS = {(81920, 640, 480): 0.45, (81920, 1920, 1080): 0.75, (1310720, 640, 480): 0.3,
           (1310720, 1920, 1080): 0.3}
FRAME_BEGIN = "<!-- frame table: begin (bench_raster.py) -->"
FRAME_END = "<!-- frame table: end -->"
FLOOR_BEGIN = "<!-- raster floor: begin (bench_raster.py) -->"
FLOOR_END = "<!-- raster floor: end -->"


def make_scene(subdivisions):
    """The crossover's scene (no camera: each case brings its own)."""
    mesh = rs.shapes.icosphere(subdivisions)
    material = rs.Material(kd=(0.8, 0.4, 0.2), ks=0.5, shininess=40.0)
    light = rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square")
    return rs.Scene([rs.Model(mesh, material)], lights=[light], ambient=0.05)


def make_camera(width, height):
    return rs.Camera(eye=(0.3, 0.5, 3.0), target=(0.0, 0.0, 0.0), width=width, height=height, fov=45.0)


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
from raycast_shade.visibility.accel import embree_accel
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


def machine():
    """The CPU's model name, its widest vector ISA and its cores, for the CSV and the chart."""
    model, flags = "unknown CPU", set()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                if key.strip() == "model name":
                    model = " ".join(value.split()).replace("(R)", "")
                elif key.strip() == "flags":
                    flags = set(value.split())
                    break
    except OSError:
        pass
    isa = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "no AVX2"
    return f"{model}, {isa}, {os.cpu_count()} cores"


def frame_cases(quick):
    """``(subdivisions, width, height, sweep)`` once each: ``sweep`` is ``"triangles"``,
    ``"pixels"`` or ``"both"`` (the chart's panels the case belongs to)."""
    subs, res = (QUICK_SUBDIVISIONS, QUICK_RESOLUTIONS) if quick else (FULL_SUBDIVISIONS, FULL_RESOLUTIONS)
    psub, pres = (QUICK_PIXEL_SUBDIVISION, QUICK_PIXEL_RESOLUTIONS) if quick else (FULL_PIXEL_SUBDIVISION,
                                                                                   FULL_PIXEL_RESOLUTIONS)
    tri = [(s, w, h) for s in subs for w, h in res]
    pix = [(psub, w, h) for w, h in pres]
    out = [(s, w, h, "both" if (s, w, h) in pix else "triangles") for s, w, h in tri]
    return out + [(s, w, h, "pixels") for s, w, h in pix if (s, w, h) not in tri]


def frame_case(sub, width, height, repeats, ctx, log=print):
    """Rows (``FIELDS``) of one case of ``bench_peers``' icosphere scene: ``METHODS`` timed
    interleaved (each round starts one further along), medians and minima of ``repeats`` rounds
    after two warm-up rounds, each over llvmpipe's median; and the BVH build (once, first)."""
    import numba

    from benchmarks import bench_limits, bench_peers

    load0 = os.getloadavg()[0]
    scene = bench_peers.make_scene(bench_peers.make_mesh("icosphere", sub), width, height)
    geo, camera = scene.geometry, scene.camera
    t0 = time.perf_counter()
    embree_accel(geo)
    build = time.perf_counter() - t0
    restore, trace, store, packet_hits = bench_limits.packet_floor(geo, camera)

    def floor():
        trace()
        store()

    fns = {"frame_embree": lambda: rs.render(scene, "phong"),
           "frame_raster": lambda: rs.render(scene, "phong", backend="raster"),
           "packets_floor": floor,
           "visibility_embree": lambda: rs.cast_camera(geo, camera),
           "visibility_raster": lambda: rasterize(geo, camera)}
    note = ""
    if isinstance(ctx, str):
        note = f"llvmpipe skipped: {ctx}"
    else:
        fns["llvmpipe"] = bench_peers.llvmpipe_pipeline(ctx, scene, camera)[1]
    names = [m for m in METHODS if m in fns]
    for _ in range(2):  # warm-up: JIT or cache load, page faults, llvmpipe's shader variant
        for name in names:
            restore()
            fns[name]()
    times = {name: [] for name in names}
    for r in range(repeats):
        for name in names[r % len(names):] + names[:r % len(names)]:
            if name == "packets_floor":
                restore()  # untimed: a traced packet's tfar is its hit
            t0 = time.perf_counter()
            fns[name]()
            times[name].append(time.perf_counter() - t0)
    restore()
    trace()
    frame_hits, floor_hits = int(rs.render(scene, "phong").mask.sum()), packet_hits()
    if floor_hits != frame_hits:  # the floor traces the frame's own rays: the same pixels must hit
        note = (note + "; " if note else "") + f"packets hit {floor_hits} pixels, the frame {frame_hits}"
    load = f"{load0:.1f}-{os.getloadavg()[0]:.1f}"
    med = {k: 1e3 * float(np.median(v)) for k, v in times.items()}
    gl = med.get("llvmpipe", math.nan)
    base = dict(subdivisions=sub, triangles=len(geo.faces), width=width, height=height, pixels=width * height,
                repeats=repeats, threads=numba.get_num_threads(), load1=load,
                utc=time.strftime("%Y-%m-%d %H:%M", time.gmtime()), machine=machine(), note=note)
    rows = [dict(base, method=name, median_ms=round(med[name], 3), min_ms=round(1e3 * min(times[name]), 3),
                 over_llvmpipe=round(med[name] / gl, 3)) for name in names]
    rows.append(dict(base, method="bvh_build", median_ms=round(1e3 * build, 3), min_ms=round(1e3 * build, 3),
                     over_llvmpipe=round(1e3 * build / gl, 3), repeats=1))
    log(f"  {len(geo.faces):>9,d} tris {width}x{height} (load {load}): "
        + ", ".join(f"{k} {v:.1f} ms ({v / gl:.2f}x)" for k, v in med.items()) + (f" [{note}]" if note else ""))
    return rows


def run(cases, repeats, log=print):
    """Rows of every case of :func:`frame_cases`, llvmpipe on one headless context (none: a note)."""
    from benchmarks import bench_peers

    ctx = bench_peers.llvmpipe_context()
    if isinstance(ctx, str):
        log(f"  llvmpipe skipped: {ctx}")
    rows = []
    for sub, width, height, sweep in cases:
        rows += [dict(r, sweep=sweep) for r in frame_case(sub, width, height, repeats, ctx, log)]
    # Open3D's OpenMP threads spin after each call and slow the next pipeline (bench_limits' openmp section).
    assert "open3d" not in sys.modules, "bench_raster must not load Open3D"
    return rows


def _value(rows, triangles, width, height, method):
    """``median_ms`` of one row, NaN if it was not measured."""
    for r in rows:
        if (int(r["triangles"]), int(r["width"]), int(r["height"]), r["method"]) == (triangles, width, height, method):
            return float(r["median_ms"])
    return math.nan


def _sizes(rows, sweep):
    """``(triangles, width, height)`` of the cases in one sweep (``"both"`` belongs to each)."""
    keys = {(int(r["triangles"]), int(r["width"]), int(r["height"])) for r in rows if r["sweep"] in (sweep, "both")}
    return sorted(keys, key=lambda k: (k[1] * k[2], k[0]))


def crossovers(rows, a="frame_embree", b="frame_raster"):
    """Per image size of the triangle sweep, the triangle count where ``b`` stops being faster than
    ``a`` (log-log interpolation between the measured meshes); None if it does not cross there."""
    out = {}
    sizes = _sizes(rows, "triangles")
    for res in sorted({(w, h) for _, w, h in sizes}, key=lambda wh: wh[0] * wh[1]):
        tris = sorted(t for t, w, h in sizes if (w, h) == res)
        out[res] = _crossing(tris, [np.log(_value(rows, t, *res, b) / _value(rows, t, *res, a)) for t in tris])
    return out


def frame_table(rows):
    """The markdown table of every case (docs/raster.md, between the ``frame table`` markers)."""
    ms = lambda v: "-" if math.isnan(v) else (f"{v:.1f} ms" if v < 100 else f"{v:,.0f} ms")  # noqa: E731
    x = lambda v: "-" if math.isnan(v) else f"{v:.2f}x"  # noqa: E731
    lines = ["| faces | image | Embree frame | raster frame | packets + store | llvmpipe | Embree / llvmpipe "
             "| raster / llvmpipe | floor / llvmpipe | hit buffer: Embree, raster | BVH build | load |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    keys = sorted({(int(r["triangles"]), int(r["width"]), int(r["height"])) for r in rows},
                  key=lambda k: (k[1] * k[2], k[0]))
    for t, w, h in keys:
        v = {m: _value(rows, t, w, h, m) for m in (*METHODS, "bvh_build")}
        gl = v["llvmpipe"]
        load = next(r["load1"] for r in rows if (int(r["triangles"]), int(r["width"]), int(r["height"])) == (t, w, h))
        lines.append(f"| {t:,d} | {w}x{h} | {ms(v['frame_embree'])} | {ms(v['frame_raster'])} | "
                     f"{ms(v['packets_floor'])} | {ms(gl)} | {x(v['frame_embree'] / gl)} | {x(v['frame_raster'] / gl)} "
                     f"| {x(v['packets_floor'] / gl)} | {ms(v['visibility_embree'])}, {ms(v['visibility_raster'])} "
                     f"| {ms(v['bvh_build'])} | {load} |")
    r0 = rows[0]
    lines += ["", f"`benchmarks/results/raster_vs_raycast.csv`, {r0['utc']} UTC, {r0['machine']}, {r0['threads']} "
                  f"threads: medians of {r0['repeats']} interleaved rounds after two warm-up rounds; load average "
                  "(1 minute) before and after each case in the last column."]
    return "\n".join(lines) + "\n"


def floor_text(rows):
    """What the Embree floor leaves of issue 41's targets, case by case (docs/performance.md,
    between the ``raster floor`` markers): a sentence per measured target case."""
    out = []
    for (t, w, h), target in TARGETS.items():
        gl, floor = _value(rows, t, w, h, "llvmpipe"), _value(rows, t, w, h, "packets_floor")
        embree, raster = _value(rows, t, w, h, "frame_embree"), _value(rows, t, w, h, "frame_raster")
        if math.isnan(gl) or math.isnan(floor):
            continue
        f = floor / gl
        verdict = (f"at or above the target of {target:.2f}x: the Embree path cannot reach it here, whatever its "
                   "shading costs" if f >= target else
                   f"under the target of {target:.2f}x: the Embree path has {target - f:.2f}x of llvmpipe's frame "
                   "for all it does beyond the packets")
        out.append(f"- {t:,d} faces, {w}x{h}: the packets and the store take {floor:.1f} ms, **{f:.2f}x** llvmpipe's "
                   f"{gl:.1f} ms, {verdict}; the Embree frame is {embree / gl:.2f}x, the raster frame "
                   f"{raster / gl:.2f}x.")
    if not out:
        return "_No target case (or no llvmpipe) in this run._\n"
    r0 = rows[0]
    out.append(f"\n(`bench_raster.py`, {r0['utc']} UTC, {r0['machine']}, load {r0['load1']} at its first case.)")
    return "\n".join(out) + "\n"


def write_csv(rows, path):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS, restval="")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def plot(rows, path, title_note=""):
    """Two log-log panels of the frame time: against triangles (both image sizes) and against
    pixels (the pixel sweep's mesh); lines for ``LABELS``' four pipelines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, NullLocator

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, (left, right) = plt.subplots(1, 2, figsize=(13.5, 6.0), dpi=110)
    tri_sizes = _sizes(rows, "triangles")
    styles = {0: ("-", "o"), 1: ("--", "s"), 2: (":", "^")}
    for k, res in enumerate(sorted({(w, h) for _, w, h in tri_sizes}, key=lambda wh: wh[0] * wh[1])):
        ls, mk = styles[k % 3]
        tris = sorted(t for t, w, h in tri_sizes if (w, h) == res)
        for m, label in LABELS.items():
            y = [_value(rows, t, *res, m) for t in tris]
            if not all(math.isnan(v) for v in y):
                left.plot(tris, y, ls, marker=mk, ms=4, color=COLOURS[m], label=f"{label}, {res[0]}x{res[1]}")
    left.set_xlabel("triangles (icosphere)")
    left.set_title("against triangles", fontsize=10)
    pix_sizes = _sizes(rows, "pixels")
    if pix_sizes:
        tri = pix_sizes[0][0]
        px = [w * h for _, w, h in pix_sizes]
        for m, label in LABELS.items():
            y = [_value(rows, tri, w, h, m) for _, w, h in pix_sizes]
            if not all(math.isnan(v) for v in y):
                right.plot(px, y, "-", marker="o", ms=4, color=COLOURS[m], label=label)
        gl = [_value(rows, tri, w, h, "llvmpipe") for _, w, h in pix_sizes]
        if not all(math.isnan(v) for v in gl):
            right.plot(px, [0.75 * v for v in gl], ":", color=COLOURS["llvmpipe"], lw=1,
                       label="0.75x llvmpipe (issue 41's target at 1080p)")
        right.set_xlabel("pixels (image size)")
        right.set_title(f"against pixels, {tri:,d} triangles", fontsize=10)
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if f"{v:.0e}"[0] in "25" else ""))
        ax.set_ylabel("frame time, ms (median)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7.5, loc="upper left")
    if pix_sizes:  # after the log scale, which would replace them
        right.set_xticks(px, [f"{w}x{h}" for _, w, h in pix_sizes], rotation=30, fontsize=8)
        right.xaxis.set_minor_locator(NullLocator())
    all_tris = sorted({t for t, _, _ in tri_sizes})
    if all_tris:  # the measured meshes, after the log scale (which would replace them)
        left.set_xticks(all_tris, [f"{t:,d}" for t in all_tris], rotation=30, fontsize=8)
        left.xaxis.set_minor_locator(NullLocator())
    r0 = rows[0] if rows else {}
    loads = [float(x) for r in rows for x in str(r.get("load1", "nan")).split("-")]
    fig.suptitle(f"Phong frame of bench_peers' icosphere scene{title_note}: median of {r0.get('repeats', '?')} "
                 f"interleaved rounds after warm-up\n{r0.get('machine', '?')}, {r0.get('threads', '?')} threads, "
                 f"{r0.get('utc', '?')} UTC, load average {min(loads):.1f}-{max(loads):.1f}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def outputs(quick: bool) -> list[str]:
    """The files :func:`main` writes by default (see :mod:`benchmarks.outputs`): the CSV, the chart,
    and the docs' generated blocks (quick: alone, under out/quick/results/)."""
    from benchmarks.outputs import page_file

    if quick:
        docs = [results_file("raster_frame_table.md", True), results_file("raster_floor.md", True)]
    else:
        docs = [page_file("raster.md", False), page_file("performance.md", False)]
    return [results_file("raster_vs_raycast.csv", quick), image_file("raster_vs_raycast.png", quick), *docs]


def write_docs(rows, quick):
    """The frame table into docs/raster.md and the floor's verdicts into docs/performance.md,
    between their markers (quick: each alone under out/quick/results/); returns the paths."""
    from benchmarks.outputs import write_table

    table, floor = frame_table(rows), floor_text(rows)
    paths = [write_table(floor, "raster_floor.md", FLOOR_BEGIN, FLOOR_END, quick)]
    if quick:
        path = Path(results_file("raster_frame_table.md", True))
        path.write_text(table, encoding="utf-8")
    else:
        from benchmarks.outputs import page_file

        path = Path(page_file("raster.md", False))
        text = path.read_text(encoding="utf-8")
        start, stop = text.index(FRAME_BEGIN) + len(FRAME_BEGIN), text.index(FRAME_END)
        path.write_text(text[:start] + "\n" + table + text[stop:], encoding="utf-8")
    return [path, *paths]


STAGE_CASES = ((6, 640, 480), (6, 1920, 1080))  # icosphere(6): 81,920 faces, the frame
QUICK_STAGE_CASES = ((4, 320, 240),)
STAGE_FIELDS = ["triangles", "width", "height", "stage", "median_ms", "over_llvmpipe", "repeats", "threads", "load1"]
STAGE_BEGIN, STAGE_END = "<!-- stage table: begin (bench_raster.py --stages) -->", "<!-- stage table: end -->"
# The table's lines: a stage of raster_stages.csv and what it is.
STAGE_LINES = (("project", "project (vertices)"), ("setup", "set-up"), ("bin", "binning"),
               ("scan_resolve", "scan and resolve"), ("raster", "the hit buffer, all stages"),
               ("resolve_alone", "the resolve alone, serially (one thread; about half of it is in scan and resolve on two)"),
               ("shade", "Phong shading of it (shared with the Embree path)"),
               ("frame_raster", 'the whole frame, `render(backend="raster")`'),
               ("frame_raycast", "the whole frame, `render()` (Embree)"),
               ("store_srgb", "sRGB store (`rs.to_uint8`, not in llvmpipe's frame)"))


def stage_table(rows):
    """The markdown table of ``raster_stages.csv``'s rows: a line per stage, a column per image size,
    each cell the stage's time over llvmpipe's frame and its milliseconds (docs/raster.md, between the
    ``stage table`` markers)."""
    sizes = sorted({(int(r["width"]), int(r["height"])) for r in rows}, key=lambda s: s[0] * s[1])
    cell = {(r["stage"], int(r["width"]), int(r["height"])): r for r in rows}
    out = ["| stage | " + " | ".join(f"{w}x{h}" for w, h in sizes) + " |", "|---" * (len(sizes) + 1) + "|"]
    for key, label in STAGE_LINES:
        cells = []
        for w, h in sizes:
            r = cell.get((key, w, h))
            cells.append("-" if r is None else f"{float(r['over_llvmpipe']):.2f}x ({float(r['median_ms']):.1f} ms)")
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    gl = [cell[("llvmpipe", w, h)] for w, h in sizes if ("llvmpipe", w, h) in cell]
    if gl:
        out.append("| llvmpipe's frame (the unit) | " + " | ".join(f"{float(r['median_ms']):.1f} ms" for r in gl) + " |")
    loads = ", ".join(sorted({r["load1"] for r in rows}))
    return "\n".join(out) + f"\n\nMedians of {rows[0]['repeats']} interleaved rounds, {rows[0]['threads']} threads, load average {loads}.\n"


def write_stage_table(rows, quick):
    """:func:`stage_table` between docs/raster.md's markers (quick: alone, under out/quick/results/)."""
    table = stage_table(rows)
    if quick:
        path = Path(results_file("raster_stage_table.md", True))
        path.write_text(table, encoding="utf-8")
        return path
    from benchmarks.outputs import page_file

    path = Path(page_file("raster.md", False))
    text = path.read_text(encoding="utf-8")
    start, stop = text.index(STAGE_BEGIN) + len(STAGE_BEGIN), text.index(STAGE_END)
    path.write_text(text[:start] + "\n" + table + text[stop:], encoding="utf-8")
    return path


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
    from raycast_shade.visibility.raster_band import _resolve_rows, resolve_scratch

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
        band = (fid, np.full((height, width), np.inf), *_columns(width, hw), *resolve_scratch())
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
CROSS_FIELDS = ["width", "height", "distance", "covered_pixels", "triangles", "raycast_frame_s", "raster_frame_s",
                "repeats", "crossover_triangles", "load1"]
CROSS_BEGIN, CROSS_END = "<!-- crossover table: begin (bench_raster.py --crossover) -->", "<!-- crossover table: end -->"


def crossover_rows(subdivisions, resolutions, repeats, log=print):
    """One row per (resolution, distance, mesh): both back ends' Phong frames (``rs.render(...,
    backend=)``: what ``backend="auto"`` chooses between), medians timed interleaved, and per
    (resolution, distance) the crossover (on every row of the case)."""
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
                fns = {b: (lambda b=b, sc=sc: rs.render(sc, "phong", camera=camera, backend=b))
                       for b in ("raycast", "raster")}
                times = {k: [] for k in fns}
                for fn in fns.values():
                    fn()
                for r in range(repeats):
                    for k in (("raycast", "raster") if r % 2 == 0 else ("raster", "raycast")):
                        t0 = time.perf_counter()
                        fns[k]()
                        times[k].append(time.perf_counter() - t0)
                row = dict(width=width, height=height, distance=dist, covered_pixels=covered_pixels(geo, camera),
                           triangles=len(geo.faces), raycast_frame_s=float(np.median(times["raycast"])),
                           raster_frame_s=float(np.median(times["raster"])), repeats=repeats,
                           load1=round(os.getloadavg()[0], 2))
                log(f"  {width}x{height} d={dist:g} {row['triangles']:>9,d} tris: frames raycast "
                    f"{row['raycast_frame_s'] * 1e3:8.2f} ms, raster {row['raster_frame_s'] * 1e3:8.2f} ms "
                    f"(covered {row['covered_pixels']:,d} px)")
                case.append(row)
            cross = _crossing([r["triangles"] for r in case],
                              [np.log(r["raster_frame_s"] / r["raycast_frame_s"]) for r in case])
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
    ap.add_argument("--cases", default=None,
                    help="a spot check of these cases only, e.g. 6:1920x1080,8:640x480 (written under out/quick/)")
    ap.add_argument("--replot", action="store_true",
                    help="redraw the chart and the docs' generated blocks from the CSV, measuring nothing")
    args = ap.parse_args(argv)
    if args.stages:
        path = Path(results_file("raster_stages.csv", args.quick))
        if args.replot:  # the docs' stage table again from the CSV, nothing measured
            with open(path, newline="") as fh:
                print(f"wrote {os.path.relpath(write_stage_table(list(csv.DictReader(fh)), args.quick))}")
            return
        warm_up()
        rows = stage_rows(QUICK_STAGE_CASES if args.quick else STAGE_CASES, args.repeats or (3 if args.quick else 9))
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=STAGE_FIELDS)
            w.writeheader()
            w.writerows(rows)
        print(f"wrote {os.path.relpath(path)}, {os.path.relpath(write_stage_table(rows, args.quick))}")
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
    spot = _spot_cases(ap, args.cases) if args.cases else None
    quick = args.quick or spot is not None  # a spot check writes only where a quick run does
    default_csv, default_png, *_ = outputs(quick)
    csv_path = Path(args.csv or default_csv)
    png_path = Path(args.png or default_png)
    if args.replot:  # the chart and the docs' blocks again from the CSV, nothing measured
        rows = read_csv(csv_path)
        plot(rows, png_path, " (quick)" if quick else "")
        paths = write_docs(rows, quick)
        print("wrote " + ", ".join(os.path.relpath(p) for p in (png_path, *paths)))
        return
    repeats = args.repeats or (3 if args.quick else 7)
    if repeats < 1:
        ap.error("--repeats: must be >= 1")
    if args.compile or (not quick and not args.no_compile):
        cold = cold_compile()
        print("JIT compile from scratch (fresh process, empty cache): "
              + ", ".join(f"{k} {v:.1f} s" for k, v in cold.items() if k != "import"))
    else:
        cold = None
    warm = warm_up()
    print("first calls in this process (cache load), apart from the timings: "
          + ", ".join(f"{k} {v:.2f} s" for k, v in warm.items()))
    rows = run(spot or frame_cases(args.quick), repeats)
    if cold:
        for r in rows:
            r["compile_s"] = {"visibility_embree": cold["raycast"], "visibility_raster": cold["raster"]}.get(r["method"], "")
    write_csv(rows, csv_path)
    plot(rows, png_path, " (quick)" if args.quick else " (spot check)" if spot else "")
    paths = write_docs(rows, quick)
    for res, n in crossovers(rows).items():
        where = f"~{n:,.0f} triangles" if n else "not within the measured range"
        print(f"frames cross over at {res[0]}x{res[1]}: {where}")
    print("wrote " + ", ".join(os.path.relpath(p) for p in (csv_path, png_path, *paths)))


def _spot_cases(ap, text):
    """``--cases "6:1920x1080,8:640x480"`` as :func:`frame_cases`' tuples (one line, exit 2 if malformed)."""
    out = []
    for item in text.split(","):
        try:
            sub, size = item.split(":")
            w, h = size.lower().split("x")
            out.append((int(sub), int(w), int(h), "both"))
        except ValueError:
            ap.error(f"--cases: expected SUBDIVISIONS:WIDTHxHEIGHT[,...], got {item!r}")
        if not (0 <= out[-1][0] <= 9 and out[-1][1] > 0 and out[-1][2] > 0):
            ap.error(f"--cases: subdivisions 0..9 and positive sizes, got {item!r}")
    return out

if __name__ == "__main__":
    main()
