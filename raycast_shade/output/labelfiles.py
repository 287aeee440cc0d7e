"""Labels on disk: semantic and instance label PNGs, their id mapping, amodal mask files, COCO polygons.

Label PNGs (one grey image per view, the ``model_id`` buffer relabelled)
    Background 0 in both. ``instance``: a model's id plus 1 (its index in the scene);
    ``semantic``: its class (:func:`~raycast_shade.output.labels.semantic_classes`, models of
    one name share one) plus 1, the COCO ``category_id``. 8-bit while the largest label is at
    most 255, else 16-bit (for the whole set: the bit depth follows the scene, not the view);
    more than 65535 labels are refused. :func:`label_map` is the id mapping, written beside
    the views as ``labels.json``.
Amodal masks
    Each model's silhouette with the other models taken away (the ``rle_unoccluded`` of a
    view's record, :func:`~raycast_shade.output.labels.silhouettes`), 0 or 255, as BOP's
    ``mask/`` files are written (the same writer).
COCO polygons
    A mask's boundary along the pixel edges (pixel ``i`` spans ``[i, i + 1)``, COCO's
    convention: the corners of the pixel squares, not their centres), simplified by
    Douglas-Peucker (OpenCV's ``approxPolyDP``) to within ``tolerance`` pixels; at tolerance 0
    ``pycocotools`` rasterises it back to the mask exactly. A polygon cannot hold a hole
    (COCO unites an annotation's polygons), so a mask with a hole keeps its RLE.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..common.validate import as_scalar

__all__ = ["LABEL_KINDS", "require_opencv", "label_bits", "label_lookup", "label_image", "label_png_bytes", "label_map",
           "mask_polygons", "coco_polygons", "write_amodal"]

LABEL_KINDS = ("semantic", "instance")
_MAX_LABEL = 65535


def label_bits(count: int, field: str = "labels") -> int:
    """8 or 16: the PNG bit depth that holds labels ``0 .. count`` (0 the background).

    Raises
    ------
    ValueError
        Naming ``field`` when ``count`` is above 65535 (no 16-bit PNG holds it).
    """
    count = int(count)
    if count > _MAX_LABEL:
        raise ValueError(f"{field}: {count} labels; a 16-bit label PNG holds at most {_MAX_LABEL} (0 the background)")
    return 8 if count <= 255 else 16


def label_lookup(scene, kind: str) -> np.ndarray:
    """(G,) int64: each model's label of ``kind`` (``"semantic"``: class + 1; ``"instance"``: id + 1)."""
    from .labels import semantic_classes

    if kind not in LABEL_KINDS:
        raise ValueError(f"kind: expected one of {LABEL_KINDS}, got {kind!r}")
    if kind == "instance":
        return np.arange(1, len(scene.models) + 1, dtype=np.int64)
    return semantic_classes(scene)[1].astype(np.int64) + 1


def label_image(model_id, lookup, bits: int) -> np.ndarray:
    """(H, W) uint8 or uint16: ``lookup[model_id]``, 0 where ``model_id`` is negative (background)."""
    ids = np.asarray(model_id)
    lookup = np.asarray(lookup)
    table = np.zeros(len(lookup) + 1, np.uint8 if bits == 8 else np.uint16)
    table[1:] = lookup  # index 0: the background, id -1 moved up by one
    return table[np.clip(ids.astype(np.int64) + 1, 0, len(lookup))]


def label_png_bytes(model_id, lookup, bits: int, *, fast: bool = True) -> bytes:
    """The label PNG of one view (:func:`label_image`) as a file's bytes."""
    from .imagefile import png_bytes

    return png_bytes(label_image(model_id, lookup, bits), fast=fast)


def label_map(scene, kinds=LABEL_KINDS) -> dict:
    """``labels.json``'s dictionary: per kind in ``kinds`` its bit depth and what each label means.

    ``semantic``: ``{"bits", "labels": [{"label", "name"}]}``; ``instance``: ``{"bits", "labels":
    [{"label", "model_id", "name", "semantic_label"}]}``; ``background`` is 0.
    """
    from .labels import semantic_classes

    names, sem = semantic_classes(scene)
    out = {"background": 0}
    if "semantic" in kinds:
        out["semantic"] = {"bits": label_bits(len(names), "semantic"),
                           "labels": [{"label": i + 1, "name": n} for i, n in enumerate(names)]}
    if "instance" in kinds:
        out["instance"] = {"bits": label_bits(len(scene.models), "instance"),
                           "labels": [{"label": g + 1, "model_id": g, "name": m.name, "semantic_label": int(sem[g]) + 1}
                                      for g, m in enumerate(scene.models)]}
    return out


# -- COCO polygons ---------------------------------------------------------------------------------


def require_opencv():
    try:
        import cv2
    except ImportError:
        raise ImportError("COCO polygons trace the masks with OpenCV: pip install opencv-python-headless "
                          "(raycast_shade[vision])") from None
    return cv2


def mask_polygons(mask, tolerance: float = 0.5):
    """COCO polygons ``[[x0, y0, x1, y1, ...], ...]`` of a mask's outer boundaries along the pixel
    edges, simplified to within ``tolerance`` pixels; None when the mask has a hole (no polygon
    says it).

    Parameters
    ----------
    mask : (H, W) bool
    tolerance : float
        Douglas-Peucker tolerance in pixels (``>= 0``; 0: every corner of the boundary kept).

    Returns
    -------
    list of list of float, or None
    """
    cv2 = require_opencv()
    tolerance = float(as_scalar(tolerance, "tolerance", minimum=0.0))
    m = np.asarray(mask, bool)
    if not m.any():
        return []
    # On the mask doubled each way, a boundary pixel's centre lies in one half of an original pixel:
    # ceil(x / 2) is the pixel edge on that side, so the traced contour becomes the crack boundary.
    up = np.repeat(np.repeat(m.astype(np.uint8), 2, axis=0), 2, axis=1)
    contours, hierarchy = cv2.findContours(up, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    if (hierarchy[0, :, 3] >= 0).any():  # a contour inside another: a hole
        return None
    out = []
    for c in contours:
        p = (c.reshape(-1, 2) + 1) // 2
        p = p[np.r_[True, (np.diff(p, axis=0) != 0).any(axis=1)]]
        if len(p) > 1 and (p[0] == p[-1]).all():
            p = p[:-1]
        q = p.astype(np.float32).reshape(-1, 1, 2)
        if tolerance > 0:
            simple = cv2.approxPolyDP(q, tolerance, True)
            q = simple if len(simple) >= 3 else q  # a sliver simplified to a line keeps its corners
        out.append([float(v) for v in q.reshape(-1)])
    return out


def coco_polygons(data: dict, tolerance: float = 0.5) -> dict:
    """``data`` (:func:`~raycast_shade.output.labels.coco_instances`) with each RLE segmentation
    replaced by :func:`mask_polygons` (in place; returned). A mask with a hole keeps its RLE
    (COCO readers take either per annotation), with one warning counting them.

    Warns
    -----
    UserWarning
        When masks with holes kept their RLE.
    """
    from .labels import rle_decode

    tolerance = float(as_scalar(tolerance, "tolerance", minimum=0.0))
    require_opencv()
    kept = 0
    for ann in data["annotations"]:
        polys = mask_polygons(rle_decode(ann["segmentation"]), tolerance)
        if polys is None:
            kept += 1
        else:
            ann["segmentation"] = polys
    if kept:
        warnings.warn(f"coco polygons: {kept} of {len(data['annotations'])} masks have holes, which a COCO polygon "
                      "cannot say; they keep their RLE segmentation", UserWarning, stacklevel=2)
    return data


# -- amodal masks ----------------------------------------------------------------------------------


def write_amodal(folder, stems, views) -> list:
    """Write each view's amodal masks as ``{stem}_{model_id:06d}.png`` (0 or 255) under ``folder``.

    Parameters
    ----------
    folder : str
        Created; files of an earlier, larger set left there are removed.
    stems : sequence of str
        Each view's file stem (``view_00000``).
    views : sequence of list of dict
        Each view's objects (:func:`~raycast_shade.output.labels.view_objects`, each with
        ``rle_unoccluded``): one file per object listed, its silhouette reaching the enlarged frame.

    Returns
    -------
    list of dict
        Per file: ``view`` (position), ``model_id`` and ``file`` (name in ``folder``).

    Raises
    ------
    ValueError
        Naming the view, when an object has no silhouette (rendered without ``unoccluded``).
    """
    from .bop import _write_mask
    from .labels import rle_decode

    for k, objects in enumerate(views):
        if any("rle_unoccluded" not in o for o in objects):
            raise ValueError(f"views[{k}]: an object without its silhouette (rle_unoccluded): render the views "
                             "with unoccluded=True")
    os.makedirs(folder, exist_ok=True)
    listing = []
    for k, (stem, objects) in enumerate(zip(stems, views)):
        for o in objects:
            name = f"{stem}_{int(o['id']):06d}.png"
            _write_mask(os.path.join(folder, name), rle_decode(o["rle_unoccluded"]))
            listing.append({"view": k, "model_id": int(o["id"]), "file": name})
    keep = {e["file"] for e in listing}
    for name in os.listdir(folder):
        if name not in keep and name.endswith(".png") and os.path.isfile(os.path.join(folder, name)):
            os.unlink(os.path.join(folder, name))
    return listing
