"""Auto-mode benchmark: does ``shading="auto"`` meet its tolerance, and what does it cost?

Run ``python -m benchmarks.bench_auto [--quick]``. On mixed scenes (spheres
of several tessellations and materials on a floor, each model with an exact
analytic twin), every mode -- ``auto`` and each single method -- is

* timed: a full ``render`` call (for ``auto`` that includes
  ``choose_methods``), after one untimed warm-up render per mode that loads
  the kernels and builds the BVH; the repeats of the modes of a scene are
  interleaved so that a burst of load elsewhere hits them alike; median and
  minimum of the repeats are both reported (on a shared machine the median
  is noisy: each parallel kernel launch can wait ~8 ms for a busy core);
* measured against the exact image (:mod:`raycast_shade.study.analytic`), per
  model: the largest absolute error on the pixels both images give the
  model, leaving out a 2-pixel rim (``interior``: the shading error proper;
  the rim holds the silhouette's geometric error, which no shading method
  removes), and the 99th percentile and the maximum over all common pixels.

A mode *meets* the tolerance when every model's interior error does. Each
``auto`` row also reports the cheapest single method that meets it, and
auto's time relative to that method (target: <= 1.10).

Timed with all Numba threads and with one (``--threads 0,1``, the default).

Results: ``benchmarks/results/auto.csv`` (``out/quick/results/auto.csv`` in quick mode):
one row per scene, mode and model (``model = -1``: the whole frame, with the
timings and the verdict).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from benchmarks.outputs import results_file, write_csv

MODES = ("auto", "flat", "gouraud", "phong")

FIELDS = ["numba_threads", "scene", "tolerance", "width", "height", "mode", "model", "name", "method", "predicted", "interior_max",
          "p99", "max", "meets", "median_ms", "min_ms", "repeats", "cheapest_meeting", "ratio_median", "ratio_min",
          "reason"]


def _scenes(width: int, height: int):
    """name -> (scene, analytic surfaces, tolerance)."""
    import raycast_shade as rs
    from raycast_shade.study.analytic import Plane, Sphere

    def cam(eye, fov):
        return rs.Camera(eye=eye, target=(0, 0, 0), width=width, height=height, fov=fov)

    out = {}
    # A fourth scene keeps a coarse shiny sphere that no method can shade within
    # the tolerance (auto falls back to Phong and says so).
    out["coarse_shiny"] = (rs.Scene(
        [rs.Model(rs.shapes.icosphere(5, radius=0.8, center=(-1.1, 0, 0)), rs.Material(kd=0.7)),
         rs.Model(rs.shapes.icosphere(2, radius=0.8, center=(1.1, 0, 0)),
                  rs.Material(kd=0.5, ks=0.5, shininess=200)),
         rs.Model(rs.shapes.plane(6, 1, center=(0, -0.8, 0), normal="+y"), rs.Material(kd=0.6))],
        lights=[rs.DirectionalLight((-1, -1, -1))], camera=cam((0, 1.0, 6), 40), ambient=0.1),
        [Sphere((-1.1, 0, 0), 0.8), Sphere((1.1, 0, 0), 0.8), Plane((0, -0.8, 0), 6, "+y")], 0.01)
    # A: directional light; fine diffuse sphere, a shiny sphere, diffuse floor.
    out["mixed_directional"] = (rs.Scene(
        [rs.Model(rs.shapes.icosphere(5, radius=0.8, center=(-1.1, 0, 0)), rs.Material(kd=0.7)),
         rs.Model(rs.shapes.icosphere(4, radius=0.8, center=(1.1, 0, 0)),
                  rs.Material(kd=0.5, ks=0.5, shininess=200)),
         rs.Model(rs.shapes.plane(6, 1, center=(0, -0.8, 0), normal="+y"), rs.Material(kd=0.6))],
        lights=[rs.DirectionalLight((-1, -1, -1))], camera=cam((0, 1.0, 6), 40), ambient=0.1),
        [Sphere((-1.1, 0, 0), 0.8), Sphere((1.1, 0, 0), 0.8), Plane((0, -0.8, 0), 6, "+y")], 0.01)
    # B: point light; medium diffuse sphere, fine low-shininess sphere, shiny UV sphere, shiny floor.
    out["mixed_point"] = (rs.Scene(
        [rs.Model(rs.shapes.icosphere(4, radius=0.7, center=(-1.6, 0, 0)), rs.Material(kd=0.7)),
         rs.Model(rs.shapes.icosphere(4, radius=0.7, center=(0, 0, -0.5)), rs.Material(kd=0.5, ks=0.3, shininess=8)),
         rs.Model(rs.shapes.uv_sphere(32, 64, radius=0.7, center=(1.6, 0, 0)),
                  rs.Material(kd=0.4, ks=0.6, shininess=64)),
         rs.Model(rs.shapes.plane(7, 1, center=(0, -0.7, 0), normal="+y"),
                  rs.Material(kd=0.5, ks=0.2, shininess=16))],
        lights=[rs.PointLight((2, 3, 3))], camera=cam((0, 1.5, 5.5), 45), ambient=0.1),
        [Sphere((-1.6, 0, 0), 0.7), Sphere((0, 0, -0.5), 0.7), Sphere((1.6, 0, 0), 0.7), Plane((0, -0.7, 0), 7, "+y")],
        0.02)
    # C: mostly diffuse: two fine matt spheres and a floor, directional light (where auto can save work).
    out["mostly_diffuse"] = (rs.Scene(
        [rs.Model(rs.shapes.icosphere(6, radius=0.8, center=(-1.0, 0, 0)), rs.Material(kd=0.7)),
         rs.Model(rs.shapes.icosphere(6, radius=0.8, center=(1.0, 0, 0)), rs.Material(kd=(0.3, 0.6, 0.8))),
         rs.Model(rs.shapes.plane(6, 1, center=(0, -0.8, 0), normal="+y"), rs.Material(kd=0.6))],
        lights=[rs.DirectionalLight((-1, -1, -1))], camera=cam((0, 1.0, 6), 40), ambient=0.1),
        [Sphere((-1.0, 0, 0), 0.8), Sphere((1.0, 0, 0), 0.8), Plane((0, -0.8, 0), 6, "+y")], 0.02)
    return out


def _errors(exact, frame, g, rim=2):
    from raycast_shade.study.metrics import interior_mask

    both = exact.mask & frame.mask & (exact.model_id == g) & (frame.model_id == g)
    if not both.any():
        return float("nan"), float("nan"), float("nan")
    err = np.abs(exact.image - frame.image.astype(np.float64)).max(axis=2)
    inner = interior_mask(both, rim)
    interior = float(err[inner].max()) if inner.any() else float("nan")
    return interior, float(np.percentile(err[both], 99)), float(err[both].max())


def run(quick: bool = False, repeats: int | None = None):
    """Measure every scene; returns the CSV rows (list of dict)."""
    import raycast_shade as rs
    from raycast_shade.study.analytic import exact_for_scene
    from raycast_shade.insight.auto import choose_methods

    width, height = (320, 240) if quick else (640, 480)
    repeats = repeats or (15 if quick else 25)
    rows = []
    for name, (scene, surfaces, tol) in _scenes(width, height).items():
        exact = exact_for_scene(scene, surfaces)
        decisions = choose_methods(scene, scene.camera, tol)

        def go(mode, scene=scene, tol=tol):
            return rs.render(scene, mode, tolerance=tol) if mode == "auto" else rs.render(scene, mode)

        frames = {m: go(m) for m in MODES}  # warm-up: JIT cache, BVH
        times = {m: [] for m in MODES}
        for _ in range(repeats):
            for m in MODES:  # interleaved
                t0 = time.perf_counter()
                go(m)
                times[m].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(repeats):
            choose_methods(scene, scene.camera, tol)
        choose_ms = (time.perf_counter() - t0) / repeats * 1e3

        verdict = {}
        for m in MODES:
            per_model = []
            for d in decisions:
                method = d.method if m == "auto" else m
                interior, p99, mx = _errors(exact, frames[m], d.model)
                per_model.append(interior)
                rows.append(dict(scene=name, tolerance=tol, width=width, height=height, mode=m, model=d.model,
                                 name=d.name, method=method, predicted=f"{d.predicted[method]:.4g}",
                                 interior_max=f"{interior:.4g}", p99=f"{p99:.4g}", max=f"{mx:.4g}",
                                 meets=interior <= tol, reason=d.reason if m == "auto" else ""))
            verdict[m] = all(e <= tol for e in per_model)
        med = {m: statistics.median(times[m]) for m in MODES}
        low = {m: min(times[m]) for m in MODES}
        meeting = [m for m in MODES[1:] if verdict[m]]
        cheapest = min(meeting, key=lambda m: med[m]) if meeting else ""
        cheapest_min = min(meeting, key=lambda m: low[m]) if meeting else ""
        for m in MODES:
            row = dict(scene=name, tolerance=tol, width=width, height=height, mode=m, model=-1, name="(frame)",
                       method="+".join(d.method for d in decisions) if m == "auto" else m, meets=verdict[m],
                       median_ms=f"{med[m] * 1e3:.2f}", min_ms=f"{low[m] * 1e3:.2f}", repeats=repeats)
            if m == "auto":
                row["cheapest_meeting"] = cheapest if cheapest == cheapest_min else f"{cheapest} (min: {cheapest_min})"
                if cheapest:
                    row["ratio_median"] = f"{med['auto'] / med[cheapest]:.3f}"
                    row["ratio_min"] = f"{low['auto'] / low[cheapest_min]:.3f}"
                row["reason"] = f"choose_methods {choose_ms:.2f} ms"
            rows.append(row)
    return rows


def _print(rows):
    for r in rows:
        if r["model"] == -1:
            print(f"[{r['numba_threads']}t] {r['scene']:18s} {r['mode']:8s} {r['method']:22s} meets={str(r['meets']):5s} "
                  f"median {r['median_ms']:>7s} ms  min {r['min_ms']:>7s} ms"
                  + (f"  cheapest meeting: {r['cheapest_meeting'] or '-'}  ratio median {r.get('ratio_median', '-')}"
                     f" min {r.get('ratio_min', '-')}  ({r['reason']})" if r["mode"] == "auto" else ""))
        else:
            print(f"    {r['mode']:8s} model {r['model']} {r['name']:16s} {r['method']:8s} predicted {r['predicted']:>8s} "
                  f"interior {r['interior_max']:>8s} p99 {r['p99']:>8s} max {r['max']:>8s} (tol {r['tolerance']})"
                  f" meets={r['meets']}")


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes by default (see :mod:`benchmarks.outputs`)."""
    return [results_file("auto.csv", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="320x240 instead of 640x480, fewer repeats")
    ap.add_argument("--repeats", type=int, default=None)
    ap.add_argument("--threads", default="0,1",
                    help="comma-separated Numba thread counts to run, 0 = all (default '0,1': 1 thread never waits "
                         "for a busy core at a parallel launch, so its times are steady on a shared machine)")
    ap.add_argument("--out", default=None, help="CSV path (default: results/auto.csv, out/quick/results/auto.csv)")
    args = ap.parse_args(argv)
    import numba

    rows = []
    saved = numba.get_num_threads()
    try:
        for n in (int(x) for x in args.threads.split(",")):
            numba.set_num_threads(n or numba.config.NUMBA_NUM_THREADS)
            part = run(args.quick, args.repeats)
            for r in part:
                r["numba_threads"] = numba.get_num_threads()
            rows += part
    finally:
        # The suite runs the next benchmark in this process: it must not inherit one thread.
        numba.set_num_threads(saved)
    path = args.out or outputs(args.quick)[0]
    write_csv(path, rows, FIELDS)
    _print(rows)
    print(f"wrote {path}")
    return rows


if __name__ == "__main__":
    main()
