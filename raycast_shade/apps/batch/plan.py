"""Planning a batch: its frames as small jobs over a few base scenes.

A batch is a list of scenes, or one scene with a list of cameras and/or a
list of light sets. :func:`plan_batch` expands it into one base scene per
mesh set, keyed by the content hash of the models (:func:`scene_key`), and
one :class:`FrameJob` per frame: what travels to a worker with every frame,
without the meshes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from dataclasses import dataclass

import numpy as np

from ...output.imagefile import check_image_path
from ...scene.camera import Camera
from ...scene.lights import DirectionalLight, PointLight
from ...scene.scene import Scene

__all__ = ["FrameJob", "scene_key", "plan_batch"]


@dataclass(frozen=True, eq=False)
class FrameJob:
    """One frame of a batch: what it changes on its mesh set's base scene.

    A job is small (a camera, a few lights, two colours and a path): it is
    what travels to a worker with every frame; the meshes do not.

    Attributes
    ----------
    index : int
        Position of the frame in the batch, from 0.
    key : str
        Content hash of the models (see :func:`scene_key`): which base scene
        the frame renders.
    camera : Camera
    lights : tuple of PointLight or DirectionalLight
    ambient, background : (3,) float64
    path : str or None
        Where the frame is written, or None to return the image.
    """

    index: int
    key: str
    camera: Camera
    lights: tuple
    ambient: np.ndarray
    background: np.ndarray
    path: str | None = None


# -- content hashing -----------------------------------------------------------------------------------


def _digest(obj, h) -> None:
    if obj is None:
        h.update(b"N;")
    elif isinstance(obj, (bool, int, float, str, np.generic)):
        h.update(f"{type(obj).__name__}:{obj!r};".encode())
    elif isinstance(obj, np.ndarray):
        h.update(f"A{obj.dtype.str}{obj.shape};".encode())
        h.update(memoryview(np.ascontiguousarray(obj)).cast("B"))
    elif isinstance(obj, (tuple, list)):
        h.update(f"T{len(obj)}(".encode())
        for item in obj:
            _digest(item, h)
        h.update(b");")
    elif isinstance(obj, dict):
        h.update(f"D{len(obj)}(".encode())
        for k in sorted(obj, key=repr):
            _digest(k, h)
            _digest(obj[k], h)
        h.update(b");")
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        h.update(f"{type(obj).__module__}.{type(obj).__qualname__}(".encode())
        for f in dataclasses.fields(obj):
            h.update(f.name.encode())
            _digest(getattr(obj, f.name), h)
        h.update(b");")
    else:
        raise TypeError(f"scene_key: cannot hash a {type(obj).__name__}")


def scene_key(scene: Scene) -> str:
    """Content hash of a scene's models (meshes and materials).

    Two scenes with equal keys have the same packed geometry and BVH; lights,
    camera, ambient and background do not enter the key.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    str
        32 hexadecimal digits (BLAKE2b).
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    h = hashlib.blake2b(digest_size=16)
    _digest(scene.models, h)
    return h.hexdigest()


# -- input checks --------------------------------------------------------------------------------------


def _sequence(value, name: str, kind, what: str):
    """``(value, False)`` for one ``kind``, ``(list, True)`` for a non-empty sequence of them."""
    if value is None or isinstance(value, kind):
        return value, False
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"{name}: expected a {what} or a sequence of {what}s, got {type(value).__name__}")
    items = list(value)
    if not items:
        raise ValueError(f"{name}: the sequence is empty")
    for i, item in enumerate(items):
        if not isinstance(item, kind):
            raise TypeError(f"{name}[{i}]: expected a {what}, got {type(item).__name__}")
    return items, True


def _light_set(value, where):
    if isinstance(value, (PointLight, DirectionalLight)):
        return (value,)
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"{where}: expected a light or a sequence of lights, got {type(value).__name__}")
    lights = tuple(value)
    for j, light in enumerate(lights):
        if not isinstance(light, (PointLight, DirectionalLight)):
            raise TypeError(f"{where}[{j}]: expected a PointLight or DirectionalLight, got {type(light).__name__}")
    return lights


def _as_light_sets(value):
    if value is None:
        return None, False
    if isinstance(value, (PointLight, DirectionalLight)):
        return (value,), False
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"lights: expected a sequence of light sets, got {type(value).__name__}")
    sets = list(value)
    if not sets:
        raise ValueError("lights: the sequence is empty")
    return [_light_set(s, f"lights[{i}]") for i, s in enumerate(sets)], True


def _check_pattern(pattern):
    if not isinstance(pattern, str):
        raise TypeError(f"pattern: expected a str, got {type(pattern).__name__}")
    try:
        a, b = pattern.format(0), pattern.format(1)
    except (IndexError, KeyError, ValueError) as exc:
        raise ValueError(f"pattern: must format one integer, like 'frame_{{:05d}}.png' ({exc})") from None
    if a == b:
        raise ValueError(f"pattern: {pattern!r} gives the same name to every frame; put a field like {{:05d}} in it")
    if os.path.basename(a) != a or a in (".", ".."):
        raise ValueError(f"pattern: must name a file inside out_dir, not a path: {pattern!r}")
    check_image_path(a, "pattern")
    return pattern


def _frame_names(out_dir, pattern, n):
    if out_dir is None:
        return None
    _check_pattern(pattern)
    names = [pattern.format(i) for i in range(n)]
    if len(set(names)) != n:
        raise ValueError(f"pattern: {pattern!r} gives two frames the same name")
    return names


# -- planning ------------------------------------------------------------------------------------------


def plan_batch(scene_or_scenes, cameras=None, lights=None, *, out_dir=None, pattern="frame_{:05d}.png",
               memory=None):
    """Expand a batch into its base scenes and frame jobs.

    Each of ``scene_or_scenes``, ``cameras`` and ``lights`` is either one
    value, used for every frame, or a sequence with one entry per frame; all
    the sequences given must have the same length, the number of frames.

    Parameters
    ----------
    scene_or_scenes : Scene or sequence of Scene
    cameras : Camera or sequence of Camera, optional
        Default: each scene's own camera.
    lights : sequence of light sets, optional
        A light set is a sequence of lights (or one light). Default: each
        scene's own lights.
    out_dir : str or path-like, optional
        Folder the frames are written to; None to return images.
    pattern : str
        File name of frame ``i``: ``pattern.format(i)``.
    memory : dict, optional
        What each frame holds besides its image, for
        :meth:`~raycast_shade.scene.camera.Camera.check_frame_memory`
        (``buffers``, ``samples``, ...): every frame is checked before any
        is rendered or written.

    Returns
    -------
    bases : dict of str to Scene
        One scene per mesh set, keyed by :func:`scene_key`.
    jobs : list of FrameJob
        In frame order.

    Raises
    ------
    TypeError, ValueError
        Naming the argument at fault.
    """
    if scene_or_scenes is None:
        raise TypeError("scenes: expected a Scene or a sequence of Scenes, got NoneType")
    scenes, many_scenes = _sequence(scene_or_scenes, "scenes", Scene, "Scene")
    cams, many_cams = _sequence(cameras, "cameras", Camera, "Camera")
    light_sets, many_lights = _as_light_sets(lights)
    lengths = {name: len(v) for name, v, many in (("scenes", scenes, many_scenes), ("cameras", cams, many_cams),
                                                   ("lights", light_sets, many_lights)) if many}
    if len(set(lengths.values())) > 1:
        detail = ", ".join(f"{len_} {name}" for name, len_ in lengths.items())
        name = list(lengths)[-1]
        raise ValueError(f"{name}: the sequences must have one entry per frame, got {detail}")
    n = next(iter(lengths.values()), 1)
    out_dir = None if out_dir is None else os.fspath(out_dir)
    names = _frame_names(out_dir, pattern, n)
    keys_by_models = {}
    bases = {}
    jobs = []
    for i in range(n):
        scene = scenes[i] if many_scenes else scenes
        camera = (cams[i] if many_cams else cams) if cams is not None else scene.camera
        if camera is None:
            raise ValueError(f"cameras: frame {i}'s scene has no camera and none was given")
        try:  # every frame's memory before the first is rendered or written
            camera.check_frame_memory(**(memory or {}))
        except ValueError as exc:
            raise ValueError(f"cameras[{i}]: {exc}") from None
        frame_lights = (light_sets[i] if many_lights else light_sets) if light_sets is not None else scene.lights
        # Scene.replace makes a new models tuple of the same Model objects: memoise on those.
        ident = tuple(id(m) for m in scene.models)
        key = keys_by_models.get(ident)
        if key is None:
            key = keys_by_models[ident] = scene_key(scene)
        bases.setdefault(key, scene)
        path = None if out_dir is None else os.path.join(out_dir, names[i])
        jobs.append(FrameJob(i, key, camera, tuple(frame_lights), scene.ambient, scene.background, path))
    return bases, jobs
