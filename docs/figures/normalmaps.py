"""Figure for docs/textures.md's normal maps.

``python -m docs.figures.normalmaps [--quick]`` writes ``normal_maps.png`` into ``docs/images/``:
a square of side 2 (UVs 0..1) with 4 x 4 round dimples, lit from the upper left, Phong; left as a
Blinn bump map (``HeightMap.dimples``), middle as a tangent-space normal map baked from the same
heights (``n' = normalize(-Bu / |Pu|, -Bv / |Pv|, 1)`` per texel, ``Bu, Bv`` the heights' scaled
central differences), right the bump map's image without any map (the flat square). Prints the
largest difference between the bump-mapped and the normal-mapped images.
"""

from __future__ import annotations

import os
import sys

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

SIZE = 2.0  # the square's side: |Pu| = |Pv| = SIZE for UVs 0..1


def maps(resolution=128, scale=0.12):
    """The dimples as a HeightMap, and the normal map baked from its texels."""
    hm = rs.HeightMap.dimples(4, 0.35, resolution=resolution, scale=scale)
    h = hm.heights.astype(np.float64)
    rows, cols = h.shape
    # Central differences one texel wide, as the bump kernel takes them (repeat wrap), per unit of u, v.
    bu = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / 2.0 * cols * scale
    bv = (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) / 2.0 * rows * scale
    n = np.stack([-bu / SIZE, -bv / SIZE, np.ones_like(h)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return hm, rs.Texture((n + 1.0) / 2.0, filter="bilinear", name="dimples_normals")


def scene(**material):
    square = rs.shapes.plane(SIZE)
    cam = rs.Camera(eye=(0.0, -2.2, 2.4), target=(0.0, 0.0, 0.0), up=(0, 0, 1), fov=45, width=300, height=240)
    mat = rs.Material(kd=(0.75, 0.6, 0.4), ks=0.35, shininess=30, **material)
    return rs.Scene([rs.Model(square, mat)], lights=[rs.DirectionalLight((1.0, -0.3, -0.8))], camera=cam,
                    ambient=0.1)


def main(argv=None):
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    import imageio.v3 as iio

    argv = sys.argv[1:] if argv is None else list(argv)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    hm, nmap = maps()
    frames = [rs.render(scene(bump=hm)), rs.render(scene(normal_map=nmap)), rs.render(scene())]
    diff = float(np.abs(frames[0].image - frames[1].image).max())
    panels = [np.asarray(f.to_uint8()) for f in frames]
    gap = np.full((panels[0].shape[0], 6, 3), 255, np.uint8)
    path = os.path.join(out, "normal_maps.png")
    iio.imwrite(path, np.concatenate([panels[0], gap, panels[1], gap, panels[2]], axis=1))
    print("wrote", path)
    print(f"max |bump-mapped - normal-mapped| (linear RGB): {diff:.3g}")
    return 0


if __name__ == "__main__":
    main()
