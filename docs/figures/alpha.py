"""Figure for docs/textures.md's alpha masks.

``python -m docs.figures.alpha [--quick]`` writes ``alpha_mask.png`` into ``docs/images/``: a
leaf-like cut-out (a disc of coverage with round holes, as an alpha map on one quad of two
triangles) over a floor, lit by a point light with shadows, and a mirror behind it; left the
same quad opaque, right masked at 0.5: the camera, the shadow and the mirror all see through
the holes.
"""

from __future__ import annotations

import os
import sys

import numpy as np

import raycast_shade as rs

from benchmarks.outputs import images_dir

IMAGES = images_dir(False)


def coverage(n=128):
    """(n, n) coverage: 1 inside a disc, 0 outside it and in four round holes; smooth across 2 texels."""
    c = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    d = 0.9 - np.hypot(x, y)
    for hx, hy in ((0.4, 0.4), (-0.4, 0.4), (0.4, -0.4), (-0.4, -0.4)):
        d = np.minimum(d, np.hypot(x - hx, y - hy) - 0.2)
    return np.clip(0.5 + d * n / 4.0, 0.0, 1.0)


def scene(masked: bool):
    quad = rs.Mesh(np.array([(-1, -1, 0.0), (1, -1, 0.0), (1, 1, 0.0), (-1, 1, 0.0)]),
                   np.array([(0, 1, 2), (0, 2, 3)]), uvs=np.array([(0, 0), (1, 0), (1, 1), (0, 1.0)]), name="leaf")
    cov = coverage()
    alpha = dict(alpha_map=rs.Texture(np.repeat(cov[..., None], 3, 2), wrap="clamp", name="leaf_alpha"),
                 alpha_cutoff=0.5) if masked else {}
    leaf = rs.Model(quad, rs.Material(kd=(0.25, 0.7, 0.2), ks=0.2, name="leaf", **alpha))
    floor = rs.Model(rs.shapes.plane(size=8.0, center=(0.0, 0.0, -1.0)), rs.Material(kd=0.8, name="floor"))
    mirror = rs.Model(rs.Mesh(np.array([(-3, 3, -1.0), (3, 3, -1.0), (3, 3, 3.0), (-3, 3, 3.0)]),
                              np.array([(0, 1, 2), (0, 2, 3)]), name="mirror"),
                      rs.Material(kd=0.05, reflectivity=0.85, name="mirror"))
    cam = rs.Camera(eye=(2.6, -4.2, 2.4), target=(0.0, 0.6, -0.2), up=(0, 0, 1), fov=45, width=360, height=270)
    return rs.Scene([leaf, floor, mirror], lights=[rs.PointLight((-0.6, -1.2, 3.0), intensity=9.0,
                                                                 attenuation="inverse_square", shadows=True)],
                    camera=cam, ambient=0.15)


def main(argv=None):
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    import imageio.v3 as iio

    argv = sys.argv[1:] if argv is None else list(argv)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    panels = [np.asarray(rs.render(scene(m), max_depth=1).to_uint8()) for m in (False, True)]
    gap = np.full((panels[0].shape[0], 6, 3), 255, np.uint8)
    path = os.path.join(out, "alpha_mask.png")
    iio.imwrite(path, np.concatenate([panels[0], gap, panels[1]], axis=1))
    print("wrote", path)
    return 0


if __name__ == "__main__":
    main()
