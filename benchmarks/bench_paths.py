"""Every path against the plain frame (issue 27's table): buffers, writers and view sets as ratios.

Run ``python -m benchmarks.bench_paths [--quick]``. For each mesh (an
icosphere of 81,920 triangles and the noisy sphere of 1,310,720 of
:mod:`benchmarks.bench_peers`) and size (640x480, 1920x1080), every path is
timed in turn, round after round, in one process (so a change of load
touches them all alike), after one warm-up round; each path's median is
divided by the plain Phong frame's median:

* ``frame``: ``render(scene)``, the plain Phong frame (the unit);
* ``buffers_all``: the 12 buffers of :data:`~raycast_shade.output.buffers.BUFFER_NAMES`
  but ``coverage``; ``position``; ``view_default``: ``zdepth, normal, id, mask``
  (the view sets' default), each the whole ``render`` call;
* ``buffers_all_reused``: the 12 buffers written into an earlier frame's arrays
  (``render(buffers_out=...)``): no fresh pages;
* ``alloc_all``, ``alloc_view_default``: the bytes of the output arrays of those two
  sets as one fresh block, filled once: the page-fault floor no kernel removes (fresh
  memory is what costs: the OS zeroes each page, ~5-8 ms for 50 MB with huge pages);
  the frame plus ``alloc_view_default`` is the view-set default's floor;
* ``store_all``: the bytes of the 12 buffers stored once into one warm block (allocated
  and faulted in before the rounds): the frame plus it is ``buffers_all_reused``'s floor;
* ``write_floor``: the bytes of the 12 buffers and the image in one plain
  ``open().write()``, the least any writer of them can take on this disk;
* ``npz_plain``, ``npz_level1``, ``npz_level6``, ``exr``, ``exr_zip``,
  ``exr_zstd``: writing the 12 buffers and the image
  (:func:`~raycast_shade.output.bufferfile.save_npz` stored, deflated at
  level 1 (ISA-L) and 6 (zlib), on threads;
  :func:`~raycast_shade.output.bufferfile.write_exr` uncompressed,
  ZIP and ZSTD on OpenEXR's threads), the write alone; their sizes in MiB;
* ``view_npz``, ``view_npz_zip``, ``view_npz_exr_png``:
  :func:`~raycast_shade.apps.views.render_views` of three orbiting cameras,
  per view, with the default buffers and files (PNG image, npz) stored and
  with ``compression="zip"`` (the default where ISA-L is installed), and
  with npz, EXR and a depth PNG (zip): render and files (each view's files
  written while the next renders); their sizes: one view's files;
* ``view_floor``: one view's files of ``view_npz_zip`` (PNG, npz, record)
  in one plain ``open().write()``, the least writing them can take here.
* ``flat``, ``gouraud``: the frame flat- and Gouraud-shaded; ``samples4``:
  four rays per pixel; ``samples4_coverage``: the same with ``coverage`` and
  the view-set default buffers.
* ``terms``, ``terms_flat``, ``terms_gouraud``, ``shadows``, ``mirror``, ``explain``:
  ``render(terms=True)`` (Phong, flat, Gouraud: compare the last two with the ``flat`` and
  ``gouraud`` rows), the light casting shadows, the mesh a mirror with one bounce, and one
  ``frame.explain(x, y)`` of a rendered frame (its milliseconds in the table too)
  (:func:`_teaching_paths`); ``terms_floor``: ``np.empty`` + fill of the arrays the terms
  write, their page-fault floor;

Each path's median minor page faults and system CPU per call go beside its time (``faults``,
``sys_ms``), and into a second table for the paths that fault more than :data:`KERNEL_FAULTS`
times a call: on this machine (a Firecracker VM whose guest hands free 8 MiB blocks back to
the host, ``page_reporting_order=11``) the same faults cost many times more in one round than in
the next, which is what moves the ratios of the paths that write fresh memory.

Peak memory of a frame without and with all 12 buffers (``peak_frame``,
``peak_buffers_all``, in the ``size_MiB`` column) is measured in a fresh
subprocess each: how far the resident set peaks above its level before the
frame (Linux's ``VmHWM``, reset through ``/proc/self/clear_refs``), with glibc's mmap threshold
fixed (``MALLOC_MMAP_THRESHOLD_``) so that every large array is mapped fresh rather than served
from heap that building the mesh freed.

Results: ``benchmarks/results/paths.csv``, the chart ``docs/images/paths.png``
and the table between the ``paths`` markers of ``docs/performance.md``
(``--table`` redoes the table alone from the CSV). ``--quick`` runs one small
case and writes into the git-ignored ``out/quick/`` (the table to
``out/quick/results/paths.md``; :mod:`benchmarks.outputs`).
"""

from __future__ import annotations

import argparse
import csv
import glob
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

from benchmarks import outputs as where
from benchmarks.outputs import ROOT, image_file, results_file, write_csv

FIELDS = ["mesh", "triangles", "width", "height", "path", "median_ms", "ratio", "size_MiB", "repeats", "note",
          "faults", "sys_ms"]
CASES = [("icosphere", 6, 640, 480), ("icosphere", 6, 1920, 1080), ("noisy_sphere", 8, 640, 480),
         ("noisy_sphere", 8, 1920, 1080)]
QUICK_CASES = [("icosphere", 4, 320, 240)]
ALL = ("depth", "zdepth", "position", "normal", "normal_camera", "face_normal", "face_normal_camera",
       "barycentric", "model_id", "triangle_id", "mask", "semantic_id")
VIEW_DEFAULT = ("zdepth", "normal", "id", "mask")
VIEWS = 3  # cameras per timed view set


def outputs(quick: bool = False) -> list:
    return [results_file("paths.csv", quick), image_file("paths.png", quick)] + (
        [results_file("paths.md", True)] if quick else [os.path.join(ROOT, "docs", "performance.md")])


def _paths(scene, tmp):
    """name -> (callable, file or None, divisor): every timed path of one case (its time / divisor)."""
    import raycast_shade as rs

    full = rs.render(scene, buffers=ALL)
    return {
        "frame": (lambda: rs.render(scene), None, 1),
        "buffers_all": (lambda: rs.render(scene, buffers=ALL), None, 1),
        "position": (lambda: rs.render(scene, buffers=("position",)), None, 1),
        "view_default": (lambda: rs.render(scene, buffers=VIEW_DEFAULT), None, 1),
        "buffers_all_reused": (lambda: rs.render(scene, buffers=ALL, buffers_out=full.buffers), None, 1),
        "alloc_all": (lambda: _alloc(ALL, scene.camera), None, 1),
        "alloc_view_default": (lambda: _alloc(VIEW_DEFAULT, scene.camera), None, 1),
        "store_all": (_store(ALL, scene.camera), None, 1),
        **_writer_paths(full, tmp),
        **_view_paths(scene, tmp),
        **_band_paths(scene),
    }


def _alloc(names, camera):
    """The bytes of the output arrays ``render(buffers=names)`` makes, as one fresh block, filled
    once: the page faults (the OS zeroing each new page) and one write, which no buffer kernel
    avoids. (The arrays one after another, each freed before the next, measure less: glibc
    serves each from heap pages the one before freed, already faulted; a block of 32 MiB or more
    is always a new mapping.)"""
    import numpy as np

    from raycast_shade.output.buffers import buffer_bytes

    np.empty(buffer_bytes(names) * camera.height * camera.width, np.uint8).fill(0)


def _store(names, camera):
    """One plain store (``fill``) of the bytes of the output arrays ``render(buffers=names)`` makes,
    into one block allocated and faulted in here, before the rounds: the least a kernel writing
    them into reused arrays (``buffers_out=``) takes."""
    import numpy as np

    from raycast_shade.output.buffers import buffer_bytes

    block = np.zeros(buffer_bytes(names) * camera.height * camera.width, np.uint8)
    return lambda: block.fill(0)


def _writer_paths(full, tmp):
    """The writers of the 12 buffers and the image, and the floor: the same bytes in one plain write."""
    import numpy as np

    from raycast_shade.output.bufferfile import save_npz, write_exr

    b, img, cam = full.buffers, full.image, full.camera
    f = lambda name: os.path.join(tmp, name)  # noqa: E731
    blob = b"".join(np.ascontiguousarray(a).tobytes() for a in [*b.values(), img])

    def floor():
        with open(f("floor.bin"), "wb") as fh:
            fh.write(blob)

    return {
        "write_floor": (floor, f("floor.bin"), 1),
        "npz_plain": (lambda: save_npz(f("p.npz"), b, image=img, camera=cam, compressed=False), f("p.npz"), 1),
        "npz_level1": (lambda: save_npz(f("z1.npz"), b, image=img, camera=cam, compressed=1), f("z1.npz"), 1),
        "npz_level6": (lambda: save_npz(f("z6.npz"), b, image=img, camera=cam, compressed=6), f("z6.npz"), 1),
        "exr": (lambda: write_exr(f("v.exr"), b, image=img), f("v.exr"), 1),
        "exr_zip": (lambda: write_exr(f("z.exr"), b, image=img, compression="zip"), f("z.exr"), 1),
        "exr_zstd": (lambda: write_exr(f("s.exr"), b, image=img, compression="zstd"), f("s.exr"), 1),
    }


def _view_paths(scene, tmp, views: int = VIEWS):
    """render_views over ``views`` orbiting cameras (so each view's writing overlaps the next render),
    timed per view: the default files (PNG + npz), with compression="zip", and with npz, EXR, depth PNG;
    and ``view_floor``: the bytes of one view's files of the default set (PNG, zipped npz, record) in
    one plain write. Each view row's file is its first view's files (their size: one view's)."""
    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.views import RunOptions, ViewFiles, render_views

    cams = orbit_cameras(scene.camera, views)

    def view(name, **kw):
        folder = os.path.join(tmp, name)
        files, again = ViewFiles(**kw), RunOptions(resume=False)
        run = lambda: render_views(scene, cams, folder, files=files, run=again, overwrite=True)  # noqa: E731
        return run, os.path.join(folder, "view_00000*"), views

    blob = []

    def floor():
        if not blob:  # the first call (the warm-up round) reads what view_npz_zip wrote
            files = sorted(glob.glob(os.path.join(tmp, "zip", "view_00000*")))
            blob.append(b"".join(open(f, "rb").read() for f in files))
        with open(os.path.join(tmp, "view_floor.bin"), "wb") as fh:
            fh.write(blob[0])

    return {
        "view_npz": view("none", compression="none"),
        "view_npz_zip": view("zip", compression="zip"),
        "view_npz_exr_png": view("all", formats=("npz", "exr", "depth_png"), compression="zip"),
        "view_floor": (floor, os.path.join(tmp, "view_floor.bin"), 1),
    }


def _band_paths(scene):
    """The banded path's other frames (issue 27: flat and Gouraud banded like Phong, ``samples=N``
    at most N frames + 10%): name -> (callable, None, 1)."""
    import raycast_shade as rs

    return {"flat": (lambda: rs.render(scene, "flat"), None, 1),
            "gouraud": (lambda: rs.render(scene, "gouraud"), None, 1),
            "samples4": (lambda: rs.render(scene, samples=4), None, 1),
            "samples4_coverage": (lambda: rs.render(scene, samples=4, buffers=("coverage",) + VIEW_DEFAULT), None, 1)}


def _teaching_paths(scene):
    """name -> (callable, None, 1): the teaching and lighting paths of one case (issue 27's last rows).

    ``terms`` renders the terms too; ``shadows`` the scene with its light casting shadows;
    ``mirror`` the mesh as a mirror (reflectivity 0.5) with one bounce; ``explain`` one
    ``frame.explain(x, y)`` on an already rendered plain frame (banded at 1080p: it casts the
    pixel's packet rows, not the frame), cycling over nine pixels across the image."""
    import dataclasses

    import raycast_shade as rs

    shadows = scene.replace(lights=[dataclasses.replace(light, shadows=True) for light in scene.lights])
    mirror = scene.replace(models=[rs.Model(m.mesh, dataclasses.replace(m.material, reflectivity=0.5))
                                   for m in scene.models])
    frame = rs.render(scene)
    w, h = frame.camera.width, frame.camera.height
    pixels = [(w * i // 4, h * j // 4) for i in (1, 2, 3) for j in (1, 2, 3)]
    turn = iter(range(1 << 62))

    def explain():
        x, y = pixels[next(turn) % len(pixels)]
        frame.explain(x, y)

    return {
        "terms": (lambda: rs.render(scene, terms=True), None, 1),
        "terms_flat": (lambda: rs.render(scene, "flat", terms=True), None, 1),
        "terms_gouraud": (lambda: rs.render(scene, "gouraud", terms=True), None, 1),
        "terms_floor": (_terms_floor(scene), None, 1),
        "shadows": (lambda: rs.render(shadows), None, 1),
        "mirror": (lambda: rs.render(mirror, max_depth=1), None, 1),
        "explain": (explain, None, 1),
    }


def _terms_floor(scene):
    """The fresh pages a ``terms=True`` frame writes beyond the plain frame's, and nothing else:
    ``np.empty`` + fill of the ambient, diffuse and specular images, one light's shadow mask
    and ``keep``, all alive at once as on the frame (the page-fault floor of the terms;
    emissive, background and reflected are zeros nobody touches in this scene). Each freed
    before the next is made would measure a fifth of it at 1080p: glibc serves the next from
    the pages the last one freed, already faulted in."""
    import numpy as np

    h, w = scene.camera.height, scene.camera.width
    nl = len(scene.lights)

    def floor():
        arrays = [np.empty(shape, np.float32) for shape in [(h, w, 3)] * 3 + [(nl, h, w), (h, w)]]
        for a in arrays:
            a.fill(1.0)

    return floor


def bench_case(kind, level, width, height, repeats, only=None):
    """Rows of one case; ``only``: the names of the paths to time (and ``frame``, the unit)."""
    from benchmarks.bench_peers import make_mesh, make_scene

    mesh = make_mesh(kind, level)
    scene = make_scene(mesh, width, height)
    tmp = tempfile.mkdtemp(prefix="bench_paths_")
    try:
        paths = {**_paths(scene, tmp), **_teaching_paths(scene)}
        if only:
            paths = {k: v for k, v in paths.items() if k == "frame" or k in only}
        times = {name: [] for name in paths}
        kernel = {name: [] for name in paths}  # (minor page faults, system CPU seconds) of each call
        for r in range(repeats + 1):  # round 0: warm-up (JIT, Embree build, page faults)
            for name, (fn, _, per) in paths.items():
                k0 = _kernel_side()
                t0 = time.perf_counter()
                fn()
                if r:
                    times[name].append((time.perf_counter() - t0) / per)
                    kernel[name].append(tuple(b - a for a, b in zip(k0, _kernel_side())))
        sizes = {name: sum(os.path.getsize(f) for f in glob.glob(path)) / 2**20
                 for name, (_, path, _) in paths.items() if path}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    unit = statistics.median(times["frame"])
    rows = []
    for name, ts in times.items():
        med = statistics.median(ts)
        faults, sys_s = (statistics.median(k[i] for k in kernel[name]) for i in (0, 1))
        rows.append(dict(mesh=kind, triangles=len(mesh.faces), width=width, height=height, path=name,
                         median_ms=f"{med * 1e3:.1f}", ratio=f"{med / unit:.2f}",
                         size_MiB=f"{sizes[name]:.1f}" if name in sizes else "", repeats=repeats, note="",
                         faults=f"{faults:.0f}", sys_ms=f"{sys_s * 1e3:.1f}"))
    return rows


def _kernel_side():
    """(minor page faults, system CPU seconds) of this process so far: what a call spent in the OS,
    mostly giving it fresh pages (on a VM, what the host charges for them moves by the minute)."""
    import resource

    use = resource.getrusage(resource.RUSAGE_SELF)
    return use.ru_minflt, use.ru_stime


_PEAK = """
import sys
sys.path.insert(0, {root!r})
from benchmarks.bench_peers import make_mesh, make_scene
import raycast_shade as rs

def status(key):
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith(key))

scene = make_scene(make_mesh({kind!r}, {level}), {w}, {h})
rs.render(scene, camera=scene.camera.replace(width=64, height=48), buffers={names!r})  # compiled, BVH built
before = status("VmRSS")
with open("/proc/self/clear_refs", "w") as fh:
    fh.write("5")  # resets VmHWM to the present resident set
rs.render(scene, buffers={names!r})
print((status("VmHWM") - before) / 2**20)
"""


def peak_mib(kind, level, width, height, names) -> float:
    """MiB the resident set peaks above its level before one frame with ``names`` (a fresh process,
    compiled and with the BVH built; Linux's VmHWM, reset through ``/proc/self/clear_refs``)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    code = _PEAK.format(root=root, kind=kind, level=level, w=width, h=height, names=tuple(names))
    # A fixed mmap threshold (as tests/scene/test_frame_memory.py): every large array is mapped fresh,
    # none served from heap the mesh build freed (glibc raises the threshold to the largest freed
    # block), which showed the 1.31 M-triangle frames growing by 0 MiB.
    env = dict(os.environ, MALLOC_MMAP_THRESHOLD_="131072")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    return float(out.stdout.strip().splitlines()[-1])


BEGIN, END = "<!-- paths:begin (benchmarks/bench_paths.py) -->", "<!-- paths:end -->"
LABELS = {"buffers_all": "all 12 buffers",
          "alloc_all": "their bytes, one fresh block + one fill (the page-fault floor)",
          "buffers_all_reused": "all 12 buffers into an earlier frame's arrays (`buffers_out=`)",
          "store_all": "the 12 buffers' bytes, one fill of a warm block (the reused floor)",
          "position": "`position` alone",
          "view_default": "zdepth, normal, id, mask (the view-set default)",
          "alloc_view_default": "their bytes, one fresh block + one fill (the floor)",
          "write_floor": "the same bytes, one plain write (the floor)", "npz_plain": "`save_npz`, stored (default)",
          "npz_level1": "`save_npz`, deflate level 1 (ISA-L)", "npz_level6": "`save_npz`, deflate level 6 (zlib)",
          "exr": "`write_exr`, uncompressed (default)", "exr_zip": "`write_exr`, ZIP", "exr_zstd": "`write_exr`, ZSTD",
          "view_npz": "`render_views`, per view (PNG + npz, stored)",
          "view_npz_zip": "`render_views`, per view (PNG + npz, zip: the default with ISA-L)",
          "view_npz_exr_png": "`render_views`, per view (PNG + npz + EXR + depth PNG, zip)",
          "view_floor": "one view's files (PNG + zipped npz + record), one plain write (the floor)",
          "flat": "flat-shaded frame", "gouraud": "Gouraud-shaded frame", "samples4": "`samples=4`",
          "samples4_coverage": "`samples=4` with coverage and the view-set default",
          "terms": "`terms=True`", "terms_flat": "`terms=True`, flat-shaded",
          "terms_gouraud": "`terms=True`, Gouraud-shaded",
          "terms_floor": "the term arrays' page faults (`np.empty` + fill: their floor)",
          "shadows": "shadows on", "mirror": "a mirror material, one bounce",
          "explain": "`frame.explain(x, y)`, one pixel"}


MS_ROWS = ("explain",)  # shown with their milliseconds too (the target is in ms)
KERNEL_FAULTS = 100  # paths above this many minor page faults a call get a row in the faults table


def table(rows) -> str:
    """The markdown table of ``rows``: each path's ratio per mesh and size (and the files' MiB)."""
    cases = list(dict.fromkeys((r["mesh"], r["triangles"], r["width"], r["height"]) for r in rows))
    get = {(r["mesh"], r["width"], r["height"], r["path"]): r for r in rows}
    head = ["path"] + [f"{int(t):,} tris, {w}×{h}" for _, t, w, h in cases]
    out = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    out.append("| plain Phong frame (the unit), ms | "
               + " | ".join(get[(m, w, h, "frame")]["median_ms"] for m, _, w, h in cases) + " |")
    if any(r.get("note", "").startswith("re-timed") for r in rows):
        units = {(r["mesh"], r["width"], r["height"]): r["note"].split("frame ")[-1].split(" ms")[0]
                 for r in rows if r.get("note", "").startswith("re-timed")}
        out.append("| the same, in the re-timed rounds (†), ms | "
                   + " | ".join(units.get((m, w, h), "") for m, _, w, h in cases) + " |")
    for name, label in LABELS.items():
        cells = []
        for m, _, w, h in cases:
            r = get.get((m, w, h, name))
            tail = f" ({r['size_MiB']} MiB)" if r and r["size_MiB"] else (f" ({r['median_ms']} ms)" if r and name in MS_ROWS else "")
            mark = "†" if r and r.get("note", "").startswith("re-timed") else ""
            cells.append("" if r is None else f"{r['ratio']}×{mark}" + tail)
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    for name, label in (("peak_frame", "peak memory growth, plain frame"), ("peak_buffers_all", "the same, all 12 buffers")):
        out.append(f"| {label} | " + " | ".join(f"{get[(m, w, h, name)]['size_MiB']} MiB" for m, _, w, h in cases) + " |")
    out += _kernel_table(rows, cases)
    notes = sorted({r["note"].split(", frame")[0] for r in rows if r.get("note", "").startswith("re-timed")})
    if notes:
        out.append("")
        out.append("† Re-timed alone (`--only`), each ratio to the frame timed in the same rounds: "
                   + "; ".join(notes) + ".")
    return "\n".join(out) + "\n"


def _kernel_table(rows, cases) -> list:
    """Lines of a second table: the median minor page faults and system CPU of one call, for the
    paths that took more than :data:`KERNEL_FAULTS` faults a call in some case (none: no lines).
    Rows from a CSV without those columns (older runs) count as none."""
    get = {(r["mesh"], r["width"], r["height"], r["path"]): r for r in rows}
    names = [n for n in LABELS
             if any(int(r.get("faults") or 0) > KERNEL_FAULTS for r in rows if r["path"] == n)]
    if not names:
        return []
    head = ["page faults / system CPU of one call"] + [f"{int(t):,} tris, {w}×{h}" for _, t, w, h in cases]
    out = ["", "| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    def cell(r):
        return "" if r is None or not r.get("faults") else f"{int(r['faults']):,} / {r['sys_ms']} ms"

    for name in ["frame"] + names:
        cells = [cell(get.get((m, w, h, name))) for m, _, w, h in cases]
        out.append(f"| {'plain Phong frame' if name == 'frame' else LABELS[name]} | " + " | ".join(cells) + " |")
    return out


def write_table(rows, quick: bool) -> str:
    """Put :func:`table` between the markers of ``docs/performance.md`` (quick: ``out/quick/results/paths.md``)."""
    return where.write_table(table(rows), "paths.md", BEGIN, END, quick)


def chart(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = sorted({(r["mesh"], int(r["width"]), int(r["height"])) for r in rows if r["path"] != "peak"},
                   key=lambda c: (c[0], c[1]))
    names = [n for n in dict.fromkeys(r["path"] for r in rows) if not n.startswith("peak")]
    fig, ax = plt.subplots(figsize=(10, 4.2))
    width = 0.8 / len(cases)
    for k, case in enumerate(cases):
        vals = {r["path"]: float(r["ratio"]) for r in rows
                if (r["mesh"], int(r["width"]), int(r["height"])) == case and r["ratio"]}
        ax.bar([i + k * width for i in range(len(names))], [vals.get(n, 0.0) for n in names], width,
               label=f"{case[0]} {case[1]}x{case[2]}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_yscale("log")  # from half a frame to twenty frames
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(names))], names, rotation=30, ha="right")
    ax.set_ylabel("time / plain Phong frame (log)")
    ax.set_title("Every path against the plain frame (medians, interleaved in one run)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _retime(cases, repeats, only, quick):
    """Re-time the paths ``only`` (with the frame) and put their rows in place of the CSV's: every
    ratio is still to a frame timed in the same rounds (the frame row re-timed with them is kept
    apart, in the new rows' notes, so the other rows keep their unit)."""
    path = results_file("paths.csv", quick)
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    load = os.getloadavg()[0]
    for case in cases:
        for r in bench_case(*case, repeats, only):
            r = {k: str(v) for k, v in r.items()}
            if r["path"] == "frame":
                unit = r["median_ms"]
                continue
            r["note"] = f"re-timed {stamp}, load {load:.1f}, frame {unit} ms in these rounds"
            key = (r["mesh"], str(r["width"]), str(r["height"]), r["path"])
            at = [i for i, old in enumerate(rows) if (old["mesh"], old["width"], old["height"], old["path"]) == key]
            if at:
                rows[at[0]] = r
            else:
                rows.append(r)
            print(r["mesh"], r["width"], r["path"], r["median_ms"], r["ratio"], flush=True)
    write_csv(path, rows, FIELDS)
    chart(rows, image_file("paths.png", quick))
    write_table(rows, quick)
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="one small case; writes under out/quick/")
    p.add_argument("--repeats", type=int, default=None)
    p.add_argument("--table", action="store_true", help="only redo the table and chart from the CSV")
    p.add_argument("--only", default=None,
                   help="comma-separated paths to re-time (with the frame, their unit); their rows replace "
                        "those of the CSV, each marked in its note")
    args = p.parse_args(argv)
    unknown = set((args.only or "").split(",")) - set(LABELS) - {"frame", ""}
    if unknown:
        p.error(f"--only: unknown paths {sorted(unknown)}; expected some of {sorted(LABELS)}")
    if args.table:
        with open(results_file("paths.csv", args.quick), newline="") as fh:
            rows = list(csv.DictReader(fh))
        chart(rows, image_file("paths.png", args.quick))
        write_table(rows, args.quick)
        return rows
    cases = QUICK_CASES if args.quick else CASES
    repeats = args.repeats or (2 if args.quick else 5)  # 5: a median that one slow moment of a VM does not move
    if args.only and not os.path.exists(results_file("paths.csv", args.quick)):
        p.error(f"--only: re-times rows of {results_file('paths.csv', args.quick)}, which does not exist yet; "
                "run without --only first")
    if args.only:
        return _retime(cases, repeats, set(args.only.split(",")), args.quick)
    rows = []
    for case in cases:
        rows += bench_case(*case, repeats)
        for label, names in (("peak_frame", ()), ("peak_buffers_all", ALL)):
            rows.append(dict(mesh=case[0], triangles=20 * 4 ** case[1], width=case[2], height=case[3], path=label,
                             median_ms="", ratio="", size_MiB=f"{peak_mib(*case, names):.0f}", repeats=1,
                             note="peak RSS growth of one frame, fresh process"))
        for r in rows[-(len(LABELS) + 3):]:
            print(r["mesh"], r["width"], r["path"], r["median_ms"], r["ratio"], r["size_MiB"], flush=True)
    out = results_file("paths.csv", args.quick)
    write_csv(out, rows, FIELDS)
    chart(rows, image_file("paths.png", args.quick))
    write_table(rows, args.quick)
    return rows


if __name__ == "__main__":
    main()
