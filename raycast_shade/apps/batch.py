"""Batch rendering: many frames, in order, in this process or on Dask.

A batch is a list of scenes, or one scene with a list of cameras and/or a
list of light sets. Frames come back (or are written) in order.

* By default every frame renders in the current process, and all frames of
  one mesh set share one packed geometry and one Embree BVH.
* ``workers=N`` starts a local Dask cluster of ``N`` processes with one
  thread each (Numba's default threading layer is not safe under several
  Python threads of one process); each worker's Numba kernels get
  ``cores // N`` threads. ``scheduler="tcp://host:8786"`` (or a
  :class:`distributed.Client`) uses an existing cluster.
* Meshes travel once: the base scene of each mesh set is scattered to every
  worker, and a frame's task carries only its camera and lights. A worker
  unpickles the scene without its geometry (see ``Scene.__getstate__``),
  builds the geometry and BVH on its first frame and keeps the scene in a
  small per-process cache keyed by the content hash of the models, so later
  frames, and later batches over the same meshes, reuse them.
* Nothing is lost: with an output folder, frames already there are skipped
  (resume); every frame is written atomically (a temporary file in the same
  folder, then :func:`os.replace`); a frame whose worker dies is re-run on
  another worker by Dask, and a frame whose render raised is retried
  ``retries`` times.

>>> import raycast_shade as rs
>>> from raycast_shade.animate import orbit_cameras
>>> scene = rs.Scene([rs.shapes.icosphere(2)], lights=[rs.PointLight((2, 3, 4), intensity=20)],
...                  camera=rs.Camera(eye=(0, 0, 4), width=32, height=24))
>>> images = render_batch(scene, cameras=orbit_cameras(scene.camera, 4), progress=False)
>>> len(images), images[0].shape
(4, (24, 32, 3))
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import hashlib
import logging
import os
import re
import threading
import uuid
import warnings
from dataclasses import dataclass

import numpy as np

from ..scene.camera import Camera
from ..output.imagefile import check_image_path
from ..output.imagefile import write_image as _write_file
from ..scene.lights import DirectionalLight, PointLight
from ..scene.scene import Scene
from ..visibility.accel import embree_accel

__all__ = ["FrameJob", "BatchOptions", "render_batch", "iter_batch", "plan_batch", "local_cluster", "scene_key",
           "write_image", "worker_stats"]

RENDER_KWARGS = ("backend", "interpolation", "caster", "max_depth")
TONE_KWARGS = ("exposure", "tonemap", "gamma")
WINDOW_BYTES = 256 << 20  # default bound on the images in flight or awaiting their turn (iter_batch)
_TMP_RE = re.compile(r"^\.(?P<name>.+)\.[0-9a-f]{12}\.tmp(\.[^.]*)?$")


# -- job specification ---------------------------------------------------------------------------------


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


@dataclass(frozen=True, eq=False)
class BatchOptions:
    """How every frame of a batch is rendered and written.

    Attributes
    ----------
    shading : str
        ``"flat"``, ``"gouraud"`` or ``"phong"``.
    render_kwargs : dict
        Extra keywords of :func:`raycast_shade.render` (``backend``,
        ``interpolation``, ``caster``, ``max_depth``).
    tone : dict
        Keywords of :func:`raycast_shade.to_uint8` for 8-bit outputs.
    resume : bool
        Skip a frame whose output file exists.
    """

    shading: str = "phong"
    render_kwargs: dict = dataclasses.field(default_factory=dict)
    tone: dict = dataclasses.field(default_factory=dict)
    resume: bool = True


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


def _as_scenes(value):
    if isinstance(value, Scene):
        return value, False
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"scenes: expected a Scene or a sequence of Scenes, got {type(value).__name__}")
    scenes = list(value)
    if not scenes:
        raise ValueError("scenes: the sequence is empty")
    for i, s in enumerate(scenes):
        if not isinstance(s, Scene):
            raise TypeError(f"scenes[{i}]: expected a Scene, got {type(s).__name__}")
    return scenes, True


def _as_cameras(value):
    if value is None or isinstance(value, Camera):
        return value, False
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"cameras: expected a Camera or a sequence of Cameras, got {type(value).__name__}")
    cams = list(value)
    if not cams:
        raise ValueError("cameras: the sequence is empty")
    for i, c in enumerate(cams):
        if not isinstance(c, Camera):
            raise TypeError(f"cameras[{i}]: expected a Camera, got {type(c).__name__}")
    return cams, True


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


def _check_options(shading, render_kwargs, tone, resume):
    from ..common.choices import BACKENDS, INTERPOLATIONS, SHADINGS
    from ..output.tonemap import to_uint8

    if not isinstance(shading, str) or shading.lower() not in SHADINGS:
        raise ValueError(f"shading: expected one of {list(SHADINGS)}, got {shading!r}")
    for k in render_kwargs:
        if k not in RENDER_KWARGS:
            raise TypeError(f"render_batch: unexpected keyword argument {k!r} (render options: {list(RENDER_KWARGS)})")
    checks = {"backend": BACKENDS, "interpolation": INTERPOLATIONS, "caster": ("auto", "embree", "embreex")}
    for k, choices in checks.items():
        if k in render_kwargs and render_kwargs[k] not in choices:
            raise ValueError(f"{k}: expected one of {list(choices)}, got {render_kwargs[k]!r}")
    depth = render_kwargs.get("max_depth", 0)
    if isinstance(depth, bool) or not isinstance(depth, (int, np.integer)) or depth < 0:
        raise ValueError(f"max_depth: expected an integer >= 0, got {depth!r}")
    tone = {} if tone is None else tone
    if not isinstance(tone, dict):
        raise TypeError(f"tone: expected a dict of to_uint8 options, got {type(tone).__name__}")
    for k in tone:
        if k not in TONE_KWARGS:
            raise TypeError(f"tone: unexpected key {k!r} (expected some of {list(TONE_KWARGS)})")
    to_uint8(np.zeros((1, 1, 3), np.float32), **tone)  # raises ValueError naming a bad value
    if not isinstance(resume, (bool, np.bool_)):
        raise TypeError(f"resume: expected True or False, got {type(resume).__name__}")
    return BatchOptions(shading.lower(), dict(render_kwargs), dict(tone), bool(resume))


def plan_batch(scene_or_scenes, cameras=None, lights=None, *, out_dir=None, pattern="frame_{:05d}.png"):
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
    scenes, many_scenes = _as_scenes(scene_or_scenes)
    cams, many_cams = _as_cameras(cameras)
    light_sets, many_lights = _as_light_sets(lights)
    lengths = {name: len(v) for name, v, many in (("scenes", scenes, many_scenes), ("cameras", cams, many_cams),
                                                   ("lights", light_sets, many_lights)) if many}
    if len(set(lengths.values())) > 1:
        detail = ", ".join(f"{len_} {name}" for name, len_ in lengths.items())
        name = list(lengths)[-1]
        raise ValueError(f"{name}: the sequences must have one entry per frame, got {detail}")
    n = next(iter(lengths.values()), 1)
    if out_dir is not None:
        out_dir = os.fspath(out_dir)
        _check_pattern(pattern)
        names = [pattern.format(i) for i in range(n)]
        if len(set(names)) != n:
            raise ValueError(f"pattern: {pattern!r} gives two frames the same name")
    keys_by_models = {}
    bases = {}
    jobs = []
    for i in range(n):
        scene = scenes[i] if many_scenes else scenes
        camera = (cams[i] if many_cams else cams) if cams is not None else scene.camera
        if camera is None:
            raise ValueError(f"cameras: frame {i}'s scene has no camera and none was given")
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


# -- writing -------------------------------------------------------------------------------------------


def write_image(path, image, **tone) -> str:
    """Write a linear float image atomically.

    The image goes to a temporary file in the destination folder, which then
    replaces ``path`` in one :func:`os.replace`: a reader (or a resumed
    batch) sees the old file or the complete new one, never half a file.

    Parameters
    ----------
    path : str or path-like
        ``.pfm`` or ``.npy``: float32, lossless; ``.png``, ``.jpg``, ... (see
        :mod:`raycast_shade.imagefile`): 8-bit after :func:`raycast_shade.to_uint8`.
    image : (H, W, 3) float array
    **tone
        ``exposure``, ``tonemap``, ``gamma`` for 8-bit formats.

    Returns
    -------
    str
        ``path``.
    """
    path = os.fspath(path)
    ext = check_image_path(path)
    folder, name = os.path.split(os.path.abspath(path))
    tmp = os.path.join(folder, f".{name}.{uuid.uuid4().hex[:12]}.tmp{ext}")
    try:
        _write_file(tmp, image, **tone)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def _remove_stale_temps(out_dir, names) -> int:
    """Delete temporary files that a killed writer left for these frames."""
    names = set(names)
    removed = 0
    for entry in os.listdir(out_dir):
        m = _TMP_RE.match(entry)
        if m and m.group("name") in names:
            with contextlib.suppress(OSError):
                os.unlink(os.path.join(out_dir, entry))
                removed += 1
    return removed


# -- rendering one frame (in this process or on a worker) --------------------------------------------

_STATS = {"builds": 0, "renders": 0, "skipped": 0}
_CACHE: collections.OrderedDict = collections.OrderedDict()
_CACHE_SIZE = 4
_LOCK = threading.Lock()


def worker_stats() -> dict:
    """Counters of this process: ``builds`` (geometry + BVH builds),
    ``renders`` and ``skipped`` (frames found written by an earlier attempt),
    and ``cached`` (mesh sets held). Run it on every worker with
    ``client.run(worker_stats)``."""
    with _LOCK:
        return dict(_STATS, cached=len(_CACHE))


def _reset_stats() -> None:
    with _LOCK:
        for k in _STATS:
            _STATS[k] = 0


def _cached_base(key: str, scene: Scene) -> Scene:
    """The scene this process already holds for ``key``, else ``scene``."""
    with _LOCK:
        base = _CACHE.get(key)
        if base is None:
            base = _CACHE[key] = scene
            while len(_CACHE) > _CACHE_SIZE:
                _CACHE.popitem(last=False)
        else:
            _CACHE.move_to_end(key)
        return base


def _render_image(job: FrameJob, base: Scene, options: BatchOptions) -> np.ndarray:
    """Render one job on its base scene, reusing (or building once) its geometry."""
    from ..render import render

    if "geometry" not in base.__dict__:
        with _LOCK:
            _STATS["builds"] += 1
    geometry = base.geometry  # packs once; Scene.replace below shares it
    if options.render_kwargs.get("caster", "auto") != "embreex" and options.render_kwargs.get("backend") != "raster":
        embree_accel(geometry)  # the BVH, built once per process and mesh set
    scene = base.replace(lights=job.lights, camera=job.camera, ambient=job.ambient, background=job.background)
    frame = render(scene, options.shading, camera=job.camera, **options.render_kwargs)
    with _LOCK:
        _STATS["renders"] += 1
    return frame.image


def _render_job(job: FrameJob, base: Scene, options: BatchOptions):
    if job.path is not None and options.resume and os.path.exists(job.path):
        with _LOCK:
            _STATS["skipped"] += 1
        return job.path  # written by an earlier attempt (e.g. on a worker that died afterwards)
    image = _render_image(job, base, options)
    if job.path is None:
        return image
    return write_image(job.path, image, **options.tone)


def _revalidated(job: FrameJob) -> FrameJob:
    """The job with its camera and lights rebuilt by their constructors.

    Unpickled arrays lose their read-only flag, and Numba compiles (and
    caches) a separate specialisation of every kernel for writeable arrays:
    without this, each worker would compile the whole renderer again
    instead of loading the client's cache. The constructors mark the
    validated arrays read-only again (ambient and background go through
    :meth:`Scene.replace`, which does the same).
    """
    return dataclasses.replace(job, camera=dataclasses.replace(job.camera),
                               lights=tuple(dataclasses.replace(light) for light in job.lights))


def _run_chunk_on_worker(jobs, scene: Scene, options: BatchOptions) -> list:
    """The Dask task: consecutive frames of one mesh set; ``scene`` is its
    scattered base scene. Re-run whole if its worker dies; frames it had
    already written are then skipped (see :func:`_render_job`)."""
    base = _cached_base(jobs[0].key, scene)
    return [_render_job(_revalidated(job), base, options) for job in jobs]


# -- clusters ------------------------------------------------------------------------------------------


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


@contextlib.contextmanager
def local_cluster(n_workers: int, *, numba_threads: int | None = None, **cluster_kwargs):
    """A local Dask cluster for rendering, as a context manager yielding a Client.

    Workers are processes with one thread each; their Numba kernels use
    ``numba_threads`` threads (default: ``cores // n_workers``, at least 1).

    Parameters
    ----------
    n_workers : int
        ``> 0``.
    numba_threads : int, optional
        ``NUMBA_NUM_THREADS`` of every worker.
    **cluster_kwargs
        Passed on to :class:`distributed.LocalCluster`.

    Yields
    ------
    distributed.Client
    """
    if isinstance(n_workers, bool) or not isinstance(n_workers, (int, np.integer)) or n_workers < 1:
        raise ValueError(f"workers: expected an integer > 0, got {n_workers!r}")
    if numba_threads is None:
        numba_threads = max(1, _cores() // int(n_workers))
    if isinstance(numba_threads, bool) or not isinstance(numba_threads, (int, np.integer)) or numba_threads < 1:
        raise ValueError(f"numba_threads: expected an integer > 0, got {numba_threads!r}")
    try:
        from distributed import Client, LocalCluster
    except ImportError as exc:
        raise ImportError("workers=: Dask is not installed; pip install 'raycast_shade[scale]'") from exc
    env = {"NUMBA_NUM_THREADS": str(int(numba_threads)), "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1"}
    env.update(cluster_kwargs.pop("env", {}))
    kw = dict(n_workers=int(n_workers), threads_per_worker=1, processes=True, dashboard_address=None,
              silence_logs=logging.ERROR, env=env)
    kw.update(cluster_kwargs)
    with warnings.catch_warnings():
        # The scheduler's HTTP server falls back to a free port when 8787 is taken (e.g. by another cluster).
        warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
        cluster = LocalCluster(**kw)
    with cluster, Client(cluster) as client:
        yield client


@contextlib.contextmanager
def _client(workers, scheduler, numba_threads):
    if workers is not None and scheduler is not None:
        raise ValueError("workers: give workers (a local cluster) or scheduler (an existing one), not both")
    if workers is not None:
        with local_cluster(workers, numba_threads=numba_threads) as client:
            yield client
        return
    try:
        from distributed import Client
    except ImportError as exc:
        raise ImportError("scheduler=: Dask is not installed; pip install 'raycast_shade[scale]'") from exc
    if isinstance(scheduler, Client):
        yield scheduler
        return
    if not isinstance(scheduler, str):
        raise TypeError(f"scheduler: expected an address like 'tcp://host:8786' or a Client, "
                        f"got {type(scheduler).__name__}")
    with Client(scheduler) as client:
        yield client


class _NoBar:
    def update(self, n=1):
        pass

    def close(self):
        pass


def _progress_bar(enabled, total, initial, desc):
    if not enabled:
        return _NoBar()
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return _NoBar()
    return tqdm(total=total, initial=initial, desc=desc, unit="frame", dynamic_ncols=True)


# -- driver --------------------------------------------------------------------------------------------


def iter_batch(scene_or_scenes, cameras=None, lights=None, *, shading: str = "phong", out_dir=None,
               pattern: str = "frame_{:05d}.png", workers: int | None = None, scheduler=None, progress: bool = True,
               retries: int = 2, resume: bool = True, tone: dict | None = None, numba_threads: int | None = None,
               frames_per_task: int = 1, window: int | None = None, **render_kwargs):
    """Render a batch, yielding each frame's result in frame order.

    Same parameters as :func:`render_batch`, plus ``window``: at most that
    many frames are in flight or held for reordering at once when images
    are returned, which bounds memory for long animations streamed to a
    writer (default: as many as fit in :data:`WINDOW_BYTES`, 256 MiB of
    float32 images, and at least 4 tasks per worker).

    Yields
    ------
    (H, W, 3) float32 ndarray or str
        The linear image, or the written path when ``out_dir`` is given.
    """
    options = _check_options(shading, render_kwargs, tone, resume)
    if not isinstance(retries, (int, np.integer)) or isinstance(retries, bool) or retries < 0:
        raise ValueError(f"retries: expected an integer >= 0, got {retries!r}")
    for name, value in (("frames_per_task", frames_per_task), ("window", 1 if window is None else window)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"{name}: expected an integer > 0, got {value!r}")
    bases, jobs = plan_batch(scene_or_scenes, cameras, lights, out_dir=out_dir, pattern=pattern)
    done = set()
    if out_dir is not None:
        os.makedirs(out_dir, exist_ok=True)
        _remove_stale_temps(out_dir, [os.path.basename(j.path) for j in jobs])
        if options.resume:
            done = {j.index for j in jobs if os.path.exists(j.path)}
    bar = _progress_bar(progress, len(jobs), len(done), f"{options.shading} frames")
    try:
        if workers is None and scheduler is None:
            for job in jobs:
                if job.index in done:
                    yield job.path
                    continue
                result = _render_job(job, bases[job.key], options)
                bar.update(1)
                yield result
            return
        with _client(workers, scheduler, numba_threads) as client:
            yield from _iter_dask(client, bases, jobs, done, options, retries, window, int(frames_per_task), bar)
    finally:
        bar.close()


def _chunks(todo, size):
    """Consecutive jobs of one mesh set, ``size`` at most per chunk."""
    chunk = []
    for job in todo:
        if chunk and (len(chunk) == size or chunk[0].key != job.key):
            yield chunk
            chunk = []
        chunk.append(job)
    if chunk:
        yield chunk


def _iter_dask(client, bases, jobs, done, options, retries, window, frames_per_task, bar):
    from distributed import as_completed

    todo = [j for j in jobs if j.index not in done]
    scattered = {}
    for key in dict.fromkeys(j.key for j in todo):
        # One copy per worker, sent once; without its geometry (Scene.__getstate__).
        scattered[key] = client.scatter(bases[key], broadcast=True, hash=False)
    n_workers = max(1, len(client.scheduler_info().get("workers", {})))
    if window is None:
        if jobs and jobs[0].path is not None:
            window = len(jobs)  # results are paths: no memory to bound
        else:
            # Deep enough to hide the round trips, shallow enough to bound the images held.
            frame_bytes = max(1, max(j.camera.width * j.camera.height * 12 for j in jobs))
            window = max(4 * n_workers * frames_per_task, min(len(jobs), WINDOW_BYTES // frame_bytes))
    window = max(int(window), frames_per_task)
    batch_id = uuid.uuid4().hex[:8]
    queue = collections.deque(_chunks(todo, frames_per_task))
    live = {}  # task key -> (future, frame indices)
    in_flight = 0  # frames in live tasks
    results = {}
    ready = as_completed(with_results=True)  # results fetched in the background, not one blocking call each

    def submit_more():
        nonlocal in_flight
        while queue and in_flight + len(results) + len(queue[0]) <= window:
            chunk = queue.popleft()
            first = chunk[0].index
            fut = client.submit(_run_chunk_on_worker, chunk, scattered[chunk[0].key], options,
                                key=f"rs-frames-{batch_id}-{first}", retries=int(retries), priority=-first,
                                pure=False)
            live[fut.key] = (fut, [j.index for j in chunk])
            in_flight += len(chunk)
            ready.add(fut)

    next_index = 0
    try:
        submit_more()
        while next_index < len(jobs):
            if jobs[next_index].index in done:
                yield jobs[next_index].path
                next_index += 1
                continue
            if next_index in results:
                yield results.pop(next_index)
                next_index += 1
                submit_more()
                continue
            fut, chunk_results = next(ready)  # raises a frame's error once its retries are spent
            _, indices = live.pop(fut.key)
            in_flight -= len(indices)
            results.update(zip(indices, chunk_results))
            fut.release()
            bar.update(len(indices))
    finally:
        if live:  # an error, or the consumer stopped early
            client.cancel([f for f, _ in live.values()])
        ready.clear()
        for fut in scattered.values():
            fut.release()


def render_batch(scene_or_scenes, cameras=None, lights=None, *, shading: str = "phong", out_dir=None,
                 pattern: str = "frame_{:05d}.png", workers: int | None = None, scheduler=None,
                 progress: bool = True, retries: int = 2, resume: bool = True, tone: dict | None = None,
                 numba_threads: int | None = None, frames_per_task: int = 1, **render_kwargs) -> list:
    """Render many frames, in order.

    Each of ``scene_or_scenes``, ``cameras`` and ``lights`` is one value
    (used for every frame) or a sequence with one entry per frame; the
    sequences given must have equal lengths.

    Parameters
    ----------
    scene_or_scenes : Scene or sequence of Scene
        Scenes that share their models (e.g. made with :meth:`Scene.replace`)
        share one geometry and BVH; so do scenes with equal models.
    cameras : Camera or sequence of Camera, optional
        Default: each scene's camera.
    lights : sequence of light sets, optional
        One light set (a sequence of lights, or one light) per frame.
        Default: each scene's lights.
    shading : {"flat", "gouraud", "phong"}
    out_dir : str or path-like, optional
        Write frame ``i`` to ``out_dir / pattern.format(i)`` (the folder is
        created) instead of returning images.
    pattern : str
        Frame file name; the extension picks the format: ``.png``,
        ``.jpg``, ... (8-bit, tone-mapped with ``tone``), ``.pfm`` or
        ``.npy`` (linear float32).
    workers : int, optional
        Render on a local Dask cluster of this many single-threaded worker
        processes.
    scheduler : str or distributed.Client, optional
        Render on an existing Dask cluster: its scheduler address
        (``"tcp://host:8786"``) or a connected client.
    progress : bool
        Show a tqdm progress bar (when tqdm is installed).
    retries : int
        Times a frame whose render raised is re-run (Dask only). A frame
        whose worker died is re-run on another worker regardless (up to
        Dask's ``distributed.scheduler.allowed-failures``).
    resume : bool
        With ``out_dir``: skip frames whose file exists.
    tone : dict, optional
        :func:`raycast_shade.to_uint8` options for 8-bit files:
        ``exposure``, ``tonemap``, ``gamma``.
    numba_threads : int, optional
        Numba threads per worker of a ``workers=`` cluster (default: cores
        divided by workers).
    frames_per_task : int
        Consecutive frames rendered by one Dask task. Each task costs a few
        milliseconds of scheduling and transfer; group small, fast frames
        to spread that cost (``benchmarks/bench_batch.py`` measures it).
    **render_kwargs
        ``backend``, ``interpolation``, ``caster``, ``max_depth`` of
        :func:`raycast_shade.render`.

    Returns
    -------
    list
        One entry per frame, in order: the (H, W, 3) float32 linear image,
        or with ``out_dir`` the path written (or found, when resumed).

    Raises
    ------
    TypeError, ValueError
        For a bad argument, naming it, before any frame renders.
    """
    return list(iter_batch(scene_or_scenes, cameras, lights, shading=shading, out_dir=out_dir, pattern=pattern,
                           workers=workers, scheduler=scheduler, progress=progress, retries=retries, resume=resume,
                           tone=tone, numba_threads=numba_threads, frames_per_task=frames_per_task,
                           **render_kwargs))
