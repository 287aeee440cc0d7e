"""``rs.explore(scene)``: the lecture's knobs as notebook sliders, re-rendered live.

Controls (ipywidgets, the ``notebook`` extra): the light's azimuth,
elevation, distance and intensity; ``ka``, ``kd``, ``ks`` and the shininess
``t`` of one model; the attenuation law and its ``k``; the shading method,
or flat | Gouraud | Phong side by side (each panel labelled); the
interpolation (3D or 2D); Phong's ``r.v`` or Blinn's ``n.h``; a wireframe
overlay; reset and save. A click on a pixel (with ipyevents installed; the
pixel's x and y boxes otherwise) prints its :func:`raycast_shade.explain`
beside the image, and keeps it up to date as the controls move.

It shows exactly the scene it is given: each slider's range widens to take
the scene's value (``ks = 1.5``, a shininess of 5000, a light of 1e5), and a
control left at its start value leaves that field of the scene as it was
(bit for bit: an RGB ``ka`` or ``ks`` keeps its tint, a spot light its cone,
a directional light stays directional). A value no slider can show (a light
of intensity 0 on the logarithmic slider) is refused with a ValueError.
``max_depth`` is bounded as in :func:`raycast_shade.render`.

Size: the picture is drawn ``width`` pixels wide (440 by default; side by
side, each panel ``min(width, 320)`` pixels, never below the frame's own
width), the pixels drawn as squares (``image-rendering: pixelated``), with
the controls in two columns under it and the explanation beside it, at 14 px
and without a scroll bar of its own (:mod:`.explore_view`), in JupyterLab
on a 1366-px screen with the file browser closed (Ctrl+B): its result first,
in bold, and a flat or Phong printout of one light whole in a 1366x625 view.
Side by side, the printout stands right under the three panels, above the
controls, its head and result on screen with them. The explained pixel is ringed in
every panel and its panel's title names it; switching to or from side by
side keeps explaining the same method's panel, and says so when that
method is no longer on screen.

Each change re-renders at once. What makes that live: the camera never
moves, so the hit buffer of each interpolation is cast once and kept, and a
change of material or light only re-shades it; a new material reuses the
packed geometry and its BVH (:func:`raycast_shade.shading.terms.with_materials`).
The image is exactly :func:`raycast_shade.render` of :meth:`Explorer.scene`
(``tests/apps/test_explore.py`` checks the PNG bytes). Frame rates:
``benchmarks/bench_explore.py``.

The light is placed on a sphere around the centre of the scene's bounding
box: azimuth about +y from +z (degrees), elevation above the xz plane. A
spot light turns with its position (its axis keeps its angle to the line to
the centre); a directional light's direction is the one from that point to
the centre.
"""

from __future__ import annotations

import dataclasses
import math
import os
import threading
import warnings

import numpy as np

from ..common.choices import ATTENUATIONS, INTERPOLATIONS, SHADINGS, SPECULAR_MODELS
from ..common.extras import require
from ..common.validate import as_int, as_path
from ..output.frame import Frame
from ..output.imagefile import check_output_file, check_output_folder, png_bytes
from ..output.tonemap import to_uint8
from ..scene.camera import Camera
from ..scene.lights import DirectionalLight, PointLight, SpotLight
from ..scene.scene import Model, Scene
from ..shading.mirrors import MAX_MIRROR_DEPTH, trace_mirrors
from ..shading.shade import shade_hits
from ..shading.terms import with_materials
from ..insight.explain import explain
from ..visibility.cast import cast_camera, resolve_caster, secondary_rays
from ..visibility.interpolation import to_screen_space
from .explore_view import CONTROL_PX, CSS, EXPLANATION_PX, SIDE_PANEL_PX, explanation_html, marks_html, title_html

__all__ = ["explore", "Explorer", "SIDE_BY_SIDE", "DEFAULT_WIDTH"]

SIDE_BY_SIDE = "flat | gouraud | phong"
DEFAULT_WIDTH = 440  # display pixels of one frame: legible, and leaves room for the controls on 1366 px
_LABELS = {"flat": "flat", "gouraud": "Gouraud", "phong": "Phong"}
_LIGHT_CONTROLS = ("azimuth", "elevation", "distance", "intensity", "attenuation", "k")


def _spherical(offset):
    """Azimuth, elevation (degrees) and distance of a vector (see the module docstring)."""
    d = float(np.linalg.norm(offset))
    if d == 0.0:
        return 0.0, 0.0, 0.0
    return (math.degrees(math.atan2(offset[0], offset[2])), math.degrees(math.asin(np.clip(offset[1] / d, -1, 1))),
            d)


def _offset(azimuth, elevation, distance):
    a, e = math.radians(azimuth), math.radians(elevation)
    return distance * np.array([math.cos(e) * math.sin(a), math.sin(e), math.cos(e) * math.cos(a)])


def _turn(azimuth, elevation) -> np.ndarray:
    """(3, 3) rotation taking +z to the unit vector at ``azimuth``, ``elevation``."""
    a, e = math.radians(azimuth), math.radians(elevation)
    ry = np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(e), -math.sin(e)], [0.0, math.sin(e), math.cos(e)]])
    return ry @ rx.T


def _exponents(value, low, high, name):
    """Log-slider exponent range [low, high] widened to take ``value`` (> 0)."""
    if not value > 0.0:
        raise ValueError(f"{name}: the explorer's slider is logarithmic and cannot show {value:g}; "
                         "give it a positive value")
    e = math.log10(value)
    return min(low, math.floor(e)), max(high, math.ceil(e))


def _tint(value) -> tuple:
    """(slider value, tint): an RGB coefficient as its largest channel times a tint."""
    v = np.broadcast_to(np.asarray(value, np.float64), (3,))
    top = float(v.max())
    return top, (v / top if top > 0 else np.ones(3))


class Explorer:
    """The widgets of :func:`explore` and the scene they describe.

    Parameters
    ----------
    scene : Scene
        With a camera (or pass ``camera``).
    camera : Camera, optional
    model : int
        The model whose material the sliders set.
    light : int
        The light the sliders move (point, spot or directional, kept so).
        A scene without lights gets a point light, with a warning.
    max_depth : int
        Mirror bounces, as ``render``'s (0 to 64).
    width : int
        Display width in pixels of one frame (side by side: ``min(width, 320)``
        per panel); never below the frame's own width.
    save_dir : str or path-like
        Where the save button writes ``explorer_001.png``, ...

    Attributes
    ----------
    controls : dict of str to ipywidgets.Widget
        ``azimuth``, ``elevation``, ``distance``, ``intensity``, ``ka``,
        ``kd``, ``ks``, ``t``, ``attenuation``, ``k``, ``shading``,
        ``interpolation``, ``specular``, ``wireframe``.
    pixel : dict of str to ipywidgets.BoundedIntText
        ``x``, ``y`` of the explained pixel; ``panel`` which frame side by side.
    image : ipywidgets.Image
        The PNG of the current frame (or of the three side by side).
    explanation : ipywidgets.HTML
        The explained pixel's :func:`raycast_shade.explain`.
    widget : ipywidgets.Widget
        Everything, for display.
    frame : Frame
        The current frame (side by side: the Phong one); ``frames`` all panels.
    """

    def __init__(self, scene, camera=None, *, model: int = 0, light: int = 0, max_depth: int = 3,
                 width: int = DEFAULT_WIDTH, save_dir=".") -> None:
        widgets = require("ipywidgets", "ipywidgets", "explore()", "notebook")
        if not isinstance(scene, Scene):
            raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
        if camera is not None and not isinstance(camera, Camera):
            raise TypeError(f"camera: expected a Camera, got {type(camera).__name__}")
        self.camera = camera if camera is not None else scene.camera
        if self.camera is None:
            raise ValueError("camera: the scene has no camera and none was passed")
        self.model = as_int(model, "model", minimum=0, maximum=len(scene.models) - 1)
        self.light = as_int(light, "light", minimum=0, maximum=max(len(scene.lights) - 1, 0))
        self.max_depth = as_int(max_depth, "max_depth", minimum=0, maximum=MAX_MIRROR_DEPTH)
        self.width = as_int(width, "width", minimum=16, maximum=4096)
        self.save_dir = as_path(save_dir, "save_dir")
        if os.path.lexists(self.save_dir) and not os.path.isdir(self.save_dir):  # the save button would fail
            raise ValueError(f"save_dir: {self.save_dir!r} is a file, not a folder")
        if not scene.lights:
            warnings.warn("explore: the scene has no lights; the explorer adds a white point light "
                          "(Explorer.scene() includes it)", stacklevel=3)
        self.base = scene
        geo = scene.geometry
        self.centre = geo.origin.copy()
        self._hits = {}
        self._quiet = False
        self._lock = threading.RLock()
        self.controls = self._make_controls(widgets, scene, geo.scale)
        self.initial = self.values()
        self.frame, self.frames, self.saved = None, [], []
        # the explained panel's method, why it changed (if it did), the methods on screen
        self._explained, self._note, self._shown = None, "", []
        self._build_layout(widgets)
        for control in self.controls.values():
            control.observe(self._changed, "value")
        for control in self.pixel.values():
            control.observe(self._explain_changed, "value")
        self.update()

    # -- controls ----------------------------------------------------------------------------------------

    def _light_start(self, scene, scale):
        """(azimuth, elevation, distance, law, k, intensity) of the explored light."""
        old = scene.lights[self.light] if scene.lights else None
        if isinstance(old, PointLight):
            az, el, dist = _spherical(old.position - self.centre)
            return az, el, dist, old.attenuation, old.k, old.intensity
        direction = -np.asarray(old.direction, np.float64) if old is not None else np.ones(3) / math.sqrt(3.0)
        az, el, dist = _spherical(direction * 2.0 * scale)
        return az, el, dist, "none", 1.0, old.intensity if old is not None else 1.0

    def _make_controls(self, widgets, scene, scale):
        mat = scene.models[self.model].material
        old = scene.lights[self.light] if scene.lights else None
        az, el, dist, law, k, intensity = self._light_start(scene, scale)
        self._kind = "directional" if isinstance(old, DirectionalLight) else "point"
        ka, self._tint_ka = _tint(mat.ka)
        kd, self._tint = _tint(mat.kd)
        ks, self._tint_ks = _tint(mat.ks)
        lo_i, hi_i = _exponents(intensity, -3, 4, f"light {self.light} intensity")
        lo_t, hi_t = _exponents(mat.shininess, 0, 3, "material shininess")
        lo_k, hi_k = _exponents(k, -2, 2, f"light {self.light} k")
        # Two columns of 216 px (their readouts narrowed by CSS) stay within the 440-px picture's width,
        # leaving the printout beside it 84 characters a line on a 1366-px screen.
        ds = dict(style={"description_width": "90px"}, layout=widgets.Layout(width=f"{CONTROL_PX}px"))
        fs = dict(continuous_update=True, readout_format=".3g", **ds)

        def slider(cls, value, lo, hi, description, **kw):
            # min and max first: a value set before its range would be clamped to the default one
            w = cls(min=lo, max=hi, description=description, **kw, **fs)
            w.value = value
            return w

        controls = dict(
            azimuth=slider(widgets.FloatSlider, az, -180.0, 180.0, "azimuth", step=1.0),
            elevation=slider(widgets.FloatSlider, el, -90.0, 90.0, "elevation", step=1.0),
            distance=slider(widgets.FloatSlider, dist, min(0.05 * scale, dist), max(10.0 * scale, 2.0 * dist),
                            "distance d", step=0.01 * scale),
            intensity=slider(widgets.FloatLogSlider, intensity, lo_i, hi_i, "Ii"),
            ka=slider(widgets.FloatSlider, ka, 0.0, max(1.0, ka), "ka", step=0.01),
            kd=slider(widgets.FloatSlider, kd, 0.0, max(1.0, kd), "kd", step=0.01),
            ks=slider(widgets.FloatSlider, ks, 0.0, max(1.0, ks), "Ks", step=0.01),
            t=slider(widgets.FloatLogSlider, float(mat.shininess), lo_t, hi_t, "t (shininess)"),
            attenuation=widgets.Dropdown(options=list(ATTENUATIONS), value=law, description="attenuation", **ds),
            k=slider(widgets.FloatLogSlider, k, lo_k, hi_k, "k (heuristic)"),
            shading=widgets.Dropdown(options=list(SHADINGS) + [SIDE_BY_SIDE], value="phong", description="shading",
                                     **ds),
            interpolation=widgets.Dropdown(options=list(INTERPOLATIONS), value="perspective",
                                           description="interpolation", **ds),
            specular=widgets.Dropdown(options=list(SPECULAR_MODELS), value=mat.specular, description="specular",
                                      **ds),
            wireframe=widgets.Checkbox(value=False, description="wireframe", indent=False,
                                       layout=widgets.Layout(width="140px")),
        )
        if self._kind == "directional":  # no position: no distance, no attenuation
            for name in ("distance", "attenuation", "k"):
                controls[name].disabled = True
        return controls

    def _build_layout(self, widgets):
        c = self.controls
        self.image = widgets.Image(format="png")
        self.image.add_class("rs-explorer-image")
        self.marks = widgets.HTML()  # rings over the explained pixel, drawn over the picture, not into it
        self.marks.add_class("rs-explorer-marks")
        stage = widgets.Box([self.image, self.marks])
        stage.add_class("rs-explorer-stage")
        self.titles = widgets.HBox([])
        h, w = self.camera.height, self.camera.width
        self.pixel = dict(
            x=widgets.BoundedIntText(value=w // 2, min=0, max=w - 1, description="pixel x",
                                     layout=widgets.Layout(width="115px"), style={"description_width": "45px"}),
            y=widgets.BoundedIntText(value=h // 2, min=0, max=h - 1, description="y",
                                     layout=widgets.Layout(width="85px"), style={"description_width": "15px"}),
            panel=widgets.BoundedIntText(value=0, min=0, max=2, description="panel",
                                         layout=widgets.Layout(width="100px"), style={"description_width": "40px"}))
        # as tall as its text (not stretched to the controls' column), so its frame ends where the text does
        self.explanation = widgets.HTML(layout=widgets.Layout(border="1px solid #ccc", align_self="flex-start"))
        self.explanation.add_class("rs-explorer-text")
        self.status = widgets.Label("click a pixel to explain it" + ("" if self._click_events() else
                                                                    " (pip install ipyevents; or set x, y)"),
                                    layout=widgets.Layout(width=f"{2 * CONTROL_PX}px"))
        reset = widgets.Button(description="reset", layout=widgets.Layout(width="70px"))
        save = widgets.Button(description="save frame", layout=widgets.Layout(width="95px"))
        reset.on_click(lambda _: self.reset())
        save.on_click(lambda _: self._save_clicked())
        self.buttons = dict(reset=reset, save=save)
        light = widgets.VBox([c[k] for k in _LIGHT_CONTROLS])
        material = widgets.VBox([c[k] for k in ("ka", "kd", "ks", "t", "specular", "shading")])
        c["wireframe"].layout.width = "105px"
        view = widgets.HBox([c["interpolation"], c["wireframe"], reset])
        pixel = widgets.HBox([save, self.pixel["x"], self.pixel["y"], self.pixel["panel"]])
        self._picture = (self.titles, stage)
        self._under = (widgets.HBox([light, material]), view, pixel, self.status)
        self._left = widgets.VBox()
        self._body = widgets.HBox(layout=widgets.Layout(flex_flow="row wrap"))
        self.widget = widgets.VBox([widgets.HTML(CSS), self._body])
        self.widget.add_class("rs-explorer")
        self._widgets = widgets
        self._arrange(1)

    def _arrange(self, n: int) -> None:
        """One picture: the printout beside it, filling the row (at least EXPLANATION_PX; under it on a
        narrower screen). Side by side: the printout right under the panels, as wide as they are, and
        the controls under it, so that its head and result are on screen with the panels."""
        box = self.explanation.layout
        if n == 1:
            self._left.children = self._picture + self._under
            self._body.children = (self._left, self.explanation)
            box.width, box.flex = None, f"1 1 {EXPLANATION_PX}px"
        else:
            self._left.children = self._picture + (self.explanation,) + self._under
            self._body.children = (self._left,)
            box.width, box.flex = f"{self.panel_width() * n}px", "0 0 auto"

    def _click_events(self) -> bool:
        """Clicks on the image through ipyevents, when it is installed."""
        if getattr(self, "_events", None) is not None:
            return True
        try:
            from ipyevents import Event
        except ImportError:
            self._events = None
            return False
        self._events = Event(source=self.image, watched_events=["click"])
        self._events.on_dom_event(self.click)
        return True

    def at_start(self, name: str, values: dict) -> bool:
        """Whether control ``name`` is at its start value: equal, or for a slider within half a
        step of it (the browser's slider snaps the scene's value to its grid, 40 to 39.81 on a
        logarithmic one, and sends that back; the field then stays the scene's own)."""
        v, s, c = values[name], self.initial[name], self.controls[name]
        if v == s:
            return True
        step = getattr(c, "step", None)
        if not isinstance(v, float) or not step:
            return False
        if hasattr(c, "base"):  # FloatLogSlider: the step is in the exponent
            return v > 0 and s > 0 and abs(math.log(v / s, c.base)) <= 0.5 * step * (1 + 1e-9)
        return abs(v - s) <= 0.5 * step * (1 + 1e-9)

    def values(self) -> dict:
        """The controls' current values, by name."""
        return {name: c.value for name, c in self.controls.items()}

    def reset(self) -> None:
        """Every control back to the scene's own value; one re-render."""
        with self._lock:
            self._quiet = True
            try:
                for name, value in self.initial.items():
                    self.controls[name].value = value
            finally:
                self._quiet = False
            self.update()

    # -- the scene ---------------------------------------------------------------------------------------

    def _material(self, v):
        old = self.base.models[self.model].material
        s = self.initial
        at = self.at_start
        if all(at(k, v) for k in ("ka", "kd", "ks", "t", "specular")):
            return old

        def coef(name, field, tint):  # a control left alone keeps the field as given, bit for bit
            return getattr(old, field) if at(name, v) else v[name] * tint

        return dataclasses.replace(old, ka=coef("ka", "ka", self._tint_ka), kd=coef("kd", "kd", self._tint),
                                   ks=coef("ks", "ks", self._tint_ks),
                                   shininess=old.shininess if at("t", v) else v["t"], specular=v["specular"])

    def _light(self, v):
        s = self.initial
        prev = self.base.lights[self.light] if self.base.lights else None
        at = self.at_start
        moved = not all(at(k, v) for k in ("azimuth", "elevation", "distance"))
        if prev is not None and all(at(k, v) for k in _LIGHT_CONTROLS):
            return prev  # as given: replace() would re-normalise a direction by an ulp
        if prev is None:
            return PointLight(self.centre + _offset(v["azimuth"], v["elevation"], v["distance"]),
                              intensity=v["intensity"], attenuation=v["attenuation"], k=v["k"])
        intensity = prev.intensity if at("intensity", v) else v["intensity"]
        if isinstance(prev, DirectionalLight):
            direction = -_offset(v["azimuth"], v["elevation"], 1.0) if moved else prev.direction
            return dataclasses.replace(prev, direction=direction, intensity=intensity)
        changes = dict(intensity=intensity, attenuation=v["attenuation"], k=prev.k if at("k", v) else v["k"])
        if moved:
            changes["position"] = self.centre + _offset(v["azimuth"], v["elevation"], v["distance"])
            if isinstance(prev, SpotLight):  # turns with its position, as a rigid body about the centre
                r = _turn(v["azimuth"], v["elevation"]) @ _turn(s["azimuth"], s["elevation"]).T
                changes["direction"] = r @ np.asarray(prev.direction, np.float64)
        return dataclasses.replace(prev, **changes)

    def scene(self) -> Scene:
        """The scene the controls describe: the chosen model's material and light as the controls set them;
        with every control at its start, the scene given (same materials and lights)."""
        v = self.values()
        models = list(self.base.models)
        models[self.model] = Model(models[self.model].mesh, self._material(v))
        lights = list(self.base.lights)
        if lights:
            lights[self.light] = self._light(v)
        else:
            lights = [self._light(v)]
        rows = np.stack([m.material.packed() for m in models])  # what a fresh SceneGeometry packs
        return with_materials(self.base, rows, models=tuple(models), lights=tuple(lights))

    # -- rendering ---------------------------------------------------------------------------------------

    def _hit_buffer(self, scene, interpolation):
        """The camera's hits, cast once per interpolation (the camera never moves)."""
        if interpolation not in self._hits:
            caster = resolve_caster("auto", secondary_rays(scene, self.max_depth))
            hits = cast_camera(scene.geometry, self.camera, caster)
            if interpolation == "screen":
                hits = to_screen_space(hits, scene.geometry, self.camera)
            self._hits[interpolation] = hits
        return self._hits[interpolation]

    def render(self, scene, shading: str, interpolation: str) -> Frame:
        """The frame :func:`raycast_shade.render` makes of ``scene``, from the kept hit buffer."""
        hits = self._hit_buffer(scene, interpolation)
        image = shade_hits(scene, self.camera, hits, shading)
        if scene.geometry.reflective and self.max_depth > 0:
            trace_mirrors(scene, self.camera, hits, image, self.max_depth)
        return Frame(image=image, hits=hits, shading=shading, scene=scene, camera=self.camera,
                     max_depth=self.max_depth, explainer=explain)

    def methods(self) -> list:
        """The shading methods on screen, left to right."""
        shading = self.controls["shading"].value
        return list(SHADINGS) if shading == SIDE_BY_SIDE else [shading]

    def picture(self) -> np.ndarray:
        """(H, W, 3) uint8, or (H, 3 W, 3) side by side: what the image widget shows."""
        v = self.values()
        scene = self.scene()
        panels, frames = [], []
        for method in self.methods():
            frame = self.render(scene, method, v["interpolation"])
            image = frame.overlay(wireframe=True) if v["wireframe"] else frame.image
            panels.append(to_uint8(image))
            frames.append(frame)
        self.frames, self.frame = frames, frames[-1]  # swapped in whole, never seen half built
        return np.concatenate(panels, axis=1) if len(panels) > 1 else panels[0]

    def panel_width(self) -> int:
        """Display pixels of one panel: ``width`` (side by side, at most 320), never below the frame's
        own width; the browser draws the pixels as squares (``image-rendering: pixelated``)."""
        room = self.width if len(self.methods()) == 1 else min(self.width, SIDE_PANEL_PX)
        return max(self.camera.width, room)

    def update(self) -> bytes:
        """Re-render, put the PNG into the image widget and re-explain the chosen pixel; returns the PNG.

        One update at a time: the kernel may deliver a widget's change from the browser on another
        thread while a cell is changing the controls, and the picture, the titles and the explanation
        must come from one state."""
        with self._lock:
            return self._update()

    def _update(self) -> bytes:
        data = png_bytes(self.picture())
        self.image.value = data
        self.image.layout.width = f"{self.panel_width() * len(self.frames)}px"
        self._arrange(len(self.frames))
        self.titles.children = [self._widgets.HTML() for _ in self.frames]
        methods = [f.shading for f in self.frames]
        # The panel explained before stays explained: the same method's panel, wherever it now stands.
        panel = methods.index(self._explained) if self._explained in methods else 0
        if self._explained is not None and self._explained not in methods:
            self._note = (f"{_LABELS[self._explained]} is no longer on screen: "
                          f"now explaining the {_LABELS[methods[0]]} panel")
        elif methods != self._shown:
            self._note = ""  # the panel explained is on screen again: nothing to explain about it
        self._shown = methods
        self._quiet = True
        try:
            self.pixel["panel"].max = len(self.frames) - 1
            self.pixel["panel"].value = panel
        finally:
            self._quiet = False
        self._explain()
        return data

    def _changed(self, change):
        if not self._quiet:
            self.update()

    # -- pixels ------------------------------------------------------------------------------------------

    def explain(self, x: int, y: int, panel: int | None = None):
        """The :func:`raycast_shade.explain` of pixel (x, y) of a panel (the last by default), and it
        becomes the pixel explained beside the image."""
        with self._lock:
            panel = len(self.frames) - 1 if panel is None else panel
            self._quiet = True
            try:
                self.pixel["panel"].value = panel
                self.pixel["x"].value, self.pixel["y"].value = x, y
            finally:
                self._quiet = False
            self._note = ""  # chosen, not carried over
            return self._explain()

    def click(self, event: dict) -> None:
        """An ipyevents click on the image: the pixel under the mouse, in the panel it fell in."""
        n, w, h = len(self.frames), self.camera.width, self.camera.height
        if event.get("boundingRectWidth"):
            fx = float(event["relativeX"]) / float(event["boundingRectWidth"]) * n * w
            fy = float(event["relativeY"]) / float(event["boundingRectHeight"]) * h
        else:
            fx, fy = float(event.get("dataX", 0)), float(event.get("dataY", 0))
        ix = min(max(int(math.floor(fx)), 0), n * w - 1)
        self.explain(ix % w, min(max(int(math.floor(fy)), 0), h - 1), ix // w)

    def _explain_changed(self, change):
        if not self._quiet:
            self._note = ""
            self._explain()

    def _explain(self):
        with self._lock:
            return self._explain_now()

    def _explain_now(self):
        if not self.frames:
            return None
        panel = min(self.pixel["panel"].value, len(self.frames) - 1)
        x, y = self.pixel["x"].value, self.pixel["y"].value
        e = self.frames[panel].explain(x, y)
        self._explained = self.frames[panel].shading
        label = _LABELS[self._explained]
        self.explanation.value = explanation_html(label, x, y, str(e), self._note)
        pw, n = self.panel_width(), len(self.frames)
        for i, (title, f) in enumerate(zip(self.titles.children, self.frames)):
            title.value = title_html(_LABELS[f.shading], pw, i == panel, x, y)
        self.marks.value = marks_html(n, pw, self.camera.width, self.camera.height, x, y, panel)
        return e

    # -- saving ------------------------------------------------------------------------------------------

    def save(self, path=None) -> str:
        """Write the picture on screen as a PNG (its own pixels, panels side by side); returns the path.

        Parameters
        ----------
        path : str or path-like, optional
            Ends in ``.png``; by default the next free ``explorer_NNN.png`` in ``save_dir``.
        """
        if path is None:
            i = 1
            while os.path.exists(os.path.join(self.save_dir, f"explorer_{i:03d}.png")):
                i += 1
            path = os.path.join(self.save_dir, f"explorer_{i:03d}.png")
            check_output_folder(self.save_dir, "save_dir")
            os.makedirs(self.save_dir, exist_ok=True)
        path = as_path(path, "path")
        if not path.lower().endswith(".png"):
            raise ValueError(f"path: the explorer saves .png files, got {path!r}")
        check_output_file(path, "path")  # a folder, a missing or unwritable place: named, nothing written
        with open(path, "wb") as f:
            f.write(bytes(self.image.value))
        self.saved.append(path)
        return path

    def _save_clicked(self):
        try:
            self.status.value = f"saved {self.save(None)}"
        except (OSError, ValueError) as exc:
            self.status.value = f"could not save: {exc}"

    def _ipython_display_(self):
        from IPython.display import display

        display(self.widget)


def explore(scene, camera=None, *, model: int = 0, light: int = 0, max_depth: int = 3, width: int = DEFAULT_WIDTH,
            save_dir=".") -> Explorer:
    """Sliders for the lecture's parameters over a live render of ``scene``.

    Shows itself in a notebook cell; see :class:`Explorer` for the
    parameters and the widgets, :meth:`Explorer.scene` for the scene on
    screen and :meth:`Explorer.explain` (or a click) for one of its pixels.

    Raises
    ------
    raycast_shade.common.extras.MissingExtraError
        Without ipywidgets: ``pip install 'raycast_shade[notebook]'``.
    ValueError
        ``max_depth`` above 64 (as :func:`raycast_shade.render`), a value no slider can show.
    """
    return Explorer(scene, camera, model=model, light=light, max_depth=max_depth, width=width, save_dir=save_dir)
