"""The batch entry points: check everything, plan, then run in this process,
on a pool of processes of this machine, or on Dask."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile

from ...output.imagefile import remove_stale_temps
from .cache import SceneCache
from .options import BatchOptions, check_counts, check_options, check_shading_fits, check_transfer
from .plan import plan_batch
from .pool import ProcessPool, cores
from .serial import iter_serial

__all__ = ["iter_batch", "render_batch", "EXECUTORS", "LOCAL_EXECUTOR", "check_executor"]

EXECUTORS = ("auto", "serial", "processes", "dask")
# What executor="auto" runs for workers=N (the cores of this machine): the process pool, faster than
# Dask's LocalCluster and than this process on 2 cores from 640x480 up (benchmarks/bench_batch.py).
LOCAL_EXECUTOR = "processes"


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


def _label(shading) -> str:
    return shading if isinstance(shading, str) else ",".join(shading)


@contextlib.contextmanager
def _spool_folder(transfer: str, client, out_dir):
    """The temporary folder images come back through, or None (see :mod:`.dask_driver`)."""
    from .cluster import is_local

    if out_dir is not None or transfer == "dask" or (transfer == "auto" and not is_local(client)):
        yield None  # workers write the frames themselves, or images travel through Dask
        return
    folder = tempfile.mkdtemp(prefix="raycast-shade-batch-")
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def check_executor(executor, workers, scheduler):
    """``"serial"``, ``"processes"``, ``"dask"`` or the given :class:`ProcessPool`.

    ``"auto"``: Dask with ``scheduler``, :data:`LOCAL_EXECUTOR` with
    ``workers``, else this process.
    """
    if isinstance(executor, ProcessPool):
        if workers is not None or scheduler is not None:
            raise ValueError("executor: a ProcessPool has its own workers; give neither workers nor scheduler")
        return executor
    if not isinstance(executor, str):
        raise TypeError(f"executor: expected one of {list(EXECUTORS)} or a ProcessPool, got {type(executor).__name__}")
    kind = executor.lower()
    if kind not in EXECUTORS:
        raise ValueError(f"executor: expected one of {list(EXECUTORS)} or a ProcessPool, got {executor!r}")
    if kind == "auto":
        kind = "dask" if scheduler is not None else LOCAL_EXECUTOR if workers is not None else "serial"
    if kind == "serial" and (workers is not None or scheduler is not None):
        raise ValueError("workers: executor='serial' renders in this process; give neither workers nor scheduler")
    if kind == "processes" and scheduler is not None:
        raise ValueError("scheduler: executor='processes' runs on this machine; scheduler= is for Dask")
    return kind


def iter_batch(scene_or_scenes, cameras=None, lights=None, *, shading="phong", out_dir=None,
               pattern: str = "frame_{:05d}.png", workers: int | None = None, scheduler=None, progress: bool = True,
               retries: int = 2, resume: bool = True, tone: dict | None = None, numba_threads: int | None = None,
               frames_per_task: int | None = None, window: int | None = None, cache: SceneCache | None = None,
               transfer: str = "auto", executor="auto", options: BatchOptions | None = None, **render_kwargs):
    """Render a batch, yielding each frame's result in frame order.

    Same parameters as :func:`render_batch`, plus ``window``: at most that
    many frames are in flight or held for reordering at once when images
    are returned from worker processes or Dask, which bounds memory for long
    animations streamed to a writer (default: as many as fit in 256 MiB of
    float32 images, and at least 4 tasks per Dask worker, 2 frames per
    process of a pool).

    Yields
    ------
    (H, W, 3) float32 ndarray or str
        The linear image, or the written path when ``out_dir`` is given.
    """
    options = _frame_options(options, dict(shading=shading, tone=tone, resume=resume), render_kwargs)
    check_counts(retries, frames_per_task, window)
    transfer = check_transfer(transfer)
    kind = check_executor(executor, workers, scheduler)
    if kind == "processes":
        kind = ProcessPool(workers, numba_threads=numba_threads)  # checks both; starts on the first frame
    if cache is not None and kind != "serial":
        raise ValueError("cache: only for runs in this process; each worker process has its own")
    if cache is not None and not isinstance(cache, SceneCache):
        raise TypeError(f"cache: expected a SceneCache, got {type(cache).__name__}")
    bases, jobs = plan_batch(scene_or_scenes, cameras, lights, out_dir=out_dir, pattern=pattern)
    check_shading_fits(options, bases)
    done = set()
    if out_dir is not None:
        os.makedirs(out_dir, exist_ok=True)
        remove_stale_temps(out_dir, [os.path.basename(j.path) for j in jobs])
        if options.resume:
            done = {j.index for j in jobs if os.path.exists(j.path)}
    bar = _progress_bar(progress, len(jobs), len(done), f"{_label(options.shading)} frames")
    try:
        if kind == "serial":
            yield from iter_serial(bases, jobs, done, options, SceneCache() if cache is None else cache, bar)
            return
        if isinstance(kind, ProcessPool):
            with contextlib.nullcontext(kind) if kind is executor else kind:  # a pool made here closes here
                yield from kind.run(bases, jobs, done, options, retries, window, bar)
            return
        from .cluster import connect
        from .dask_driver import iter_dask

        if workers is None and scheduler is None:
            workers = cores()  # executor="dask" alone: a local cluster, one worker per core
        with connect(workers, scheduler, numba_threads) as client, _spool_folder(transfer, client, out_dir) as spool:
            per_task = None if frames_per_task is None else int(frames_per_task)
            yield from iter_dask(client, bases, jobs, done, options, retries, window, per_task, bar, spool)
    finally:
        bar.close()


def render_batch(scene_or_scenes, cameras=None, lights=None, *, shading="phong", out_dir=None,
                 pattern: str = "frame_{:05d}.png", workers: int | None = None, scheduler=None,
                 progress: bool = True, retries: int = 2, resume: bool = True, tone: dict | None = None,
                 numba_threads: int | None = None, frames_per_task: int | None = None,
                 cache: SceneCache | None = None, transfer: str = "auto", executor="auto",
                 options: BatchOptions | None = None, **render_kwargs) -> list:
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
    shading : str or sequence of str
        ``"flat"``, ``"gouraud"``, ``"phong"`` or ``"auto"`` (any case), or
        one method per model, as in :func:`raycast_shade.render`.
    out_dir : str or path-like, optional
        Write frame ``i`` to ``out_dir / pattern.format(i)`` (the folder is
        created) instead of returning images.
    pattern : str
        Frame file name; the extension picks the format: ``.png``,
        ``.jpg``, ... (8-bit, tone-mapped with ``tone``), ``.pfm`` or
        ``.npy`` (linear float32).
    workers : int, optional
        Render in this many worker processes of this machine: a
        :class:`ProcessPool` (``executor="auto"`` or ``"processes"``), or a
        local Dask cluster (``executor="dask"``). Default with those: one
        per core.
    scheduler : str or distributed.Client, optional
        Render on an existing Dask cluster: its scheduler address
        (``"tcp://host:8786"``) or a connected client.
    progress : bool
        Show a tqdm progress bar (when tqdm is installed).
    retries : int
        Times a frame whose render raised is re-run (worker processes and
        Dask; this process raises at once). A frame whose worker died is
        re-run on another worker regardless (up to Dask's
        ``distributed.scheduler.allowed-failures``; 3 deaths on a pool).
    resume : bool
        With ``out_dir``: skip frames whose file exists.
    tone : dict, optional
        :func:`raycast_shade.to_uint8` options for 8-bit files:
        ``exposure``, ``tonemap``, ``gamma``.
    numba_threads : int, optional
        Numba threads per worker process of this machine (default: cores
        divided by workers).
    frames_per_task : int, optional
        Consecutive frames rendered by one Dask task. Each task costs about
        5 ms of CPU for scheduling and messages (``benchmarks/bench_batch.py``
        measures it); the default (None) groups frames into tasks of about
        4 megapixels (13 frames of 640x480, 1 of 1920x1080), keeping at
        least 4 tasks per worker.
    cache : SceneCache, optional
        The scene cache and counters of a run in this process (default: a
        new one per call); pass one to read its :meth:`~SceneCache.stats`
        or to share it between batches. On Dask each worker has its own:
        see :func:`worker_stats`.
    transfer : {"auto", "dask", "disk"}
        How images (not written frames) come back from Dask workers:
        ``"dask"`` through Dask's comms; ``"disk"`` through a temporary
        folder of this process (``tempfile``), which the workers must see;
        ``"auto"`` (default) the folder on a ``workers=`` or
        :func:`local_cluster` cluster, Dask's comms on any other.
    executor : {"auto", "serial", "processes", "dask"} or ProcessPool
        Where frames render. ``"serial"``: this process. ``"processes"``:
        a :class:`ProcessPool` of ``workers`` single-threaded processes,
        started for the batch (interpreter start and Numba cache load, about
        1-2 s) and stopped after it; pass a started pool to reuse one.
        ``"dask"``: a local Dask cluster of ``workers`` processes, or
        ``scheduler``'s. ``"auto"`` (default): Dask with ``scheduler``, the
        process pool with ``workers``, else this process.
    options : BatchOptions, optional
        How every frame renders (``shading``, the render keywords, ``tone``,
        ``resume``) in one object, checked as the keyword arguments are;
        those are then left out (one given too is refused; one at its
        default counts as not given).
    **render_kwargs
        ``backend``, ``interpolation``, ``caster``, ``max_depth``,
        ``tolerance`` of :func:`raycast_shade.render`.

    Returns
    -------
    list
        One entry per frame, in order: the (H, W, 3) float32 linear image,
        or with ``out_dir`` the path written (or found, when resumed).

    Raises
    ------
    TypeError, ValueError
        For a bad argument, naming it, before any frame renders.
    FrameError
        From worker processes: a frame's render raised ``retries + 1``
        times (its index, the exception's message and the worker's
        traceback; the exception itself as ``__cause__``), or its worker
        died 3 times. Dask raises the frame's exception itself.
    """
    return list(iter_batch(scene_or_scenes, cameras, lights, shading=shading, out_dir=out_dir, pattern=pattern,
                           workers=workers, scheduler=scheduler, progress=progress, retries=retries, resume=resume,
                           tone=tone, numba_threads=numba_threads, frames_per_task=frames_per_task, cache=cache,
                           transfer=transfer, executor=executor, options=options, **render_kwargs))


def _frame_options(options, given: dict, render_kwargs: dict) -> BatchOptions:
    """The checked frame options: of the keyword arguments, or of ``options`` (checked again, as a
    :class:`BatchOptions` made by hand is not), refusing a keyword argument given besides it."""
    if options is None:
        return check_options(given["shading"], render_kwargs, given["tone"], given["resume"])
    if not isinstance(options, BatchOptions):
        raise TypeError(f"options: expected a BatchOptions, got {type(options).__name__}")
    defaults = iter_batch.__kwdefaults__
    clash = [k for k, v in given.items() if v is not defaults[k]] + list(render_kwargs)
    if clash:
        raise ValueError(f"options: {clash[0]} is given both in options and as a keyword argument; "
                         "pass it in one place")
    if not isinstance(options.render_kwargs, dict):
        raise TypeError(f"options.render_kwargs: expected a dict, got {type(options.render_kwargs).__name__}")
    return check_options(options.shading, dict(options.render_kwargs), options.tone, options.resume)
