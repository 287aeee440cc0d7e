"""Figure for docs/vision.md's BOP export.

``python -m docs.figures.bop [--quick]`` writes ``bop_masks.png`` into ``docs/images/``: a view set
of three posed models written with ``exports=("bop",)`` (160x120), left its ``rgb/000000.png``,
right the same image with each ``mask_visib/000000_{gt:06d}.png`` tinted in its own colour and
each ``bbox_obj`` drawn (the ball on the left is cut by the border: its box starts left of the
image, and its ``visib_fract`` counts the part beyond it).
"""

from __future__ import annotations

import json
import os
import sys
import tempfile

import numpy as np

import raycast_shade as rs
from benchmarks.outputs import images_dir

TINTS = np.array([(230, 60, 40), (40, 150, 230), (60, 200, 80)], np.float64)


def scene():
    def pose(a, t):
        P = np.eye(4)
        P[:3, :3] = [[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]
        P[:3, 3] = t
        return P

    ball, cube = rs.shapes.icosphere(3), rs.shapes.cube(size=0.8)
    models = [rs.Model(ball, rs.Material(kd=(0.8, 0.3, 0.2)), name="ball", pose=pose(0.5, (-1.9, 0.2, 0.0))),
              rs.Model(cube, rs.Material(kd=(0.3, 0.5, 0.8)), name="cube", pose=pose(-0.3, (0.6, -0.1, 0.5))),
              rs.Model(ball, rs.Material(kd=(0.4, 0.7, 0.3)), name="ball")]
    return rs.Scene(models, lights=[rs.PointLight((2, 3, 4), intensity=2.5)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=160, height=120))


def panels(folder):
    """(left, right) uint8 images of the set written in ``folder``."""
    import imageio.v3 as iio

    sc = scene()
    rs.render_views(sc, [sc.camera], folder, files=rs.ViewFiles(buffers=["model_id"]), exports=["bop"])
    root = os.path.join(folder, "bop", "train", "000000")
    rgb = iio.imread(os.path.join(root, "rgb", "000000.png"))[..., :3].astype(np.float64)
    over = rgb.copy()
    info = json.load(open(os.path.join(root, "scene_gt_info.json")))["0"]
    h, w = rgb.shape[:2]
    for g, entry in enumerate(info):
        m = iio.imread(os.path.join(root, "mask_visib", f"000000_{g:06d}.png")) > 0
        over[m] = 0.45 * over[m] + 0.55 * TINTS[g]
        x, y, bw, bh = entry["bbox_obj"]
        if x < 0 and bw < 0:
            continue
        for c in (max(x, 0), min(x + bw, w - 1)):  # clipped for drawing only
            over[max(y, 0):min(y + bh, h - 1) + 1, c] = TINTS[g]
        for r in (max(y, 0), min(y + bh, h - 1)):
            over[r, max(x, 0):min(x + bw, w - 1) + 1] = TINTS[g]
    return rgb.astype(np.uint8), over.astype(np.uint8)


def main(argv=None):
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    import imageio.v3 as iio

    argv = sys.argv[1:] if argv is None else list(argv)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        left, right = panels(tmp)
    gap = np.full((left.shape[0], 6, 3), 255, np.uint8)
    big = np.kron(np.concatenate([left, gap, right], axis=1), np.ones((2, 2, 1), np.uint8))  # 2x, nearest
    path = os.path.join(out, "bop_masks.png")
    iio.imwrite(path, big)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
