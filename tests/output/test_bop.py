"""The BOP export: a view set read back by a small BOP reader written from the format's document
(``bop_datasets_format`` of ``bop_toolkit``), its poses checked with ``cv2.projectPoints``,
and its ``scene_gt_info`` against the toolkit's ``calc_gt_info`` logic, reproduced here from its source
(the object rendered alone in a ``3W x 3H`` frame, distance images, the ``bop19`` visibility test).

The scene: a posed ball cut by the left border, a posed cube and an unposed ball (two instances of
one object), 64x48, two views.
"""

from __future__ import annotations

import json
import os

import imageio.v3 as iio
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.views import render_views
from raycast_shade.output.bufferfile import load_npz

W, H = 64, 48


def _rot_z(a, t):
    P = np.eye(4)
    P[:3, :3] = [[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]
    P[:3, 3] = t
    return P


@pytest.fixture(scope="module")
def bop_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("bop")
    ball, cube = rs.shapes.icosphere(2), rs.shapes.cube(size=0.8)
    models = [rs.Model(ball, name="ball", pose=_rot_z(0.5, (-1.9, 0.2, 0.0))),
              rs.Model(cube, name="cube", pose=_rot_z(-0.3, (0.6, -0.1, 0.5))), rs.Model(ball, name="ball")]
    scene = rs.Scene(models, lights=[rs.PointLight((2, 3, 4), intensity=20)],
                     camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H))
    cams = [scene.camera, scene.camera.replace(eye=(1.0, 0.4, 3.8))]
    render_views(scene, cams, out, files=rs.ViewFiles(buffers=["model_id", "zdepth"]), exports=["bop"])
    return scene, cams, out


def _read_ply(path):
    """Vertices and faces of an ASCII PLY with x y z nx ny nz and triangle lists."""
    lines = open(path).read().splitlines()
    end = lines.index("end_header")
    nv = int(next(x for x in lines if x.startswith("element vertex")).split()[-1])
    nf = int(next(x for x in lines if x.startswith("element face")).split()[-1])
    v = np.array([[float(a) for a in x.split()] for x in lines[end + 1:end + 1 + nv]])
    f = np.array([[int(a) for a in x.split()[1:]] for x in lines[end + 1 + nv:end + 1 + nv + nf]])
    return v, f


def _read_bop(root):
    """A BOP reader from the format's document: per image its K, depth in mm, and per gt its pose,
    object and masks."""
    scene_dir = os.path.join(root, "train", "000000")
    cams = json.load(open(os.path.join(scene_dir, "scene_camera.json")))
    gts = json.load(open(os.path.join(scene_dir, "scene_gt.json")))
    infos = json.load(open(os.path.join(scene_dir, "scene_gt_info.json")))
    images = {}
    for key, cam in cams.items():
        im = int(key)
        depth = iio.imread(os.path.join(scene_dir, "depth", f"{im:06d}.png")).astype(np.float64) * cam["depth_scale"]
        entries = []
        for gt_id, (gt, info) in enumerate(zip(gts[key], infos[key])):
            masks = [iio.imread(os.path.join(scene_dir, d, f"{im:06d}_{gt_id:06d}.png")) for d in ("mask", "mask_visib")]
            entries.append({"R": np.reshape(gt["cam_R_m2c"], (3, 3)), "t": np.reshape(gt["cam_t_m2c"], 3),
                            "obj_id": gt["obj_id"], "mask": masks[0], "mask_visib": masks[1], **info})
        images[im] = {"K": np.reshape(cam["cam_K"], (3, 3)), "R_w2c": np.reshape(cam["cam_R_w2c"], (3, 3)),
                      "t_w2c": np.reshape(cam["cam_t_w2c"], 3), "depth": depth,
                      "rgb": iio.imread(os.path.join(scene_dir, "rgb", f"{im:06d}.png")), "gt": entries}
    models = json.load(open(os.path.join(root, "models", "models_info.json")))
    return images, models


def test_the_set_reads_back_in_millimetres(bop_set):
    scene, cams, out = bop_set
    images, models = _read_bop(os.path.join(out, "bop"))
    assert sorted(models) == ["1", "2"]  # the two balls are one object
    for oid, info in models.items():
        v, f = _read_ply(os.path.join(out, "bop", "models", f"obj_{int(oid):06d}.ply"))
        mesh = scene.models[0 if oid == "1" else 1].mesh
        assert len(f) == len(mesh.faces)
        np.testing.assert_allclose(v[:, :3].min(axis=0), mesh.vertices.min(axis=0) * 1000, atol=1e-4)
        assert [info["min_x"], info["size_y"]] == pytest.approx([v[:, 0].min(), np.ptp(v[:, 1])], abs=1e-4)
        d = np.linalg.norm(v[:, None, :3] - v[None, :, :3], axis=-1).max()  # brute force, every pair
        assert info["diameter"] == pytest.approx(d, rel=1e-9)
        assert "symmetries_discrete" not in info and "symmetries_continuous" not in info
    for im, cam in enumerate(cams):
        got = images[im]
        K, R, t = cam.to_opencv()
        np.testing.assert_array_equal(got["K"], K)
        np.testing.assert_allclose(got["t_w2c"], t * 1000, rtol=1e-15)
        z = load_npz(os.path.join(out, f"view_{im:05d}.npz"))["zdepth"]
        hit = np.isfinite(z) & (z > 0)
        assert np.abs(got["depth"][hit] - z[hit] * 1000).max() <= 0.5  # the PNG rounds to 1 mm
        assert [g["obj_id"] for g in got["gt"]] == [1, 2, 1]
        for g, entry in enumerate(got["gt"]):
            m2w = scene.models[g].model_to_world
            np.testing.assert_allclose(entry["R"], R @ m2w[:3, :3], atol=1e-15)
            np.testing.assert_allclose(entry["t"], (R @ m2w[:3, 3] + t) * 1000, rtol=1e-12)
            assert set(np.unique(entry["mask"])) <= {0, 255} and set(np.unique(entry["mask_visib"])) <= {0, 255}
            assert not np.any(entry["mask_visib"] & ~entry["mask"])
            assert entry["px_count_visib"] == np.count_nonzero(entry["mask_visib"])
            assert entry["px_count_valid"] == np.count_nonzero(entry["mask"] & (got["depth"] > 0))


def test_poses_project_onto_the_masks_with_opencv(bop_set):
    import cv2

    _, cams, out = bop_set
    images, _ = _read_bop(os.path.join(out, "bop"))
    for im in images.values():
        for entry in im["gt"]:
            v, _ = _read_ply(os.path.join(out, "bop", "models", f"obj_{entry['obj_id']:06d}.ply"))
            uv = cv2.projectPoints(np.ascontiguousarray(v[:, :3]), cv2.Rodrigues(entry["R"])[0], entry["t"], im["K"], None)[0][:, 0]
            px = np.round(uv).astype(int)
            inside = (px[:, 0] >= 0) & (px[:, 0] < W) & (px[:, 1] >= 0) & (px[:, 1] < H)
            assert inside.sum() > 20
            near = cv2.dilate(entry["mask"], np.ones((3, 3), np.uint8))  # a vertex on the outline may round off
            assert np.all(near[px[inside, 1], px[inside, 0]] == 255)
            assert (~inside).any() == (entry["px_count_all"] > np.count_nonzero(entry["mask"]))


def _dist(depth, K):
    """bop_toolkit's misc.depth_im_to_dist_im_fast: the distance of each pixel's point."""
    ys, xs = np.mgrid[:depth.shape[0], :depth.shape[1]]
    px, py = (xs - K[0, 2]) / K[0, 0], (ys - K[1, 2]) / K[1, 1]
    return np.sqrt((px * depth) ** 2 + (py * depth) ** 2 + depth.astype(np.float64) ** 2)


def _bbox(xs, ys):
    """bop_toolkit's misc.calc_2d_bbox: [x, y, xmax - xmin, ymax - ymin]."""
    return [int(xs.min()), int(ys.min()), int(xs.max() - xs.min()), int(ys.max() - ys.min())]


def test_gt_info_is_the_toolkits_calc_gt_info(bop_set):
    """scripts/calc_gt_info.py step by step: the object alone in a 3W x 3H frame (principal point
    shifted by W, H), distance images, visib_gt by 'bop19' with delta 15 mm, the counts and boxes."""
    scene, cams, out = bop_set
    images, _ = _read_bop(os.path.join(out, "bop"))
    truncated = estimated = 0
    for im, cam in enumerate(cams):
        got = images[im]
        K = got["K"]
        big = cam.replace(width=3 * W, height=3 * H, fx=K[0, 0], fy=K[1, 1], cx=K[0, 2] + W, cy=K[1, 2] + H)
        dist_im = _dist(got["depth"], K)
        for g, entry in enumerate(got["gt"]):
            z = rs.render(rs.Scene([scene.models[g]], lights=scene.lights), camera=big, buffers=("zdepth",)).buffers["zdepth"]
            depth_gt_large = np.where(np.isfinite(z), z * 1000.0, 0.0)
            depth_gt = depth_gt_large[H:2 * H, W:2 * W]
            dist_gt = _dist(depth_gt, K)
            d_diff = dist_gt.astype(np.float32) - dist_im.astype(np.float32)
            visib_gt = ((d_diff <= 15) | (dist_im == 0)) & (dist_gt > 0)
            large = depth_gt_large > 0
            px_all, px_visib = int(large.sum()), int(visib_gt.sum())
            ys, xs = np.nonzero(large)
            vy, vx = np.nonzero(visib_gt)
            want = {"px_count_all": px_all, "px_count_valid": int(np.sum(dist_im[dist_gt > 0] > 0)),
                    "px_count_visib": px_visib, "visib_fract": px_visib / px_all if px_all else 0.0,
                    "bbox_obj": _bbox(xs - W, ys - H) if px_visib else [-1] * 4,
                    "bbox_visib": _bbox(vx, vy) if px_visib else [-1] * 4}
            exact = ("px_count_all", "px_count_valid", "bbox_obj")
            assert {k: entry[k] for k in exact} == {k: want[k] for k in exact}
            np.testing.assert_array_equal(entry["mask"] > 0, dist_gt > 0)  # calc_gt_masks' mask
            # Ours is the model_id mask; the toolkit estimates it from depth, taking in pixels of the object
            # up to delta behind what is in front (here where the cube cuts into the ball): ours lies
            # inside its estimate, a few edge pixels apart.
            ours = entry["mask_visib"] > 0
            assert not np.any(ours & ~visib_gt) and np.count_nonzero(visib_gt & ~ours) <= 0.05 * ours.sum() + 2
            estimated += np.count_nonzero(visib_gt & ~ours)
            assert entry["px_count_visib"] == ours.sum() and entry["visib_fract"] == ours.sum() / px_all
            assert entry["bbox_visib"] == (_bbox(*np.nonzero(ours)[::-1]) if ours.any() else [-1] * 4)
            truncated += entry["visib_fract"] < entry["px_count_visib"] / max(1, np.count_nonzero(entry["mask"]))
    assert 0 < estimated <= 0.01 * len(cams) * 3 * W * H  # the estimate adds pixels where surfaces meet
    assert truncated >= 1  # the ball cut by the left border: BOP's fraction counts the part beyond it
    assert images[0]["gt"][0]["bbox_obj"][0] < 0  # and its box is not clipped


def test_poses_are_rigid_and_the_identity_is_none():
    mesh = rs.shapes.icosphere(1)
    assert rs.Model(mesh, pose=np.eye(4)).pose is None and rs.Model(mesh).pose is None
    P = _rot_z(0.7, (1.0, -2.0, 0.5))
    moved = rs.Scene([rs.Model(mesh, pose=P)]).geometry
    direct = rs.Scene([rs.Mesh(mesh.vertices @ P[:3, :3].T + P[:3, 3], mesh.faces)]).geometry
    np.testing.assert_allclose(moved.vertices + moved.origin, direct.vertices + direct.origin, atol=1e-14)
    np.testing.assert_allclose(moved.normals, direct.normals, atol=1e-12)
    for bad, match in ((np.diag([2.0, 1, 1, 1]), "must be a rotation"), (np.diag([-1.0, 1, 1, 1]), "determinant"),
                       (np.ones((4, 4)), "last row"), (np.eye(3), "model.pose")):
        with pytest.raises(ValueError, match=match):
            rs.Model(mesh, pose=bad)


def test_bop_refuses_what_it_cannot_say_before_rendering(tmp_path):
    scene = rs.Scene([rs.shapes.icosphere(1)], camera=rs.Camera(eye=(0, 0, 4.0), width=W, height=H))
    fish = scene.camera.replace(distortion=(0.1, 0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="exports: 'bop' cannot be written: cameras\\[0\\]: lens distortion"):
        render_views(scene, [fish], tmp_path / "a", exports=["bop"])
    with pytest.raises(ValueError, match="exports: 'bop' takes each view's image as its rgb/ PNG"):
        render_views(scene, [scene.camera], tmp_path / "b", files=rs.ViewFiles(image=".npy"), exports=["bop"])
    assert not os.path.exists(tmp_path / "a") and not os.path.exists(tmp_path / "b")
