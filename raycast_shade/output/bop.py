"""BOP data sets (the Benchmark for 6D Object Pose Estimation, ``bop_toolkit``'s scene-wise format).

:func:`write_bop` writes, under its folder::

    models/models_info.json        per obj_id: diameter, min_x/y/z, size_x/y/z (mm)
    models/obj_000001.ply          each distinct mesh in its own frame, in mm (ASCII PLY, normals)
    train/000000/scene_camera.json per im_id: cam_K, depth_scale, cam_R_w2c, cam_t_w2c (mm)
    train/000000/scene_gt.json     per im_id, one entry per model (gt_id = model id): cam_R_m2c, cam_t_m2c (mm), obj_id
    train/000000/scene_gt_info.json  bbox_obj, bbox_visib, px_count_all/valid/visib, visib_fract
    train/000000/rgb/000000.png    the view's image; depth/000000.png its uint16 depth
    train/000000/mask/000000_000000.png, mask_visib/...   {im_id:06d}_{gt_id:06d}.png, 0 or 255

Conventions (the toolkit's format document, ``bop_datasets_format``, and its ``calc_gt_info`` script):

* ``obj_id``: one per distinct mesh (the same vertices and faces in model coordinates), from 1
  in order of first appearance; two models of one mesh are two instances of one object.
* Units: millimetres, ``mm_per_unit`` per world unit (1000: a world in metres). Depth in mm is
  the PNG's value times ``depth_scale``.
* Poses: ``x_cam = cam_R_m2c x_model + cam_t_m2c`` (OpenCV camera axes; ``cam_K`` OpenCV's, pixel
  centres at integer coordinates), the camera's ``[R t]`` times the model's
  :attr:`~raycast_shade.scene.scene.Model.pose`.
* ``px_count_all`` and ``bbox_obj``: the model alone in the frame enlarged to ``3W x 3H``
  (:func:`~raycast_shade.output.labels.silhouettes`), the part beyond the border counted;
  ``mask/``: the model alone in the image. ``mask_visib/`` and ``px_count_visib``: its pixels of
  the ``model_id`` buffer (exact, where the toolkit estimates them from depth with a tolerance
  ``delta``); ``px_count_valid``: ``mask/`` pixels with a depth above 0 in the written PNG.
* Boxes ``[x, y, w, h]`` with ``w = xmax - xmin`` (``misc.calc_2d_bbox``: one less than the
  pixel count across), ``bbox_obj`` not clipped; both ``[-1, -1, -1, -1]`` when no pixel is
  visible (the toolkit's rule, for ``bbox_obj`` too).
* Left out: symmetries (``models_info.json`` holds no ``symmetries_discrete`` or
  ``symmetries_continuous``: the toolkit reads that as none), vertex colours and textures of the
  models, ``scene_gt_coco.json`` and the toolkit's ``camera.json`` / ``dataset_info.json``.
  The model frame is the mesh's own (BOP centres its models on their 3D box: ours are not moved).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil

import numpy as np

from ..common.validate import as_path, as_scalar, as_sequence

__all__ = ["BOP_SPLIT", "object_ids", "models_info", "write_bop_models", "bop_box", "write_bop"]

BOP_SPLIT = os.path.join("train", "000000")  # the one scene of a view set


def object_ids(scene) -> list:
    """Each model's BOP ``obj_id`` (from 1): models of the same mesh (vertices and faces, model
    coordinates) share one."""
    ids, out = {}, []
    for model in scene.models:
        mesh = model.mesh
        h = hashlib.blake2b(digest_size=16)
        for a in (mesh.vertices, mesh.faces):
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(np.ascontiguousarray(a).tobytes())
        out.append(ids.setdefault(h.hexdigest(), len(ids) + 1))
    return out


def _diameter(points) -> float:
    """The largest distance between two of ``points`` (N, 3): over the convex hull's vertices (all
    points where the hull is flat), in blocks."""
    from scipy.spatial import ConvexHull, QhullError

    p = np.unique(np.asarray(points, np.float64), axis=0)
    if len(p) > 4:
        try:
            p = p[ConvexHull(p).vertices]
        except QhullError:  # flat or degenerate: every point stays a candidate
            pass
    best = 0.0
    for i in range(0, len(p), 1024):
        d = np.linalg.norm(p[i:i + 1024, None, :] - p[None, :, :], axis=-1)
        best = max(best, float(d.max()))
    return best


def models_info(scene, mm_per_unit: float = 1000.0) -> dict:
    """``models_info.json``'s dictionary: per ``obj_id`` (a str) its ``diameter``, ``min_x``,
    ``min_y``, ``min_z``, ``size_x``, ``size_y``, ``size_z`` in mm (model coordinates)."""
    out = {}
    for oid, model in zip(object_ids(scene), scene.models):
        if str(oid) in out:
            continue
        v = model.mesh.vertices * mm_per_unit
        lo, hi = v.min(axis=0), v.max(axis=0)
        out[str(oid)] = {"diameter": _diameter(v), **{f"min_{a}": float(lo[k]) for k, a in enumerate("xyz")},
                         **{f"size_{a}": float(hi[k] - lo[k]) for k, a in enumerate("xyz")}}
    return out


def _ply_text(model, mm_per_unit: float) -> str:
    prep = model.mesh.prepared  # the model's own frame: the pose is not applied
    v, n, f = prep.vertices * mm_per_unit, prep.normals, prep.faces
    head = ("ply\nformat ascii 1.0\ncomment raycast_shade BOP model, millimetres\n"
            f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    rows = "\n".join(" ".join(format(float(x), ".9g") for x in row) for row in np.c_[v, n])
    faces = "\n".join(f"3 {a} {b} {c}" for a, b, c in f.tolist())
    return head + rows + "\n" + faces + "\n"


def write_bop_models(folder, scene, mm_per_unit: float = 1000.0) -> list:
    """Write ``models/obj_{id:06d}.ply`` and ``models/models_info.json`` under ``folder``; returns
    their paths."""
    from .imagefile import atomic_target

    mm_per_unit = as_scalar(mm_per_unit, "mm_per_unit", minimum=0.0, exclusive=True)
    models_dir = os.path.join(as_path(folder, "folder"), "models")
    os.makedirs(models_dir, exist_ok=True)
    paths, done = [], set()
    for oid, model in zip(object_ids(scene), scene.models):
        if oid in done:
            continue
        done.add(oid)
        paths.append(os.path.join(models_dir, f"obj_{oid:06d}.ply"))
        with atomic_target(paths[-1]) as tmp, open(tmp, "w") as fh:
            fh.write(_ply_text(model, mm_per_unit))
    paths.append(os.path.join(models_dir, "models_info.json"))
    _write_json(paths[-1], models_info(scene, mm_per_unit))
    return paths


def bop_box(rows, cols) -> list:
    """BOP's ``[x, y, w, h]`` of pixels at ``rows``, ``cols``: ``w = xmax - xmin``, ``h = ymax - ymin``
    (the toolkit's ``calc_2d_bbox``); ``[-1, -1, -1, -1]`` for none."""
    if len(rows) == 0:
        return [-1, -1, -1, -1]
    x0, y0 = int(np.min(cols)), int(np.min(rows))
    return [x0, y0, int(np.max(cols)) - x0, int(np.max(rows)) - y0]


def _write_json(path, data) -> None:
    from .imagefile import atomic_target

    with atomic_target(path) as tmp, open(tmp, "w") as fh:
        json.dump(data, fh, indent=1)


def _write_mask(path, mask) -> None:
    from .imagefile import atomic_target, png_bytes

    with atomic_target(path) as tmp, open(tmp, "wb") as fh:
        fh.write(png_bytes(np.where(mask, np.uint8(255), np.uint8(0)), fast=True))


def _place(src, dst) -> None:
    """``dst`` a hard link to ``src`` where the file system allows, else a copy (atomically either way)."""
    from .imagefile import atomic_target

    with atomic_target(dst) as tmp:
        try:
            os.link(src, tmp)
        except OSError:  # another file system, or no links
            shutil.copyfile(src, tmp)


def _gt_info(visib, solo, box_all, pixels_all: int, depth) -> dict:
    """One ``scene_gt_info`` entry: ``visib`` and ``solo`` (H, W) bool (visible part, silhouette in
    the image), ``box_all`` the whole silhouette's ``[x0, y0, x1, y1]`` (end exclusive) or None."""
    r, c = np.nonzero(visib)
    seen = int(r.size)
    bbox_obj = [-1, -1, -1, -1]
    if seen and box_all is not None:
        bbox_obj = [box_all[0], box_all[1], box_all[2] - 1 - box_all[0], box_all[3] - 1 - box_all[1]]
    return {"bbox_obj": [int(x) for x in bbox_obj], "bbox_visib": bop_box(r, c), "px_count_all": int(pixels_all),
            "px_count_valid": int(np.count_nonzero(solo & (depth > 0))), "px_count_visib": seen,
            "visib_fract": seen / pixels_all if pixels_all else 0.0}


def write_bop(folder, scene, cameras, views, *, mm_per_unit: float = 1000.0, poses=None) -> str:
    """Write a BOP data set of one scene (see the module docstring) from rendered views.

    Parameters
    ----------
    folder : str or path-like
        The data set's folder (created).
    scene : Scene
        The models, with their poses.
    cameras : sequence of Camera
        One per view: perspective, no lens distortion.
    views : sequence of dict
        Per view: ``rgb`` (its image file, ``.png``), ``depth`` (its z-depth uint16 PNG),
        ``depth_units`` (the PNG's units per world unit) and ``objects`` (the view's
        :func:`~raycast_shade.output.labels.view_objects` with ``rle=True`` and ``alone``, each
        with ``rle_unoccluded``, its silhouette's RLE).
    mm_per_unit : float
        Millimetres per world unit (1000: the scene is in metres).
    poses : sequence of sequence of (4, 4) float, optional
        Objects that move: per view, each model's model-to-world pose in that view (default: the
        scene's :attr:`~raycast_shade.scene.scene.Model.pose` in every view).

    Returns
    -------
    str
        The scene folder (``folder/train/000000``).

    Raises
    ------
    TypeError, ValueError
        Naming the argument, before anything is written: a camera BOP cannot say
        (orthographic or distorted), a view without its files or silhouettes.
    """
    from .bufferfile import read_depth_png
    from .labels import rle_decode

    cameras, views = as_sequence(cameras, "cameras"), as_sequence(views, "views")
    check_bop(cameras)
    if len(views) != len(cameras):
        raise ValueError(f"views: {len(views)} views for {len(cameras)} cameras")
    for k, v in enumerate(views):
        if not isinstance(v, dict) or not {"rgb", "depth", "depth_units", "objects"} <= set(v):
            raise TypeError(f"views[{k}]: expected a dict with rgb, depth, depth_units and objects")
        if any("rle_unoccluded" not in o for o in v["objects"]):
            raise ValueError(f"views[{k}].objects: each object needs its silhouette (rle_unoccluded): "
                             "render the views with unoccluded=True")
    mm_per_unit = as_scalar(mm_per_unit, "mm_per_unit", minimum=0.0, exclusive=True)
    static = [m.model_to_world for m in scene.models]
    per_view = [static] * len(views) if poses is None else _view_poses(poses, len(views), len(static))
    folder = as_path(folder, "folder")
    write_bop_models(folder, scene, mm_per_unit)
    root = os.path.join(folder, BOP_SPLIT)
    for sub in ("rgb", "depth", "mask", "mask_visib"):
        os.makedirs(os.path.join(root, sub), exist_ok=True)
    oids = object_ids(scene)
    cam_json, gt_json, info_json = {}, {}, {}
    for im, (cam, view, view_poses) in enumerate(zip(cameras, views, per_view)):
        K, R, t = cam.to_opencv()
        depth_scale = mm_per_unit / float(view["depth_units"])  # the PNG's value times this: mm
        cam_json[str(im)] = {"cam_K": K.ravel().tolist(), "depth_scale": depth_scale,
                             "cam_R_w2c": R.ravel().tolist(), "cam_t_w2c": (t * mm_per_unit).tolist()}
        _place(view["rgb"], os.path.join(root, "rgb", f"{im:06d}.png"))
        _place(view["depth"], os.path.join(root, "depth", f"{im:06d}.png"))
        depth = read_depth_png(view["depth"], scale=1.0)
        by_id = {o["id"]: o for o in view["objects"]}
        empty = np.zeros((cam.height, cam.width), bool)
        gts, infos = [], []
        for g, (oid, pose) in enumerate(zip(oids, view_poses)):
            m2c = np.vstack([np.c_[R, t], [0, 0, 0, 1]]) @ pose
            gts.append({"cam_R_m2c": m2c[:3, :3].ravel().tolist(), "cam_t_m2c": (m2c[:3, 3] * mm_per_unit).tolist(),
                        "obj_id": int(oid)})
            o = by_id.get(g)
            solo = empty if o is None else rle_decode(o["rle_unoccluded"])
            visib = empty if o is None else rle_decode(o["rle"]) & solo
            infos.append(_gt_info(visib, solo, None if o is None else o["box_unoccluded"],
                                  0 if o is None else o["unoccluded_all"], depth))
            _write_mask(os.path.join(root, "mask", f"{im:06d}_{g:06d}.png"), solo)
            _write_mask(os.path.join(root, "mask_visib", f"{im:06d}_{g:06d}.png"), visib)
        gt_json[str(im)], info_json[str(im)] = gts, infos
    for name, data in (("scene_camera", cam_json), ("scene_gt", gt_json), ("scene_gt_info", info_json)):
        _write_json(os.path.join(root, name + ".json"), data)
    _remove_stale(folder, root, len(views), len(scene.models), set(oids))
    return root


def _view_poses(poses, n_views: int, n_models: int) -> np.ndarray:
    """``poses`` as (n_views, n_models, 4, 4) float64 rigid poses, or raise naming it."""
    from ..common.validate import as_array
    from ..scene.posetrack import check_pose_track

    P = as_array(poses, "poses", dtype=np.float64)
    if P.shape != (n_views, n_models, 4, 4):
        raise ValueError(f"poses: expected ({n_views}, {n_models}, 4, 4): per view each model's pose, got {P.shape}")
    check_pose_track(P.reshape(-1, 4, 4), "poses (flattened view by model)", n_views * n_models)
    return P


def _remove_stale(folder, root, n_views: int, n_models: int, oids: set) -> None:
    """Remove what an earlier, larger set left in the folders written here (more views, models or
    objects): every file there is then this set's."""
    keep = {"rgb": {f"{i:06d}.png" for i in range(n_views)}}
    keep["depth"] = keep["rgb"]
    keep["mask"] = keep["mask_visib"] = {f"{i:06d}_{g:06d}.png" for i in range(n_views) for g in range(n_models)}
    dirs = {os.path.join(root, k): v for k, v in keep.items()}
    dirs[os.path.join(folder, "models")] = {f"obj_{o:06d}.ply" for o in oids} | {"models_info.json"}
    for d, names in dirs.items():
        for name in os.listdir(d):
            if name not in names and os.path.isfile(os.path.join(d, name)):
                os.unlink(os.path.join(d, name))


def check_bop(cameras) -> None:
    """Refuse (ValueError naming the view) a camera BOP's pinhole ``cam_K`` cannot say."""
    for k, cam in enumerate(cameras):
        if cam.orthographic:
            raise ValueError(f"cameras[{k}]: orthographic; BOP's cam_K is a pinhole's")
        if cam.distorted:
            raise ValueError(f"cameras[{k}]: lens distortion; BOP's cam_K is a pinhole's, with no distortion")
