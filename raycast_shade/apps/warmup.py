"""``raycast-shade warmup`` and ``warmup()``: compile every kernel into the cache before class.

Numba compiles each kernel the first time a frame needs it and keeps the
machine code in the package's ``__pycache__`` (``cache=True``); a fresh
install or a new Python pays for it once: about two minutes of a first
notebook run, the first render cell alone 35 s. Warm-up renders a set of tiny
scenes that between them take every path the lecture uses (each shading
method and interpolation, both specular models, every attenuation law, point,
directional and spot lights, shadows, mirrors, bump maps, textures, vertex
colours, terms, buffers, anti-aliasing, the raster backend, overlays, tone
maps, ``explain``), so that later frames load their kernels from the cache.
Run it once after installing, or in the break before class.

Each step counts the kernels Numba compiled in it (its ``numba:compile``
events: loading a kernel from the cache fires none), so a second run says
whether the cache is warm: ``compiled 0``.

>>> report = warmup(progress=False)          # doctest: +SKIP
>>> report.compiled                          # doctest: +SKIP
0
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

from ..output.buffers import BUFFER_NAMES
from ..render import render
from ..scene import shapes
from ..scene.camera import Camera
from ..scene.heightmap import HeightMap
from ..scene.lights import DirectionalLight, PointLight, SpotLight
from ..scene.material import Material
from ..scene.mesh import Mesh
from ..scene.scene import Model, Scene
from ..scene.texture import Texture

__all__ = ["warmup", "WarmupReport", "STEPS", "register_cli", "run_cli"]


# -- the scenes ---------------------------------------------------------------------------------------------

def _scene(material=None, lights=None, *, floor=None, mesh=None, w=32, h=24):
    material = material if material is not None else Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40)
    models = [Model(mesh if mesh is not None else shapes.icosphere(2), material)]
    models.append(Model(shapes.plane(5.0, center=(0.0, -1.0, 0.0), normal="+y"),
                           floor if floor is not None else Material(kd=0.6)))
    if lights is None:
        lights = [PointLight((2.0, 3.0, 2.0), intensity=20.0, attenuation="inverse_square", shadows=True)]
    return Scene(models, lights=lights, camera=Camera(eye=(0.0, 1.0, 4.0), target=(0.0, -0.3, 0.0),
                                                            width=w, height=h), ambient=0.1)


def _methods(scene, **kwargs):
    return [render(scene, m, **kwargs) for m in ("flat", "gouraud", "phong")]


def _gap_scene():
    """Two squares a pixel apart, a plane behind: the gap's pixels are flagged, and re-tested
    by the serial repair (:func:`raycast_shade.visibility.holes.fill_holes`)."""
    pitch = 1.0 / 8.0
    squares = [Model(shapes.plane(1.0, center=(x, 0.0, 0.0)), Material(kd=0.6)) for x in (-0.5, 0.5 + pitch)]
    return Scene(squares + [Model(shapes.plane(8.0, center=(0.0, 0.0, -2.0)), Material(kd=0.6))],
                 lights=[DirectionalLight((0.0, 0.0, -1.0), intensity=1.0)],
                 camera=Camera(eye=(0.0, 0.0, 3.0), width=24, height=16, projection="orthographic",
                               ortho_height=16 * pitch))


def _step_core():
    _methods(_scene())  # specular and attenuation on
    render(_gap_scene())


def _variants(floor=None, sun_shadows=False, **kwargs):
    """The three variants other than :func:`_step_core`'s. The kernels (the mirrors' bounce
    shading too) fold "any specular" and "any attenuating light" at compile time: four each.
    ``sun_shadows``: the sun casts shadows (the batched Phong kernel's shadowed variants; with
    :func:`_step_core`'s shadowing lamp, all four)."""
    dull = Material(kd=0.7, ks=0.0)
    sun = [DirectionalLight((-1.0, -1.0, -1.0), intensity=1.0, shadows=sun_shadows)]
    for material, lights in ((dull, sun), (None, sun), (dull, None)):
        _methods(_scene(material, lights, floor=floor), **kwargs)


def _step_variants():
    _variants()
    _variants(sun_shadows=True)


def _step_batched():
    """The batched Phong kernel (shading/phong_fast.py) of frames without shadows, textures or
    bump maps, in its four variants: with and without a specular term and an attenuating light;
    its terms build too (``terms=True``) (its shadowed variants: :func:`_step_core` and
    :func:`_step_variants`)."""
    lamp = [PointLight((2.0, 3.0, 2.0), intensity=20.0, attenuation="inverse_square")]
    sun = [DirectionalLight((-1.0, -1.0, -1.0), intensity=1.0)]
    for material in (Material(kd=0.7, ks=0.0), None):
        for lights in (lamp, sun):
            render(_scene(material, lights), "phong")
            render(_scene(material, lights), "phong", terms=True)


def _step_laws():
    lights = [PointLight((2.0, 3.0, 2.0), intensity=5.0, attenuation="heuristic", k=1.0),
              PointLight((-2.0, 2.0, 1.0), intensity=1.0, attenuation="none")]
    _methods(_scene(Material(kd=0.7, ks=0.4, shininess=20, specular="blinn"), lights))


def _step_screen():
    _methods(_scene(), interpolation="screen")


def _step_spot():
    """A spot light: the kernels' full build (``shading.illumination.LEAN`` holds only point lights and
    lights at infinity), which area lights and the GGX model take too; with mirrors and terms, as the
    other steps take the lean build's."""
    spot = SpotLight(position=(0.0, 3.0, 0.0), direction=(0.0, -1.0, 0.0), intensity=2.2, exponent=8,
                        inner_angle=22, outer_angle=32, shadows=True)
    _methods(_scene(lights=[spot]))
    mirror = Material(kd=0.6, reflectivity=0.4)
    _methods(_scene(lights=[spot], floor=mirror), max_depth=3)
    _methods(_scene(lights=[spot], floor=mirror), terms=True)


def _step_mirror():
    mirror = Material(kd=0.6, reflectivity=0.4)
    _methods(_scene(floor=mirror), max_depth=3)
    _variants(floor=mirror, max_depth=3)


def _step_bump():
    """A bump map, above a mirror floor: a bump-mapped frame's mirror lanes start pixel by pixel,
    a build of the mirror kernel of its own (``raycast-shade demo``'s)."""
    bumps = HeightMap.dimples(6, 0.35, resolution=32, scale=0.02, tiling=(2.0, 2.0))
    _methods(_scene(Material(kd=(0.8, 0.6, 0.3), ks=0.5, shininess=30, bump=bumps),
                    floor=Material(kd=0.6, reflectivity=0.4)), max_depth=3)


def _step_textures():
    checker = Texture.checker(squares=4, texels_per_square=4)
    mapped = _scene(Material(kd_map=checker, ks_map=checker, ks=0.3, shininess=30), mesh=shapes.uv_sphere(8, 16))
    _methods(mapped)
    _methods(mapped, terms=True)  # the terms kernels' textured variants (Gouraud's modulate path too)
    ico = shapes.icosphere(2)
    painted = Mesh(ico.vertices, ico.faces, normals=ico.normals, colors=(ico.vertices + 1.0) / 2.0)
    _methods(_scene(Material(ks=0.2), mesh=painted))


def _step_terms_buffers():
    scene = _scene(floor=Material(kd=0.6, reflectivity=0.3))
    _methods(scene, terms="per_light")
    _variants(terms=True)  # the one-pass terms kernels (every method) fold "any specular" / "any attenuation" too
    # and with shadow rays, in every variant: Phong's general terms kernel (the batched one traces none)
    _methods(_scene(), terms=True)
    _variants(terms=True, sun_shadows=True)
    render(scene, "phong", buffers=tuple(BUFFER_NAMES))


def _step_samples():
    _methods(_scene(), samples=4)


def _step_raster():
    _methods(_scene(), backend="raster")


def _step_auto():
    render(_scene(), "auto")


def _step_display():
    frame = render(_scene(), "gouraud")
    frame.overlay(wireframe=True, vertices=True, normals=True)
    for curve in ("clamp", "reinhard", "exponential"):
        frame.to_uint8(tonemap=curve)
    ys, xs = np.nonzero(frame.mask)
    for method in ("flat", "gouraud", "phong"):
        render(frame.scene, method).explain(int(xs[0]), int(ys[0]))
    mirror = render(_scene(floor=Material(kd=0.6, reflectivity=0.3)), max_depth=1)
    on_floor = np.argwhere(mirror.model_id == 1)
    mirror.explain(int(on_floor[0, 1]), int(on_floor[0, 0]))  # a mirror pixel: its bounce as one cast ray


STEPS = (
    ("flat, Gouraud, Phong", _step_core),
    ("no specular / no attenuation variants", _step_variants),
    ("batched Phong (no shadows or maps)", _step_batched),
    ("heuristic and no attenuation, Blinn", _step_laws),
    ("2D (screen-space) interpolation", _step_screen),
    ("spot light (the full build), mirrors, terms", _step_spot),
    ("mirrors", _step_mirror),
    ("bump map above a mirror", _step_bump),
    ("textures and vertex colours", _step_textures),
    ("terms and buffers", _step_terms_buffers),
    ("anti-aliasing (samples)", _step_samples),
    ("raster backend", _step_raster),
    ("auto shading", _step_auto),
    ("overlays, tone maps, explain", _step_display),
)


# -- running them -------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class WarmupReport:
    """What :func:`warmup` did.

    Attributes
    ----------
    steps : tuple of (str, float, int)
        Per step: its name, seconds, kernels Numba compiled in it (0 when all came from the cache).
    seconds : float
        The whole warm-up.
    """

    steps: tuple
    seconds: float

    @property
    def compiled(self) -> int:
        """Kernels compiled (not loaded from the cache) over all steps."""
        return sum(n for _, _, n in self.steps)

    def __str__(self) -> str:
        width = max(len(name) for name, _, _ in self.steps)
        lines = [f"  {name:<{width}}  {s:6.1f} s  compiled {n}" for name, s, n in self.steps]
        state = "the cache was warm" if self.compiled == 0 else f"{self.compiled} kernels compiled into the cache"
        return "\n".join([f"warm-up: {self.seconds:.1f} s, {state}"] + lines)

    def _repr_pretty_(self, p, cycle):
        p.text(str(self))


def _bar(total: int, progress: bool):
    """A tqdm bar (the notebook's where it runs in one) or plain lines on stderr."""
    if not progress:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    return tqdm(total=total, desc="warm-up", unit="step")


def warmup(progress: bool = True) -> WarmupReport:
    """Compile every kernel the lecture uses into Numba's cache.

    Parameters
    ----------
    progress : bool
        A progress bar (tqdm if installed, else one line per step on stderr).

    Returns
    -------
    WarmupReport
        Per step the seconds and the kernels compiled; ``str()`` is a table.
    """
    import warnings

    from numba.core import event

    from ..common.validate import as_bool

    bar = _bar(len(STEPS), as_bool(progress, "progress"))
    done = []
    t0 = time.perf_counter()
    try:
        for i, (name, step) in enumerate(STEPS):
            if bar is not None:
                bar.set_postfix_str(name)
            elif progress:
                print(f"warm-up {i + 1}/{len(STEPS)}: {name} ...", file=sys.stderr, flush=True)
            ts = time.perf_counter()
            with event.install_recorder("numba:compile") as rec, warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the tiny scenes' pitfalls are not the user's
                step()
            compiled = sum(1 for _, ev in rec.buffer if ev.is_start)
            done.append((name, time.perf_counter() - ts, compiled))
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return WarmupReport(tuple(done), time.perf_counter() - t0)


# -- command line ---------------------------------------------------------------------------------------------

def register_cli(subparsers):
    """Add ``warmup`` to the ``raycast-shade`` subcommands."""
    p = subparsers.add_parser(
        "warmup", help="compile every kernel into the cache (run once before class)",
        description="Render tiny scenes that take every path of the lecture, so that Numba compiles each "
                    "kernel into its on-disk cache now rather than in the first notebook cells. A second "
                    "run reports 'compiled 0' per step: the cache is warm.")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def run_cli(ns) -> int:
    report = warmup(progress=not ns.no_progress)
    print(report)
    return 0
