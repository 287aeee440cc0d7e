"""Objects that move through a view set (:func:`raycast_shade.render_views`' ``poses``) and the flow export.

``poses`` maps a model (its index, or its name: every model of that name) to its pose track, a
``(V, 4, 4)`` array of rigid model-to-world poses, one per view
(:mod:`raycast_shade.scene.posetrack`); each view renders its own scene, the models at the view's
poses, so each view's record, the index, COCO and BOP say that view's poses. A model keeps its
index, hence its instance id, in every view. The models not named keep their own pose.

The ``flow`` export (:func:`write_flow`) writes into ``flow/`` the forward flow of each view ``i``
to view ``i + 1`` (``forward_{i:05d}``) and the backward flow of each view ``i`` to view ``i - 1``
(``backward_{i:05d}``), each as a Middlebury ``.flo`` and a KITTI 16-bit PNG
(:mod:`raycast_shade.output.flowfiles`), from :func:`raycast_shade.optical_flow` (each pixel's
exact float64 surface point, carried by its model's pose change, projected by the other view's
camera). A pixel's flow is *defined* where it sees a surface whose point lies in front of the
other camera (the ``.flo`` holds ``1e10`` elsewhere), and *valid* (the PNG's ``B``) where, also,
the point lands inside the other image and no surface of the other view's scene lies between
its camera and the point: visible in both views.
"""

from __future__ import annotations

import dataclasses
import os
import re

import numpy as np

from ..scene.posetrack import check_pose_track
from .viewplan import write_json

__all__ = ["plan_motion", "check_poses", "moving_models", "posed_scenes", "fresh_scene", "model_poses", "check_static_exports",
           "write_flow", "FLOW_FOLDER", "FLOW_INDEX"]

FLOW_FOLDER = "flow"
FLOW_INDEX = os.path.join(FLOW_FOLDER, "flow.json")
_FLOW_FILE = re.compile(r"^(forward|backward)_\d{5}\.(flo|png)$")
STATIC_EXPORTS = ("nerfstudio", "colmap")  # multi-view reconstruction of one static scene


def check_poses(poses, scene, n_views: int) -> dict:
    """``{model index: (n_views, 4, 4) read-only float64}`` of ``poses`` (None: ``{}``).

    Raises
    ------
    TypeError, ValueError
        Naming ``poses`` and the key: not a mapping, a model not in the scene (by index or
        name), a model given twice, a track of another shape or count, a pose that is not rigid.
    """
    if poses is None:
        return {}
    if not isinstance(poses, dict):
        raise TypeError(f"poses: expected a dict of model (index or name) to a (V, 4, 4) pose track, "
                        f"got {type(poses).__name__}")
    names = [m.name for m in scene.models]
    out = {}
    for key, track in poses.items():
        if isinstance(key, str):
            found = [g for g, n in enumerate(names) if n == key]
            if not found:
                raise ValueError(f"poses: no model is named {key!r} (the models: {sorted(set(map(str, names)))})")
        elif isinstance(key, (int, np.integer)) and not isinstance(key, bool) and 0 <= key < len(names):
            found = [int(key)]
        else:
            raise ValueError(f"poses: key {key!r} is neither a model's index (0 to {len(names) - 1}) nor a name")
        P = check_pose_track(track, f"poses[{key!r}]", n_views)
        for g in found:
            if g in out:
                raise ValueError(f"poses: model {g} ({names[g]!r}) is given twice")
            out[g] = P
    return out


def plan_motion(poses, scene, cameras, exports) -> tuple:
    """``(scenes, poses)``: ``poses`` checked (:func:`check_poses`; one per camera) with the exports
    (:func:`check_static_exports`), and the scene of each view (:func:`posed_scenes`; ``scene``
    itself without poses)."""
    from ..scene.camera import Camera

    n_views = len(cameras) if isinstance(cameras, (list, tuple)) else 1
    if poses is not None and isinstance(cameras, (list, tuple)):  # the cameras first: they count the views
        bad = next((i for i, c in enumerate(cameras) if not isinstance(c, Camera)), None)
        if bad is not None:
            raise TypeError(f"cameras[{bad}]: expected a Camera, got {type(cameras[bad]).__name__}")
    poses = check_poses(poses, scene, n_views)
    check_static_exports(exports, poses, scene)
    return posed_scenes(scene, poses, n_views), poses


def moving_models(poses: dict) -> list:
    """The models whose pose differs between two views."""
    return sorted(g for g, P in poses.items() if len(P) and not (P == P[0]).all())


def check_static_exports(exports, poses: dict, scene) -> None:
    """Refuse the exports that assume a static scene (nerfstudio, COLMAP) when a model moves."""
    moved = moving_models(poses)
    for e in STATIC_EXPORTS:
        if e in exports and moved:
            raise ValueError(f"exports: {e!r} describes one static scene seen by many cameras, but poses move "
                             f"model {moved[0]} ({scene.models[moved[0]].name!r}) between views: a reconstruction "
                             "of it would be wrong (drop the export, or render the static scene)")


def posed_scenes(scene, poses: dict, n_views: int):
    """One scene per view with the models at that view's poses (``scene`` itself when ``poses`` is empty).

    A model at the same pose in two views is one :class:`~raycast_shade.scene.scene.Model` object
    in both, so those views share a mesh set (one geometry) in the batch plan.
    """
    if not poses:
        return scene
    made = {}
    scenes = []
    for i in range(n_views):
        models = list(scene.models)
        for g, P in poses.items():
            key = (g, P[i].tobytes())
            if key not in made:
                made[key] = dataclasses.replace(scene.models[g], pose=P[i])
            models[g] = made[key]
        scenes.append(scene.replace(models=models))
    return scenes


def fresh_scene(scene, moved) -> "object":
    """``scene`` with new objects for the models ``moved`` and no geometry: what is built from it
    (the packed geometry, the models' posed arrays) lives only as long as the copy, not in the plan."""
    models = [dataclasses.replace(m) if g in moved else m for g, m in enumerate(scene.models)]
    return scene.replace(models=models)


def model_poses(scenes) -> list:
    """Per view, each model's (4, 4) model-to-world pose as nested lists."""
    return [[m.model_to_world.tolist() for m in s.models] for s in scenes]


def _pair(scenes, cameras, a: int, b: int, hits) -> dict:
    from ..output.flow import optical_flow

    out = optical_flow(scenes[a], cameras[a], scenes[b], cameras[b], hits=hits[a])
    out["valid"] = out["mask"] & ~out["occluded"] & ~out["outside"]
    return out


def write_flow(out_dir: str, scenes, cameras) -> dict:
    """Write the forward and backward flow between consecutive views into ``out_dir/flow/`` (see the
    module docstring) and ``flow/flow.json``; returns that index (also the view set index's ``flow``).
    """
    from ..output.flowfiles import write_flo, write_flow_png
    from ..visibility.cast import cast_camera

    folder = os.path.join(out_dir, FLOW_FOLDER)
    os.makedirs(folder, exist_ok=True)
    n = len(cameras)
    hits = {}
    pairs = []
    moved = set(range(len(scenes[0].models))) if n else set()
    scenes = [fresh_scene(s, moved) for s in scenes]  # geometries built here go with the loop's window
    for i in range(n):
        for j in (i - 1, i + 1):
            if j < 0 or j >= n:
                continue
            for k in (i, j):
                if k not in hits:
                    hits[k] = cast_camera(scenes[k].geometry, cameras[k])
            out = _pair(scenes, cameras, i, j, hits)
            stem = f"{'forward' if j > i else 'backward'}_{i:05d}"
            write_flo(os.path.join(folder, stem + ".flo"), out["flow"], out["mask"])
            write_flow_png(os.path.join(folder, stem + ".png"), out["flow"], out["valid"])
            pairs.append({"from": i, "to": j, "flo": f"{FLOW_FOLDER}/{stem}.flo", "png": f"{FLOW_FOLDER}/{stem}.png",
                          "defined": int(out["mask"].sum()), "valid": int(out["valid"].sum())})
        for k in [k for k in hits if k < i]:  # view i - 1 is no longer needed: its hits and geometry go
            del hits[k]
            scenes[k] = None
    index = {"conventions": {
        "flow": "u along x (columns, right), v along y (rows, down), in pixels: the pixel's surface point in the "
                "other view (OpenCV pixel centres) minus the pixel",
        "flo": "Middlebury .flo: float32 202021.25, int32 width, height, float32 u,v interleaved, little-endian; "
               "1e10 where no flow is defined (background, or the point behind the other camera)",
        "png": "KITTI 16-bit RGB: R = u*64 + 2^15, G = v*64 + 2^15, B = 1 where valid, else 0 (R = G = 2^15)",
        "valid": "the pixel sees a surface whose point lies inside the other view's image, in front of its camera, "
                 "with no surface of the other view's scene between that camera and the point"},
        "pairs": pairs}
    written = {os.path.basename(p[k]) for p in pairs for k in ("flo", "png")}
    for name in os.listdir(folder):  # an earlier set's pairs beyond this one's views
        if _FLOW_FILE.match(name) and name not in written:
            os.unlink(os.path.join(folder, name))
    write_json(os.path.join(out_dir, FLOW_INDEX), index)
    return index
