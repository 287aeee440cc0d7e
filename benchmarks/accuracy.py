"""Speed against accuracy: every shading method against the exact image.

Run ``python -m benchmarks.accuracy [--quick]`` (or the whole suite with
``python -m benchmarks``). For each analytic surface (a unit sphere and a
torus with R = 1, r = 0.4) the ground truth is rendered exactly
(:mod:`raycast_shade.study.analytic`); the same scene is then rendered from
tessellations of increasing resolution (icosphere subdivisions, UV spheres
of N x 2N and tori of N x N/2 segments, all with exact vertex normals) with

* ``flat``, ``gouraud`` and ``phong`` shading of the Phong reflection model,
* ``blinn-phong``: Phong shading of the Blinn-Phong model (against the exact
  Blinn-Phong image),

for shininess t in {1, 8, 64, 512} at two resolutions. Each frame is timed
(median of repeats after a warm-up render, the repeats of the methods
interleaved; the JIT warm-up of the whole process is measured apart) and
compared on the pixels both images cover (:func:`raycast_shade.study.metrics.compare`).

Outputs (in ``quick/`` subfolders of the same folders in ``--quick`` mode, see
:mod:`benchmarks.outputs`):

* ``benchmarks/results/accuracy.csv``: one row per frame;
* ``benchmarks/results/accuracy_orders.csv``: fitted convergence orders,
  slope of log RMSE against log of the angular step (the mean angle between
  the exact normals at an edge's ends), over all levels, over the levels with
  ``step <= 1/sqrt(t)`` ("asymptotic") and over the three finest levels;
* ``benchmarks/results/accuracy_peers.csv``: the same Phong frames by other
  pipelines in the same process (naive NumPy + embreex on one thread,
  trimesh's embree ray interface, Open3D's RaycastingScene + our kernels),
  with time ratios against ours;
* ``benchmarks/results/accuracy_meta.csv``: warm-up time, run time, versions;
* ``docs/images/speed_vs_accuracy.png`` (RMSE against median frame time,
  icosphere levels, one curve per method, Pareto front marked) and
  ``docs/images/convergence.png`` (RMSE against the angular step, fitted
  slopes in the legend);
* the block of fitted orders in ``docs/accuracy.md`` (full runs only, and not
  with ``--no-docs``).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import platform
import sys
import time
from dataclasses import dataclass

import numpy as np

from raycast_shade.visibility.accel import embreex_scene

from benchmarks.outputs import ROOT, images_dir as _images_dir, results_dir as _results_dir

ACCURACY_DOC = os.path.join(ROOT, "docs", "accuracy.md")
CSV_NAMES = {"rows": "accuracy.csv", "orders": "accuracy_orders.csv", "peers": "accuracy_peers.csv",
             "meta": "accuracy_meta.csv"}
IMAGE_NAMES = ("speed_vs_accuracy.png", "convergence.png")

# method -> (shading mode, specular model)
METHODS = {
    "flat": ("flat", "phong"),
    "gouraud": ("gouraud", "phong"),
    "phong": ("phong", "phong"),
    "blinn-phong": ("phong", "blinn"),
}
SHININESS = (1.0, 8.0, 64.0, 512.0)
COLORS = {"flat": "tab:red", "gouraud": "tab:orange", "phong": "tab:blue", "blinn-phong": "tab:green"}

ROW_KEYS = [
    "shape", "family", "mesh", "faces", "dtheta", "method", "shading", "specular", "shininess", "width", "height",
    "build_s", "first_frame_s", "median_s", "min_s", "repeats",
    "rmse", "rmse_interior", "psnr", "max_error", "ssim", "flip", "mean_angle", "p95_angle", "highlight", "n_common", "only_ref",
    "only_test",
]
ORDER_KEYS = ["shape", "family", "method", "shininess", "width", "metric", "fit", "n_points", "dtheta_min", "dtheta_max",
              "order", "stderr", "threshold"]
PEER_KEYS = ["pipeline", "mesh", "faces", "method", "shininess", "width", "height", "setup_s", "median_s", "ratio",
             "min_s", "ratio_min", "max_diff_vs_ours", "coverage_mismatch", "rmse_vs_exact", "note"]


@dataclass(frozen=True)
class Config:
    """What one run covers."""

    quick: bool
    resolutions: tuple
    ico_levels: tuple
    uv_rings: tuple  # uv_sphere(rings=N, segments=2N)
    torus_segments: tuple  # torus(major_segments=N, minor_segments=N // 2)
    repeats: int
    peer_levels: tuple
    peer_shininess: float
    flip_resolution: int  # FLIP (0.15 s a frame at 64^2, 1 s at 512^2): icospheres at this resolution only; 0: never
    shininess: tuple = SHININESS


QUICK = Config(quick=True, resolutions=(64, 128), ico_levels=(0, 1, 2, 3, 4, 5), uv_rings=(4, 8, 16, 32),
               torus_segments=(8, 16, 32, 64), repeats=5, peer_levels=(3, 5), peer_shininess=64.0,
               flip_resolution=0)
FULL = Config(quick=False, resolutions=(256, 512), ico_levels=(0, 1, 2, 3, 4, 5, 6, 7), uv_rings=(4, 8, 16, 32, 64, 128),
              torus_segments=(8, 16, 32, 64, 128, 256), repeats=7, peer_levels=(3, 5, 7), peer_shininess=64.0,
              flip_resolution=256)


# -- the scenes ----------------------------------------------------------------------------------------

def surfaces():
    """The analytic shapes and the camera that frames each: name -> (surface, eye, fov)."""
    from raycast_shade.study.analytic import Sphere, Torus

    return {
        "sphere": (Sphere(), (0.0, 0.0, 4.0), 35.0),
        "torus": (Torus(major_radius=1.0, minor_radius=0.4), (0.0, 2.2, 3.2), 42.0),
    }


def lights():
    import raycast_shade as rs

    return (rs.PointLight((3.0, 4.0, 5.0), intensity=1.0),)


AMBIENT = 0.1


def material(shininess, specular):
    import raycast_shade as rs

    return rs.Material(kd=0.6, ka=1.0, ks=0.4, shininess=float(shininess), specular=specular)


def camera(shape, res):
    import raycast_shade as rs

    _, eye, fov = surfaces()[shape]
    return rs.Camera(eye=eye, target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov=fov, width=res, height=res)


def mesh_cases(cfg: Config):
    """(shape, family, label, factory) for every tessellation in the run."""
    from raycast_shade import shapes

    out = []
    for k in cfg.ico_levels:
        out.append(("sphere", "icosphere", f"icosphere{k}", lambda k=k: shapes.icosphere(k)))
    for n in cfg.uv_rings:
        out.append(("sphere", "uv_sphere", f"uv_sphere{n}x{2 * n}", lambda n=n: shapes.uv_sphere(n, 2 * n)))
    for n in cfg.torus_segments:
        out.append(("torus", "torus", f"torus{n}x{n // 2}",
                    lambda n=n: shapes.torus(1.0, 0.4, n, max(3, n // 2))))
    return out


# -- timing ----------------------------------------------------------------------------------------------

def warm_up():
    """Compile (or load from cache) every kernel the run uses; seconds, per part."""
    import raycast_shade as rs
    from raycast_shade.study import metrics
    from raycast_shade.study.analytic import Sphere, Torus, render_exact

    out = {}
    cam = rs.Camera(eye=(0.0, 0.0, 4.0), width=16, height=16)
    t0 = time.perf_counter()
    render_exact([(Sphere(), material(8, "phong")), (Torus(center=(3, 0, 0)), material(8, "blinn"))], cam, lights())
    out["exact"] = time.perf_counter() - t0
    for spec in ("phong", "blinn"):
        scene = rs.Scene([rs.Model(rs.shapes.icosphere(1), material(8, spec))], lights=lights(), camera=cam,
                         ambient=AMBIENT)
        for mode in ("flat", "gouraud", "phong"):
            t0 = time.perf_counter()
            frame = rs.render(scene, mode)
            frame.normal  # noqa: B018 - compiles the normals kernel
            out[f"{mode}/{spec}"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    try:
        metrics.compare(frame, frame)
    except metrics.MissingExtraError:
        pass
    out["metrics"] = time.perf_counter() - t0
    return out


# -- the sweep ---------------------------------------------------------------------------------------------

def _have_flip():
    import importlib.util

    return importlib.util.find_spec("flip_evaluator") is not None


def sweep(cfg: Config, progress: bool = True):
    """Render and compare every case; one dict per frame (see ``ROW_KEYS``)."""
    import raycast_shade as rs
    from raycast_shade.study import metrics
    from raycast_shade.study.analytic import render_exact

    from tqdm.auto import tqdm

    shapes_ = surfaces()
    use_flip = _have_flip()
    exact = {}

    def reference(shape, spec, t, res):
        key = (shape, spec, t, res)
        if key not in exact:
            surface = shapes_[shape][0]
            exact[key] = render_exact([(surface, material(t, spec))], camera(shape, res), lights(), AMBIENT)
        return exact[key]

    cases = mesh_cases(cfg)
    total = len(cases) * len(cfg.shininess) * len(cfg.resolutions) * len(METHODS)
    rows = []
    bar = tqdm(total=total, desc="accuracy", unit="frame", disable=not progress, file=sys.stderr)
    for shape, family, label, factory in cases:
        mesh = factory()
        dtheta = metrics.angular_step(mesh)
        faces = len(mesh.faces)
        for t in cfg.shininess:
            for spec in ("phong", "blinn"):
                methods = [m for m, (_, s) in METHODS.items() if s == spec]
                scene = rs.Scene([rs.Model(mesh, material(t, spec))], lights=lights(), ambient=AMBIENT)
                for res in cfg.resolutions:
                    cam = camera(shape, res)
                    ref = reference(shape, spec, t, res)
                    first, first_s = {}, {}
                    for method in methods:  # warm-up; the scene's first frame also builds its BVH
                        t0 = time.perf_counter()
                        first[method] = rs.render(scene, METHODS[method][0], camera=cam)
                        first_s[method] = time.perf_counter() - t0
                    # Repeats interleaved across the methods, so that a burst of load
                    # elsewhere on a shared machine hits them all alike.
                    times = {m: [] for m in methods}
                    last = {}
                    for _ in range(cfg.repeats):
                        for method in methods:
                            t0 = time.perf_counter()
                            last[method] = rs.render(scene, METHODS[method][0], camera=cam)
                            times[method].append(time.perf_counter() - t0)
                    for method in methods:
                        flip = use_flip and res == cfg.flip_resolution and family == "icosphere"
                        cmp = metrics.compare(ref, last[method], use_flip=flip)
                        rows.append(dict(
                            shape=shape, family=family, mesh=label, faces=faces, dtheta=dtheta, method=method,
                            shading=METHODS[method][0], specular=spec, shininess=t, width=res, height=res,
                            build_s=first[method].timings.get("build", 0.0), first_frame_s=first_s[method],
                            median_s=float(np.median(times[method])), min_s=float(np.min(times[method])),
                            repeats=cfg.repeats, **_metric_fields(cmp)))
                        bar.update(1)
    bar.close()
    return rows


def _metric_fields(cmp):
    d = cmp.as_dict()
    return {k: d[k] for k in ("rmse", "rmse_interior", "psnr", "max_error", "ssim", "flip", "mean_angle", "p95_angle", "highlight",
                              "n_common", "only_ref", "only_test")}


# -- convergence orders ------------------------------------------------------------------------------------

def fit_orders(rows, metrics_=("rmse", "rmse_interior")):
    """Fitted orders of each error metric against the angular step, one dict
    per fit (see ``ORDER_KEYS``)."""
    from raycast_shade.study.metrics import convergence_order

    groups = {}
    for r in rows:
        groups.setdefault((r["shape"], r["family"], r["method"], r["shininess"], r["width"]), []).append(r)
    out = []
    for (shape, family, method, t, width), rs_ in sorted(groups.items()):
        rs_ = sorted(rs_, key=lambda r: -r["dtheta"])
        threshold = 1.0 / math.sqrt(t)
        subsets = {
            "all": rs_,
            "asymptotic": [r for r in rs_ if r["dtheta"] <= threshold],
            "finest3": rs_[-3:],
        }
        for metric in metrics_:
            for fit, sub in subsets.items():
                x = [r["dtheta"] for r in sub]
                y = [r[metric] for r in sub]
                order, err = convergence_order(x, y) if len(sub) >= 2 else (math.nan, math.nan)
                out.append(dict(shape=shape, family=family, method=method, shininess=t, width=width, metric=metric,
                                fit=fit, n_points=len(sub), dtheta_min=min(x) if x else math.nan,
                                dtheta_max=max(x) if x else math.nan, order=order, stderr=err,
                                threshold=threshold))
    return out


# -- peers -------------------------------------------------------------------------------------------------

def _hitbuffer(h, w, prim, u, v, t, miss):
    from raycast_shade.visibility.hits import HitBuffer

    prim = np.where(miss, -1, prim).astype(np.int32).reshape(h, w)
    return HitBuffer(prim=prim, geom=np.where(prim >= 0, 0, -1).astype(np.int32),
                     u=np.where(miss, 0.0, u).astype(np.float32).reshape(h, w),
                     v=np.where(miss, 0.0, v).astype(np.float32).reshape(h, w),
                     t=np.where(miss, np.inf, t).astype(np.float32).reshape(h, w))


def _numpy_shading():
    """The NumPy shading twin, or None."""
    try:
        from raycast_shade.study.reference import shade_reference
    except ImportError:
        return None
    return shade_reference


def peer_pipelines(scene, cam, mode):
    """name -> (setup seconds, frame function) or the reason it is skipped.

    Each frame function renders the whole frame (rays, cast, shading) and
    returns the (H, W, 3) image and its (H, W) coverage mask.
    """
    from raycast_shade.study.twins import generate_rays_numpy
    from raycast_shade.visibility.rays import generate_rays
    from raycast_shade.shading.shade import shade

    geo = scene.geometry
    h, w = cam.height, cam.width
    out = {}
    numpy_shade = _numpy_shading()

    # 1. naive: NumPy rays, embreex's run on one thread, NumPy shading.
    if numpy_shade is None:
        out["naive"] = "raycast_shade.study.reference (the NumPy shading) is not available"
    else:
        t0 = time.perf_counter()
        ex_scene = embreex_scene(geo)
        setup = time.perf_counter() - t0

        def naive():
            o, d = generate_rays_numpy(cam, geo.origin)
            res = ex_scene.run(o.astype(np.float32), d.astype(np.float32), output=1)
            miss = res["geomID"] < 0
            hits = _hitbuffer(h, w, res["primID"], res["u"], res["v"], res["tfar"], miss)
            return numpy_shade(scene, cam, hits, mode), hits.mask

        out["naive"] = (setup, naive)

    # 2. trimesh's ray interface (embree backend), NumPy shading.
    try:
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector
    except ImportError as exc:
        out["trimesh"] = f"trimesh's embree ray interface is not available ({exc})"
    else:
        if numpy_shade is None:
            out["trimesh"] = "raycast_shade.study.reference (the NumPy shading) is not available"
        else:
            t0 = time.perf_counter()
            tm = trimesh.Trimesh(geo.vertices, geo.local_faces, process=False)
            inter = RayMeshIntersector(tm)
            inter.intersects_any(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))  # builds its BVH
            setup = time.perf_counter() - t0

            def via_trimesh():
                o, d = generate_rays_numpy(cam, geo.origin)
                tri, ray, loc = inter.intersects_id(o, d, multiple_hits=False, return_locations=True)
                bc = trimesh.triangles.points_to_barycentric(tm.triangles[tri], loc)
                n = h * w
                prim = np.full(n, -1, np.int64)
                u = np.zeros(n)
                v = np.zeros(n)
                t = np.full(n, np.inf)
                prim[ray] = tri
                u[ray] = bc[:, 1]
                v[ray] = bc[:, 2]
                t[ray] = np.linalg.norm(loc - o[ray], axis=1)
                hits = _hitbuffer(h, w, prim, u, v, t, prim < 0)
                return numpy_shade(scene, cam, hits, mode), hits.mask

            out["trimesh"] = (setup, via_trimesh)

    # 3. Open3D's RaycastingScene, our shading kernels.
    try:
        import open3d as o3d
    except ImportError as exc:
        out["open3d"] = (f"open3d is not installed ({exc}): pip install 'raycast_shade[peers]' "
                         "(on Debian also apt-get install -y libusb-1.0-0)")
    else:
        t0 = time.perf_counter()
        o3 = o3d.t.geometry.RaycastingScene()
        o3.add_triangles(o3d.core.Tensor(geo.vertices.astype(np.float32)),
                         o3d.core.Tensor(geo.local_faces.astype(np.uint32)))
        o3.cast_rays(o3d.core.Tensor(np.array([[0, 0, 0, 0, 0, 1]], np.float32)))  # builds its BVH
        setup = time.perf_counter() - t0
        invalid = o3d.t.geometry.RaycastingScene.INVALID_ID

        def via_open3d():
            o, d = generate_rays(cam, geo.origin)
            ans = o3.cast_rays(o3d.core.Tensor(np.concatenate([o, d], axis=1)))
            prim = ans["primitive_ids"].numpy().astype(np.int64)
            uv = ans["primitive_uvs"].numpy()
            miss = prim == invalid
            hits = _hitbuffer(h, w, prim, uv[:, 0], uv[:, 1], ans["t_hit"].numpy(), miss)
            return shade(scene, cam, hits, mode), hits.mask

        out["open3d"] = (setup, via_open3d)
    return out


def peers(cfg: Config, progress: bool = True):
    """Our Phong frames against the peer pipelines, same scene, same process."""
    import raycast_shade as rs
    from raycast_shade import shapes
    from raycast_shade.study import metrics
    from raycast_shade.study.analytic import render_exact

    from tqdm.auto import tqdm

    t = cfg.peer_shininess
    sphere = surfaces()["sphere"][0]
    rows = []
    notes_done = set()
    jobs = [(k, res) for k in cfg.peer_levels for res in cfg.resolutions]
    for k, res in tqdm(jobs, desc="peers", unit="case", disable=not progress, file=sys.stderr):
        mesh = shapes.icosphere(k)
        scene = rs.Scene([rs.Model(mesh, material(t, "phong"))], lights=lights(), ambient=AMBIENT)
        cam = camera("sphere", res)
        ref = render_exact([(sphere, material(t, "phong"))], cam, lights(), AMBIENT)
        first = rs.render(scene, "phong", camera=cam)  # builds the BVH

        def ours_fn():
            frame = rs.render(scene, "phong", camera=cam)
            return frame.image, frame.mask

        base = dict(mesh=f"icosphere{k}", faces=len(mesh.faces), method="phong", shininess=t, width=res, height=res)
        fns = {"raycast_shade": (first.timings.get("build", math.nan), ours_fn)}
        for name, item in peer_pipelines(scene, cam, "phong").items():
            if isinstance(item, str):
                if name not in notes_done:
                    print(f"accuracy: peer {name!r} skipped: {item}", file=sys.stderr)
                    notes_done.add(name)
                rows.append(dict(base, pipeline=name, setup_s=math.nan, median_s=math.nan, ratio=math.nan,
                                 min_s=math.nan, ratio_min=math.nan, max_diff_vs_ours=math.nan,
                                 coverage_mismatch=-1, rmse_vs_exact=math.nan, note=f"skipped: {item}"))
            else:
                fns[name] = item
        # Warm every pipeline, then interleave the repeats across them (fair under bursts of load).
        out = {name: fn() for name, (_, fn) in fns.items()}
        times = {name: [] for name in fns}
        for _ in range(cfg.repeats):
            for name, (_, fn) in fns.items():
                t0 = time.perf_counter()
                out[name] = fn()
                times[name].append(time.perf_counter() - t0)
        ours_img, ours_mask = out["raycast_shade"]
        ours_med = float(np.median(times["raycast_shade"]))
        ours_min = float(np.min(times["raycast_shade"]))
        for name, (setup, _) in fns.items():
            img, cover = out[name]
            img = np.asarray(img, np.float64)
            common = cover & ours_mask  # a silhouette pixel hit by one caster only is counted apart
            med = float(np.median(times[name]))
            mn = float(np.min(times[name]))
            rows.append(dict(
                base, pipeline=name, setup_s=setup, median_s=med, ratio=med / ours_med, min_s=mn,
                ratio_min=mn / ours_min,
                max_diff_vs_ours=float(np.max(np.abs(img[common] - ours_img[common]))) if common.any() else 0.0,
                coverage_mismatch=int(np.count_nonzero(cover != ours_mask)),
                rmse_vs_exact=metrics.rmse(ref.image, img, cover & ref.mask), note=""))
    return rows


# -- output --------------------------------------------------------------------------------------------

def _fmt(v):
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return f"{v:.6g}"
    return v


def write_csv(rows, keys, path):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        wr.writeheader()
        for r in rows:
            wr.writerow({k: _fmt(r.get(k, "")) for k in keys})


def read_csv(path):
    """Rows of a CSV written here, numbers parsed back."""
    def conv(v):
        try:
            return int(v)
        except ValueError:
            try:
                return float(v)
            except ValueError:
                return v

    with open(path, newline="") as fh:
        return [{k: conv(v) for k, v in r.items()} for r in csv.DictReader(fh)]


def pareto(points):
    """Indices of the points no other point beats in both time and error.

    Parameters
    ----------
    points : (N, 2) float
        ``(time, error)``.

    Returns
    -------
    list of int
        Sorted by time.
    """
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    out = []
    best = math.inf
    for i in order:
        if points[i][1] < best:
            out.append(i)
            best = points[i][1]
    return out


def _log_axes(ax):
    """Log-log with short labels at 1, 2 and 5 times powers of ten (matplotlib's
    default minor labels overlap on ranges shorter than a decade)."""
    from matplotlib.ticker import FuncFormatter, LogLocator

    ax.set_xscale("log")
    ax.set_yscale("log")
    fmt = FuncFormatter(lambda v, _: f"{v:g}")
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(base=10.0, numticks=12))
        axis.set_minor_locator(LogLocator(base=10.0, subs=(2.0, 5.0), numticks=12))
        axis.set_major_formatter(fmt)
        axis.set_minor_formatter(fmt)
    ax.tick_params(axis="both", which="both", labelsize=7)


def chart_speed(rows, path):
    """RMSE against median frame time, icosphere levels: panels per resolution x shininess."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ico = [r for r in rows if r["family"] == "icosphere"]
    ress = sorted({r["width"] for r in ico})
    ts = sorted({r["shininess"] for r in ico})
    fig, axes = plt.subplots(len(ress), len(ts), figsize=(3.6 * len(ts), 3.3 * len(ress)), squeeze=False)
    for i, res in enumerate(ress):
        for j, t in enumerate(ts):
            ax = axes[i, j]
            pts, sel = [], [r for r in ico if r["width"] == res and r["shininess"] == t and r["rmse"] > 0]
            for method in METHODS:
                rr = sorted([r for r in sel if r["method"] == method], key=lambda r: r["faces"])
                if not rr:
                    continue
                x = [1e3 * r["median_s"] for r in rr]
                y = [r["rmse"] for r in rr]
                ax.plot(x, y, "o-", ms=3.5, lw=1.2, color=COLORS[method], label=method)
                for r, xx, yy in zip(rr, x, y):
                    if method == "phong":
                        ax.annotate(r["mesh"].replace("icosphere", "L"), (xx, yy), fontsize=6, alpha=0.7,
                                    xytext=(2, 2), textcoords="offset points")
            pts = [(1e3 * r["median_s"], r["rmse"]) for r in sel]
            if pts:
                front = [pts[k] for k in pareto(pts)]
                ax.step([p[0] for p in front], [p[1] for p in front], where="post", color="k", lw=0.8, ls="--",
                        label="Pareto front")
                ax.plot([p[0] for p in front], [p[1] for p in front], "o", mfc="none", mec="k", ms=7, mew=0.8)
            _log_axes(ax)
            ax.set_title(f"{res}x{res}, t = {t:g}", fontsize=9)
            ax.grid(True, which="both", alpha=0.25)
            if i == len(ress) - 1:
                ax.set_xlabel("median frame time (ms)")
            if j == 0:
                ax.set_ylabel("RMSE vs exact sphere")
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    fig.suptitle("Speed against accuracy: icosphere levels (L0...), linear-image RMSE on common pixels", fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def chart_convergence(rows, orders, path):
    """RMSE against angular step per family x shininess (highest resolution), fitted slopes in the legends."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res = max(r["width"] for r in rows)
    fams = [f for f in ("icosphere", "uv_sphere", "torus") if any(r["family"] == f for r in rows)]
    ts = sorted({r["shininess"] for r in rows})
    fig, axes = plt.subplots(len(fams), len(ts), figsize=(3.6 * len(ts), 3.1 * len(fams)), squeeze=False)
    slope = {(o["family"], o["method"], o["shininess"], o["width"], o["fit"]): o["order"] for o in orders
             if o.get("metric", "rmse") == "rmse"}
    for i, fam in enumerate(fams):
        for j, t in enumerate(ts):
            ax = axes[i, j]
            for method in METHODS:
                rr = sorted([r for r in rows if r["family"] == fam and r["shininess"] == t and r["width"] == res
                             and r["method"] == method and r["rmse"] > 0], key=lambda r: r["dtheta"])
                if not rr:
                    continue
                p = slope.get((fam, method, t, res, "asymptotic"), math.nan)
                q = slope.get((fam, method, t, res, "finest3"), math.nan)
                lab = f"{method}: {p:.2f}" if not math.isnan(p) else f"{method}: ({q:.2f})"
                ax.plot([r["dtheta"] for r in rr], [r["rmse"] for r in rr], "o-", ms=3.5, lw=1.2,
                        color=COLORS[method], label=lab)
            ax.axvline(1.0 / math.sqrt(t), color="gray", lw=0.8, ls=":")
            _log_axes(ax)
            ax.set_title(f"{fam}, t = {t:g}", fontsize=9)
            ax.grid(True, which="both", alpha=0.25)
            ax.legend(fontsize=6.5, title="order", title_fontsize=6.5)
            if i == len(fams) - 1:
                ax.set_xlabel("angular step (rad)")
            if j == 0:
                ax.set_ylabel(f"RMSE ({res}x{res})")
    fig.suptitle("Convergence: slope over steps <= 1/sqrt(t) (dotted); in parentheses: the three finest steps",
                 fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


# -- markdown ------------------------------------------------------------------------------------------

def _table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def _o(v):
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.2f}"


def orders_markdown(orders, metric="rmse"):
    """The table of fitted orders of ``metric`` (highest resolution), asymptotic
    fit with the three-finest fit in parentheses."""
    orders = [o for o in orders if o.get("metric", "rmse") == metric]
    if not orders:
        return "_no fitted orders_"
    res = max(o["width"] for o in orders)
    ts = sorted({o["shininess"] for o in orders})
    look = {(o["family"], o["method"], o["shininess"], o["fit"]): o for o in orders if o["width"] == res}
    rows = []
    for fam in ("icosphere", "uv_sphere", "torus"):
        for method in METHODS:
            if (fam, method, ts[0], "all") not in look:
                continue
            cells = []
            for t in ts:
                a = look.get((fam, method, t, "asymptotic"), {}).get("order", math.nan)
                f = look.get((fam, method, t, "finest3"), {}).get("order", math.nan)
                cells.append(f"{_o(a)} ({_o(f)})")
            rows.append([fam, method] + cells)
    what = {"rmse": "RMSE (all common pixels)",
            "rmse_interior": "interior RMSE (common pixels more than 2 pixels inside the silhouette)"}.get(metric, metric)
    return (f"Fitted order p in error ~ C Δθ^p of the {what} at {res}x{res}: over the steps Δθ <= 1/sqrt(t) "
            "(– where fewer than two levels qualify), and in parentheses over the three finest levels.\n\n"
            + _table(["mesh", "method"] + [f"t = {t:g}" for t in ts], rows))


def summary_markdown(results_dir=None, suffix=""):
    """The accuracy section of ``docs/benchmarks.md``, from the CSVs of a run (default: the full run's)."""
    results_dir = _results_dir(False) if results_dir is None else results_dir
    path = os.path.join(results_dir, f"accuracy{suffix}.csv")
    if not os.path.exists(path):
        return "_accuracy benchmark: no results yet (run `python -m benchmarks.accuracy`)._\n"
    rows = read_csv(path)
    parts = []
    meta_path = os.path.join(results_dir, f"accuracy_meta{suffix}.csv")
    if os.path.exists(meta_path):
        meta = {r["key"]: r["value"] for r in read_csv(meta_path)}
        parts.append(f"Mode: {'quick' if meta.get('quick') in (1, '1', 'True', True) else 'full'}; "
                     f"{meta.get('frames', '?')} frames in {float(meta.get('run_s', math.nan)):.0f} s; "
                     f"JIT warm-up (compile or cache load) {float(meta.get('warmup_s', math.nan)):.1f} s, "
                     "not in any frame time.")
    orders_path = os.path.join(results_dir, f"accuracy_orders{suffix}.csv")
    if os.path.exists(orders_path):
        fits = read_csv(orders_path)
        parts.append(orders_markdown(fits, "rmse"))
        parts.append(orders_markdown(fits, "rmse_interior"))
    # The cheapest way to reach an error, per method (icosphere, highest resolution).
    res = max(r["width"] for r in rows)
    t_mid = 64.0 if any(r["shininess"] == 64.0 for r in rows) else rows[0]["shininess"]
    targets = (1e-2, 3e-3, 1e-3)
    trows = []
    for method in METHODS:
        cells = []
        for tol in targets:
            ok = [r for r in rows if r["family"] == "icosphere" and r["width"] == res and r["shininess"] == t_mid
                  and r["method"] == method and r["rmse"] <= tol]
            if ok:
                best = min(ok, key=lambda r: r["median_s"])
                cells.append(f"{1e3 * best['median_s']:.2f} ms ({best['mesh'].replace('icosphere', 'L')})")
            else:
                cells.append("not reached")
        trows.append([method] + cells)
    parts.append(f"Fastest frame reaching an RMSE, icosphere, {res}x{res}, t = {t_mid:g} (level in parentheses):\n\n"
                 + _table(["method"] + [f"RMSE <= {tol:g}" for tol in targets], trows))
    peers_path = os.path.join(results_dir, f"accuracy_peers{suffix}.csv")
    if os.path.exists(peers_path):
        prs = read_csv(peers_path)
        prow = []
        for r in prs:
            if isinstance(r["note"], str) and r["note"].startswith("skipped"):
                continue
            prow.append([r["pipeline"], r["mesh"], f"{r['width']}x{r['height']}", f"{1e3 * r['median_s']:.2f}",
                         f"{r['ratio']:.2f}", f"{r.get('ratio_min', math.nan):.2f}", f"{r['max_diff_vs_ours']:.1e}", r.get("coverage_mismatch", ""),
                         f"{r['rmse_vs_exact']:.2e}"])
        skipped = sorted({(r["pipeline"], r["note"]) for r in prs if isinstance(r["note"], str) and r["note"]})
        parts.append("Peers, Phong frame, same scene and process (ratio = peer time / ours, of the medians and of "
                     "the fastest repeats; on a loaded machine our two-thread kernels lose more to contention than "
                     "the single-threaded peers, and the ratio of the minima is the steadier one):\n\n"
                     + _table(["pipeline", "mesh", "size", "median ms", "ratio", "ratio of minima", "max abs diff vs ours",
                               "pixels hit by one only", "RMSE vs exact"], prow)
                     + "".join(f"\n\n{p}: {n}" for p, n in skipped))
    return "\n\n".join(parts) + "\n"


def update_accuracy_doc(orders, path=ACCURACY_DOC):
    """Replace the generated block of fitted orders in ``docs/accuracy.md``."""
    begin, end = "<!-- orders:begin -->", "<!-- orders:end -->"
    if not os.path.exists(path):
        return
    with open(path) as fh:
        text = fh.read()
    if begin not in text or end not in text:
        return
    block = f"{begin}\n{orders_markdown(orders, 'rmse')}\n\n{orders_markdown(orders, 'rmse_interior')}\n{end}"
    a = text.index(begin)
    b = text.index(end) + len(end)
    with open(path, "w") as fh:
        fh.write(text[:a] + block + text[b:])


# -- driver --------------------------------------------------------------------------------------------

def _versions():
    out = {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count()}
    for mod in ("numpy", "numba", "embreex", "trimesh", "skimage", "flip_evaluator", "open3d"):
        try:
            m = __import__(mod)
            out[mod] = getattr(m, "__version__", "installed")
        except Exception:  # noqa: BLE001 - optional: record absence, whatever the reason
            out[mod] = "not installed"
    return out


def outputs(quick: bool, results_dir: str | None = None, images_dir: str | None = None) -> list[str]:
    """The CSVs, then the charts, that :func:`run` writes (default folders: :mod:`benchmarks.outputs`)."""
    results_dir = _results_dir(quick) if results_dir is None else results_dir
    images_dir = _images_dir(quick) if images_dir is None else images_dir
    return ([os.path.join(results_dir, name) for name in CSV_NAMES.values()]
            + [os.path.join(images_dir, name) for name in IMAGE_NAMES])


def run(quick: bool = False, progress: bool = True, results_dir: str | None = None, images_dir: str | None = None,
        docs: bool = True, with_peers: bool = True) -> dict:
    """Run the benchmark and write its files (:func:`outputs`).

    Returns
    -------
    dict
        ``csv`` and ``images``: lists of the paths written; ``orders``: the fits.
    """
    from raycast_shade.study.metrics import MissingExtraError

    cfg = QUICK if quick else FULL
    t_start = time.perf_counter()
    import importlib.util

    for module, package in (("skimage", "scikit-image"), ("tqdm", "tqdm"), ("matplotlib", "matplotlib")):
        if importlib.util.find_spec(module) is None:
            raise MissingExtraError(f"the accuracy benchmark needs the 'bench' extra ({package} is missing): "
                                    "pip install 'raycast_shade[bench]'")
    warm = warm_up()
    rows = sweep(cfg, progress)
    orders = fit_orders(rows)
    peer_rows = peers(cfg, progress) if with_peers else []
    run_s = time.perf_counter() - t_start
    files = outputs(quick, results_dir, images_dir)
    paths = dict(zip(CSV_NAMES, files))
    write_csv(rows, ROW_KEYS, paths["rows"])
    write_csv(orders, ORDER_KEYS, paths["orders"])
    write_csv(peer_rows, PEER_KEYS, paths["peers"])
    meta = dict(quick=int(quick), frames=len(rows), run_s=run_s, warmup_s=sum(warm.values()),
                **{f"warmup_{k}_s": v for k, v in warm.items()}, **_versions())
    write_csv([{"key": k, "value": v} for k, v in meta.items()], ["key", "value"], paths["meta"])
    images = files[len(CSV_NAMES):]
    chart_speed(rows, images[0])
    chart_convergence(rows, orders, images[1])
    if docs and not quick:  # a quick run never overwrites the full run's table
        update_accuracy_doc(orders)
    return {"csv": list(paths.values()), "images": images, "orders": orders, "run_s": run_s}


def main(argv=None):
    ap = argparse.ArgumentParser(description="Speed against accuracy of the shading methods, against exact images.")
    ap.add_argument("--quick", action="store_true", help="small images, fewer levels (< 2 minutes on 2 cores)")
    ap.add_argument("--no-peers", action="store_true", help="skip the peer pipelines")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    ap.add_argument("--no-docs", action="store_true", help="do not rewrite the fitted orders in docs/accuracy.md")
    args = ap.parse_args(argv)
    from raycast_shade.study.metrics import MissingExtraError

    try:
        out = run(quick=args.quick, progress=not args.no_progress, with_peers=not args.no_peers,
                  docs=not args.no_docs)
    except MissingExtraError as exc:
        print(f"accuracy: {exc}", file=sys.stderr)
        return 2
    print(orders_markdown(out["orders"], "rmse"))
    print()
    print(orders_markdown(out["orders"], "rmse_interior"))
    print(f"\naccuracy: {out['run_s']:.1f} s; wrote " + ", ".join(os.path.relpath(p, ROOT) for p in out["csv"] + out["images"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
