"""A rendered frame inside a JAX model: :func:`render_fn`, a ``jax.custom_vjp`` around :func:`grad`.

``render_fn(scene, wrt)`` returns ``f(params) -> image``: ``params`` a dict of the names in ``wrt``
(each shaped as :func:`raycast_shade.grad` returns its gradient), the image the linear
``(H, W, 3)`` float32 ``frame.image`` of the scene with those values. Its reverse rule is
:func:`raycast_shade.grad` over the forward pass's own frame, so ``jax.grad(loss)(params)`` of any
JAX loss of the image is the library's exact interior gradient (the hit buffer held fixed, as
there). The renderer runs on the host through ``jax.pure_callback``: ``f`` may sit under
``jax.jit``, but it is not traced into XLA (no ``vmap`` beyond a sequential loop, no forward mode)::

    import jax, jax.numpy as jnp
    from raycast_shade.gradients_jax import render_fn, params_of

    f = render_fn(scene, ("kd", "light_position"))
    params = {k: jnp.asarray(v) for k, v in params_of(scene, ("kd", "light_position")).items()}
    loss = lambda p: jnp.mean((f(p) - target) ** 2)
    g = jax.grad(loss)(params)            # a dict shaped like params

JAX is the optional extra ``raycast_shade[jax]``: importing :mod:`raycast_shade` never imports
it; :func:`render_fn` raises :class:`~raycast_shade.common.extras.MissingExtraError` (an
ImportError) naming the extra when it is missing. :func:`params_of` and :func:`with_params` need
NumPy only.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .common.extras import require
from .common.validate import as_array, as_names
from .gradients import grad
from .render import render
from .scene.lights import DirectionalLight
from .scene.scene import Scene
from .shading.shade import resolve_methods
from .shading.terms import with_materials

__all__ = ["render_fn", "params_of", "with_params", "JAX_WRT", "JAX_DEFAULT"]

JAX_WRT = ("ka", "kd", "ks", "shininess", "ambient", "light_position", "light_direction", "light_radiance",
           "light_intensity", "light_k")
"""The names :func:`render_fn` takes: the material rows, the ambient and the lights' values of
:data:`raycast_shade.gradients.WRT` (not the spot angles, the vertex normals, the geometry, nor the
mesh colours and texels)."""
JAX_DEFAULT = tuple(n for n in JAX_WRT if n != "light_intensity")
"""What ``wrt=None`` means: every name of :data:`JAX_WRT` but ``light_intensity``, which sets the
radiance ``light_radiance`` sets."""

_MATERIAL = ("ka", "kd", "ks")


def _rgb(value) -> np.ndarray:
    return np.array(np.broadcast_to(np.asarray(value, np.float64), 3))


def _shapes(scene) -> dict:
    g, n = len(scene.models), len(scene.lights)
    return {"ka": (g, 3), "kd": (g, 3), "ks": (g, 3), "shininess": (g,), "ambient": (3,), "light_position": (n, 3),
            "light_direction": (n, 3), "light_radiance": (n, 3), "light_intensity": (n,), "light_k": (n,)}


def _names(wrt) -> tuple:
    names = as_names(JAX_DEFAULT if wrt is None else (wrt,) if isinstance(wrt, str) else wrt, "wrt", JAX_WRT,
                     item="parameter")
    if not names:
        raise ValueError(f"wrt: name at least one parameter of {list(JAX_WRT)}")
    if "light_radiance" in names and "light_intensity" in names:
        raise ValueError("wrt: 'light_radiance' and 'light_intensity' both set the lights' radiance; name one")
    return names


def params_of(scene: Scene, wrt=None) -> dict:
    """The scene's current values of the parameters ``wrt``, shaped as :func:`grad` returns their gradients.

    Parameters
    ----------
    scene : Scene
    wrt : str or sequence of str, optional
        Names of :data:`JAX_WRT` (:data:`JAX_DEFAULT` by default).

    Returns
    -------
    dict of str to ndarray
        float64: ``ka``/``kd``/``ks`` (G, 3), ``shininess`` (G,), ``ambient`` (3,),
        ``light_position`` (L, 3) (0 for directional lights), ``light_direction`` (L, 3) (0 but for
        directional lights), ``light_radiance`` (L, 3), ``light_intensity`` (L,), ``light_k`` (L,)
        (each light's ``k``; 0 for directional lights).
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    out = {}
    mats = [m.material for m in scene.models]
    lights = scene.lights
    for name in _names(wrt):
        if name in _MATERIAL:
            out[name] = np.array([_rgb(getattr(m, name)) for m in mats]).reshape(-1, 3)
        elif name == "shininess":
            out[name] = np.array([float(m.shininess) for m in mats])
        elif name == "ambient":
            out[name] = _rgb(scene.ambient)
        elif name == "light_position":
            out[name] = np.array([np.zeros(3) if isinstance(li, DirectionalLight) else np.asarray(li.position, float)
                                  for li in lights]).reshape(-1, 3)
        elif name == "light_direction":
            out[name] = np.array([np.asarray(li.direction, float) if isinstance(li, DirectionalLight) else np.zeros(3)
                                  for li in lights]).reshape(-1, 3)
        elif name == "light_radiance":
            out[name] = np.array([float(li.intensity) * _rgb(li.color) for li in lights]).reshape(-1, 3)
        elif name == "light_intensity":
            out[name] = np.array([float(li.intensity) for li in lights])
        else:
            out[name] = np.array([0.0 if isinstance(li, DirectionalLight) else float(li.k) for li in lights])
    return out


def _checked(scene, values, field) -> dict:
    """``values`` as finite float64 arrays of the shapes :func:`params_of` gives, names checked
    (messages name ``field``)."""
    if not isinstance(values, dict):
        raise TypeError(f"{field}: expected a dict of parameter arrays, got {type(values).__name__}")
    shapes = _shapes(scene)
    try:
        names = _names(tuple(values))
    except (TypeError, ValueError) as exc:
        raise type(exc)(str(exc).replace("wrt", field, 1)) from None
    return {n: as_array(values[n], f"{field}[{n!r}]", dtype=np.float64, shape=shapes[n])
            for n in names}


def _light_changes(light, values, i) -> dict:
    directional = isinstance(light, DirectionalLight)
    change = {}
    if "light_position" in values and not directional:
        change["position"] = tuple(values["light_position"][i])
    if "light_direction" in values and directional:
        change["direction"] = tuple(values["light_direction"][i])
    if "light_radiance" in values:
        rad = values["light_radiance"][i]
        top = float(np.max(rad))
        change.update(intensity=top, color=tuple(rad / top) if top > 0 else 1.0)
    if "light_intensity" in values:
        change["intensity"] = float(values["light_intensity"][i])
    if "light_k" in values and not directional and light.attenuation == "heuristic":
        change["k"] = float(values["light_k"][i])
    return change


def with_params(scene: Scene, values: dict) -> Scene:
    """``scene`` with the parameter values put into its materials and lights.

    The packed geometry and its Embree BVH are kept (only the material rows change). A light
    row of a parameter that does not apply to its kind (``light_position`` of a directional light,
    ``light_direction`` of any other, ``light_k`` of a light without the heuristic law) is ignored.

    Parameters
    ----------
    scene : Scene
    values : dict of str to array
        Names of :data:`JAX_WRT`, each shaped as :func:`params_of` gives it; finite.

    Returns
    -------
    Scene
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    values = _checked(scene, values, "values")
    changes = {}
    if any(n in values for n in (*_MATERIAL, "shininess")):
        models = []
        for g, model in enumerate(scene.models):
            mat = {n: tuple(values[n][g]) for n in _MATERIAL if n in values}
            if "shininess" in values:
                mat["shininess"] = float(values["shininess"][g])
            models.append(dataclasses.replace(model, material=dataclasses.replace(model.material, **mat)))
        changes["models"] = tuple(models)
    if "ambient" in values:
        changes["ambient"] = tuple(values["ambient"])
    if any(n.startswith("light") for n in values):
        changes["lights"] = tuple(dataclasses.replace(li, **_light_changes(li, values, i))
                                  for i, li in enumerate(scene.lights))
    if "models" in changes:  # new material rows over the same packed meshes and BVH
        rows = np.array([m.material.packed() for m in changes["models"]])
        return with_materials(scene, rows, **changes)
    return scene.replace(**changes)


class _Frames:
    """The last forward pass's scene and frame, keyed by the parameter values, for its reverse pass."""

    def __init__(self, scene, shading, names):
        self.scene, self.shading, self.names = scene, shading, names
        self.key, self.scene_at, self.frame = None, None, None

    def at(self, arrays):
        key = b"".join(np.ascontiguousarray(a, np.float64).tobytes() for a in arrays)
        if key != self.key:
            s = with_params(self.scene, dict(zip(self.names, arrays)))
            self.key, self.scene_at, self.frame = key, s, render(s, self.shading)
        return self.scene_at, self.frame

    def image(self, *arrays):
        return self.at(arrays)[1].image.astype(np.float32)

    def vjp(self, cotangent, *arrays):
        scene, frame = self.at(arrays)
        g = grad(scene, np.asarray(cotangent, np.float64), self.names, shading=self.shading, frame=frame)
        out = []
        for name, a in zip(self.names, arrays):
            gi = np.asarray(g[name], np.float64)
            if name == "light_direction":  # grad's is at the unit direction; the scene normalises the row given
                norm = np.linalg.norm(np.asarray(a, np.float64), axis=1, keepdims=True)
                gi = gi / np.where(norm > 0, norm, 1.0)
            out.append(gi.astype(np.asarray(a).dtype))
        return tuple(out)


def render_fn(scene: Scene, wrt=None, *, shading="phong"):
    """``f(params) -> image``, differentiable in JAX with :func:`raycast_shade.grad` as its reverse rule.

    Parameters
    ----------
    scene : Scene
        The scene whose other parameters, geometry and camera are held.
    wrt : str or sequence of str, optional
        Names of :data:`JAX_WRT` that ``f`` takes (:data:`JAX_DEFAULT` by default;
        ``light_radiance`` and ``light_intensity`` not together).
    shading : {"flat", "gouraud", "phong"} or sequence
        As for :func:`raycast_shade.render` (not ``"auto"``).

    Returns
    -------
    callable
        ``f(params)``: ``params`` a dict with exactly the names of ``wrt``, each a JAX or NumPy
        array shaped as :func:`params_of` gives it; returns the ``(H, W, 3)`` float32 linear
        image of ``with_params(scene, params)``. Its VJP (``jax.grad``, ``jax.vjp``) gives each
        parameter's gradient in the parameter's dtype.

    Raises
    ------
    MissingExtraError
        JAX is not installed (``pip install 'raycast_shade[jax]'``).
    ValueError
        An unknown name in ``wrt``; a shading name the scene cannot take.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a Scene, got {type(scene).__name__}")
    names = _names(wrt)
    resolve_methods(scene, shading)
    if isinstance(shading, str) and shading.lower() == "auto":
        raise ValueError("shading: 'auto' has no gradient; name the method ('flat', 'gouraud', 'phong')")
    jax = require("jax", "jax", "raycast_shade.gradients_jax.render_fn", "jax")
    frames = _Frames(scene, shading, names)
    shapes = _shapes(scene)
    image_shape = jax.ShapeDtypeStruct((scene.camera.height, scene.camera.width, 3), np.float32)

    def _forward(*arrays):
        return jax.pure_callback(frames.image, image_shape, *arrays, vmap_method="sequential")

    @jax.custom_vjp
    def _f(*arrays):
        return _forward(*arrays)

    def _fwd(*arrays):
        return _forward(*arrays), arrays

    def _bwd(arrays, cotangent):
        out_shapes = tuple(jax.ShapeDtypeStruct(a.shape, a.dtype) for a in arrays)
        return jax.pure_callback(frames.vjp, out_shapes, cotangent, *arrays, vmap_method="sequential")

    _f.defvjp(_fwd, _bwd)

    def f(params):
        if not isinstance(params, dict) or set(params) != set(names):
            raise ValueError(f"params: expected a dict with exactly the names {list(names)}, got "
                             f"{sorted(params) if isinstance(params, dict) else type(params).__name__}")
        arrays = []
        for n in names:
            a = jax.numpy.asarray(params[n])
            if a.shape != shapes[n]:
                raise ValueError(f"params[{n!r}]: expected shape {shapes[n]}, got {a.shape}")
            if not jax.numpy.issubdtype(a.dtype, jax.numpy.floating):
                a = a.astype(jax.numpy.result_type(float))
            arrays.append(a)
        return _f(*arrays)

    return f
