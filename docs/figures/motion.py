"""Figure for docs/vision.md's objects that move: a short clip and its optical flow.

``python -m docs.figures.motion [--quick]`` writes ``motion_flow.png`` into ``docs/images/``: a view
set of four views (160x120) in which a cube turns and slides on a floor past a still ball while the
camera moves right, written with ``poses={"cube": ...}`` and ``exports=("flow",)``. Top row: the
views' images; bottom row: the forward flow of views 0, 1 and 2 read back from ``flow/forward_*.flo``
and drawn on the Middlebury colour wheel (one scale for all three; grey where the KITTI PNG's valid
mask is 0: background, occluded or leaving the image), and the wheel itself.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import warnings

import numpy as np

import raycast_shade as rs
from benchmarks.outputs import images_dir

N_VIEWS = 4
GREY = (150, 150, 150)


def scene():
    floor = np.array([[1, 0, 0, 0], [0, 0, -1, -0.4], [0, 1, 0, 0], [0, 0, 0, 1.0]])
    ball = np.array([[1, 0, 0, 1.1], [0, 1, 0, 0.1], [0, 0, 1, -0.6], [0, 0, 0, 1.0]])
    models = [rs.Model(rs.shapes.cube(0.8), rs.Material(kd=(0.85, 0.35, 0.2)), name="cube"),
              rs.Model(rs.shapes.icosphere(3, radius=0.5), rs.Material(kd=(0.25, 0.5, 0.85), ks=0.4), name="ball",
                       pose=ball),
              rs.Model(rs.shapes.plane(8.0), rs.Material(kd=0.7), name="floor", pose=floor)]
    return rs.Scene(models, lights=[rs.PointLight((2.0, 4.0, 4.0), intensity=1.2)], ambient=0.15,
                    camera=rs.Camera(eye=(0.0, 1.6, 4.5), target=(0.0, 0.0, 0.0), width=160, height=120))


def track():
    """The cube's poses: a quarter turn about y while it slides from x = -1.2 to x = 0.3."""
    start, end = np.eye(4), rs.orbit_poses(4, (0.0, 1.0, 0.0), 360.0)[1]  # 90 degrees
    start[:3, 3], end[:3, 3] = (-1.2, 0.0, 0.3), (0.3, 0.0, 0.3)
    return rs.keyframes([0, N_VIEWS - 1], [start, end], N_VIEWS)


def panels(folder):
    """(images, flow pictures, wheel) of the set written in ``folder``."""
    import imageio.v3 as iio

    sc = scene()
    cams = [sc.camera.replace(eye=(0.25 * i, 1.6, 4.5)) for i in range(N_VIEWS)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the floor's plane is open: nothing to warn about here
        rs.render_views(sc, cams, folder, poses={"cube": track()}, exports=("flow",),
                        files=rs.ViewFiles(buffers=("model_id",)))
    index = json.load(open(os.path.join(folder, "index.json")))
    images = [iio.imread(os.path.join(folder, v["files"]["image"]))[..., :3] for v in index["views"]]
    pairs = [p for p in index["flow"]["pairs"] if p["to"] == p["from"] + 1]
    flows = [(rs.read_flo(os.path.join(folder, p["flo"])), rs.read_flow_png(os.path.join(folder, p["png"]))[1])
             for p in pairs]
    scale = max(float(np.hypot(*f[ok].T).max()) for f, ok in flows)
    pictures = [rs.flow_colors(f, ok, max_flow=scale, background=GREY) for f, ok in flows]
    h = images[0].shape[0]
    y, x = np.mgrid[:h, :h] - (h - 1) / 2.0
    disc = np.hypot(x, y) <= h / 2.0 - 2
    wheel = rs.flow_colors(np.dstack([x, y]) / (h / 2.0 - 2), disc, max_flow=1.0, background=(255, 255, 255))
    return images, pictures, wheel


def main(argv=None):
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    import imageio.v3 as iio

    argv = sys.argv[1:] if argv is None else list(argv)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        images, pictures, wheel = panels(tmp)
    h, w = images[0].shape[:2]
    gap = np.full((h, 6, 3), 255, np.uint8)
    pad = np.full((h, w - wheel.shape[1], 3), 255, np.uint8)
    top = np.concatenate([a for im in images for a in (im, gap)][:-1], axis=1)
    bottom = np.concatenate([a for im in pictures + [np.concatenate([wheel, pad], 1)] for a in (im, gap)][:-1], axis=1)
    sheet = np.concatenate([top, np.full((6, top.shape[1], 3), 255, np.uint8), bottom])
    path = os.path.join(out, "motion_flow.png")
    iio.imwrite(path, np.kron(sheet, np.ones((2, 2, 1), np.uint8)))  # 2x, nearest
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
