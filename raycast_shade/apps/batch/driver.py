"""The batch entry points: check everything, plan, then run in this process,
on a pool of processes of this machine, or on Dask."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile

from ...output.imagefile import check_output_folder, remove_stale_temps
from .cache import SceneCache
from .options import BatchOptions, check_options, check_shading_fits
from .plan import plan_batch
from .pool import ProcessPool, cores
from .run import EXECUTORS, LOCAL_EXECUTOR, RunOptions, check_executor, merge_keywords
from .serial import iter_serial

__all__ = ["iter_batch", "render_batch", "EXECUTORS", "LOCAL_EXECUTOR", "check_executor", "FLAT_RUN_KEYWORDS"]

# The execution options these functions took as keywords before RunOptions: old name -> its field.
FLAT_RUN_KEYWORDS = {**{k: k for k in ("workers", "scheduler", "progress", "retries", "resume", "numba_threads",
                                        "window", "transfer", "executor")}, "frames_per_task": "per_task"}


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


def iter_batch(scene_or_scenes, cameras=None, lights=None, *, shading="phong", out_dir=None,
               pattern: str = "frame_{:05d}.png", tone: dict | None = None, cache: SceneCache | None = None,
               options: BatchOptions | None = None, run: RunOptions | None = None, **render_kwargs):
    """Render a batch, yielding each frame's result in frame order.

    Same parameters as :func:`render_batch`; ``run.window`` matters most
    here: at most that many frames are in flight or held for reordering at
    once when images are returned from worker processes or Dask, which
    bounds memory for long animations streamed to a writer (default: as many
    as fit in 256 MiB of float32 images, and at least 4 tasks per Dask
    worker, 2 frames per process of a pool).

    Yields
    ------
    (H, W, 3) float32 ndarray or str
        The linear image, or the written path when ``out_dir`` is given.

    Examples
    --------
    >>> frames = iter_batch(scene, cams, run=RunOptions(workers=2, window=8))   # doctest: +SKIP
    """
    if out_dir is not None:  # a file in the way, an unwritable place: said before any frame renders
        out_dir = check_output_folder(out_dir, "out_dir")
    resume_given = run is not None or "resume" in render_kwargs
    run = merge_keywords(run, RunOptions, render_kwargs, FLAT_RUN_KEYWORDS, "run")
    options = _frame_options(options, dict(shading=shading, tone=tone), render_kwargs, run, resume_given)
    kind = check_executor(run.executor, run.workers, run.scheduler)
    if kind == "processes":
        kind = ProcessPool(run.workers, numba_threads=run.numba_threads)  # starts on the first frame
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
    bar = _progress_bar(run.progress, len(jobs), len(done), f"{_label(options.shading)} frames")
    try:
        if kind == "serial":
            yield from iter_serial(bases, jobs, done, options, SceneCache() if cache is None else cache, bar)
            return
        if isinstance(kind, ProcessPool):
            with contextlib.nullcontext(kind) if kind is run.executor else kind:  # a pool made here closes here
                yield from kind.run(bases, jobs, done, options, run.retries, run.window, bar)
            return
        from .cluster import connect
        from .dask_driver import iter_dask

        workers = run.workers
        if workers is None and run.scheduler is None:
            workers = cores()  # executor="dask" alone: a local cluster, one worker per core
        with connect(workers, run.scheduler, run.numba_threads) as client, \
                _spool_folder(run.transfer, client, out_dir) as spool:
            yield from iter_dask(client, bases, jobs, done, options, run.retries, run.window, run.per_task, bar,
                                 spool)
    finally:
        bar.close()


def render_batch(scene_or_scenes, cameras=None, lights=None, *, shading="phong", out_dir=None,
                 pattern: str = "frame_{:05d}.png", tone: dict | None = None, cache: SceneCache | None = None,
                 options: BatchOptions | None = None, run: RunOptions | None = None, **render_kwargs) -> list:
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
    tone : dict, optional
        :func:`raycast_shade.to_uint8` options for 8-bit files:
        ``exposure``, ``tonemap``, ``gamma``.
    cache : SceneCache, optional
        The scene cache and counters of a run in this process (default: a
        new one per call); pass one to read its :meth:`~SceneCache.stats`
        or to share it between batches. On Dask each worker has its own:
        see :func:`worker_stats`.
    options : BatchOptions, optional
        How every frame renders (``shading``, the render keywords, ``tone``,
        ``resume``) in one object, checked as the keyword arguments are;
        those are then left out (one given too is refused; one at its
        default counts as not given). Its ``resume`` is the run's unless
        ``run`` is given too, when the two must agree.
    run : RunOptions, optional
        Where and how the frames render: ``workers``, ``scheduler``,
        ``executor``, ``retries``, ``resume``, ``numba_threads``,
        ``per_task`` (frames per Dask task), ``progress``, ``window``,
        ``transfer`` (default: ``RunOptions()``, this process, with a
        progress bar). The flat keywords of earlier releases (``workers=2``,
        ``frames_per_task=4``, ...) still work for this release, with a
        ``DeprecationWarning``; one that disagrees with ``run`` is refused.
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

    Examples
    --------
    >>> images = render_batch(scene, cams, run=RunOptions(workers=2, retries=1))       # doctest: +SKIP
    >>> paths = render_batch(scene, cams, out_dir="frames", run=RunOptions(scheduler="tcp://host:8786",
    ...                                                                   per_task=8))  # doctest: +SKIP
    """
    return list(iter_batch(scene_or_scenes, cameras, lights, shading=shading, out_dir=out_dir, pattern=pattern,
                           tone=tone, cache=cache, options=options, run=run, **render_kwargs))


def _frame_options(options, given: dict, render_kwargs: dict, run: RunOptions, resume_given: bool) -> BatchOptions:
    """The checked frame options: of the keyword arguments and ``run.resume``, or of ``options`` (checked
    again, as a :class:`BatchOptions` made by hand is not), refusing a keyword argument given besides it
    and a ``resume`` that disagrees with a ``run`` given too."""
    if options is None:
        return check_options(given["shading"], render_kwargs, given["tone"], run.resume)
    if not isinstance(options, BatchOptions):
        raise TypeError(f"options: expected a BatchOptions, got {type(options).__name__}")
    defaults = iter_batch.__kwdefaults__
    clash = [k for k, v in given.items() if v is not defaults[k]] + list(render_kwargs)
    if clash:
        raise ValueError(f"options: {clash[0]} is given both in options and as a keyword argument; "
                         "pass it in one place")
    if not isinstance(options.render_kwargs, dict):
        raise TypeError(f"options.render_kwargs: expected a dict, got {type(options.render_kwargs).__name__}")
    checked = check_options(options.shading, dict(options.render_kwargs), options.tone, options.resume)
    if resume_given and checked.resume != run.resume:
        raise ValueError(f"options: resume={checked.resume} in options but {run.resume} in run; "
                         "pass it in one place (run.resume)")
    return checked
