"""Labels on disk: label PNGs against the ``model_id`` buffer and ``labels.json``, amodal masks against
the visible ones and a cast of each model alone, COCO polygons rasterised back by pycocotools
(``frPyObjects``) against the RLE, and the COCO file read by pycocotools' own COCO API.
"""

from __future__ import annotations

import json
import os
import warnings

import imageio.v3 as iio
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pycocotools import mask as cocomask
from pycocotools.coco import COCO

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.viewexports import ExportOptions
from raycast_shade.apps.views import render_views
from raycast_shade.output.bufferfile import load_npz
from raycast_shade.output.labelfiles import coco_polygons, label_bits, label_image, label_png_bytes, mask_polygons
from raycast_shade.output.labels import rle_decode, rle_encode

W, H = 64, 48


def _pose(t):
    P = np.eye(4)
    P[:3, 3] = t
    return P


@pytest.fixture(scope="module")
def label_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("labels")
    models = [rs.Model(rs.shapes.icosphere(2), name="ball"),
              rs.Model(rs.shapes.cube(size=0.8), name="cube", pose=_pose((0.9, 0.0, 0.6))),
              rs.Model(rs.shapes.icosphere(1), name="ball", pose=_pose((-1.0, 0.4, 0.8)))]
    scene = rs.Scene(models, lights=[rs.PointLight((2, 3, 4), intensity=20)],
                     camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H))
    cams = orbit_cameras(scene.camera, 3)
    files = rs.ViewFiles(buffers=["model_id"], formats=("npz", "semantic_png", "instance_png"))
    render_views(scene, cams, out, files=files, exports=["coco", "amodal"],
                 export_options=ExportOptions(coco_segmentation="polygon", polygon_tolerance=0.0))
    return scene, cams, out


def test_label_pngs_are_the_model_id_buffer_relabelled(label_set):
    scene, cams, out = label_set
    labels = json.load(open(out / "labels.json"))
    assert labels["background"] == 0
    assert labels["semantic"]["labels"] == [{"label": 1, "name": "ball"}, {"label": 2, "name": "cube"}]
    assert [e["semantic_label"] for e in labels["instance"]["labels"]] == [1, 2, 1]
    assert labels["semantic"]["bits"] == labels["instance"]["bits"] == 8
    sem_of = {e["model_id"]: e["semantic_label"] for e in labels["instance"]["labels"]}
    for i in range(3):
        ids = load_npz(out / f"view_{i:05d}.npz")["model_id"]
        inst = iio.imread(out / labels["instance"]["files"][i])
        sem = iio.imread(out / labels["semantic"]["files"][i])
        assert inst.dtype == sem.dtype == np.uint8 and inst.shape == (H, W)
        assert (inst == ids + 1).all()  # -1, the background, is 0
        expect = np.where(ids >= 0, np.vectorize(lambda g: sem_of.get(int(g), 0))(ids), 0)
        assert (sem == expect).all()
    assert len(np.unique(iio.imread(out / labels["instance"]["files"][0]))) >= 3


def test_sixteen_bits_past_255_labels_and_too_many_refused_naming_the_field(tmp_path):
    ids = np.arange(-1, 299).reshape(12, 25)
    lookup = np.arange(1, 300)
    assert label_bits(255) == 8 and label_bits(256) == 16 and label_bits(65535) == 16
    with pytest.raises(ValueError, match="formats: 'instance_png': 65536 labels"):
        label_bits(65536, "formats: 'instance_png'")
    (tmp_path / "l.png").write_bytes(label_png_bytes(ids, lookup, label_bits(299)))
    back = iio.imread(tmp_path / "l.png")
    assert back.dtype == np.uint16 and (back == ids + 1).all()
    img = label_image(ids, lookup * 3, 16)  # any lookup: the semantic ids
    assert img[0, 0] == 0 and img[0, 1] == 3 and img.max() == 897


def test_amodal_masks_hold_the_visible_pixels_and_are_the_model_cast_alone(label_set):
    from raycast_shade.visibility.cast import cast_camera

    scene, cams, out = label_set
    listing = json.load(open(out / "labels.json"))["amodal"]["files"]
    assert sorted(os.listdir(out / "amodal")) == sorted(e["file"] for e in listing)
    larger = 0
    for e in listing:
        mask = iio.imread(out / "amodal" / e["file"])
        assert set(np.unique(mask)) <= {0, 255}
        ids = load_npz(out / f"view_{e['view']:05d}.npz")["model_id"]
        visible = ids == e["model_id"]
        amodal = mask == 255
        assert not (visible & ~amodal).any()  # what is seen lies in the silhouette
        larger += int((amodal & ~visible).sum() > 0)
        alone = cast_camera(rs.Scene([scene.models[e["model_id"]]]), cams[e["view"]]).prim >= 0
        assert (alone == amodal).all()
    assert larger >= 1  # the scene has occlusion: some silhouette is larger than its visible part


def test_coco_polygons_rasterise_back_to_the_rle(label_set):
    scene, cams, out = label_set
    data = json.load(open(out / "coco_instances.json"))
    coco = COCO(str(out / "coco_instances.json"))  # pycocotools' reader takes the file
    assert {c["name"] for c in coco.loadCats(coco.getCatIds())} == {"ball", "cube"}
    records = [json.load(open(out / f"view_{i:05d}.json"))["objects"] for i in range(3)]
    for ann in data["annotations"]:
        assert isinstance(ann["segmentation"], list) and all(len(p) >= 6 for p in ann["segmentation"])
        rle = next(o["rle"] for o in records[ann["image_id"] - 1] if o["id"] == ann["model_id"])
        back = cocomask.decode(cocomask.merge(cocomask.frPyObjects(ann["segmentation"], H, W))).astype(bool)
        assert (back == rle_decode(rle)).all()  # tolerance 0: exact
        assert (coco.annToMask(ann).astype(bool) == back).all()


def _ellipse(h=48, w=64):
    yy, xx = np.mgrid[0:h, 0:w]
    return ((xx - 30) ** 2 / 200 + (yy - 20) ** 2 / 80) < 1


@pytest.mark.parametrize("tol, min_iou", [(0.0, 1.0), (0.5, 0.99), (1.0, 0.95), (2.0, 0.9)])
def test_polygon_tolerance_bounds_the_difference(tol, min_iou):
    m = _ellipse()
    polys = mask_polygons(m, tol)
    back = cocomask.decode(cocomask.merge(cocomask.frPyObjects(polys, *m.shape))).astype(bool)
    iou = (back & m).sum() / (back | m).sum()
    assert iou >= min_iou, iou
    corners = sum(len(p) // 2 for p in polys)
    assert corners <= len(mask_polygons(m, 0.0)[0]) // 2  # simplified, never more corners


def test_single_pixels_and_several_parts_are_polygons_too():
    m = np.zeros((10, 12), bool)
    m[2, 3] = True
    m[6:9, 7:11] = True
    polys = mask_polygons(m, 0.0)
    assert len(polys) == 2
    back = cocomask.decode(cocomask.merge(cocomask.frPyObjects(polys, 10, 12))).astype(bool)
    assert (back == m).all()
    assert mask_polygons(np.zeros((4, 4), bool)) == []


def test_a_mask_with_a_hole_keeps_its_rle_with_a_warning():
    yy, xx = np.mgrid[0:40, 0:40]
    ring = ((xx - 20) ** 2 + (yy - 20) ** 2 < 150) & ((xx - 20) ** 2 + (yy - 20) ** 2 >= 25)
    assert mask_polygons(ring) is None
    data = {"annotations": [{"segmentation": rle_encode(ring)}, {"segmentation": rle_encode(_ellipse(40, 64)[:, :40])}]}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        coco_polygons(data, 0.0)
    assert len(caught) == 1 and "1 of 2 masks have holes" in str(caught[0].message)
    assert isinstance(data["annotations"][0]["segmentation"], dict)  # the RLE, exact
    assert isinstance(data["annotations"][1]["segmentation"], list)
    with pytest.raises(ValueError, match="tolerance"):
        mask_polygons(ring, -1.0)


def _has_hole(m):
    from scipy import ndimage

    return bool((ndimage.binary_fill_holes(m) & ~m).any())


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 12), st.integers(1, 12), st.integers(0, 2**32 - 1), st.floats(0.1, 0.9))
def test_polygons_of_random_masks_are_exact_or_the_mask_has_a_hole(h, w, seed, density):
    m = np.random.default_rng(seed).random((h, w)) < density
    polys = mask_polygons(m, 0.0)
    # refused exactly for a hole: background the mask encloses (4-connected background, as OpenCV
    # traces the 8-connected foreground)
    assert (polys is None) == _has_hole(m)
    if polys is None:
        return
    if not m.any():
        assert polys == []
        return
    back = cocomask.decode(cocomask.merge(cocomask.frPyObjects(polys, h, w))).astype(bool)
    assert (back == m).all()

