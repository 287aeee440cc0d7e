"""The pipeline: plan -> prepare -> see (hit buffer) -> shade -> output (frame).

:func:`render` checks every argument into a plan before any kernel runs, builds the BVH
and packs the frame's kernel inputs once (:func:`~raycast_shade.shading.inputs.prepare`),
casts or rasterizes the hit buffer, shades it (mirror bounces from the same inputs), and
hands the image and its buffers to the :class:`~raycast_shade.output.frame.Frame`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .scene.camera import Camera
from .visibility.accel import embree_accel, has_embree_accel
from .visibility import bands
from .visibility.cast import cast_camera, resolve_caster, secondary_rays
from .visibility.facing import warn_single_sided
from .visibility.hits import image_buffer
from .visibility.interpolation import to_screen_space
from .visibility.pixel import CameraCast
from .visibility.raster import check_raster_camera, choose_backend, rasterize
from .visibility.rays import subpixel_camera
from .common.bufferspec import BUFFERS
from .output.buffers import FrameBuffers, check_buffers, check_buffers_out
from .output.frame import Frame
from .scene.pitfalls import warn_render
from .scene.scene import Scene
from .insight.auto import choose_methods
from .insight.explain import explain
from .common.choices import BACKEND_CHOICES, CASTER_CHOICES, INTERPOLATIONS, SHADING_CHOICES
from .common.samples import check_samples, sample_offsets
from .common.validate import as_int, as_scalar
from .shading.inputs import prepare
from .shading.mirror_rays import hand_over_buffers
from .shading.mirrors import MAX_MIRROR_DEPTH, trace_mirrors
from .shading.shade import GROUP, SampleShading, accumulate, resolve_methods, sample_mean
from .shading.terms import check_terms
from .shading.termshade import TermShading

__all__ = ["render", "render_file"]


def render(scene: Scene, shading="phong", *, camera: Camera | None = None, backend: str = "raycast",
           interpolation: str = "perspective", caster: str = "auto", max_depth: int = 3,
           tolerance: float = 0.01, buffers=(), terms=False, samples: int = 1, out=None,
           buffers_out=None) -> Frame:
    """Render a scene.

    Parameters
    ----------
    scene : Scene
    shading : {"flat", "gouraud", "phong", "auto"} or sequence
        One method for every model, one per model, or ``"auto"``: per model,
        the cheapest method whose predicted error is under ``tolerance``
        (:mod:`raycast_shade.insight.auto`; the choices and reasons are on
        ``frame.decisions``).
    camera : Camera, optional
        Overrides ``scene.camera``.
    backend : {"raycast", "raster", "auto"}
        Embree ray casting, the z-buffer rasterizer (:mod:`raycast_shade.visibility.raster`), or
        ``"auto"``: the one measured faster for the frame, if it can draw it (``choose_backend``
        there). All fill one hit buffer and share every shading kernel.
    interpolation : {"perspective", "screen"}
        The lecture's "3D or 2D": barycentrics of the 3D hit point
        (perspective-correct), or weights affine in screen space (classic
        scanline Gouraud, :mod:`raycast_shade.visibility.interpolation`).
    caster : {"auto", "embree", "embreex"}
        Camera rays: ``"auto"`` is the direct, packet-traced Embree path when
        available, else embreex's API for a frame that traces no shadow or
        mirror ray (those need the direct binding:
        :func:`raycast_shade.visibility.cast.resolve_caster`).
    max_depth : int
        Mirror bounces traced for reflective materials (0: none), at most
        ``MAX_MIRROR_DEPTH`` (64); a ray whose remaining weight falls below
        float32's resolution (2**-24) stops early.
    tolerance : float
        Error budget of ``shading="auto"``, in linear intensity, ``> 0``
        (checked in every mode).
    buffers : sequence of str
        Per-pixel buffers to put on ``frame.buffers`` by name: ``"zdepth"``,
        ``"position"``, ``"normal_camera"``, ``"coverage"``, ...
        (:mod:`raycast_shade.output.buffers`).
    samples : int
        Anti-aliasing rays per pixel, ``1 <= samples <= MAX_SAMPLES`` (1024),
        on the pattern of :mod:`raycast_shade.common.samples` (sample 0 the
        pixel centre), each shaded (mirrors too) and averaged with equal
        weights: a box filter over the pixel. Both backends take them. The
        hit buffer, depth, normals and ids stay sample 0's, exactly the
        ``samples=1`` ones; ``"coverage"`` is the fraction of samples that
        hit. ``samples=1`` is the one-ray-per-pixel frame, bit for bit.
    out : (H, W, 3) float32 ndarray, optional
        A writeable C-contiguous array of the camera's size to write the
        image into (``frame.image`` is ``out``): a sequence of frames of one
        size reuses one image instead of page-faulting a fresh one per frame
        (24 MB at 1080p). Its old contents are overwritten, so an earlier
        frame holding it changes too.
    buffers_out : dict of str to ndarray, optional
        Arrays to write asked-for buffers into, by name (e.g. an earlier
        frame's ``frame.buffers``, which then changes too): no fresh pages
        per view (186 MB for all buffers at 1080p); ``frame.buffers`` holds
        these very arrays (:func:`~raycast_shade.output.buffers.check_buffers_out`).
    terms : bool, str or sequence of str
        ``True``: the reflectance equation's terms as images on ``frame.terms``
        (ambient, diffuse, specular, reflected, shadow mask; ``"per_light"``
        adds each light's), which add up to the image
        (:mod:`raycast_shade.shading.terms`), written by the image's own shading
        pass (the same image). ``frame.explain(x, y)`` works either way.

    Returns
    -------
    Frame

    Notes
    -----
    A frame of at least 2**19 pixels cast by the packet caster with
    perspective-correct weights and no mirror bounce is cast, shaded
    and its buffers and terms computed in bands of 128 rows
    (:mod:`raycast_shade.visibility.bands`), whatever its methods and number
    of samples: it never holds a full-frame hit buffer, and ``frame.hits``
    is cast again the first time it is read (the same buffer, bit for bit;
    ``frame.mask`` is kept). Flat faces and Gouraud vertices are shaded once,
    by the first band (and sample) that sees them. The image and buffers are
    the whole-frame path's, bit for bit.

    Raises
    ------
    TypeError, ValueError
        For a bad argument, before any kernel runs; also for a camera whose
        frame, with the buffers, samples and terms asked for, would need more
        memory than allowed
        (:meth:`~raycast_shade.scene.camera.Camera.check_frame_memory`).
    RuntimeError
        When the frame needs the direct Embree binding and it is unavailable
        (the message says why), before any kernel runs.
    """
    t0 = time.perf_counter()
    plan = _plan(scene, shading, camera, backend, interpolation, caster, max_depth, tolerance, buffers, samples, out,
                 terms, buffers_out)
    camera, shading, terms = plan.camera, plan.shading, plan.terms
    banded = _banded(scene, plan, terms)  # then the memory of what is asked for, before any kernel
    camera.check_frame_memory(plan.buffers, plan.samples, terms, len(scene.lights), bands.BAND_ROWS * banded,
                              reused=tuple(plan.buffers_out))
    warn_render(scene, shading)  # no lights, a light inside a closed mesh, a bump map the method ignores
    timings, mask = {}, None
    _build(scene, plan, timings)
    warn_single_sided(scene, camera)  # back faces of a single-sided (glTF) model in view: said, not silent
    inputs = prepare(scene, camera)  # once per frame: shading, every sample and the mirror bounces
    fb = FrameBuffers(scene, camera, plan.buffers, shading, out=plan.buffers_out) if plan.buffers else None
    shader = _shader(scene, plan, inputs) if banded or plan.samples == 1 else None  # samples: their own
    if banded:
        hits, image, mask, extra = _render_bands(scene, plan, timings, inputs, shader, fb)
    else:
        hits, image, extra = _render_whole(scene, plan, timings, inputs, shader, fb)
    te = time.perf_counter()
    parts = {} if terms is None else shader.terms(None if banded else hits, plan.max_depth)  # shaded with the image
    if terms is not None:
        timings["terms"] = time.perf_counter() - te
        te = time.perf_counter()
    timings["total"] = te - t0
    return Frame(image=image, hits=hits, shading=shading, scene=scene, camera=camera, timings=timings,
                 decisions=plan.decisions, buffers=extra, terms=parts, max_depth=plan.max_depth,
                 explainer=explain if plan.samples == 1 else _averaged, hit_mask=mask, inputs=inputs)


def _averaged(frame, x, y):
    """Frame.explain of an anti-aliased frame: its pixels are averages of several models, not one."""
    raise ValueError(f"explain: pixel ({x}, {y}) averages several samples (render(samples=...)); explain() "
                     "gives the model of one ray per pixel: render the frame with samples=1")


@dataclass(frozen=True)
class _Plan:
    """render()'s arguments, checked and resolved."""

    shading: object  # a method name, or one per model
    camera: Camera
    backend: str
    interpolation: str
    caster: str
    max_depth: int
    buffers: tuple
    decisions: tuple
    samples: int = 1
    out: object = None  # the image array to fill, or None
    terms: object = None  # check_terms's options, or None for no terms
    buffers_out: dict = None  # buffer name -> the caller's array to fill (check_buffers_out)


def _plan(scene, shading, camera, backend, interpolation, caster, max_depth, tolerance, buffers,
          samples=1, out=None, terms=False, buffers_out=None) -> _Plan:
    """Every argument checked before any kernel runs (the names as the user spelled them)."""
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if isinstance(shading, str):
        shading = _choice(shading, "shading", SHADING_CHOICES)
    else:
        resolve_methods(scene, shading)  # validates one name per model
        shading = tuple(m.lower() for m in shading)
    backend = _choice(backend, "backend", BACKEND_CHOICES)
    interpolation = _choice(interpolation, "interpolation", INTERPOLATIONS)
    caster = _choice(caster, "caster", CASTER_CHOICES)
    max_depth = as_int(max_depth, "max_depth", minimum=0)  # NumPy integers too
    if max_depth > MAX_MIRROR_DEPTH:
        raise ValueError(f"max_depth: at most {MAX_MIRROR_DEPTH} mirror bounces, got {max_depth} (a mirror "
                         "enclosing the camera would bounce every ray that many times)")
    # Checked in every mode, not only by "auto" which uses it: a NaN is a mistake either way.
    try:
        tolerance = as_scalar(tolerance, "tolerance", minimum=0.0, exclusive=True)
    except TypeError as exc:  # a ValueError for every bad tolerance, as choose_methods has always raised
        raise ValueError(str(exc)) from None
    buffers = check_buffers(buffers)
    samples = check_samples(samples)  # NumPy integers too
    camera = camera if camera is not None else scene.camera
    if camera is None:
        raise ValueError("camera: the scene has no camera and none was passed")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    camera.check_frame_memory()
    if backend == "auto":
        backend = choose_backend(scene.geometry, camera)[0]
    if backend == "raster":
        check_raster_camera(camera)  # the rasterizer's own check, before the geometry is packed
    # Shadow and mirror rays need the direct binding whatever the caster: refuse now, before any kernel.
    caster = resolve_caster(caster if backend == "raycast" else "auto", secondary_rays(scene, max_depth))
    decisions = ()
    if shading == "auto":
        decisions = tuple(choose_methods(scene, camera, tolerance))
        shading = tuple(d.method for d in decisions)
    out = _check_out(out, camera)
    buffers_out = check_buffers_out(buffers_out, buffers, (camera.height, camera.width), others=(out,))
    terms = check_terms(terms)
    if terms is not None and samples > 1:
        raise ValueError(f"terms: the terms are those of one ray per pixel; with samples={samples} they "
                         "would not add up to the averaged image: render them with samples=1")
    return _Plan(shading, camera, backend, interpolation, caster, max_depth, buffers, decisions, samples, out, terms,
                 buffers_out)


def _check_out(out, camera):
    """``out`` as the frame's image array, or None; TypeError/ValueError naming it."""
    if out is None:
        return None
    if not isinstance(out, np.ndarray):
        raise TypeError(f"out: expected a numpy array, got {type(out).__name__}")
    want = (camera.height, camera.width, 3)
    if out.shape != want or out.dtype != np.float32:
        raise ValueError(f"out: expected a {want} float32 array (the camera's image), got {out.shape} {out.dtype}")
    if not out.flags.c_contiguous or not out.flags.writeable:
        raise ValueError("out: expected a writeable C-contiguous array")
    return out


def _choice(value, name: str, choices) -> str:
    """``value`` lower-cased if it names one of ``choices``; a ValueError naming the field otherwise."""
    if not isinstance(value, str) or value.lower() not in choices:
        raise ValueError(f"{name}: expected one of {list(choices)}, got {value!r}")
    return value.lower()


def _build(scene, plan: _Plan, timings: dict) -> None:
    """Build the Embree BVH of a frame the packet caster casts, timed alone as ``"build"``
    (a scene whose BVH exists, e.g. after ``scene.replace(camera=...)``, reuses it)."""
    if plan.backend != "raycast" or plan.caster == "embreex":
        return
    if not scene.has_geometry or not has_embree_accel(scene.geometry):
        tb = time.perf_counter()
        embree_accel(scene.geometry)
        timings["build"] = time.perf_counter() - tb


def _visibility(scene, plan: _Plan, timings: dict, offset=(0.0, 0.0), out=None):
    """The hit buffer of ``plan.camera``, by the plan's backend and weights (:data:`_BACKENDS`,
    :data:`_WEIGHTS`; timed into ``timings``, summed over calls), through the pixel centres or
    the points ``offset`` pixels off them; filled into ``out`` (a HitBuffer of the image's size)
    when given."""
    camera = subpixel_camera(plan.camera, *offset)  # plan.camera itself at the centre
    key, see = _BACKENDS[plan.backend]
    tc = time.perf_counter()
    hits = _WEIGHTS[plan.interpolation](see(scene.geometry, camera, plan.caster, out), scene.geometry, camera)
    timings[key] = timings.get(key, 0.0) + time.perf_counter() - tc
    return hits


def _cast(geometry, camera, caster, out):
    return cast_camera(geometry, camera, caster, out=out)


def _raster(geometry, camera, caster, out):
    return rasterize(geometry, camera, out=out)  # no caster: the rasterizer traces nothing


def _perspective(hits, geometry, camera):
    return hits  # the casters' and the rasterizer's barycentrics are the 3D hit point's


# One entry per choice of common/choices.py: a backend's timing key and hit buffer, and the
# remap of its barycentrics per interpolation (tests/project/test_variant_registries.py).
_BACKENDS = {"raycast": ("cast", _cast), "raster": ("raster", _raster)}
_WEIGHTS = {"perspective": _perspective, "screen": to_screen_space}


def _render_whole(scene, plan: _Plan, timings: dict, inputs, shader, fb):
    """The whole-frame path: the hit buffer, the image (one ray per pixel by ``shader``, or the
    samples' mean) and the buffers of ``fb`` (a :class:`FrameBuffers`, or None), whose shading
    normals the Phong kernel writes as it shades (not the terms' kernels)."""
    writes = shader is None or shader.WRITES_NORMALS  # samples: SampleShading
    normal = None if fb is None or not writes else fb.normal_target(0, plan.camera.height, plan.camera.width)
    if plan.samples == 1:
        hits, image, coverage = _render_one(scene, plan, timings, inputs, shader, normal)
    else:
        hits, image, coverage = _render_samples(scene, plan, timings, inputs, normal)
    extra = {}
    if fb is not None:
        tb = time.perf_counter()
        fb.band(hits, 0, shaded=normal is not None)
        counted = any(BUFFERS[n].writer == "samples" for n in fb.names)
        extra = fb.result(hits.prim >= 0 if counted else None, coverage)
        timings["buffers"] = time.perf_counter() - tb
    return hits, image, extra


def _shader(scene, plan: _Plan, inputs):
    """The frame's shader: :class:`~raycast_shade.shading.termshade.TermShading` when terms are
    asked for (the image and its terms in one pass), else
    :class:`~raycast_shade.shading.shade.SampleShading`."""
    if plan.terms is not None:
        return TermShading(scene, plan.camera, plan.shading, inputs, "per_light" in plan.terms)
    return SampleShading(scene, plan.camera, plan.shading, inputs)


def _handed_rays(scene, plan: _Plan, shader, rows: int):
    """Where the shading kernel hands each reflective pixel's mirror ray over to the mirror kernel
    (:func:`~raycast_shade.shading.mirror_rays.hand_over_buffers`, ``rows`` rows), or None: no
    mirror bounce, or a reflective model not Phong-shaded (the mirror kernel computes them)."""
    if scene.geometry.reflective and plan.max_depth > 0 and shader.hands_over:
        return hand_over_buffers(rows, plan.camera.width)
    return None


def _render_one(scene, plan: _Plan, timings: dict, inputs, shader, normal=None):
    """One ray per pixel: the hit buffer, its shaded image (mirrors blended in) and no coverage;
    ``normal``: where the Phong kernel writes the shading normals (:meth:`FrameBuffers.normal_target`)."""
    hits = _visibility(scene, plan, timings)
    ts = time.perf_counter()
    rays = _handed_rays(scene, plan, shader, plan.camera.height)
    image = shader.shade(hits, out=plan.out, normal=normal, rays=rays)  # our hits: valid
    te = time.perf_counter()
    timings["shade"] = te - ts
    if scene.geometry.reflective and plan.max_depth > 0:
        trace_mirrors(scene, plan.camera, hits, image, plan.max_depth, inputs, rays=rays)
        timings["mirror"] = time.perf_counter() - te
    return hits, image, None


def _banded(scene, plan: _Plan, terms) -> bool:
    """Whether the frame is cast and shaded band by band (:func:`_render_bands`): by the packet
    caster with perspective-correct weights, any methods, buffers, samples, terms and mirror
    bounces, but not terms with mirror bounces (the mirror terms read the whole frame's hits),
    taller than one band and of at least :data:`~raycast_shade.visibility.bands.MIN_PIXELS` pixels."""
    cam = plan.camera
    return (plan.backend == "raycast" and plan.caster == "embree" and plan.interpolation == "perspective"
            and not (terms is not None and scene.geometry.reflective and plan.max_depth > 0)
            and cam.height > bands.BAND_ROWS and cam.width * cam.height >= bands.MIN_PIXELS)


def _render_bands(scene, plan: _Plan, timings: dict, inputs, shader, buffers=None):
    """Each band of rows cast, shaded and its buffers computed as soon as it is cast (while
    its hits are in cache), so the frame never holds (or page-faults in) a full-frame hit
    buffer: 20 bytes a pixel. Mirror bounces follow each shaded band (and sample), from its
    hits. Anti-aliasing casts every sample's band in turn (one window per sample) and
    averages them into the band's rows of the image; flat faces and Gouraud vertices are
    shaded once, by the first band (and sample) that sees them.

    Returns the recipe of the hit buffer (the same cast again, run if ``frame.hits`` is read:
    :func:`~raycast_shade.visibility.cast.cast_camera` with the frame's camera and caster,
    nothing of ``render``), the image, the hit mask and the buffers. Every pixel is the one
    the whole-frame path (:func:`_render_one`, :func:`_render_samples`, then
    :func:`~raycast_shade.output.buffers.compute_buffers`) gives, bit for bit."""
    camera = plan.camera
    h, w = camera.height, camera.width
    image = np.empty((h, w, 3), np.float32) if plan.out is None else plan.out
    mask = np.empty((h, w), np.bool_)
    casts = [bands.cast_bands(scene.geometry, subpixel_camera(camera, dx, dy), bands.BAND_ROWS)
             for dx, dy in sample_offsets(plan.samples)]
    counted = plan.samples > 1 and "coverage" in plan.buffers
    mean = _BandMean(plan.samples, w, counted) if plan.samples > 1 else None
    coverage = None
    if counted:
        coverage = plan.buffers_out["coverage"] if "coverage" in plan.buffers_out else np.empty((h, w), np.float32)
    spent = dict.fromkeys(("shade", "mirror", "buffers", "average"), 0.0)
    mirrors = scene.geometry.reflective and plan.max_depth > 0
    handed = _handed_rays(scene, plan, shader, bands.BAND_ROWS)  # one band's, reused by every band

    def shade(hits, out, y, normal=None):  # one band of one sample, its mirror bounces blended in
        nonlocal handed
        ts = time.perf_counter()
        m = hits.shape[0]
        if handed is not None and handed[0].shape[0] < m:  # a distorted camera's one band: the frame
            handed = _handed_rays(scene, plan, shader, m)
        rays = None if handed is None else (handed[0][:m], handed[1][:m])
        shader.shade(hits, out=out, y0=y, normal=normal, rays=rays)
        tm = time.perf_counter()
        spent["shade"] += tm - ts
        if mirrors:
            trace_mirrors(scene, camera, hits, out, plan.max_depth, inputs, y, rays)
            spent["mirror"] += time.perf_counter() - tm

    t_start = time.perf_counter()
    for y, band in casts[0]:
        m = band.shape[0]
        rows = slice(y, y + m)
        # The Phong kernel writes the shading normals (the terms' kernels do not: the buffers do)
        normal = None if buffers is None or not shader.WRITES_NORMALS else buffers.normal_target(y, m, w)
        if mean is None:
            shade(band, image[rows], y, normal)
        else:
            for i, cast in enumerate(casts):
                hits = band if i == 0 else next(cast)[1]
                shade(hits, mean.image(i, m), y, None if i else normal)
                ta = time.perf_counter()
                mean.add(i, hits.prim, image[rows], None if coverage is None else coverage[rows])
                spent["average"] += time.perf_counter() - ta
        t0 = time.perf_counter()
        np.greater_equal(band.prim, 0, out=mask[rows])
        t1 = time.perf_counter()
        spent["shade"] += t1 - t0
        if buffers is not None:
            buffers.band(band, y, shaded=normal is not None)
            spent["buffers"] += time.perf_counter() - t1
    timings["cast"] = time.perf_counter() - t_start - sum(spent.values())
    timings.update((k, v) for k, v in spent.items() if v or k == "shade")
    extra = buffers.result(mask, coverage) if buffers is not None else {}
    return CameraCast(scene.geometry, camera, plan.caster), image, mask, extra


class _BandMean:
    """The box filter of one band's samples, as :func:`_render_samples` forms it (a group of
    ``GROUP`` per pass over a float64 accumulator, the last group straight into the mean), on
    band-sized scratch arrays (grown to the tallest band)."""

    def __init__(self, n: int, w: int, counted: bool):
        self.n, self.w, self.counted = n, w, counted
        self.rows = 0
        self.group = []

    def _grow(self, m):
        n, w, k = self.n, self.w, min(self.n, GROUP)
        self.rows = m
        self.images = [np.empty((m, w, 3), np.float32) for _ in range(k)]
        self.acc = np.empty((m, w, 3) if n > GROUP else (1, 1, 3), np.float64)
        self.count = np.empty((m, w) if n > GROUP else (1, 1), np.int32) if self.counted else None

    def image(self, i: int, m: int):
        """Where sample ``i`` of a band of ``m`` rows is shaded."""
        if m > self.rows:
            self._grow(m)
        return self.images[i % GROUP][:m]

    def add(self, i: int, prim, out, coverage) -> None:
        """Sample ``i``'s band (shaded into :meth:`image`, its hits' ``prim``) added; the last
        sample's writes the mean to ``out`` (and the hit fraction to ``coverage``)."""
        m, n = prim.shape[0], self.n
        self.group.append(prim)
        imgs = [a[:m] for a in self.images[:len(self.group)]]
        acc = self.acc[:m] if n > GROUP else self.acc
        count = None if self.count is None else (self.count[:m] if n > GROUP else self.count)
        if i == n - 1:
            _, cov = sample_mean(acc, count, imgs, self.group, n, first=n <= GROUP, out=out, coverage=self.counted)
            if cov is not None:
                coverage[...] = cov
            self.group = []
        elif len(self.group) == GROUP:
            accumulate(acc, count, imgs, self.group, first=i < GROUP)
            self.group = []


def _render_samples(scene, plan: _Plan, timings: dict, inputs, normal=None):
    """Anti-aliasing: every sample's hit buffer, shaded (and mirrored) with the per-face and
    per-vertex work shared, then averaged. Returns sample 0's (the centre's) hits, the mean
    image and the coverage (None unless a "coverage" buffer was asked for).

    Samples go in groups of ``GROUP`` (4), sample ``i`` into ``images[i % GROUP]``; each group
    is added to the float64 accumulator in one pass, and the last one goes straight into the
    mean (a frame of at most 4 samples needs no accumulator). Sample 0's hits are the centre's
    own buffer, every later sample's one scratch buffer (one per member of a group when the
    coverage is counted: a group's hit masks are counted together). Every buffer is allocated once per frame and filled in
    place by each sample (no fresh pages per sample: ~8 ms a cast at 1080p)."""
    camera = plan.camera
    h, w = camera.height, camera.width
    shader = SampleShading(scene, camera, plan.shading, inputs)
    mirrors = scene.geometry.reflective and plan.max_depth > 0
    rays = _handed_rays(scene, plan, shader, h)  # reused by every sample
    offsets = sample_offsets(plan.samples)
    n = len(offsets)
    # The accumulator is read only once a group has gone before (a 1x1 stand-in until: never
    # indexed); the hits are counted only for a "coverage" buffer.
    acc = np.empty((h, w, 3) if n > GROUP else (1, 1, 3), np.float64)
    counted = "coverage" in plan.buffers
    count = np.empty((h, w) if n > GROUP else (1, 1), np.int32) if counted else None
    images = [np.empty((h, w, 3), np.float32) if i or plan.out is None else plan.out for i in range(min(n, GROUP))]
    scratch = [None] * GROUP
    centre = None
    group = []  # the group's hit buffers, for its counts
    for i, (dx, dy) in enumerate(offsets):
        j = i % GROUP if counted else 0  # a group's hit counts are taken together: one buffer each
        if i > 0 and scratch[j] is None:
            scratch[j] = image_buffer(None, h, w)  # every pixel gets written
        hits = _visibility(scene, plan, timings, (dx, dy), None if i == 0 else scratch[j])
        image = images[i % GROUP]
        ts = time.perf_counter()
        shader.shade(hits, out=image, normal=normal if i == 0 else None, rays=rays)  # sample 0's normals: the centre's
        te = time.perf_counter()
        timings["shade"] = timings.get("shade", 0.0) + te - ts
        if mirrors:  # per sample: a mirror's reflection is anti-aliased too
            trace_mirrors(scene, camera, hits, image, plan.max_depth, inputs, rays=rays)
            timings["mirror"] = timings.get("mirror", 0.0) + time.perf_counter() - te
        if i == 0:
            centre = hits
        group.append(hits.prim)
        ta = time.perf_counter()
        if i == n - 1:  # the last group, straight into the mean (in place of its first image)
            image, coverage = sample_mean(acc, count, images[:len(group)], group, n, first=n <= GROUP,
                                          out=images[0], coverage=counted)
        elif len(group) == GROUP:
            accumulate(acc, count, images, group, first=i < GROUP)
            group = []
        timings["average"] = timings.get("average", 0.0) + time.perf_counter() - ta
    return centre, image, coverage


def render_file(path, **overrides) -> Frame:
    """Render a TOML scene file with its own ``[render]`` options, in one call.

    The same as::

        scene, kwargs, tone = load_for_render(path, **overrides)  # scene.scenefile
        frame = render(scene, **kwargs)

    (``load_scene`` then the file's ``[render]`` options, overridden), with
    the tone options kept on the frame. ``raycast-shade render`` renders
    exactly this.

    Parameters
    ----------
    path : str or path-like
        A scene file (``docs/scene-files.md``).
    **overrides
        Any ``[render]`` entry, beating the file's: ``shading`` (a method,
        ``"auto"`` or one per ``[[object]]``), ``width``, ``height``,
        ``max_depth``, ``samples``, ``backend``, ``interpolation``, ``caster``,
        ``tolerance``, and the tone options ``exposure``, ``tonemap``,
        ``gamma``. ``None`` keeps the file's value.

    Returns
    -------
    Frame
        ``frame.tone`` holds the tone options (the file's, overridden):
        ``frame.save("out.png")`` and ``frame.to_uint8()`` apply them.

    Raises
    ------
    SceneFileError
        For an invalid scene file (a ``ValueError`` naming the file and table).
    TypeError, ValueError
        For an unknown or invalid override, naming it, before rendering.
    """
    from .scene.motionfile import warn_motion_ignored
    from .scene.scenefile import load_for_render

    scene, kwargs, tone = load_for_render(path, **overrides)
    warn_motion_ignored(path, "a single render")
    return render(scene, **kwargs).with_tone(tone)
