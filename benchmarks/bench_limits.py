"""The frame against the machine's limits, memory, load and the cold start.

Run ``python -m benchmarks.bench_limits [--quick] [--only SECTION ...]``.
Sections (issue 16):

``limit``
    For each case of :mod:`benchmarks.bench_peers` (same scenes): Embree's
    raw packet throughput, the camera's 4x4-pixel tiles as coherent 16-ray
    packets generated beforehand (the renderer's ``RTCRayHit16`` layout, see
    :mod:`raycast_shade.visibility.cast`) and traced by a small parallel
    Numba kernel that does nothing but call ``rtcIntersect16`` (no ray
    generation, no unpacking, no shading; the packets are restored between
    repeats, untimed), and the same for 4x2 tiles of 8 rays (``packets8``,
    the renderer's packets before); the memory bandwidth of writing the bytes
    a frame writes to memory (linear image 12 B + hit mask 1 B per pixel; its
    hits stay in a band, :mod:`raycast_shade.visibility.bands`) by a parallel
    Numba store, into preallocated arrays (the bandwidth) and into fresh
    ``np.empty`` arrays each time (what the renderer does: first-touch page
    faults included); the renderer's cast kernel alone over a whole frame
    (rays, packets, unpacking, the slip test; no re-cast); and ``rs.render`` itself, fresh
    and with ``out=`` (one image reused), and fresh with the general Phong kernel
    (``frame_general``: the dispatch to the batched kernel of
    :mod:`raycast_shade.shading.phong_fast` turned off); and the two Phong kernels
    alone over the frame's hits on one thread in CPU time (``shade_batched``,
    ``shade_general``: the measure that a loaded machine disturbs least). Reported: the frame over the sum of
    packets + preallocated store (issue 16 aims at <= 1.3), the cast kernel and
    the frame's cast stage over the packets (issue 27 aims at <= 1.15), the stages
    of the frame and how many isolated misses it re-casts.
``memory``
    Resident memory of a 7680x4320 Phong frame, one subprocess per mesh, stage
    by stage: import, the mesh, the packed geometry, a small warm-up frame (the
    JIT, the BVH), the 8K frame, its 8-bit image, its PNG (``frame.save``): the
    resident size before and after each, and each stage's own peak (the
    high-water mark ``VmHWM``, reset before the stage); ``tracemalloc`` peaks of
    the NumPy allocations of the last three.
``load``
    The frame with 1 and 2 Numba threads, on the machine as it is and with
    a busy process spinning on CPU 0, at 320x240, 640x480 and 1920x1080, in
    subprocesses under threading variants: the environment as it is
    (the kernels run in parts on the package's own threads, :mod:`raycast_shade.common.parallel`,
    so OpenMP's settings should change nothing), GNU OpenMP's default wait,
    a short spin (``GOMP_SPINCOUNT=10000``), ``OMP_WAIT_POLICY=active``, and
    ``NUMBA_THREADING_LAYER=workqueue``; two rounds in alternating order.
``recast``
    The single-ray kernel in parts (``cast_rays_kernel``) and whole in the
    calling thread (``cast_rays_serial``) for 1 to 4096 rays through random image
    points (the noisy sphere at 640x480), quiet and with a busy core: where
    the hole re-cast switches (``visibility.cast.SERIAL_BELOW``).
``openmp``
    The icosphere frame alone and right after a small call of another
    library with its own thread pool (Open3D; FLIP's bundled GNU OpenMP,
    loaded before or after us, spinning, or with the user's passive policy),
    one subprocess per variant (:func:`benchmarks.bench_peers.neighbour_rows`).
``cold``
    The demo's flat first picture and the whole ``raycast-shade demo`` from an
    empty ``NUMBA_CACHE_DIR`` (every kernel compiled), each run at the same
    time as the code before issue 40 (``COLD_REFERENCE``), one per core: the
    children's CPU (user + sys) and its ratio; then the demo with a warm cache
    (:func:`cold`). ``docs/performance.md`` shows the table between its
    ``cold`` markers.

Every row carries the 1-minute load average when it was measured: this
machine may be shared. Results: ``benchmarks/results/limits.csv``;
``--quick`` (small frames, few repeats, no cold compile unless asked) writes
only under ``out/quick/results/`` (untracked).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from unittest import mock

import numpy as np
from numba import njit

from raycast_shade.common.parallel import KERNEL, in_parts, share

from raycast_shade.visibility import embree
from raycast_shade.visibility.rays import pixel_ray

from benchmarks import outputs as where
from benchmarks.outputs import results_file, write_csv

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SECTIONS = ("limit", "memory", "load", "recast", "cold", "openmp")
KEYS = ["section", "mesh", "triangles", "width", "height", "variant", "metric", "value", "unit", "load1"]

_RAY = embree.RAYHIT_SLOTS  # float32 slots per ray in a packet (the renderer's RTCRayHit16 stride)
FRAME_BYTES = 12 + 1  # per pixel written to memory: linear RGB float32 + the hit mask (hits stay in a band)
PACKETS = {"packets": (4, 4), "packets8": (4, 2)}  # the renderer's 4x4 tiles of 16 rays; the 4x2 tiles of 8 it had


# -- kernels -------------------------------------------------------------------------------------------------

@in_parts
@njit(**KERNEL)
def _make_packets(cam, w, h, tw, th, rays, valid, part):
    """Fill ``rays`` (P * 24 * n,) float32 and ``valid`` (P * n,) int32 with the camera's
    ``tw`` x ``th`` tiles of ``n = tw * th`` rays, row of tiles after row, as
    :mod:`raycast_shade.visibility.cast` does."""
    n = tw * th
    ntx = (w + tw - 1) // tw
    nty = (h + th - 1) // th
    ib = rays.view(np.uint32)
    for ty in range(*share(nty, part)):  # this part's share (common.parallel)
        for tx in range(ntx):
            p = ty * ntx + tx
            o = p * _RAY * n
            for k in range(n):
                x = tx * tw + (k % tw)
                y = ty * th + (k // tw)
                if x < w and y < h:
                    valid[p * n + k] = -1
                    ox, oy, oz, dx, dy, dz = pixel_ray(cam, x, y)
                else:
                    valid[p * n + k] = 0
                    ox, oy, oz, dx, dy, dz = 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
                embree.write_ray(rays, ib, o + k, n, (ox, oy, oz), (dx, dy, dz), 0.0, np.inf)
                embree.reset_hit(ib, o + k, n)


@in_parts
@njit(**KERNEL)
def _trace_packets(scene, rays, valid, args, npackets, n, part):
    """``rtcIntersect16`` (``n = 16``) or ``rtcIntersect8`` on every prepared packet, in
    parallel; nothing else."""
    for p in range(*share(npackets, part)):  # this part's share (common.parallel)
        if n == 16:
            embree.intersect16_packet(valid[p * 16:], scene, rays[p * _RAY * 16:], args)
        else:
            embree.intersect8_packet(valid[p * 8:], scene, rays[p * _RAY * 8:], args)


@in_parts
@njit(**KERNEL)
def _store_frame(image, mask, part):
    """Write every byte a frame writes to memory (rows in parallel): the bandwidth floor."""
    h, w = mask.shape
    for y in range(*share(h, part)):  # this part's share (common.parallel)
        for x in range(w):
            image[y, x, 0] = 0.1
            image[y, x, 1] = 0.2
            image[y, x, 2] = 0.3
            mask[y, x] = True


def _aligned(n, dtype, align=32):
    """(n,) array of ``dtype`` starting at an ``align``-byte boundary."""
    item = np.dtype(dtype).itemsize
    raw = np.empty(n + align // item, dtype)
    off = ((align - raw.ctypes.data % align) % align) // item
    return raw[off:off + n]


def _frame_buffers(h, w):
    """A full-frame hit buffer's five arrays (what the cast kernel alone fills)."""
    return (np.empty((h, w), np.int32), np.empty((h, w), np.int32), np.empty((h, w), np.float32),
            np.empty((h, w), np.float32), np.empty((h, w), np.float32))


def _frame_outputs(h, w):
    """What a frame writes to memory: the linear image and the hit mask."""
    return np.empty((h, w, 3), np.float32), np.empty((h, w), np.bool_)


def _load():
    return round(os.getloadavg()[0], 2)


def packet_floor(geo, camera):
    """The floor of any Embree-path frame of ``camera`` over the packed ``geo``: its 4x4 tiles as
    16-ray packets made beforehand, and a preallocated store of what a frame writes.

    Returns ``(restore, trace, store, hits)``: ``restore()`` puts the pristine packets back (untimed,
    between repeats: a traced packet's ``tfar`` is its hit), ``trace()`` calls ``rtcIntersect16`` on
    every packet, ``store()`` writes the (H, W, 3) float32 image and (H, W) mask,
    ``hits()`` counts the traced packets' hits (for a check against the frame's).
    """
    from raycast_shade.visibility.accel import embree_accel
    from raycast_shade.visibility.rays import camera_frame

    w, h = camera.width, camera.height
    cam = camera_frame(camera, geo.origin)
    handle = embree_accel(geo).handle
    args = _aligned(embree.ARGS_SLOTS, np.uint32, 8)
    args[:] = 0
    args[0] = embree.RAY_QUERY_FLAG_COHERENT
    args[1] = embree.FEATURE_FLAG_ALL
    tw, th = PACKETS["packets"]
    n = tw * th
    npk = ((w + tw - 1) // tw) * ((h + th - 1) // th)
    pristine = _aligned(npk * _RAY * n, np.float32, 64)
    valid = _aligned(npk * n, np.int32, 64)
    _make_packets(cam, w, h, tw, th, pristine, valid)
    work = _aligned(pristine.size, np.float32, 64)
    np.copyto(work, pristine)
    pre = _frame_outputs(h, w)

    def hits():
        hit_geom = work.view(np.uint32).reshape(npk, _RAY, n)[:, embree.HIT_GEOM_ID, :]
        return int(np.count_nonzero(hit_geom[valid.reshape(npk, n) != 0] != embree.INVALID_ID))

    return (lambda: np.copyto(work, pristine), lambda: _trace_packets(handle, work, valid, args, npk, n),
            lambda: _store_frame(*pre), hits)


def shade_cpu(scene, repeats):
    """The shade stage's Phong kernels over a whole frame's hits on one thread, in CPU time
    (``time.thread_time``: what a loaded machine's other processes add least to), the batched
    kernel and the general one alternating; median seconds each."""
    import numba
    from raycast_shade.shading import shade as shading
    from raycast_shade.visibility.cast import cast_camera

    hits = cast_camera(scene.geometry, scene.camera, "embree")
    out = np.empty(hits.shape + (3,), np.float32)
    shaders = {"batched": shading.SampleShading(scene, scene.camera, "phong")}
    with mock.patch.object(shading, "_fast_applies", lambda *a: False):  # decided as the shader is made
        shaders["general"] = shading.SampleShading(scene, scene.camera, "phong")
    old = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        times = {k: [] for k in shaders}
        for r in range(repeats + 1):  # the first round warms up
            for k, shader in shaders.items():
                t0 = time.thread_time()
                shader.shade(hits, out=out)
                if r:
                    times[k].append(time.thread_time() - t0)
    finally:
        numba.set_num_threads(old)
    return {k: float(np.median(v)) for k, v in times.items()}


# -- sections -----------------------------------------------------------------------------------------------

def limit_case(kind, level, w, h, repeats):
    """Rows of the ``limit`` section for one case."""
    import raycast_shade as rs
    from raycast_shade.shading import shade as shading
    from raycast_shade.visibility.accel import embree_accel
    from raycast_shade.study.twins import isolated_misses_numpy
    from raycast_shade.visibility.cast import _cast_camera_kernel
    from raycast_shade.visibility.rays import camera_frame

    from .bench_peers import make_mesh, make_scene

    scene = make_scene(make_mesh(kind, level), w, h)
    geo = scene.geometry
    cam = camera_frame(scene.camera, geo.origin)
    frame = rs.render(scene, "phong")
    rs.render(scene, "phong")
    handle = embree_accel(geo).handle
    args = _aligned(embree.ARGS_SLOTS, np.uint32, 8)
    args[:] = 0
    args[0] = embree.RAY_QUERY_FLAG_COHERENT
    args[1] = embree.FEATURE_FLAG_ALL
    packs = {}
    for name, (tw, th) in PACKETS.items():
        n = tw * th
        npk = ((w + tw - 1) // tw) * ((h + th - 1) // th)
        pristine = _aligned(npk * _RAY * n, np.float32, 64)
        valid = _aligned(npk * n, np.int32, 64)
        _make_packets(cam, w, h, tw, th, pristine, valid)
        packs[name] = (pristine, _aligned(pristine.size, np.float32, 64), valid, npk, n)
    pre = _frame_outputs(h, w)
    reused = np.empty((h, w, 3), np.float32)

    def tracer(name):
        pristine, work, valid, npk, n = packs[name]
        return lambda: _trace_packets(handle, work, valid, args, npk, n)

    counts = np.empty(h, np.int64)

    def cast_kernel():  # the cast kernel alone over a whole frame: rays, packets, unpacking, the slip test
        _cast_camera_kernel(handle, cam, *_frame_buffers(h, w), 0, 0, 0, h, counts, 1e-3)

    stages = {}

    def render(general=False, **kw):  # general: the general Phong kernel, the batched one's dispatch off
        with mock.patch.object(shading, "_fast_applies", lambda *a: False) if general else contextlib.nullcontext():
            f = rs.render(scene, "phong", **kw)
        for k in ("cast", "shade"):
            stages.setdefault(k + "_general" * general, []).append(f.timings[k])

    fns = dict(packets=tracer("packets"), packets8=tracer("packets8"), cast_kernel=cast_kernel,
               store_prealloc=lambda: _store_frame(*pre), store_fresh=lambda: _store_frame(*_frame_outputs(h, w)),
               numpy_fill=lambda: [a.fill(1) for a in pre], frame=render, frame_out=lambda: render(out=reused),
               frame_general=lambda: render(general=True))

    def restore():  # fresh tfar / hit fields, untimed
        for pristine, work, *_ in packs.values():
            np.copyto(work, pristine)

    for name, fn in fns.items():  # warm-up (JIT, page faults)
        restore()
        fn()
    stages.clear()
    times = {name: [] for name in fns}
    load0 = _load()
    names = list(fns)
    for r in range(repeats):
        for name in names[r % len(names):] + names[:r % len(names)]:
            restore()
            t0 = time.perf_counter()
            fns[name]()
            times[name].append(time.perf_counter() - t0)
    load1 = _load()
    # The packets really hit what the frame hit.
    restore()
    hits_packets = {}
    for name in PACKETS:
        pristine, work, valid, npk, n = packs[name]
        tracer(name)()
        hit_geom = work.view(np.uint32).reshape(npk, _RAY, n)[:, embree.HIT_GEOM_ID, :]
        hits_packets[name] = int(np.count_nonzero(hit_geom[valid.reshape(npk, n) != 0] != embree.INVALID_ID))
    med = {name: float(np.median(v)) for name, v in times.items()}
    tri = len(geo.faces)
    base = dict(section="limit", mesh=f"{kind}{level}", triangles=tri, width=w, height=h,
                load1=f"{load0}-{load1}")
    nbytes = FRAME_BYTES * w * h
    floor = med["packets"] + med["store_prealloc"]
    rows = [dict(base, variant=n, metric="median_ms", value=round(1e3 * m, 3), unit="ms") for n, m in med.items()]
    rows += [dict(base, variant=n, metric="min_ms", value=round(1e3 * min(v), 3), unit="ms") for n, v in times.items()]
    rows += [dict(base, variant=n, metric="mrays_per_s", value=round(w * h / med[n] / 1e6, 1), unit="Mray/s")
             for n in PACKETS]
    rows += [dict(base, variant=n, metric="hits", value=v, unit="pixels") for n, v in hits_packets.items()]
    rows += [dict(base, variant=n, metric="write_gb_per_s", value=round(nbytes / med[n] / 1e9, 2), unit="GB/s")
             for n in ("store_prealloc", "store_fresh", "numpy_fill")]
    rows += [dict(base, variant=var, metric=f"stage_{k}_ms", value=round(1e3 * float(np.median(stages[key])), 3),
                  unit="ms") for var, k, key in (("frame", "cast", "cast"), ("frame", "shade", "shade"),
                                                 ("frame_general", "cast", "cast_general"),
                                                 ("frame_general", "shade", "shade_general"))]
    cpu = shade_cpu(scene, repeats)
    rows += [dict(base, variant=f"shade_{k}", metric="cpu_ms_1thread", value=round(1e3 * v, 3), unit="ms")
             for k, v in cpu.items()]
    rows += [
        dict(base, variant="frame", metric="isolated_misses", value=int(isolated_misses_numpy(frame.hits.prim).sum()),
             unit="pixels"),
        dict(base, variant="frame", metric="hits", value=int(frame.mask.sum()), unit="pixels"),
        dict(base, variant="ratio", metric="frame_over_packets_plus_store", value=round(med["frame"] / floor, 3),
             unit="x"),
        dict(base, variant="ratio", metric="frame_general_over_packets_plus_store",
             value=round(med["frame_general"] / floor, 3), unit="x"),
        dict(base, variant="ratio", metric="frame_out_over_packets_plus_store", value=round(med["frame_out"] / floor, 3),
             unit="x"),
        # Under load a parallel launch can wait for a busy core: the floor is the faster store.
        dict(base, variant="ratio", metric="frame_over_packets_plus_best_store",
             value=round(med["frame"] / (med["packets"] + min(med["store_prealloc"], med["numpy_fill"])), 3), unit="x"),
        dict(base, variant="ratio", metric="frame_over_packets_plus_fresh_store",
             value=round(med["frame"] / (med["packets"] + med["store_fresh"]), 3), unit="x"),
        dict(base, variant="ratio", metric="packets8_over_packets", value=round(med["packets8"] / med["packets"], 3),
             unit="x"),
        # The cast against the packets alone (issue 27 aims at <= 1.15): the kernel, and the frame's cast stage.
        dict(base, variant="ratio", metric="cast_kernel_over_packets", value=round(med["cast_kernel"] / med["packets"], 3),
             unit="x"),
        dict(base, variant="ratio", metric="stage_cast_over_packets",
             value=round(float(np.median(stages["cast"])) / med["packets"], 3), unit="x"),
    ]
    print(f"limits: {kind}{level} {w}x{h}: frame {1e3 * med['frame']:.1f} ms (out= {1e3 * med['frame_out']:.1f}), "
          f"packets {1e3 * med['packets']:.1f} (8-wide {1e3 * med['packets8']:.1f}), cast kernel "
          f"{1e3 * med['cast_kernel']:.1f}, cast stage {1e3 * np.median(stages['cast']):.1f}, store "
          f"{1e3 * med['store_prealloc']:.1f} (fresh {1e3 * med['store_fresh']:.1f}), ratio "
          f"{med['frame'] / floor:.2f} (general Phong kernel {med['frame_general'] / floor:.2f}: shade "
          f"{1e3 * np.median(stages['shade_general']):.1f} -> {1e3 * np.median(stages['shade']):.1f} ms; one thread's "
          f"CPU {1e3 * cpu['general']:.1f} -> {1e3 * cpu['batched']:.1f} ms), "
          f"load {load0}-{load1}", file=sys.stderr)
    return rows


_MEMORY_CHILD = r"""
import gc, json, os, sys, tempfile, tracemalloc
def status(key):
    # VmHWM, not ru_maxrss: Linux carries ru_maxrss over from the parent across fork and exec.
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith(key + ":"))
def reset_peak():  # "5" resets VmHWM to the resident size (Linux 4.0+): each stage's own peak
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False
out = {}
def stage(name, fn):
    gc.collect()
    out["reset"] = reset_peak()
    before = status("VmRSS")
    value = fn()
    out[name] = dict(before=before, peak=status("VmHWM"), after=status("VmRSS"))
    return value
stage("import", lambda: __import__("raycast_shade"))
import raycast_shade as rs
from benchmarks.bench_peers import make_mesh, make_scene
kind, level, w, h = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
mesh = stage("mesh", lambda: make_mesh(kind, level))
scene = make_scene(mesh, 64, 48)
stage("geometry", lambda: scene.geometry)
stage("warmup", lambda: rs.render(scene, "phong"))  # JIT, BVH
tracemalloc.start()
frame = stage("render", lambda: rs.render(scene, "phong", camera=scene.camera.replace(width=w, height=h)))
out["tracemalloc_render"] = tracemalloc.get_traced_memory()[1]
tracemalloc.reset_peak()
img = stage("uint8", frame.to_uint8)
out["tracemalloc_uint8"] = tracemalloc.get_traced_memory()[1]
del img
with tempfile.TemporaryDirectory() as tmp:
    tracemalloc.reset_peak()
    stage("save_png", lambda: frame.save(os.path.join(tmp, "frame.png")))
    out["tracemalloc_save_png"] = tracemalloc.get_traced_memory()[1]
out["hwm"] = status("VmHWM")
out["seconds"] = frame.timings["total"]
print(json.dumps(out))
"""

MEMORY_STAGES = ("import", "mesh", "geometry", "warmup", "render", "uint8", "save_png")


def memory(cases, w, h):
    """Rows of the ``memory`` section: one subprocess per mesh, stage by stage.

    Each stage's resident size before and after it, and its own peak (``VmHWM``, reset before
    the stage through ``/proc/self/clear_refs``; where that is refused, the process's peak so
    far); ``tracemalloc`` peaks of the frame's own stages (NumPy's allocations)."""
    rows = []
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    for kind, level in cases:
        load = _load()
        res = subprocess.run([sys.executable, "-c", _MEMORY_CHILD, kind, str(level), str(w), str(h)], cwd=ROOT,
                             env=env, capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(f"memory child failed: {res.stderr[-2000:]}")
        out = json.loads(res.stdout.strip().splitlines()[-1])
        tri = 20 * 4 ** level
        base = dict(section="memory", mesh=f"{kind}{level}", triangles=tri, width=w, height=h,
                    load1=f"{load}-{_load()}")
        gb = lambda b: round(b / 1e9, 3)  # noqa: E731
        peak = "stage_peak" if out["reset"] else "process_peak"
        for name in MEMORY_STAGES:
            got = out[name]
            rows += [dict(base, variant=name, metric="resident_before_gb", value=gb(got["before"]), unit="GB"),
                     dict(base, variant=name, metric=f"{peak}_gb", value=gb(got["peak"]), unit="GB"),
                     dict(base, variant=name, metric="resident_after_gb", value=gb(got["after"]), unit="GB"),
                     dict(base, variant=name, metric="peak_over_before_gb", value=gb(got["peak"] - got["before"]),
                          unit="GB")]
        rows += [dict(base, variant="tracemalloc", metric=f"{k}_peak_gb", value=gb(out[f"tracemalloc_{k}"]), unit="GB")
                 for k in ("render", "uint8", "save_png")]
        rows += [dict(base, variant="process", metric="vmhwm_gb", value=gb(out["hwm"]), unit="GB"),
                 dict(base, variant="frame", metric="render_s", value=round(out["seconds"], 3), unit="s")]
        print(f"limits: memory {kind}{level} {w}x{h}: " + ", ".join(
            f"{name} {gb(out[name]['before'])}->{gb(out[name]['peak'])}->{gb(out[name]['after'])}"
            for name in MEMORY_STAGES) + f" GB (before->peak->after); process peak {gb(out['hwm'])} GB",
            file=sys.stderr)
    return rows


_LOAD_CHILD = r"""
import json, os, subprocess, sys, time
import numpy as np, numba
import raycast_shade as rs
if os.environ.pop("BENCH_UNSET_WAIT", None):  # GNU OpenMP's own default: undo the library's, before any launch
    os.environ.pop("OMP_WAIT_POLICY", None)
from benchmarks.bench_peers import make_mesh, make_scene
kind, level, w, h, repeats = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
scene = make_scene(make_mesh(kind, level), w, h)
for n in (1, 2, 1, 2):
    numba.set_num_threads(n)
    rs.render(scene, "phong")
def measure():
    times = {1: [], 2: []}
    for r in range(repeats):
        for n in ((1, 2) if r % 2 == 0 else (2, 1)):
            numba.set_num_threads(n)
            t0 = time.perf_counter()
            rs.render(scene, "phong")
            times[n].append(time.perf_counter() - t0)
    return times
out = dict(layer=numba.threading_layer(), wait=os.environ.get("OMP_WAIT_POLICY", ""), load_quiet=os.getloadavg()[0])
out["quiet"] = measure()
spin = subprocess.Popen([sys.executable, "-c", "while True: pass"])
try:
    os.sched_setaffinity(spin.pid, {0})
    time.sleep(0.5)
    out["busy"] = measure()
    out["load_busy"] = os.getloadavg()[0]
finally:
    spin.kill()
    spin.wait()
print(json.dumps(out))
"""

# "library": the environment as it is; "gomp_default": OMP_WAIT_POLICY unset in the child. The kernels
# run in parts on Python threads (common/parallel.py): the OpenMP variants are kept to show they no longer matter.
LOAD_VARIANTS = [("library", {}), ("gomp_default", {"BENCH_UNSET_WAIT": "1"}),
                 ("gomp_spin10k", {"GOMP_SPINCOUNT": "10000"}),
                 ("omp_active", {"NUMBA_THREADING_LAYER": "omp", "OMP_WAIT_POLICY": "active"}),
                 ("workqueue", {"NUMBA_THREADING_LAYER": "workqueue"})]
LOAD_CASES = [("icosphere", 6, 320, 240), ("icosphere", 6, 640, 480), ("icosphere", 6, 1920, 1080)]


def load_section(cases, repeats, rounds=2):
    """Rows of the ``load`` section: 1 vs 2 threads, quiet vs one busy core, per threading variant.

    The variants cannot share a process (the layer and the wait policy are
    fixed when OpenMP loads), so each runs in its own child, ``rounds`` times
    in alternating order (the machine's load drifts); the medians pool the
    rounds' frames.
    """
    rows = []
    for kind, level, w, h in cases:
        pooled, info = {}, {}
        for r in range(rounds):
            for name, extra in (LOAD_VARIANTS if r % 2 == 0 else LOAD_VARIANTS[::-1]):
                env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
                for k in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "NUMBA_THREADING_LAYER", "BENCH_UNSET_WAIT"):
                    env.pop(k, None)
                env.update(extra)
                res = subprocess.run([sys.executable, "-c", _LOAD_CHILD, kind, str(level), str(w), str(h),
                                      str(repeats)], cwd=ROOT, env=env, capture_output=True, text=True)
                if res.returncode != 0:
                    raise RuntimeError(f"load child ({name}) failed: {res.stderr[-2000:]}")
                out = json.loads(res.stdout.strip().splitlines()[-1])
                info[name] = f"{name} ({out['layer']}, wait {out['wait'] or 'unset'})"
                for cond in ("quiet", "busy"):
                    got = pooled.setdefault((name, cond), {"1": [], "2": [], "load": []})
                    got["1"] += out[cond]["1"]
                    got["2"] += out[cond]["2"]
                    got["load"].append(round(out["load_quiet" if cond == "quiet" else "load_busy"], 2))
        for (name, cond), got in pooled.items():
            base = dict(section="load", mesh=f"{kind}{level}", triangles=20 * 4 ** level, width=w, height=h,
                        variant=info[name])
            load = "-".join(str(x) for x in (min(got["load"]), max(got["load"])))
            t1, t2 = float(np.median(got["1"])), float(np.median(got["2"]))
            rows += [dict(base, metric=f"{cond}_1thread_ms", value=round(1e3 * t1, 2), unit="ms", load1=load),
                     dict(base, metric=f"{cond}_2threads_ms", value=round(1e3 * t2, 2), unit="ms", load1=load),
                     dict(base, metric=f"{cond}_2threads_over_1", value=round(t2 / t1, 3), unit="x", load1=load)]
            print(f"limits: load {kind}{level} {w}x{h} {name:12} {cond}: 1 thread {1e3 * t1:.1f} ms, "
                  f"2 threads {1e3 * t2:.1f} ms, ratio {t2 / t1:.2f} (load {load})", file=sys.stderr)
    return rows


_RECAST_CHILD = r"""
import json, os, subprocess, sys, time
import numpy as np
import raycast_shade as rs
from raycast_shade.visibility import cast
from raycast_shade.visibility.accel import embree_accel
from raycast_shade.visibility.holes import empty_hits, rays_at
from raycast_shade.visibility.rays import camera_frame
from benchmarks.bench_peers import make_mesh, make_scene
kind, level, w, h, repeats = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
scene = make_scene(make_mesh(kind, level), w, h)
geo = scene.geometry
cam = camera_frame(scene.camera, geo.origin)
handle = embree_accel(geo).handle
rng = np.random.default_rng(0)
SIZES = (1, 4, 16, 64, 256, 1024, 4096)
rays = {}
for n in SIZES:  # rays through random points of the image, as the hole re-cast's jittered rays are
    o, d = rays_at(cam, rng.uniform(0, w - 1, n), rng.uniform(0, h - 1, n))
    rays[n] = (o, d, np.zeros(n), np.full(n, np.inf))
kernels = dict(parallel=cast.cast_rays_kernel, serial=cast.cast_rays_serial)
def measure():
    out = {}
    for n in SIZES:
        times = {k: [] for k in kernels}
        for r in range(repeats):
            for k in (("parallel", "serial") if r % 2 == 0 else ("serial", "parallel")):
                hb = empty_hits(n)
                t0 = time.perf_counter()
                kernels[k](handle, *rays[n], *hb)
                times[k].append(time.perf_counter() - t0)
        out[n] = {k: float(np.median(v)) for k, v in times.items()}
    return out
for k in kernels.values():
    k(handle, *rays[4], *empty_hits(4))
res = dict(load_quiet=os.getloadavg()[0], quiet=measure())
spin = subprocess.Popen([sys.executable, "-c", "while True: pass"])
try:
    os.sched_setaffinity(spin.pid, {0})
    time.sleep(0.5)
    res["busy"] = measure()
    res["load_busy"] = os.getloadavg()[0]
finally:
    spin.kill()
    spin.wait()
print(json.dumps(res))
"""


def recast(case, repeats):
    """Rows of the ``recast`` section: ``cast_rays_kernel`` (parallel) against its
    serial twin for 1-4096 rays, quiet and with a busy core (the choice of
    ``raycast_shade.visibility.cast.SERIAL_BELOW``)."""
    kind, level, w, h = case
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    res = subprocess.run([sys.executable, "-c", _RECAST_CHILD, kind, str(level), str(w), str(h), str(repeats)],
                         cwd=ROOT, env=env, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"recast child failed: {res.stderr[-2000:]}")
    out = json.loads(res.stdout.strip().splitlines()[-1])
    rows = []
    for cond in ("quiet", "busy"):
        load = round(out["load_quiet" if cond == "quiet" else "load_busy"], 2)
        for n, t in out[cond].items():
            base = dict(section="recast", mesh=f"{kind}{level}", triangles=20 * 4 ** level, width=w, height=h,
                        variant=f"{n} rays", unit="ms", load1=load)
            rows += [dict(base, metric=f"{cond}_{k}_ms", value=round(1e3 * t[k], 4)) for k in ("parallel", "serial")]
            print(f"limits: recast {n:>5} rays {cond}: parallel {1e3 * t['parallel']:.3f} ms, serial "
                  f"{1e3 * t['serial']:.3f} ms (load {load})", file=sys.stderr)
    return rows


# The code before issue 40 (one evaluator, compiled once): the reference of the cold start's aim,
# "the demo's first picture <= 15 s of CPU" where this code took 44 s (the guide's figure).
COLD_REFERENCE = "f316368"
COLD_AIM = (15.0, 44.0)  # aim, and the reference's CPU when the aim was set: a ratio of 0.34
COLD_ROUNDS = 3
_COLD_CHILD = {
    # The demo's first panel alone: what the first picture of a session costs.
    "flat": "from raycast_shade.apps.demo import demo_scene\n"
            "from raycast_shade.render import render\n"
            "import warnings\nwarnings.simplefilter('ignore')\n"
            "render(demo_scene(), 'flat')\n",
    # raycast-shade demo: three panels and the PNG.
    "demo": "import sys, runpy\nsys.argv = ['raycast_shade', 'demo', '-o', sys.argv[1]]\n"
            "try:\n    runpy.run_module('raycast_shade', run_name='__main__')\nexcept SystemExit as e:\n"
            "    assert not e.code, e.code\n",
}
_COLD_TAIL = ("import resource, json\nru = resource.getrusage(resource.RUSAGE_SELF)\n"
              "print('COLD ' + json.dumps(ru.ru_utime + ru.ru_stime))\n")


def _reference_tree(commit, tmp):
    """The package at ``commit`` (``git archive``) under ``tmp``, or ``None`` where git or the commit
    is missing (a shallow clone, an unpacked archive)."""
    dest = os.path.join(tmp, "reference")
    try:
        tar = subprocess.run(["git", "-C", ROOT, "archive", commit, "raycast_shade"], capture_output=True, check=True)
    except (OSError, subprocess.CalledProcessError) as e:
        print(f"limits: cold: no reference tree ({commit}): {getattr(e, 'stderr', b'') or e}", file=sys.stderr)
        return None
    os.makedirs(dest)
    subprocess.run(["tar", "-x", "-C", dest], input=tar.stdout, check=True)
    return dest


def _cold_start(tree, what, cache, core):
    """Start one child: ``what`` from ``tree`` on ``core`` with one Numba thread and the kernel cache
    ``cache`` (empty: a cold start)."""
    env = dict(os.environ, PYTHONPATH=tree, NUMBA_CACHE_DIR=cache, NUMBA_NUM_THREADS="1")
    out = os.path.join(cache, "demo.png")
    pre = (lambda c=core: os.sched_setaffinity(0, {c})) if core is not None else None
    return subprocess.Popen([sys.executable, "-c", _COLD_CHILD[what] + _COLD_TAIL, out], cwd=cache, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=pre)


def _cold_result(proc):
    """A child's CPU seconds (user + sys, its threads included) and stdout, once it ends."""
    stdout, stderr = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"cold child failed: {stderr[-2000:]}")
    return next(float(x.split()[1]) for x in stdout.splitlines() if x.startswith("COLD ")), stdout


def _cold_children(jobs):
    """Run ``jobs`` (``(tree, what, cache, core)``) at once, each on its own core with one Numba thread
    and its kernel cache; return each child's CPU seconds and stdout."""
    return [_cold_result(p) for p in [_cold_start(*job) for job in jobs]]


def _cold_beside(ours, reference, tmp):
    """``ours`` run back to back, each from an empty cache, for as long as ``reference`` (one run)
    runs beside it on the other core: both ``(tree, what, cache, core)``. Returns ours' runs and the
    reference's, each ``(cpu, stdout)``.

    The reference takes about three times as long as ours: measured once each, only the first third
    of the reference's run would share ours' minutes, and the machine's speed drifts by a third
    within minutes. Run back to back, ours' runs span the reference's, so both see the same drift."""
    ref = _cold_start(*reference)
    runs = []
    while True:
        runs.append(_cold_result(_cold_start(*ours)))
        if ref.poll() is not None:
            break
        ours = (ours[0], ours[1], tempfile.mkdtemp(dir=tmp), ours[3])  # the next run from an empty cache
    return runs, _cold_result(ref)


def _stages(stdout):
    # "wrote ... (...): build 1478 ms, cast 4978 ms, shade 25948 ms, mirror 17081 ms, ..."
    stages = {}
    for part in stdout.replace(":", ",").split(","):
        words = part.split()
        if len(words) == 3 and words[0] in ("build", "cast", "shade", "mirror") and words[2] == "ms":
            stages[words[0]] = float(words[1])
    return stages


def cold(rounds=COLD_ROUNDS, reference=COLD_REFERENCE):
    """Rows of the ``cold`` section: the first picture from an empty kernel cache, against the code
    before issue 40 in the same minutes.

    Each round runs the ``reference`` commit once and, beside it on the other core (swapped every
    round), this code back to back until the reference ends (:func:`_cold_beside`), each child in a
    fresh process with one Numba thread and an empty ``NUMBA_CACHE_DIR``: the demo's flat first
    picture (``render(demo_scene(), "flat")``), then the whole ``raycast-shade demo`` (three panels,
    the PNG). A child's CPU (user + sys, import included) is the measure, ours the mean of the
    round's runs: the machine's speed drifts by a third within minutes, and children measured in
    the same minutes drift alike, so their ratio holds where either figure does not. Then the demo
    once more with the cache it left (warm). Without a second core the two run one after the other."""
    rows = []
    two = len(os.sched_getaffinity(0)) >= 2
    with tempfile.TemporaryDirectory() as tmp:
        ref = _reference_tree(reference, tmp)
        for k in range(1, rounds + 1):
            for what in ("flat", "demo"):
                load = _load()
                cores = (0, 1) if k % 2 else (1, 0)
                jobs = [(ROOT, what, tempfile.mkdtemp(dir=tmp), cores[0] if two else None)]
                if ref is not None:
                    jobs.append((ref, what, tempfile.mkdtemp(dir=tmp), cores[1] if two else None))
                if ref is not None and two:
                    mine, theirs = _cold_beside(jobs[0], jobs[1], tmp)
                else:
                    found = [r for j in jobs for r in _cold_children([j])]
                    mine, theirs = found[:1], (found[1] if ref is not None else None)
                cpu = float(np.mean([c for c, _ in mine]))  # ours' runs beside the reference's one
                base = dict(section="cold", mesh="demo", triangles=0, width=960,
                            height=280 if what == "flat" else 3 * 280 + 4, variant=f"{what}/{k}",
                            load1=f"{load}-{_load()}", unit="s")
                rows.append(dict(base, metric="ours_cpu_s", value=round(cpu, 2)))
                rows.append(dict(base, metric="ours_runs", value=len(mine), unit="runs"))
                msg = f"limits: cold {what} round {k}: ours {cpu:.1f} s CPU ({len(mine)} runs: " + \
                    ", ".join(f"{c:.1f}" for c, _ in mine) + ")"
                if ref is not None:
                    rows.append(dict(base, metric="reference_cpu_s", value=round(theirs[0], 2)))
                    msg += f", {reference} {theirs[0]:.1f} s: {cpu / theirs[0]:.3f}"
                if what == "demo" and k == 1:
                    rows += [dict(base, variant="cold_cache", metric=f"{st}_ms", value=v, unit="ms")
                             for st, v in _stages(mine[0][1]).items()]
                print(msg + f" (load {base['load1']})", file=sys.stderr)
                if what == "demo" and k == rounds:
                    warm = _cold_children([(ROOT, "demo", jobs[0][2], cores[0] if two else None)])[0][0]
                    rows.append(dict(base, variant="warm_cache", metric="demo_cpu_s", value=round(warm, 2)))
        ours = sorted(float(r["value"]) for r in rows if r["metric"] == "ours_cpu_s" and r["variant"][:5] == "demo/")
        rows.append(dict(section="cold", mesh="demo", triangles=0, width=960, height=3 * 280 + 4, variant="cold_cache",
                         metric="demo_cpu_s", value=round(float(np.median(ours)), 2), unit="s", load1=""))
    return rows


def run(quick=False, only=SECTIONS, repeats=None, cold_rounds=COLD_ROUNDS):
    from .bench_peers import CASES, QUICK_CASES

    repeats = repeats or (3 if quick else 9)
    cases = QUICK_CASES if quick else CASES
    rows = []
    if "limit" in only:
        for kind, level, w, h in cases:
            rows += limit_case(kind, level, w, h, repeats)
    if "memory" in only:
        rows += memory([(k, lv) for k, lv, _, _ in cases[::2]] if not quick else [cases[0][:2]],
                       *((1920, 1080) if quick else (7680, 4320)))
    if "load" in only:
        rows += load_section(cases[:1] if quick else LOAD_CASES, repeats)
    if "recast" in only:
        rows += recast(cases[2] if not quick else cases[1], max(repeats, 15) * (1 if quick else 3))
    if "cold" in only:
        rows += cold(cold_rounds)
    if "openmp" in only:
        from .bench_peers import neighbour_rows  # next to the peers it loads

        rows += neighbour_rows(cases[:1] if quick else cases[:2], max(repeats, 5), ROOT)
    return rows


LIMIT_BEGIN, LIMIT_END = "<!-- limits:begin (benchmarks/bench_limits.py --only limit) -->", "<!-- limits:end -->"
FRAME_AIM = 1.25  # frame / (packets + store), every size (issue 41)
SHADE_AIM_MS = (81920, 1920, 1080, 6.0)  # the shade stage at 82k/1080p (issue 41)


def limit_table(rows) -> str:
    """The ``limit`` section's rows (:func:`limit_case`'s or the CSV's) as the markdown table
    ``docs/performance.md`` shows between its ``limits`` markers, with the aims' verdicts."""
    rows = [r for r in rows if r["section"] == "limit"]
    cases = list(dict.fromkeys((r["mesh"], int(r["triangles"]), int(r["width"]), int(r["height"])) for r in rows))
    get = {(r["mesh"], int(r["width"]), int(r["height"]), r["variant"], r["metric"]): float(r["value"]) for r in rows}
    out = ["| case | frame | packets + store | frame / (packets + store) | cast stage / packets | shade stage "
           "| shade, one thread's CPU: batched / general kernel |", "|---|---|---|---|---|---|---|"]
    verdicts, shade_verdict = [], None
    for mesh, tri, w, h in cases:
        def g(variant, metric):
            return get.get((mesh, w, h, variant, metric), float("nan"))
        floor = g("packets", "median_ms") + g("store_prealloc", "median_ms")
        ratio = g("ratio", "frame_over_packets_plus_store")
        shade = g("frame", "stage_shade_ms")
        label = f"{mesh.rstrip('0123456789').replace('_', ' ')} ({tri:,} tris), {w}×{h}"
        out.append(f"| {label} | {g('frame', 'median_ms'):.1f} ms | {floor:.1f} ms | **{ratio:.2f}** | "
                   f"{g('ratio', 'stage_cast_over_packets'):.2f} | {shade:.1f} ms | "
                   f"{g('shade_batched', 'cpu_ms_1thread'):.1f} / {g('shade_general', 'cpu_ms_1thread'):.1f} ms |")
        verdicts.append(f"{ratio:.2f} at {label} ({'met' if ratio <= FRAME_AIM else 'not met'})")
        if (tri, w, h) == SHADE_AIM_MS[:3]:
            aim = SHADE_AIM_MS[3]
            shade_verdict = (f"The shade stage at {label}: {shade:.1f} ms (aim ≤ {aim:.0f} ms: "
                             f"{'met' if shade <= aim else 'not met'}).")
    loads = [float(x) for r in rows for x in (str(r["load1"]).split("-") if r["load1"] else [])]
    out += ["", f"Medians of interleaved rounds, load average {min(loads):.1f}–{max(loads):.1f}.", "",
            f"Frame / (packets + store) against the aim of ≤ {FRAME_AIM}: " + "; ".join(verdicts) + "."]
    if shade_verdict:
        out += ["", shade_verdict]
    return "\n".join(out) + "\n"


COLD_BEGIN, COLD_END = "<!-- cold:begin (benchmarks/bench_limits.py --only cold) -->", "<!-- cold:end -->"


def _cold_pairs(rows, what):
    """``(ours, reference)`` CPU seconds per round of the ``cold`` section (``what``: ``"flat"`` or
    ``"demo"``), for the rounds that ran the reference."""
    by = {}
    for r in rows:
        if r["section"] == "cold" and r["variant"].startswith(what + "/"):
            by.setdefault(r["variant"], {})[r["metric"]] = float(r["value"])
    return [(v["ours_cpu_s"], v["reference_cpu_s"]) for v in by.values() if "reference_cpu_s" in v]


def cold_ratios(rows, what="demo") -> list[float]:
    """Ours / the reference per round of the ``cold`` section (``what``: ``"flat"`` or ``"demo"``)."""
    return [o / b for o, b in _cold_pairs(rows, what)]


def cold_table(rows) -> str:
    """The ``cold`` section's rows (:func:`cold`'s or the CSV's) as the markdown table
    ``docs/performance.md`` shows between its ``cold`` markers, with the aim's verdict."""
    rows = [r for r in rows if r["section"] == "cold"]
    label = {"flat": "the flat first picture (`render(demo_scene(), \"flat\")`)",
             "demo": "the whole `raycast-shade demo` (three panels, the PNG)"}
    aim = COLD_AIM[0] / COLD_AIM[1]
    out = [f"| from an empty kernel cache | ours | the code before issue 40 ({COLD_REFERENCE}) | ours / before "
           f"| rounds: ours / before |", "|---|---|---|---|---|"]
    verdicts = []
    for what in ("flat", "demo"):
        pairs = _cold_pairs(rows, what)
        if not pairs:
            continue
        ratio = float(np.median([o / b for o, b in pairs]))
        out.append(f"| {label[what]} | {np.median([o for o, _ in pairs]):.1f} s | "
                   f"{np.median([b for _, b in pairs]):.1f} s | **{ratio:.2f}** | "
                   + ", ".join(f"{o / b:.2f}" for o, b in pairs) + " |")
        verdicts.append(f"{ratio:.2f} for {label[what].split(' (')[0]} ({'met' if ratio <= aim else 'not met'})")
    warm = [float(r["value"]) for r in rows if (r["variant"], r["metric"]) == ("warm_cache", "demo_cpu_s")]
    loads = [float(x) for r in rows for x in (str(r["load1"]).split("-") if r["load1"] else [])]
    n = len({r["variant"] for r in rows if r["variant"].startswith("demo/")})
    out += ["", f"CPU of the process (user + sys, import included), one Numba thread, medians of {n} rounds; "
            "in each round ours ran back to back beside one run of the code before, one per core (swapped every "
            "round; ours the mean of its runs), load average "
            f"{min(loads):.1f}–{max(loads):.1f}."
            + (f" With the kernel cache the first run left, the demo takes {warm[0]:.1f} s of CPU." if warm else ""),
            "", f"Ours / before against issue 40's aim of {COLD_AIM[0]:.0f} s where the code before it took "
            f"{COLD_AIM[1]:.0f} s (≤ {aim:.2f}): " + "; ".join(verdicts) + "."]
    return "\n".join(out) + "\n"


def write_cold_table(rows, quick: bool) -> str:
    """:func:`cold_table` between the markers of ``docs/performance.md`` (quick: ``out/quick/results/cold.md``)."""
    return where.write_table(cold_table(rows), "cold.md", COLD_BEGIN, COLD_END, quick)


def write_limit_table(rows, quick: bool) -> str:
    """:func:`limit_table` between the markers of ``docs/performance.md`` (quick: ``out/quick/results/limits.md``)."""
    return where.write_table(limit_table(rows), "limits.md", LIMIT_BEGIN, LIMIT_END, quick)


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("limits.csv", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small frames, 3 repeats, no cold compile; untracked output")
    ap.add_argument("--only", nargs="+", choices=SECTIONS, default=None, help="sections to run (default: all; "
                    "quick: all but cold)")
    ap.add_argument("--repeats", type=int, default=None)
    ap.add_argument("--cold-rounds", type=int, default=COLD_ROUNDS, help="rounds of the cold section")
    ap.add_argument("--table", action="store_true", help="only redo the docs tables (limit, cold) from the CSV")
    args = ap.parse_args(argv)
    path, = outputs(args.quick)
    if args.table:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
        write_limit_table(rows, args.quick)
        if any(r["section"] == "cold" for r in rows):
            write_cold_table(rows, args.quick)
        return rows
    only = args.only or (tuple(s for s in SECTIONS if s != "cold") if args.quick else SECTIONS)
    rows = run(args.quick, only, args.repeats, args.cold_rounds)
    if os.path.exists(path):  # keep the rows of the sections that did not run
        with open(path, newline="") as fh:
            kept = [r for r in csv.DictReader(fh) if r["section"] not in only]
        rows = kept + rows
    write_csv(path, rows, KEYS)
    if "limit" in only:
        write_limit_table(rows, args.quick)
    if "cold" in only:
        write_cold_table(rows, args.quick)
    return rows


if __name__ == "__main__":
    main()
