"""Running a planned batch in this process, frame after frame."""

from __future__ import annotations

from .cache import SceneCache, render_job
from .options import BatchOptions

__all__ = ["iter_serial"]


def iter_serial(bases: dict, jobs: list, done: set, options: BatchOptions, cache: SceneCache, bar):
    """Render ``jobs`` (except the ``done`` indices) here, with ``cache``.

    All frames of one mesh set share one packed geometry and one Embree BVH.

    Yields
    ------
    (H, W, 3) float32 ndarray or str
        Each frame's result, in frame order; a done frame yields its path.
    """
    for job in jobs:
        if job.index in done:
            yield job.path
            continue
        result = render_job(job, cache.base(job.key, bases[job.key]), options, cache)
        bar.update(1)
        yield result
