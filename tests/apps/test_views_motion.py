"""Objects that move in a view set: per-view poses in every file, stable ids, and the flow export
checked against OpenCV's projection of the position buffer."""

from __future__ import annotations

import json
import os
import warnings

import cv2
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.cli import main
from raycast_shade.output.labels import rle_decode

W, H, V = 64, 48, 3


def _scene():
    floor = np.array([[1, 0, 0, 0], [0, 0, -1, -0.6], [0, 1, 0, 0], [0, 0, 0, 1.0]])
    return rs.Scene([rs.Model(rs.shapes.cube(0.8), rs.Material(kd=(0.8, 0.3, 0.2)), name="cube"),
                     rs.Model(rs.shapes.icosphere(2, radius=0.5), name="ball",
                              pose=np.array([[1, 0, 0, 1.2], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])),
                     rs.Model(rs.shapes.plane(6.0), name="floor", pose=floor)],
                    lights=[rs.PointLight((2.0, 4.0, 4.0))],
                    camera=rs.Camera(eye=(0.0, 1.5, 5.0), width=W, height=H))


def _track():
    track = rs.keyframes([0, V - 1], [np.eye(4), rs.orbit_poses(2, (0, 1, 0), 60)[1]], V)
    track[:, :3, 3] += np.linspace(0.0, 0.4, V)[:, None] * [1.0, 0.0, 0.0]
    return track


def _cameras(scene):
    return [scene.camera.replace(eye=(0.2 * i, 1.5, 5.0)) for i in range(V)]


@pytest.fixture(scope="module")
def moving(tmp_path_factory):
    scene, out = _scene(), tmp_path_factory.mktemp("moving")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the scene's own pitfalls are not what is tested
        rs.render_views(scene, _cameras(scene), out, poses={"cube": _track()}, exports=("flow", "coco", "bop"),
                        files=rs.ViewFiles(buffers=("position", "model_id"), formats=("npz",)))
    return scene, out, json.load(open(out / "index.json"))


def test_every_file_says_each_views_pose(moving):
    scene, out, index = moving
    track = _track()
    gt = json.load(open(out / "bop" / "train" / "000000" / "scene_gt.json"))
    for i, view in enumerate(index["views"]):
        poses = np.array(view["model_to_world"])
        assert np.array_equal(poses[0], track[i]) and np.array_equal(poses[1], scene.models[1].model_to_world)
        w2c = np.eye(4)
        w2c[:3, :3], w2c[:3, 3] = view["R"], view["t"]
        record = json.load(open(out / view["files"]["record"]))
        cube = next(o for o in record["objects"] if o["id"] == 0)
        assert np.allclose(cube["pose"], w2c @ track[i], atol=1e-12)
        m2c = w2c @ track[i]
        assert np.allclose(np.reshape(gt[str(i)][0]["cam_R_m2c"], (3, 3)), m2c[:3, :3], atol=1e-12)
        assert np.allclose(gt[str(i)][0]["cam_t_m2c"], m2c[:3, 3] * 1000.0, atol=1e-9)
    assert not np.allclose(index["views"][0]["model_to_world"][0], index["views"][-1]["model_to_world"][0])


def test_ids_are_stable_and_coco_masks_are_each_views(moving):
    scene, out, index = moving
    coco = json.load(open(out / "coco_instances.json"))
    track = _track()
    for i, view in enumerate(index["views"]):
        ids = rs.load_npz(out / view["files"]["npz"])["model_id"]
        assert set(np.unique(ids)) <= {-1, 0, 1, 2}
        # The cube's centre, projected through the view's camera, is the cube's pixel in every view.
        uv, _ = cv2.projectPoints(track[i][:3, 3][None], cv2.Rodrigues(np.array(view["R"]))[0], np.array(view["t"]),
                                  np.array(view["K"]), None)
        col, row = np.rint(uv[0, 0]).astype(int)
        assert ids[row, col] == 0
        anns = {a["model_id"]: a for a in coco["annotations"] if a["image_id"] == i + 1}
        for g, ann in anns.items():
            assert np.array_equal(rle_decode(ann["segmentation"]), ids == g)
        assert sorted(anns) == sorted(int(g) for g in np.unique(ids) if g >= 0)


def test_flow_matches_opencvs_projection_of_the_moved_position_buffer(moving):
    scene, out, index = moving
    pairs = index["flow"]["pairs"]
    assert [(p["from"], p["to"]) for p in pairs] == [(0, 1), (1, 0), (1, 2), (2, 1)]
    assert json.load(open(out / "flow" / "flow.json"))["pairs"] == pairs
    for pair in pairs:
        a, b = pair["from"], pair["to"]
        bufs = rs.load_npz(out / index["views"][a]["files"]["npz"])
        flo = rs.read_flo(str(out / pair["flo"]))
        assert np.array_equal(flo.view(np.uint32), cv2.readOpticalFlow(str(out / pair["flo"])).view(np.uint32))
        png, valid = rs.read_flow_png(str(out / pair["png"]))
        rows, cols = np.nonzero(valid)
        assert len(rows) == pair["valid"] > 0.3 * W * H
        ids, p = bufs["model_id"][rows, cols], bufs["position"][rows, cols].astype(np.float64)
        for g in np.unique(ids):  # each model's points carried by its pose change from view a to view b
            pa, pb = (np.array(index["views"][k]["model_to_world"][g]) for k in (a, b))
            M = pb @ np.linalg.inv(pa)
            p[ids == g] = p[ids == g] @ M[:3, :3].T + M[:3, 3]
        vb = index["views"][b]
        uv, _ = cv2.projectPoints(p, cv2.Rodrigues(np.array(vb["R"]))[0], np.array(vb["t"]), np.array(vb["K"]), None)
        expect = uv[:, 0] - np.c_[cols, rows]
        assert np.abs(flo[rows, cols] - expect).max() < 1e-3
        assert np.abs(png[rows, cols] - expect).max() <= 1 / 128 + 1e-4
        background = bufs["model_id"] < 0
        assert (flo[background] == 1e10).all() and not valid[background].any()
        moved = (ids == 0)
        assert np.abs(expect[moved]).max() > 1.0  # the cube moves: a flow to check


def test_the_static_case_is_unchanged_and_constant_poses_are_static(tmp_path):
    scene = _scene()
    cams = _cameras(scene)
    files = rs.ViewFiles(buffers=("zdepth", "model_id"), formats=("npz",), compression="none")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rs.render_views(scene, cams, tmp_path / "a", files=files)
        rs.render_views(scene, cams, tmp_path / "b", files=files, poses={0: np.tile(np.eye(4), (V, 1, 1))},
                        exports=("nerfstudio",))  # the cube stays: a static scene, nerfstudio allowed
    for i in range(V):
        for ext in (".png", ".npz"):
            name = f"view_{i:05d}{ext}"
            assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    assert "model_to_world" not in json.load(open(tmp_path / "a" / "index.json"))["views"][0]


@pytest.mark.parametrize("poses, exports, message", [
    ({"lid": np.tile(np.eye(4), (V, 1, 1))}, (), "poses: no model is named 'lid'"),
    ({7: np.tile(np.eye(4), (V, 1, 1))}, (), "poses: key 7 is neither"),
    ({0: np.tile(np.eye(4), (V - 1, 1, 1))}, (), r"poses\[0\]: expected one pose per view \(3\), got 2"),
    ({0: np.tile(np.diag([1.0, 1, 1.01, 1]), (V, 1, 1))}, (), r"poses\[0\]\[0\]: its 3x3 part must be a rotation"),
    ([np.eye(4)], (), "poses: expected a dict"),
    ({"cube": "track"}, ("nerfstudio",), r"poses\['cube'\]"),
    ({"cube": None}, ("colmap",), r"poses\['cube'\]"),
])
def test_bad_poses_are_refused_before_anything_is_written(tmp_path, poses, exports, message):
    scene = _scene()
    with pytest.raises((TypeError, ValueError), match=message):
        rs.render_views(scene, _cameras(scene), tmp_path / "v", poses=poses, exports=exports)
    assert not (tmp_path / "v").exists()


@pytest.mark.parametrize("export", ["nerfstudio", "colmap"])
def test_static_scene_exports_are_refused_when_a_model_moves(tmp_path, export):
    scene = _scene()
    with pytest.raises(ValueError, match=f"exports: '{export}' describes one static scene.*model 0 \\('cube'\\)"):
        rs.render_views(scene, _cameras(scene), tmp_path / "v", poses={"cube": _track()}, exports=(export,))
    with pytest.raises(ValueError, match="exports: 'flow' .* at least two cameras"):
        rs.render_views(scene, _cameras(scene)[:1], tmp_path / "v", exports=("flow",))
    assert not (tmp_path / "v").exists()


def test_the_cli_reads_motion_tables(tmp_path):
    toml = tmp_path / "scene.toml"
    toml.write_text('[camera]\neye = [0.0, 1.0, 5.0]\nwidth = 32\nheight = 24\n\n'
                    '[[object]]\nshape = "cube"\nname = "box"\n\n'
                    '[[light]]\ntype = "point"\nposition = [2.0, 3.0, 4.0]\n\n'
                    '[[motion]]\nmodel = "box"\norbit = { axis = [0.0, 1.0, 0.0], degrees = 30.0 }\n')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["views", str(toml), "--orbit", "2", "--export", "flow", "-o", str(tmp_path / "v")]) == 0
    index = json.load(open(tmp_path / "v" / "index.json"))
    track = rs.orbit_poses(2, (0, 1, 0), 30)
    assert all(np.allclose(v["model_to_world"][0], track[i], atol=1e-15) for i, v in enumerate(index["views"]))
    assert os.path.exists(tmp_path / "v" / "flow" / "forward_00000.flo")


def test_bop_refuses_per_view_poses_of_another_shape_before_writing(tmp_path):
    from raycast_shade.output.bop import write_bop

    scene = _scene()
    views = [{"rgb": "a.png", "depth": "a_depth.png", "depth_units": 1000.0, "objects": []}]
    for poses, message in [(np.tile(np.eye(4), (1, 2, 1, 1)), r"poses: expected \(1, 3, 4, 4\)"),
                           (np.tile(np.diag([1.0, 2.0, 1.0, 1.0]), (1, 3, 1, 1)), "poses .*must be a rotation")]:
        with pytest.raises(ValueError, match=message):
            write_bop(tmp_path / "bop", scene, [scene.camera], views, poses=poses)
    assert not (tmp_path / "bop").exists()


def test_a_single_render_says_it_does_not_apply_motion_tables(tmp_path):
    toml = tmp_path / "scene.toml"
    toml.write_text('[camera]\neye = [0.0, 1.0, 5.0]\nwidth = 32\nheight = 24\n\n'
                    '[[object]]\nshape = "cube"\nname = "box"\n\n'
                    '[[light]]\ntype = "point"\nposition = [2.0, 3.0, 4.0]\n\n'
                    '[[motion]]\nmodel = "box"\norbit = { axis = [0.0, 1.0, 0.0], degrees = 30.0 }\n')
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"1 \[\[motion\]\] table\(s\) not applied by a single render"):
        frame = rs.render_file(toml)
    still = toml.read_text().split("[[motion]]")[0]
    (tmp_path / "still.toml").write_text(still)
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        plain = rs.render_file(tmp_path / "still.toml")
    assert np.array_equal(frame.image, plain.image)  # drawn as placed, as the warning says


def test_an_overwrite_without_the_flow_export_names_the_earlier_flow_folder(tmp_path):
    """The flow files of an earlier run stay (overwrite replaces the set's own files); the run that no
    longer exports flow says so, naming the folder, and a run that exports it again does not."""
    scene = _scene()
    cams = _cameras(scene)[:2]
    files = rs.ViewFiles(buffers=("zdepth",), formats=("npz",), compression="none")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rs.render_views(scene, cams, tmp_path, files=files, exports=("flow",))
    assert any(n.endswith(".flo") for n in os.listdir(tmp_path / "flow"))
    with pytest.warns(UserWarning, match=r"flow/ in .* hold an earlier run's flow export, which this set does not "
                                         r"write"):
        rs.render_views(scene, cams[::-1], tmp_path, files=files, overwrite=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rs.render_views(scene, cams, tmp_path, files=files, overwrite=True, exports=("flow",))
    assert not [w for w in caught if "earlier run" in str(w.message)]
