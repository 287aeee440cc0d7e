"""A pool of single-threaded renderer processes on this machine (``executor="processes"``).

Each worker is a fresh interpreter (``sys.executable -c ...``, a spawn: the
client, which may have started Numba's threads, is never forked) whose
environment sets ``NUMBA_NUM_THREADS`` (1 when there is one worker per
core) before it imports anything. :mod:`multiprocessing`'s ``spawn`` context
cannot do that: its children inherit this process's environment and re-run
the caller's ``__main__``, which may import Numba before a target could set
the variable.

Client and worker talk over one socket pair (a
:class:`multiprocessing.connection.Connection`): each mesh set's base scene is
pickled once per batch and sent once to every worker, which keeps it in its
:class:`~.cache.SceneCache`; a frame travels as its :class:`~.plan.FrameJob`
(about 1 kB). A worker renders with :func:`~.cache.render_job` /
:func:`~.cache.render_image`, the functions the serial and Dask paths run, so
frames are the same bit for bit. A
written frame (``out_dir``) is written by the worker, and only its path
comes back; an image is rendered straight into one of the worker's two
shared-memory slots (``render(out=)``;
:class:`multiprocessing.shared_memory.SharedMemory`, created and unlinked by
the client), and the client copies it out, so nothing as large
as an image is pickled. Two jobs per worker are in flight: one rendering,
one waiting, so a worker never waits for the client.

Failures: a frame whose render raised is re-run ``retries`` times, then
:class:`FrameError` names it; a worker that dies is replaced and its frames
re-run, up to :data:`ALLOWED_FAILURES` deaths per frame. Closing the pool
(also on an error or ``KeyboardInterrupt``) stops every worker, kills one
that does not stop, and unlinks the shared memory.
"""

from __future__ import annotations

import heapq
import os
import pickle
import socket
import subprocess
import sys
import time
import traceback
from dataclasses import dataclass, field
from multiprocessing import connection, shared_memory

import numpy as np

from .cache import SceneCache, render_image, render_job, revalidated
from ...common.validate import as_count
from .options import WINDOW_BYTES, BatchOptions, cores

__all__ = ["ProcessPool", "FrameError", "ALLOWED_FAILURES", "cores", "worker_main"]

ALLOWED_FAILURES = 3  # deaths of a frame's worker before the frame fails (Dask's allowed-failures default)
SLOTS = 2  # jobs in flight per worker, each with its own shared-memory slot
STOP_SECONDS = 10.0  # a stopping worker finishes its frame; past this it is killed


class FrameError(RuntimeError):
    """A frame failed in a worker process: its render raised ``retries + 1``
    times, or its worker died :data:`ALLOWED_FAILURES` times.

    Attributes
    ----------
    index : int
        The frame.
    """

    def __init__(self, index: int, message: str):
        super().__init__(f"frame {index}: {message}")
        self.index = index


# -- the worker ------------------------------------------------------------------------------------------


def _attach(name: str) -> shared_memory.SharedMemory:
    """Open the client's segment without letting this process's resource
    tracker unlink it when the worker exits (the client owns it)."""
    if sys.version_info >= (3, 13):
        return shared_memory.SharedMemory(name, track=False)
    from multiprocessing import resource_tracker

    shm = shared_memory.SharedMemory(name)
    resource_tracker.unregister(shm._name, "shared_memory")  # noqa: SLF001 - the documented pre-3.13 way
    return shm


def _error_reply(index: int, exc: BaseException) -> tuple:
    try:
        blob = pickle.dumps(exc)
        pickle.loads(blob)
    except Exception:  # noqa: BLE001 - an exception that does not travel still has its message
        blob = None
    return ("error", index, blob, f"{type(exc).__name__}: {exc}", traceback.format_exc())


def _render(job, slot, batch: dict, cache: SceneCache, segments: dict) -> tuple:
    """The reply for one job: its path, or its image copied into ``slot``."""
    view = None
    try:
        base = cache.base(job.key, batch["scenes"][job.key])
        job = revalidated(job)
        if job.path is not None:
            return ("done", job.index, render_job(job, base, batch["options"], cache))
        shm = segments.get(slot)
        if shm is None:
            shm = segments[slot] = _attach(slot)
        # Render straight into the slot: no copy on this side.
        view = np.ndarray((job.camera.height, job.camera.width, 3), np.float32, buffer=shm.buf)
        image = render_image(job, base, batch["options"], cache, out=view)
        return ("done", job.index, (image.shape, image.dtype.str))
    except Exception as exc:  # noqa: BLE001 - reported to the client with the frame's index
        return _error_reply(job.index, exc)
    finally:
        del view  # a live view would keep the segment from closing


def worker_main(fd: int) -> None:
    """A worker process's loop over its end of the socket pair ``fd``.

    Messages in: ``("batch", options, pickled scenes, kept keys, slots)``,
    ``("job", job, slot)``, ``("stop",)``. Out: ``("ready", pid)``, then one
    ``("done", index, path or (shape, dtype))`` or ``("error", index,
    pickled exception, message, traceback)`` per job. Returns on ``stop``,
    or when the client has gone (its end closed).
    """
    from .cluster import match_numba_threads

    conn = connection.Connection(fd)
    cache = SceneCache()
    batch = {"scenes": {}, "options": None}
    segments = {}
    try:
        match_numba_threads()
        conn.send(("ready", os.getpid()))
        while True:
            msg = conn.recv()
            if msg[0] == "stop":
                return
            if msg[0] == "batch":
                _, options, blob, keep, slots = msg
                scenes = {k: v for k, v in batch["scenes"].items() if k in keep}
                scenes.update(pickle.loads(blob))
                batch = {"scenes": scenes, "options": options}
                for name in [n for n in segments if n not in slots]:
                    segments.pop(name).close()
            else:
                _, job, slot = msg
                conn.send(_render(job, slot, batch, cache, segments))
    except (EOFError, OSError, KeyboardInterrupt):
        return  # the client has gone or is stopping everything: nothing to report to
    finally:
        for shm in segments.values():
            shm.close()
        conn.close()


# -- the client ------------------------------------------------------------------------------------------


@dataclass(eq=False)
class _Worker:
    proc: subprocess.Popen
    conn: connection.Connection
    pid: int = 0
    scenes: set = field(default_factory=set)  # keys of the base scenes it holds
    busy: dict = field(default_factory=dict)  # slot -> the job sent with it
    slots: list = field(default_factory=list)


def _package_root() -> str:
    return os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


def _spawn(numba_threads: int) -> _Worker:
    """Start one worker process; it is ready once it has sent ``("ready", pid)``."""
    ours, theirs = socket.socketpair()
    path = os.environ.get("PYTHONPATH")
    env = dict(os.environ, NUMBA_NUM_THREADS=str(numba_threads), OMP_NUM_THREADS="1", MKL_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=_package_root() + (os.pathsep + path if path else ""))  # this very package
    code = f"from raycast_shade.apps.batch.pool import worker_main; worker_main({theirs.fileno()})"
    try:
        proc = subprocess.Popen([sys.executable, "-c", code], env=env, pass_fds=(theirs.fileno(),),
                                stdin=subprocess.DEVNULL)
    except BaseException:
        ours.close()
        raise
    finally:
        theirs.close()
    return _Worker(proc, connection.Connection(ours.detach()))


def _stop(workers, graceful: bool) -> None:
    """Stop ``workers``: ask, wait (``graceful``) or terminate, kill what remains, reap all."""
    for w in workers:
        try:
            if graceful:
                w.conn.send(("stop",))
            else:
                w.proc.terminate()
        except (OSError, ValueError):
            pass
        w.conn.close()
    deadline = time.monotonic() + (STOP_SECONDS if graceful else 2.0)
    for w in workers:
        try:
            w.proc.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            w.proc.kill()
            w.proc.wait()


class ProcessPool:
    """Single-threaded renderer processes on this machine, for
    :func:`~raycast_shade.apps.batch.render_batch` (``run=RunOptions(executor=pool)``).

    ``render_batch(..., run=RunOptions(executor="processes", workers=N))`` starts one for the batch and
    closes it afterwards; start one yourself (a context manager) to keep the
    workers, their JIT-loaded kernels and their scene caches across batches.

    Parameters
    ----------
    workers : int, optional
        Processes (default: one per core).
    numba_threads : int, optional
        ``NUMBA_NUM_THREADS`` of each worker (default: cores // workers, at
        least 1).

    Examples
    --------
    >>> with ProcessPool(2) as pool:                          # doctest: +SKIP
    ...     images = render_batch(scene, cams, run=RunOptions(executor=pool))
    """

    def __init__(self, workers: int | None = None, *, numba_threads: int | None = None):
        self.n_workers = cores() if workers is None else as_count(workers, "workers")
        default = max(1, cores() // self.n_workers)
        self.numba_threads = default if numba_threads is None else as_count(numba_threads, "numba_threads")
        self._workers: list = []
        self._running = False  # a batch is under way (one at a time)
        self._batch = None  # (bases, todo, options) of the batch under way, for a replaced worker

    def __enter__(self) -> "ProcessPool":
        self.start()
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close(graceful=exc_type is None)

    @property
    def pids(self) -> list:
        """Process ids of the live workers."""
        return [w.pid for w in self._workers]

    def start(self) -> "ProcessPool":
        """Start the workers (all at once) and wait until each has imported the renderer."""
        if self._workers:
            return self
        try:
            self._workers = [_spawn(self.numba_threads) for _ in range(self.n_workers)]
            for w in self._workers:
                self._handshake(w)
        except BaseException:
            self.close(graceful=False)
            raise
        return self

    @staticmethod
    def _handshake(w: _Worker) -> None:
        try:
            kind, pid = w.conn.recv()
        except (EOFError, OSError):
            code = w.proc.wait()
            raise RuntimeError(f"executor: a worker process exited at start-up (exit code {code}); "
                               "its error is on stderr above") from None
        if kind != "ready":  # pragma: no cover - a protocol error
            raise RuntimeError(f"executor: a worker process said {kind!r} at start-up")
        w.pid = pid

    def close(self, graceful: bool = True) -> None:
        """Stop every worker (``graceful``: after its current frame; else at once)."""
        workers, self._workers = self._workers, []
        _stop(workers, graceful)

    def _replace(self, dead: _Worker) -> _Worker:
        """A new worker in ``dead``'s place, with its slots."""
        _stop([dead], graceful=False)
        new = _spawn(self.numba_threads)
        self._handshake(new)
        new.slots = dead.slots
        self._workers[self._workers.index(dead)] = new
        if self._batch is not None:
            self._send_batch(*self._batch, workers=[new])
        return new

    def run(self, bases: dict, jobs: list, done: set, options: BatchOptions, retries: int, window, bar):
        """Render ``jobs`` (except the ``done`` indices) on the workers.

        Yields
        ------
        (H, W, 3) float32 ndarray or str
            Each frame's result, in frame order; a done frame yields its path.

        Raises
        ------
        FrameError
            For a frame that failed ``retries + 1`` times or whose workers died.
        """
        if self._running:
            raise RuntimeError("executor: this ProcessPool is already running a batch")
        self.start()
        todo = [j for j in jobs if j.index not in done]
        slot_bytes = max([12 * j.camera.width * j.camera.height for j in todo if j.path is None], default=0)
        segments = []
        self._running = True
        try:
            for w in self._workers:
                w.slots = [f"s{i}" for i in range(SLOTS)]
                if slot_bytes:
                    for i in range(SLOTS):
                        segments.append(shared_memory.SharedMemory(create=True, size=slot_bytes))
                        w.slots[i] = segments[-1].name
            for w in [w for w in self._workers if w.proc.poll() is not None]:
                self._replace(w)  # died since the last batch
            self._send_batch(bases, todo, options)
            run = _Run(self, todo, retries, _window(window, todo, self.n_workers), bar,
                       {s.name: s for s in segments})
            yield from run.iterate(jobs, done)
        except BaseException:
            self.close(graceful=False)  # stop the frames in flight now; the next batch starts afresh
            raise
        finally:
            self._running, self._batch = False, None
            for shm in segments:
                shm.close()
                shm.unlink()

    def _send_batch(self, bases: dict, todo: list, options: BatchOptions, workers=None) -> None:
        """Each worker's batch message: the options, the base scenes it lacks, its slots."""
        self._batch = (bases, todo, options)
        keys = list(dict.fromkeys(j.key for j in todo))
        blobs = {}  # pickled once for all the workers that lack the same scenes
        for w in list(self._workers) if workers is None else workers:
            new = tuple(k for k in keys if k not in w.scenes)
            if new not in blobs:  # without geometry (Scene.__getstate__)
                blobs[new] = pickle.dumps({k: bases[k] for k in new}, protocol=pickle.HIGHEST_PROTOCOL)
            try:
                w.conn.send(("batch", options, blobs[new], keys, w.slots))
            except (BrokenPipeError, ConnectionResetError):
                # Killed after run()'s liveness check: replaced, and the replacement gets this batch.
                self._replace(w)
                continue
            w.scenes = set(keys)


def _window(window, todo: list, n_workers: int) -> int:
    """Frames in flight or held for reordering at most (as :mod:`.dask_driver`'s)."""
    if window is not None:
        return max(1, int(window))
    if not todo or todo[0].path is not None:
        return max(1, len(todo))  # results are paths: no memory to bound
    frame_bytes = max(1, max(12 * j.camera.width * j.camera.height for j in todo))
    return max(SLOTS * n_workers, min(len(todo), WINDOW_BYTES // frame_bytes))


class _Run:
    """One batch on a started pool: dispatch jobs, collect replies, yield in frame order."""

    def __init__(self, pool: ProcessPool, todo: list, retries: int, window: int, bar, segments: dict):
        self.pool, self.retries, self.window, self.bar, self.segments = pool, int(retries), window, bar, segments
        self.queue = [(j.index, j) for j in todo]  # a heap: re-run frames go back in frame order
        self.held = {}  # frame -> result, waiting for its turn
        self.in_flight = 0
        self.raised = {}  # frame -> times its render raised
        self.deaths = {}  # frame -> times its worker died

    def iterate(self, jobs: list, done: set):
        for job in jobs:
            if job.index in done:
                yield job.path
                continue
            while job.index not in self.held:
                self._dispatch(job.index)
                self._collect()
            yield self.held.pop(job.index)

    def _dispatch(self, next_index: int) -> None:
        """Fill the free slots, within the window; the frame due next always goes."""
        for w in self.pool._workers:
            for slot in w.slots:
                if not self.queue:
                    return
                if slot in w.busy:
                    continue
                if self.in_flight + len(self.held) >= self.window and self.queue[0][0] != next_index:
                    return
                _, job = heapq.heappop(self.queue)
                w.busy[slot] = job
                self.in_flight += 1
                try:
                    w.conn.send(("job", job, slot))
                except OSError:  # it died since its last reply
                    self._died(w)
                    return

    def _collect(self) -> None:
        """Wait for replies (at least one) and take them in."""
        by_conn = {w.conn: w for w in self.pool._workers if w.busy}
        if not by_conn:  # pragma: no cover - the frame due next is always queued or in flight
            raise RuntimeError("executor: no frame in flight")
        for conn in connection.wait(list(by_conn)):
            w = by_conn[conn]
            try:
                reply = conn.recv()
            except (EOFError, OSError):
                self._died(w)
                continue
            slot = next(s for s, j in w.busy.items() if j.index == reply[1])
            job = w.busy.pop(slot)
            self.in_flight -= 1
            if reply[0] == "done":
                self.held[job.index] = self._take(reply[2], slot)
                self.bar.update(1)
            else:
                self._failed(job, *reply[2:])

    def _take(self, payload, slot: str):
        if isinstance(payload, str):
            return payload
        shape, dtype = payload
        view = np.ndarray(shape, np.dtype(dtype), buffer=self.segments[slot].buf)
        image = view.copy()
        del view  # the segment cannot close while a view exists
        return image

    def _failed(self, job, blob, message: str, tb: str) -> None:
        n = self.raised[job.index] = self.raised.get(job.index, 0) + 1
        if n <= self.retries:
            heapq.heappush(self.queue, (job.index, job))
            return
        cause = None if blob is None else pickle.loads(blob)
        tries = f" ({n} attempts)" if n > 1 else ""
        raise FrameError(job.index, f"{message}{tries}\n\nworker traceback:\n{tb}") from cause

    def _died(self, w: _Worker) -> None:
        code = w.proc.poll()
        for job in w.busy.values():
            n = self.deaths[job.index] = self.deaths.get(job.index, 0) + 1
            if n >= ALLOWED_FAILURES:
                raise FrameError(job.index, f"its worker process died {n} times (last exit code {code})")
            heapq.heappush(self.queue, (job.index, job))
            self.in_flight -= 1
        w.busy.clear()
        self.pool._replace(w)
