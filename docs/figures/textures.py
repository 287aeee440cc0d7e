"""Figures for docs/textures.md: a textured model in the three modes, mip-mapping, colours.

``python -m docs.figures.textures [--quick]`` writes, into ``docs/images/``:

* ``texture_modes.png``: a low-polygon sphere with a colour map (a checkerboard of
  coloured squares and a stripe) under a point light, flat / Gouraud / Phong;
* ``texture_mipmap.png``: a checkerboard floor receding to the horizon, sampled at
  full resolution (bilinear) and mip-mapped, and the mip level each pixel used;
* ``texture_colors.png``: per-vertex colours (interpolated) and per-face colours
  on an icosphere, Phong, and the per-vertex sphere in Gouraud;

and prints the texel error figures: the rendered texel under the centres of the
head-on plane's blocks against the texture (closed form), and the largest
difference of each mode from the NumPy reference.
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np

import raycast_shade as rs
from raycast_shade.shading.texture import texture_levels
from raycast_shade.study.reference import shade_reference

from benchmarks.outputs import images_dir

IMAGES = images_dir(False)


def _save(name, panels, gap=6):
    import imageio.v3 as iio

    h = max(p.shape[0] for p in panels)
    row = []
    for i, p in enumerate(panels):
        if i:
            row.append(np.full((h, gap, 3), 255, np.uint8))
        row.append(np.pad(p, ((0, h - p.shape[0]), (0, 0), (0, 0)), constant_values=255))
    iio.imwrite(os.path.join(IMAGES, name), np.concatenate(row, axis=1))
    print("wrote", os.path.join(IMAGES, name))


def map_texture(n=256):
    """A colour checkerboard (8 x 4 squares) with a white stripe along v = 1/2."""
    j, i = np.meshgrid(np.arange(2 * n), np.arange(n))
    sq = ((j * 8) // (2 * n) + (i * 4) // n) % 2
    hue = (j * 8) // (2 * n) / 8.0
    a = np.stack([0.5 + 0.5 * np.cos(2 * np.pi * (hue + k / 3)) for k in range(3)], axis=-1)
    tex = np.where(sq[..., None] == 1, a, 0.15 + 0.1 * a)
    tex[np.abs(i - n // 2) < n // 40] = 0.9
    return rs.Texture(tex, name="checker-map")


def modes_figure():
    mesh = rs.shapes.uv_sphere(rings=10, segments=16)
    scene = rs.Scene([rs.Model(mesh, rs.Material(kd_map=map_texture(), ks=0.5, shininess=40))],
                     lights=[rs.PointLight((2.5, 2.0, 4.0), intensity=28, attenuation="inverse_square")],
                     ambient=0.08, camera=rs.Camera(eye=(0.0, 0.5, 3.0), width=300, height=300, fov=42))
    panels, errors = [], {}
    for shading in ("flat", "gouraud", "phong"):
        frame = rs.render(scene, shading=shading)
        ref = shade_reference(scene, scene.camera, frame.hits, shading)
        errors[shading] = float(np.abs(frame.image - ref).max())
        panels.append(rs.to_uint8(frame.image))
    _save("texture_modes.png", panels)
    return errors


def mipmap_figure():
    board = dict(squares=64, texels_per_square=4, tiling=(4.0, 4.0))
    cam = rs.Camera(eye=(0.0, 0.35, 3.0), target=(0.0, 0.0, -2.0), width=320, height=200, fov=50)
    panels = []
    for filt in ("bilinear", "mipmap"):
        floor = rs.shapes.plane(size=12, normal="+y", center=(0, 0, -3))
        scene = rs.Scene([rs.Model(floor, rs.Material(kd_map=rs.Texture.checker(**board, filter=filt)))],
                         lights=[rs.DirectionalLight((0, -1, -0.3), intensity=1.0)], ambient=0.05,
                         background=(0.55, 0.65, 0.8), camera=cam)
        frame = rs.render(scene)
        panels.append(rs.to_uint8(frame.image))
    levels = texture_levels(scene, cam, frame.hits)
    shown = np.nan_to_num(np.clip(levels, 0, 10) / 10, nan=1.0)
    import matplotlib

    rgb = (matplotlib.colormaps["viridis"](shown)[..., :3] * 255).astype(np.uint8)
    rgb[np.isnan(levels)] = 255
    panels.append(rgb)
    _save("texture_mipmap.png", panels)


def colors_figure():
    ico = rs.shapes.icosphere(2)
    rng = np.random.default_rng(7)
    vc = 0.5 + 0.5 * ico.vertices  # position as colour: smooth
    per_vertex = rs.Mesh(ico.vertices, ico.faces, normals=ico.normals, colors=np.clip(vc, 0, 1) ** 2)
    per_face = rs.Mesh(ico.vertices, ico.faces, normals=ico.normals, colors=rng.random((len(ico.faces), 3)))
    light = [rs.PointLight((2.0, 2.5, 4.0), intensity=24, attenuation="inverse_square")]
    cam = rs.Camera(eye=(0, 0.3, 3.2), width=240, height=240, fov=40)
    panels = []
    for mesh, shading in ((per_vertex, "phong"), (per_face, "phong"), (per_vertex, "gouraud")):
        scene = rs.Scene([rs.Model(mesh, rs.Material(ks=0.3, shininess=30))], lights=light, ambient=0.1, camera=cam)
        panels.append(rs.to_uint8(rs.render(scene, shading=shading).image))
    _save("texture_colors.png", panels)


def texel_errors():
    """Head-on plane, 8 x 8 blocks of 4 x 4 texels: the pixel nearest each block centre
    shows the block's colour (lit head on, no ambient)."""
    colours = np.random.default_rng(0).random((8, 8, 3))
    tex = rs.Texture(np.repeat(np.repeat(colours, 4, axis=0), 4, axis=1))
    scene = rs.Scene([rs.Model(rs.shapes.plane(size=2.0), rs.Material(kd_map=tex))],
                     lights=[rs.DirectionalLight((0, 0, -1))], ambient=0.0,
                     camera=rs.Camera(eye=(0, 0, 2), width=256, height=256, fov=90))
    out = {}
    for shading in ("gouraud", "phong"):
        img = rs.render(scene, shading=shading).image
        err = 0.0
        for bi in range(8):
            for bj in range(8):
                u, v = (bj + 0.5) / 8, (bi + 0.5) / 8
                x = int(round(((2 * u - 1) / 2 + 1) * 128 - 0.5))
                y = int(round((1 - (2 * v - 1) / 2) * 128 - 0.5))
                err = max(err, float(np.abs(img[y, x] - colours[bi, bj]).max()))
        out[shading] = err
    # Footprint level on a plane at distance d, against log2(N / S * 2 d tan(fov/2) / H).
    worst = 0.0
    for d in (1.0, 4.0, 16.0, 50.0):
        s = rs.Scene([rs.Model(rs.shapes.plane(size=2 * d), rs.Material(kd_map=rs.Texture(np.ones((256, 256, 3)))))],
                     lights=[rs.DirectionalLight((0, 0, -1))], camera=rs.Camera(eye=(0, 0, d), width=80, height=64, fov=60))
        f = rs.render(s)
        lv = texture_levels(s, s.camera, f.hits)
        want = math.log2(256 / (2 * d) * 2 * d * math.tan(math.radians(30)) / 64)
        worst = max(worst, float(np.nanmax(np.abs(lv - want))))
    out["level"] = worst
    return out


def main(argv=None):
    """Draw the figures; ``--quick`` writes them into the git-ignored ``out/quick/images/``."""
    global IMAGES
    argv = sys.argv[1:] if argv is None else list(argv)
    quick = "--quick" in argv
    IMAGES = images_dir(quick)
    os.makedirs(IMAGES, exist_ok=True)
    errors = modes_figure()
    mipmap_figure()
    colors_figure()
    texel = texel_errors()
    print("max |kernel - NumPy reference| per mode (textured sphere):",
          ", ".join(f"{k} {v:.2e}" for k, v in errors.items()))
    print("max |texel under block centre - block colour|:", ", ".join(f"{k} {v:.2e}" for k, v in texel.items()
                                                                   if k != "level"))
    print(f"max |mip level - log2(texels per pixel)| on head-on planes: {texel['level']:.2e}")
    return 0


if __name__ == "__main__":
    main()
