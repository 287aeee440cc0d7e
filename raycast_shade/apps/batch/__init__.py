"""Batch rendering: many frames, in order, in this process, in worker processes or on Dask.

A batch is a list of scenes, or one scene with a list of cameras and/or a
list of light sets. Frames come back (or are written) in order.

* By default every frame renders in the current process, and all frames of
  one mesh set share one packed geometry and one Embree BVH
  (:mod:`.serial`).
* Where and how frames run is one record, ``run=RunOptions(...)``
  (:mod:`.run`). ``RunOptions(workers=N)`` renders in a :class:`ProcessPool`
  of ``N`` processes of this machine, each with ``cores // N`` Numba threads,
  scenes sent once and images back through shared memory (:mod:`.pool`);
  ``executor="dask"`` makes that a local Dask cluster instead.
  ``RunOptions(scheduler="tcp://host:8786")`` (or a :class:`distributed.Client`)
  uses an existing Dask cluster (:mod:`.cluster`, :mod:`.dask_driver`).
* Meshes travel once: the base scene of each mesh set is scattered to every
  worker, and a frame's task carries only its camera and lights
  (:mod:`.plan`). A worker builds the geometry and BVH on its first frame
  and keeps the scene in its :class:`SceneCache`, so later frames, and later
  batches over the same meshes, reuse them (:mod:`.cache`).
* Nothing is lost: with an output folder, frames already there are skipped
  (resume); every frame is written atomically
  (:func:`raycast_shade.output.imagefile.write_image` with ``atomic=True``);
  a frame whose worker dies is re-run on another worker, and a frame whose
  render raised is retried ``run.retries`` times.
* Options are checked once, as a scene file's ``[render]`` table is
  (:mod:`.options`): a batch accepts what the other front-ends accept.

>>> import raycast_shade as rs
>>> from raycast_shade.apps.animate import orbit_cameras
>>> scene = rs.Scene([rs.shapes.icosphere(2)], lights=[rs.PointLight((2, 3, 4), intensity=20)],
...                  camera=rs.Camera(eye=(0, 0, 4), width=32, height=24))
>>> images = render_batch(scene, cameras=orbit_cameras(scene.camera, 4), run=RunOptions(progress=False))
>>> len(images), images[0].shape
(4, (24, 32, 3))
"""

from .cache import SceneCache
from .cluster import local_cluster, reset_worker_stats, worker_stats
from .driver import iter_batch, render_batch
from .options import RENDER_KWARGS, BatchOptions
from .plan import FrameJob, plan_batch, scene_key
from .pool import FrameError, ProcessPool
from .run import RunOptions

__all__ = ["FrameJob", "ProcessPool", "FrameError", "BatchOptions", "RunOptions", "SceneCache", "render_batch",
           "iter_batch", "plan_batch", "local_cluster", "scene_key", "worker_stats", "reset_worker_stats",
           "RENDER_KWARGS"]
