"""Objects in data sets: model names (given, or from a glTF's nodes), the semantic mask, each view's
boxes, pixel counts and poses, and the COCO instances file read back by pycocotools itself.

pycocotools is the oracle of the COCO file: its RLE of our mask is our RLE string, its decoding
of ours is our mask bit for bit, its areas and boxes are ours; ``COCO(path)`` loads the file and
``annToMask`` gives back each object's mask.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from pycocotools import mask as cocomask
from pycocotools.coco import COCO

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.views import INDEX_NAME, render_views
from raycast_shade.output.bufferfile import load_npz
from raycast_shade.output.labels import (object_table, rle_decode, rle_encode, semantic_classes, view_objects,
                                         write_coco)

W, H = 48, 36
# pycocotools' decode hands NumPy 2 an object without __array__(copy=...): its warning, not ours.
pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation doesn't accept a copy keyword")


@pytest.fixture(scope="module")
def scene():
    ball = rs.shapes.icosphere(2)
    models = [rs.Model(ball, rs.Material(kd=(0.8, 0.2, 0.1), name="red"), name="ball"),
              rs.Model(rs.shapes.plane(size=5.0, center=(0, 0, -1.2)), rs.Material(name="grey"), name="floor"),
              rs.Model(rs.Mesh(ball.vertices * 0.4 + (1.3, 0.2, 0.3), ball.faces, name="small"), name="ball")]
    return rs.Scene(models, lights=[rs.PointLight((2, 3, 4), intensity=20)],
                    camera=rs.Camera(eye=(0.4, 0.8, 4.0), width=W, height=H))


def test_a_model_is_named_after_its_mesh_unless_named():
    mesh = rs.shapes.icosphere(1)
    assert rs.Model(mesh).name == mesh.name == "icosphere1"
    assert rs.Model(mesh, name="moon").name == "moon"
    for bad in ("", "  ", 3, True):
        with pytest.raises(TypeError, match="model.name: expected a non-empty str"):
            rs.Model(mesh, name=bad)


def test_models_loaded_from_a_gltf_carry_its_node_names(tmp_path):
    import trimesh

    tm = trimesh.Scene()
    tm.add_geometry(trimesh.creation.box(), node_name="crate", geom_name="box_mesh")
    tm.add_geometry(trimesh.creation.icosphere(subdivisions=1), node_name="lamp", geom_name="sphere_mesh",
                    transform=trimesh.transformations.translation_matrix((3, 0, 0)))
    path = tmp_path / "two.glb"
    tm.export(path)
    names = sorted(m.name for m in rs.load_models(path))
    assert names == ["two.glb:crate", "two.glb:lamp"]


def test_semantic_ids_group_models_by_name(scene):
    names, ids = semantic_classes(scene)
    assert names == ("ball", "floor") and ids.tolist() == [0, 1, 0]
    frame = rs.render(scene, buffers=("model_id", "semantic_id"))
    mid, sem = frame.buffers["model_id"], frame.buffers["semantic_id"]
    assert sem.dtype == np.int32
    assert np.array_equal(sem, np.where(mid >= 0, np.array([0, 1, 0])[np.maximum(mid, 0)], -1))
    assert set(np.unique(mid).tolist()) == {-1, 0, 1, 2}  # all three seen, and some background


def test_object_table_names_materials_and_boxes(scene):
    table = object_table(scene)
    assert [o["name"] for o in table] == ["ball", "floor", "ball"]
    assert [o["material"]["name"] for o in table] == ["red", "grey", "material"]
    assert table[0]["material"]["kd"] == [0.8, 0.2, 0.1]
    for obj, model in zip(table, scene.models):
        lo, hi = np.array(obj["box_3d"])
        assert np.array_equal(lo, model.mesh.vertices.min(0)) and np.array_equal(hi, model.mesh.vertices.max(0))
        assert obj["pose"] == np.eye(4).tolist()


def test_view_objects_count_box_and_pose(scene):
    for cam in orbit_cameras(scene.camera, 3):
        mid = rs.render(scene, camera=cam, buffers=("model_id",)).buffers["model_id"]
        objects = view_objects(mid, cam)
        assert [o["id"] for o in objects] == sorted(set(np.unique(mid).tolist()) - {-1})
        K, R, t = cam.to_opencv()
        for o in objects:
            m = mid == o["id"]
            assert o["pixels"] == int(m.sum())
            x0, y0, x1, y1 = o["box"]
            assert m[y0:y1, x0:x1].sum() == m.sum()  # the box holds the mask...
            assert m[y0, x0:x1].any() and m[y1 - 1, x0:x1].any() and m[y0:y1, x0].any() and m[y0:y1, x1 - 1].any()
            P = np.array(o["pose"])
            v = scene.models[o["id"]].mesh.vertices
            assert np.allclose(v @ P[:3, :3].T + P[:3, 3], v @ R.T + t, rtol=0, atol=1e-12)


@settings(max_examples=150, deadline=None)
@given(arrays(np.bool_, st.tuples(st.integers(1, 13), st.integers(1, 11))))
def test_rle_is_pycocotools_rle(mask):
    ours = rle_encode(mask)
    theirs = cocomask.encode(np.asfortranarray(mask.astype(np.uint8)))
    assert ours["counts"] == theirs["counts"].decode("ascii") and ours["size"] == list(theirs["size"])
    decoded = cocomask.decode({"size": ours["size"], "counts": ours["counts"].encode("ascii")})
    assert np.array_equal(decoded.astype(bool), mask)
    assert np.array_equal(rle_decode(ours), mask)
    assert int(cocomask.area(theirs)) == int(mask.sum())


def test_rle_of_long_runs_is_pycocotools_rle():
    """Runs longer than one 5-bit group and differences of both signs."""
    rng = np.random.default_rng(0)
    for _ in range(20):
        mask = np.zeros((300, 200), bool)
        for _ in range(rng.integers(1, 6)):
            r, c = rng.integers(0, 300), rng.integers(0, 200)
            mask[r:r + rng.integers(1, 250), c:c + rng.integers(1, 150)] = True
        ours = rle_encode(mask)
        assert ours["counts"] == cocomask.encode(np.asfortranarray(mask.astype(np.uint8)))["counts"].decode()
        assert np.array_equal(rle_decode(ours), mask)


def test_rle_refuses_what_is_not_a_mask():
    with pytest.raises(ValueError, match="mask: expected an \\(H, W\\) bool array"):
        rle_encode(np.zeros((3, 3), np.uint8))
    with pytest.raises(ValueError, match="rle: runs cover 5 pixels, not 2 x 2"):
        rle_decode({"size": [2, 2], "counts": "5"})


def test_coco_file_reads_back_with_pycocotools(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 3)
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["model_id", "semantic_id"]), exports=["coco"])
    coco = COCO(str(tmp_path / "coco_instances.json"))
    index = json.load(open(tmp_path / INDEX_NAME))
    assert [c["name"] for c in coco.loadCats(coco.getCatIds())] == ["ball", "floor"]
    assert index["classes"] == ["ball", "floor"] and [o["name"] for o in index["objects"]] == ["ball", "floor", "ball"]
    n = 0
    for k, view in enumerate(index["views"]):
        mid = load_npz(tmp_path / view["files"]["npz"])["model_id"]
        img = coco.loadImgs(k + 1)[0]
        assert img["file_name"] == view["files"]["image"] and (img["height"], img["width"]) == mid.shape
        anns = coco.loadAnns(coco.getAnnIds(imgIds=[k + 1]))
        assert sorted(a["model_id"] for a in anns) == [o["id"] for o in view["objects"]]
        for a in anns:
            m = mid == a["model_id"]
            assert np.array_equal(coco.annToMask(a).astype(bool), m)
            rle = coco.annToRLE(a)
            assert a["area"] == int(cocomask.area(rle)) == int(m.sum())
            assert a["bbox"] == cocomask.toBbox(rle).tolist()
            assert a["category_id"] == [1, 2, 1][a["model_id"]]
            n += 1
    assert n == len(coco.getAnnIds()) >= 6


def test_write_coco_checks_its_path(scene, tmp_path):
    with pytest.raises(ValueError, match="expected a .json file"):
        write_coco(tmp_path / "a.txt", scene, [])


def test_cli_views_exports_coco_and_semantic_masks(tmp_path, capsys):
    import os

    from raycast_shade.apps.cli import main

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    args = ["views", os.path.join(root, "examples", "shapes.toml"), "--orbit", "2", "--buffers", "id,semantic_id",
            "--width", "32", "--height", "20", "-o", str(tmp_path)]
    assert main(args + ["--export", "coco,colmap"]) == 0
    coco = COCO(str(tmp_path / "coco_instances.json"))
    assert len(coco.getImgIds()) == 2 and len(coco.getAnnIds()) >= 2
    assert (tmp_path / "colmap" / "images.txt").exists()
    assert set(load_npz(tmp_path / "view_00000.npz")) >= {"model_id", "triangle_id", "semantic_id"}
    capsys.readouterr()
    assert main(args + ["--export", "yolo"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exports: unknown export 'yolo'" in err
    # 'bop' among the buffer formats is the BOP export (the brief's spelling), written beside the npz files
    assert main(args + ["--formats", "npz,bop", "--overwrite"]) == 0
    info = json.load(open(tmp_path / "bop" / "train" / "000000" / "scene_gt_info.json"))
    assert sorted(info) == ["0", "1"] and (tmp_path / "view_00001_depth.png").exists()


def test_unoccluded_counts_boxes_and_visible_fractions(tmp_path):
    """A ball before a wall, and a small cube hidden behind the wall: each model rendered alone
    (an independent render of a one-model scene) gives the unoccluded mask, and alone in a frame
    three times as wide and high with the image in its middle (BOP's ``calc_gt_info``) the count and
    box of the whole silhouette: the wall runs past every border."""
    ball = rs.Model(rs.shapes.icosphere(2), name="ball")
    wall = rs.Model(rs.shapes.plane(size=6.0, center=(0, 0, -1.5)), name="wall")
    hidden = rs.Model(rs.shapes.cube(size=0.5, center=(0.2, 0.1, -2.5)), name="cube")
    scene = rs.Scene([ball, wall, hidden], lights=[rs.PointLight((2, 3, 4))],
                     camera=rs.Camera(eye=(0.4, 0.3, 4.0), width=W, height=H))
    cams = [scene.camera, scene.camera.replace(eye=(1.5, 0.6, 3.8))]
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["model_id"]), unoccluded=True, exports=["coco"])
    index = json.load(open(tmp_path / INDEX_NAME))
    for view, cam in zip(index["views"], cams):
        mid = load_npz(tmp_path / view["files"]["npz"])["model_id"]
        objects = {o["id"]: o for o in view["objects"]}
        assert set(objects) == {0, 1, 2}
        for g, model in enumerate(scene.models):
            solo = rs.render(rs.Scene([model], lights=scene.lights), camera=cam, buffers=("mask",)).buffers["mask"]
            K = cam.K
            big = cam.replace(width=3 * W, height=3 * H, fx=K[0, 0], fy=K[1, 1], cx=K[0, 2] + W, cy=K[1, 2] + H)
            large = rs.render(rs.Scene([model], lights=scene.lights), camera=big, buffers=("mask",)).buffers["mask"]
            o = objects[g]
            assert o["unoccluded"] == int(solo.sum()) > 0
            assert o["unoccluded_all"] == int(large.sum()) >= o["unoccluded"]
            rows, cols = np.nonzero(large)
            assert o["box_unoccluded"] == [cols.min() - W, rows.min() - H, cols.max() + 1 - W, rows.max() + 1 - H]
            assert o["pixels"] == int((mid == g).sum())
            seen = ((mid == g) & solo).sum()
            assert o["visible_fraction"] == pytest.approx(seen / large.sum(), abs=0)
            assert o["visible_fraction_in_image"] == pytest.approx(seen / solo.sum(), abs=0)
        assert objects[0]["visible_fraction"] == 1.0 and objects[0]["box_unoccluded"][0] >= 0
        wall = objects[1]
        assert wall["box_unoccluded"][1] < 0 and wall["box_unoccluded"][3] > H  # past both borders, not clipped
        assert wall["unoccluded_all"] > wall["unoccluded"]
        assert 0 < wall["visible_fraction"] < wall["visible_fraction_in_image"] < 1.0
        assert objects[2]["pixels"] == 0 and objects[2]["box"] is None and objects[2]["visible_fraction"] == 0.0
    coco = COCO(str(tmp_path / "coco_instances.json"))
    assert all(a["model_id"] != 2 for a in coco.loadAnns(coco.getAnnIds()))  # nothing to segment


def test_box_corners_project_like_opencv(scene):
    import cv2

    from raycast_shade.output.labels import box_corners

    corners = box_corners([[0, 1, 2], [3, 4, 5]])
    assert corners.tolist()[0] == [0, 1, 2] and corners.tolist()[7] == [3, 4, 5] and corners.tolist()[5] == [3, 1, 5]
    table = object_table(scene)
    for dist in (None, [-0.2, 0.05, 0.001, 0.0]):
        K, R, t = scene.camera.to_opencv()
        cam = rs.Camera.from_opencv(K, R, t, W, H, dist=dist)
        mid = rs.render(scene, camera=cam, buffers=("model_id",)).buffers["model_id"]
        objects = view_objects(mid, cam, boxes_3d=[o["box_3d"] for o in table])
        for o in objects:
            uv, _ = cv2.projectPoints(box_corners(table[o["id"]]["box_3d"]), cv2.Rodrigues(R)[0], t, K,
                                      None if dist is None else np.array(dist))
            assert np.abs(np.array(o["corners"]) - uv.reshape(-1, 2)).max() < 1e-9


# -- the one-kernel labels against the NumPy version they replaced ---------------------------------------


def _numpy_runs(mask):
    """Run lengths of a column-major flattened mask, starting with a run of 0s (the former NumPy code)."""
    flat = np.asarray(mask, bool).ravel(order="F")
    edges = np.concatenate([[0], np.flatnonzero(flat[1:] != flat[:-1]) + 1, [flat.size]])
    runs = np.diff(edges)
    return np.concatenate([[0], runs]) if flat.size and flat[0] else runs


def _numpy_counts(mask) -> str:
    runs = _numpy_runs(mask).tolist()
    chars = []
    for i, run in enumerate(runs):
        x = run - runs[i - 2] if i > 2 else run
        more = True
        while more:
            c = x & 0x1F
            x >>= 5
            more = (x != -1) if (c & 0x10) else (x != 0)
            chars.append(chr((c | 0x20 if more else c) + 48))
    return "".join(chars)


def _numpy_labels(ids) -> dict:
    out = {}
    for g in np.unique(ids[ids >= 0]).tolist():
        m = ids == g
        rows, cols = np.nonzero(m)
        out[g] = (int(rows.size), [int(cols.min()), int(rows.min()), int(cols.max()) + 1, int(rows.max()) + 1],
                  _numpy_counts(m))
    return out


@settings(max_examples=200, deadline=None)
@given(arrays(st.sampled_from([np.int8, np.int32, np.int64]), st.tuples(st.integers(1, 17), st.integers(1, 13)),
              elements=st.integers(-3, 4)))
def test_id_labels_are_the_numpy_counts_boxes_and_rle(ids):
    from raycast_shade.output.labels import id_labels

    assert id_labels(ids) == _numpy_labels(ids)
    assert {g: v[:2] for g, v in id_labels(ids, rle=False).items()} == {g: v[:2] for g, v in _numpy_labels(ids).items()}


def test_id_labels_of_sparse_large_ids_and_a_rendered_frame(scene):
    from raycast_shade.output.labels import id_labels

    rng = np.random.default_rng(4)
    blocks = rng.integers(-1, 4, (6, 8))
    ids = np.repeat(np.repeat(blocks, 9, 0), 7, 1).astype(np.int64)
    sparse = np.where(ids >= 0, ids * (1 << 40) + 5, -1)  # numbered densely first
    dense = id_labels(ids)
    assert id_labels(sparse) == {g * (1 << 40) + 5: v for g, v in dense.items()} and dense == _numpy_labels(ids)
    mid = rs.render(scene, buffers=("model_id",)).buffers["model_id"]
    assert id_labels(mid) == _numpy_labels(mid)
    for o in view_objects(mid, scene.camera, rle=True):
        assert o["rle"]["counts"] == _numpy_counts(mid == o["id"]) and o["rle"]["size"] == [H, W]


def test_id_labels_with_a_bound_are_those_without_even_when_an_id_passes_it():
    from raycast_shade.output.labels import id_labels

    ids = np.random.default_rng(5).integers(-1, 6, (19, 23)).astype(np.int32)
    want = _numpy_labels(ids)
    for bound in (6, 7, 100, 3, 0):  # 3 and 0: an id at or above the bound, the ids searched after all
        assert id_labels(ids, bound=bound) == want
