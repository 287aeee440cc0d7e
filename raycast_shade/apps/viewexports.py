"""The set-level files of a view set (:func:`raycast_shade.apps.views.render_views`' ``exports``): checked
before any view is rendered, written after the views.

Everything a format refuses is known from the cameras and the file names alone
(:func:`~raycast_shade.output.export.check_colmap`,
:func:`~raycast_shade.output.export.check_transforms`), and so is a folder or a
file in the way of the set's files: :func:`check_set_targets` refuses them
before the first view, not after the last.
"""

from __future__ import annotations

import json
import os

from ..output.bop import BOP_SPLIT, check_bop, write_bop
from ..output.export import COLMAP_FILES, check_colmap, check_transforms, write_colmap, write_transforms
from ..output.imagefile import check_output_folder
from ..output.labels import write_coco

__all__ = ["EXPORTS", "EXPORT_FILES", "check_set_targets", "write_exports"]

EXPORTS = ("coco", "nerfstudio", "colmap", "bop")
EXPORT_FILES = {"coco": ("coco_instances.json",), "nerfstudio": ("transforms.json",),
                "colmap": tuple(os.path.join("colmap", n) for n in COLMAP_FILES),
                "bop": (os.path.join("bop", "models", "models_info.json"),
                        *(os.path.join("bop", BOP_SPLIT, n + ".json") for n in ("scene_camera", "scene_gt", "scene_gt_info")))}
BOP_UNITS_MM = 1000.0  # millimetres per world unit of a view set's BOP export: the scene in metres


def check_set_targets(out_dir: str, exports, cameras, view_names: dict, set_names) -> None:
    """Refuse, before anything is rendered or written, what would stop the set's files being written.

    Parameters
    ----------
    out_dir : str
        The set's folder (checked by the caller: absent, or a folder that can be written).
    exports : tuple of str
        Checked names from :data:`EXPORTS`.
    cameras : list of Camera
        One per view, in order.
    view_names : dict
        Per view index, its file names by kind (``"image"`` among them when an image is written).
    set_names : iterable of str
        The set-level file names (the index and the plan).

    Raises
    ------
    ValueError
        Naming ``exports`` (and the view) when a format cannot say the cameras or names, or
        ``out_dir`` (and the path) when a folder stands where a file goes, or a file where the
        ``colmap`` folder goes.
    """
    images = [names.get("image") for names in view_names.values()]
    for kind, check in (("nerfstudio", check_transforms), ("colmap", check_colmap)):
        if kind in exports:
            try:
                check(cameras, images)
            except ValueError as exc:  # the cameras are the views: name the export that cannot say them
                raise ValueError(f"exports: {kind!r} cannot be written: {exc}") from None
    if "bop" in exports:
        try:
            check_bop(cameras)
        except ValueError as exc:
            raise ValueError(f"exports: 'bop' cannot be written: {exc}") from None
    for kind in ("colmap", "bop"):
        if kind in exports:
            folder = os.path.join(out_dir, kind)
            if os.path.lexists(folder) and not os.path.isdir(folder):
                raise ValueError(f"exports: {kind!r} writes the folder {folder!r}, but a file is there")
            check_output_folder(folder, "exports")
    if not os.path.isdir(out_dir):
        return  # made later, empty
    targets = set(set_names) | {n for e in exports for n in EXPORT_FILES[e]}
    targets |= {n for names in view_names.values() for n in names.values()}
    in_the_way = sorted(n for n in targets if os.path.isdir(os.path.join(out_dir, n)))
    if in_the_way:
        raise ValueError(f"out_dir: {os.path.join(out_dir, in_the_way[0])!r} is a folder where the view set "
                         f"writes a file ({len(in_the_way)} such)")


def write_exports(scene, cameras, index: dict, out_dir: str, exports) -> None:
    """Write the set-level files ``exports`` from the views' records and the index (all written)."""
    views = index["views"]
    if "coco" in exports:
        coco_views = []
        for v in views:
            with open(os.path.join(out_dir, v["files"]["record"])) as fh:
                objects = json.load(fh)["objects"]
            main = v["files"].get("image") or next(iter(v["files"].values()))
            coco_views.append({"file_name": main, "width": v["width"], "height": v["height"], "objects": objects})
        write_coco(os.path.join(out_dir, EXPORT_FILES["coco"][0]), scene, coco_views)
    if "nerfstudio" in exports:
        write_transforms(os.path.join(out_dir, EXPORT_FILES["nerfstudio"][0]), cameras,
                         [v["files"]["image"] for v in views])
    if "colmap" in exports:
        write_colmap(os.path.join(out_dir, "colmap"), cameras, [v["files"]["image"] for v in views])
    if "bop" in exports:
        bop_views = []
        for v in views:
            with open(os.path.join(out_dir, v["files"]["record"])) as fh:
                objects = json.load(fh)["objects"]
            bop_views.append({"rgb": os.path.join(out_dir, v["files"]["image"]),
                              "depth": os.path.join(out_dir, v["files"]["depth_png"]),
                              "depth_units": index["depth_scale"], "objects": objects})
        write_bop(os.path.join(out_dir, "bop"), scene, cameras, bop_views, mm_per_unit=BOP_UNITS_MM)
