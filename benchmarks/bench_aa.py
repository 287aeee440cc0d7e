"""Anti-aliasing benchmark: the cost of N samples per pixel, and the edge error against N.

Run ``python -m benchmarks.bench_aa [--quick]``. Measures

* **cost**: ``render(scene, shading, samples=N)`` of a 1920x1080 frame of an
  icosphere (81,920 triangles; the core benchmark's scene, one
  inverse-square point light) for N = 1, 4, 16, per shading method and
  backend: the best wall time of 5 frames after a warm-up, interleaved
  across N (the least
  disturbed by other processes on a shared machine) and the best CPU time
  (all threads of this process: steadier when other processes share the
  cores), each with its ratio to N = 1. Per-face (flat) and per-vertex (Gouraud) shading is done once
  per frame for all samples; the casts and per-pixel kernels run N times.
* **edge**: a half-plane whose straight edge crosses a 48x48 orthographic
  image at 30 degrees: the largest and the mean ``|coverage - exact area
  fraction|`` over the edge pixels, for N = 1 .. 256, on both backends.

Results: ``benchmarks/results/aa.csv``. ``--quick`` runs a 480x270 frame and
fewer N and writes into the git-ignored ``out/quick/results/`` (:mod:`benchmarks.outputs`).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.outputs import results_file, write_csv

FIELDS = ["benchmark", "case", "backend", "samples", "value", "unit"]


def _scene(width, height):
    import raycast_shade as rs

    return rs.Scene(
        [rs.Model(rs.shapes.icosphere(6), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
        lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")],
        camera=rs.Camera(eye=(0, 0, 3), width=width, height=height),
    )


def _best_ms(fn, repeats):
    """Best wall and CPU (process) time in ms."""
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return 1e3 * float(np.min(wall)), 1e3 * float(np.min(cpu))


def bench_cost(width, height, counts, repeats):
    import raycast_shade as rs

    scene = _scene(width, height)
    rows = []
    for backend, shading in (("raycast", "flat"), ("raycast", "gouraud"), ("raycast", "phong"), ("raster", "phong")):
        for n in counts:
            rs.render(scene, shading, backend=backend, samples=n)  # warm-up: compile, BVH
        # Interleaved (N = 1, 4, 16, 1, 4, 16, ...) so that a change of load hits every N alike.
        best = {n: (np.inf, np.inf) for n in counts}
        for _ in range(repeats):
            for n in counts:
                ms, cpu = _best_ms(lambda: rs.render(scene, shading, backend=backend, samples=n), 1)
                best[n] = (min(best[n][0], ms), min(best[n][1], cpu))
        base = best[counts[0]]
        for n in counts:
            ms, cpu = best[n]
            case = f"{shading} {width}x{height}"
            for bench, value, unit in (("cost", ms, "ms wall"), ("cost_ratio", ms / base[0], "x one sample, wall"),
                                       ("cpu", cpu, "ms CPU"), ("cpu_ratio", cpu / base[1], "x one sample, CPU")):
                rows.append(dict(benchmark=bench, case=case, backend=backend, samples=n,
                                 value=round(value, 2 if "ratio" in bench else 1), unit=unit))
            print(f"{case:24s} {backend:8s} N={n:3d} {ms:8.1f} ms {ms / base[0]:5.2f}x wall, "
                  f"{cpu:8.1f} ms {cpu / base[1]:5.2f}x CPU", flush=True)
    return rows


def half_plane(width=48, height=48, degrees=30.0):
    """The half-plane scene of tests/visibility/test_antialiasing.py, and each pixel's exact covered fraction (H, W)."""
    import raycast_shade as rs

    a = np.radians(degrees)
    d = np.array([np.cos(a), np.sin(a), 0.0])
    n = np.array([-d[1], d[0], 0.0])
    p0 = np.array([0.3141, -0.2718, 0.0])
    verts = np.array([p0 - 4000 * d, p0 + 4000 * d, p0 + 4000 * n])
    cam = rs.Camera(eye=(0, 0, 10), target=(0, 0, 0), width=width, height=height, projection="orthographic",
                    ortho_height=float(height))
    scene = rs.Scene([rs.Model(rs.Mesh(verts, np.array([[0, 1, 2]])), rs.Material(kd=0.5))],
                     lights=[rs.DirectionalLight((0, 0, -1))], camera=cam)
    exact = np.zeros((height, width))
    for j in range(height):
        for i in range(width):
            x0, y1 = -width / 2 + i, height / 2 - j
            sq = [(x0, y1 - 1), (x0 + 1, y1 - 1), (x0 + 1, y1), (x0, y1)]
            f = [n[0] * (x - p0[0]) + n[1] * (y - p0[1]) for x, y in sq]
            poly = []
            for k in range(4):
                pa, pb, fa, fb = sq[k], sq[(k + 1) % 4], f[k], f[(k + 1) % 4]
                if fa >= 0:
                    poly.append(pa)
                if fa * fb < 0:
                    s = fa / (fa - fb)
                    poly.append((pa[0] + s * (pb[0] - pa[0]), pa[1] + s * (pb[1] - pa[1])))
            if len(poly) >= 3:
                x, y = np.array(poly).T
                exact[j, i] = 0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1)))
    return scene, exact


def bench_edge(counts):
    import raycast_shade as rs

    scene, exact = half_plane()
    edge = (exact > 1e-9) & (exact < 1 - 1e-9)
    rows = []
    for backend in ("raycast", "raster"):
        for n in counts:
            cov = rs.render(scene, "flat", backend=backend, samples=n, buffers=("coverage",)).buffers["coverage"]
            err = np.abs(cov[edge] - exact[edge])
            for stat, value in (("max", err.max()), ("mean", err.mean())):
                rows.append(dict(benchmark="edge_error", case=f"{stat} over {edge.sum()} edge pixels, 30 deg",
                                 backend=backend, samples=n, value=round(float(value), 5), unit="area fraction"))
            print(f"edge {backend:8s} N={n:3d} max {err.max():.4f} mean {err.mean():.4f}", flush=True)
    return rows


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("aa.csv", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes; untracked output")
    args = ap.parse_args(argv)
    if args.quick:
        rows = bench_cost(480, 270, (1, 4), 2) + bench_edge((1, 4, 16))
    else:
        rows = bench_cost(1920, 1080, (1, 4, 16), 5) + bench_edge((1, 2, 4, 8, 16, 32, 64, 128, 256))
    out, = outputs(args.quick)
    write_csv(out, rows, FIELDS)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    main()
