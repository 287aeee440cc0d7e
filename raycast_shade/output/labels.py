"""Object labels for detection, segmentation and pose data sets: names, boxes, poses, COCO.

A model's id is its index in the scene (the ``model_id`` buffer: the
instance mask); its semantic label is its name (:attr:`Model.name`): models
of one name share a semantic id, numbered in order of first appearance (the
``semantic_id`` buffer). Per view, :func:`view_objects` gives each visible
model's pixel count, 2D box and pose in the camera; :func:`coco_instances`
turns views into a COCO instances file with run-length-encoded masks, as
``pycocotools`` reads it.

Conventions
-----------
Boxes
    ``[x0, y0, x1, y1]`` in pixel indices, end exclusive: the model covers
    columns ``x0 .. x1 - 1`` and rows ``y0 .. y1 - 1``. COCO's
    ``bbox = [x0, y0, x1 - x0, y1 - y0]`` (pixel ``i`` spans ``[i, i + 1)``).
Poses
    ``(4, 4)`` model-to-camera, OpenCV camera axes (``x`` right, ``y`` down,
    ``z`` forward): ``[R t; 0 1]`` of the camera times the model's
    model-to-world :attr:`~raycast_shade.scene.scene.Model.pose` (the identity
    by default), so points of the mesh map as ``x_cam = P[:3, :3] x + P[:3, 3]``.
Visible fraction
    BOP's ``visib_fract``: visible pixels over the pixels of the model alone in
    a frame enlarged to ``3W x 3H`` (:func:`silhouettes`), so an object cut by
    the border counts the part beyond it; ``box_unoccluded`` is not clipped.
COCO RLE
    Column-major runs starting with a run of 0s, compressed to a string as
    COCO's ``maskApi`` does (5-bit groups, runs after the second stored as
    the difference to the run two before).
"""

from __future__ import annotations

import json
import os
from typing import NamedTuple

import numpy as np
from numba import njit

from ..common.validate import as_bool, as_instance, as_int, as_name, as_path, as_sequence

__all__ = ["semantic_classes", "object_table", "box_corners", "view_objects", "Silhouette", "silhouettes",
           "unoccluded_masks", "rle_encode", "rle_decode", "coco_instances",
           "write_coco", "id_labels"]


def _check_scene(scene):
    from ..scene.scene import Scene

    as_instance(scene, "scene", Scene)


def _check_views(views) -> list:
    """``views`` as :func:`coco_instances` takes them, checked before any is read."""
    views = as_sequence(views, "views")
    for k, view in enumerate(views):
        if not isinstance(view, dict) or not {"file_name", "width", "height", "objects"} <= set(view):
            raise TypeError(f"views[{k}]: expected a dict with file_name, width, height and objects "
                            "(objects as view_objects(..., rle=True) gives them)")
        as_name(view["file_name"], f"views[{k}].file_name")
        as_int(view["width"], f"views[{k}].width", minimum=1)
        as_int(view["height"], f"views[{k}].height", minimum=1)
        as_sequence(view["objects"], f"views[{k}].objects")
    return views


def semantic_classes(scene) -> tuple:
    """``(names, ids)``: the distinct model names in order of first appearance, and each model's index
    into them, ``(G,) int32``."""
    _check_scene(scene)
    names = []
    ids = np.empty(len(scene.models), np.int32)
    for i, model in enumerate(scene.models):
        if model.name not in names:
            names.append(model.name)
        ids[i] = names.index(model.name)
    return tuple(names), ids


def object_table(scene) -> list:
    """One entry per model: ``id``, ``name``, ``semantic_id``, ``material`` (its name and
    coefficients), ``box_3d`` (world axis-aligned ``[min, max]`` of the posed mesh), ``pose``
    ((4, 4) model-to-world, :attr:`~raycast_shade.scene.scene.Model.pose`)."""
    _, sem = semantic_classes(scene)
    out = []
    for i, model in enumerate(scene.models):
        m = model.material
        lo, hi = model.bounds
        out.append({"id": i, "name": model.name, "semantic_id": int(sem[i]),
                    "material": {"name": m.name, "ka": m.ka.tolist(), "kd": m.kd.tolist(), "ks": m.ks.tolist(),
                                 "shininess": float(m.shininess), "specular": m.specular,
                                 "reflectivity": float(m.reflectivity)},
                    "box_3d": [lo.tolist(), hi.tolist()],
                    "pose": model.model_to_world.tolist()})
    return out


def _box(rows, cols) -> list:
    return [int(cols.min()), int(rows.min()), int(cols.max()) + 1, int(rows.max()) + 1]


def box_corners(box_3d) -> np.ndarray:
    """(8, 3) float64 corners of an axis-aligned box ``[min, max]``: corner ``k`` takes x from
    ``max`` if bit 2 of ``k`` is set (else ``min``), y by bit 1, z by bit 0."""
    lo, hi = np.asarray(box_3d, np.float64)
    k = np.arange(8)
    return np.stack([np.where(k & 4, hi[0], lo[0]), np.where(k & 2, hi[1], lo[1]), np.where(k & 1, hi[2], lo[2])], -1)


def view_objects(model_id, camera, *, rle: bool = False, alone=None, boxes_3d=None, poses=None) -> list:
    """The models visible in one view.

    Parameters
    ----------
    model_id : (H, W) int
        The view's ``model_id`` buffer (-1: background).
    camera : Camera
        The view's camera.
    rle : bool
        Add each model's mask as COCO RLE (``"rle"``).
    alone : dict of int to Silhouette or (H, W) bool, optional
        Each model's silhouette with nothing in front of it (:func:`silhouettes`;
        a plain mask is taken as the whole silhouette, none of it beyond the
        border). Adds per object ``unoccluded`` (its pixel count in the image),
        ``unoccluded_all`` (in the frame enlarged as BOP's toolkit does: BOP's
        ``px_count_all``), ``box_unoccluded`` (the whole silhouette's box, not
        clipped to the image: it may start below 0 or end past the size;
        ``None`` when empty), ``visible_fraction`` (visible pixels over
        ``unoccluded_all``: BOP's ``visib_fract``, below 1 for an object cut by
        the border) and ``visible_fraction_in_image`` (visible over
        ``unoccluded``), and lists the models hidden entirely (``pixels`` 0) too.
    boxes_3d : sequence of (2, 3) float, optional
        Each model's world box ``[min, max]`` (:func:`object_table`'s
        ``box_3d``). Adds ``corners``: its 8 corners (:func:`box_corners`'
        order) in OpenCV pixel coordinates, lens included (``None`` for a
        corner behind a perspective camera), the keypoints of box-based pose
        estimators.
    poses : sequence of (4, 4) float, optional
        Each model's model-to-world transform (:func:`object_table`'s ``pose``);
        default: the identity for every model.

    Returns
    -------
    list of dict
        By id: ``id``, ``pixels`` (visible pixel count), ``box`` (see the
        module docstring; ``None`` for a hidden model), ``pose`` ((4, 4)
        model-to-camera), ``rle``, and the ``alone`` fields.
    """
    from ..scene.projection import project_points

    from ..scene.camera import Camera

    ids = np.asarray(model_id)
    if ids.ndim != 2 or ids.dtype.kind not in "iu":
        raise ValueError(f"model_id: expected an (H, W) integer array, got {ids.dtype} {ids.shape}")
    as_instance(camera, "camera", Camera)
    rle = as_bool(rle, "rle")
    K, R, t = camera.to_opencv()
    w2c = np.eye(4)
    w2c[:3, :3], w2c[:3, 3] = R, t
    out = []
    labels = id_labels(ids, rle, None if boxes_3d is None else len(boxes_3d))
    seen = set(labels)
    if alone is not None:
        alone = {int(g): _as_silhouette(m, ids.shape, f"alone[{g}]") for g, m in alone.items()}
        seen |= {g for g, m in alone.items() if m.pixels_all}
    for i in sorted(seen):
        pixels, box, counts = labels.get(i, (0, None, None))
        pose = w2c if poses is None else w2c @ np.asarray(poses[i], np.float64)
        entry = {"id": int(i), "pixels": pixels, "box": box, "pose": pose.tolist()}
        if rle:
            entry["rle"] = rle_encode(np.zeros(ids.shape, bool)) if counts is None else \
                {"size": [int(ids.shape[0]), int(ids.shape[1])], "counts": counts}
        if boxes_3d is not None:
            uv = project_points(camera, box_corners(boxes_3d[i]))[0]
            entry["corners"] = [None if not np.isfinite(c).all() else c.tolist() for c in uv]
        if alone is not None:
            entry.update(_alone_fields(ids == i, alone.get(i)))
        out.append(entry)
    return out


def _alone_fields(mask, solo) -> dict:
    """The ``alone`` fields of :func:`view_objects` for one model: ``mask`` its visible pixels, ``solo``
    its :class:`Silhouette` (None: none)."""
    if solo is None:
        return {"unoccluded": 0, "unoccluded_all": 0, "box_unoccluded": None, "visible_fraction": 0.0,
                "visible_fraction_in_image": 0.0}
    n = int(np.count_nonzero(solo.mask))
    visible = int(np.count_nonzero(mask & solo.mask))  # BOP's visible mask lies inside the silhouette
    return {"unoccluded": n, "unoccluded_all": int(solo.pixels_all), "box_unoccluded": solo.box_all,
            "visible_fraction": visible / solo.pixels_all if solo.pixels_all else 0.0,
            "visible_fraction_in_image": visible / n if n else 0.0}


class Silhouette(NamedTuple):
    """A model's silhouette in one view with the other models taken away (:func:`silhouettes`).

    Attributes
    ----------
    mask : (H, W) bool
        Its pixels in the image (the amodal mask).
    pixels_all : int
        Its pixel count in the frame enlarged as BOP's toolkit enlarges it (``calc_gt_info``:
        ``3W x 3H``, the image in its middle), the part beyond the border included.
    box_all : list of int or None
        ``[x0, y0, x1, y1]`` (image pixel indices, end exclusive) of all those pixels: not clipped
        to the image. None when ``pixels_all`` is 0.
    """

    mask: np.ndarray
    pixels_all: int
    box_all: list | None


def _as_silhouette(value, shape, name) -> Silhouette:
    if isinstance(value, Silhouette):
        if value.mask.shape != shape:
            raise ValueError(f"{name}: its mask is {value.mask.shape}, the view {shape}")
        return value
    mask = np.asarray(value, bool)
    if mask.shape != shape:
        raise ValueError(f"{name}: expected an {shape} bool mask or a Silhouette, got shape {mask.shape}")
    rows, cols = np.nonzero(mask)
    return Silhouette(mask, int(rows.size), _box(rows, cols) if rows.size else None)


def id_labels(ids, rle: bool = True, bound: int | None = None) -> dict:
    """Per id ``>= 0`` present in ``ids`` (H, W): ``(pixels, box, counts)``, the pixel count, the box
    (module docstring) and the COCO RLE ``counts`` string of ``ids == id`` (None unless ``rle``).

    One pass of one kernel over ``ids`` in column-major order (COCO's), the ids read in place: each
    id's pixels and box, and the places where the id changes along that order (its mask's edges),
    sorted by id after the pass; the runs are the gaps between an id's edges, coded as
    :func:`rle_encode` codes them. ``bound``: the ids are known to lie below it (a scene's model
    count), so the tables need no search for the largest id first (an id at or above it is found,
    and the ids are searched after all). Ids up to ``2**20`` (or the pixel count) index the tables
    directly; larger ones are numbered densely first (``np.unique``).

    Parameters
    ----------
    ids : (H, W) int
        Negative: background.
    rle : bool
        Also each id's RLE counts string.
    bound : int, optional
        An upper bound (exclusive) of the ids, when known.

    Returns
    -------
    dict of int to tuple
        ``{id: (pixels, [x0, y0, x1, y1], counts or None)}``, ids in increasing order.
    """
    ids = np.asarray(ids)
    if ids.size == 0:
        return {}
    table = None if bound is None else _id_table(ids, int(bound), rle)
    values = None
    if table is None:  # no bound, or an id at or above it
        top = int(ids.max())
        if top < 0:
            return {}
        dense = ids
        if top >= max(1 << 20, ids.size):  # sparse large ids: numbered 0..n-1 in order, the background negative
            uniq, inverse = np.unique(ids, return_inverse=True)
            below = int(np.searchsorted(uniq, 0))
            dense = (inverse.reshape(ids.shape) - below).astype(np.int64)
            values, top = uniq[below:], len(uniq) - below - 1
        table = _id_table(dense, top + 1, rle)
    count, box, edges = table
    chars, starts = _rle_chars(edges, ids.size) if rle else (None, None)
    out = {}
    for g in np.flatnonzero(count).tolist():
        counts = bytes(chars[starts[g]:starts[g + 1]]).decode("ascii") if rle else None
        key = g if values is None else int(values[g])
        out[key] = (int(count[g]), [int(v) for v in box[g]], counts)
    return out


@njit(cache=True, nogil=True)
def _id_pass(ids, n, events):
    """One column-major pass over ``ids`` (H, W): per id below ``n`` its pixel count ``(n,)``, box
    ``(n, 4)`` ``[x0, y0, x1, y1]`` and edge count ``(n,)``, and the changes of id along that order
    into ``events`` (E, 3) int64 rows ``(flat position, id before, id after)`` (the first pixel is a
    change from -1). Returns ``(count, box, edge counts, changes)``; changes is -1 at an id ``>= n``."""
    h, w = ids.shape
    count = np.zeros(n, np.int64)
    nedge = np.zeros(n, np.int64)
    box = np.empty((n, 4), np.int64)
    box[:, 0] = w
    box[:, 1] = h
    box[:, 2] = 0
    box[:, 3] = 0
    prev = np.int64(-1)
    p = 0
    changes = 0
    for c in range(w):
        for r in range(h):
            v = np.int64(ids[r, c])
            if v >= 0:
                if v >= n:
                    return count, box, nedge, -1
                count[v] += 1
                if c < box[v, 0]:
                    box[v, 0] = c
                if r < box[v, 1]:
                    box[v, 1] = r
                if c + 1 > box[v, 2]:
                    box[v, 2] = c + 1
                if r + 1 > box[v, 3]:
                    box[v, 3] = r + 1
            if v != prev:
                events[changes, 0] = p
                events[changes, 1] = prev
                events[changes, 2] = v
                changes += 1
                if prev >= 0:
                    nedge[prev] += 1
                if v >= 0:
                    nedge[v] += 1
                prev = v
            p += 1
    return count, box, nedge, changes


@njit(cache=True, nogil=True)
def _sort_edges(events, changes, nedge):
    """Each id's edge positions in order, from :func:`_id_pass`' changes: ``(flat, offsets)``, id
    ``g``'s at ``flat[offsets[g]:offsets[g + 1]]``."""
    n = nedge.shape[0]
    offsets = np.zeros(n + 1, np.int64)
    for g in range(n):
        offsets[g + 1] = offsets[g] + nedge[g]
    flat = np.empty(max(1, offsets[n]), np.int64)
    at = offsets[:n].copy()
    for e in range(changes):
        for k in (1, 2):
            g = events[e, k]
            if g >= 0:
                flat[at[g]] = events[e, 0]
                at[g] += 1
    return flat, offsets


def _id_table(ids, n: int, rle: bool):
    """``(count (n,), box (n, 4), edges)`` (edges: :func:`_sort_edges`' pair, None unless ``rle``), or
    None when an id is ``>= n``."""
    # At most one change a pixel; only the rows written are ever touched (fresh pages on demand).
    events = np.empty((ids.size, 3), np.int64)
    count, box, nedge, changes = _id_pass(ids, n, events)
    if changes < 0:
        return None
    return count, box, (_sort_edges(events, changes, nedge) if rle else None)


@njit(cache=True, nogil=True)
def _encode_runs(edges, lo, hi, size, out, at):
    """COCO's compressed counts of one mask into ``out`` from ``at``: its runs are the gaps between
    0, ``edges[lo:hi]`` and ``size`` (:func:`rle_encode`'s coding). Returns the end position."""
    m = hi - lo + 1  # runs
    back2 = np.int64(0)
    back1 = np.int64(0)
    last = np.int64(0)
    for i in range(m):
        end = edges[lo + i] if i < m - 1 else size
        run = end - last
        last = end
        x = run - back2 if i > 2 else run  # after the second run: the change from two runs back
        back2 = back1
        back1 = run
        more = True
        while more:
            c = x & 0x1F
            x >>= 5
            more = (x != -1) if (c & 0x10) else (x != 0)
            if more:
                c |= 0x20
            out[at] = c + 48
            at += 1
    return at


@njit(cache=True, nogil=True)
def _rle_all(flat, offsets, size, out, starts):
    n = offsets.shape[0] - 1
    at = 0
    for g in range(n):
        starts[g] = at
        at = _encode_runs(flat, offsets[g], offsets[g + 1], size, out, at)
    starts[n] = at
    return at


def _rle_chars(edges, size: int) -> tuple:
    """``(chars uint8, starts (n + 1,))``: every id's counts string, id ``g``'s at
    ``chars[starts[g]:starts[g + 1]]``."""
    flat, offsets = edges
    n = offsets.shape[0] - 1
    out = np.empty(8 * (int(offsets[-1]) + n), np.uint8)  # a run below 2**39 codes in at most 8 characters
    starts = np.empty(n + 1, np.int64)
    _rle_all(flat, offsets, np.int64(size), out, starts)
    return out, starts


def unoccluded_masks(scene, camera) -> dict:
    """Each model's mask in ``camera`` with the other models taken away (the amodal mask).

    One cast per model, of a scene holding that model alone (its BVH kept
    with ``scene``'s geometry for the next camera).

    Returns
    -------
    dict of int to (H, W) bool
    """
    from ..visibility.cast import cast_camera

    return {g: cast_camera(s.geometry, camera).prim >= 0 for g, s in enumerate(_alone_scenes(scene))}


def _alone_scenes(scene) -> list:
    from ..scene.scene import Scene

    return scene.geometry.memo("labels.alone", lambda geo: [Scene([m]) for m in scene.models])


def silhouettes(scene, camera) -> dict:
    """Each model's :class:`Silhouette` in ``camera``: its amodal mask, and its pixel count and box in
    the frame enlarged as BOP's toolkit enlarges it (``3W x 3H``, the image in its middle).

    One cast of the image per model (:func:`unoccluded_masks`), and of the eight image-sized tiles
    around it that the model may reach: a tile is the camera with its principal point shifted by
    the image's width or height, so its rays are those of the enlarged frame. A model whose 3D box
    projects inside the image (all eight corners in front of the camera, a lens without distortion)
    needs no tile; one cut by the border, the tiles its projected box overlaps; a distorted lens or
    a corner behind the camera, all eight.

    Returns
    -------
    dict of int to Silhouette
    """
    from ..scene.projection import project_points
    from ..visibility.cast import cast_camera

    _check_scene(scene)
    K = camera.K
    w, h = int(camera.width), int(camera.height)
    out = {}
    for g, alone in enumerate(_alone_scenes(scene)):
        mask = cast_camera(alone.geometry, camera).prim >= 0
        rows, cols = np.nonzero(mask)
        lo = [int(cols.min()), int(rows.min())] if rows.size else [None, None]
        hi = [int(cols.max()) + 1, int(rows.max()) + 1] if rows.size else [None, None]
        count = int(rows.size)
        for dx, dy in _tiles_reached(project_points(camera, box_corners(scene.models[g].bounds))[0], camera):
            tile = camera.replace(fx=float(K[0, 0]), fy=float(K[1, 1]), cx=float(K[0, 2]) - dx * w,
                                  cy=float(K[1, 2]) - dy * h)
            r, c = np.nonzero(cast_camera(alone.geometry, tile).prim >= 0)
            if not r.size:
                continue
            count += int(r.size)
            edges = ((int(c.min()) + dx * w, int(r.min()) + dy * h), (int(c.max()) + 1 + dx * w, int(r.max()) + 1 + dy * h))
            lo = [e if v is None else min(v, e) for v, e in zip(lo, edges[0])]
            hi = [e if v is None else max(v, e) for v, e in zip(hi, edges[1])]
        out[g] = Silhouette(mask, count, None if count == 0 else lo + hi)
    return out


def _tiles_reached(uv, camera) -> list:
    """The tiles ``(dx, dy)`` (``-1 .. 1`` each, not ``(0, 0)``) around the image that a model whose
    3D box corners project to ``uv`` (8, 2) may reach."""
    ring = [(dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dx, dy) != (0, 0)]
    if camera.distorted or not np.isfinite(uv).all():
        return ring
    w, h = int(camera.width), int(camera.height)
    # The box's projection holds the silhouette's; tile (dx, dy) spans pixel centres
    # dx * w .. dx * w + w - 1 (and likewise in y), each pixel reaching half a pixel either side.
    (u0, v0), (u1, v1) = uv.min(axis=0), uv.max(axis=0)
    return [(dx, dy) for dx, dy in ring
            if u1 >= dx * w - 0.5 and u0 <= dx * w + w - 0.5 and v1 >= dy * h - 0.5 and v0 <= dy * h + h - 0.5]


# -- COCO run-length encoding -----------------------------------------------------------------------


def rle_encode(mask) -> dict:
    """COCO's compressed RLE of a binary mask.

    Parameters
    ----------
    mask : (H, W) bool

    Returns
    -------
    dict
        ``{"size": [H, W], "counts": str}``, as ``pycocotools.mask.encode``
        gives it (decoded to str).
    """
    m = np.asarray(mask)
    if m.ndim != 2 or m.dtype != np.bool_:
        raise ValueError(f"mask: expected an (H, W) bool array, got {m.dtype} {m.shape}")
    _, _, edges = _id_table(m.view(np.int8) - np.int8(1), 1, True)  # True: id 0, False: -1
    chars, starts = _rle_chars(edges, m.size)
    return {"size": [int(m.shape[0]), int(m.shape[1])], "counts": bytes(chars[:starts[1]]).decode("ascii")}


def rle_decode(rle) -> np.ndarray:
    """The (H, W) bool mask of a compressed RLE (the inverse of :func:`rle_encode`)."""
    try:
        if not isinstance(rle, dict):
            raise TypeError
        h, w = (int(x) for x in rle["size"])
        s = rle["counts"]
    except (TypeError, KeyError, ValueError):
        raise ValueError("rle: expected {'size': [H, W], 'counts': str}") from None
    if isinstance(s, bytes):
        s = s.decode("ascii")
    runs = []
    p = 0
    while p < len(s):
        x, k, more = 0, 0, True
        while more:
            if p >= len(s):
                raise ValueError("rle: counts end inside a number")
            c = ord(s[p]) - 48
            x |= (c & 0x1F) << (5 * k)
            more = bool(c & 0x20)
            p += 1
            k += 1
            if not more and (c & 0x10):
                x |= -1 << (5 * k)
        if len(runs) > 2:
            x += runs[-2]
        runs.append(x)
    if any(r < 0 for r in runs) or sum(runs) != h * w:
        raise ValueError(f"rle: runs cover {sum(runs)} pixels, not {h} x {w}")
    values = np.zeros(len(runs), bool)
    values[1::2] = True
    return np.repeat(values, runs).reshape((w, h)).T.copy()


def coco_instances(scene, views) -> dict:
    """A COCO instances data set (images, categories, annotations) of rendered views.

    Parameters
    ----------
    scene : Scene
        For the categories: one per distinct model name (id ``semantic_id + 1``;
        COCO ids start at 1).
    views : sequence of dict
        Per view ``file_name``, ``width``, ``height`` and ``objects`` as
        :func:`view_objects` gives them with ``rle=True``.

    Returns
    -------
    dict
        Images ``id`` = position + 1; one annotation per visible model and
        view: ``segmentation`` (compressed RLE), ``area`` (pixels), ``bbox``
        ``[x, y, w, h]``, ``iscrowd`` 0, ``category_id``, and ``model_id``.
    """
    names, sem = semantic_classes(scene)
    views = _check_views(views)
    images, annotations = [], []
    for k, view in enumerate(views):
        images.append({"id": k + 1, "file_name": view["file_name"], "width": int(view["width"]),
                       "height": int(view["height"])})
        for obj in view["objects"]:
            if not obj["pixels"]:
                continue  # hidden entirely: nothing to segment
            x0, y0, x1, y1 = obj["box"]
            annotations.append({"id": len(annotations) + 1, "image_id": k + 1,
                                "category_id": int(sem[obj["id"]]) + 1, "model_id": obj["id"],
                                "segmentation": obj["rle"], "area": obj["pixels"],
                                "bbox": [x0, y0, x1 - x0, y1 - y0], "iscrowd": 0})
    return {"info": {"description": "raycast_shade views"}, "images": images,
            "categories": [{"id": i + 1, "name": n, "supercategory": "object"} for i, n in enumerate(names)],
            "annotations": annotations}


def write_coco(path, scene, views) -> str:
    """Write :func:`coco_instances` as JSON to ``path`` (``.json``), atomically."""
    from .imagefile import atomic_target

    path = as_path(path, "path")
    if not path.lower().endswith(".json"):
        raise ValueError(f"path: {path!r}: expected a .json file")
    data = coco_instances(scene, views)
    with atomic_target(path) as tmp, open(tmp, "w") as fh:
        json.dump(data, fh)
    return path
