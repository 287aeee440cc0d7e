"""``rs.explore(scene)``: the lecture's knobs as notebook sliders, re-rendered live.

Controls (ipywidgets, the ``notebook`` extra): the light's azimuth,
elevation, distance and intensity; ``ka``, ``kd``, ``ks`` and the shininess
``t`` of one model; the attenuation law and its ``k``; the shading method,
or flat | Gouraud | Phong side by side; the interpolation (3D or 2D);
Phong's ``r.v`` or Blinn's ``n.h``; and a wireframe overlay.

Each change re-renders at once. What makes that live: the camera never
moves, so the hit buffer of each interpolation is cast once and kept, and a
change of material or light only re-shades it; a new material reuses the
packed geometry and its BVH (:func:`raycast_shade.shading.terms.with_materials`).
The image is exactly :func:`raycast_shade.render` of :meth:`Explorer.scene`
(``tests/apps/test_explore.py`` checks the PNG bytes). Frame rates:
``benchmarks/bench_explore.py``.

The light is placed on a sphere around the centre of the scene's bounding
box: azimuth about +y from +z (degrees), elevation above the xz plane.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..common.choices import ATTENUATIONS, INTERPOLATIONS, SHADINGS, SPECULAR_MODELS
from ..common.extras import require
from ..common.validate import as_int
from ..output.frame import Frame
from ..output.imagefile import png_bytes
from ..output.tonemap import to_uint8
from ..scene.lights import PointLight
from ..scene.scene import Model, Scene
from ..shading.mirrors import trace_mirrors
from ..shading.shade import shade_hits
from ..shading.terms import with_materials
from ..study.explain import explain
from ..visibility.cast import cast_camera, resolve_caster, secondary_rays
from ..visibility.interpolation import to_screen_space

__all__ = ["explore", "Explorer", "SIDE_BY_SIDE"]

SIDE_BY_SIDE = "flat | gouraud | phong"



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
        The light the sliders move; it becomes a point light (keeping its
        colour and shadows). A scene without lights gets one.
    max_depth : int
        Mirror bounces, as ``render``'s.

    Attributes
    ----------
    controls : dict of str to ipywidgets.Widget
        ``azimuth``, ``elevation``, ``distance``, ``intensity``, ``ka``,
        ``kd``, ``ks``, ``t``, ``attenuation``, ``k``, ``shading``,
        ``interpolation``, ``specular``, ``wireframe``.
    image : ipywidgets.Image
        The PNG of the current frame.
    widget : ipywidgets.Widget
        Image and controls, for display.
    frame : Frame
        The current frame (the left one side by side is flat; this is the Phong one).
    """

    def __init__(self, scene, camera=None, *, model: int = 0, light: int = 0, max_depth: int = 3):
        widgets = require("ipywidgets", "ipywidgets", "explore()", "notebook")
        if not isinstance(scene, Scene):
            raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
        self.camera = camera if camera is not None else scene.camera
        if self.camera is None:
            raise ValueError("camera: the scene has no camera and none was passed")
        self.model = as_int(model, "model", minimum=0, maximum=len(scene.models) - 1)
        self.light = as_int(light, "light", minimum=0, maximum=max(len(scene.lights) - 1, 0))
        self.max_depth = as_int(max_depth, "max_depth", minimum=0)
        self.base = scene
        geo = scene.geometry
        self.centre = geo.origin.copy()
        self._hits = {}
        controls = self._make_controls(widgets, scene, geo.scale)
        self.controls = controls
        self.image = widgets.Image(format="png")
        self.frame = None
        rows = [widgets.HBox([controls[k] for k in names]) for names in (
            ("azimuth", "elevation", "distance", "intensity"), ("ka", "kd", "ks", "t"),
            ("attenuation", "k", "specular", "wireframe"), ("shading",), ("interpolation",))]
        self.widget = widgets.VBox([self.image] + rows)
        for control in controls.values():
            control.observe(self._changed, "value")
        self.update()

    def _make_controls(self, widgets, scene, scale):
        mat = scene.models[self.model].material
        old = scene.lights[self.light] if scene.lights else None
        if isinstance(old, PointLight):
            az, el, dist = _spherical(old.position - self.centre)
            law, k, intensity = old.attenuation, old.k, old.intensity
        else:
            direction = -old.direction if old is not None else np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
            az, el, dist = _spherical(direction * 2.0 * scale)
            law, k, intensity = "none", 1.0, old.intensity if old is not None else 1.0
        kd0 = float(np.max(mat.kd))
        self._tint = mat.kd / kd0 if kd0 > 0 else np.ones(3)
        fs = dict(continuous_update=True, readout_format=".3g", style={"description_width": "initial"})
        return dict(
            azimuth=widgets.FloatSlider(value=az, min=-180.0, max=180.0, step=1.0, description="azimuth", **fs),
            elevation=widgets.FloatSlider(value=el, min=-89.0, max=89.0, step=1.0, description="elevation", **fs),
            distance=widgets.FloatSlider(value=dist, min=0.05 * scale, max=max(10.0 * scale, 2 * dist),
                                         step=0.01 * scale, description="distance d", **fs),
            intensity=widgets.FloatLogSlider(value=max(intensity, 1e-3), min=-3, max=4, description="Ii", **fs),
            ka=widgets.FloatSlider(value=float(np.max(mat.ka)), min=0.0, max=1.0, step=0.01, description="ka", **fs),
            kd=widgets.FloatSlider(value=kd0, min=0.0, max=1.0, step=0.01, description="kd", **fs),
            ks=widgets.FloatSlider(value=float(np.max(mat.ks)), min=0.0, max=1.0, step=0.01, description="Ks", **fs),
            t=widgets.FloatLogSlider(value=mat.shininess, min=0, max=3, description="t (shininess)", **fs),
            attenuation=widgets.Dropdown(options=list(ATTENUATIONS), value=law, description="attenuation"),
            k=widgets.FloatLogSlider(value=k, min=-2, max=2, description="k (heuristic)", **fs),
            shading=widgets.ToggleButtons(options=list(SHADINGS) + [SIDE_BY_SIDE], value="phong",
                                          description="shading"),
            interpolation=widgets.ToggleButtons(options=list(INTERPOLATIONS), value="perspective",
                                                description="interpolation"),
            specular=widgets.ToggleButtons(options=list(SPECULAR_MODELS), value=mat.specular, description="specular"),
            wireframe=widgets.Checkbox(value=False, description="wireframe"),
        )

    def values(self) -> dict:
        """The controls' current values, by name."""
        return {name: c.value for name, c in self.controls.items()}

    def scene(self) -> Scene:
        """The scene the controls describe: new material on the chosen model, the light moved."""
        v = self.values()
        old = self.base.models[self.model].material
        material = dataclasses.replace(old, ka=v["ka"], kd=v["kd"] * self._tint, ks=v["ks"], shininess=v["t"],
                                       specular=v["specular"])
        models = list(self.base.models)
        models[self.model] = Model(models[self.model].mesh, material)
        prev = self.base.lights[self.light] if self.base.lights else None
        light = PointLight(self.centre + _offset(v["azimuth"], v["elevation"], v["distance"]),
                           intensity=v["intensity"], color=prev.color if prev is not None else 1.0,
                           attenuation=v["attenuation"], k=v["k"],
                           shadows=bool(prev.shadows) if prev is not None else False)
        lights = list(self.base.lights)
        if lights:
            lights[self.light] = light
        else:
            lights = [light]
        rows = np.stack([m.material.packed() for m in models])  # what a fresh SceneGeometry packs
        return with_materials(self.base, rows, models=tuple(models), lights=tuple(lights))

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

    def picture(self) -> np.ndarray:
        """(H, W, 3) uint8, or (H, 3 W, 3) side by side: what the image widget shows."""
        v = self.values()
        scene = self.scene()
        methods = list(SHADINGS) if v["shading"] == SIDE_BY_SIDE else [v["shading"]]
        panels = []
        for method in methods:
            frame = self.render(scene, method, v["interpolation"])
            image = frame.overlay(wireframe=True) if v["wireframe"] else frame.image
            panels.append(to_uint8(image))
            self.frame = frame
        return np.concatenate(panels, axis=1) if len(panels) > 1 else panels[0]

    def update(self) -> bytes:
        """Re-render and put the PNG into the image widget; returns its bytes."""
        data = png_bytes(self.picture())
        self.image.value = data
        return data

    def _changed(self, change):
        self.update()

    def _ipython_display_(self):
        from IPython.display import display

        display(self.widget)


def explore(scene, camera=None, *, model: int = 0, light: int = 0, max_depth: int = 3) -> Explorer:
    """Sliders for the lecture's parameters over a live render of ``scene``.

    Shows itself in a notebook cell; see :class:`Explorer` for the
    parameters and the widgets, :meth:`Explorer.scene` for the scene on
    screen and ``explorer.frame.explain(x, y)`` for one of its pixels.

    Raises
    ------
    raycast_shade.common.extras.MissingExtraError
        Without ipywidgets: ``pip install 'raycast_shade[notebook]'``.
    """
    return Explorer(scene, camera, model=model, light=light, max_depth=max_depth)
