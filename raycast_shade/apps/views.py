"""Data sets of views: one file set per camera, plus an index of cameras and files.

``render_views(scene, cameras, out_dir, buffers=[...])`` renders every view
on the batch machinery (:mod:`raycast_shade.apps.batch`: planning, one base
scene per mesh set, the scene cache; serially, on a local Dask cluster with
``workers=N``, or on ``scheduler=address``) and writes, per view ``i``:

* ``view_{i:05d}.png``: the tone-mapped image (``image=".png"``; or
  ``.pfm``/``.npy`` linear, or None for none);
* ``view_{i:05d}.npz``: the buffers, the linear image and ``K, R, t``
  (``formats`` holds ``"npz"``);
* ``view_{i:05d}.exr``: the buffers and the linear image (``"exr"``);
* ``view_{i:05d}_depth.png``: 16-bit z-depth in millimetres (``"depth_png"``);

and ``index.json``: per view its ``K``, ``R``, ``t`` (OpenCV's convention),
size, projection and files. Each file is written atomically; a view whose
files all exist is skipped (resume), so an interrupted run, run again,
finishes the set. Only one view's buffers are in memory per worker at a
time, and the client holds paths, so memory stays flat in the number of
views.
"""

from __future__ import annotations

import dataclasses
import json
import os

from ..common.validate import as_int, as_scalar
from ..output.bufferfile import save_npz, write_depth_png, write_exr
from ..output.buffers import check_buffers
from ..output.imagefile import atomic_target, check_image_path, remove_stale_temps, write_image
from ..render import render
from .batch.cache import PLUGIN_NAME, SceneCache, cache_of
from .batch.options import check_options
from .batch.plan import plan_batch

__all__ = ["render_views", "FORMATS", "INDEX_NAME", "view_files", "register_cli", "run_cli"]

FORMATS = ("npz", "exr", "depth_png")
INDEX_NAME = "index.json"
_STEM = "view_{:05d}"


def _check_formats(formats) -> tuple:
    if isinstance(formats, str):
        formats = [f for f in formats.split(",") if f.strip()]
    out = []
    for f in formats:
        key = str(f).strip().lower()
        if key not in FORMATS:
            raise ValueError(f"formats: unknown format {f!r}; expected some of {', '.join(FORMATS)}")
        out.append(key)
    return tuple(dict.fromkeys(out))


def view_files(index: int, formats, image) -> dict:
    """File names (no folder) of view ``index``, by kind (``image``, ``npz``, ``exr``, ``depth_png``)."""
    stem = _STEM.format(index)
    files = {} if image is None else {"image": stem + image}
    for f in formats:
        files[f] = stem + ("_depth.png" if f == "depth_png" else "." + f)
    return files


@dataclasses.dataclass(frozen=True, eq=False)
class _ViewSpec:
    """What every view task needs besides its job: checked options and outputs."""

    options: object
    buffers: tuple
    formats: tuple
    image: str | None
    out_dir: str
    depth_scale: float


def _write_view(job, base, spec: _ViewSpec, cache: SceneCache) -> str:
    """Render and write one view (unless all its files exist); returns its stem."""
    files = {k: os.path.join(spec.out_dir, v) for k, v in view_files(job.index, spec.formats, spec.image).items()}
    if spec.options.resume and all(os.path.exists(p) for p in files.values()):
        cache.count("skipped")
        return _STEM.format(job.index)
    if "geometry" not in base.__dict__:
        cache.count("builds")
    scene = base.replace(lights=job.lights, camera=job.camera, ambient=job.ambient, background=job.background)
    buffers = spec.buffers + (("zdepth",) if "depth_png" in spec.formats and "zdepth" not in spec.buffers else ())
    frame = render(scene, spec.options.shading, camera=job.camera, buffers=buffers, **spec.options.render_kwargs)
    cache.count("renders")
    kept = {k: v for k, v in frame.buffers.items() if k in spec.buffers}
    if "image" in files:
        write_image(files["image"], frame.image, atomic=True, **spec.options.tone)
    if "npz" in files:
        save_npz(files["npz"], kept, image=frame.image, camera=job.camera, atomic=True)
    if "exr" in files:
        write_exr(files["exr"], kept, image=frame.image, atomic=True)
    if "depth_png" in files:
        write_depth_png(files["depth_png"], frame.buffers["zdepth"], scale=spec.depth_scale, atomic=True)
    return _STEM.format(job.index)


def _run_on_worker(jobs, scene, spec: _ViewSpec) -> list:
    """The Dask task: a few views of one mesh set, with the worker's scene cache."""
    from distributed import get_worker

    from .batch.cluster import match_numba_threads

    match_numba_threads()  # NUMBA_NUM_THREADS of the worker, even if Numba was imported before it was set
    cache = cache_of(get_worker())
    if cache is None:  # pragma: no cover - _iter_dask registers the plugin first
        raise RuntimeError(f"worker plugin {PLUGIN_NAME!r} is not registered")
    base = cache.base(jobs[0].key, scene)
    # Rebuilt cameras and lights are read-only again: the workers load the cached kernels.
    jobs = [dataclasses.replace(j, camera=dataclasses.replace(j.camera),
                                lights=tuple(dataclasses.replace(light) for light in j.lights)) for j in jobs]
    return [_write_view(job, base, spec, cache) for job in jobs]


def _iter_dask(client, bases, todo, spec, retries, per_task):
    from distributed import as_completed

    from .batch.dask_driver import SceneCachePlugin

    client.register_plugin(SceneCachePlugin(), name=PLUGIN_NAME)
    scattered = {key: client.scatter(bases[key], broadcast=True, hash=False) for key in dict.fromkeys(j.key for j in todo)}
    n_workers = max(1, len(client.scheduler_info().get("workers", {})))
    chunks = [todo[i:i + per_task] for i in range(0, len(todo), per_task)]
    chunks = [c for chunk in chunks for c in _split_by_key(chunk)]
    window = 4 * n_workers  # tasks in flight: results are names, but futures cost the scheduler memory
    pending = iter(chunks)
    ready = as_completed()
    live = []
    try:
        for chunk in pending:
            fut = client.submit(_run_on_worker, chunk, scattered[chunk[0].key], spec, retries=int(retries),
                                pure=False, priority=-chunk[0].index)
            ready.add(fut)
            live.append(fut)
            if ready.count() >= window:
                done = next(ready)
                yield from done.result()
                live.remove(done)
        for done in ready:
            yield from done.result()
            live.remove(done)
    finally:
        if live:
            client.cancel(live)
        for fut in scattered.values():
            fut.release()


def _split_by_key(chunk):
    out = []
    for job in chunk:
        if out and out[0].key != job.key:
            yield out
            out = []
        out.append(job)
    if out:
        yield out


def _index_entry(job, files) -> dict:
    K, R, t = job.camera.to_opencv()
    cam = job.camera
    return {"index": job.index, "width": cam.width, "height": cam.height, "projection": cam.projection,
            "K": K.tolist(), "R": R.tolist(), "t": t.tolist(), "files": files}


def render_views(scene, cameras, out_dir, *, buffers=("zdepth", "normal", "id", "mask"), formats=("npz",),
                 image: str | None = ".png", shading="phong", workers: int | None = None, scheduler=None,
                 resume: bool = True, tone: dict | None = None, retries: int = 2, views_per_task: int = 1,
                 numba_threads: int | None = None, depth_scale: float = 1000.0, **render_kwargs) -> str:
    """Render a set of views with their buffers and cameras into ``out_dir``.

    Parameters
    ----------
    scene : Scene
    cameras : sequence of Camera
        One per view.
    out_dir : str or path-like
        Created if need be.
    buffers : sequence of str
        Buffer names (:mod:`raycast_shade.output.buffers`).
    formats : sequence of {"npz", "exr", "depth_png"}
        Buffer files per view (see the module docstring).
    image : {".png", ".pfm", ".npy", ...} or None
        Extension of the per-view image file, or None for none.
    shading, tone, **render_kwargs
        As :func:`raycast_shade.apps.batch.render_batch`.
    workers, scheduler, retries, numba_threads
        As :func:`raycast_shade.apps.batch.render_batch`.
    resume : bool
        Skip views whose files all exist.
    views_per_task : int
        Consecutive views per Dask task.
    depth_scale : float
        Units per world unit of the depth PNG (1000: millimetres).

    Returns
    -------
    str
        Path of the index (``out_dir / index.json``).

    Raises
    ------
    TypeError, ValueError
        For a bad argument, naming it, before any view renders.
    ImportError
        ``"exr"`` without the openexr package.
    """
    from ..scene.scene import Scene

    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if not isinstance(out_dir, (str, os.PathLike)) or not os.fspath(out_dir):
        raise TypeError(f"out_dir: expected a folder path, got {out_dir!r:.40}")
    out_dir = os.fspath(out_dir)
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise ValueError(f"out_dir: {out_dir!r} is a file, not a folder")
    depth_scale = as_scalar(depth_scale, "depth_scale", minimum=0.0, exclusive=True)
    as_int(retries, "retries", minimum=0)
    names = check_buffers(buffers)
    formats = _check_formats(formats)
    if image is not None:
        check_image_path("view" + str(image), "image")
    if not formats and image is None:
        raise ValueError("formats: nothing to write (no buffer format and image=None)")
    if formats and not names and "depth_png" not in formats:
        raise ValueError("buffers: no buffers asked for, but formats names buffer files")
    if "exr" in formats:
        import OpenEXR  # noqa: F401 - fail now, not on the first view
    views_per_task = as_int(views_per_task, "views_per_task", minimum=1)
    options = check_options(shading, render_kwargs, tone, resume)
    bases, jobs = plan_batch(scene, cameras)
    spec = _ViewSpec(options, names, formats, None if image is None else str(image).lower(), out_dir,
                     float(depth_scale))
    os.makedirs(out_dir, exist_ok=True)
    all_files = {j.index: view_files(j.index, formats, spec.image) for j in jobs}
    remove_stale_temps(out_dir, [n for files in all_files.values() for n in files.values()] + [INDEX_NAME])
    on_dask = workers is not None or scheduler is not None
    if not on_dask:
        cache = SceneCache()
        for job in jobs:
            _write_view(job, cache.base(job.key, bases[job.key]), spec, cache)
    else:
        from .batch.cluster import connect

        with connect(workers, scheduler, numba_threads) as client:
            for _ in _iter_dask(client, bases, jobs, spec, retries, views_per_task):
                pass
    index = {"conventions": {"camera": "OpenCV: x right, y down, z forward; x_cam = R x_world + t",
                             "pixels": "centre of pixel (i, j) at (u, v) = (i, j)",
                             "zdepth": "camera-space z", "depth": "distance along the ray",
                             "depth_png": f"uint16 zdepth * {spec.depth_scale:g}, 0 = none",
                             "ids": "-1 on the background (EXR: id + 1, 0 on the background)"},
             "buffers": list(names), "formats": list(formats),
             "views": [_index_entry(j, all_files[j.index]) for j in jobs]}
    path = os.path.join(out_dir, INDEX_NAME)
    with atomic_target(path) as tmp, open(tmp, "w") as fh:
        json.dump(index, fh, indent=1)
    return path


# -- the command line ------------------------------------------------------------------------------


def register_cli(subparsers):
    """Add the ``views`` command to the ``raycast-shade`` parser; dispatch to :func:`run_cli`."""
    import argparse

    from .args import add_render_options, add_tone_options, buffer_list, positive_int

    p = subparsers.add_parser(
        "views", help="render a data set of views: images, buffers and cameras",
        description="Render a TOML scene file from N cameras orbiting its target: per view the image and "
                    "the buffers (npz, exr, 16-bit depth png), and index.json with each view's K, R, t "
                    "(OpenCV's convention) and files. Views already written are skipped.",
        epilog="examples:\n"
               "  raycast-shade views examples/shapes.toml --orbit 24 --buffers depth,normal,id -o shapes_views\n"
               "  raycast-shade views scene.toml --orbit 100 --buffers zdepth,position --formats npz,exr "
               "--workers 2 -o views",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("scene", metavar="SCENE.toml", help="scene file")
    p.add_argument("--orbit", type=positive_int, required=True, metavar="N",
                   help="number of views, the camera turned about its target by 360/N degrees each")
    p.add_argument("--buffers", type=buffer_list, default=("zdepth", "normal", "model_id", "triangle_id", "mask"),
                   metavar="NAMES", help="comma-separated buffer names (default: zdepth,normal,id,mask)")
    p.add_argument("--formats", default="npz", metavar="LIST",
                   help=f"buffer files per view, comma-separated: {', '.join(FORMATS)} (default: npz)")
    p.add_argument("--image", default=".png", metavar="EXT",
                   help="per-view image file extension, or 'none' (default: .png)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder (created)")
    add_render_options(p)
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=positive_int, metavar="N", help="render on a local Dask cluster of N workers")
    where.add_argument("--scheduler", metavar="ADDR", help="render on an existing Dask cluster, e.g. tcp://host:8786")
    add_tone_options(p)
    return p


def run_cli(ns) -> int:
    """Run ``raycast-shade views``; errors are raised for the caller to print on one line."""
    import time

    from ..scene.scenefile import load_for_render
    from .animate import orbit_cameras
    from .args import overrides

    scene, render_kwargs, tone = load_for_render(ns.scene, **overrides(ns))
    shading = render_kwargs.pop("shading", "phong")
    image = None if ns.image.lower() == "none" else (ns.image if ns.image.startswith(".") else "." + ns.image)
    t0 = time.perf_counter()
    index = render_views(scene, orbit_cameras(scene.camera, ns.orbit), ns.output, buffers=ns.buffers,
                         formats=ns.formats, image=image, shading=shading, workers=ns.workers,
                         scheduler=ns.scheduler, tone=tone, **render_kwargs)
    secs = time.perf_counter() - t0
    cam = scene.camera
    print(f"wrote {index} ({ns.orbit} views, {cam.width}x{cam.height}, buffers {','.join(ns.buffers)}): "
          f"{secs:.1f} s, {ns.orbit / secs:.2f} views/s")
    return 0
