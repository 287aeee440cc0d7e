"""From a glTF scene to a vision data set: every buffer, labels, exports, flow, a distorted lens.

    python examples/vision_dataset.py OUT_DIR [--figure docs/images/vision_dataset.png]

1. Builds a small glTF (three named nodes with their own PBR materials) from
   ``raycast_shade.shapes`` with trimesh, and loads it back: the models carry
   the node names, which become the semantic classes.
2. Renders 8 views around it into ``OUT_DIR`` with every buffer (npz, EXR,
   16-bit depth PNG), the COCO instances file, nerfstudio's transforms.json
   and COLMAP's text model; ``index.json`` maps ids to names and materials
   and gives each object's box, pixel count, visible fraction and pose per
   view.
3. Computes the optical flow from view 0 to view 1 with its occlusion mask,
   and renders view 0 again through a barrel-distorted lens (OpenCV's model).
4. With ``--figure``, draws the first view's image with its COCO boxes, its
   depth, semantic and instance masks, the flow and the distorted view.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np


def build_gltf(path):
    """Three named nodes (ball, ring, floor), each with its own PBR material, as one .glb."""
    import trimesh

    import raycast_shade as rs

    parts = [("ball", rs.shapes.icosphere(3, radius=0.8, center=(-1.1, 0.8, 0.0)), (200, 60, 40)),
             ("ring", rs.shapes.torus(0.7, 0.25, center=(1.1, 0.7, 0.4)), (60, 120, 220)),
             ("floor", rs.shapes.plane(size=8.0, normal="+y"), (170, 170, 160))]
    scene = trimesh.Scene()
    for name, mesh, rgb in parts:
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        tm.visual = trimesh.visual.TextureVisuals(material=trimesh.visual.material.PBRMaterial(
            name=f"{name}_paint", baseColorFactor=(*rgb, 255), metallicFactor=0.0, roughnessFactor=0.5))
        scene.add_geometry(tm, node_name=name, geom_name=f"{name}_mesh")
    scene.export(path)
    return path


def make_dataset(out_dir):
    import raycast_shade as rs
    from raycast_shade.apps.animate import orbit_cameras
    from raycast_shade.apps.views import ViewFiles, render_views
    from raycast_shade.output.buffers import BUFFER_NAMES

    os.makedirs(out_dir, exist_ok=True)
    models = rs.load_models(build_gltf(os.path.join(out_dir, "scene.glb")))
    scene = rs.Scene(models, lights=[rs.PointLight((3.0, 5.0, 4.0), intensity=1.0)],
                     camera=rs.Camera(eye=(0.0, 2.6, 5.5), target=(0.0, 0.5, 0.0), fov=40, width=320, height=200))
    cameras = orbit_cameras(scene.camera, 8)
    files = ViewFiles(buffers=BUFFER_NAMES, formats=["npz", "exr", "depth_png"])  # what each view writes
    index = render_views(scene, cameras, os.path.join(out_dir, "views"), files=files,
                         exports=["coco", "nerfstudio", "colmap"], unoccluded=True)
    return scene, cameras, index


def flow_and_lens(scene, cameras):
    """Flow from view 0 to view 1, and view 0 through a barrel lens (OpenCV's k1, k2, p1, p2, k3)."""
    import raycast_shade as rs
    from raycast_shade.output.flow import optical_flow

    flow = optical_flow(scene, cameras[0], camera_b=cameras[1])
    K, R, t = cameras[0].to_opencv()
    barrel = rs.Camera.from_opencv(K, R, t, cameras[0].width, cameras[0].height, dist=[-0.35, 0.12, 0.0, 0.0, -0.02])
    distorted = rs.render(scene, camera=barrel, buffers=("mask",))
    return flow, distorted


def _flow_rgb(flow, mask):
    """Flow as colour: hue the direction, value the length (black: no flow)."""
    import matplotlib.colors as mcolors

    ang = (np.arctan2(flow[..., 1], flow[..., 0]) + np.pi) / (2 * np.pi)
    mag = np.hypot(flow[..., 0], flow[..., 1])
    val = np.clip(mag / max(np.percentile(mag[mask], 99), 1e-9), 0, 1) if mask.any() else mag
    return np.where(mask[..., None], mcolors.hsv_to_rgb(np.stack([ang, np.ones_like(ang), val], -1)), 1.0)


def figure(out_dir, flow, distorted, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = os.path.join(out_dir, "views")
    index = json.load(open(os.path.join(folder, "index.json")))
    coco = json.load(open(os.path.join(folder, "coco_instances.json")))
    view = index["views"][0]
    data = np.load(os.path.join(folder, view["files"]["npz"]))
    m = data["mask"]
    import imageio.v3 as iio

    image = iio.imread(os.path.join(folder, view["files"]["image"]))  # the view's tone-mapped PNG
    fig, axes = plt.subplots(2, 3, figsize=(12, 5.4))
    ax = axes[0, 0]
    ax.imshow(image)
    names = {c["id"]: c["name"].split(":")[-1] for c in coco["categories"]}
    seen = {o["id"]: o for o in view["objects"]}
    for a in coco["annotations"]:
        if a["image_id"] == 1:
            x, y, w, h = a["bbox"]
            ax.add_patch(plt.Rectangle((x - 0.5, y - 0.5), w, h, fill=False, color="yellow", lw=1))
            frac = seen[a["model_id"]]["visible_fraction"]
            ax.text(x, y - 2, f"{names[a['category_id']]} {a['area']} px, {frac:.0%} visible", color="yellow",
                    fontsize=7)
    ax.set_title("view 0 with its COCO boxes", fontsize=9)
    axes[0, 1].imshow(np.where(m, data["zdepth"], np.nan), cmap="viridis_r")
    axes[0, 1].set_title("zdepth", fontsize=9)
    axes[0, 2].imshow(np.where(m, data["semantic_id"], np.nan), cmap="tab10", vmin=0, vmax=9)
    axes[0, 2].set_title("semantic_id: " + ", ".join(c.split(":")[-1] for c in index["classes"]), fontsize=9)
    axes[1, 0].imshow(np.where(m, data["model_id"], np.nan), cmap="Set2", vmin=0, vmax=7)
    axes[1, 0].set_title("model_id (instances)", fontsize=9)
    rgb = _flow_rgb(flow["flow"], flow["mask"] & ~flow["occluded"])
    rgb[flow["occluded"]] = 0.55
    axes[1, 1].imshow(rgb)
    axes[1, 1].set_title("flow view 0 -> 1 (hue: direction; grey: occluded)", fontsize=9)
    axes[1, 2].imshow(distorted.to_uint8())
    axes[1, 2].set_title("view 0 through a barrel lens (exact rays)", fontsize=9)
    for a in axes.ravel():
        a.set_axis_off()
    fig.tight_layout()
    fig.savefig(path, dpi=72)
    plt.close(fig)
    return path


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out_dir")
    p.add_argument("--figure", metavar="PNG")
    ns = p.parse_args(argv)
    scene, cameras, index = make_dataset(ns.out_dir)
    flow, distorted = flow_and_lens(scene, cameras)
    data = json.load(open(index))
    print(f"{index}: {len(data['views'])} views, classes {data['classes']}, "
          f"files {sorted(os.listdir(os.path.dirname(index)))[:6]} ...")
    print(f"flow 0 -> 1: {int(flow['mask'].sum())} px, {int(flow['occluded'].sum())} occluded, "
          f"{int(flow['outside'].sum())} leave the frame")
    if ns.figure:
        print("figure:", figure(ns.out_dir, flow, distorted, ns.figure))
    return 0


if __name__ == "__main__":
    sys.exit(main())
