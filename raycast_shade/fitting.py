"""Fitting the lecture's parameters to a target image: :func:`fit`.

The inverse problem of the reflectance equation: given a target linear image (a photograph's
linear radiance, or a frame rendered with parameters to recover), find the material, ambient
and light parameters whose render matches it. The hit buffer is cast once and held fixed (those
parameters do not move the geometry); each evaluation re-shades it with the
library's own kernels (:class:`~raycast_shade.shading.shade.SampleShading`, the image
:func:`raycast_shade.render` gives) and differentiates it with :func:`raycast_shade.grad`'s
kernels; SciPy's L-BFGS-B takes the steps, within each parameter's bounds. The geometry (each
model's translation, the camera's eye) is fitted apart: each evaluation renders the moved scene
and differentiates it with the edge term.

Each parameter block is optimised in units of its starting size (a diagonal preconditioning:
a light 5 units away and a kd of 0.5 both start at 1), and the loss in units of its
starting value, so that the optimiser's tolerances mean the same for any scene.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .common.layout import (ATT_HEURISTIC, LIGHT_ATT, LIGHT_DIRECTIONAL, LIGHT_K, LIGHT_KIND, LIGHT_RADIANCE,
                            LIGHT_VEC, MAT_KA, MAT_KD, MAT_KS, MAT_SHININESS)
from .common.validate import as_array, as_bool, as_int, as_names
from .gradients import check_scene, named
from .render import render
from .scene.scene import Scene
from .shading.grad_frame import frame_vjp
from .common.samples import check_samples
from .shading.inputs import lighting, prepare
from .shading.shade import SampleShading, resolve_methods

__all__ = ["fit", "FitResult", "FIT_PARAMS", "LOSSES"]

FIT_PARAMS = ("ka", "kd", "ks", "shininess", "ambient", "light_position", "light_direction", "light_radiance",
              "light_intensity", "light_k", "translation", "camera_eye")
"""The names :func:`fit` fits (each for every model or every light of the kind it applies to)."""
GEOMETRY_PARAMS = ("translation", "camera_eye")
"""The names that move the geometry (fitted together, apart from the shading's parameters)."""
LOSSES = ("l2",)
"""Built-in losses: ``"l2"``, the mean of ``(I - target)^2`` over pixels and channels."""

_COLUMNS = {"ka": MAT_KA, "kd": MAT_KD, "ks": MAT_KS}


@dataclass(frozen=True, eq=False)
class FitResult:
    """What :func:`fit` found.

    Attributes
    ----------
    scene : Scene
        The scene with the fitted parameters.
    values : dict of str to ndarray
        Each fitted parameter, shaped as :func:`raycast_shade.grad` returns its gradient
        (rows only for the lights it applies to: ``light_position`` (P, 3) for the P point and
        spot lights, in scene order, ...).
    losses : tuple of float
        The loss at the start and after every iteration.
    images : tuple of (H, W, 3) float32
        The image at the start and after every iteration (``keep_images=True``; else empty).
    success : bool
        The optimiser's verdict (converged within ``max_iter``).
    message : str
        The optimiser's reason for stopping.
    evaluations : int
        Renders and gradients evaluated.
    """

    scene: Scene
    values: dict
    losses: tuple
    images: tuple
    success: bool
    message: str
    evaluations: int


@dataclass
class _State:
    """The packed rows being fitted: material rows, light rows, ambient."""

    mats: np.ndarray
    lights: np.ndarray
    ambient: np.ndarray


def _light_rows(lights, name) -> np.ndarray:
    """The light rows a light parameter applies to."""
    kind = lights[:, LIGHT_KIND]
    if name == "light_position":
        return np.flatnonzero(kind != LIGHT_DIRECTIONAL)
    if name == "light_direction":
        return np.flatnonzero(kind == LIGHT_DIRECTIONAL)
    if name == "light_k":
        return np.flatnonzero((kind != LIGHT_DIRECTIONAL) & (lights[:, LIGHT_ATT] == ATT_HEURISTIC))
    return np.arange(lights.shape[0])


class _Block:
    """One fitted parameter: how it reads from and writes to the packed rows, and its gradient."""

    def __init__(self, name, scene, state, origin):
        self.name, self.origin = name, origin
        self.rows = _light_rows(state.lights, name) if name.startswith("light") else None
        if self.rows is not None and len(self.rows) == 0:
            raise ValueError(f"params: {name!r} applies to no light of this scene")
        self.colors = np.array([np.broadcast_to(light.color, 3) for light in scene.lights], float).reshape(-1, 3)
        x0 = self.get(state)
        self.size = x0.size
        floor = {"shininess": 1.0, "light_position": 1.0, "light_direction": 1.0}.get(name, 0.05)
        self.scale = max(float(np.max(np.abs(x0))), floor)
        lo = {"shininess": 1e-3, "light_k": 1e-9}.get(name, 0.0)
        self.bounds = [(None, None)] * self.size if name in ("light_position", "light_direction") else \
            [(lo / self.scale, None)] * self.size

    def get(self, st) -> np.ndarray:
        n, r = self.name, self.rows
        if n in _COLUMNS:
            return st.mats[:, _COLUMNS[n]:_COLUMNS[n] + 3].ravel().copy()
        if n == "shininess":
            return st.mats[:, MAT_SHININESS].copy()
        if n == "ambient":
            return st.ambient.copy()
        if n == "light_position":
            return (st.lights[r, LIGHT_VEC:LIGHT_VEC + 3] + self.origin).ravel()
        if n == "light_direction":
            return (-st.lights[r, LIGHT_VEC:LIGHT_VEC + 3]).ravel()
        if n == "light_radiance":
            return st.lights[r, LIGHT_RADIANCE:LIGHT_RADIANCE + 3].ravel().copy()
        if n == "light_intensity":
            rad = st.lights[r, LIGHT_RADIANCE:LIGHT_RADIANCE + 3]
            return np.array([np.max(q) / max(np.max(c), 1e-300) for q, c in zip(rad, self.colors[r])])
        return st.lights[r, LIGHT_K].copy()  # light_k

    def set(self, st, x) -> None:
        n, r = self.name, self.rows
        if n in _COLUMNS:
            st.mats[:, _COLUMNS[n]:_COLUMNS[n] + 3] = x.reshape(-1, 3)
        elif n == "shininess":
            st.mats[:, MAT_SHININESS] = x
        elif n == "ambient":
            st.ambient[:] = x
        elif n == "light_position":
            st.lights[r, LIGHT_VEC:LIGHT_VEC + 3] = x.reshape(-1, 3) - self.origin
        elif n == "light_direction":
            d = x.reshape(-1, 3)
            st.lights[r, LIGHT_VEC:LIGHT_VEC + 3] = -d / np.linalg.norm(d, axis=1, keepdims=True)
        elif n == "light_radiance":
            st.lights[r, LIGHT_RADIANCE:LIGHT_RADIANCE + 3] = x.reshape(-1, 3)
        elif n == "light_intensity":
            st.lights[r, LIGHT_RADIANCE:LIGHT_RADIANCE + 3] = x[:, None] * self.colors[r]
        else:
            st.lights[r, LIGHT_K] = x

    def gradient(self, g, x) -> np.ndarray:
        """This block's part of ``dL/dx`` from :func:`raycast_shade.grad`'s named arrays ``g``."""
        n, r = self.name, self.rows
        if n == "light_direction":  # g is tangent at the unit direction; x is normalised in set()
            d = x.reshape(-1, 3)
            return (g[n][r] / np.linalg.norm(d, axis=1, keepdims=True)).ravel()
        if r is not None:
            return np.asarray(g[n])[r].ravel()
        return np.asarray(g[n]).ravel()


def _check_target(target, camera) -> np.ndarray:
    shape = (camera.height, camera.width, 3)
    if not isinstance(target, np.ndarray):
        raise TypeError(f"target: expected a NumPy array of shape {shape}, got {type(target).__name__}")
    return as_array(target, "target", dtype=np.float64, shape=shape)


def _loss_fn(loss):
    """``loss(image) -> (value, dL/dimage)`` for a built-in name or a callable."""
    if callable(loss):
        return loss
    if not isinstance(loss, str) or loss.lower() not in LOSSES:
        raise ValueError(f"loss: expected one of {list(LOSSES)} or a callable, got {loss!r}")

    def l2(image, target):
        r = image - target
        return float(np.mean(r * r)), (2.0 / r.size) * r

    return l2


class _GeometryProblem:
    """Each model's translation and the camera's eye: x -> (loss, dL/dx), each evaluation
    rendered afresh (what each pixel sees moves) with ``samples`` rays per pixel and
    differentiated with the edge term (:func:`raycast_shade.grad`'s ``edges=True``)."""

    def __init__(self, scene, shading, names, lossf, target, samples):
        self.scene, self.shading, self.lossf, self.target, self.samples = scene, shading, lossf, target, samples
        self.names = names
        self.counts = np.diff(scene.geometry.vertex_offsets)
        self.evaluations = 0
        self.sizes = [3 * len(scene.models) if n == "translation" else 3 for n in names]
        self.scale = max(float(scene.geometry.reach), 1e-12)  # x in units of the scene's size
        self.blocks = ()

    def x0(self) -> np.ndarray:
        return np.zeros(sum(self.sizes))

    def values(self, x) -> dict:
        out, i = {}, 0
        for n, k in zip(self.names, self.sizes):
            v = x[i:i + k] * self.scale
            out[n] = v.reshape(-1, 3) if n == "translation" else v + np.asarray(self.scene.camera.eye, float)
            i += k
        return out

    def moved(self, x) -> Scene:
        from .scene.mesh import Mesh

        values = self.values(x)
        scene = self.scene
        if "translation" in values:
            models = []
            for model, t in zip(scene.models, values["translation"]):
                m = model.mesh
                mesh = Mesh(np.asarray(m.vertices) + t, m.faces, normals=m.normals, uvs=m.uvs)
                models.append(dataclasses.replace(model, mesh=mesh))
            scene = scene.replace(models=tuple(models))
        if "camera_eye" in values:
            cam = scene.camera
            step = values["camera_eye"] - np.asarray(cam.eye, float)
            scene = scene.replace(camera=cam.replace(eye=tuple(values["camera_eye"]),
                                                     target=tuple(np.asarray(cam.target, float) + step)))
        return scene

    def evaluate(self, x):
        from .gradients import grad

        scene = self.moved(x)
        frame = render(scene, self.shading, samples=self.samples)
        value, g_img = self.lossf(frame.image.astype(np.float64), self.target)
        wrt = ("vertices", "camera_eye")
        g = grad(scene, np.ascontiguousarray(g_img, np.float64), wrt, shading=self.shading, frame=frame,
                 edges=True, samples=self.samples)
        parts = []
        for n in self.names:
            if n == "translation":  # a model's translation moves each of its vertices
                parts.append(np.add.reduceat(g["vertices"], self.scene.geometry.vertex_offsets[:-1], axis=0).ravel())
            else:
                parts.append(g["camera_eye"])
        self.evaluations += 1
        return value, np.concatenate(parts) * self.scale, frame.image


class _Problem:
    """The fixed hit buffer, the packed inputs and the blocks: x -> (loss, dL/dx)."""

    def __init__(self, scene, shading, names, lossf, target):
        self.scene, self.shading, self.lossf, self.target = scene, shading, lossf, target
        self.modes = resolve_methods(scene, shading)
        frame = render(scene, shading)
        self.hits, self.base = frame.hits, frame.inputs
        check_scene(scene, self.base)
        L = self.base.lighting
        self.state = _State(self.base.materials.copy(), L.lights.copy(), np.array(L.ambient, float))
        self.blocks = [_Block(n, scene, self.state, scene.geometry.origin) for n in names]
        self.evaluations = 0

    def x0(self) -> np.ndarray:
        return np.concatenate([b.get(self.state) / b.scale for b in self.blocks])

    def _apply(self, x):
        i = 0
        for b in self.blocks:
            b.set(self.state, x[i:i + b.size] * b.scale)
            i += b.size
        L = self.base.lighting
        st = self.state
        return dataclasses.replace(self.base, materials=st.mats.copy(),
                                   lighting=lighting(st.ambient.copy(), st.lights.copy(), st.mats, L.dmin, L.handle,
                                                     L.unit, L.ext))

    def image(self, x):
        inputs = self._apply(x)
        return inputs, SampleShading(self.scene, self.scene.camera, self.shading, inputs=inputs).shade(self.hits)

    def evaluate(self, x):
        """``(loss, dL/dx, image)`` at the scaled parameters ``x``."""
        inputs, image = self.image(x)
        value, g_img = self.lossf(image.astype(np.float64), self.target)
        params = frame_vjp(self.hits, inputs, self.modes, np.ascontiguousarray(g_img, np.float64),
                           self.scene.geometry)[0]
        g = named(params, {}, self.scene, inputs, [b.name for b in self.blocks])
        parts, i = [], 0
        for b in self.blocks:
            parts.append(b.gradient(g, x[i:i + b.size] * b.scale) * b.scale)
            i += b.size
        self.evaluations += 1
        return value, np.concatenate(parts), image

    def values(self, x) -> dict:
        self._apply(x)
        out = {}
        for b in self.blocks:
            v = b.get(self.state)
            out[b.name] = v.reshape(-1, 3) if b.name not in ("shininess", "light_intensity", "light_k") else v
        return out


def _fitted_scene(scene, values, blocks) -> Scene:
    """``scene`` with the fitted values put back into its materials and lights."""
    models, lights = list(scene.models), list(scene.lights)
    for m, model in enumerate(models):
        changes = {n: tuple(values[n][m]) for n in _COLUMNS if n in values}
        if "shininess" in values:
            changes["shininess"] = float(values["shininess"][m])
        if changes:
            models[m] = dataclasses.replace(model, material=dataclasses.replace(model.material, **changes))
    for b in blocks:
        if b.rows is None:
            continue
        for j, i in enumerate(b.rows):
            v = values[b.name][j]
            if b.name == "light_position":
                change = {"position": tuple(v)}
            elif b.name == "light_direction":
                change = {"direction": tuple(v)}
            elif b.name == "light_radiance":
                top = float(np.max(v))
                change = {"intensity": top, "color": tuple(v / top) if top > 0 else 1.0}
            elif b.name == "light_intensity":
                change = {"intensity": float(v)}
            else:
                change = {"k": float(v)}
            lights[i] = dataclasses.replace(lights[i], **change)
    changes = {"lights": tuple(lights)}
    if any(n in values for n in ("ka", "kd", "ks", "shininess")):
        changes["models"] = tuple(models)
    if "ambient" in values:
        changes["ambient"] = tuple(values["ambient"].ravel())
    return scene.replace(**changes)


def fit(scene: Scene, target, params=("kd",), *, loss="l2", shading="phong", max_iter: int = 200,
        progress=None, keep_images: bool = False, samples: int = 1) -> FitResult:
    """Fit parameters of ``scene`` so that its linear image matches ``target``.

    Parameters
    ----------
    scene : Scene
        The starting point; its geometry and camera stay as they are.
    target : (H, W, 3) float ndarray
        The linear image to match (the camera's size; finite).
    params : str or sequence of str
        Names of :data:`FIT_PARAMS`, fitted together: ``"ka"``, ``"kd"``, ``"ks"`` (every
        model's RGB), ``"shininess"``, ``"ambient"``, ``"light_position"`` (point and spot
        lights), ``"light_direction"`` (directional lights), ``"light_radiance"`` or
        ``"light_intensity"`` (not both), ``"light_k"`` (heuristic attenuation); or the geometry,
        fitted apart from those: ``"translation"`` (each model's, (G, 3), from where it is) and
        ``"camera_eye"`` (the eye, its axes held), each evaluation rendered afresh and
        differentiated with the silhouettes' edge term.
    loss : "l2" or callable
        ``"l2"``: the mean of ``(I - target)^2``; or ``loss(image, target) -> (value, dL/dimage)``
        with ``image`` (H, W, 3) float64.
    shading : {"flat", "gouraud", "phong"} or sequence
        As for :func:`raycast_shade.render`.
    max_iter : int
        L-BFGS-B iterations at most (1 to 100,000).
    progress : callable, optional
        ``progress(iteration, loss)`` after every iteration (0: the start).
    keep_images : bool
        Keep the image of every iteration on the result (for pictures of the convergence).
    samples : int
        Rays per pixel of the fitted image (as for :func:`raycast_shade.render`). A geometry fit
        wants more than 1: the anti-aliased image moves smoothly with the geometry, the one-ray
        image in steps of a pixel.

    Returns
    -------
    FitResult
    """
    from scipy.optimize import minimize

    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    names = as_names((params,) if isinstance(params, str) else params, "params", FIT_PARAMS, item="parameter")
    if not names:
        raise ValueError(f"params: name at least one of {list(FIT_PARAMS)}")
    if "light_radiance" in names and "light_intensity" in names:
        raise ValueError("params: 'light_radiance' and 'light_intensity' are the same light's; fit one")
    max_iter = as_int(max_iter, "max_iter", minimum=1, maximum=100_000)
    keep_images = as_bool(keep_images, "keep_images")
    if progress is not None and not callable(progress):
        raise TypeError(f"progress: expected a callable or None, got {type(progress).__name__}")
    target = _check_target(target, scene.camera)
    samples = check_samples(samples)
    geometric = [n for n in names if n in GEOMETRY_PARAMS]
    if geometric and len(geometric) != len(names):
        raise ValueError(f"params: {geometric} move the geometry; fit them apart from {sorted(set(names) - set(geometric))}")
    if geometric:
        check_scene(scene, prepare(scene, scene.camera))
        problem = _GeometryProblem(scene, shading, names, _loss_fn(loss), target, samples)
    else:
        problem = _Problem(scene, shading, names, _loss_fn(loss), target)
    x0 = problem.x0()
    f0, _, img0 = problem.evaluate(x0)
    norm = f0 if f0 > 0 else 1.0
    seen = {}

    def objective(x):
        value, g, image = problem.evaluate(x)
        seen.clear()
        seen[x.tobytes()] = (value, image)
        return value / norm, g / norm

    losses, images = [f0], [img0] if keep_images else []
    if progress is not None:
        progress(0, f0)

    def step(x):
        value, image = seen.get(x.tobytes()) or problem.evaluate(x)[::2]
        losses.append(value)
        if keep_images:
            images.append(image)
        if progress is not None:
            progress(len(losses) - 1, value)

    bounds = [bd for b in problem.blocks for bd in b.bounds] or None  # the geometry: unbounded
    res = minimize(objective, x0, jac=True, method="L-BFGS-B", bounds=bounds, callback=step,
                   options=dict(maxiter=max_iter, ftol=1e-15, gtol=1e-12, maxls=40))
    values = problem.values(res.x)
    fitted = problem.moved(res.x) if geometric else _fitted_scene(scene, values, problem.blocks)
    return FitResult(scene=fitted, values=values, losses=tuple(losses),
                     images=tuple(images), success=bool(res.success), message=str(res.message),
                     evaluations=problem.evaluations)
