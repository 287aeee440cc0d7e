"""Figure for docs/vision.md's labels on disk and COLMAP points.

``python -m docs.figures.labels [--quick]`` writes ``label_files.png`` into ``docs/images/``: a view
set of three models (two of one name) written with ``formats=("semantic_png", "instance_png")`` and
``exports=("amodal", "colmap")`` (160x120, three views), for view 0: its image; its
``view_00000_instance.png`` and ``view_00000_semantic.png`` colourised (one colour per label, black
the background 0); the amodal mask of the ball the cube hides in part (``amodal/``) over its
visible pixels; and the COLMAP ``points3D`` that view 0 tracks, drawn at their ``points2D``.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile

import numpy as np

import raycast_shade as rs
from benchmarks.outputs import images_dir

PALETTE = np.array([(0, 0, 0), (230, 60, 40), (40, 150, 230), (60, 200, 80), (240, 200, 40)], np.uint8)


def scene():
    def at(t):
        P = np.eye(4)
        P[:3, 3] = t
        return P

    ball = rs.shapes.icosphere(3)
    models = [rs.Model(ball, rs.Material(kd=(0.8, 0.3, 0.2)), name="ball"),
              rs.Model(rs.shapes.cube(size=0.8), rs.Material(kd=(0.3, 0.5, 0.8)), name="cube", pose=at((0.5, -0.1, 0.9))),
              rs.Model(ball, rs.Material(kd=(0.4, 0.7, 0.3)), name="ball", pose=at((-1.6, 0.3, -0.4)))]
    return rs.Scene(models, lights=[rs.PointLight((2, 3, 4), intensity=2.5)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=160, height=120))


def panels(folder):
    """Five (H, W, 3) uint8 panels of the set written in ``folder``."""
    import imageio.v3 as iio

    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.viewexports import ExportOptions

    sc = scene()
    cams = orbit_cameras(sc.camera, 3)
    rs.render_views(sc, cams, folder, files=rs.ViewFiles(buffers=["model_id"], formats=("semantic_png", "instance_png")),
                    exports=["amodal", "colmap"], export_options=ExportOptions(colmap_points=400))
    rgb = iio.imread(os.path.join(folder, "view_00000.png"))[..., :3]
    inst = PALETTE[iio.imread(os.path.join(folder, "view_00000_instance.png"))]
    sem = PALETTE[iio.imread(os.path.join(folder, "view_00000_semantic.png"))]
    amodal = rgb.astype(np.float64) * 0.35
    visible = iio.imread(os.path.join(folder, "view_00000_instance.png")) == 1
    silhouette = iio.imread(os.path.join(folder, "amodal", "view_00000_000000.png")) > 0
    amodal[silhouette & ~visible] = (255, 230, 60)  # hidden by the cube: amodal, not visible
    amodal[visible] = 0.4 * amodal[visible] + 0.6 * np.array((230, 60, 40))
    points = rgb.astype(np.float64) * 0.35
    lines = open(os.path.join(folder, "colmap", "images.txt")).read().splitlines()
    data = [x for x in lines if not x.startswith("#")]
    xy = np.array([float(v) for v in data[1].split()]).reshape(-1, 3)[:, :2] - 0.5  # image 1's POINTS2D
    for x, y in np.rint(xy).astype(int):
        points[y, x] = (255, 255, 255)
    return [rgb, inst, sem, amodal.astype(np.uint8), points.astype(np.uint8)]


def main(argv=None):
    """Draw the figure; ``--quick`` writes it into the git-ignored ``out/quick/images/``."""
    import imageio.v3 as iio

    argv = sys.argv[1:] if argv is None else list(argv)
    out = images_dir("--quick" in argv)
    os.makedirs(out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        parts = panels(tmp)
        labels = json.load(open(os.path.join(tmp, "labels.json")))
    gap = np.full((parts[0].shape[0], 6, 3), 255, np.uint8)
    row = np.concatenate([p for part in parts for p in (part, gap)][:-1], axis=1)
    big = np.kron(row, np.ones((2, 2, 1), np.uint8))  # 2x, nearest
    path = os.path.join(out, "label_files.png")
    iio.imwrite(path, big)
    print(f"wrote {path}; labels: " + ", ".join(f"{e['label']} {e['name']}" for e in labels["semantic"]["labels"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
