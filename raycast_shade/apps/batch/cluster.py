"""Dask clusters for rendering: a local one, or a connection to an existing one,
and the per-worker counters of the batches run on them."""

from __future__ import annotations

import contextlib
import logging
import os
import warnings

from .cache import SceneCache, cache_of
from ...common.validate import as_count
from .options import cores

__all__ = ["local_cluster", "connect", "is_local", "match_numba_threads", "worker_stats", "reset_worker_stats"]


@contextlib.contextmanager
def local_cluster(n_workers: int, *, numba_threads: int | None = None, **cluster_kwargs):
    """A local Dask cluster for rendering, as a context manager yielding a Client.

    Workers are processes with one thread each (Numba's default threading
    layer is not safe under several Python threads of one process); their
    Numba kernels use ``numba_threads`` threads (default: ``cores //
    n_workers``, at least 1).

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
    n_workers = as_count(n_workers, "workers")
    if numba_threads is None:
        numba_threads = max(1, cores() // n_workers)
    numba_threads = as_count(numba_threads, "numba_threads")
    try:
        from distributed import Client, LocalCluster
    except ImportError as exc:
        raise ImportError("workers=: Dask is not installed; pip install 'raycast_shade[scale]'") from exc
    env = {"NUMBA_NUM_THREADS": str(numba_threads), "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1"}
    env.update(cluster_kwargs.pop("env", {}))
    kw = dict(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None,
              silence_logs=logging.ERROR, env=env)
    kw.update(cluster_kwargs)
    with warnings.catch_warnings():
        # The scheduler's HTTP server falls back to a free port when 8787 is taken (e.g. by another cluster).
        warnings.filterwarnings("ignore", message="Port .* is already in use", category=UserWarning)
        cluster = LocalCluster(**kw)
    with cluster, Client(cluster) as client:
        yield client


@contextlib.contextmanager
def connect(workers, scheduler, numba_threads):
    """A client: of a new local cluster of ``workers``, or of ``scheduler``
    (an address, or a Client used as it is)."""
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


def is_local(client) -> bool:
    """Whether ``client`` drives a :class:`distributed.LocalCluster`: workers on
    this machine, which see this process's temporary folder."""
    from distributed import LocalCluster

    return isinstance(getattr(client, "cluster", None), LocalCluster)


def match_numba_threads() -> int:
    """On a worker: make this thread's Numba kernels use ``NUMBA_NUM_THREADS`` threads.

    Numba reads ``NUMBA_NUM_THREADS`` once, when it is imported, and a spawned
    worker re-imports the client's ``__main__`` module before its nanny sets
    the variable: a script that imports raycast_shade at its top (or the
    ``raycast-shade`` command) gave every worker all the cores, so N workers
    ran N times as many threads as cores. :func:`numba.set_num_threads` is per
    thread, so this runs in the thread that renders, at the start of each task.

    Returns
    -------
    int
        The threads this thread's kernels use now.
    """
    import numba

    try:
        wanted = int(os.environ.get("NUMBA_NUM_THREADS", ""))
    except ValueError:
        return numba.get_num_threads()  # unset (or not a number): Numba's own choice stands
    wanted = max(1, min(wanted, numba.config.NUMBA_NUM_THREADS))  # cannot exceed the pool Numba launched
    if numba.get_num_threads() != wanted:
        numba.set_num_threads(wanted)
    return wanted


def _stats_on(dask_worker) -> dict:
    cache = cache_of(dask_worker)
    return (cache if cache is not None else SceneCache()).stats()


def _reset_on(dask_worker) -> None:
    cache = cache_of(dask_worker)
    if cache is not None:
        cache.reset_stats()


def worker_stats(client) -> dict:
    """Each worker's scene-cache counters.

    Parameters
    ----------
    client : distributed.Client

    Returns
    -------
    dict of str to dict
        Worker address to :meth:`SceneCache.stats` (all zero on a worker
        that has not rendered a batch yet).
    """
    return client.run(_stats_on)


def reset_worker_stats(client) -> None:
    """Zero every worker's counters (the cached scenes stay)."""
    client.run(_reset_on)
