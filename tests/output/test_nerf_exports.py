"""NeRF and splatting exports of a view set, checked by the readers' own rules.

* COLMAP: pycolmap reads ``colmap/sparse/0`` (and the flat layout); every point reprojects into
  every view of its track within 1e-6 px (pycolmap's camera models, our numbers); the tracks agree
  with the rendered z-depth buffers (a tracked point lies on the surface its pixel sees, an
  untracked one inside the image lies behind it); the colours are the images' pixels.
* nerfstudio: ``depth_file_path`` and ``mask_path`` read back as nerfstudio's dataparser and depth
  loss read them (re-implemented here in NumPy: ``cv2.imread(ANYDEPTH) * depth_unit_scale_factor``;
  the mask's non-zero pixels trained on; a pinhole depth times the norm of the ray direction
  ``((u - cx) / fx, (v - cy) / fy, 1)`` is the distance along the ray, a fisheye depth is that
  distance as it is), against the rendered ``depth`` buffer (distance along the ray).

The scene: two balls and a cube, 64x48, three views.
"""

from __future__ import annotations

import json
import os

import cv2
import imageio.v3 as iio
import numpy as np
import pycolmap
import pytest

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.viewexports import ExportOptions
from raycast_shade.apps.views import render_views
from raycast_shade.output.bufferfile import load_npz
from raycast_shade.output.export import write_colmap
from raycast_shade.output.surfacepoints import surface_points

W, H = 64, 48
DEPTH_SCALE = 1000.0


def _pose(t):
    P = np.eye(4)
    P[:3, 3] = t
    return P


def nerf_scene():
    models = [rs.Model(rs.shapes.icosphere(2), name="ball"),
              rs.Model(rs.shapes.cube(size=0.8), name="cube", pose=_pose((0.9, 0.0, 0.6))),
              rs.Model(rs.shapes.icosphere(1), name="ball", pose=_pose((-1.0, 0.4, 0.8)))]
    return rs.Scene(models, lights=[rs.PointLight((2, 3, 4), intensity=20)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H))


@pytest.fixture(scope="module")
def view_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("nerf")
    scene = nerf_scene()
    cams = orbit_cameras(scene.camera, 3)
    files = rs.ViewFiles(buffers=["zdepth", "depth", "model_id"], formats=("npz", "depth_png", "mask_png"))
    render_views(scene, cams, out, files=files, exports=["nerfstudio", "colmap"],
                 export_options=ExportOptions(colmap_layout="sparse", colmap_points=150))
    return scene, cams, out


def _colmap_project(image, xyz):
    return np.array(image.project_point(xyz), np.float64)


def test_pycolmap_reads_the_sparse_layout_and_every_track_reprojects(view_set):
    scene, cams, out = view_set
    root = out / "colmap"
    assert sorted(os.listdir(root / "images")) == [f"view_{i:05d}.png" for i in range(3)]
    for i in range(3):  # the images a splatting trainer opens are the views' images
        assert (root / "images" / f"view_{i:05d}.png").read_bytes() == (out / f"view_{i:05d}.png").read_bytes()
    rec = pycolmap.Reconstruction(str(root / "sparse" / "0"))
    assert rec.num_images() == 3 and 300 <= rec.num_points3D() <= 450
    worst, elements = 0.0, 0
    for pid, p in rec.points3D.items():
        assert p.track.length() >= 1
        for el in p.track.elements:
            image = rec.images[el.image_id]
            assert image.points2D[el.point2D_idx].point3D_id == pid  # both directions of the link
            worst = max(worst, float(np.abs(_colmap_project(image, p.xyz) - image.points2D[el.point2D_idx].xy).max()))
            elements += 1
    assert worst < 1e-6, worst
    assert elements > rec.num_points3D()  # some points are seen from two views
    assert sum(im.num_points3D for im in rec.images.values()) == elements


def _zdepth(out, i):
    return load_npz(out / f"view_{i:05d}.npz")["zdepth"]


def test_tracks_agree_with_the_rendered_depth_and_colours_with_the_images(view_set):
    scene, cams, out = view_set
    rec = pycolmap.Reconstruction(str(out / "colmap" / "sparse" / "0"))
    xyz = np.array([p.xyz for p in rec.points3D.values()])
    ids = np.array(list(rec.points3D.keys()))
    tracked = {i: set() for i in range(3)}
    for pid, p in rec.points3D.items():
        for el in p.track.elements:
            tracked[el.image_id - 1].add(pid)
    agree, wrong = [], 0
    for i, cam in enumerate(cams):
        K, R, t = cam.to_opencv()
        q = xyz @ R.T + t
        uv = q[:, :2] / q[:, 2:] * [K[0, 0], K[1, 1]] + [K[0, 2], K[1, 2]]
        z = _zdepth(out, i)
        model = load_npz(out / f"view_{i:05d}.npz")["model_id"]
        for k in np.flatnonzero((q[:, 2] > 0) & (uv >= -0.5).all(axis=1) & (uv < [W - 0.5, H - 0.5]).all(axis=1)):
            # the 2x2 pixel centres around the projection: is the point on the surface one of them sees
            # (within 2% of its depth), or clearly behind every one of them?
            c0, r0 = np.floor(uv[k]).astype(int)
            cells = [(r, c) for r in (r0, r0 + 1) for c in (c0, c0 + 1) if 0 <= r < H and 0 <= c < W]
            near = np.array([z[r, c] for r, c in cells])
            clean = len({int(model[r, c]) for r, c in cells}) == 1 and model[cells[0]] >= 0  # not at a silhouette
            near = np.where(np.isfinite(near) & (near > 0), near, np.inf)
            on = (np.abs(near - q[k, 2]) < 0.02 * q[k, 2]).any()
            behind = (near < 0.98 * q[k, 2]).all()
            seen = ids[k] in tracked[i]
            wrong += int(clean and ((seen and behind) or (not seen and on and not (near < 0.98 * q[k, 2]).any())))
            agree.append(on if seen else behind)
    # Away from silhouettes (the four pixels on one model): never tracked where every one sees a nearer
    # surface, never left out where none does and one sees it; next to a silhouette the pixel centres
    # see other surfaces than the point's exact ray (a few percent at 64x48).
    assert wrong == 0 and len(agree) > 400 and np.mean(agree) > 0.9, (wrong, len(agree), np.mean(agree))
    images = [iio.imread(out / f"view_{i:05d}.png") for i in range(3)]
    hits = 0
    for p in rec.points3D.values():  # each point's colour is a pixel whose centre it projects to
        for el in p.track.elements:
            xy = rec.images[el.image_id].points2D[el.point2D_idx].xy - 0.5
            if np.abs(xy - np.rint(xy)).max() < 1e-3:
                c, r = np.rint(xy).astype(int)
                assert (images[el.image_id - 1][r, c, :3] == p.color).all()
                hits += 1
                break
    assert hits == rec.num_points3D()


def test_the_flat_layout_stays_and_no_points_is_an_empty_points3d(tmp_path):
    scene = nerf_scene()
    cams = orbit_cameras(scene.camera, 2)
    images = [np.zeros((H, W, 3), np.uint8)] * 2
    write_colmap(tmp_path / "none", cams, ["a.png", "b.png"])
    assert pycolmap.Reconstruction(str(tmp_path / "none")).num_points3D() == 0
    pts = surface_points(scene, cams, images, per_view=0)
    assert len(pts.xyz) == 0
    pts = surface_points(scene, cams, images, per_view=40)
    assert 60 <= len(pts.xyz) <= 80 and pts.track_lengths.min() >= 1
    write_colmap(tmp_path / "m", cams, ["a.png", "b.png"], pts)
    assert pycolmap.Reconstruction(str(tmp_path / "m")).num_points3D() == len(pts.xyz)
    with pytest.raises(ValueError, match="images\\[1\\]: expected \\(48, 64, 3\\) uint8"):
        surface_points(scene, cams, [images[0], np.zeros((H, W), np.uint8)])
    with pytest.raises(ValueError, match="per_view"):
        surface_points(scene, cams, images, per_view=-1)


def test_fisheye_points_reproject_through_pycolmaps_fisheye_model(tmp_path):
    scene = nerf_scene()
    cams = [rs.Camera.from_opencv(c.K, *c.to_opencv()[1:], W, H, dist=[0.06, -0.02, 0.004, -0.001], fisheye=True)
            for c in orbit_cameras(scene.camera, 3)]
    pts = surface_points(scene, cams, [np.zeros((H, W, 3), np.uint8)] * 3, per_view=60)
    write_colmap(tmp_path, cams, ["a.png", "b.png", "c.png"], pts)
    rec = pycolmap.Reconstruction(str(tmp_path))
    assert rec.images[1].camera.model_name == "OPENCV_FISHEYE" and rec.num_points3D() == len(pts.xyz)
    worst = max(float(np.abs(_colmap_project(rec.images[el.image_id], p.xyz)
                             - rec.images[el.image_id].points2D[el.point2D_idx].xy).max())
                for p in rec.points3D.values() for el in p.track.elements)
    assert worst < 1e-6


def _nerfstudio_depth(path, unit):
    """nerfstudio's get_depth_image_from_path for a PNG: OpenCV's any-depth read times the factor."""
    return cv2.imread(str(path), cv2.IMREAD_ANYDEPTH).astype(np.float64) * unit


def _nerfstudio_mask(path):
    """nerfstudio's get_image_mask_tensor_from_path: one channel, trained where non-zero."""
    from PIL import Image

    m = np.array(Image.open(path))
    assert m.ndim == 2  # nerfstudio refuses a mask of more than one channel
    return m.astype(bool)


def test_nerfstudio_reads_z_depth_and_masks_of_a_pinhole_set(view_set):
    scene, cams, out = view_set
    meta = json.load(open(out / "transforms.json"))
    assert meta["camera_model"] == "OPENCV" and meta["depth_unit_scale_factor"] == 1.0 / DEPTH_SCALE
    for i, frame in enumerate(sorted(meta["frames"], key=lambda f: f["file_path"])):
        assert frame["depth_file_path"] == f"view_{i:05d}_depth.png" and frame["mask_path"] == f"view_{i:05d}_mask.png"
        buffers = load_npz(out / f"view_{i:05d}.npz")
        depth = _nerfstudio_depth(out / frame["depth_file_path"], meta["depth_unit_scale_factor"])
        hit = buffers["model_id"] >= 0
        assert (_nerfstudio_mask(out / frame["mask_path"]) == hit).all()
        assert (depth[~hit] == 0).all()
        # the depth loss (is_euclidean_depth False): depth times |direction| with z = 1 is the ray's length
        jj, ii = np.mgrid[0:H, 0:W]
        x = (ii + 0.5 - meta["cx"]) / meta["fl_x"]
        y = (jj + 0.5 - meta["cy"]) / meta["fl_y"]
        along = depth * np.sqrt(x * x + y * y + 1.0)
        assert np.abs(along - buffers["depth"])[hit].max() < 0.5 / DEPTH_SCALE * np.sqrt(x * x + y * y + 1).max() + 1e-6


def test_nerfstudio_reads_ray_distance_of_a_fisheye_set(tmp_path):
    scene = nerf_scene()
    cams = [rs.Camera.from_opencv(c.K, *c.to_opencv()[1:], W, H, dist=[0.06, -0.02, 0.004, -0.001], fisheye=True)
            for c in orbit_cameras(scene.camera, 2)]
    files = rs.ViewFiles(buffers=["depth", "model_id"], formats=("npz", "depth_png"))
    render_views(scene, cams, tmp_path, files=files, exports=["nerfstudio"])
    meta = json.load(open(tmp_path / "transforms.json"))
    index = json.load(open(tmp_path / "index.json"))
    assert meta["camera_model"] == "OPENCV_FISHEYE" and "distance_png" in index["formats"]
    for i, frame in enumerate(meta["frames"]):
        assert frame["depth_file_path"] == f"view_{i:05d}_distance.png" and "mask_path" not in frame
        buffers = load_npz(tmp_path / f"view_{i:05d}.npz")
        depth = _nerfstudio_depth(tmp_path / frame["depth_file_path"], meta["depth_unit_scale_factor"])
        hit = buffers["model_id"] >= 0
        # fisheye directions are unit in nerfstudio: the value is the distance along the ray as it is
        assert hit.any() and np.abs(depth - buffers["depth"])[hit].max() <= 0.5 / DEPTH_SCALE + 1e-6


def test_export_options_are_checked_naming_the_field():
    with pytest.raises(ValueError, match="colmap_layout"):
        ExportOptions(colmap_layout="dense")
    with pytest.raises(ValueError, match="colmap_points"):
        ExportOptions(colmap_points=-1)
    with pytest.raises(ValueError, match="polygon_tolerance"):
        ExportOptions(polygon_tolerance=-0.5)
    with pytest.raises(ValueError, match="polygon_tolerance"):
        ExportOptions(polygon_tolerance=1e308)
    with pytest.raises(ValueError, match="coco_segmentation"):
        ExportOptions(coco_segmentation="bitmap")
    with pytest.raises(TypeError, match="colmap_points"):
        ExportOptions(colmap_points=1.5)


def test_bad_export_options_are_refused_before_any_view(tmp_path, monkeypatch):
    import raycast_shade.apps.views as views

    monkeypatch.setattr(views, "render", lambda *a, **k: pytest.fail("a view was rendered"))
    scene = nerf_scene()
    with pytest.raises(TypeError, match="export_options: expected an ExportOptions"):
        render_views(scene, orbit_cameras(scene.camera, 2), tmp_path / "a", export_options={"colmap_points": 3})
    assert not (tmp_path / "a").exists()


def test_the_cli_prints_one_line_for_a_bad_export_option(tmp_path, capsys):
    from raycast_shade.apps.cli import main

    import trimesh

    mesh = tmp_path / "cube.stl"
    trimesh.creation.box().export(mesh)
    code = main(["views", str(mesh), "--orbit", "2", "-o", str(tmp_path / "set"), "--colmap-points", "-3"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "colmap_points" in err[0]
    assert not (tmp_path / "set").exists()


@pytest.mark.parametrize("ext", [".pfm", ".npy"])
def test_points_of_a_float_image_set_take_the_colours_its_png_would_have(tmp_path, ext):
    scene = nerf_scene()
    cams = orbit_cameras(scene.camera, 2)
    colours = {}
    for image in (".png", ext):
        out = tmp_path / image[1:]
        render_views(scene, cams, out, files=rs.ViewFiles(buffers=["zdepth"], image=image), exports=["colmap"],
                     export_options=ExportOptions(colmap_points=30))
        rec = pycolmap.Reconstruction(str(out / "colmap"))
        colours[image] = np.array([rec.points3D[k].color for k in sorted(rec.points3D)])
    assert len(colours[ext]) > 40 and colours[ext].max() > 0
    assert (colours[ext] == colours[".png"]).all()  # tone-mapped as the PNG is by default
