"""Rays through every vertex of closed meshes: do they slip through? (issue 17, class 1).

Run ``python -m benchmarks.vertex_rays [--quick]``. For each setting (icosphere
radius 1, 1e-3, 1e4, and radius 1 moved 1e5 from the origin) it aims rays at
every vertex of an icosphere:

* from outside: from 8 random eyes at 4 radii from the centre, at every vertex
  whose vertex normal faces the eye. A ray whose line enters the polyhedron at
  the vertex ("entering": every face at the vertex faces the eye by more than
  1e-3 in cosine) must hit there; one that only touches it (a supporting line
  at the polyhedral silhouette, "grazing") may hit it or miss. A *leak* is a hit
  beyond the vertex (t > |V - E| (1 + 1e-4)): the ray passed through;
* from inside: from the centre through every vertex; every ray must hit at the
  vertex's distance.

each with ``cast_rays(..., watertight=False)`` (Embree alone) and ``True``. It
also renders the failure catalogue's perspective vertex grid (case 9) with a
plane behind it and counts the pixels that show the plane: with no repair, with
the miss re-cast alone (the behaviour before this study) and with the
depth-jump re-test; and times ``cast_rays`` over 1M rays both ways.

Writes ``benchmarks/results/vertex_rays.csv`` (case, setting, quantity, value);
``--quick`` (icosphere(3), fewer rays) prints the same table and writes it into
the git-ignored ``out/quick/results/``.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time

import numpy as np

import raycast_shade as rs
from raycast_shade.visibility import holes
from raycast_shade.study import failure_scenes

from benchmarks.outputs import results_file

SETTINGS = (("scale 1", 1.0, 0.0), ("offset 1e5", 1.0, 1e5), ("scale 1e-3", 1e-3, 0.0), ("scale 1e4", 1e4, 0.0))


def sphere_scene(sub, scale=1.0, offset=0.0):
    mesh = rs.shapes.icosphere(sub, radius=scale)
    return mesh, rs.Scene([rs.Model(rs.Mesh(mesh.vertices + offset, mesh.faces, normals=mesh.normals))])


def entering_margin(mesh, eye):
    """(V,) max over the faces at each vertex of cos(face normal, ray): < 0 where the
    ray from ``eye`` through the vertex enters the (convex) polyhedron there."""
    v, f = mesh.vertices, mesh.faces
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    d = v - eye
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    out = np.full(len(v), -np.inf)
    for c in range(3):
        np.maximum.at(out, f[:, c], np.einsum("ij,ij->i", fn, d[f[:, c]]))
    return out


def aimed(scene, eye, targets, watertight):
    """Hits of rays from ``eye`` through each target, and the targets' distances."""
    dirs = targets - eye
    dist = np.linalg.norm(dirs, axis=1)
    dirs = dirs / dist[:, None]
    hits = rs.cast_rays(scene, np.broadcast_to(eye, dirs.shape).copy(), dirs, watertight=watertight)
    return hits, dist


def count(hits, dist):
    miss = hits.prim < 0
    leak = ~miss & (hits.t > dist * (1 + 1e-4))
    return int(leak.sum()), int(miss.sum())


def vertex_study(sub, scale, offset, eyes=8, seed=0, watertight=True):
    """{"outside": (rays, leaks, misses, entering, entering leaks, entering misses),
    "inside": (rays, leaks, misses)}."""
    mesh, scene = sphere_scene(sub, scale, offset)
    rng = np.random.default_rng(seed)
    out = np.zeros(6, np.int64)
    for _ in range(eyes):
        u = rng.normal(size=3)
        eye = 4.0 * scale * u / np.linalg.norm(u)
        front = np.einsum("ij,ij->i", mesh.normals, eye - mesh.vertices) > 0
        enter = (entering_margin(mesh, eye) < -1e-3)[front]
        hits, dist = aimed(scene, eye + offset, mesh.vertices[front] + offset, watertight)
        leak, miss = count(hits, dist)
        el, em = count(type(hits)(*(a[enter] for a in hits)), dist[enter])
        out += [len(dist), leak, miss, int(enter.sum()), el, em]
    hits, dist = aimed(scene, np.full(3, offset), mesh.vertices + offset, watertight)
    return {"outside": tuple(int(x) for x in out), "inside": (len(dist), *count(hits, dist))}


def grid_behind(step=1, label="near"):
    """The catalogue's perspective vertex grid (case 9) with a plane 1 unit behind it:
    pixels showing the plane with no repair, with misses re-cast alone, and with the
    depth-jump re-test."""
    eye, fov = {"near": ((0.3, -1.2, 2.5), 50.0), "far": ((3.0, -40.0, 50.0), 2.0)}[label]
    cam = failure_scenes.pixel_ray_camera(eye, fov)
    grid = failure_scenes.grid_at_pixel_rays(cam, step)
    floor = rs.shapes.plane(size=400.0, center=(0.0, 0.0, -1.0), normal="+z")
    scene = rs.Scene([rs.Model(grid), rs.Model(floor)], camera=cam)
    out = {}
    saved = holes._JITTER, holes._JUMP
    try:
        for name, jitter, jump in (("no repair", (), saved[1]), ("misses re-cast", saved[0], np.inf),
                                   ("misses and depth jumps", *saved)):
            holes._JITTER, holes._JUMP = jitter, jump
            hits = rs.cast_camera(scene.geometry, cam)
            out[name] = (int((hits.geom == 1).sum()), int((hits.geom < 0).sum()), hits)
    finally:
        holes._JITTER, holes._JUMP = saved
    return out


def cost(n, repeats=3):
    """Seconds per cast of ``n`` random rays at icosphere(5) from a sphere of radius 4, best of ``repeats``."""
    _, scene = sphere_scene(5)
    rng = np.random.default_rng(1)
    o = rng.normal(size=(n, 3))
    o *= 4.0 / np.linalg.norm(o, axis=1, keepdims=True)
    d = rng.normal(size=(n, 3)) * 0.3 - o / 4.0
    res = {}
    for wt in (False, True):
        rs.cast_rays(scene, o[:1000], d[:1000], watertight=wt)
        best = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            rs.cast_rays(scene, o, d, watertight=wt)
            best = min(best, time.perf_counter() - t0)
        res[wt] = best
    return res


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("vertex_rays.csv", quick)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="icosphere(3), 100k rays for the cost; untracked output")
    args = ap.parse_args(argv)
    sub, n = (3, 100_000) if args.quick else (5, 1_000_000)
    rows = []

    def record(case, setting, quantity, value):
        rows.append((case, setting, quantity, value))
        print(f"  {case:<14} {setting:<34} {quantity:<22} {value:.6g}")

    for label, scale, offset in SETTINGS:
        for wt in (False, True):
            r = vertex_study(sub, scale, offset, watertight=wt)
            setting = f"icosphere({sub}) {label}, {'watertight' if wt else 'Embree alone'}"
            for q, v in zip(("rays", "leaks", "misses", "entering rays", "entering leaks", "entering misses"),
                            r["outside"]):
                record("outside", setting, q, v)
            for q, v in zip(("rays", "leaks", "misses"), r["inside"]):
                record("inside", setting, q, v)
    for label in ("near", "far"):
        for step in (1, 2, 3):
            for name, (plane, miss, _) in grid_behind(step, label).items():
                record("grid + plane", f"{label}, step {step}, {name}", "pixels showing plane", plane)
                record("grid + plane", f"{label}, step {step}, {name}", "misses", miss)
    secs = cost(n)
    for wt, s in secs.items():
        record("cost", f"{n} rays, icosphere(5), watertight={wt}", "Mrays/s", n / s / 1e6)
    record("cost", f"{n} rays, icosphere(5)", "watertight / plain time", secs[True] / secs[False])
    path, = outputs(args.quick)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["case", "setting", "quantity", "value"])
        for r in rows:
            wr.writerow([r[0], r[1], r[2], f"{r[3]:.6g}"])
    print(f"  -> {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
