"""Figures for ``docs/antialiasing.md``.

Run ``python -m docs.figures.aa [--quick]``. Writes to ``docs/images/``:

* ``aa_samples.png``: one scene at 1, 4 and 16 samples per pixel (top), and
  the same 24x16-pixel corner of each magnified 10 times, nearest-neighbour
  (bottom);
* ``aa_pattern.png``: the sample positions in a pixel for N = 4, 16, 64;
* ``spot_light.png``: a spot light with shadows on a floor (left), and the
  rendered falloff along a row of the floor against Warn's closed form (right);
* ``area_light.png``: one scene under a point light and under disc area lights of 1 and 64
  samples (top), and the penumbra of an edge against the closed-form fraction of the
  disc it uncovers (bottom).
"""

from __future__ import annotations

import dataclasses
import os
import sys

import numpy as np

import raycast_shade as rs
from raycast_shade.common.samples import sample_offsets

from benchmarks.outputs import ROOT, images_dir

IMAGES = images_dir(False)


def _save_rgb(rgb8, name):
    import imageio.v3 as iio

    path = os.path.join(IMAGES, name)
    iio.imwrite(path, rgb8)
    print(f"wrote {os.path.relpath(path, ROOT)}")


def aa_scene(width=240, height=160):
    cube = rs.Model(rs.shapes.cube(1.0, center=(-0.55, 0.0, 0.0)), rs.Material(kd=(0.85, 0.35, 0.2), ks=0.3))
    ball = rs.Model(rs.shapes.icosphere(3, radius=0.55, center=(0.75, 0.05, 0.1)),
                    rs.Material(kd=(0.25, 0.45, 0.85), ks=0.6, shininess=60))
    floor = rs.Model(rs.shapes.plane(6, normal="+y", center=(0, -0.5, 0)), rs.Material(kd=0.75))
    cam = rs.Camera(eye=(0.6, 1.4, 3.4), target=(0.1, 0.0, 0.0), width=width, height=height, fov=40)
    lights = [rs.PointLight((2.5, 3.5, 2.5), intensity=18, attenuation="inverse_square", shadows=True),
              rs.DirectionalLight((-0.5, -1, -0.3), intensity=0.25)]
    return rs.Scene([cube, ball, floor], lights=lights, camera=cam, ambient=0.06, background=(0.9, 0.92, 0.95))


def aa_figure(counts=(1, 4, 16), crop=(slice(42, 58), slice(34, 58)), zoom=10):
    scene = aa_scene()
    tops, zooms = [], []
    for n in counts:
        img = rs.to_uint8(rs.render(scene, "phong", samples=n).image)
        tops.append(img)
        part = img[crop]
        zooms.append(np.repeat(np.repeat(part, zoom, axis=0), zoom, axis=1))
    gap = 8
    white = 255
    top_w = sum(t.shape[1] for t in tops) + gap * (len(tops) - 1)
    zoom_w = sum(z.shape[1] for z in zooms) + gap * (len(zooms) - 1)
    width = max(top_w, zoom_w)
    height = tops[0].shape[0] + gap + zooms[0].shape[0]
    canvas = np.full((height, width, 3), white, np.uint8)
    x = (width - top_w) // 2
    for t in tops:
        canvas[:t.shape[0], x:x + t.shape[1]] = t
        # the crop's outline on the full image
        ys, xs = crop
        canvas[ys.start, x + xs.start:x + xs.stop] = (255, 0, 0)
        canvas[ys.stop - 1, x + xs.start:x + xs.stop] = (255, 0, 0)
        canvas[ys.start:ys.stop, x + xs.start] = (255, 0, 0)
        canvas[ys.start:ys.stop, x + xs.stop - 1] = (255, 0, 0)
        x += t.shape[1] + gap
    x = (width - zoom_w) // 2
    y = tops[0].shape[0] + gap
    for z in zooms:
        canvas[y:y + z.shape[0], x:x + z.shape[1]] = z
        x += z.shape[1] + gap
    _save_rgb(canvas, "aa_samples.png")


def pattern_figure(counts=(4, 16, 64)):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(counts), figsize=(3.0 * len(counts), 3.1))
    for ax, n in zip(axes, counts):
        off = sample_offsets(n)
        ax.scatter(off[1:, 0], -off[1:, 1], s=18, color="tab:blue")
        ax.scatter([0], [0], s=40, color="tab:red", label="sample 0: the centre")
        ax.set_xlim(-0.5, 0.5)
        ax.set_ylim(-0.5, 0.5)
        ax.set_xticks(np.linspace(-0.5, 0.5, 5))
        ax.set_yticks(np.linspace(-0.5, 0.5, 5))
        ax.grid(True, lw=0.4)
        ax.set_aspect("equal")
        ax.set_title(f"N = {n}")
    axes[0].legend(loc="lower left", fontsize=7)
    fig.tight_layout()
    path = os.path.join(IMAGES, "aa_pattern.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {os.path.relpath(path, ROOT)}")


def spot_figure(size=360):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spot = rs.SpotLight((0.0, 3.0, 0.0), (0.0, -1.0, 0.0), intensity=2.2, color=(1.0, 0.92, 0.75), exponent=8.0,
                        inner_angle=22.0, outer_angle=32.0, shadows=True)
    floor = rs.Model(rs.shapes.plane(8, subdivisions=4, normal="+y"), rs.Material(kd=0.8, ka=0.3))
    ball = rs.Model(rs.shapes.icosphere(4, radius=0.45, center=(0.55, 0.45, 0.2)),
                    rs.Material(kd=(0.3, 0.5, 0.9), ks=0.5, shininess=50, ka=0.3))
    fill = rs.DirectionalLight((0.3, -1.0, -0.6), intensity=0.05)
    cam = rs.Camera(eye=(0.0, 3.2, 4.2), target=(0.0, 0.0, 0.3), width=size, height=size, fov=42)
    scene = rs.Scene([floor, ball], lights=[spot, fill], camera=cam, ambient=0.05, background=0.0)
    img = rs.to_uint8(rs.render(scene, "phong", samples=4).image)

    # The falloff: the bare floor, seen from straight above, along the row through the axis.
    top = rs.Camera(eye=(0, 5, 0), target=(0, 0, 0), up=(0, 0, -1), width=401, height=9,
                    projection="orthographic", ortho_height=8 * 9 / 401)
    bare = rs.Scene([rs.Model(rs.shapes.plane(8, normal="+y"), rs.Material(kd=0.8, ka=0.0))],
                    lights=[dataclasses.replace(spot, shadows=False)], camera=top,
                    ambient=0.0)
    frame = rs.render(bare, "phong", buffers=("position",))
    x = frame.buffers["position"][4, :, 0].astype(np.float64)
    got = frame.image[4, :, 0]
    c = 3.0 / np.hypot(x, 3.0)
    closed = 0.8 * spot.intensity * spot.falloff(c) * c
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(9.6, 4.2), gridspec_kw=dict(width_ratios=(1, 1.25)))
    a0.imshow(img)
    a0.set_axis_off()
    a0.set_title("n = 8, cones 22 and 32 degrees, shadows", fontsize=10)
    a1.plot(x, got, lw=3, color="tab:orange", label="rendered (red channel)")
    a1.plot(x, closed, "k--", lw=1, label=r"$k_d I \cos^n\!a \,\mathrm{smoothstep}(\cos a)\,\cos a$")
    for deg, ls in ((spot.inner_angle, ":"), (spot.outer_angle, "-.")):
        r = 3.0 * np.tan(np.radians(deg))
        for s in (-r, r):
            a1.axvline(s, color="grey", ls=ls, lw=0.8)
    a1.set_xlabel("x on the floor (light 3 units above x = 0)")
    a1.set_ylabel("linear intensity")
    a1.set_title(f"falloff: max |rendered - closed form| = {np.abs(got - closed).max():.1e}")
    a1.legend(fontsize=8)
    fig.tight_layout()
    path = os.path.join(IMAGES, "spot_light.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(f"wrote {os.path.relpath(path, ROOT)}")


def _segment(c, radius):
    """The fraction of a disc of ``radius`` with x >= c (a circular segment over the disc)."""
    d = np.clip(np.asarray(c, np.float64) / radius, -1.0, 1.0)
    return (np.arccos(d) - d * np.sqrt(1.0 - d * d)) / np.pi


def area_figure(size=260):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    floor = rs.Model(rs.shapes.plane(8, subdivisions=4, normal="+y"), rs.Material(kd=0.8))
    ball = rs.Model(rs.shapes.icosphere(4, radius=0.5, center=(0.0, 0.9, 0.0)),
                    rs.Material(kd=(0.3, 0.5, 0.9), ks=0.4, shininess=50))
    box = rs.Model(rs.shapes.cube(0.5, center=(-1.1, 0.25, 0.6)), rs.Material(kd=(0.85, 0.4, 0.2)))
    cam = rs.Camera(eye=(0.0, 3.0, 4.2), target=(0.0, 0.3, 0.0), width=size, height=size, fov=45)
    kw = dict(intensity=9.0, attenuation="inverse_square", shadows=True)
    where, radius = (0.6, 3.0, -0.3), 0.6
    lights = [("point light", rs.PointLight(where, **kw)),
              ("disc, 1 sample", rs.AreaLight.disc(where, (0, -1, 0), radius, samples=1, **kw)),
              ("disc r = 0.6, 64 samples", rs.AreaLight.disc(where, (0, -1, 0), radius, samples=64, **kw))]
    fill = rs.DirectionalLight((0.3, -1.0, -0.6), intensity=0.08)
    images = [rs.to_uint8(rs.render(rs.Scene([floor, ball, box], lights=[light, fill], camera=cam, ambient=0.04,
                                             background=0.0), "phong", samples=4).image) for _, light in lights]

    # The penumbra of a straight edge: a half-plane x <= 0 at height h under a disc at height H.
    R, H, h, n = 0.5, 2.0, 1.0, 256
    disc = rs.AreaLight.disc((0.0, 0.0, H), (0.0, 0.0, -1.0), R, samples=n, shadows=True)
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    ground = rs.Mesh(np.array([[-3.0, -3, 0], [3, -3, 0], [3, 3, 0], [-3, 3, 0]]), quad)
    blocker = rs.Mesh(np.array([[-9.0, -9, h], [0, -9, h], [0, 9, h], [-9, 9, h]]), quad)
    top = rs.Camera(eye=(0.3, 0.0, 5.0), target=(0.3, 0.0, 0.0), width=401, height=5,
                    projection="orthographic", ortho_height=0.6 * 5 / 401)
    scene = rs.Scene([rs.Model(ground, rs.Material(kd=0.8)), rs.Model(blocker, rs.Material(kd=0.1))],
                     lights=[disc], camera=top, ambient=0.0)
    frame = rs.render(scene, terms=True, buffers=("position",))
    x = frame.buffers["position"][2, :, 0].astype(np.float64)
    got = frame.terms["shadow"][0, 2]
    closed = _segment(-x * (H - h) / h, R)

    fig = plt.figure(figsize=(9.6, 6.4))
    grid = fig.add_gridspec(2, 3, height_ratios=(1.0, 0.8))
    for i, ((title, _), img) in enumerate(zip(lights, images)):
        ax = fig.add_subplot(grid[0, i])
        ax.imshow(img)
        ax.set_axis_off()
        ax.set_title(title, fontsize=10)
    ax = fig.add_subplot(grid[1, :])
    ax.plot(x, got, lw=3, color="tab:orange", label=f"rendered: unblocked samples of {n} (terms['shadow'])")
    ax.plot(x, closed, "k--", lw=1, label="closed form: the segment of the disc uncovered")
    ax.set_xlabel("x on the floor (edge of the blocker above x = 0; disc r = 0.5 at 2, blocker at 1)")
    ax.set_ylabel("fraction of the light")
    ax.set_title(f"penumbra: max |rendered - closed form| = {np.abs(got - closed).max():.1e}", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    path = os.path.join(IMAGES, "area_light.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(f"wrote {os.path.relpath(path, ROOT)}")


def main(argv=None):
    """Draw the figures; ``--quick`` writes them into the git-ignored ``out/quick/images/``."""
    global IMAGES
    argv = sys.argv[1:] if argv is None else list(argv)
    quick = "--quick" in argv
    IMAGES = images_dir(quick)
    os.makedirs(IMAGES, exist_ok=True)
    aa_figure()
    pattern_figure()
    spot_figure()
    area_figure()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
