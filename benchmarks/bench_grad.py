"""Gradient benchmark: ``rs.grad`` of a Phong frame against the frame itself.

Run ``python -m benchmarks.bench_grad [--quick]``. The lecture's scene at 640x480 (an icosphere
of 5,120 triangles with a Phong highlight over a floor; an inverse-square point light and a
directional light, no shadows) is rendered, and in each repeat, interleaved in one process:

* ``forward``: ``rs.render(scene, "phong")``, cast and shade (the frame the issue compares with);
* ``shade``: re-shading the kept hit buffer (what one evaluation of ``rs.fit`` renders);
* ``grad``: ``rs.grad`` with respect to every material, ambient and light parameter, reusing the
  frame's hit buffer (``frame=``);
* ``grad+normals``: the same and the vertex normals;
* ``grad+vertices``: the vertex positions and the camera pose, through the triangles' interiors
  (the hit buffer's triangles held);
* ``grad+vertices+edges``: the same with the edge term (``edges=True``: silhouettes and boundary
  edges sampled at 4 per pixel of length, two rays cast and shaded per sample), the issue's
  "vertex gradients (interior + edges)", whose budget is 6x the frame;
* ``forward+shadows``: the frame with the point light casting shadows (the same scene otherwise);
* ``grad+shadow edges``: on that frame, the vertex positions, camera pose and light positions,
  interior and edges: the silhouettes' term and the shadow outlines' (the point light's silhouette
  edges cast onto the floor and the sphere, sampled at 4 per pixel of outline; its ``ratio`` is
  over ``forward+shadows``).

Medians over the repeats after one warm-up call of each (the first calls, compile or cache load
included, are their own rows, ``first ...``). ``ratio`` is each median over the ``forward``
median of the same run. Every row has the 1-minute load average when it was measured
(``load``): on a shared 2-core machine the absolute times move with it, the ratios much less.
Results: ``benchmarks/results/grad.csv``; ``--quick`` runs 160x120 with 3 repeats and writes
into the git-ignored ``out/quick/results/``.
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import time

import numpy as np

from benchmarks.outputs import results_file

FIELDS = ["benchmark", "case", "width", "height", "repeats", "ms_median", "ratio", "load", "note"]


def _scene(width, height, shadows=False):
    import raycast_shade as rs

    return rs.Scene([rs.Model(rs.shapes.icosphere(4), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40)),
                     rs.Model(rs.shapes.plane(6.0, center=(0.0, -1.0, 0.0), normal="+y"), rs.Material(kd=0.6))],
                    lights=[rs.PointLight((2.0, 3.0, 2.0), intensity=25.0, attenuation="inverse_square", shadows=shadows),
                            rs.DirectionalLight((-1.0, -1.0, -0.5), intensity=0.4)],
                    camera=rs.Camera(eye=(0.0, 1.2, 4.0), target=(0.0, -0.3, 0.0), width=width, height=height),
                    ambient=0.1)


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return (time.perf_counter() - t0) * 1e3


def run(quick: bool = False):
    import raycast_shade as rs
    from raycast_shade.gradients import DEFAULT_WRT, GEOMETRY
    from raycast_shade.shading.shade import SampleShading

    w, h = (160, 120) if quick else (640, 480)
    repeats = 3 if quick else 15
    scene = _scene(w, h)
    weights = np.random.default_rng(0).standard_normal((h, w, 3))
    frame = rs.render(scene, "phong")
    shadowed = _scene(w, h, shadows=True)
    frame_s = rs.render(shadowed, "phong")
    movers = GEOMETRY + ("light_position",)
    cases = {
        "forward": lambda: rs.render(scene, "phong"),
        "shade": lambda: SampleShading(scene, scene.camera, "phong", inputs=frame.inputs).shade(frame.hits),
        "grad": lambda: rs.grad(scene, weights, DEFAULT_WRT, frame=frame),
        "grad+normals": lambda: rs.grad(scene, weights, DEFAULT_WRT + ("normals",), frame=frame),
        "grad+vertices": lambda: rs.grad(scene, weights, GEOMETRY, frame=frame),
        "grad+vertices+edges": lambda: rs.grad(scene, weights, GEOMETRY, frame=frame, edges=True),
        "forward+shadows": lambda: rs.render(shadowed, "phong"),
        "grad+shadow edges": lambda: rs.grad(shadowed, weights, movers, frame=frame_s, edges=True),
    }
    over = {"grad+shadow edges": "forward+shadows"}  # each row's ratio is over this case's median
    load = lambda: round(os.getloadavg()[0], 2)  # noqa: E731
    rows = [dict(benchmark="grad", case=f"first {name}", width=w, height=h, repeats=1, ms_median=round(_timed(fn), 1),
                 ratio="", load=load(), note="compile or cache load included") for name, fn in cases.items()]
    times = {name: [] for name in cases}
    for _ in range(repeats):  # interleaved: each repeat times every case once
        for name, fn in cases.items():
            times[name].append(_timed(fn))
    forward = statistics.median(times["forward"])
    notes = {"forward": "render(): cast and shade", "shade": "the kept hit buffer re-shaded",
             "grad": "material, ambient and light parameters", "grad+normals": "and the vertex normals",
             "grad+vertices": "vertex positions and camera pose, interior",
             "grad+vertices+edges": "vertex positions and camera pose, interior and edges",
             "forward+shadows": "render() with the point light's shadow rays",
             "grad+shadow edges": "vertices, camera, light positions; interior, silhouettes and shadow outlines "
                                  "(ratio over forward+shadows)"}
    for name, ms in times.items():
        med = statistics.median(ms)
        base = statistics.median(times[over[name]]) if name in over else forward
        rows.append(dict(benchmark="grad", case=name, width=w, height=h, repeats=repeats, ms_median=round(med, 2),
                         ratio=round(med / base, 2), load=load(), note=notes[name]))
        print(f"{name:20s} {w}x{h}: median {med:8.2f} ms  ({med / base:.2f} x {over.get(name, 'forward')})")
    return rows


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("grad.csv", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="160x120, 3 repeats; untracked output")
    args = ap.parse_args(argv)
    rows = run(args.quick)
    path, = outputs(args.quick)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
