"""Running a planned batch on a Dask cluster, frames yielded in order.

Meshes travel once: the base scene of each mesh set is scattered to every
worker, and a task carries only its frames' jobs. Every worker gets its
:class:`~.cache.SceneCache` from :class:`SceneCachePlugin`, which the client
registers (once: re-registering keeps the caches) and the scheduler hands on
to workers that join later, e.g. one restarted after a crash. A task whose
worker dies is re-run elsewhere by Dask; frames it had already written are
then skipped.

Images come back through Dask's comms, or, on a cluster of this machine,
through a temporary folder (``transfer="disk"``): a worker saves each image
as ``.npy`` and returns its path, the client loads and deletes it. Dask
pickles a returned image and sends it over TCP, which costs both processes
about 1.5 ms of CPU per MB (6 ms per 640x480 frame, on the same cores
that render); a file in the page cache costs a third of that.

Imports :mod:`distributed`: loaded only for ``workers=`` or ``scheduler=``.
"""

from __future__ import annotations

import collections
import os
import uuid

import numpy as np

from distributed import WorkerPlugin, as_completed, get_worker

from ...scene.scene import Scene
from .cache import PLUGIN_NAME, SceneCache, cache_of, render_job, revalidated
from .cluster import match_numba_threads
from .options import WINDOW_BYTES, BatchOptions
from .plan import FrameJob

__all__ = ["SceneCachePlugin", "iter_dask", "auto_frames_per_task", "WINDOW_BYTES", "TASK_PIXELS"]

# Pixels per task that frames_per_task=None aims at: about 0.25 s of one-thread rendering (20k triangles,
# Phong), so that the ~5 ms of CPU a task costs the client, scheduler and worker (benchmarks/bench_batch.py)
# stays near 2 %.
TASK_PIXELS = 4_000_000
TASKS_PER_WORKER = 4  # at least, when frames_per_task=None: the last tasks still balance over the workers


class SceneCachePlugin(WorkerPlugin):
    """Gives each worker its own :class:`~.cache.SceneCache` (``plugin.cache``).

    Parameters
    ----------
    size : int
        Mesh sets each worker holds at most.
    """

    idempotent = True  # registering it again (every batch does) keeps the workers' caches

    def __init__(self, size: int = 4):
        self.size = size
        self.cache = None

    def setup(self, worker):
        self.cache = SceneCache(self.size)

    def teardown(self, worker):
        self.cache = None


def _run_chunk_on_worker(jobs, scene: Scene, options: BatchOptions, spool: str | None = None) -> list:
    """The Dask task: consecutive frames of one mesh set; ``scene`` is its
    scattered base scene. With ``spool`` (a folder), each image is saved
    there and its path returned instead. Re-run whole if its worker dies;
    frames it had already written are then skipped (see
    :func:`~.cache.render_job`)."""
    match_numba_threads()
    cache = cache_of(get_worker())
    if cache is None:  # pragma: no cover - iter_dask registers the plugin before submitting
        raise RuntimeError(f"worker plugin {PLUGIN_NAME!r} is not registered")
    base = cache.base(jobs[0].key, scene)
    out = []
    for job in jobs:
        result = render_job(revalidated(job), base, options, cache)
        if spool is not None and job.path is None:
            result = _spool(spool, job.index, result)
        out.append(result)
    return out


def _spool(folder: str, index: int, image: np.ndarray) -> str:
    """Save frame ``index``'s image in ``folder``; its path."""
    path = os.path.join(folder, f"{index}.npy")
    np.save(path, image, allow_pickle=False)
    return path


def _unspool(path: str) -> np.ndarray:
    """The image a worker saved at ``path``, which is then deleted."""
    image = np.load(path, allow_pickle=False)
    os.remove(path)
    return image


def auto_frames_per_task(jobs, n_workers: int) -> int:
    """Frames per task for ``frames_per_task=None``: about :data:`TASK_PIXELS`
    pixels per task, and at least :data:`TASKS_PER_WORKER` tasks per worker."""
    if not jobs:
        return 1
    pixels = max(j.camera.width * j.camera.height for j in jobs)
    by_cost = max(1, TASK_PIXELS // max(1, pixels))
    by_balance = max(1, len(jobs) // (TASKS_PER_WORKER * max(1, n_workers)))
    return int(min(by_cost, by_balance))


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


def _window(window, jobs, n_workers: int, frames_per_task: int) -> int:
    """Frames in flight or held for reordering at most."""
    if window is None:
        if jobs and jobs[0].path is not None:
            window = len(jobs)  # results are paths: no memory to bound
        else:
            # Deep enough to hide the round trips, shallow enough to bound the images held.
            frame_bytes = max(1, max(j.camera.width * j.camera.height * 12 for j in jobs))
            window = max(4 * n_workers * frames_per_task, min(len(jobs), WINDOW_BYTES // frame_bytes))
    return max(int(window), frames_per_task)


def iter_dask(client, bases: dict, jobs: list, done: set, options: BatchOptions, retries: int, window,
              frames_per_task: int | None, bar, spool: str | None = None):
    """Render ``jobs`` (except the ``done`` indices) on ``client``'s cluster.

    ``frames_per_task=None`` picks :func:`auto_frames_per_task`. With
    ``spool``, a folder the workers and this process share, images come
    back through it (see the module docstring); the caller removes it.

    Yields
    ------
    (H, W, 3) float32 ndarray or str
        Each frame's result, in frame order; a done frame yields its path.
    """
    client.register_plugin(SceneCachePlugin(), name=PLUGIN_NAME)
    todo = [j for j in jobs if j.index not in done]
    scattered = {}
    for key in dict.fromkeys(j.key for j in todo):
        # One copy per worker, sent once; without its geometry (Scene.__getstate__).
        scattered[key] = client.scatter(bases[key], broadcast=True, hash=False)
    n_workers = max(1, len(client.scheduler_info().get("workers", {})))
    if frames_per_task is None:
        frames_per_task = auto_frames_per_task(todo, n_workers)
    window = _window(window, jobs, n_workers, frames_per_task)
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
            fut = client.submit(_run_chunk_on_worker, chunk, scattered[chunk[0].key], options, spool,
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
                result = results.pop(next_index)
                yield _unspool(result) if spool is not None and jobs[next_index].path is None else result
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
