"""Figures (and a quick timing) for docs/surfaces.md: bumps, shadows and mirrors.

``python -m docs.figures.surfaces [--no-timing] [--quick]`` writes, into ``docs/images/``:

* ``surfaces.png``: bumps, two shadowing lights and a mirror in one scene;
* ``surfaces_bump.png``: a sphere without a bump map, with dimples, with
  wrinkles (Phong), and the wrinkled one in Gouraud mode (bumps ignored);
* ``surfaces_terminator.png``: a coarse smooth-shaded sphere under a
  shadow-casting light, without and with Hanika's terminator fix, and the
  pixels the fix gives back. The renderer has no switch to turn the fix off,
  so the "without" panel is the rendered image with the pixels whose
  unlifted shadow ray is blocked (traced with ``rs.cast_rays``, same offset
  and end as the kernels) set to what a shadowed pixel shows, the ambient term;
* ``surfaces_mirror.png``: a perfect mirror beside a sphere, and the sphere
  seen by the mirrored camera, flipped left to right (``tests/shading/test_mirror.py``);

and prints the frame time with and without the extra casts (median of repeats
after a warm-up; the full measurement is ``benchmarks/bench_surfaces.py``).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

IMAGES = images_dir(False)


def scene(width=640, height=400, shadows=True, mirror=True):
    hm = rs.HeightMap.dimples(8, 0.35, scale=0.03)  # heights in [-1, 0]: dents
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


def _save(image, name):
    import imageio.v3 as iio

    path = os.path.join(IMAGES, name)
    iio.imwrite(path, rs.to_uint8(image))
    print(f"wrote {path}")


def bump_figure(width=640, height=240):
    """Four panels, 160 x 240 each: plain, dimples, wrinkles (Phong), wrinkles (Gouraud)."""
    w = width // 4
    cam = rs.Camera(eye=(0.0, 0.3, 5.0), width=w, height=height, fov=34)
    sphere = rs.shapes.uv_sphere(48, 96)
    lights = [rs.PointLight((2.0, 3.0, 3.0), intensity=1.0), rs.DirectionalLight((1.0, 0.3, -0.5), 0.3)]
    maps = [None, rs.HeightMap.dimples(6, 0.35, scale=0.05), rs.HeightMap.wrinkles(6, 4, scale=0.08), "gouraud"]
    panels, masks = [], []
    for hm in maps:
        shading = "gouraud" if hm == "gouraud" else "phong"
        bump = maps[2] if hm == "gouraud" else hm
        mat = rs.Material(kd=(0.8, 0.5, 0.3), ks=0.5, shininess=40, bump=bump)
        frame = rs.render(rs.Scene([rs.Model(sphere, mat)], lights=lights, camera=cam, ambient=0.08,
                                   background=(0.9, 0.9, 0.92)), shading)
        panels.append(frame.image)
        masks.append(frame.mask)
    assert all(np.array_equal(m, masks[0]) for m in masks)  # silhouettes unchanged
    return np.concatenate(panels, axis=1)


def _nudge(p, n, unit):
    """NumPy twin of the kernels' ray offset (see raycast_shade.shading.shadows._nudge)."""
    _, e = np.frexp(p)
    return np.where(np.abs(p) < unit / 32.0, p + n * (unit / 65536.0), p + n * np.ldexp(256.0, e - 24))


def terminator_figure(width=640, height=400, mesh=None):
    """Without the fix | with it | the difference; returns (image, counts)."""
    w = width // 3
    mesh = mesh if mesh is not None else rs.shapes.icosphere(1)
    cam = rs.Camera(eye=(0.0, 0.0, 4.0), width=w, height=height, fov=40)
    light = rs.PointLight((4.0, 0.5, 0.3), intensity=1.0, shadows=True)
    ka, ia = 0.15, 0.5
    sc = rs.Scene([rs.Model(mesh, rs.Material(kd=0.8, ka=ka))], lights=[light], camera=cam, ambient=ia,
                  background=(0.9, 0.9, 0.92))
    fixed = rs.render(sc)
    plain = rs.render(sc.replace(lights=[replace(light, shadows=False)]))
    lit = fixed.mask & (plain.image[..., 0] > np.float32(ka * ia))  # n.s > 0 by the kernel's own arithmetic
    geo = sc.geometry
    m = fixed.mask
    face = geo.face_offsets[fixed.hits.geom[m]] + fixed.hits.prim[m]
    tri = geo.faces[face]
    b1, b2 = fixed.hits.u[m].astype(np.float64), fixed.hits.v[m].astype(np.float64)
    p = np.einsum("ik,ikj->ij", np.stack([1 - b1 - b2, b1, b2], 1), geo.vertices[tri])
    g = geo.face_normals[face]
    g = g * np.where(np.sum(g * (cam.eye - geo.origin - p), 1) < 0, -1.0, 1.0)[:, None]
    lp = light.position - geo.origin
    side = np.where(np.sum(g * (lp - p), 1) >= 0, 1.0, -1.0)[:, None]
    o = _nudge(p, side * g, geo.scale)
    prim, *_ = rs.cast_rays(geo, o + geo.origin, lp - o, tfar=1.0 - 1e-5)
    blocked = np.zeros(m.shape, bool)
    blocked[m] = prim >= 0
    false_without = lit & blocked
    false_with = lit & np.all(fixed.image == np.float32(ka * ia), axis=-1)
    without = fixed.image.copy()
    without[false_without] = np.float32(ka * ia)
    diff = np.full_like(fixed.image, 0.9)
    diff[m] = 0.3
    diff[false_without] = (1.0, 0.1, 0.1)
    counts = dict(lit=int(lit.sum()), without_fix=int(false_without.sum()), with_fix=int(false_with.sum()))
    return np.concatenate([without, fixed.image, diff], axis=1), counts


def mirror_figure(width=640, height=400):
    """The scene of tests/shading/test_mirror.py: mirror view | mirrored camera's view, flipped."""
    m = np.array([0.2, 0.1, 1.0]) / np.linalg.norm([0.2, 0.1, 1.0])  # the mirror's normal
    q = np.array([0.1, -0.1, 0.0])  # and a point on it

    def reflect_point(p):
        return p - 2.0 * np.dot(p - q, m) * m

    def reflect_dir(d):
        return d - 2.0 * np.dot(d, m) * m

    base = rs.shapes.plane(size=8.0, subdivisions=2)  # facing +z: turn it onto m
    axis = np.cross([0.0, 0.0, 1.0], m)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + k + k @ k * ((1 - m[2]) / np.dot(axis, axis))
    mirror = rs.Mesh(base.vertices @ rot.T + q, base.faces, normals=np.tile(m, (len(base.vertices), 1)))
    BACKGROUND = (0.05, 0.1, 0.2)
    LIGHTS = [rs.PointLight((2.0, 3.0, 4.0), intensity=0.8, color=(1.0, 0.9, 0.8)),
              rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.4)]
    SPHERE_MAT = rs.Material(kd=(0.8, 0.4, 0.2), ks=0.6, shininess=25)
    w = width // 2
    sphere = rs.shapes.icosphere(4, radius=0.5, center=(0.3, 0.2, 0.9))
    lights = LIGHTS + [rs.PointLight((0.3, 1.6, 0.25), intensity=0.6, color=(0.6, 0.8, 1.0))]
    eye, target, up = np.array([2.0, 1.0, 2.2]), np.array([0.1, 0.1, 0.3]), np.array([0.0, 1.0, 0.0])
    cam = rs.Camera(eye=eye, target=target, up=up, width=w, height=height, fov=40)
    mirrored = rs.Camera(eye=reflect_point(eye), target=reflect_point(target), up=reflect_dir(up),
                         width=w, height=height, fov=40)
    mirror_mat = rs.Material(ka=0.15, kd=0.15, ks=0.0, reflectivity=0.85)
    a = rs.render(rs.Scene([rs.Model(mirror, mirror_mat), rs.Model(sphere, SPHERE_MAT)], lights=lights,
                           camera=cam, ambient=0.1, background=BACKGROUND))
    b = rs.render(rs.Scene([rs.Model(sphere, SPHERE_MAT)], lights=lights, camera=mirrored, ambient=0.1,
                           background=BACKGROUND))
    return np.concatenate([a.image, b.image[:, ::-1]], axis=1)


def median_ms(s, repeats=7):
    rs.render(s)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rs.render(s)
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def main(argv=None):
    """Draw the figures (``--quick``: into the git-ignored ``out/quick/images/``, no timing)."""
    global IMAGES
    argv = sys.argv[1:] if argv is None else list(argv)
    IMAGES = images_dir("--quick" in argv)
    os.makedirs(IMAGES, exist_ok=True)
    rs.render(scene()).save(os.path.join(IMAGES, "surfaces.png"))
    print(f"wrote {os.path.join(IMAGES, 'surfaces.png')}")
    _save(bump_figure(), "surfaces_bump.png")
    image, counts = terminator_figure()
    _save(image, "surfaces_terminator.png")
    print(f"terminator (icosphere 1, {counts['lit']} lit pixels): falsely shadowed without the fix "
          f"{counts['without_fix']}, with it {counts['with_fix']}")
    _save(mirror_figure(), "surfaces_mirror.png")
    if "--no-timing" not in argv and "--quick" not in argv:
        w, h = 640, 400
        plain = median_ms(scene(w, h, shadows=False, mirror=False))
        both = median_ms(scene(w, h))
        print(f"{w}x{h}: primary only {plain:.1f} ms, 2 shadow lights + mirror {both:.1f} ms, ratio {both / plain:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
