"""Where and how a run executes: :class:`RunOptions`, the one record of the execution options.

:func:`~raycast_shade.apps.batch.render_batch`, :func:`~raycast_shade.apps.batch.iter_batch`,
:func:`~raycast_shade.apps.views.render_views` and :func:`~raycast_shade.apps.animate.animate`
take it as ``run=RunOptions(...)``; each field is checked once, when the record is made.
Their old flat keywords (``workers=``, ``retries=``, ``frames_per_task=``, ...) still work for
one release: :func:`merge_keywords` maps them onto the record with a ``DeprecationWarning``
naming the field (and onto :class:`~raycast_shade.apps.viewfiles.ViewFiles` for the view files).
"""

from __future__ import annotations

import dataclasses
import os
import sys
import warnings

from ...common.validate import as_bool, as_choice, as_count, as_instance
from .options import TRANSFERS
from .pool import ProcessPool

__all__ = ["RunOptions", "EXECUTORS", "LOCAL_EXECUTOR", "check_executor", "merge_keywords"]

EXECUTORS = ("auto", "serial", "processes", "dask")
# What executor="auto" runs for workers=N (the cores of this machine): the process pool, faster than
# Dask's LocalCluster and than this process on 2 cores from 640x480 up (benchmarks/bench_batch.py).
LOCAL_EXECUTOR = "processes"


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


def _check_scheduler(scheduler):
    """None, an address (a non-empty string) or a ``distributed.Client``."""
    if scheduler is None or isinstance(scheduler, str):
        if scheduler == "":
            raise ValueError("scheduler: an empty address; expected one like 'tcp://host:8786'")
        return scheduler
    try:  # only a non-string needs Dask to tell what it is
        from distributed import Client
    except ImportError:
        Client = ()
    return as_instance(scheduler, "scheduler", Client, "scheduler address like 'tcp://host:8786' or a Client")


@dataclasses.dataclass(frozen=True)
class RunOptions:
    """Where and how the frames (or views) of a run render: the execution options in one record.

    ``render_batch(scene, cams, run=RunOptions(workers=2, retries=1))``; the same record serves
    :func:`~raycast_shade.apps.batch.iter_batch`, :func:`~raycast_shade.apps.views.render_views`
    and :func:`~raycast_shade.apps.animate.animate`.

    Parameters
    ----------
    workers : int, optional
        Render in this many worker processes of this machine: a :class:`ProcessPool`
        (``executor="auto"`` or ``"processes"``), or a local Dask cluster (``executor="dask"``;
        :func:`~raycast_shade.apps.views.render_views` always uses Dask). Default: this process.
    scheduler : str or distributed.Client, optional
        Render on an existing Dask cluster: its scheduler address (``"tcp://host:8786"``) or a
        connected client. Not with ``workers``.
    executor : {"auto", "serial", "processes", "dask"} or ProcessPool
        Where frames render. ``"serial"``: this process. ``"processes"``: a
        :class:`ProcessPool` of ``workers`` single-threaded processes, started for the batch
        (interpreter start and Numba cache load, about 1-2 s) and stopped after it; pass a
        started pool to reuse one. ``"dask"``: a local Dask cluster of ``workers`` processes, or
        ``scheduler``'s. ``"auto"`` (default): Dask with ``scheduler``, the process pool with
        ``workers``, else this process. :func:`~raycast_shade.apps.views.render_views` takes
        ``"auto"`` (Dask with ``workers`` or ``scheduler``), ``"serial"`` or ``"dask"``.
    retries : int
        Times a frame whose render raised is re-run (worker processes and Dask; this process
        raises at once). A frame whose worker died is re-run on another worker regardless (up
        to Dask's ``distributed.scheduler.allowed-failures``; 3 deaths on a pool).
    resume : bool
        With an output folder: skip frames (views) already written.
    numba_threads : int, optional
        Numba threads per worker process of this machine (default: cores divided by workers).
    per_task : int, optional
        Consecutive frames (views) rendered by one Dask task: ``frames_per_task`` and
        ``views_per_task`` of earlier releases. Each task costs about 5 ms of CPU for scheduling
        and messages (``benchmarks/bench_batch.py``); the default (None) groups a batch's frames
        into tasks of about 4 megapixels (13 frames of 640x480, 1 of 1920x1080), keeping at
        least 4 tasks per worker, and gives a view set one view a task.
    progress : bool
        Show a tqdm progress bar (batches and animations, when tqdm is installed).
    window : int, optional
        At most this many frames in flight or held for reordering when images return from
        worker processes or Dask (:func:`~raycast_shade.apps.batch.iter_batch`; default: as many
        as fit in 256 MiB).
    transfer : {"auto", "dask", "disk"}
        How images (not written frames) come back from Dask workers: ``"dask"`` through Dask's
        comms; ``"disk"`` through a temporary folder of this process, which the workers must
        see; ``"auto"`` (default) the folder on a ``workers=`` or
        :func:`~raycast_shade.apps.batch.local_cluster` cluster, Dask's comms on any other.

    ``progress``, ``window`` and ``transfer`` are of batches and animations; a view set, whose
    workers write their files and return names, has no use for them.

    Raises
    ------
    TypeError, ValueError
        Naming the field, when the record is made (a float ``workers``, ``retries=-1``,
        ``executor="serial"`` with ``workers``, both ``workers`` and ``scheduler``, ...).
    """

    workers: int | None = None
    scheduler: object = None
    executor: object = "auto"
    retries: int = 2
    resume: bool = True
    numba_threads: int | None = None
    per_task: int | None = None
    progress: bool = True
    window: int | None = None
    transfer: str = "auto"

    def __post_init__(self):
        checked = dict(workers=as_count(self.workers, "workers", optional=True),
                       scheduler=_check_scheduler(self.scheduler),
                       retries=as_count(self.retries, "retries", minimum=0), resume=as_bool(self.resume, "resume"),
                       numba_threads=as_count(self.numba_threads, "numba_threads", optional=True),
                       per_task=as_count(self.per_task, "per_task", optional=True),
                       progress=as_bool(self.progress, "progress"),
                       window=as_count(self.window, "window", optional=True),
                       transfer=as_choice(self.transfer, "transfer", TRANSFERS))
        if checked["workers"] is not None and checked["scheduler"] is not None:
            raise ValueError("workers: give workers (a local cluster) or scheduler (an existing one), not both")
        check_executor(self.executor, checked["workers"], checked["scheduler"])
        checked["executor"] = self.executor if isinstance(self.executor, ProcessPool) else self.executor.lower()
        for name, value in checked.items():
            object.__setattr__(self, name, value)


def _caller_stacklevel() -> int:
    """The ``stacklevel`` of the first frame outside this package: the user's call, however many of
    our functions (or a generator's ``next``) lie between it and the warning."""
    package = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    frame, level = sys._getframe(1), 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package + os.sep):
        frame, level = frame.f_back, level + 1
    return level


def merge_keywords(record, cls, given: dict, names: dict, arg: str):
    """The record a front end runs with: ``record`` (a ``cls``, or None for ``cls()``) with the deprecated
    flat keywords of ``given`` (a ``**kwargs`` dict; those found are popped) mapped onto its fields.

    Parameters
    ----------
    record : cls or None
        What the caller passed as ``arg``.
    cls : type
        A frozen dataclass (:class:`RunOptions`, :class:`~raycast_shade.apps.viewfiles.ViewFiles`).
    given : dict
        The front end's ``**kwargs``; the keys of ``names`` are popped from it.
    names : dict
        Old flat keyword -> field of ``cls`` (``{"frames_per_task": "per_task", "workers": "workers"}``).
    arg : str
        The new keyword (``"run"``, ``"files"``), for the messages.

    Returns
    -------
    cls
        Checked by ``cls`` itself, once.

    Warns
    -----
    DeprecationWarning
        One per flat keyword found, naming the field that replaces it.

    Raises
    ------
    TypeError
        ``record`` is not a ``cls``.
    ValueError
        A flat keyword that disagrees with ``record``'s field (one that agrees only warns);
        and the record's own checks, naming the flat keyword where it was one.
    """
    if record is not None:
        as_instance(record, arg, cls)
    flat = {old: given.pop(old) for old in list(given) if old in names}
    if not flat:
        return cls() if record is None else record
    for old in flat:
        field = names[old]
        warnings.warn(f"{old}= is deprecated and will be removed in the next release; pass "
                      f"{arg}={cls.__name__}({field}=...) instead", DeprecationWarning, stacklevel=_caller_stacklevel())
    base = cls() if record is None else record
    try:
        merged = dataclasses.replace(base, **{names[old]: v for old, v in flat.items()})
    except (TypeError, ValueError) as exc:
        message = str(exc)
        for old in flat:  # name what the caller wrote, and where it goes now
            field = names[old]
            if old != field and message.startswith(field + ":"):
                raise type(exc)(f"{old} ({arg}.{field}){message[len(field):]}") from None
        raise
    if record is not None:
        for old in flat:
            field = names[old]
            if getattr(merged, field) != getattr(record, field):
                raise ValueError(f"{arg}: {old}={flat[old]!r} is given besides {arg}.{field}="
                                 f"{getattr(record, field)!r}; pass it in one place ({arg}.{field})")
    return merged
