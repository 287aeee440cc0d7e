"""Vision data-set benchmark: buffer files per view, views per second, projection agreement.

Run ``python -m benchmarks.bench_views [--quick]``. Measures

* **files**: one 1920x1080 view of an icosphere (20,480 triangles) with the
  buffers ``zdepth, position, normal, normal_camera, id, mask``: the size
  and write time of its ``.npz`` (stored, deflate level 1), its multi-channel
  ``.exr`` (uncompressed, ZIP) and its 16-bit depth PNG (default, fast),
  and of one plain write of the same bytes, the floor (best of 3 writes);
* **png**: the same view's 8-bit image: the tone mapping by the curve
  (:func:`~raycast_shade.output.tonemap.to_uint8`) and by its table
  (:func:`~raycast_shade.output.quantize.to_uint8_table`) on one thread, and
  the filtered rows deflated by ISA-L at levels 0-3 and zlib at 1 and 6:
  time (median of 5) and size, the choice behind ``png_deflate(fast=True)``;
* **cost**: one view of ``render_views``' default set (PNG image, npz of
  ``zdepth, normal, id, mask``, zip) taken apart, 81,920 triangles
  (:mod:`benchmarks.bench_peers`' scene) at 1920x1080 and 640x480: the
  render with its buffers, the 8-bit pixels (table), the PNG deflate, the
  objects and their RLE masks (one kernel pass over the ids), the npz
  (zip and stored) each written through the SHA-256 of the record
  (:func:`~raycast_shade.output.imagefile.write_hashed`, as a view writes
  it), that hash alone over the npz's bytes in memory, the same files in
  one plain write (the floor), fresh arrays of the view's size
  (``np.empty`` + fill: the page-fault floor), and whole views per view
  with and without the writer thread's overlap. Each is timed interleaved
  with the plain frame, round after round; wall and process CPU time, each
  as a ratio to the frame's (on 2 cores the frame keeps both busy, so a
  view costs its CPU ratio whatever overlaps);
* **views/s**: :func:`raycast_shade.apps.views.render_views` of an orbit
  (buffers ``zdepth, normal, id``, npz and PNG per view), serially and on a
  local Dask cluster of 2 single-threaded workers, after a warm-up run;
* **projection**: for cameras with ``fx != fy`` and an off-centre principal
  point, each visible vertex projected with ``cv2.projectPoints``: the
  pixel's triangle id is one of the vertex's faces (``wrong`` counts the
  others) on both backends, and ``|OpenGL - OpenCV|`` the largest pixel
  difference between ``projection_matrix`` and OpenCV;
* **round trips**: ``K -> Camera -> K`` and ``(R, t) -> Camera -> (R, t)``
  over 1,000 random poses, the largest absolute error.

Results: ``benchmarks/results/views.csv`` (``--only cost,png`` runs those parts
and replaces their rows, keeping the others). ``--quick`` runs smaller sizes
and writes into the git-ignored ``out/quick/results/`` (:mod:`benchmarks.outputs`).
"""

from __future__ import annotations

import argparse
import csv
import os
import shutil
import tempfile
import time

import numpy as np

from benchmarks.outputs import results_file, write_csv

FIELDS = ["benchmark", "case", "width", "height", "value", "unit", "note"]


def _scene(width, height, subdiv=5):
    import raycast_shade as rs

    return rs.Scene([rs.Model(rs.shapes.icosphere(subdiv), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
                    lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")],
                    camera=rs.Camera(eye=(0.0, 0.6, 3.2), width=width, height=height))


def _best(fn, repeats=3):
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def bench_files(tmp, width, height):
    import raycast_shade as rs
    from raycast_shade.output.bufferfile import save_npz, write_depth_png, write_exr

    scene = _scene(width, height)
    names = ("zdepth", "position", "normal", "normal_camera", "id", "mask")
    frame = rs.render(scene, buffers=names)
    b, rows = frame.buffers, []
    blob = b"".join(np.ascontiguousarray(a).tobytes() for a in [*b.values(), frame.image])

    def floor(p):
        with open(p, "wb") as fh:
            fh.write(blob)

    writers = {
        "plain write (floor)": (os.path.join(tmp, "f.bin"), floor),
        "npz_plain": (os.path.join(tmp, "p.npz"), lambda p: save_npz(p, b, image=frame.image, camera=frame.camera)),
        "npz_level1": (os.path.join(tmp, "v.npz"), lambda p: save_npz(p, b, image=frame.image, camera=frame.camera,
                                                                     compressed=1)),
        "exr_none": (os.path.join(tmp, "n.exr"), lambda p: write_exr(p, b, image=frame.image)),
        "exr_zip": (os.path.join(tmp, "v.exr"), lambda p: write_exr(p, b, image=frame.image, compression="zip")),
        "depth_png16": (os.path.join(tmp, "d.png"), lambda p: write_depth_png(p, b["zdepth"])),
        "depth_png16_fast": (os.path.join(tmp, "e.png"), lambda p: write_depth_png(p, b["zdepth"], fast=True)),
    }
    note = "image + " + ",".join(names)
    for case, (path, write) in writers.items():
        seconds = _best(lambda: write(path))
        rows.append(dict(benchmark="files", case=f"{case} size", width=width, height=height,
                         value=f"{os.path.getsize(path) / 2**20:.2f}", unit="MiB", note=note))
        rows.append(dict(benchmark="files", case=f"{case} write", width=width, height=height,
                         value=f"{seconds * 1e3:.0f}", unit="ms", note=note))
    rows.append(dict(benchmark="files", case="buffers compute", width=width, height=height,
                     value=f"{frame.timings['buffers'] * 1e3:.0f}", unit="ms", note=note))
    return rows


def bench_png(width, height):
    import zlib

    import numba

    import raycast_shade as rs
    from raycast_shade.output.quantize import to_uint8_table
    from raycast_shade.output.tonemap import to_uint8

    image = rs.render(_scene(width, height)).image
    rows = []

    def add(case, fn, size=None):
        fn()
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        rows.append(dict(benchmark="png", case=f"{case} time", width=width, height=height,
                         value=f"{np.median(times) * 1e3:.1f}", unit="ms", note="median of 5, one thread"))
        if size is not None:
            rows.append(dict(benchmark="png", case=f"{case} size", width=width, height=height,
                             value=f"{size / 2**20:.3f}", unit="MiB", note="IDAT of a rendered frame"))

    before = numba.get_num_threads()
    numba.set_num_threads(1)  # as on a view set's writer thread
    try:
        add("to_uint8 (curve)", lambda: to_uint8(image))
        add("to_uint8_table", lambda: to_uint8_table(image))
    finally:
        numba.set_num_threads(before)
    rgb = to_uint8(image)
    h, w, _ = rgb.shape
    flat = rgb.reshape(h, 3 * w)
    raw = np.empty((h, 3 * w + 1), np.uint8)
    raw[:, 0], raw[:, 1:4] = 1, flat[:, :3]  # PNG's Sub filter, as png_bytes writes
    np.subtract(flat[:, 3:], flat[:, :-3], out=raw[:, 4:])
    codecs = {f"zlib {lv}": (lambda lv=lv: zlib.compress(raw, lv)) for lv in (1, 6)}
    try:
        from isal import isal_zlib

        codecs.update({f"isal {lv}": (lambda lv=lv: isal_zlib.compress(raw, lv)) for lv in (0, 1, 2, 3)})
    except ImportError:
        pass
    for case, fn in codecs.items():
        add(f"deflate {case}", fn, len(fn()))
    return rows


def bench_cost(tmp, width, height, repeats=5, level=6):
    import statistics

    import raycast_shade as rs
    from benchmarks.bench_peers import make_mesh, make_scene
    from raycast_shade.apps import views as views_mod
    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.viewplan import file_hasher
    from raycast_shade.output.bufferfile import npz_into
    from raycast_shade.output.buffers import check_buffers
    from raycast_shade.output.imagefile import png_bytes, write_hashed
    from raycast_shade.output.labels import view_objects
    from raycast_shade.output.quantize import to_uint8_table

    scene = make_scene(make_mesh("icosphere", level), width, height)
    names = check_buffers(("zdepth", "normal", "id", "mask"))
    frame = rs.render(scene, buffers=names)
    rgb = to_uint8_table(frame.image)
    cams = orbit_cameras(scene.camera, 3)
    f = lambda name: os.path.join(tmp, name)  # noqa: E731
    files = {}

    def npz(name, level):  # as a view writes it: atomically, hashed for the record as it is written
        write_hashed(f(name), lambda fh: npz_into(fh, frame.buffers, camera=frame.camera, compressed=level),
                     file_hasher())
        files[name] = f(name)

    def hashed(name):
        if name + " bytes" not in files:
            files[name + " bytes"] = blob(name)
        file_hasher().update(files[name + " bytes"])

    def blob(*names):
        return b"".join(open(files[n], "rb").read() for n in names)

    def floor():
        if "floor" not in files:
            with open(f("i.png"), "wb") as fh:
                fh.write(png_bytes(rgb, fast=True))
            files["i.png"] = f("i.png")
            files["floor"] = blob("i.png", "z.npz")
        with open(f("floor.bin"), "wb") as fh:
            fh.write(files["floor"])

    def fresh():
        for a in [frame.image, *frame.buffers.values()]:
            np.empty(a.shape, a.dtype).fill(0)

    def view_set(overlap):
        def run():
            real = views_mod._two_frames_fit
            views_mod._two_frames_fit = lambda jobs, memory: overlap
            try:
                views_mod.render_views(scene, cams, f("set"), files=views_mod.ViewFiles(compression="zip"),
                                       run=views_mod.RunOptions(resume=False), overwrite=True)
            finally:
                views_mod._two_frames_fit = real
        return run

    paths = {"frame": (lambda: rs.render(scene), 1),
             "render with the buffers": (lambda: rs.render(scene, buffers=names), 1),
             "8-bit pixels (table)": (lambda: to_uint8_table(frame.image), 1),
             "PNG deflate (ISA-L 2)": (lambda: png_bytes(rgb, fast=True), 1),
             "objects + RLE": (lambda: view_objects(frame.buffers["model_id"], frame.camera, rle=True), 1),
             "npz zip, hashed as written": (lambda: npz("z.npz", 1), 1),
             "npz stored, hashed as written": (lambda: npz("s.npz", False), 1),
             "SHA-256 alone, zip npz in memory": (lambda: hashed("z.npz"), 1),
             "SHA-256 alone, stored npz in memory": (lambda: hashed("s.npz"), 1),
             "PNG + zip npz, one plain write (floor)": (floor, 1),
             "fresh arrays (np.empty + fill)": (fresh, 1),
             "view, writer thread overlapping": (view_set(True), len(cams)),
             "view, no overlap": (view_set(False), len(cams))}
    wall = {k: [] for k in paths}
    cpu = {k: [] for k in paths}
    for r in range(repeats + 1):  # round 0: warm-up
        for name, (fn, per) in paths.items():
            c0, t0 = time.process_time(), time.perf_counter()
            fn()
            if r:
                wall[name].append((time.perf_counter() - t0) / per)
                cpu[name].append((time.process_time() - c0) / per)
    unit_wall, unit_cpu = statistics.median(wall["frame"]), statistics.median(cpu["frame"])
    sizes = {"npz zip, hashed as written": "z.npz", "npz stored, hashed as written": "s.npz",
             "PNG deflate (ISA-L 2)": "i.png"}
    rows = []
    for name in paths:
        w, c = statistics.median(wall[name]), statistics.median(cpu[name])
        size = f", {os.path.getsize(files[sizes[name]]) / 2**20:.2f} MiB" if name in sizes else ""
        rows.append(dict(benchmark="cost", case=f"{name} wall", width=width, height=height,
                         value=f"{w / unit_wall:.2f}", unit="x frame", note=f"{w * 1e3:.1f} ms{size}"))
        rows.append(dict(benchmark="cost", case=f"{name} cpu", width=width, height=height,
                         value=f"{c / unit_cpu:.2f}", unit="x frame", note=f"{c * 1e3:.1f} ms cpu"))
    return rows


def bench_views(tmp, width, height, views):
    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.batch import local_cluster
    from raycast_shade.apps.views import RunOptions, ViewFiles, render_views

    scene = _scene(width, height)
    cams = orbit_cameras(scene.camera, views)
    files = ViewFiles(buffers=("zdepth", "normal", "id"), formats=("npz",))
    render_views(scene, cams[:2], os.path.join(tmp, "warm"), files=files)
    rows = []
    t0 = time.perf_counter()
    render_views(scene, cams, os.path.join(tmp, "serial"), files=files)
    serial = time.perf_counter() - t0
    rows.append(dict(benchmark="views", case="serial", width=width, height=height,
                     value=f"{views / serial:.2f}", unit="views/s", note=f"{views} views, npz+png"))
    with local_cluster(2, numba_threads=1) as client:
        render_views(scene, cams[:4], os.path.join(tmp, "warm2"), files=files, run=RunOptions(scheduler=client))
        t0 = time.perf_counter()
        render_views(scene, cams, os.path.join(tmp, "dask"), files=files, run=RunOptions(scheduler=client))
        dask = time.perf_counter() - t0
    rows.append(dict(benchmark="views", case="2 workers", width=width, height=height,
                     value=f"{views / dask:.2f}", unit="views/s", note=f"{views} views, 1 Numba thread each"))
    return rows


def _pose(rng, distance=4.0):
    eye = rng.normal(size=3)
    eye *= distance / np.linalg.norm(eye)
    z = -eye / np.linalg.norm(eye)
    x = np.cross(z, rng.normal(size=3))
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    return R, -R @ eye


def bench_projection(width, height):
    import cv2

    import raycast_shade as rs

    mesh = rs.shapes.icosphere(2)
    scene = rs.Scene([rs.Model(mesh)], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                     camera=rs.Camera(eye=(0, 0, 4), width=width, height=height))
    faces_of = [set(np.flatnonzero((mesh.faces == i).any(axis=1))) for i in range(len(mesh.vertices))]
    rows = []
    rng = np.random.default_rng(0)
    for k in range(4):
        fx, fy = width * rng.uniform(0.8, 1.4), width * rng.uniform(0.8, 1.4)
        K = np.array([[fx, 0, width * rng.uniform(0.35, 0.65)], [0, fy, height * rng.uniform(0.35, 0.65)], [0, 0, 1]])
        R, t = _pose(rng)
        cam = rs.Camera.from_opencv(K, R, t, width, height)
        uv = cv2.projectPoints(mesh.vertices, cv2.Rodrigues(R)[0], t, K, None)[0].reshape(-1, 2)
        clip = (cam.projection_matrix(0.1, 100) @ cam.view_matrix() @ np.c_[mesh.vertices, np.ones(len(uv))].T).T
        gl = np.c_[(clip[:, 0] / clip[:, 3] + 1) * width / 2 - 0.5, (1 - clip[:, 1] / clip[:, 3]) * height / 2 - 0.5]
        eye = -R.T @ t
        to_eye = eye - mesh.vertices
        facing = np.einsum("ij,ij->i", mesh.vertices, to_eye) / np.linalg.norm(to_eye, axis=1) > 0.3
        px = np.rint(uv).astype(int)
        ok = facing & (px[:, 0] >= 0) & (px[:, 0] < width) & (px[:, 1] >= 0) & (px[:, 1] < height)
        for backend in ("raycast", "raster"):
            tri = rs.render(scene, camera=cam, backend=backend, buffers=("triangle_id",)).buffers["triangle_id"]
            wrong = sum(tri[px[i, 1], px[i, 0]] not in faces_of[i] for i in np.flatnonzero(ok))
            rows.append(dict(benchmark="projection", case=f"camera {k} {backend} wrong", width=width, height=height,
                             value=f"{wrong}/{int(ok.sum())}", unit="vertices",
                             note=f"fx={fx:.1f} fy={fy:.1f} cx={K[0, 2]:.1f} cy={K[1, 2]:.1f}"))
        rows.append(dict(benchmark="projection", case=f"camera {k} |OpenGL - OpenCV|", width=width, height=height,
                         value=f"{np.abs(gl - uv).max():.1e}", unit="px", note="projection_matrix vs cv2.projectPoints"))
    k_err = rt_err = t_err = 0.0
    for _ in range(1000):
        R, t = _pose(rng, rng.uniform(0.5, 50))
        K = np.array([[rng.uniform(50, 2000), 0, rng.uniform(-100, 2000)], [0, rng.uniform(50, 2000),
                      rng.uniform(-100, 1200)], [0, 0, 1]])
        K2, R2, t2 = rs.Camera.from_opencv(K, R, t, width, height).to_opencv()
        k_err, rt_err = max(k_err, np.abs(K2 - K).max()), max(rt_err, np.abs(R2 - R).max())
        t_err = max(t_err, np.abs(t2 - t).max() / max(1.0, np.abs(t).max()))
    for case, value in (("K round trip", k_err), ("R round trip", rt_err), ("t round trip (relative)", t_err)):
        rows.append(dict(benchmark="roundtrip", case=case, width="", height="", value=f"{value:.1e}", unit="abs",
                         note="1000 random poses"))
    return rows


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("views.csv", quick)]


PARTS = ("files", "png", "cost", "views", "projection")


def _run(part, tmp, quick):
    if part == "files":
        return bench_files(tmp, *((320, 180) if quick else (1920, 1080)))
    if part == "png":
        return bench_png(*((320, 180) if quick else (1920, 1080)))
    if part == "cost":
        if quick:
            return bench_cost(tmp, 160, 120, repeats=2, level=3)
        return bench_cost(tmp, 1920, 1080) + bench_cost(tmp, 640, 480)
    if part == "views":
        return bench_views(tmp, *((160, 120, 8) if quick else (640, 480, 32)))
    return bench_projection(*((96, 72) if quick else (320, 240)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes; untracked output")
    ap.add_argument("--only", default="", metavar="PARTS",
                    help=f"comma-separated parts to run ({', '.join(PARTS)}); their rows replace theirs in the CSV")
    args = ap.parse_args(argv)
    parts = [p for p in args.only.split(",") if p] or list(PARTS)
    bad = [p for p in parts if p not in PARTS]
    if bad:
        ap.error(f"--only: unknown part {bad[0]!r}; expected some of {', '.join(PARTS)}")
    out, = outputs(args.quick)
    kept = []
    if args.only and os.path.exists(out):  # the other parts' rows stay as they were
        with open(out, newline="") as fh:
            part_of = {"roundtrip": "projection"}  # bench_projection writes both
            kept = [r for r in csv.DictReader(fh) if part_of.get(r["benchmark"], r["benchmark"]) not in parts]
    tmp = tempfile.mkdtemp(prefix="bench_views_")
    try:
        rows = [r for part in parts for r in _run(part, tmp, args.quick)]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    for r in rows:
        print(f"{r['benchmark']:<10} {r['case']:<32} {r['width']!s:>5}x{r['height']!s:<5} {r['value']:>10} {r['unit']:<8} "
              f"{r['note']}")
    write_csv(out, kept + rows, FIELDS)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    main()
