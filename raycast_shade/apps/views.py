"""Data sets of views: one file set per camera, plus an index of cameras and files.

``render_views(scene, cameras, out_dir, files=ViewFiles(buffers=[...]), run=RunOptions(...))``
renders every view on the batch machinery (:mod:`raycast_shade.apps.batch`:
planning, one base scene per mesh set, the scene cache; serially, on a local
Dask cluster with ``RunOptions(workers=N)``, or on
``RunOptions(scheduler=address)``) and writes, per view ``i``:

* ``view_{i:05d}.png``: the tone-mapped image (``image=".png"``; or
  ``.pfm``/``.npy`` linear, or None for none);
* ``view_{i:05d}.npz``: the buffers and ``K, R, t`` (``formats`` holds
  ``"npz"``), and the linear image with ``float_image=True``;
* ``view_{i:05d}.exr``: the buffers (``"exr"``), and the linear image with
  ``float_image=True``;
* ``view_{i:05d}_depth.png``: 16-bit z-depth in millimetres (``"depth_png"``); ``_distance.png``,
  ``_mask.png``, ``_semantic.png``, ``_instance.png``: the distance along the ray, the foreground
  mask and the label PNGs (:class:`~raycast_shade.apps.viewfiles.ViewFiles`);

npz and EXR files are compressed (``compression="zip"``: npz deflate level
1, EXR ZIP, deflated on threads) or stored (``"none"``). The default,
``"auto"``, is ``"zip"`` where ISA-L's deflate (the ``isal`` package) is
installed, which compresses about as fast as the stored bytes are written
(``benchmarks/bench_paths.py``, two loaded runs: a view with zip was the
faster in four of eight cases, within the noise of one stored, for npz
files about 4x smaller), and ``"none"`` without it (zlib is several times
slower). The plan records the choice made.

* ``view_{i:05d}.json``: the view's record, written last: the hash of
  what it was rendered from, each file's size and BLAKE2b digest, and the
  visible objects (:func:`raycast_shade.output.labels.view_objects`: id,
  pixel count, 2D box, model-to-camera pose, 3D box corners in pixels,
  mask as COCO RLE);

and ``index.json``: the objects (id, name, semantic id, material, 3D box,
pose; :func:`raycast_shade.output.labels.object_table`), and per view its
``K``, ``R``, ``t`` (OpenCV's convention), size, projection, files and
visible objects. ``exports`` adds set-level files: ``coco_instances.json``
(COCO instances, RLE masks), ``transforms.json`` (nerfstudio / instant-ngp),
``colmap/`` (COLMAP's text model, surface points with tracks), ``bop/`` (a BOP data set),
``amodal/`` (the silhouettes) and ``flow/`` (optical flow between consecutive views); see
:mod:`raycast_shade.output.labels`, :mod:`raycast_shade.output.export` and
:mod:`raycast_shade.output.bop`. The exports are written from the
views' records and cameras, so they are not part of the plan: asking for
another export later renders nothing again.

Honest resumes
--------------
``plan.json`` is written first: the settings (buffers, formats, image,
render options, depth scale, package version) and per view the hashes of
its scene (meshes and materials), camera and lights. Run again into the
same folder, a view is skipped only if its record holds the same hash and
every file it lists is there with its size and digest (a 0-byte or
truncated file is rendered again). A folder that holds another plan (other
cameras, another size, other buffers, ...) or view files without a plan is
refused with a message saying what differs, before anything is written;
``overwrite=True`` replaces it, keeping only the views that match (an export
folder this set does not write, such as an earlier run's ``flow/``, stays, with a
warning naming it). Each
file is written atomically, so a killed run, run again, finishes the set
with the bytes a single run writes. At most two views' buffers are in
memory per worker (one written while the next renders, where two frames fit
the memory limit), and the client holds paths: memory stays flat in the
number of views.
"""

from __future__ import annotations

import dataclasses
import json
import os

from ..common.validate import as_instance
from ..output.bufferfile import exr_into, npz_into
from ..output.buffers import check_buffers
from ..output.labelfiles import label_bits, label_lookup
from ..output.labels import object_table, rle_encode, semantic_classes, silhouettes, view_objects
from ..output.imagefile import check_output_folder, png_bytes, remove_stale_temps, write_hashed, write_image
from ..output.quantize import to_uint8_table
from ..render import render
from ..visibility.accel import embree_accel
from .batch.cache import PLUGIN_NAME, SceneCache, cache_of
from .batch.options import check_options
from .batch.plan import plan_batch
from .batch.pool import ProcessPool, cores
from .batch.run import RunOptions, merge_keywords
from .viewexports import (EXPORT_FILES, EXPORTS, ExportOptions, add_export_arguments, check_set_options, check_set_targets,
                          export_options_of, set_level_files, warn_stale_folders, write_exports)
from .viewfiles import COMPRESSIONS, FORMATS, PNG_FORMATS, ViewFiles, format_buffers, png_format_bytes, view_files
from .viewmotion import fresh_scene, model_poses, moving_models, plan_motion
from .viewslots import ViewSlots, view_conventions
from .viewslots import two_frames_fit as _two_frames_fit  # a name tests and benchmarks replace
from .viewplan import (PLAN_FORMAT, PLAN_NAME, digest, file_hasher, prepare_folder, view_hashes, view_is_done, view_key,
                       write_json, write_record)

__all__ = ["render_views", "ViewFiles", "RunOptions", "FORMATS", "EXPORTS", "INDEX_NAME", "PLAN_NAME", "view_files",
           "register_cli", "run_cli"]

INDEX_NAME = "index.json"
# The keywords render_views took before its records: old name -> field of ViewFiles, of RunOptions.
FLAT_FILE_KEYWORDS = {k: k for k in ("buffers", "formats", "image", "depth_scale", "float_image", "compression")}
FLAT_RUN_KEYWORDS = {**{k: k for k in ("workers", "scheduler", "resume", "retries", "numba_threads")},
                     "views_per_task": "per_task"}
_STEM = "view_{:05d}"


@dataclasses.dataclass(frozen=True, eq=False)
class _ViewSpec:
    """What every view task needs besides its job: checked options and outputs."""

    options: object
    buffers: tuple
    formats: tuple
    image: str | None
    out_dir: str
    depth_scale: float
    settings_hash: str = ""
    exports: tuple = ()
    unoccluded: bool = False
    float_image: bool = False
    compression: str = "none"
    overlap: bool = True  # write a view's files while the next renders (two frames alive)


def _render_view(job, base, spec: _ViewSpec, cache: SceneCache, slot=None):
    """Render one view (its image and buffers into the arrays of ``slot``, a turned
    :class:`~raycast_shade.apps.viewslots.ViewSlots`, when given): ``(files, frame, key, alone,
    boxes)`` for :func:`_store_view`, or None when its record shows it done."""
    files = {k: os.path.join(spec.out_dir, v) for k, v in view_files(job.index, spec.formats, spec.image).items()}
    key = view_key(spec.settings_hash, job)
    if spec.options.resume and view_is_done(files, key):
        cache.count("skipped")
        return None
    if os.path.exists(files["record"]):
        os.unlink(files["record"])  # the record goes first: never a record beside half-replaced files
    if not base.has_geometry:
        cache.count("builds")
    kwargs = spec.options.render_kwargs
    if kwargs.get("caster", "auto") != "embreex" and kwargs.get("backend") != "raster":
        embree_accel(base.geometry)  # packed and built once per mesh set; Scene.replace shares both
    scene = base.replace(lights=job.lights, camera=job.camera, ambient=job.ambient, background=job.background)
    extra = [b for b in dict.fromkeys(("model_id",) + format_buffers(spec.formats)) if b not in spec.buffers]
    # The image and buffers go into the arrays of the view that last used this slot (about 75 MB at
    # 1080p for the default set): no fresh pages per view; two slots alternate (see _run_views).
    names = spec.buffers + tuple(extra)
    out, reused = (None, None) if slot is None else slot.arrays(job.camera, check_buffers(names))
    frame = render(scene, spec.options.shading, camera=job.camera, buffers=names, out=out, buffers_out=reused,
                   **spec.options.render_kwargs)
    if slot is not None:
        slot.keep(frame.buffers)
    alone = silhouettes(scene, job.camera) if spec.unoccluded else None  # casts: on the rendering thread
    boxes = scene.geometry.memo("views.boxes", lambda geo: ([m.bounds for m in scene.models],  # once per mesh set
                                                          [m.model_to_world for m in scene.models], _labels(scene)))
    cache.count("renders")
    return files, frame, key, alone, boxes


def _labels(scene) -> dict:
    """``{kind: (lookup, bits)}`` of the label PNGs (:mod:`raycast_shade.output.labelfiles`; more labels
    than a 16-bit PNG holds were refused before rendering, when a label PNG was asked for)."""
    out = {}
    for kind in ("semantic", "instance"):
        lookup = label_lookup(scene, kind)
        out[kind] = (lookup, label_bits(min(int(lookup.max(initial=0)), 65535), kind))
    return out


def _store_view(job, spec: _ViewSpec, files, frame, key, alone, boxes) -> None:
    """Write a rendered view's files, then its record with the visible objects (masks as RLE always:
    a later run may ask for the COCO export without rendering again)."""
    kept = {k: v for k, v in frame.buffers.items() if k in spec.buffers}
    written = _write_files(files, frame, kept, job, spec, boxes[2])
    objects = view_objects(frame.buffers["model_id"], job.camera, rle=True, alone=alone, boxes_3d=boxes[0],
                           poses=boxes[1])
    if alone is not None:  # the silhouettes too, for the BOP export's mask/ files (a later run may ask for it)
        for o in objects:
            o["rle_unoccluded"] = rle_encode(alone[o["id"]].mask)
    write_record(files, key, job, objects, written)


def _one_thread() -> None:
    """Numba kernels called on the writer thread run on it alone: the next view renders on every core
    meanwhile, and a second team of threads would stall the render's parallel loops at their barriers."""
    import numba

    if numba.get_num_threads() != 1:
        numba.set_num_threads(1)  # per thread: the rendering thread keeps its count


def _run_views(jobs, base_of, spec: _ViewSpec, cache: SceneCache) -> list:
    """Render and store ``jobs`` in order; with ``spec.overlap`` each view's files are written on a
    writer thread while the next view renders (compression, writing, fsync and hashing release the
    GIL), so two views' frames are alive at once, their images in two arrays used in turn (a view's
    image array is rendered into again only once its files are written). Returns the views' stems."""
    from concurrent.futures import ThreadPoolExecutor

    images = ViewSlots(2 if spec.overlap else 1)
    stems = []
    if not spec.overlap:
        for job in jobs:
            rendered = _render_view(job, base_of(job), spec, cache, images.next(job.camera))
            if rendered is not None:
                _store_view(job, spec, *rendered)
            stems.append(_STEM.format(job.index))
        return stems
    with ThreadPoolExecutor(1, thread_name_prefix="view-writer", initializer=_one_thread) as writer:
        pending = None
        for job in jobs:
            rendered = _render_view(job, base_of(job), spec, cache, images.next(job.camera))
            if pending is not None:
                pending.result()  # the previous view's files and record (its error, if any, stops the set)
            pending = None if rendered is None else writer.submit(_store_view, job, spec, *rendered)
            stems.append(_STEM.format(job.index))
        if pending is not None:
            pending.result()
    return stems


def _write_files(files, frame, kept, job, spec: _ViewSpec, labels) -> dict:
    """The view's image and buffer files, written side by side on threads (compression, writing and
    fsync release the GIL, so one file's disk wait overlaps another's compression). Returns
    ``{path: (bytes, digest)}`` of the files hashed as they were written (all but a non-PNG image)."""
    from concurrent.futures import ThreadPoolExecutor

    linear = frame.image if spec.float_image else None
    zipped = spec.compression == "zip"

    def hashed(fill):
        return lambda p: (p, write_hashed(p, fill, file_hasher()))

    def image(p):
        if not p.endswith(".png"):
            write_image(p, frame.image, atomic=True, fast=True, **spec.options.tone)
            return None  # hashed from the file by the record
        return hashed(lambda fh: fh.write(png_bytes(to_uint8_table(frame.image, **spec.options.tone), fast=True)))(p)

    writers = {
        "image": image,
        "npz": hashed(lambda fh: npz_into(fh, kept, image=linear, camera=job.camera,
                                          compressed=1 if zipped else False)),
        "exr": hashed(lambda fh: exr_into(fh, kept, image=linear, compression="zip" if zipped else "none")),
        **{f: (lambda f: hashed(lambda fh: fh.write(png_format_bytes(f, frame.buffers, spec.depth_scale, labels))))(f)
           for f in PNG_FORMATS},
    }
    todo = [(writers[k], p) for k, p in files.items() if k in writers]
    if len(todo) == 1:
        done = [todo[0][0](todo[0][1])]
    else:
        with ThreadPoolExecutor(len(todo)) as pool:
            done = [future.result() for future in [pool.submit(write, p) for write, p in todo]]  # the first failure
    return dict(d for d in done if d is not None)  # is raised; the record is not written


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
    return _run_views(jobs, lambda job: base, spec, cache)


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


def _index_entry(job, files, out_dir) -> dict:
    K, R, t = job.camera.to_opencv()
    cam = job.camera
    with open(os.path.join(out_dir, files["record"])) as fh:
        objects = [{k: v for k, v in o.items() if k not in ("rle", "rle_unoccluded")} for o in json.load(fh)["objects"]]
    lens = {"distortion": list(cam.distortion), "distortion_model": cam.distortion_model} if cam.distorted else {}
    return {"index": job.index, "width": cam.width, "height": cam.height, "projection": cam.projection,
            "K": K.tolist(), "R": R.tolist(), "t": t.tolist(), **lens, "files": files, "objects": objects}


def _settings(spec: _ViewSpec) -> dict:
    """The plan's settings: everything every view's files depend on besides the view's own inputs."""
    from ..common.version import __version__

    opts = spec.options
    return json.loads(json.dumps({
        "version": __version__, "buffers": list(spec.buffers), "formats": list(spec.formats), "image": spec.image,
        "depth_scale": spec.depth_scale, "unoccluded": spec.unoccluded, "float_image": spec.float_image,
        "compression": spec.compression,
        "options": {"shading": opts.shading, "render": opts.render_kwargs, "tone": opts.tone}}, default=repr))


def _make_plan(spec: _ViewSpec, jobs) -> dict:
    settings = _settings(spec)
    return {"format": PLAN_FORMAT, "settings": settings,
            "views": [{"index": j.index, "width": j.camera.width, "height": j.camera.height, **view_hashes(j),
                       "files": view_files(j.index, spec.formats, spec.image)} for j in jobs]}


def _on_dask(run: RunOptions) -> bool:
    """Whether the views render on Dask (``workers`` or ``scheduler``, or ``executor="dask"``) rather than
    in this process; a view set has no process-pool path (its workers write files and keep scene caches)."""
    if isinstance(run.executor, ProcessPool) or run.executor == "processes":
        raise ValueError("run.executor: render_views renders in this process or on Dask; expected 'auto', "
                         "'serial' or 'dask'")
    return run.executor == "dask" or run.workers is not None or run.scheduler is not None


def render_views(scene, cameras, out_dir, *, files: ViewFiles | None = None, run: RunOptions | None = None,
                 shading="phong", tone: dict | None = None, overwrite: bool = False, exports=(),
                 unoccluded: bool = False, export_options: ExportOptions | None = None, poses=None,
                 **render_kwargs) -> str:
    """Render a set of views with their buffers and cameras into ``out_dir``.

    Parameters
    ----------
    scene : Scene
    cameras : sequence of Camera
        One per view.
    out_dir : str or path-like
        Created if need be.
    files : ViewFiles, optional
        What each view writes: ``buffers``, ``formats``, ``image``, ``depth_scale``,
        ``float_image`` and ``compression`` (see :class:`~raycast_shade.apps.viewfiles.ViewFiles`
        and the module docstring; default: ``ViewFiles()``, a PNG and an npz of z-depth,
        normal, id and mask per view). ``compression="auto"`` is ``"zip"`` where the ``isal``
        package is installed, else ``"none"``.
    run : RunOptions, optional
        Where and how the views render: ``workers`` (a local Dask cluster), ``scheduler``
        (an existing one), ``executor`` (``"auto"``, ``"serial"`` or ``"dask"``), ``retries``,
        ``numba_threads``, ``per_task`` (consecutive views per Dask task; default 1) and
        ``resume`` (skip views whose record matches the plan and whose files are intact, see
        the module docstring; False renders every view again). Default: ``RunOptions()``,
        in this process.
    shading, tone, **render_kwargs
        As :func:`raycast_shade.apps.batch.render_batch`.
    overwrite : bool
        Replace a view set of another plan in ``out_dir`` (default: refuse
        it, saying what differs).
    exports : sequence of {"coco", "nerfstudio", "colmap", "bop", "amodal", "flow"}
        Set-level files written after the views (see the module docstring and
        :mod:`~raycast_shade.apps.viewexports`; ``amodal`` turns ``unoccluded`` on);
        ``nerfstudio`` and ``colmap`` name the image files, so they need
        ``files.image``; ``bop`` (:mod:`raycast_shade.output.bop`, the scene
        in metres) needs ``.png`` images and turns on ``unoccluded`` and the
        ``depth_png`` format (its ``depth/`` files); ``flow`` the forward and backward optical flow
        between consecutive views in ``flow/`` (``.flo`` and KITTI PNG, see
        :mod:`~raycast_shade.apps.viewmotion`).
    unoccluded : bool
        Also cast each model alone per view: each object's unoccluded
        (amodal) pixel count and box and its visible fraction in the records
        and the index (:func:`raycast_shade.output.labels.view_objects`); one
        more cast per model and view.
    export_options : ExportOptions, optional
        How the exports are written (COCO polygons, COLMAP layout and points).
    poses : dict of (int or str) to (V, 4, 4) float, optional
        Objects that move: per model (index, or name: every model of that name) its rigid
        model-to-world pose in each view (:func:`~raycast_shade.keyframes`,
        :func:`~raycast_shade.orbit_poses`); the records, index, COCO and BOP say each view's
        poses; ``nerfstudio`` and ``colmap`` are refused when a model moves
        (:mod:`~raycast_shade.apps.viewmotion`). Default: every model as the scene places it.

    Returns
    -------
    str
        Path of the index (``out_dir / index.json``).

    Warns
    -----
    DeprecationWarning
        For the flat keywords of earlier releases, which still work for this release:
        ``buffers``, ``formats``, ``image``, ``depth_scale``, ``float_image``, ``compression``
        (now fields of ``files``) and ``workers``, ``scheduler``, ``resume``, ``retries``,
        ``numba_threads``, ``views_per_task`` (now of ``run``; ``views_per_task`` is
        ``run.per_task``). One that disagrees with the record given too is refused.

    Raises
    ------
    TypeError, ValueError
        For a bad argument, naming it, a camera whose frame exceeds the
        memory limit, or a folder holding another plan: before any file is
        written.
    ImportError
        ``"exr"`` without the openexr package.

    Examples
    --------
    >>> render_views(scene, orbit_cameras(scene.camera, 24), "views",
    ...              files=ViewFiles(buffers=["zdepth", "normal", "id"], formats=["npz", "depth_png"]),
    ...              run=RunOptions(workers=2))                                         # doctest: +SKIP
    'views/index.json'
    """
    from ..scene.scene import Scene

    as_instance(scene, "scene", Scene)
    if not isinstance(out_dir, (str, os.PathLike)) or not os.fspath(out_dir):
        raise TypeError(f"out_dir: expected a folder path, got {out_dir!r:.40}")
    out_dir = check_output_folder(out_dir, "out_dir")  # a file there, or no writing: refused before any work
    files = merge_keywords(files, ViewFiles, render_kwargs, FLAT_FILE_KEYWORDS, "files")
    run = merge_keywords(run, RunOptions, render_kwargs, FLAT_RUN_KEYWORDS, "run")
    on_dask = _on_dask(run)
    names, formats, image, depth_scale = check_buffers(files.buffers), files.formats, files.image, files.depth_scale
    exports, compression, formats, unoccluded, export_options = check_set_options(
        exports, files, unoccluded, overwrite, scene, cameras, export_options)
    options = check_options(shading, render_kwargs, tone, run.resume)
    memory = dict(buffers=names + ("model_id",), samples=options.render_kwargs.get("samples", 1))
    scenes, poses = plan_motion(poses, scene, cameras, exports)  # one scene per view when models move
    bases, jobs = plan_batch(scenes, cameras, memory=memory)
    spec = _ViewSpec(options, names, formats, None if image is None else str(image).lower(), out_dir,
                     float(depth_scale), exports=exports, unoccluded=bool(unoccluded), float_image=files.float_image,
                     compression=compression, overlap=_two_frames_fit(jobs, memory))
    spec = dataclasses.replace(spec, settings_hash=digest(json.dumps(_settings(spec), sort_keys=True)))
    plan = _make_plan(spec, jobs)
    all_files = {j.index: view_files(j.index, formats, spec.image) for j in jobs}
    check_set_targets(out_dir, exports, [j.camera for j in jobs], all_files, (INDEX_NAME, PLAN_NAME))
    os.makedirs(out_dir, exist_ok=True)
    set_files = [INDEX_NAME] + set_level_files()
    prepare_folder(out_dir, plan, bool(overwrite), set_files)
    warn_stale_folders(out_dir, exports)
    set_level = [INDEX_NAME, PLAN_NAME] + [n for n in set_level_files() if os.sep not in n]
    remove_stale_temps(out_dir, [n for files in all_files.values() for n in files.values()] + set_level)
    _run_set(run, on_dask, bases, jobs, spec, set(moving_models(poses)))
    return _write_index(scene, spec, jobs, [bases[j.key] for j in jobs] if poses else None, all_files,
                        export_options)


def _run_set(run: RunOptions, on_dask: bool, bases, jobs, spec: _ViewSpec, moved: set) -> None:
    """Render and store every view, here or on Dask; the geometries of the ``moved`` models' scenes live
    in the scene cache alone (:func:`~raycast_shade.apps.viewmotion.fresh_scene`), not in the plan."""
    if not on_dask:
        cache = SceneCache()
        _run_views(jobs, lambda job: cache.base(job.key, fresh_scene(bases[job.key], moved) if moved
                                                else bases[job.key]), spec, cache)
        return
    from .batch.cluster import connect

    workers = cores() if run.workers is None and run.scheduler is None else run.workers  # executor="dask" alone
    with connect(workers, run.scheduler, run.numba_threads) as client:
        for _ in _iter_dask(client, bases, jobs, spec, run.retries, run.per_task or 1):
            pass


def _write_index(scene, spec: _ViewSpec, jobs, scenes, all_files, export_options) -> str:
    """The exports, then ``index.json`` (with each view's ``model_to_world`` when models move: ``scenes``)."""
    out_dir = spec.out_dir
    index = {"conventions": view_conventions(spec.depth_scale),
             "buffers": list(spec.buffers), "formats": list(spec.formats), "depth_scale": spec.depth_scale,
             "classes": list(semantic_classes(scene)[0]), "objects": object_table(scene),
             "views": [_index_entry(j, all_files[j.index], out_dir) for j in jobs]}
    if scenes is not None:  # objects that move: every model's pose per view (hidden ones too)
        index["conventions"]["model_to_world"] = "per view, each model's 4x4 pose: x_world = R x_model + t"
        for view, poses in zip(index["views"], model_poses(scenes)):
            view["model_to_world"] = poses
    write_exports(scene, [j.camera for j in jobs], index, out_dir, spec.exports, export_options, scenes=scenes)
    path = os.path.join(out_dir, INDEX_NAME)
    write_json(path, index)
    return path



# -- the command line ------------------------------------------------------------------------------


def register_cli(subparsers):
    """Add the ``views`` command to the ``raycast-shade`` parser; dispatch to :func:`run_cli`."""
    import argparse

    from .args import add_mesh_options, add_render_options, add_tone_options, buffer_list, positive_int

    p = subparsers.add_parser(
        "views", help="render a data set of views: images, buffers and cameras",
        description="Render a TOML scene file (or a mesh file, framed and lit as `render` does) from N "
                    "cameras orbiting its target: per view the image and "
                    "the buffers (npz, exr, 16-bit depth png), and index.json with each view's K, R, t "
                    "(OpenCV's convention) and files. Views already written for the same plan are skipped; a "
                    "folder holding another plan is refused (--overwrite replaces it).",
        epilog="examples:\n"
               "  raycast-shade views examples/shapes.toml --orbit 24 --buffers depth,normal,id -o shapes_views\n"
               "  raycast-shade views scene.toml --orbit 100 --buffers zdepth,position --formats npz,exr "
               "--workers 2 -o views",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("scene", metavar="SCENE", help="scene file (.toml) or mesh file (.glb, .obj, .stl, ...)")
    p.add_argument("--orbit", type=positive_int, required=True, metavar="N",
                   help="number of views, the camera turned about its target by 360/N degrees each")
    p.add_argument("--buffers", type=buffer_list, default=("zdepth", "normal", "model_id", "triangle_id", "mask"),
                   metavar="NAMES", help="comma-separated buffer names (default: zdepth,normal,id,mask)")
    p.add_argument("--formats", default="npz", metavar="LIST",
                   help=f"buffer files per view, comma-separated: {', '.join(FORMATS)} (default: npz); 'bop' "
                        "here is taken as --export bop")
    p.add_argument("--image", default=".png", metavar="EXT",
                   help="per-view image file extension, or 'none' (default: .png)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder (created)")
    p.add_argument("--export", default="", metavar="LIST",
                   help=f"set-level files, comma-separated: {', '.join(EXPORTS)} (COCO instances with RLE masks, "
                        "nerfstudio/instant-ngp transforms.json, COLMAP text, a BOP data set in bop/: the scene in "
                        "metres, written in mm; flow/: .flo and KITTI PNG flow between consecutive views); a scene "
                        "file's [[motion]] tables move its objects")
    p.add_argument("--unoccluded", action="store_true",
                   help="also cast each model alone: per object its unoccluded pixel count and box and its "
                        "visible fraction, in index.json")
    p.add_argument("--float-image", action="store_true",
                   help="also store the linear float image in the npz/exr files (default: buffers only)")
    p.add_argument("--compression", default="auto", choices=COMPRESSIONS,
                   help="npz/exr files compressed (zip: npz deflate level 1, EXR ZIP) or stored (none); auto, the "
                        "default: zip where the isal package is installed (as fast as storing), else none")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a view set of another plan in the output folder (default: refuse it)")
    add_export_arguments(p)
    add_render_options(p)
    add_mesh_options(p)
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=positive_int, metavar="N", help="render on a local Dask cluster of N workers")
    where.add_argument("--scheduler", metavar="ADDR", help="render on an existing Dask cluster, e.g. tcp://host:8786")
    add_tone_options(p)
    return p


def run_cli(ns) -> int:
    """Run ``raycast-shade views``; errors are raised for the caller to print on one line."""
    import time

    from ..scene.motionfile import load_motion
    from ..scene.scenefile import load_for_render
    from .animate import orbit_cameras
    from .args import model_for_render, overrides, run_options, scene_file_refuses_mesh_options

    poses = None
    if ns.scene.lower().endswith(".toml"):
        scene_file_refuses_mesh_options(ns)
        scene, render_kwargs, tone = load_for_render(ns.scene, **overrides(ns))
        poses = load_motion(ns.scene, scene, ns.orbit) or None  # [[motion]] tables: objects that move
    else:  # a mesh file, framed and lit as ``raycast-shade render`` frames it
        scene, render_kwargs, tone = model_for_render(ns.scene, overrides(ns), ns.crease_angle, ns.reflectance)
    shading = render_kwargs.pop("shading", "phong")
    image = None if ns.image.lower() == "none" else (ns.image if ns.image.startswith(".") else "." + ns.image)
    t0 = time.perf_counter()
    formats = [f.strip().lower() for f in ns.formats.split(",") if f.strip()]
    exports = [e.strip().lower() for e in ns.export.split(",") if e.strip()]
    if "bop" in formats:  # a data set format, asked for where the buffer formats are: the BOP export
        formats.remove("bop")
        exports += [] if "bop" in exports else ["bop"]
    files = ViewFiles(buffers=ns.buffers, formats=tuple(formats), image=image, float_image=ns.float_image,
                      compression=ns.compression)
    run = run_options(ns)  # --workers, --scheduler: the record Python callers pass
    index = render_views(scene, orbit_cameras(scene.camera, ns.orbit), ns.output, files=files, run=run,
                         shading=shading, tone=tone, overwrite=ns.overwrite, exports=exports,
                         unoccluded=ns.unoccluded, export_options=export_options_of(ns), poses=poses,
                         **render_kwargs)
    secs = time.perf_counter() - t0
    cam = scene.camera
    print(f"wrote {index} ({ns.orbit} views, {cam.width}x{cam.height}, buffers {','.join(ns.buffers)}): "
          f"{secs:.1f} s, {ns.orbit / secs:.2f} views/s")
    return 0
