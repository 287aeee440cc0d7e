"""The pipeline: rays -> hit buffer -> shading -> frame."""

from __future__ import annotations

import time

from .scene.camera import Camera
from .visibility.accel import embree_accel, has_embree_accel
from .visibility.cast import cast_camera, resolve_caster, secondary_rays
from .output.buffers import check_buffers, compute_buffers
from .output.frame import Frame
from .scene.scene import Scene
from .study.auto import choose_methods
from .common.choices import BACKENDS, CASTERS, INTERPOLATIONS, SHADINGS
from .shading.kernels import resolve_methods, shade_hits, trace_mirrors

__all__ = ["render", "render_file"]




def render(scene: Scene, shading="phong", *, camera: Camera | None = None, backend: str = "raycast",
           interpolation: str = "perspective", caster: str = "auto", max_depth: int = 3,
           tolerance: float = 0.01, buffers=()) -> Frame:
    """Render a scene.

    Parameters
    ----------
    scene : Scene
    shading : {"flat", "gouraud", "phong", "auto"} or sequence
        One method for every model, one per model, or ``"auto"``: per model,
        the cheapest method whose predicted error is under ``tolerance``
        (:mod:`raycast_shade.auto`; the choices and reasons are on
        ``frame.decisions``).
    camera : Camera, optional
        Overrides ``scene.camera``.
    backend : {"raycast", "raster"}
        Visibility by Embree ray casting, or by the reference z-buffer
        rasterizer (:mod:`raycast_shade.raster`). Both fill the same hit
        buffer and share every shading kernel.
    interpolation : {"perspective", "screen"}
        The lecture's "3D or 2D": barycentrics of the 3D hit point
        (perspective-correct), or weights affine in screen space (classic
        scanline Gouraud, :mod:`raycast_shade.interpolation`).
    caster : {"auto", "embree", "embreex"}
        Camera rays: ``"auto"`` is the direct, packet-traced Embree path when
        available, else embreex's API for a frame that traces no shadow or
        mirror ray (those need the direct binding:
        :func:`raycast_shade.visibility.cast.resolve_caster`).
    max_depth : int
        Mirror bounces traced for reflective materials (0: none).
    tolerance : float
        Error budget of ``shading="auto"``, in linear intensity.
    buffers : sequence of str
        Per-pixel buffers to put on ``frame.buffers`` by name: ``"zdepth"``,
        ``"position"``, ``"normal_camera"``, ... (:mod:`raycast_shade.output.buffers`).

    Returns
    -------
    Frame

    Raises
    ------
    TypeError, ValueError
        For a bad argument, before any kernel runs.
    RuntimeError
        When the frame needs the direct Embree binding and it is unavailable
        (the message says why), before any kernel runs.
    """
    t0 = time.perf_counter()
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if isinstance(shading, str):
        if shading.lower() not in SHADINGS + ("auto",):
            raise ValueError(f"shading: expected one of {list(SHADINGS) + ['auto']}, got {shading!r}")
        shading = shading.lower()
    else:
        resolve_methods(scene, shading)  # validates one name per model
    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {list(BACKENDS)}, got {backend!r}")
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation: expected one of {list(INTERPOLATIONS)}, got {interpolation!r}")
    if not isinstance(caster, str) or (caster not in CASTERS and caster != "auto"):
        raise ValueError(f"caster: expected one of {list(CASTERS)} or 'auto', got {caster!r}")
    if isinstance(max_depth, bool) or not isinstance(max_depth, int) or max_depth < 0:
        raise ValueError(f"max_depth: expected an integer >= 0, got {max_depth!r}")
    buffers = check_buffers(buffers)
    camera = camera if camera is not None else scene.camera
    if camera is None:
        raise ValueError("camera: the scene has no camera and none was passed")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
    # Shadow and mirror rays need the direct binding whatever the caster: refuse now, before any kernel.
    caster = resolve_caster(caster if backend == "raycast" else "auto", secondary_rays(scene, max_depth))
    decisions = ()
    if isinstance(shading, str) and shading == "auto":
        decisions = tuple(choose_methods(scene, camera, tolerance))
        shading = tuple(d.method for d in decisions)
    elif not isinstance(shading, str):
        shading = tuple(m.lower() for m in shading)
    timings = {}
    fresh = "geometry" not in scene.__dict__ or not has_embree_accel(scene.geometry)
    if fresh and caster != "embreex" and backend == "raycast":
        tb = time.perf_counter()
        embree_accel(scene.geometry)  # build now so that the cast is timed alone
        timings["build"] = time.perf_counter() - tb
    tc = time.perf_counter()
    if backend == "raycast":
        hits = cast_camera(scene.geometry, camera, caster)
    else:
        from .visibility.raster import rasterize

        hits = rasterize(scene.geometry, camera)
    if interpolation == "screen":
        from .visibility.interpolation import to_screen_space

        hits = to_screen_space(hits, scene.geometry, camera)
    ts = time.perf_counter()
    timings["cast" if backend == "raycast" else "raster"] = ts - tc
    image = shade_hits(scene, camera, hits, shading)  # hits from our caster or rasterizer: valid by construction
    te = time.perf_counter()
    timings["shade"] = te - ts
    if scene.geometry.reflective and max_depth > 0:
        trace_mirrors(scene, camera, hits, image, max_depth)
        timings["mirror"] = time.perf_counter() - te
        te = time.perf_counter()
    if buffers:
        extra = compute_buffers(scene, camera, hits, buffers, shading)
        timings["buffers"] = time.perf_counter() - te
        te = time.perf_counter()
    timings["total"] = te - t0
    return Frame(image=image, hits=hits, shading=shading, scene=scene, camera=camera, timings=timings,
                 decisions=decisions, buffers=extra if buffers else {})


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
        ``max_depth``, ``backend``, ``interpolation``, ``caster``,
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
    import dataclasses

    from .scene.scenefile import load_for_render

    scene, kwargs, tone = load_for_render(path, **overrides)
    return dataclasses.replace(render(scene, **kwargs), tone=tone)
