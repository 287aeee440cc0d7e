"""Surfaces benchmark: shadows from two lights and a mirror against the primary-only frame.

Run ``python -m benchmarks.bench_surfaces [--quick]``. One scene (a floor, a
bump-mapped sphere, an 81,920-triangle icosphere and a mirror, lit by a point
light and a directional light) is rendered twice per resolution:

* *primary*: the same scene with ``shadows=False`` on both lights and
  ``max_depth=0``: one camera cast plus Phong shading;
* *surfaces*: both lights cast shadows, the mirror reflects (``max_depth=3``;
  a single planar mirror never bounces twice).

Issue 3's target is ``(1 + number of extra casts) x`` the primary frame. Two
ways to count the extra casts are reported:

* nominal: 2 shadow casts (one per light) + 1 mirror cast = 3, target 4x;
* by rays: the shadow rays actually traced at primary hits (one per light
  where ``n.s > 0``: the kernels skip lights behind the surface), the mirror
  rays, and the shadow rays at the mirror rays' hits, divided by the number
  of primary rays; target ``(1 + that) x``.

Times are medians of repeats after a warm-up (JIT and BVH build excluded).
Results: ``benchmarks/results/surfaces.csv`` (``out/quick/results/surfaces.csv``
with ``--quick``: 640x480 only, as everywhere in this suite).
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import replace

import numpy as np

from benchmarks.outputs import results_file, write_csv


def scene(width: int, height: int, surfaces: bool = True):
    """The benchmark scene; ``surfaces=False`` turns the shadows off."""
    import raycast_shade as rs

    hm = rs.HeightMap.dimples(8, 0.35, scale=0.03)
    models = [
        rs.Model(rs.shapes.plane(8.0, subdivisions=4, center=(0.0, -0.8, 0.0), normal="+y"), rs.Material(kd=0.7)),
        rs.Model(rs.shapes.uv_sphere(32, 64, radius=0.8, center=(-0.9, 0.0, 0.0)),
                 rs.Material(kd=(0.9, 0.4, 0.2), ks=0.4, shininess=30, bump=hm)),
        rs.Model(rs.shapes.icosphere(6, radius=0.7, center=(0.9, -0.1, 0.2)),
                 rs.Material(kd=(0.2, 0.5, 0.9), ks=0.6, shininess=60)),
        rs.Model(rs.shapes.plane(4.0, center=(0.0, 1.0, -1.5), normal="+z"), rs.Material(kd=0.05, reflectivity=0.9)),
    ]
    lights = [rs.PointLight((2.0, 4.0, 3.0), intensity=25.0, attenuation="inverse_square", shadows=surfaces),
              rs.DirectionalLight((1.0, -1.0, -0.5), 0.4, color=(0.4, 0.5, 1.0), shadows=surfaces)]
    return rs.Scene(models, lights=lights, camera=rs.Camera(eye=(0.0, 1.2, 5.0), width=width, height=height),
                    ambient=0.08, background=(0.02, 0.02, 0.04))


def _to_lights(points, lights, origin):
    """(L, N, 3) unit directions from each point towards each light (world coordinates)."""
    import raycast_shade as rs

    out = []
    for light in lights:
        if isinstance(light, rs.PointLight):
            s = light.position - (points + origin)
            s = s / np.linalg.norm(s, axis=1, keepdims=True)
        else:
            s = np.broadcast_to(-light.direction, points.shape)
        out.append(s)
    return np.stack(out)


def count_rays(sc, frame):
    """Rays each kind of cast traces in one frame of ``sc`` (with shadows and mirror).

    Returns dict: primary, shadow_primary, mirror, shadow_secondary.
    """
    import raycast_shade as rs
    from raycast_shade.study.twins import generate_rays_numpy

    geo = sc.geometry
    cam = sc.camera
    hit = frame.mask.reshape(-1)
    o, d = generate_rays_numpy(cam, geo.origin)  # re-centred coordinates
    p = o[hit] + frame.hits.t.reshape(-1)[hit, None].astype(np.float64) * d[hit]
    n = frame.normal.reshape(-1, 3)[hit].astype(np.float64)
    s = _to_lights(p, sc.lights, geo.origin)
    shadow_primary = int(np.sum(np.einsum("lij,ij->li", s, n) > 0))
    # mirror rays: from every pixel of a reflective model, along r = d - 2 (d.n) n
    refl = geo.materials[frame.hits.geom.reshape(-1)[hit], 11] > 0
    dm, nm, pm = d[hit][refl], n[refl], p[refl]
    r = dm - 2 * np.sum(dm * nm, 1, keepdims=True) * nm
    prim, gm, u, v, _ = rs.cast_rays(geo, pm + geo.origin + 1e-4 * nm, r)
    ok = prim >= 0
    face = geo.face_offsets[gm[ok]] + prim[ok]
    tri = geo.faces[face]
    b1, b2 = u[ok].astype(np.float64), v[ok].astype(np.float64)
    w = np.stack([1 - b1 - b2, b1, b2], 1)
    q = np.einsum("ik,ikj->ij", w, geo.vertices[tri])
    nq = np.einsum("ik,ikj->ij", w, geo.normals[tri])
    nq *= np.where(np.sum(nq * r[ok], 1) > 0, -1.0, 1.0)[:, None]  # towards the incoming ray
    sq = _to_lights(q, sc.lights, geo.origin)
    shadow_secondary = int(np.sum(np.einsum("lij,ij->li", sq, nq) > 0))
    return dict(primary=cam.width * cam.height, shadow_primary=shadow_primary, mirror=int(refl.sum()),
                shadow_secondary=shadow_secondary)


def _median_ms(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def bench(width: int, height: int, repeats: int) -> dict:
    import raycast_shade as rs

    full = scene(width, height)
    plain = full.replace(lights=[replace(light, shadows=False) for light in full.lights])  # shares the BVH
    for _ in range(2):  # warm-up: JIT, BVH build, tangent frames
        rs.render(plain, max_depth=0)
        frame = rs.render(full, max_depth=3)
    t_primary = _median_ms(lambda: rs.render(plain, max_depth=0), repeats)
    t_surfaces = _median_ms(lambda: rs.render(full, max_depth=3), repeats)
    stages = {k: 1e3 * v for k, v in rs.render(full, max_depth=3).timings.items()}
    rays = count_rays(full, frame)
    extra = (rays["shadow_primary"] + rays["mirror"] + rays["shadow_secondary"]) / rays["primary"]
    target_nominal = 4.0 * t_primary
    target_rays = (1.0 + extra) * t_primary
    return dict(
        size=f"{width}x{height}", repeats=repeats,
        primary_ms=round(t_primary, 2), surfaces_ms=round(t_surfaces, 2),
        slowdown=round(t_surfaces / t_primary, 3),
        cast_ms=round(stages.get("cast", float("nan")), 2), shade_ms=round(stages.get("shade", float("nan")), 2),
        mirror_ms=round(stages.get("mirror", float("nan")), 2),
        primary_rays=rays["primary"], shadow_rays_primary=rays["shadow_primary"], mirror_rays=rays["mirror"],
        shadow_rays_secondary=rays["shadow_secondary"], extra_casts_by_rays=round(extra, 3),
        target_nominal_ms=round(target_nominal, 2), ratio_to_nominal_target=round(t_surfaces / target_nominal, 3),
        target_by_rays_ms=round(target_rays, 2), ratio_to_rays_target=round(t_surfaces / target_rays, 3),
    )


def run(quick: bool = False) -> list[dict]:
    """Rows for 640x480 (quick) or 640x480 and 1920x1080."""
    sizes = [(640, 480)] if quick else [(640, 480), (1920, 1080)]
    return [bench(w, h, 5 if quick else 9) for w, h in sizes]


def outputs(quick: bool) -> list[str]:
    """The CSV :func:`main` writes (see :mod:`benchmarks.outputs`)."""
    return [results_file("surfaces.csv", quick)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="640x480 only, fewer repeats")
    args = ap.parse_args(argv)
    rows = run(args.quick)
    path, = outputs(args.quick)
    write_csv(path, rows)
    for r in rows:
        print(f"{r['size']}: primary {r['primary_ms']:.1f} ms, shadows (2 lights) + mirror {r['surfaces_ms']:.1f} ms "
              f"({r['slowdown']:.2f}x); target 4x primary = {r['target_nominal_ms']:.1f} ms "
              f"(ratio {r['ratio_to_nominal_target']:.2f}); by rays (1 + {r['extra_casts_by_rays']:.2f})x = "
              f"{r['target_by_rays_ms']:.1f} ms (ratio {r['ratio_to_rays_target']:.2f})")
    print(f"wrote {os.path.relpath(path)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
