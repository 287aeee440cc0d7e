"""The scene cache of one process, its counters, and rendering one frame with it.

A Dask worker receives each base scene without its geometry (see
``Scene.__getstate__``), builds the geometry and BVH on its first frame, and
keeps the scene in a :class:`SceneCache` keyed by the content hash of the
models: later frames, and later batches over the same meshes, reuse them.
A worker's cache is created by the batch's worker plugin (see
:mod:`.dask_driver`) and found with :func:`cache_of`; a serial run owns one.
"""

from __future__ import annotations

import collections
import dataclasses
import os
import threading

import numpy as np

from ...output.imagefile import write_image
from ...render import render
from ...scene.scene import Scene
from ...visibility.accel import embree_accel
from .options import BatchOptions
from .plan import FrameJob

__all__ = ["SceneCache", "PLUGIN_NAME", "cache_of", "render_image", "render_job", "revalidated"]

# Name of the Dask worker plugin that holds a worker's SceneCache.
PLUGIN_NAME = "raycast-shade-batch"
COUNTERS = ("builds", "renders", "skipped")


class SceneCache:
    """Base scenes by content key (least recently used dropped first) and counters.

    Parameters
    ----------
    size : int
        Mesh sets held at most.

    Notes
    -----
    Thread-safe: on a Dask worker, tasks run in its executor thread while
    ``client.run`` calls (:func:`worker_stats`) run in its event loop.
    """

    def __init__(self, size: int = 4):
        from ...common.validate import as_count

        self.size = as_count(size, "size")
        self._scenes: collections.OrderedDict = collections.OrderedDict()
        self._counts = dict.fromkeys(COUNTERS, 0)
        self._lock = threading.Lock()

    def base(self, key: str, scene: Scene) -> Scene:
        """The scene held for ``key``, else ``scene``, which is then held."""
        with self._lock:
            base = self._scenes.get(key)
            if base is None:
                base = self._scenes[key] = scene
                while len(self._scenes) > self.size:
                    self._scenes.popitem(last=False)
            else:
                self._scenes.move_to_end(key)
            return base

    def count(self, name: str) -> None:
        """Add one to counter ``name`` (one of ``builds``, ``renders``, ``skipped``)."""
        with self._lock:
            self._counts[name] += 1

    def stats(self) -> dict:
        """``builds`` (geometry + BVH builds), ``renders``, ``skipped`` (frames
        found written by an earlier attempt) and ``cached`` (mesh sets held)."""
        with self._lock:
            return dict(self._counts, cached=len(self._scenes))

    def reset_stats(self) -> None:
        """Zero the counters; the scenes stay."""
        with self._lock:
            self._counts = dict.fromkeys(COUNTERS, 0)


def cache_of(worker) -> SceneCache | None:
    """The SceneCache the batch plugin gave a Dask worker, or None before any batch."""
    plugin = worker.plugins.get(PLUGIN_NAME)
    return None if plugin is None else plugin.cache


def render_image(job: FrameJob, base: Scene, options: BatchOptions, cache: SceneCache, out=None) -> np.ndarray:
    """Render one job on its base scene, reusing (or building once) its geometry.

    ``out``, an (H, W, 3) float32 array, receives the image (``render(out=)``).

    Returns
    -------
    (H, W, 3) float32
        ``out`` when given.
    """
    if not base.has_geometry:
        cache.count("builds")
    geometry = base.geometry  # packs once; Scene.replace below shares it
    if options.render_kwargs.get("caster", "auto") != "embreex" and options.render_kwargs.get("backend") != "raster":
        embree_accel(geometry)  # the BVH, built once per process and mesh set
    scene = base.replace(lights=job.lights, camera=job.camera, ambient=job.ambient, background=job.background)
    frame = render(scene, options.shading, camera=job.camera, out=out, **options.render_kwargs)
    cache.count("renders")
    return frame.image


def render_job(job: FrameJob, base: Scene, options: BatchOptions, cache: SceneCache):
    """The image of one job, or with ``job.path`` the path written (or found, when resumed)."""
    if job.path is not None and options.resume and os.path.exists(job.path):
        cache.count("skipped")
        return job.path  # written by an earlier attempt (e.g. on a worker that died afterwards)
    image = render_image(job, base, options, cache)
    if job.path is None:
        return image
    return write_image(job.path, image, atomic=True, **options.tone)


def revalidated(job: FrameJob) -> FrameJob:
    """The job with its camera and lights rebuilt by their constructors.

    Unpickled arrays lose their read-only flag, and Numba compiles (and
    caches) a separate specialisation of every kernel for writeable arrays:
    without this, each worker process would compile the whole renderer
    again instead of loading the client's cache. The constructors mark the
    validated arrays read-only again (ambient and background go through
    :meth:`Scene.replace`, which does the same).
    """
    return dataclasses.replace(job, camera=dataclasses.replace(job.camera),
                               lights=tuple(dataclasses.replace(light) for light in job.lights))
