"""Figure and timing for docs/surfaces.md: bumps, shadows and a mirror in one scene.

``python benchmarks/make_surface_figures.py`` writes ``docs/images/surfaces.png``
and prints the frame time with and without the extra casts (median of repeats
after a warm-up).
"""

import os
import time

import numpy as np

import raycast_shade as rs

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def scene(width=640, height=400, shadows=True, mirror=True):
    hm = rs.HeightMap.dimples(8, 0.35, scale=-0.03)
    models = [
        rs.Model(rs.shapes.uv_sphere(32, 64, center=(-0.9, 0, 0), radius=0.8),
                 rs.Material(kd=(0.9, 0.4, 0.2), ks=0.4, shininess=30, bump=hm)),
        rs.Model(rs.shapes.icosphere(4, center=(0.9, 0, 0.2), radius=0.7),
                 rs.Material(kd=(0.2, 0.5, 0.9), ks=0.6, shininess=60)),
        rs.Model(rs.shapes.plane(8, center=(0, -0.8, 0), normal="+y"), rs.Material(kd=0.7)),
        rs.Model(rs.shapes.plane(4, center=(0, 1, -1.5), normal="+z"),
                 rs.Material(kd=0.05, reflectivity=0.9 if mirror else 0.0)),
    ]
    lights = [rs.PointLight((2, 4, 3), intensity=25, attenuation="inverse_square", shadows=shadows),
              rs.DirectionalLight((1, -1, -0.5), 0.4, color=(0.4, 0.5, 1.0), shadows=shadows)]
    return rs.Scene(models, lights=lights, camera=rs.Camera(eye=(0, 1.2, 5), width=width, height=height),
                    ambient=0.08, background=(0.02, 0.02, 0.04))


def median_ms(s, repeats=7):
    rs.render(s)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rs.render(s)
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


if __name__ == "__main__":
    full = scene()
    rs.render(full).save(os.path.join(ROOT, "docs", "images", "surfaces.png"))
    for w, h in ((640, 400), (1920, 1080)):
        plain = median_ms(scene(w, h, shadows=False, mirror=False))
        both = median_ms(scene(w, h))
        frame = rs.render(scene(w, h))
        mirror_px = int(np.isin(frame.hits.geom, [3]).sum())
        print(f"{w}x{h}: primary only {plain:.1f} ms, 2 shadow lights + mirror {both:.1f} ms, "
              f"ratio {both / plain:.2f} (extra casts: up to 2 shadow rays per lit point, "
              f"{mirror_px} mirror pixels of {w * h})")
