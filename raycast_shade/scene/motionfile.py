"""Objects that move, from a scene file's ``[[motion]]`` tables (read by ``raycast-shade views``).

One table per moving model (``docs/scene-files.md``)::

    [[motion]]
    model = "knot"                  # a model's name (every model of that name), or its index
    pivot = [0.0, 0.0, 0.0]         # the point rotations turn about (default: the origin)
    orbit = { axis = [0.0, 1.0, 0.0], degrees = 360.0 }   # turned by i * degrees / N at view i ...

    [[motion]]
    model = 1
    keyframes = [                   # ... or keyed: slerp between keys, held beyond the ends
      { view = 0, rotate = [0.0, 0.0, 0.0], translate = [0.0, 0.0, 0.0] },
      { view = 12, rotate = [0.0, 90.0, 0.0], translate = [1.0, 0.0, 0.0] },
    ]

The motion is the model's :attr:`~raycast_shade.scene.scene.Model.pose` per view, applied to the
object as its ``[[object]]`` table placed it (after ``scale``, ``rotate``, ``translate``):
``T(pivot + translate) Rot(rotate) T(-pivot)``, ``rotate`` in degrees about x, then y, then z
(the objects' convention). A still render (``raycast-shade render``) shows the objects as placed.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..common.warnings import DroppedOnLoadWarning
from ..common.validate import as_int, as_scalar, as_vec3
from .posetrack import keyframes, orbit_poses
from .scenefile import SceneFileError, _rotation

__all__ = ["load_motion", "motion_from_dict", "warn_motion_ignored"]

_MOTION_KEYS = ("model", "pivot", "orbit", "keyframes")
_ORBIT_KEYS = ("axis", "degrees")
_KEY_KEYS = ("view", "rotate", "translate")


def _check_keys(table, where, allowed):
    if not isinstance(table, dict):
        raise ValueError(f"{where}: expected a table, got {type(table).__name__}")
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise ValueError(f"{where}: unknown key {unknown[0]!r} (expected {', '.join(allowed)})")


def _models(value, where, scene) -> list:
    names = [m.name for m in scene.models]
    if isinstance(value, str):
        found = [g for g, n in enumerate(names) if n == value]
        if not found:
            raise ValueError(f"{where}.model: no model is named {value!r} (the models: {sorted(set(map(str, names)))})")
        return found
    return [as_int(value, f"{where}.model", minimum=0, maximum=len(names) - 1)]


def _track(table, where, n_views) -> np.ndarray:
    pivot = as_vec3(table.get("pivot", (0.0, 0.0, 0.0)), f"{where}.pivot")
    if ("orbit" in table) == ("keyframes" in table):
        raise ValueError(f"{where}: needs exactly one of 'orbit' or 'keyframes'")
    if "orbit" in table:
        orbit = table["orbit"]
        _check_keys(orbit, f"{where}.orbit", _ORBIT_KEYS)
        axis = as_vec3(orbit.get("axis", (0.0, 1.0, 0.0)), f"{where}.orbit.axis", nonzero=True)
        degrees = as_scalar(orbit.get("degrees", 360.0), f"{where}.orbit.degrees", minimum=-1e6, maximum=1e6)
        return orbit_poses(n_views, axis, degrees, center=pivot)
    keys = table["keyframes"]
    if not isinstance(keys, list) or not keys:
        raise ValueError(f"{where}.keyframes: expected a non-empty array of tables")
    views, poses = [], []
    for k, key in enumerate(keys):
        at = f"{where}.keyframes[{k}]"
        _check_keys(key, at, _KEY_KEYS)
        if "view" not in key:
            raise ValueError(f"{at}: missing 'view' (the view index the key holds at)")
        views.append(as_int(key["view"], f"{at}.view", minimum=0))
        pose = np.eye(4)
        pose[:3, :3] = _rotation(as_vec3(key.get("rotate", (0.0, 0.0, 0.0)), f"{at}.rotate"))
        pose[:3, 3] = pivot + as_vec3(key.get("translate", (0.0, 0.0, 0.0)), f"{at}.translate") - pose[:3, :3] @ pivot
        poses.append(pose)
    if any(b <= a for a, b in zip(views, views[1:])):
        raise ValueError(f"{where}.keyframes: the views must increase, got {views}")
    return keyframes(views, poses, n_views)


def motion_from_dict(data: dict, scene, n_views: int, source: str = "<scene>") -> dict:
    """The pose tracks of a parsed scene file's ``[[motion]]`` tables.

    Parameters
    ----------
    data : dict
        The scene file's table (what :func:`tomllib.load` returns).
    scene : Scene
        The scene the file describes (its models, in file order, are what ``model`` names).
    n_views : int
        Views in the set.
    source : str
        The file's name, at the start of error messages.

    Returns
    -------
    dict of int to (n_views, 4, 4) float64
        Per moving model (index), its pose per view; empty without ``[[motion]]``.

    Raises
    ------
    SceneFileError
        Naming the file, the table and the key: an unknown key, a model not in the scene, a model
        moved by two tables, neither or both of ``orbit`` and ``keyframes``, keys not increasing.
    """
    tables = data.get("motion", [])
    out = {}
    try:
        if not isinstance(tables, list):
            raise ValueError("motion: expected an array of tables ([[motion]])")
        for i, table in enumerate(tables):
            where = f"motion[{i}]"
            _check_keys(table, where, _MOTION_KEYS)
            if "model" not in table:
                raise ValueError(f"{where}: missing 'model' (a model's name or index)")
            track = _track(table, where, n_views)
            for g in _models(table["model"], where, scene):
                if g in out:
                    raise ValueError(f"{where}.model: model {g} ({scene.models[g].name!r}) is moved by an earlier "
                                     "[[motion]] table too")
                start = scene.models[g].model_to_world  # the model's own pose, under the motion
                out[g] = track @ start
    except (TypeError, ValueError) as exc:
        raise SceneFileError(f"{source}: {exc}") from None
    return out


def load_motion(path, scene, n_views: int) -> dict:
    """The pose tracks of scene file ``path``'s ``[[motion]]`` tables (see :func:`motion_from_dict`)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib

    path = os.fspath(path)
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    return motion_from_dict(data, scene, n_views, source=path)


def warn_motion_ignored(path, what: str) -> None:
    """Warn when scene file ``path`` has ``[[motion]]`` tables that ``what`` (a single render, an orbit
    clip) does not apply: they move objects between the views of a set (``raycast-shade views``)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib

    try:
        with open(os.fspath(path), "rb") as fh:
            tables = tomllib.load(fh).get("motion")
    except (OSError, ValueError):  # the scene loader has already read it and said what is wrong
        return
    if tables:
        n = len(tables) if isinstance(tables, list) else 1
        warnings.warn(f"{os.fspath(path)}: {n} [[motion]] table(s) not applied by {what}: they move objects "
                      "between the views of a view set (raycast-shade views); the objects are drawn as placed",
                      DroppedOnLoadWarning, stacklevel=3)
