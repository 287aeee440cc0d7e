"""Running a planned batch on a Dask cluster, frames yielded in order.

Meshes travel once: the base scene of each mesh set is scattered to every
worker, and a task carries only its frames' jobs. Every worker gets its
:class:`~.cache.SceneCache` from :class:`SceneCachePlugin`, which the client
registers (once: re-registering keeps the caches) and the scheduler hands on
to workers that join later, e.g. one restarted after a crash. A task whose
worker dies is re-run elsewhere by Dask; frames it had already written are
then skipped.

Imports :mod:`distributed`: loaded only for ``workers=`` or ``scheduler=``.
"""

from __future__ import annotations

import collections
import dataclasses
import uuid

from distributed import WorkerPlugin, as_completed, get_worker

from ...scene.scene import Scene
from .cache import PLUGIN_NAME, SceneCache, cache_of, render_job
from .options import BatchOptions
from .plan import FrameJob

__all__ = ["SceneCachePlugin", "iter_dask", "WINDOW_BYTES"]

WINDOW_BYTES = 256 << 20  # default bound on the images in flight or awaiting their turn


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
    already written are then skipped (see :func:`~.cache.render_job`)."""
    cache = cache_of(get_worker())
    if cache is None:  # pragma: no cover - iter_dask registers the plugin before submitting
        raise RuntimeError(f"worker plugin {PLUGIN_NAME!r} is not registered")
    base = cache.base(jobs[0].key, scene)
    return [render_job(_revalidated(job), base, options, cache) for job in jobs]


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
              frames_per_task: int, bar):
    """Render ``jobs`` (except the ``done`` indices) on ``client``'s cluster.

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
