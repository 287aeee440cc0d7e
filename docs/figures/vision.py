"""Figures of docs/vision.md: every buffer of one view, and a view set reprojected to a point cloud.

Run ``python -m docs.figures.vision [--quick]``. Renders
``examples/shapes.toml`` through a camera with ``fx != fy`` and an
off-centre principal point, writes ``docs/images/vision_buffers.png`` (one
panel per buffer), then renders an 8-view orbit with
:func:`raycast_shade.apps.views.render_views`, loads it back with NumPy
only, unprojects each view's z-depth through its ``K, R, t`` and writes
``docs/images/vision_pointcloud.png``, printing the distance of each point
to the triangle its pixel saw (``model_id``, ``triangle_id``).
"""

from __future__ import annotations

import json
import os
import sys
import tempfile

import numpy as np

from benchmarks.outputs import ROOT, images_dir

IMAGES = images_dir(False)


def _camera(scene, width=480, height=300):
    import raycast_shade as rs

    base = scene.camera.replace(width=width, height=height)
    K, R, t = base.to_opencv()
    K = np.array([[1.15 * K[0, 0], 0, 0.56 * width], [0, K[1, 1], 0.45 * height], [0, 0, 1]])
    return rs.Camera.from_opencv(K, R, t, width, height)


def _show(ax, img, title, cmap=None, vmin=None, vmax=None):
    ax.imshow(img, cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest")
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()


def buffers_figure(scene):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import raycast_shade as rs
    from raycast_shade.output.buffers import BUFFER_NAMES

    cam = _camera(scene)
    frame = rs.render(scene, camera=cam, buffers=BUFFER_NAMES)
    b, m = frame.buffers, frame.buffers["mask"]
    fig, axes = plt.subplots(3, 4, figsize=(13, 6.6))
    axes = axes.ravel()
    _show(axes[0], frame.to_uint8(), "image")
    lo, hi = b["zdepth"][m].min(), b["zdepth"][m].max()
    for ax, name in zip(axes[1:3], ("depth", "zdepth")):
        _show(ax, np.where(m, b[name], np.nan), f"{name} ({lo:.1f}..{hi:.1f})", "viridis_r", lo, b["depth"][m].max())
    p = b["position"]
    span = p[m].max(axis=0) - p[m].min(axis=0)
    _show(axes[3], np.where(m[..., None], (p - p[m].min(axis=0)) / span, 1.0), "position (xyz -> rgb)")
    for ax, name in zip(axes[4:8], ("normal", "normal_camera", "face_normal", "face_normal_camera")):
        _show(ax, np.where(m[..., None], 0.5 * (b[name] + 1.0), 1.0), f"{name} (0.5 n + 0.5)")
    _show(axes[8], np.where(m[..., None], b["barycentric"], 1.0), "barycentric")
    _show(axes[9], np.where(m, b["model_id"], np.nan), "model_id", "tab10", 0, 9)
    rng = np.random.default_rng(0)
    lut = rng.random((int(b["triangle_id"].max()) + 2, 3))
    _show(axes[10], np.where(m[..., None], lut[b["triangle_id"] + 1], 1.0), "triangle_id (random colours)")
    _show(axes[11], m, "mask", "gray")
    fig.suptitle(f"examples/shapes.toml, fx={cam.fx:.0f} fy={cam.fy:.0f} cx={cam.cx:.0f} cy={cam.cy:.0f} "
                 f"({cam.width}x{cam.height})", fontsize=10)
    fig.tight_layout()
    out = os.path.join(IMAGES, "vision_buffers.png")
    fig.savefig(out, dpi=80)
    plt.close(fig)
    return out


def load_points(folder):
    """The docs' example: a view set back to world points, with NumPy only."""
    index = json.load(open(os.path.join(folder, "index.json")))
    clouds, ids = [], []
    for view in index["views"]:
        data = np.load(os.path.join(folder, view["files"]["npz"]))
        K, R, t = np.array(view["K"]), np.array(view["R"]), np.array(view["t"])
        z, mask = data["zdepth"], data["mask"]
        v, u = np.nonzero(mask)  # OpenCV pixel centres are the integer coordinates
        rays = np.linalg.inv(K) @ np.stack([u, v, np.ones_like(u)]).astype(np.float64)
        x_cam = rays * z[v, u]
        clouds.append((R.T @ (x_cam - t[:, None])).T)  # x_world = R^T (x_cam - t)
        ids.append(np.stack([data["model_id"][v, u], data["triangle_id"][v, u]], axis=1))
    return np.concatenate(clouds), np.concatenate(ids)


def triangle_distance(scene, pts, ids):
    """Distance of each point to the plane of the triangle it was seen on, and the smallest
    barycentric weight of its projection there (>= 0: inside the triangle)."""
    dist = np.empty(len(pts))
    inside = np.empty(len(pts))
    for g, model in enumerate(scene.models):
        sel = ids[:, 0] == g
        tri = model.mesh.vertices[model.mesh.faces[ids[sel, 1]]]
        e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        n = np.cross(e1, e2)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        q = pts[sel] - tri[:, 0]
        dist[sel] = np.abs(np.einsum("ij,ij->i", q, n))
        # barycentrics of the projection, from the 2x2 normal equations
        a, b, c = (np.einsum("ij,ij->i", x, y) for x, y in ((e1, e1), (e1, e2), (e2, e2)))
        d, e = np.einsum("ij,ij->i", q, e1), np.einsum("ij,ij->i", q, e2)
        den = a * c - b * b
        w1, w2 = (c * d - b * e) / den, (a * e - b * d) / den
        inside[sel] = np.minimum(np.minimum(w1, w2), 1.0 - w1 - w2)
    return dist, inside


def pointcloud_figure(scene):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.views import ViewFiles, render_views

    cams = orbit_cameras(_camera(scene, 320, 200), 8)
    with tempfile.TemporaryDirectory() as tmp:
        render_views(scene, cams, tmp, files=ViewFiles(buffers=("zdepth", "mask", "id"), image=None))
        pts, ids = load_points(tmp)
    dist, inside = triangle_distance(scene, pts, ids)
    scale = scene.geometry.scale
    fig = plt.figure(figsize=(9, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    sel = np.random.default_rng(1).choice(len(pts), min(len(pts), 30000), replace=False)
    ax.scatter(pts[sel, 0], pts[sel, 2], pts[sel, 1], s=0.2, c=pts[sel, 1], cmap="viridis")
    ax.set_title(f"{len(pts):,} points from 8 views' z-depth", fontsize=9)
    ax.set_xlabel("x")
    ax.set_ylabel("z")
    ax.set_zlabel("y")
    ax2 = fig.add_subplot(1, 2, 2)
    ax2.hist(np.log10(np.maximum(dist / scale, 1e-12)), bins=60, log=True)
    ax2.set_xlabel("log10(distance to its triangle / diagonal), -12: exact")
    ax2.set_title(f"max {dist.max() / scale:.1e}, median {np.median(dist) / scale:.1e} of the diagonal", fontsize=9)
    fig.tight_layout()
    out = os.path.join(IMAGES, "vision_pointcloud.png")
    fig.savefig(out, dpi=80)
    plt.close(fig)
    return out, dist, scale, inside


def main(argv=None):
    """Draw the figures; ``--quick`` writes them into the git-ignored ``out/quick/images/``."""
    global IMAGES
    argv = sys.argv[1:] if argv is None else list(argv)
    quick = "--quick" in argv
    IMAGES = images_dir(quick)
    from raycast_shade.scene.scenefile import load_scene

    os.makedirs(IMAGES, exist_ok=True)
    scene, _ = load_scene(os.path.join(ROOT, "examples", "shapes.toml"))
    print("wrote", buffers_figure(scene))
    out, dist, scale, inside = pointcloud_figure(scene)
    print(f"wrote {out}: {len(dist):,} points; distance to their triangles: max {dist.max():.2e}, "
          f"median {np.median(dist):.2e}, 99.9% {np.quantile(dist, 0.999):.2e} (scene diagonal {scale:.2f}); "
          f"smallest barycentric {inside.min():.1e}")
    return 0


if __name__ == "__main__":
    main()
