"""Animations that play in the notebook: ``rs.animate_light(scene)``, ``rs.animate_orbit(scene)``.

One call renders the frames (the orbits of :mod:`raycast_shade.apps.animate`:
:func:`~raycast_shade.apps.animate.orbit_light` moves one light around the
scene, a spot light turning with it; :func:`~raycast_shade.apps.animate.orbit_cameras`
turns the camera) with one shading method or several side by side, and
returns an :class:`Animation`: the cell shows it playing, as an animated PNG
(APNG: lossless, so Gouraud's Mach bands are not hidden by a GIF's 256
colours) inside an ``<img>``, which every current browser plays and which an
exported HTML page keeps. ``animation.save("sweep.gif")`` (or ``.mp4``) writes
it with :func:`~raycast_shade.apps.animate.write_animation`.

>>> movie = rs.animate_light(scene, frames=24, shading=("flat", "gouraud", "phong"))   # doctest: +SKIP
>>> movie                                       # plays in the notebook   # doctest: +SKIP
"""

from __future__ import annotations

import base64
import html
import io

import numpy as np

from ..common.choices import SHADINGS
from ..common.validate import as_scalar
from ..output.display import display_scale, upscale
from ..render import render
from ..scene.scene import Scene
from .animate import _check_frames, orbit_cameras, orbit_light, write_animation

__all__ = ["Animation", "animate_light", "animate_orbit"]

_LABELS = {"flat": "flat", "gouraud": "Gouraud", "phong": "Phong"}


class Animation:
    """Frames that a notebook plays (``_repr_html_``: an animated PNG, looping).

    Parameters
    ----------
    frames : (N, H, W, 3) uint8
        sRGB frames; side by side, the panels are next to each other in each.
    fps : float
    labels : sequence of str
        One per panel, shown above it.
    scale : int
        Display pixels per image pixel (nearest neighbour), each way.

    Attributes
    ----------
    frames, fps, labels, scale
    """

    def __init__(self, frames, fps: float = 12.0, labels=(), scale: int = 1):
        frames = np.asarray(frames)
        if frames.dtype != np.uint8 or frames.ndim != 4 or frames.shape[3] != 3 or frames.shape[0] == 0:
            raise ValueError(f"frames: expected (N, H, W, 3) uint8 with N >= 1, got {frames.dtype} {frames.shape}")
        self.frames = frames
        self.fps = as_scalar(fps, "fps", minimum=0.0, exclusive=True, maximum=120.0)
        self.labels = tuple(str(x) for x in labels)
        self.scale = int(scale)

    def png(self) -> bytes:
        """The animated PNG's bytes, at the display scale, looping forever."""
        from PIL import Image

        images = [Image.fromarray(upscale(f, self.scale)) for f in self.frames]
        buf = io.BytesIO()
        images[0].save(buf, format="PNG", save_all=True, append_images=images[1:],
                       duration=int(round(1000.0 / self.fps)), loop=0)
        return buf.getvalue()

    def _repr_html_(self) -> str:
        n, h, w = self.frames.shape[:3]
        width = w * self.scale
        src = base64.b64encode(self.png()).decode("ascii")
        head = ""
        if self.labels:
            cell = width // len(self.labels)
            head = "<div style='display:flex'>" + "".join(
                f"<div style='width:{cell}px;text-align:center;font-weight:bold'>{html.escape(x)}</div>"
                for x in self.labels) + "</div>"
        return (f"<div class='rs-animation'>{head}<img src='data:image/png;base64,{src}' width='{width}' "
                f"style='image-rendering:pixelated' alt='animation, {n} frames at {self.fps:g} fps'/></div>")

    def __repr__(self) -> str:
        n, h, w = self.frames.shape[:3]
        panels = f", {' | '.join(self.labels)}" if self.labels else ""
        return f"Animation({n} frames of {w}x{h} at {self.fps:g} fps{panels})"

    def save(self, path) -> int:
        """Write ``.gif`` or a video (``.mp4``, ...) at the image's own size; returns the frame count."""
        return write_animation(list(self.frames), path, fps=self.fps)


def _methods(shading) -> list:
    if not isinstance(shading, str) and not isinstance(shading, (list, tuple)):
        raise TypeError(f"shading: expected a method name or a sequence of them, got {type(shading).__name__}")
    methods = [shading] if isinstance(shading, str) else list(shading)
    if not methods or any(not isinstance(m, str) or m not in SHADINGS for m in methods):
        raise ValueError(f"shading: expected one of {list(SHADINGS)} or a sequence of them, got {shading!r}")
    return methods


def _film(scenes, cameras, methods, fps, scale, width, render_options) -> Animation:
    """Render every scene (or camera) with every method; panels side by side."""
    frames = []
    for i, scene in enumerate(scenes):
        camera = cameras[i] if cameras is not None else None
        panels = [render(scene, m, camera=camera, **render_options).to_uint8() for m in methods]
        frames.append(np.concatenate(panels, axis=1))
    stack = np.stack(frames)
    scale = display_scale(stack.shape[1:], scale, width)
    labels = [_LABELS[m] for m in methods] if len(methods) > 1 else []
    return Animation(stack, fps=fps, labels=labels, scale=scale)


def _check_scene(scene):
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    if scene.camera is None:
        raise ValueError("scene: it has no camera to render from")


def _check_film(scene, methods, fps, scale, width):
    """The display options, checked before the first frame renders (the film's size is known)."""
    as_scalar(fps, "fps", minimum=0.0, exclusive=True, maximum=120.0)
    display_scale((scene.camera.height, scene.camera.width * len(methods)), scale, width)


def animate_light(scene, frames: int = 24, *, shading="phong", light_index: int = 0, degrees: float = 360.0,
                  axis=None, fps: float = 12.0, scale=None, width=None, **render_options) -> Animation:
    """A light circling the scene, as a notebook animation.

    Parameters
    ----------
    scene : Scene
        With a camera and at least one light.
    frames : int
        Frames in one turn.
    shading : str or sequence of str
        One method, or several side by side, e.g. ``("flat", "gouraud", "phong")``.
    light_index, degrees, axis
        As :func:`raycast_shade.apps.animate.orbit_light`.
    fps : float
    scale, width
        Display size, as :func:`raycast_shade.output.display.display_scale`.
    **render_options
        For :func:`raycast_shade.render` (``max_depth``, ``interpolation``, ...).

    Returns
    -------
    Animation
    """
    _check_scene(scene)
    methods = _methods(shading)
    _check_film(scene, methods, fps, scale, width)
    scenes = orbit_light(scene, _check_frames(frames), light_index=light_index, degrees=degrees, axis=axis)
    return _film(scenes, None, methods, fps, scale, width, render_options)


def animate_orbit(scene, frames: int = 24, *, shading="phong", degrees: float = 360.0, axis=None,
                  fps: float = 12.0, scale=None, width=None, **render_options) -> Animation:
    """The camera circling its target (a turntable), as a notebook animation.

    Parameters are those of :func:`animate_light`, with ``degrees`` and ``axis``
    as :func:`raycast_shade.apps.animate.orbit_cameras`.

    Returns
    -------
    Animation
    """
    _check_scene(scene)
    methods = _methods(shading)
    _check_film(scene, methods, fps, scale, width)
    cameras = orbit_cameras(scene.camera, _check_frames(frames), degrees=degrees, axis=axis)
    return _film([scene] * len(cameras), cameras, methods, fps, scale, width, render_options)
