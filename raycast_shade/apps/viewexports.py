"""The set-level files of a view set (:func:`raycast_shade.apps.views.render_views`' ``exports``): checked
before any view is rendered, written after the views; :class:`ExportOptions` says how.

``nerfstudio`` links each view's depth and mask PNGs when the set writes them: z-depth
(``depth_png``) for pinhole and OpenCV lenses, the distance along the ray (``distance_png``,
added to the formats when ``depth_png`` is asked for) for fisheye ones, as nerfstudio reads
each. ``colmap`` samples the visible surface into ``points3D.txt`` with tracks
(:mod:`raycast_shade.output.surfacepoints`); with ``colmap_layout="sparse"`` it writes
``colmap/sparse/0/*.txt`` and ``colmap/images/`` (links to the views' images), the folder
Gaussian-splatting trainers take. ``amodal`` writes each model's silhouette per view into
``amodal/`` (turning ``unoccluded`` on). ``labels.json`` (the label PNGs' id mapping and the
amodal files) is written with the label PNG formats or ``amodal``.

Everything a format refuses is known from the cameras and the file names alone
(:func:`~raycast_shade.output.export.check_colmap`,
:func:`~raycast_shade.output.export.check_transforms`), and so is a folder or a
file in the way of the set's files: :func:`check_set_targets` refuses them
before the first view, not after the last.
"""

from __future__ import annotations

import dataclasses
import json
import os
import warnings

from ..common.stack import user_stacklevel
from ..common.validate import as_bool, as_choice, as_int, as_names, as_scalar
from ..output.bop import BOP_SPLIT, check_bop, write_bop
from ..output.export import COLMAP_FILES, check_colmap, check_transforms, place_file, write_colmap, write_transforms
from ..output.imagefile import atomic_target, check_output_folder
from ..output.labelfiles import coco_polygons, label_bits, label_map, write_amodal
from ..output.labels import coco_instances, write_coco
from .viewmotion import FLOW_INDEX, write_flow

__all__ = ["EXPORTS", "EXPORT_FILES", "LABELS_NAME", "ExportOptions", "check_set_options", "check_set_targets",
           "set_level_files", "warn_stale_folders", "write_exports", "add_export_arguments", "export_options_of"]

EXPORTS = ("coco", "nerfstudio", "colmap", "bop", "amodal", "flow")
LABELS_NAME = "labels.json"
COLMAP_SPARSE = os.path.join("sparse", "0")
EXPORT_FILES = {"coco": ("coco_instances.json",), "nerfstudio": ("transforms.json",),
                "colmap": tuple(os.path.join("colmap", d, n) for d in ("", COLMAP_SPARSE) for n in COLMAP_FILES),
                "bop": (os.path.join("bop", "models", "models_info.json"),
                        *(os.path.join("bop", BOP_SPLIT, n + ".json") for n in ("scene_camera", "scene_gt", "scene_gt_info"))),
                "amodal": (), "flow": (FLOW_INDEX,)}
BOP_UNITS_MM = 1000.0  # millimetres per world unit of a view set's BOP export: the scene in metres
_FOLDERS = ("colmap", "bop", "amodal", "flow")
MAX_POLYGON_TOLERANCE = 100.0  # pixels: beyond, a mask's polygon is a triangle or its unsimplified outline  # exports that write a folder of their own


@dataclasses.dataclass(frozen=True)
class ExportOptions:
    """How the set-level exports are written (:func:`~raycast_shade.apps.views.render_views`' ``export_options``).

    Parameters
    ----------
    coco_segmentation : {"rle", "polygon"}
        COCO masks as compressed RLE (exact) or polygons along the pixel edges
        (:func:`~raycast_shade.output.labelfiles.mask_polygons`; needs OpenCV; a mask with a hole
        keeps its RLE, with a warning).
    polygon_tolerance : float
        Douglas-Peucker tolerance of the polygons, in pixels (0 to 100; 0: exact; past a few pixels
        every mask collapses to a few corners).
    colmap_layout : {"flat", "sparse"}
        ``colmap/{cameras,images,points3D}.txt`` (as before), or ``colmap/sparse/0/*.txt`` beside
        ``colmap/images/`` (links to the views' images): the folder 3D Gaussian splatting reads.
    colmap_points : int
        Surface points sampled per view into ``points3D.txt`` (``>= 0``; 0: none, an empty file).

    Raises
    ------
    TypeError, ValueError, ImportError
        Naming the field, when the instance is made (ImportError: polygons without OpenCV).
    """

    coco_segmentation: str = "rle"
    polygon_tolerance: float = 0.5
    colmap_layout: str = "flat"
    colmap_points: int = 1000

    def __post_init__(self):
        seg = as_choice(self.coco_segmentation, "coco_segmentation", ("rle", "polygon"))
        if seg == "polygon":
            from ..output.labelfiles import require_opencv

            require_opencv()
        values = {"coco_segmentation": seg,
                  "polygon_tolerance": float(as_scalar(self.polygon_tolerance, "polygon_tolerance", minimum=0.0,
                                                       maximum=MAX_POLYGON_TOLERANCE)),
                  "colmap_layout": as_choice(self.colmap_layout, "colmap_layout", ("flat", "sparse")),
                  "colmap_points": int(as_int(self.colmap_points, "colmap_points", minimum=0))}
        for name, value in values.items():
            object.__setattr__(self, name, value)


def set_level_files() -> list:
    """Every set-level file name the exports may write (relative to the set's folder)."""
    return [LABELS_NAME] + [n for names in EXPORT_FILES.values() for n in names]


def _fisheye(cameras) -> bool:
    return any(getattr(c, "distorted", False) and c.distortion_model == "fisheye" for c in cameras)


def check_set_options(exports, files, unoccluded, overwrite, scene, cameras, options) -> tuple:
    """``(exports, compression, formats, unoccluded, options)`` checked: compression ``"auto"`` resolved;
    ``bop`` adds ``depth_png`` and turns ``unoccluded`` on, ``amodal`` turns it on, ``nerfstudio`` with a
    depth PNG adds the kind it reads (``distance_png`` for fisheye lenses, else ``depth_png``).

    Raises
    ------
    TypeError, ValueError
        Naming the argument or field (``exports``, ``export_options``, ``formats``), before any view.
    """
    exports = as_names(exports, "exports", EXPORTS)
    options = ExportOptions() if options is None else options
    if not isinstance(options, ExportOptions):
        raise TypeError(f"export_options: expected an ExportOptions, got {type(options).__name__}")
    compression = files.compression
    if compression == "auto":
        from ..output.npzwrite import deflate_backend

        compression = "zip" if deflate_backend(1) == "isal" else "none"
    for e in ("nerfstudio", "colmap", "bop"):
        if e in exports and files.image is None:
            raise ValueError(f"exports: {e!r} names each view's image file, but image=None writes none")
    if "bop" in exports and files.image != ".png":
        raise ValueError(f"exports: 'bop' takes each view's image as its rgb/ PNG, but image={files.image!r}")
    for name, value in (("unoccluded", unoccluded), ("overwrite", overwrite)):
        as_bool(value, name)
    formats = tuple(files.formats)
    if "bop" in exports:  # BOP's depth/ and mask/ files and visib_fract: the depth PNG and the silhouettes
        formats = formats if "depth_png" in formats else formats + ("depth_png",)
    if "nerfstudio" in exports and {"depth_png", "distance_png"} & set(formats):
        kind = "distance_png" if _fisheye(cameras) else "depth_png"  # what nerfstudio's depth loss reads
        formats = formats if kind in formats else formats + (kind,)
    unoccluded = bool(unoccluded) or "bop" in exports or "amodal" in exports
    if "flow" in exports and (not isinstance(cameras, (list, tuple)) or len(cameras) < 2):
        raise ValueError("exports: 'flow' is the flow between consecutive views: it needs at least two cameras")
    if "semantic_png" in formats:
        from ..output.labels import semantic_classes

        label_bits(len(semantic_classes(scene)[0]), "formats: 'semantic_png'")
    if "instance_png" in formats:
        label_bits(len(scene.models), "formats: 'instance_png'")
    return exports, compression, formats, unoccluded, options


def warn_stale_folders(out_dir: str, exports) -> None:
    """Warn about export folders (``colmap/``, ``bop/``, ``amodal/``, ``flow/``) in ``out_dir`` that this set
    does not write: an earlier run's files, which the index no longer lists (``overwrite`` replaces the
    set's own files, never a folder's contents)."""
    stale = [k for k in _FOLDERS if k not in exports and os.path.isdir(os.path.join(out_dir, k))
             and os.listdir(os.path.join(out_dir, k))]
    if stale:
        warnings.warn(f"out_dir: {', '.join(k + '/' for k in stale)} in {out_dir} hold an earlier run's "
                      f"{', '.join(stale)} export, which this set does not write (its index does not list "
                      "them); delete the folder(s) if they are not wanted", UserWarning,
                      stacklevel=user_stacklevel())


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
    for kind in _FOLDERS:
        if kind in exports:
            folder = os.path.join(out_dir, kind)
            if os.path.lexists(folder) and not os.path.isdir(folder):
                raise ValueError(f"exports: {kind!r} writes the folder {folder!r}, but a file is there")
            check_output_folder(folder, "exports")
    if not os.path.isdir(out_dir):
        return  # made later, empty
    targets = set(set_names) | {n for e in exports for n in EXPORT_FILES[e]} | {LABELS_NAME}
    targets |= {n for names in view_names.values() for n in names.values()}
    in_the_way = sorted(n for n in targets if os.path.isdir(os.path.join(out_dir, n)))
    if in_the_way:
        raise ValueError(f"out_dir: {os.path.join(out_dir, in_the_way[0])!r} is a folder where the view set "
                         f"writes a file ({len(in_the_way)} such)")


def _records(out_dir, views) -> list:
    out = []
    for v in views:
        with open(os.path.join(out_dir, v["files"]["record"])) as fh:
            out.append(json.load(fh)["objects"])
    return out


def _write_json(path, data) -> None:
    with atomic_target(path) as tmp, open(tmp, "w") as fh:
        json.dump(data, fh, indent=1)


def _rgb8(path):
    """(H, W, 3) uint8 of a view's image file (float images tone-mapped as the PNGs are by default)."""
    import imageio.v3 as iio
    import numpy as np

    from ..output.quantize import to_uint8_table
    from ..output.tonemap import read_pfm

    ext = os.path.splitext(path)[1].lower()
    img = np.load(path) if ext == ".npy" else read_pfm(path) if ext == ".pfm" else iio.imread(path)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    img = img[..., :3]
    if img.dtype == np.uint16:
        return (img >> 8).astype(np.uint8)
    return img if img.dtype == np.uint8 else to_uint8_table(np.ascontiguousarray(img, np.float32))


def _write_colmap(out_dir, scene, cameras, images, options: ExportOptions) -> None:
    from ..output.surfacepoints import surface_points

    points = None
    if options.colmap_points:
        points = surface_points(scene, cameras, [_rgb8(os.path.join(out_dir, n)) for n in images], options.colmap_points)
    root = os.path.join(out_dir, "colmap")
    if options.colmap_layout == "flat":
        write_colmap(root, cameras, images, points)
        return
    write_colmap(os.path.join(root, COLMAP_SPARSE), cameras, images, points)
    os.makedirs(os.path.join(root, "images"), exist_ok=True)
    for n in images:
        place_file(os.path.join(out_dir, n), os.path.join(root, "images", n))


def write_exports(scene, cameras, index: dict, out_dir: str, exports, options: ExportOptions | None = None, *,
                  scenes=None) -> None:
    """Write the set-level files ``exports`` (and ``labels.json``) from the views' records and the index;
    ``scenes``: each view's scene when models move (default: ``scene`` in every view). ``flow`` adds the
    index's ``flow`` entry."""
    options = ExportOptions() if options is None else options
    views = index["views"]
    images = [v["files"].get("image") for v in views]
    records = _records(out_dir, views) if {"coco", "bop", "amodal"} & set(exports) else None
    if "coco" in exports:
        coco_views = [{"file_name": v["files"].get("image") or next(iter(v["files"].values())), "width": v["width"],
                       "height": v["height"], "objects": objects} for v, objects in zip(views, records)]
        path = os.path.join(out_dir, EXPORT_FILES["coco"][0])
        if options.coco_segmentation == "rle":
            write_coco(path, scene, coco_views)
        else:
            _write_json(path, coco_polygons(coco_instances(scene, coco_views), options.polygon_tolerance))
    if "nerfstudio" in exports:
        links = {"depth_scale": index["depth_scale"]}
        depth = "distance_png" if _fisheye(cameras) else "depth_png"
        for key, kind in (("depth_paths", depth), ("mask_paths", "mask_png")):
            if kind in index["formats"]:
                links[key] = [v["files"][kind] for v in views]
        write_transforms(os.path.join(out_dir, EXPORT_FILES["nerfstudio"][0]), cameras, images, **links)
    if "colmap" in exports:
        _write_colmap(out_dir, scene, cameras, images, options)
    if "bop" in exports:
        bop_views = [{"rgb": os.path.join(out_dir, v["files"]["image"]),
                      "depth": os.path.join(out_dir, v["files"]["depth_png"]),
                      "depth_units": index["depth_scale"], "objects": objects} for v, objects in zip(views, records)]
        write_bop(os.path.join(out_dir, "bop"), scene, cameras, bop_views, mm_per_unit=BOP_UNITS_MM,
                  poses=None if scenes is None else [[m.model_to_world for m in s.models] for s in scenes])
    if "flow" in exports:
        index["flow"] = write_flow(out_dir, [scene] * len(cameras) if scenes is None else scenes, cameras)
    kinds = [k for k in ("semantic", "instance") if k + "_png" in index["formats"]]
    if kinds or "amodal" in exports:
        labels = label_map(scene, kinds)
        for k in kinds:
            labels[k]["files"] = [v["files"][k + "_png"] for v in views]
        if "amodal" in exports:
            stems = [os.path.splitext(v["files"]["record"])[0] for v in views]
            labels["amodal"] = {"folder": "amodal", "pixels": "255 inside the model's silhouette, 0 elsewhere",
                                "files": write_amodal(os.path.join(out_dir, "amodal"), stems, records)}
        _write_json(os.path.join(out_dir, LABELS_NAME), labels)


def add_export_arguments(p) -> None:
    """The ``views`` command's options of :class:`ExportOptions`."""
    p.add_argument("--coco-polygons", type=float, default=None, metavar="TOL",
                   help="COCO masks as polygons along the pixel edges, simplified to TOL pixels (0: exact; needs "
                        "OpenCV; masks with holes keep their RLE); default: RLE")
    p.add_argument("--colmap-layout", default="flat", choices=("flat", "sparse"),
                   help="colmap/*.txt (flat, the default) or colmap/sparse/0/*.txt with colmap/images/ (sparse: the "
                        "folder Gaussian-splatting trainers read)")
    p.add_argument("--colmap-points", type=int, default=1000, metavar="N",
                   help="surface points sampled per view into COLMAP's points3D.txt, with their tracks "
                        "(default 1000; 0: none)")


def export_options_of(ns) -> ExportOptions:
    """The :class:`ExportOptions` of the ``views`` command's parsed arguments."""
    tol = ns.coco_polygons
    return ExportOptions(coco_segmentation="rle" if tol is None else "polygon",
                         polygon_tolerance=0.5 if tol is None else tol, colmap_layout=ns.colmap_layout,
                         colmap_points=ns.colmap_points)
