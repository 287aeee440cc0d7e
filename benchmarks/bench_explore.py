"""Explorer benchmark: frames per second of ``rs.explore``, from a slider change to PNG bytes ready.

Run ``python -m benchmarks.bench_explore [--quick]``. For 480x360 and 960x720
frames of the lecture's scene (an icosphere of 5,120 triangles, Phong
specular, over a floor; one inverse-square point light casting shadows), a
control is set from Python exactly as a slider drag sets it, and the time
until the image widget holds the new PNG is measured (the callback runs
synchronously), over a sweep of values after a warm-up:

* ``light``: azimuth steps, each shading method and flat | Gouraud | Phong
  side by side;
* ``material``: ``ks`` steps (a new material: re-packed rows, same BVH);
* ``wireframe``: azimuth steps with the overlay on;
* ``stage``: the parts of one Phong frame (scene, shade, tone map, PNG).

Every parallel kernel waits for both cores: on a machine shared with other
work each one costs about a scheduler time slice, so the ``load`` column
(the 1-minute load average when the row was measured) says how busy the
machine was. Results: ``benchmarks/results/explore.csv``. ``--quick`` runs 160x120 only,
a few frames, and writes into the git-ignored ``out/quick/results/``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from benchmarks.outputs import results_file, write_csv

FIELDS = ["benchmark", "case", "width", "height", "frames", "fps", "ms_median", "ms_p90", "load", "note"]


def _scene(width, height):
    import raycast_shade as rs

    return rs.Scene([rs.Model(rs.shapes.icosphere(4), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40)),
                     rs.Model(rs.shapes.plane(6.0, center=(0.0, -1.0, 0.0), normal="+y"), rs.Material(kd=0.6))],
                    lights=[rs.PointLight((2.0, 3.0, 2.0), intensity=25.0, attenuation="inverse_square",
                                          shadows=True)],
                    camera=rs.Camera(eye=(0.0, 1.2, 4.0), target=(0.0, -0.3, 0.0), width=width, height=height),
                    ambient=0.1)


def _sweep(explorer, control, values):
    """Milliseconds from setting ``control`` to the widget's new PNG, per value."""
    out = []
    for value in values:
        t0 = time.perf_counter()
        explorer.controls[control].value = value
        _ = explorer.image.value  # the bytes are there when the assignment returns
        out.append((time.perf_counter() - t0) * 1e3)
    return out


def _row(case, w, h, ms, note=""):
    ms_sorted = sorted(ms)
    med = statistics.median(ms)
    return dict(benchmark="explore", case=case, width=w, height=h, frames=len(ms), fps=round(1e3 / med, 1),
                ms_median=round(med, 1), ms_p90=round(ms_sorted[int(0.9 * (len(ms) - 1))], 1),
                load=round(os.getloadavg()[0], 2), note=note)


def _stages(explorer, frames):
    """Median ms of each part of a Phong frame: the scene, shading, tone mapping, PNG."""
    from raycast_shade.output.imagefile import png_bytes
    from raycast_shade.output.tonemap import to_uint8

    parts = {"scene": [], "shade": [], "tonemap": [], "png": []}
    for _ in range(frames):
        t0 = time.perf_counter()
        scene = explorer.scene()
        t1 = time.perf_counter()
        frame = explorer.render(scene, "phong", "perspective")
        t2 = time.perf_counter()
        rgb = to_uint8(frame.image)
        t3 = time.perf_counter()
        png_bytes(rgb)
        t4 = time.perf_counter()
        for k, a, b in (("scene", t0, t1), ("shade", t1, t2), ("tonemap", t2, t3), ("png", t3, t4)):
            parts[k].append((b - a) * 1e3)
    return parts


def run(quick: bool = False):
    import raycast_shade as rs
    from raycast_shade.apps.explore import SIDE_BY_SIDE

    sizes = [(160, 120)] if quick else [(480, 360), (960, 720)]
    frames = 4 if quick else 30
    rows = []
    for w, h in sizes:
        ex = rs.explore(_scene(w, h))
        for mode in ("flat", "gouraud", "phong", SIDE_BY_SIDE):  # warm-up: compile and cast once
            ex.controls["shading"].value = mode
        azimuths = list(np.linspace(-150.0, 150.0, frames))
        for mode in ("phong", "gouraud", "flat", SIDE_BY_SIDE):
            ex.controls["shading"].value = mode
            rows.append(_row(f"light {mode}", w, h, _sweep(ex, "azimuth", azimuths), "azimuth steps"))
        ex.controls["shading"].value = "phong"
        rows.append(_row("material phong", w, h, _sweep(ex, "ks", list(np.linspace(0.05, 0.95, frames))),
                         "ks steps: new material rows, same geometry and BVH"))
        ex.controls["wireframe"].value = True
        rows.append(_row("wireframe phong", w, h, _sweep(ex, "azimuth", azimuths), "azimuth steps, overlay on"))
        ex.controls["wireframe"].value = False
        for part, ms in _stages(ex, frames).items():
            rows.append(_row(f"stage {part}", w, h, ms, "one part of a Phong frame"))
        for r in rows[-10:]:
            print(f"{r['case']:28s} {w}x{h}: {r['fps']:7.1f} frames/s  (median {r['ms_median']} ms, "
                  f"p90 {r['ms_p90']} ms)")
    return rows


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("explore.csv", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="160x120, a few frames; untracked output")
    args = ap.parse_args(argv)
    rows = run(args.quick)
    path, = outputs(args.quick)
    write_csv(path, rows, FIELDS)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
