"""Animations: camera turntables and light orbits, as GIF, MP4 or PNG frames.

:func:`orbit_cameras` turns a camera around its target; :func:`orbit_light`
moves one light of a scene around it (the scenes share one geometry and
BVH). :func:`animate` renders either through :func:`raycast_shade.apps.batch.iter_batch`
(in this process, on a local Dask cluster or on an existing one) and writes
the frames with :func:`write_animation` or as a numbered PNG sequence.

The command line ``raycast-shade animate`` is :func:`register_cli` and
:func:`run_cli`::

    raycast-shade animate scene.toml --orbit camera --frames 36 -o turntable.gif
    raycast-shade animate scene.toml --orbit light --light-index 0 --frames 48 --shading gouraud -o sweep.mp4
    raycast-shade animate scene.toml --orbit camera --frames 360 -o frames/ --workers 2

>>> import raycast_shade as rs
>>> scene = rs.Scene([rs.shapes.icosphere(2)], lights=[rs.PointLight((2, 3, 4), intensity=20)],
...                  camera=rs.Camera(eye=(0, 0, 4), width=32, height=24))
>>> [round(float(c.eye[0]), 6) for c in orbit_cameras(scene.camera, 4)]
[0.0, 4.0, 0.0, -4.0]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time

import numpy as np

from ..common.choices import ORBITS, VIDEO_EXTS
from ..common.validate import as_choice, as_int, as_scalar
from ..output.imagefile import atomic_target, check_output_file, check_output_folder
from ..scene.camera import Camera
from ..scene.lights import DirectionalLight, PointLight, SpotLight
from ..scene.scene import Scene
from .args import (add_render_options, add_tone_options, finite_float, nonnegative_int, overrides, positive_float,
                   positive_int, run_options, shading_label)
from .batch import iter_batch, render_batch
from .batch.driver import FLAT_RUN_KEYWORDS
from .batch.run import EXECUTORS, RunOptions, check_executor, merge_keywords

__all__ = ["orbit_cameras", "orbit_light", "write_animation", "animate", "output_kind", "check_output", "register_cli",
           "run_cli",
           "ORBITS", "VIDEO_EXTS"]

FRAME_PATTERN = "frame_{:05d}.png"


# -- orbits ----------------------------------------------------------------------------------------------


def _rotation(axis, degrees: float) -> np.ndarray:
    """(3, 3) rotation by ``degrees`` about the unit ``axis`` (right-handed)."""
    x, y, z = axis
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return c * np.eye(3) + s * k + (1.0 - c) * np.outer(axis, axis)


def _unit_axis(axis, name: str) -> np.ndarray:
    a = np.asarray(axis, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {axis!r}")
    n = np.linalg.norm(a)
    if not n > 0:
        raise ValueError(f"{name}: must be non-zero")
    return a / n


def _check_frames(frames) -> int:
    return as_int(frames, "frames", minimum=1)  # NumPy integers and 0-d arrays too; booleans never


def _check_degrees(degrees) -> float:
    return as_scalar(degrees, "degrees")  # any finite angle; NumPy scalars and 0-d arrays too


def _angles(frames: int, degrees: float) -> np.ndarray:
    # Frame i at degrees * i / frames: a full turn loops without repeating a frame. A turn of
    # 360 * frames degrees brings every frame back: reduce by it first (exactly, fmod), so that
    # degrees * i cannot overflow (1e308 * 35 is inf, and a rotation by inf is NaN).
    if abs(degrees) >= 360.0 * frames:
        degrees = math.fmod(degrees, 360.0 * frames)
    return degrees * np.arange(frames) / frames


def orbit_cameras(camera: Camera, frames: int, *, degrees: float = 360.0, axis=None, center=None) -> list:
    """A turntable: the camera's eye circles about an axis through the target.

    Parameters
    ----------
    camera : Camera
        Frame 0's camera.
    frames : int
        Number of cameras, ``> 0``.
    degrees : float
        Total turn; frame ``i`` is turned by ``degrees * i / frames``, so a
        full turn loops seamlessly. Positive turns are counter-clockwise seen
        from the tip of ``axis``.
    axis : (3,) float, optional
        Rotation axis (default: ``camera.up``).
    center : (3,) float, optional
        A point on the axis (default: ``camera.target``); the target turns
        about it too.

    Returns
    -------
    list of Camera
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    frames, degrees = _check_frames(frames), _check_degrees(degrees)
    axis = _unit_axis(camera.up if axis is None else axis, "axis")
    c = camera.target if center is None else np.asarray(center, dtype=np.float64)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise ValueError(f"center: expected 3 finite numbers, got {center!r}")
    cams = []
    for a in _angles(frames, degrees):
        r = _rotation(axis, a)
        eye = c + r @ (camera.eye - c)
        target = c + r @ (camera.target - c)
        up = camera.up if np.allclose(np.cross(camera.up, axis), 0.0) else r @ camera.up
        cams.append(camera.replace(eye=eye, target=target, up=up))
    return cams


def _scene_center(scene: Scene) -> np.ndarray:
    lo = np.min([m.bounds[0] for m in scene.models], axis=0)  # world boxes: each mesh moved by its pose
    hi = np.max([m.bounds[1] for m in scene.models], axis=0)
    return 0.5 * (lo + hi)


def orbit_light(scene: Scene, frames: int, *, light_index: int = 0, degrees: float = 360.0, axis=None,
                center=None) -> list:
    """One light circles the scene; everything else stays.

    A point light's position turns about an axis through ``center``; a
    directional light's direction turns about ``axis``; a spot light turns
    as a rigid body, its position about ``center`` and its axis with it (so
    a spot aimed at the scene stays aimed at it).

    Parameters
    ----------
    scene : Scene
    frames : int
        Number of scenes, ``> 0``.
    light_index : int
        Which of ``scene.lights`` moves.
    degrees : float
        Total turn; frame ``i`` is turned by ``degrees * i / frames``.
    axis : (3,) float, optional
        Default: the camera's up vector, or +y without a camera.
    center : (3,) float, optional
        Default: the centre of the models' bounding box.

    Returns
    -------
    list of Scene
        Made with :meth:`Scene.replace`: they share the models, hence one
        geometry and one BVH.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    frames, degrees = _check_frames(frames), _check_degrees(degrees)
    light_index = as_int(light_index, "light_index")
    n = len(scene.lights)
    if n == 0:
        raise ValueError("light_index: the scene has no lights to orbit")
    if not 0 <= light_index < n:
        raise ValueError(f"light_index: the scene has {n} light(s), so 0..{n - 1}; got {light_index}")
    default_axis = scene.camera.up if scene.camera is not None else (0.0, 1.0, 0.0)
    axis = _unit_axis(default_axis if axis is None else axis, "axis")
    c = _scene_center(scene) if center is None else np.asarray(center, dtype=np.float64)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise ValueError(f"center: expected 3 finite numbers, got {center!r}")
    light = scene.lights[light_index]
    scenes = []
    for a in _angles(frames, degrees):
        r = _rotation(axis, a)
        if isinstance(light, SpotLight):
            moved = dataclasses.replace(light, position=c + r @ (light.position - c), direction=r @ light.direction)
        elif isinstance(light, PointLight):
            moved = dataclasses.replace(light, position=c + r @ (light.position - c))
        elif isinstance(light, DirectionalLight):
            moved = dataclasses.replace(light, direction=r @ light.direction)
        else:  # pragma: no cover - Scene admits only these two
            raise TypeError(f"scene.lights[{light_index}]: cannot orbit a {type(light).__name__}")
        lights = list(scene.lights)
        lights[light_index] = moved
        scenes.append(scene.replace(lights=lights))
    return scenes


# -- writing ---------------------------------------------------------------------------------------------


def output_kind(output) -> str:
    """What an output path asks for: ``"gif"``, ``"video"`` or ``"frames"``.

    A path ending in a separator, an existing folder or a name without an
    extension is a folder of numbered PNG frames.

    Raises
    ------
    ValueError
        For any other extension.
    """
    if not isinstance(output, (str, os.PathLike)):
        raise TypeError(f"output: expected a path, got {type(output).__name__}")
    path = os.fspath(output)
    if path.endswith(("/", os.sep)) or os.path.isdir(path):
        return "frames"
    ext = os.path.splitext(path)[1].lower()
    if not ext:
        return "frames"
    if ext == ".gif":
        return "gif"
    if ext in VIDEO_EXTS:
        return "video"
    raise ValueError(f"output: {path!r}: expected .gif, one of {list(VIDEO_EXTS)}, or a folder for PNG frames")


def check_output(output) -> str:
    """What :func:`output_kind` says, after checking the place can be written, before any frame:
    a folder of frames must be (or can be made) a writable folder, a GIF or video file must not be
    a folder and must go into an existing, writable one.

    Raises
    ------
    TypeError, ValueError
        Naming ``output``.
    """
    kind = output_kind(output)
    if kind == "frames":
        check_output_folder(output, "output")
    else:
        check_output_file(output, "output")
    return kind


def _to_uint8(image, tone: dict) -> np.ndarray:
    a = np.asarray(image)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"images: expected (H, W, 3) frames, got shape {a.shape}")
    if a.dtype == np.uint8:
        return a
    from ..output.tonemap import to_uint8

    return to_uint8(a, **tone)


def write_animation(images, output, *, fps: float = 12.0, tone: dict | None = None, loop: int = 0) -> int:
    """Write frames as an animated GIF or a video, atomically.

    Parameters
    ----------
    images : iterable of (H, W, 3) arrays
        uint8 sRGB frames as they are, or linear float frames (tone-mapped
        with ``tone``). Consumed one at a time: a video never holds more
        than one frame (a GIF holds its 8-bit frames until it is encoded).
    output : str or path-like
        ``.gif`` (Pillow), or ``.mp4``/``.m4v``/``.mov``/``.mkv`` (H.264
        through imageio-ffmpeg; odd sizes are padded by one pixel).
    fps : float
        Frames per second, ``> 0``.
    tone : dict, optional
        :func:`raycast_shade.to_uint8` options.
    loop : int
        GIF repetitions; 0 loops forever.

    Returns
    -------
    int
        The number of frames written.
    """
    kind = output_kind(output)
    if kind == "frames":
        raise ValueError(f"output: {os.fspath(output)!r} is a folder; write_animation writes .gif or video files")
    as_scalar(fps, "fps", minimum=0.0, exclusive=True)
    tone = dict(tone or {})
    path = check_output_file(output, "output")  # before the first frame is drawn from ``images``
    count = 0
    with atomic_target(path) as tmp:
        if kind == "gif":
            import imageio.v3 as iio

            frames = [_to_uint8(im, tone) for im in images]
            if not frames:
                raise ValueError("images: no frames to write")
            if any(f.shape != frames[0].shape for f in frames):
                raise ValueError("images: all frames must have the same size")
            iio.imwrite(tmp, np.stack(frames), extension=".gif", plugin="pillow", duration=1000.0 / fps, loop=loop)
            count = len(frames)
        else:
            try:
                import imageio.v2 as iio2
                import imageio_ffmpeg  # noqa: F401 - the FFMPEG plugin's backend
            except ImportError as exc:
                raise ImportError("video output needs imageio-ffmpeg; pip install 'raycast_shade[scale]'") from exc
            writer = None
            try:
                shape = None
                for im in images:
                    frame = _to_uint8(im, tone)
                    if shape is None:
                        shape = frame.shape
                        writer = iio2.get_writer(tmp, format="FFMPEG", mode="I", fps=float(fps), codec="libx264",
                                                 pixelformat="yuv420p", macro_block_size=1, quality=8,
                                                 ffmpeg_log_level="error")
                    elif frame.shape != shape:
                        raise ValueError("images: all frames must have the same size")
                    h, w = frame.shape[:2]
                    if h % 2 or w % 2:  # yuv420p needs even sizes
                        frame = np.pad(frame, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
                    writer.append_data(frame)
                    count += 1
                if count == 0:
                    raise ValueError("images: no frames to write")
            finally:
                if writer is not None:
                    writer.close()
    return count


# -- one call ------------------------------------------------------------------------------------------


def animate(scene: Scene, output, *, orbit: str = "camera", frames: int = 36, light_index: int = 0,
            degrees: float = 360.0, axis=None, shading="phong", fps: float = 12.0, tone: dict | None = None,
            run: RunOptions | None = None, **render_kwargs) -> dict:
    """Render an orbit animation and write it.

    Parameters
    ----------
    scene : Scene
        With a camera.
    output : str or path-like
        ``.gif``, a video (``.mp4``, ...), or a folder (a path ending in
        ``/``, an existing folder, or a name without an extension) for
        ``frame_00000.png``, ... . A folder resumes: frames already there
        are not rendered again.
    orbit : {"camera", "light"}
        Turntable (:func:`orbit_cameras`) or a moving light (:func:`orbit_light`).
    frames : int
    light_index : int
        The light that moves (``orbit="light"``).
    degrees : float
        Total turn.
    axis : (3,) float, optional
        Default: the camera's up vector.
    shading : str or sequence of str
        ``"flat"``, ``"gouraud"``, ``"phong"`` or ``"auto"`` (any case), or
        one method per model, as in :func:`raycast_shade.render`.
    fps : float
        Playback rate of GIF and video.
    tone : dict, optional
        :func:`raycast_shade.to_uint8` options.
    run : RunOptions, optional
        Where and how the frames render (``workers``, ``scheduler``, ``executor``,
        ``per_task``, ``progress``, ``resume`` of a folder output, ...), as in
        :func:`raycast_shade.apps.batch.render_batch`. The flat keywords of earlier
        releases (``workers=2``, ``frames_per_task=4``, ...) still work for this release,
        with a ``DeprecationWarning``.
    **render_kwargs
        As in :func:`raycast_shade.apps.batch.render_batch` (``backend``,
        ``interpolation``, ``caster``, ``max_depth``, ``tolerance``).

    Returns
    -------
    dict
        ``output``, ``kind`` (``"gif"``, ``"video"``, ``"frames"``),
        ``frames`` and ``seconds``.

    Examples
    --------
    >>> animate(scene, "turntable.mp4", frames=120, run=RunOptions(workers=2))   # doctest: +SKIP
    """
    t0 = time.perf_counter()
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if scene.camera is None:
        raise ValueError("scene.camera: an animation needs a camera")
    run = merge_keywords(run, RunOptions, render_kwargs, FLAT_RUN_KEYWORDS, "run")
    orbit = as_choice(orbit, "orbit", ORBITS)
    kind = check_output(output)
    as_scalar(fps, "fps", minimum=0.0, exclusive=True)
    if orbit == "camera":
        batch = dict(scene_or_scenes=scene, cameras=orbit_cameras(scene.camera, frames, degrees=degrees, axis=axis))
    else:
        batch = dict(scene_or_scenes=orbit_light(scene, frames, light_index=light_index, degrees=degrees, axis=axis))
    common = dict(shading=shading, tone=tone, run=run, **render_kwargs)
    path = os.fspath(output)
    if kind == "frames":
        written = render_batch(**batch, out_dir=path, pattern=FRAME_PATTERN, **common)
        count = len(written)
    else:
        count = write_animation(iter_batch(**batch, **common), path, fps=fps, tone=tone)
    return {"output": path, "kind": kind, "frames": count, "seconds": time.perf_counter() - t0}


# -- command line ----------------------------------------------------------------------------------------


_CLI_EPILOG = """\
examples:
  raycast-shade animate scene.toml --orbit camera --frames 36 -o turntable.gif
  raycast-shade animate scene.toml --orbit light --light-index 0 --frames 48 --shading gouraud -o sweep.mp4
  raycast-shade animate scene.toml --frames 360 --width 1280 --height 720 -o frames/ --workers 2
  raycast-shade animate scene.toml --frames 360 -o frames/ --scheduler tcp://10.0.0.5:8786

A folder output (frames/) is resumable: frames already written are skipped on a re-run.
"""


def register_cli(subparsers):
    """Add the ``animate`` command to the ``raycast-shade`` parser.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        What ``parser.add_subparsers()`` returned.

    Returns
    -------
    argparse.ArgumentParser
        The ``animate`` parser; dispatch its parsed arguments to :func:`run_cli`.
    """
    p = subparsers.add_parser(
        "animate", help="render a camera turntable or a light orbit as GIF, MP4 or PNG frames",
        description="Render an orbit animation of a TOML scene file: the camera turns about its target "
                    "(--orbit camera) or one light circles the scene (--orbit light). Frames render in this "
                    "process, in N worker processes of this machine (--workers N; a local Dask cluster with "
                    "--executor dask) or on an existing Dask cluster (--scheduler ADDR).",
        epilog=_CLI_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("scene", metavar="SCENE.toml", help="scene file")
    p.add_argument("--orbit", type=str.lower, choices=ORBITS, default="camera", help="what moves (default: camera)")
    p.add_argument("--light-index", type=nonnegative_int, default=0, metavar="I",
                   help="the light that moves with --orbit light, from 0 (default: 0)")
    p.add_argument("--frames", type=positive_int, default=36, metavar="N",
                   help="number of frames (default: 36)")
    p.add_argument("--degrees", type=finite_float, default=360.0, metavar="D",
                   help="total turn in degrees (default: 360, a seamless loop)")
    add_render_options(p)
    p.add_argument("-o", "--output", metavar="PATH",
                   help="out.gif, out.mp4 (.m4v, .mov, .mkv) or a folder/ for numbered PNG frames "
                        "(default: the scene file's name + _ORBIT.gif, here)")
    p.add_argument("--fps", type=positive_float, default=12.0, metavar="F",
                   help="frames per second of GIF and video (default: 12)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=positive_int, metavar="N",
                       help="render in N single-threaded worker processes of this machine (one per core is "
                            "fastest)")
    where.add_argument("--scheduler", metavar="ADDR", help="render on an existing Dask cluster, e.g. tcp://host:8786")
    p.add_argument("--executor", type=str.lower, choices=EXECUTORS, default="auto",
                   help="where frames render: auto (default: --scheduler on Dask, --workers in processes of "
                        "this machine, else this process), serial, processes, dask (--workers N: a local "
                        "Dask cluster)")
    p.add_argument("--frames-per-task", type=positive_int, default=None, metavar="K",
                   help="frames rendered by one Dask task (default: about 4 megapixels a task, "
                        "at least 4 tasks per worker)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_tone_options(p, "tone mapping")
    return p


def run_cli(ns) -> int:
    """Run ``raycast-shade animate`` with parsed arguments.

    Parameters
    ----------
    ns : argparse.Namespace
        From the parser :func:`register_cli` added.

    Returns
    -------
    int
        0 on success.

    Raises
    ------
    ValueError, TypeError, OSError
        For anything the user can fix (the caller prints it on one line).
    """
    from ..scene.motionfile import warn_motion_ignored
    from ..scene.scenefile import load_for_render

    output = ns.output
    if output is None:
        output = f"{os.path.splitext(os.path.basename(ns.scene))[0]}_{ns.orbit}.gif"
    check_output(output)  # before the scene (and its meshes) load
    scene, render_kwargs, tone = load_for_render(ns.scene, **overrides(ns))
    warn_motion_ignored(ns.scene, "an orbit clip (raycast-shade animate)")
    camera = scene.camera
    if ns.orbit == "light":
        n = len(scene.lights)
        if n == 0:
            raise ValueError(f"--orbit light: {ns.scene} has no [[light]] to move")
        if ns.light_index >= n:
            raise ValueError(f"--light-index: {ns.scene} has {n} light(s), so 0..{n - 1}; got {ns.light_index}")
    shading = render_kwargs.pop("shading", "phong")
    run = run_options(ns)  # the flags as the record Python callers pass
    result = animate(scene, output, orbit=ns.orbit, frames=ns.frames, light_index=ns.light_index,
                     degrees=ns.degrees, shading=shading, fps=ns.fps, tone=tone, run=run, **render_kwargs)
    kind = check_executor(run.executor, run.workers, run.scheduler)
    where = (f"cluster {ns.scheduler}" if ns.scheduler else
             "this process" if kind == "serial" else
             f"{ns.workers or 'per-core'} {'Dask workers' if kind == 'dask' else 'worker processes'}")
    secs = result["seconds"]
    print(f"wrote {result['output']} ({result['frames']} frames, {camera.width}x{camera.height}, "
          f"{shading_label(shading)}, {ns.orbit} orbit, {where}): {secs:.1f} s, "
          f"{result['frames'] / secs:.1f} frames/s")
    return 0
