"""Shadow rays: the shadowed frame against the plain one, and against the rays' own floor (issue 27).

Run ``python -m benchmarks.bench_shadows [--quick]``. For each mesh and size of
:mod:`benchmarks.bench_paths` (the scene of :mod:`benchmarks.bench_peers`, its one point light
casting shadows), timed in turn, round after round, in one process after a warm-up round:

* ``frame``: the plain Phong frame (the unit of ``ratio``);
* ``shadows``: the same frame, the light casting shadows: the batched Phong kernel
  (:mod:`raycast_shade.shading.phong_fast`) traces its lanes' shadow rays as 16-ray packets;
* ``shadows_tiles``: the same, shaded by the general kernel with a packet per 4x4 tile (what
  textured or bump-mapped shadowed frames take, and every shadowed frame before);
* ``shadows_single``: the same, shaded by the kernel that traces each shadow ray on its own
  (``rtcOccluded1``), as before the packets: the three images are bit-identical (checked here);
* ``rays_occluded1`` and ``rays_occluded16``: the frame's very shadow rays (collected once, in
  packets of 4x4 pixels) traced bare, one ``rtcOccluded1`` per ray and one ``rtcOccluded16`` per
  packet (coherent), in a parallel loop with nothing else: the floor of what the rays cost;
* ``mirror``: the plain frame's mesh as a mirror (reflectivity 0.5), one bounce (the ``mirror``
  row of :mod:`benchmarks.bench_paths`);
* ``rays_bounce16``: that frame's very bounce rays (collected once as the mirror kernel packs
  them: :func:`raycast_shade.shading.mirrors._start_lane`, the lanes' rays of its depth 0,
  :func:`raycast_shade.visibility.secondary.set_closest_rays`: the reflective pixels of a 4x4 tile
  in one packet) traced bare, one coherent ``rtcIntersect16`` per packet:
  the floor of the mirror frame is ``frame`` plus this.

``rays`` is the number of shadow rays (pixels lit by the light), or for the mirror rows of bounce
rays (reflective pixels); ``ns_per_ray`` is, for the bare rays, their time over that number, and
for the shadowed and mirror frames what they take beyond the plain frame, over that number (what
a ray adds, shading and bookkeeping included).
Results: ``benchmarks/results/shadows.csv`` and the table between the ``shadows`` markers of
``docs/performance.md`` (``--table`` redoes it from the CSV); ``--quick`` runs one small case into
``out/quick/`` (the table to ``out/quick/results/shadows.md``). The machine load
(``os.getloadavg``) before each case goes into ``note``.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import os
import statistics
import time

import numpy as np
from numba import njit

from raycast_shade.common.parallel import KERNEL, in_parts, share

from benchmarks import outputs as where
from benchmarks.outputs import ROOT, results_file, write_csv
from raycast_shade.shading import mirrors, shadows
from raycast_shade.shading.illumination import _request_shadows
from raycast_shade.shading.phong import _shading_point, _surface
from raycast_shade.shading.records import At
from raycast_shade.visibility import embree, secondary

FIELDS = ["mesh", "triangles", "width", "height", "path", "median_ms", "ratio", "rays", "ns_per_ray", "repeats",
          "note"]
CASES = [("icosphere", 6, 640, 480), ("icosphere", 6, 1920, 1080), ("noisy_sphere", 8, 640, 480),
         ("noisy_sphere", 8, 1920, 1080)]
QUICK_CASES = [("icosphere", 4, 320, 240)]
_LANES = shadows.LANES


def outputs(quick: bool = False) -> list:
    return [results_file("shadows.csv", quick)] + (
        [results_file("shadows.md", True)] if quick else [os.path.join(ROOT, "docs", "performance.md")])


@in_parts
@njit(**KERNEL)
def _collect(prim, geom, u, v, G, B, L, face_off, cam, rays, valid, part):
    """Light 0's shadow rays of every 4x4 tile, as the packet kernel asks for them:
    ``rays`` (tiles, RAY16_SLOTS) float32, ``valid`` (tiles, 16) int32."""
    h, w = prim.shape
    ntx = (w + 3) // 4
    for ty in range(*share((h + 3) // 4, part)):  # this part's share (common.parallel)
        buf, ib, off, vd, voff, args, aoff, vis, points = shadows._packets(L.lights.shape[0])
        P = (buf, ib, off, vd, voff)
        for tx in range(ntx):
            shadows.clear_packets(vd, voff, vis, points)
            for k in range(_LANES):
                x = tx * 4 + k % 4
                y = ty * 4 + k // 4
                if x < w and y < h and prim[y, x] >= 0:
                    gm = geom[y, x]
                    at = At(face_off[gm] + prim[y, x], gm, np.float64(u[y, x]), np.float64(v[y, x]))
                    _request_shadows(P, k, _shading_point(G, B, L, cam, at, False, (0.0, 0.0, 0.0)), L)
            t = ty * ntx + tx
            for j in range(embree.RAY16_SLOTS):
                rays[t, j] = buf[off + j]
            for k in range(_LANES):
                valid[t, k] = vd[voff + k]


@in_parts
@njit(**KERNEL)
def _one_by_one(handle, rays, valid, out, part):
    """Each active lane's ray alone: ``rtcOccluded1``."""
    for t in range(*share(rays.shape[0], part)):  # this part's share (common.parallel)
        b = np.empty(2 * embree.RAY_SLOTS, np.float32)
        o = ((16 - b.ctypes.data % 16) % 16) // 4
        for k in range(_LANES):
            if valid[t, k] != 0:
                for s in range(embree.RAY_SLOTS):
                    b[o + s] = rays[t, s * _LANES + k]
                embree.occluded1_ray(handle, b[o:])
                out[t, k] = b[o + embree.RAY_TFAR] < 0.0


@njit(cache=True, forceinline=True)  # inlined: the floor's loop as before, no call per tile
def _tile_packet(rays, valid, t, flags):
    """Tile ``t``'s packet (``rays[t]``: an ``RTCRay16`` or ``RTCRayHit16``) copied to a 64-byte aligned
    buffer, its valid mask and its query arguments (``flags``, every feature): ``(b, o, vb, vo, a, ao,
    on)``, each array with the slot its struct starts at, and whether any lane is active."""
    slots = rays.shape[1]
    # Room for a whole RTCRayHit16 whatever the tile holds: rtcOccluded16 rewrites the hit fields past an
    # RTCRay16 on CPUs without 16-wide kernels (see visibility/secondary.py, _STRIDE).
    b = np.empty(max(slots, _LANES * embree.RAYHIT_SLOTS) + 16, np.float32)
    o = ((64 - b.ctypes.data % 64) % 64) // 4
    vb = np.empty(2 * _LANES, np.int32)
    vo = ((64 - vb.ctypes.data % 64) % 64) // 4
    a = np.zeros(embree.ARGS_SLOTS + 2, np.uint32)
    ao = ((8 - a.ctypes.data % 8) % 8) // 4
    a[ao] = flags
    a[ao + 1] = embree.FEATURE_FLAG_ALL
    on = False
    for k in range(_LANES):
        vb[vo + k] = valid[t, k]
        on = on or valid[t, k] != 0
    if on:
        for j in range(slots):
            b[o + j] = rays[t, j]
    return b, o, vb, vo, a, ao, on


@in_parts
@njit(**KERNEL)
def _packets(handle, rays, valid, out, part):
    """Each tile's rays as one coherent ``rtcOccluded16`` packet."""
    for t in range(*share(rays.shape[0], part)):  # this part's share (common.parallel)
        b, o, vb, vo, a, ao, on = _tile_packet(rays, valid, t, embree.RAY_QUERY_FLAG_COHERENT)
        if on:
            embree.occluded16_packet(vb[vo:], handle, b[o:], a[ao:])
            for k in range(_LANES):
                if valid[t, k] != 0:
                    out[t, k] = b[o + embree.RAY_TFAR * _LANES + k] < 0.0


@in_parts
@njit(**KERNEL)
def _collect_bounces(hits, G, B, materials, face_off, cam, unit, image, rays, valid, part):
    """The bounce rays of every 4x4 tile, packed as the mirror kernel packs them (its lanes, its
    ``RTCRayHit16``): ``rays`` (tiles, 16 RAYHIT_SLOTS) float32, ``valid`` (tiles, 16) int32;
    ``image`` (H, W, 3) float32 takes the kernel's ``1 - rho`` scaling (a scratch here)."""
    h, w = hits[0].shape
    ntx = (w + 3) // 4
    slots = _LANES * embree.RAYHIT_SLOTS
    for ty in range(*share((h + 3) // 4, part)):  # this part's share (common.parallel)
        Q = secondary.closest_packet(mirrors.MIRROR_FLAGS)  # the kernel's packet (its slots written once)
        buf, off, vb, vo = Q[0], Q[2], Q[3], Q[4]
        lanes = (np.empty(_LANES, np.int64), np.empty(_LANES, np.int64), np.empty(_LANES, np.float64),
                 np.zeros((3, _LANES), np.float64), np.zeros((3, _LANES), np.float64), np.zeros(_LANES, np.bool_))
        ys, xs, weight, org, dr, act = lanes
        for tx in range(ntx):
            n = np.int64(0)
            for y in range(ty * 4, min(h, ty * 4 + 4)):
                for x in range(tx * 4, min(w, tx * 4 + 4)):
                    n = mirrors._start_lane(hits, materials, image, y, x, (n, ys, xs, weight, org, dr, act))
            for k in range(n):  # the kernel's depth 0: each lane's shading point and mirror ray
                hp = _surface(G, B, cam, mirrors._pixel_at(hits, face_off, ys[k], xs[k]), np.bool_(False),
                              (0.0, 0.0, 0.0))
                mirrors._lane_ray(hp, unit, k, org, dr)
            t = ty * ntx + tx
            if n > 0:
                secondary.set_closest_rays(Q, org, dr, act, n)
                for j in range(slots):
                    rays[t, j] = buf[off + j]
            for k in range(_LANES):
                valid[t, k] = vb[vo + k] if n > 0 else 0


@in_parts
@njit(**KERNEL)
def _bounce_packets(handle, rays, valid, out, part):
    """Each tile's bounce rays as one coherent ``rtcIntersect16`` packet; ``out`` (tiles, 16) int32:
    each active lane's hit model (-1: a miss)."""
    for t in range(*share(rays.shape[0], part)):  # this part's share (common.parallel)
        b, o, vb, vo, a, ao, on = _tile_packet(rays, valid, t, mirrors.MIRROR_FLAGS)
        ib = b.view(np.uint32)
        if on:
            embree.intersect16_packet(vb[vo:], handle, b[o:], a[ao:])
            for k in range(_LANES):
                if valid[t, k] != 0:
                    out[t, k] = embree.read_hit(b, ib, o + k, _LANES)[0]


def _bounce_rays(scene):
    """The mirror frame's bounce rays (one bounce), collected once: (handle, rays, valid)."""
    from raycast_shade.shading.inputs import prepare
    from raycast_shade.visibility.accel import embree_accel
    from raycast_shade.visibility.cast import cast_camera

    k = prepare(scene, scene.camera)
    hits = cast_camera(scene.geometry, scene.camera)
    w, h = scene.camera.width, scene.camera.height
    tiles = ((w + 3) // 4) * ((h + 3) // 4)
    rays = np.zeros((tiles, _LANES * embree.RAYHIT_SLOTS), np.float32)
    valid = np.zeros((tiles, _LANES), np.int32)
    _collect_bounces((hits.prim, hits.geom, hits.u, hits.v), k["G"], k["B"], k["materials"], k["face_off"], k["cam"],
                     float(scene.geometry.scale), np.zeros((h, w, 3), np.float32), rays, valid)
    return np.uintp(embree_accel(scene.geometry).handle), rays, valid


def _shadow_rays(scene):
    """The frame's shadow rays (light 0), collected once: (handle, rays, valid)."""
    from raycast_shade.shading.inputs import prepare
    from raycast_shade.visibility.cast import cast_camera

    k = prepare(scene, scene.camera)
    hits = cast_camera(scene.geometry, scene.camera)
    w, h = scene.camera.width, scene.camera.height
    tiles = ((w + 3) // 4) * ((h + 3) // 4)
    rays = np.zeros((tiles, embree.RAY16_SLOTS), np.float32)
    valid = np.zeros((tiles, _LANES), np.int32)
    _collect(hits.prim, hits.geom, hits.u, hits.v, k["G"], k["B"], k["L"], k["face_off"], k["cam"], rays, valid)
    return k["L"].handle, rays, valid


def _per_ray(name, med, unit, n) -> str:
    if name == "frame":
        return ""
    return f"{(med - unit if name.startswith(('shadows', 'mirror')) else med) / n * 1e9:.0f}"


def bench_case(kind, level, width, height, repeats):
    import raycast_shade as rs
    from benchmarks.bench_peers import make_mesh, make_scene
    from raycast_shade.shading import shade as shade_mod

    load = os.getloadavg()[0]
    scene = make_scene(make_mesh(kind, level), width, height)
    shadowed = scene.replace(lights=[dataclasses.replace(light, shadows=True) for light in scene.lights])
    mirror = scene.replace(models=[rs.Model(m.mesh, dataclasses.replace(m.material, reflectivity=0.5))
                                   for m in scene.models])
    packets, fast = shade_mod._PHONG_PACKETS, shade_mod._fast_applies

    def general(one_by_one):
        shade_mod._fast_applies = lambda modes, k: False  # the general kernel
        if one_by_one:
            shade_mod._PHONG_PACKETS = shade_mod._PHONG  # the one-ray-at-a-time kernel
        try:
            return rs.render(shadowed)
        finally:
            shade_mod._PHONG_PACKETS, shade_mod._fast_applies = packets, fast

    handle, rays, valid = _shadow_rays(shadowed)
    one, pk = np.zeros(valid.shape, np.bool_), np.zeros(valid.shape, np.bool_)
    bhandle, bounces, bvalid = _bounce_rays(mirror)
    bhit = np.zeros(bvalid.shape, np.int32)
    paths = {"frame": lambda: rs.render(scene), "shadows": lambda: rs.render(shadowed),
             "shadows_tiles": lambda: general(False), "shadows_single": lambda: general(True),
             "rays_occluded1": lambda: _one_by_one(handle, rays, valid, one),
             "rays_occluded16": lambda: _packets(handle, rays, valid, pk),
             "mirror": lambda: rs.render(mirror, max_depth=1),
             "rays_bounce16": lambda: _bounce_packets(bhandle, bounces, bvalid, bhit)}
    times = {name: [] for name in paths}
    images = {}
    for r in range(repeats + 1):  # round 0: warm-up
        for name, fn in paths.items():
            t0 = time.perf_counter()
            out = fn()
            if r:
                times[name].append(time.perf_counter() - t0)
            if name.startswith("shadows"):
                images[name] = out.image
    for name in ("shadows", "shadows_tiles"):
        if not np.array_equal(images[name], images["shadows_single"]):
            raise AssertionError(f"{name}: the image differs from the single-ray kernel's")
    if not np.array_equal(one, pk):
        raise AssertionError("rtcOccluded16 answered differently from rtcOccluded1")
    n = int((valid != 0).sum())
    nb = int((bvalid != 0).sum())
    unit = statistics.median(times["frame"])
    rows = []
    for name, ts in times.items():
        med = statistics.median(ts)
        nr = nb if name in ("mirror", "rays_bounce16") else n
        rows.append(dict(mesh=kind, triangles=20 * 4 ** level, width=width, height=height, path=name,
                         median_ms=f"{med * 1e3:.1f}", ratio=f"{med / unit:.2f}", rays=nr,
                         ns_per_ray=_per_ray(name, med, unit, nr), repeats=repeats,
                         note=f"load {load:.1f} on {os.cpu_count()} cores"))
    return rows


BEGIN, END = "<!-- shadows:begin (benchmarks/bench_shadows.py) -->", "<!-- shadows:end -->"
LABELS = {"shadows": "shadows on (batched kernel, packets of its lanes; ns: added a ray)",
          "shadows_tiles": "shadows on, general kernel, a packet per 4x4 tile (before; ns: added a ray)",
          "shadows_single": "shadows on, one ray at a time (ns: added a ray)",
          "rays_occluded1": "the same rays, bare `rtcOccluded1`", "rays_occluded16": "the same rays, bare `rtcOccluded16`",
          "mirror": "a mirror material, one bounce (ns: added a bounce ray)",
          "rays_bounce16": "its bounce rays, bare `rtcIntersect16` (the mirror's floor: the frame + this)"}


def table(rows) -> str:
    """The markdown table of ``rows``: per mesh and size, each path's ratio to the plain frame (ns a ray)."""
    cases = list(dict.fromkeys((r["mesh"], r["triangles"], r["width"], r["height"]) for r in rows))
    get = {(r["mesh"], r["width"], r["height"], r["path"]): r for r in rows}
    head = ["path"] + [f"{int(t):,} tris, {w}×{h}" for _, t, w, h in cases]
    out = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    out.append("| plain Phong frame (the unit), ms | "
               + " | ".join(get[(m, w, h, "frame")]["median_ms"] for m, _, w, h in cases) + " |")
    out.append("| shadow rays | " + " | ".join(f"{int(get[(m, w, h, 'frame')]['rays']):,}" for m, _, w, h in cases)
               + " |")
    if all((m, w, h, "mirror") in get for m, _, w, h in cases):  # (a CSV from before the mirror rows has none)
        out.append("| bounce rays | " + " | ".join(f"{int(get[(m, w, h, 'mirror')]['rays']):,}"
                                                   for m, _, w, h in cases) + " |")
    for name, label in LABELS.items():
        if not all((m, w, h, name) in get for m, _, w, h in cases):
            continue
        cells = [f"{get[(m, w, h, name)]['ratio']}× ({get[(m, w, h, name)]['ns_per_ray']} ns a ray)"
                 for m, _, w, h in cases]
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    out.append("| machine load | " + " | ".join(get[(m, w, h, "frame")]["note"] for m, _, w, h in cases) + " |")
    return "\n".join(out) + "\n"


def write_table(rows, quick: bool) -> str:
    """Put :func:`table` between the markers of ``docs/performance.md`` (quick: ``out/quick/results/shadows.md``)."""
    return where.write_table(table(rows), "shadows.md", BEGIN, END, quick)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="one small case; writes under out/quick/")
    p.add_argument("--repeats", type=int, default=None)
    p.add_argument("--table", action="store_true", help="only redo the table from the CSV")
    args = p.parse_args(argv)
    if args.table:
        with open(results_file("shadows.csv", args.quick), newline="") as fh:
            rows = list(csv.DictReader(fh))
        write_table(rows, args.quick)
        return rows
    cases = QUICK_CASES if args.quick else CASES
    repeats = args.repeats or (2 if args.quick else 5)
    rows = []
    for case in cases:
        rows += bench_case(*case, repeats)
        for r in rows[-len(LABELS) - 1:]:
            print(r["mesh"], r["width"], r["path"], r["median_ms"], r["ratio"], r["ns_per_ray"], r["note"], flush=True)
    out = results_file("shadows.csv", args.quick)
    write_csv(out, rows, FIELDS)
    write_table(rows, args.quick)
    return rows


if __name__ == "__main__":
    main()
