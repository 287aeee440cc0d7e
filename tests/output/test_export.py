"""Camera exports: COLMAP text read back by pycolmap (COLMAP's own code) and nerfstudio's
transforms.json through nerfstudio's documented ray formula (its ``Cameras.generate_rays``:
pixel coordinates ``x + 0.5``, direction ``((x - cx) / fx, -(y - cy) / fy, -1)`` turned by the
camera-to-world matrix). Points project to within 1e-6 px of our OpenCV projection, and each
pixel's ray goes through the pixel centre of the exported camera; the naive export (OpenCV's
principal point as is) is off by half a pixel, which the same checks see.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pycolmap
import pytest

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.views import render_views
from raycast_shade.output.export import (camera_to_world_gl, nerfstudio_transforms, rotation_to_quaternion,
                                         write_colmap, write_transforms)
from raycast_shade.visibility.rays import generate_rays

W, H = 40, 30
TOL_PX = 1e-6


def _cameras():
    """Off-centre principal points, fx != fy, random poses; and a look-at camera."""
    rng = np.random.default_rng(7)
    cams = [rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H)]
    for k in range(4):
        eye = rng.normal(size=3)
        eye *= 4.0 / np.linalg.norm(eye)
        z = -eye / np.linalg.norm(eye)
        x = np.cross(z, rng.normal(size=3))
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(z, x), z])
        K = np.array([[50.0 + 10 * k, 0, 17.3 + k], [0, 45.0 + 7 * k, 16.1 - k], [0, 0, 1]])
        cams.append(rs.Camera.from_opencv(K, R, -R @ eye, W, H))
    return cams


def _opencv_project(cam, points):
    K, R, t = cam.to_opencv()
    q = points @ R.T + t
    return (q[:, :2] / q[:, 2:]) * [K[0, 0], K[1, 1]] + [K[0, 2], K[1, 2]]


def _points(rng, n=200):
    return rng.uniform(-1.0, 1.0, (n, 3))


def _pixel_rays(cam):
    """Points on our rays through every pixel centre, and the pixels' OpenCV coordinates."""
    o, d = generate_rays(cam, dtype=np.float64)
    jj, ii = np.mgrid[0:cam.height, 0:cam.width]
    return o + 3.0 * d, np.stack([ii.ravel(), jj.ravel()], axis=-1).astype(np.float64)


def test_colmap_text_read_by_pycolmap_projects_like_opencv(tmp_path):
    cams = _cameras()
    write_colmap(tmp_path, cams, [f"view_{i:05d}.png" for i in range(len(cams))])
    rec = pycolmap.Reconstruction(str(tmp_path))
    assert rec.num_images() == len(cams) and rec.num_points3D() == 0
    rng = np.random.default_rng(1)
    worst = {"points": 0.0, "rays": 0.0}
    for i, cam in enumerate(cams):
        image = rec.images[i + 1]
        assert image.name == f"view_{i:05d}.png"
        assert image.camera.model_name == "PINHOLE" and (image.camera.width, image.camera.height) == (W, H)
        for kind, (pts, expect) in {"points": (_points(rng), None), "rays": _pixel_rays(cam)}.items():
            ours = _opencv_project(cam, pts) if expect is None else expect
            theirs = np.array([image.project_point(p) for p in pts], dtype=np.float64)
            err = np.abs(theirs - 0.5 - ours).max()  # COLMAP's pixel centres are at +0.5
            worst[kind] = max(worst[kind], err)
    assert worst["points"] < TOL_PX and worst["rays"] < TOL_PX, worst


def test_a_naive_colmap_export_is_seen_half_a_pixel_off(tmp_path):
    cam = _cameras()[1]
    K, R, t = cam.to_opencv()
    q = rotation_to_quaternion(R)
    (tmp_path / "cameras.txt").write_text(f"1 PINHOLE {W} {H} " + " ".join(repr(float(v)) for v in (K[0, 0], K[1, 1], K[0, 2], K[1, 2])) + "\n")
    (tmp_path / "images.txt").write_text("1 " + " ".join(repr(float(v)) for v in (*q, *t)) + " 1 a.png\n\n")
    (tmp_path / "points3D.txt").write_text("")
    image = pycolmap.Reconstruction(str(tmp_path)).images[1]
    pts = _points(np.random.default_rng(2))
    theirs = np.array([image.project_point(p) for p in pts]) - 0.5
    assert np.allclose(np.abs(theirs - _opencv_project(cam, pts)), 0.5, atol=1e-6)


def test_quaternions_are_unit_hamilton_with_w_positive():
    rng = np.random.default_rng(3)
    for _ in range(200):
        A = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        R = A * np.sign(np.linalg.det(A))
        w, x, y, z = rotation_to_quaternion(R)
        back = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
        assert w >= 0 and np.allclose(back, R, atol=1e-12)


def _nerfstudio_ray(frame, meta, x, y):
    """nerfstudio's ray direction (world) through pixel (x, y), from its documented formula."""
    u, v = x + 0.5, y + 0.5  # Cameras.get_image_coords(pixel_offset=0.5)
    d = np.stack([(u - meta["cx"]) / meta["fl_x"], -(v - meta["cy"]) / meta["fl_y"], -np.ones_like(u)], axis=-1)
    c2w = np.array(frame["transform_matrix"])
    d = d @ c2w[:3, :3].T
    return c2w[:3, 3], d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_nerfstudio_transforms_project_and_cast_like_ours(tmp_path):
    cams = _cameras()
    path = write_transforms(tmp_path / "transforms.json", cams, [f"images/{i}.png" for i in range(len(cams))])
    data = json.load(open(path))
    assert data["camera_model"] == "OPENCV" and "fl_x" not in data  # intrinsics differ: per frame
    rng = np.random.default_rng(4)
    worst_px, worst_dir = 0.0, 0.0
    for cam, frame in zip(cams, data["frames"]):
        meta = frame
        assert (meta["w"], meta["h"]) == (W, H) and meta["k1"] == meta["p2"] == 0.0
        c2w = np.array(frame["transform_matrix"])
        pts = _points(rng)
        q = (pts - c2w[:3, 3]) @ c2w[:3, :3]  # world to OpenGL camera axes
        u = meta["fl_x"] * q[:, 0] / -q[:, 2] + meta["cx"] - 0.5
        v = -meta["fl_y"] * q[:, 1] / -q[:, 2] + meta["cy"] - 0.5
        worst_px = max(worst_px, np.abs(np.stack([u, v], -1) - _opencv_project(cam, pts)).max())
        jj, ii = np.mgrid[0:H, 0:W]
        origin, d = _nerfstudio_ray(frame, meta, ii.ravel().astype(float), jj.ravel().astype(float))
        o, ours = generate_rays(cam, dtype=np.float64)
        assert np.allclose(origin, cam.eye, rtol=0, atol=1e-12)
        worst_dir = max(worst_dir, np.abs(d - ours).max())
    assert worst_px < TOL_PX, worst_px
    # A direction error e at focal length ~50 px moves the pixel by ~50 e.
    assert worst_dir * 100 < TOL_PX, worst_dir


def test_shared_intrinsics_go_to_the_top_and_the_matrix_is_opengl():
    cams = orbit_cameras(rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H), 3)
    data = nerfstudio_transforms(cams, ["a.png", "b.png", "c.png"])
    assert data["fl_x"] == cams[0].K[0, 0] and data["cx"] == cams[0].K[0, 2] + 0.5 and data["w"] == W
    for cam, frame in zip(cams, data["frames"]):
        assert "fl_x" not in frame
        right, up, fwd = cam.basis
        c2w = np.array(frame["transform_matrix"])
        assert np.allclose(c2w[:3, :3], np.stack([right, up, -fwd], axis=1), atol=1e-15)
        assert np.array_equal(c2w, camera_to_world_gl(cam)) and np.array_equal(c2w[3], [0, 0, 0, 1])


def test_exports_refuse_what_the_formats_cannot_say(tmp_path):
    cam = rs.Camera(eye=(0, 0, 4), width=W, height=H)
    with pytest.raises(ValueError, match="cameras\\[0\\]: orthographic"):
        write_colmap(tmp_path, [cam.replace(projection="orthographic")], ["a.png"])
    with pytest.raises(ValueError, match="names: expected one per camera \\(1\\), got 2"):
        write_colmap(tmp_path, [cam], ["a.png", "b.png"])
    with pytest.raises(ValueError, match="file_paths\\[0\\]: expected a file name"):
        nerfstudio_transforms([cam], ["a\nb"])
    with pytest.raises(TypeError, match="cameras\\[1\\]: expected a Camera"):
        nerfstudio_transforms([cam, "cam"], ["a", "b"])


def test_views_write_the_exports(tmp_path):
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                     camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H))
    cams = orbit_cameras(scene.camera, 3)
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]), exports="nerfstudio,colmap")
    data = json.load(open(tmp_path / "transforms.json"))
    assert [f["file_path"] for f in data["frames"]] == [f"view_{i:05d}.png" for i in range(3)]
    rec = pycolmap.Reconstruction(str(tmp_path / "colmap"))
    assert sorted(im.name for im in rec.images.values()) == [f"view_{i:05d}.png" for i in range(3)]
    with pytest.raises(ValueError, match="exports: 'colmap' names each view's image file"):
        render_views(scene, cams, tmp_path / "b", files=rs.ViewFiles(buffers=["zdepth"], image=None),
                     exports=["colmap"])
    with pytest.raises(ValueError, match="exports: unknown export 'yolo'"):  # 'bop' is one now: test_bop.py
        render_views(scene, cams, tmp_path / "b", files=rs.ViewFiles(buffers=["zdepth"]), exports=["yolo"])


LENSES = {"OPENCV": ([-0.21, 0.05, 0.001, -0.002], False), "FULL_OPENCV": ([-0.21, 0.05, 0.001, -0.002, 0.01], False),
          "OPENCV_FISHEYE": ([0.06, -0.02, 0.004, -0.001], True)}


@pytest.mark.parametrize("model", LENSES)
def test_distorted_cameras_export_with_their_lens(tmp_path, model):
    import cv2

    from raycast_shade.scene.projection import project_points
    from raycast_shade.visibility.distortion import ray_directions

    dist, fisheye = LENSES[model]
    cams = [rs.Camera.from_opencv(c.K, *c.to_opencv()[1:], W, H, dist=dist, fisheye=fisheye) for c in _cameras()[1:3]]
    write_colmap(tmp_path, cams, ["a.png", "b.png"])
    rec = pycolmap.Reconstruction(str(tmp_path))
    data = nerfstudio_transforms(cams, ["a.png", "b.png"])
    assert data["camera_model"] == ("OPENCV_FISHEYE" if fisheye else "OPENCV")
    rng = np.random.default_rng(5)
    for i, cam in enumerate(cams):
        image = rec.images[i + 1]
        assert image.camera.model_name == model
        d, ok = ray_directions(cam)
        pts = {"points": _points(rng), "rays": cam.eye + 3.0 * d[ok]}
        for kind, p in pts.items():
            ours = project_points(cam, p)[0] if kind == "points" else _pixel_rays(cam)[1][ok]
            front = np.isfinite(ours).all(axis=1)
            theirs = np.array([image.project_point(q) for q in p[front]], dtype=np.float64) - 0.5
            assert np.abs(theirs - ours[front]).max() < TOL_PX, (model, kind)
        # nerfstudio's fields, read as OpenCV's model with its +0.5 principal point
        f = data["frames"][i]
        Kn = np.array([[f["fl_x"], 0, f["cx"]], [0, f["fl_y"], f["cy"]], [0, 0, 1]])
        _, R, t = cam.to_opencv()
        p = cam.eye + 3.0 * d[ok]
        if fisheye:
            D = np.array([f["k1"], f["k2"], f["k3"], f["k4"]])
            uv = cv2.fisheye.projectPoints(p.reshape(-1, 1, 3), cv2.Rodrigues(R)[0], t, Kn, D)[0]
        else:
            D = np.array([f["k1"], f["k2"], f["p1"], f["p2"], f["k3"]])
            uv = cv2.projectPoints(p, cv2.Rodrigues(R)[0], t, Kn, D)[0]
        assert np.abs(uv.reshape(-1, 2) - 0.5 - _pixel_rays(cam)[1][ok]).max() < TOL_PX


def test_fisheye_and_other_lenses_mix_in_colmap_but_not_in_one_transforms_json(tmp_path):
    # nerfstudio's dataparser reads camera_model from the top of the file only; COLMAP gives one per camera.
    a = rs.Camera.from_opencv(_cameras()[1].K, np.eye(3), [0, 0, 4], W, H, dist=[0.1, 0, 0, 0], fisheye=True)
    b = rs.Camera.from_opencv(_cameras()[1].K, np.eye(3), [0, 0, 4], W, H, dist=[0.1, 0, 0, 0])
    with pytest.raises(ValueError, match="fisheye \\(cameras\\[0\\]\\) and pinhole/OpenCV lenses \\(cameras\\[1\\]\\)"):
        write_transforms(tmp_path / "t.json", [a, b, a], ["a.png", "b.png", "c.png"])
    assert not (tmp_path / "t.json").exists()
    write_colmap(tmp_path, [a, b], ["a.png", "b.png"])
    rec = pycolmap.Reconstruction(str(tmp_path))
    assert [rec.images[i].camera.model_name for i in (1, 2)] == ["OPENCV_FISHEYE", "OPENCV"]


@pytest.mark.parametrize("names, match", [
    (["a b.png", "c.png"], "names\\[0\\]: 'a b.png' holds whitespace"),
    (["a.png", "c\td.png"], "names\\[1\\]: 'c\\\\td.png' holds whitespace"),
    (["a.png", "c\u00a0d.png"], "names\\[1\\]: .* holds whitespace"),
    (["a.png", "a.png"], "names\\[1\\]: 'a.png' repeats names\\[0\\]"),
])
def test_colmap_names_with_whitespace_or_repeats_are_refused_before_any_file(tmp_path, names, match):
    cams = _cameras()[:2]
    with pytest.raises(ValueError, match=match):
        write_colmap(tmp_path / "model", cams, names)
    assert not (tmp_path / "model").exists()


def test_valid_colmap_names_round_trip_through_pycolmap(tmp_path):
    names = ["view-1_a.png", "sub/dir/view.2.png", "ünïcode_名前.jpg", "UPPER.PNG"]
    write_colmap(tmp_path, _cameras()[:4], names)
    rec = pycolmap.Reconstruction(str(tmp_path))
    assert [rec.images[i + 1].name for i in range(4)] == names


def test_export_targets_in_the_way_are_refused_naming_them(tmp_path):
    cams = _cameras()[:2]
    (tmp_path / "file").write_text("mine")
    with pytest.raises(ValueError, match="folder: .*file' is a file, not a folder"):
        write_colmap(tmp_path / "file", cams, ["a.png", "b.png"])
    with pytest.raises(ValueError, match="folder: .*file/model' cannot be made: .*file is a file"):
        write_colmap(tmp_path / "file" / "model", cams, ["a.png", "b.png"])
    (tmp_path / "m" / "images.txt").mkdir(parents=True)
    with pytest.raises(ValueError, match="folder: .*images.txt' is a folder; COLMAP's images.txt goes there"):
        write_colmap(tmp_path / "m", cams, ["a.png", "b.png"])
    assert sorted(os.listdir(tmp_path / "m")) == ["images.txt"] and (tmp_path / "file").read_text() == "mine"
    (tmp_path / "t.json").mkdir()
    with pytest.raises(ValueError, match="path: .*t.json' is a folder, not a file"):
        write_transforms(tmp_path / "t.json", cams, ["a.png", "b.png"])
    with pytest.raises(ValueError, match="path: .*/proc/t.json' cannot be written"):
        write_transforms("/proc/t.json", cams, ["a.png", "b.png"])


@pytest.fixture
def no_render(monkeypatch):
    """render_views' render fails the test if called: what is refused is refused before any view."""
    import raycast_shade.apps.views as views

    def render(*args, **kwargs):
        raise AssertionError("a view was rendered")

    monkeypatch.setattr(views, "render", render)


def _export_scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H))


def test_views_refuse_cameras_an_export_cannot_say_before_any_view(tmp_path, no_render):
    scene = _export_scene()
    cams = orbit_cameras(scene.camera, 3)
    fish = rs.Camera.from_opencv(cams[2].K, *cams[2].to_opencv()[1:], W, H, dist=[0.1, 0, 0, 0], fisheye=True)
    files = rs.ViewFiles(buffers=["zdepth"])
    with pytest.raises(ValueError, match="exports: 'nerfstudio' cannot be written: cameras: fisheye \\(cameras\\[2\\]\\)"):
        render_views(scene, [cams[0], cams[1], fish], tmp_path / "a", files=files, exports="nerfstudio")
    ortho = [c.replace(projection="orthographic") if i == 1 else c for i, c in enumerate(cams)]
    with pytest.raises(ValueError, match="exports: 'colmap' cannot be written: cameras\\[1\\]: orthographic"):
        render_views(scene, ortho, tmp_path / "a", files=files, exports=["coco", "colmap"])
    assert not (tmp_path / "a").exists()


def test_views_refuse_a_file_where_an_export_goes_before_any_view(tmp_path, no_render):
    scene = _export_scene()
    cams = orbit_cameras(scene.camera, 2)
    files = rs.ViewFiles(buffers=["zdepth"])
    (tmp_path / "colmap").write_text("mine")
    with pytest.raises(ValueError, match="exports: 'colmap' writes the folder .*colmap', but a file is there"):
        render_views(scene, cams, tmp_path, files=files, exports="colmap")
    (tmp_path / "colmap").unlink()
    (tmp_path / "transforms.json").mkdir()
    with pytest.raises(ValueError, match="out_dir: .*transforms.json' is a folder where the view set writes a file"):
        render_views(scene, cams, tmp_path, files=files, exports="nerfstudio")
    (tmp_path / "transforms.json").rmdir()
    (tmp_path / "view_00001.npz").mkdir()
    with pytest.raises(ValueError, match="out_dir: .*view_00001.npz' is a folder"):
        render_views(scene, cams, tmp_path, files=files)
    assert sorted(os.listdir(tmp_path)) == ["view_00001.npz"]  # no plan.json, no view file
    with pytest.raises(ValueError, match="out_dir: '/proc/set' cannot be written"):
        render_views(scene, cams, "/proc/set", files=files)
