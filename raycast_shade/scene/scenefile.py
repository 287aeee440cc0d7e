"""Scenes from TOML files.

A scene file describes one :class:`~raycast_shade.Scene` and, optionally, how
to render it. The full reference is ``docs/scene-files.md``; in short::

    ambient = 0.08                      # Ia: scalar or [r, g, b]
    background = 0.0                    # colour where nothing is hit

    [camera]                            # required
    eye = [0.0, 1.5, 6.0]               # required (or fit = true: framed by
                                        # Camera.fit, with direction, margin)
    target = [0.0, 0.0, 0.0]            # also up, fov, projection,
    width = 640                         # ortho_height
    height = 480

    [[object]]                          # one table per model, at least one
    shape = "icosphere"                 # a procedural shape (shapes.SHAPES) ...
    subdivisions = 1                    # ... with its own parameters
    radius = 1.0
    [object.material]                   # kd, ka, ks: scalar or [r, g, b];
    kd = [0.8, 0.25, 0.2]               # shininess, specular = "phong" | "blinn",
    ks = 0.6                            # reflectivity
    shininess = 40

    [[object]]
    mesh = "meshes/knot.obj"            # a file trimesh reads, relative to this file
    crease_angle = 40                   # also normals, weighting, name, merge,
    translate = [2.0, 0.0, 0.0]         # scale, rotate, materials = "file" | "none"
    [object.material]                   # keys given here override the file's
    kd_map = "wood.png"                 # materials (kd_map, ka_map, ks_map: a path
                                        # or a table image, srgb, wrap, filter, tiling)

    [[light]]
    type = "point"                      # position, intensity, color, shadows,
    position = [3.0, 4.0, 5.0]          # attenuation = "none" | "inverse_square"
    intensity = 40.0                    #   | "heuristic", k
    attenuation = "inverse_square"

    [[light]]
    type = "spot"                       # the point keys, and direction,
    position = [0.0, 4.0, 0.0]          # exponent, inner_angle, outer_angle
    direction = [0.0, -1.0, 0.0]        # (Warn's model: SpotLight)
    outer_angle = 30.0

    [[light]]
    type = "directional"                # direction, intensity, color, shadows
    direction = [-1.0, -0.5, -1.0]
    color = [0.3, 0.4, 1.0]

    [render]                            # optional: shading (a method, "auto" or
    shading = "phong"                   # one per object), width, height, max_depth,
                                        # samples, backend, interpolation, caster,
                                        # tolerance, exposure, tonemap, gamma

Unknown keys are errors, and every error names the table and key it comes
from, e.g. ``object[1].material: unknown key 'shinyness' (did you mean
'shininess'?)``; arrays of tables count from 0.
"""

from __future__ import annotations

import difflib
import inspect
import os

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from . import shapes as _shapes
from ..common.choices import (BACKEND_CHOICES, CASTER_CHOICES, INTERPOLATIONS, SHADING_CHOICES, SHADINGS, TONEMAPS,
                              WEIGHTINGS)
from ..common.samples import check_samples
from ..common.validate import as_choice, as_int, as_rgb, as_scalar, as_vec3
from .camera import Camera
from .lights import DirectionalLight, PointLight, SpotLight
from .material import Material, overridden
from .mesh import Mesh
from .scene import Model, Scene

__all__ = ["load_scene", "load_for_render", "scene_from_dict", "SceneFileError", "check_render_options",
           "split_options", "RENDER_KEYS", "SIZE_KEYS", "TONE_KEYS"]

_TOP_KEYS = ("ambient", "background", "camera", "object", "light", "render", "motion")  # motion: views (motionfile)
_CAMERA_KEYS = ("eye", "target", "up", "fov", "width", "height", "projection", "ortho_height", "fit", "direction", "margin")
_FIT_KEYS = ("fit", "direction", "margin", "up", "fov", "width", "height", "projection")
_OBJECT_KEYS = ("shape", "mesh", "name", "normals", "weighting", "crease_angle", "scale", "rotate", "translate",
                "material")
_FILE_KEYS = ("merge", "materials")  # mesh files only
_MATERIAL_KEYS = ("kd", "ka", "ks", "shininess", "specular", "reflectivity", "bump", "name", "kd_map", "ka_map",
                  "ks_map")
_MAP_KEYS = ("image", "srgb", "wrap", "filter", "tiling")
# [object.material.bump]: a height map from an image file or a procedural pattern.
_BUMP_COMMON = ("scale", "wrap", "tiling")
_BUMP_KEYS = {
    "image": ("image",) + _BUMP_COMMON,
    "dimples": ("pattern", "count", "radius", "resolution") + _BUMP_COMMON,
    "wrinkles": ("pattern", "frequency", "octaves", "seed", "resolution") + _BUMP_COMMON,
}
_LIGHT_KEYS = {
    "point": ("type", "position", "intensity", "color", "attenuation", "k", "shadows", "name"),
    "directional": ("type", "direction", "intensity", "color", "shadows", "name"),
    "spot": ("type", "position", "direction", "intensity", "color", "attenuation", "k", "shadows", "exponent",
             "inner_angle", "outer_angle", "name"),
}
# The [render] table: the camera's size, render()'s options, and to_uint8()'s for 8-bit files.
SIZE_KEYS = ("width", "height")
TONE_KEYS = ("exposure", "tonemap", "gamma")
RENDER_KEYS = (("shading",) + SIZE_KEYS + ("max_depth", "samples", "backend", "interpolation", "caster", "tolerance")
               + TONE_KEYS)
_NORMALS = ("auto", "computed")


class SceneFileError(ValueError):
    """A scene file that does not describe a valid scene.

    The message names the file, then the table and key at fault.
    """


class _Invalid(Exception):
    """Internal: a problem at ``where``, turned into a SceneFileError with the file name."""

    def __init__(self, where: str, message: str):
        super().__init__(f"{where}: {message}" if where else message)


def _call(where: str, fn, *args, **kwargs):
    """Run a library constructor; its ValueError/TypeError gets the table path in front.

    Constructors that were given ``name=where`` already start their messages
    with it, so the path is not repeated.
    """
    try:
        return fn(*args, **kwargs)
    except (ValueError, TypeError) as exc:
        msg = str(exc)
        raise _Invalid("" if msg.startswith(where) else where, msg) from None


def _check_keys(table, where: str, allowed, what: str = ""):
    for key in table:
        if key not in allowed:
            hint = difflib.get_close_matches(key, allowed, n=1)
            tail = f" (did you mean {hint[0]!r}?)" if hint else f" (expected one of: {', '.join(allowed)})"
            raise _Invalid(where, f"unknown key {key!r}{what}{tail}")


def _table(value, where: str) -> dict:
    if not isinstance(value, dict):
        raise _Invalid(where, f"expected a table, got {_kind(value)}")
    return value


def _tables(data: dict, key: str) -> list:
    """An array of tables (``[[key]]``); a single ``[key]`` table is a common slip."""
    value = data.get(key, [])
    if isinstance(value, dict):
        raise _Invalid(key, f"expected an array of tables: write [[{key}]], not [{key}]")
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise _Invalid(key, f"expected an array of tables ([[{key}]]), got {_kind(value)}")
    return value


def _kind(value) -> str:
    return "a table" if isinstance(value, dict) else "an array" if isinstance(value, list) else type(value).__name__


def _string(value, where: str) -> str:
    if not isinstance(value, str):
        raise _Invalid(where, f"expected a string, got {_kind(value)}")
    return value


def _camera(table, render, models=None) -> Camera:
    """The [camera]; ``fit = true`` frames ``models`` (:meth:`Camera.fit`; None until they are loaded)."""
    cam = dict(_table(table, "camera"))
    _check_keys(cam, "camera", _CAMERA_KEYS)
    fit = cam.pop("fit", False)
    if not isinstance(fit, bool):
        raise _Invalid("camera.fit", f"expected true or false, got {_kind(fit)}")
    # [render] width/height override the camera's (one camera, several sizes), once the camera's are checked.
    cam.update((k, render[k]) for k in ("width", "height")
               if k in render and _call(f"camera.{k}", _RENDER_CHECKS[k], cam.get(k, 1), f"camera.{k}"))
    wrong = [k for k in cam if k not in _FIT_KEYS] if fit else [k for k in ("direction", "margin") if k in cam]
    if wrong:
        raise _Invalid(f"camera.{wrong[0]}", "not with fit = true (the fitted camera places itself; give direction "
                                             "and margin instead)" if fit else "only with fit = true")
    if fit:
        return None if models is None else _call("camera", Camera.fit, models, **cam)
    if "eye" not in cam:
        raise _Invalid("camera", "missing key 'eye' (or fit = true to frame the scene)")
    return _call("camera", Camera, **cam)


def _shape_params(shape: str) -> tuple:
    sig = inspect.signature(_shapes.SHAPES[shape])
    return tuple(p.name for p in sig.parameters.values() if p.kind is not p.VAR_KEYWORD)


def _rotation(degrees) -> np.ndarray:
    """``Rz @ Ry @ Rx``: rotate about x first, then y, then z (fixed axes)."""
    rx, ry, rz = np.radians(degrees)
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    mx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    my = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    mz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return mz @ my @ mx


def _mesh(obj: dict, where: str, base_dir: str) -> list:
    """The object's meshes, each with the material its file gives (None: none given)."""
    has_shape, has_mesh = "shape" in obj, "mesh" in obj
    if has_shape == has_mesh:
        raise _Invalid(where, "needs exactly one of 'shape' (a procedural shape) or 'mesh' (a file)")
    if has_shape:
        shape = _string(obj["shape"], f"{where}.shape")
        if shape not in _shapes.SHAPES:
            raise _Invalid(f"{where}.shape", f"expected one of {sorted(_shapes.SHAPES)}, got {shape!r}")
        params = _shape_params(shape)
        _check_keys(obj, where, _OBJECT_KEYS + params, f" for shape {shape!r}")
    else:
        _check_keys(obj, where, _OBJECT_KEYS + _FILE_KEYS, " for a mesh file")
    normals = _choice(obj.get("normals", "auto"), f"{where}.normals", _NORMALS)
    # Checked here, not by Mesh, so that messages name the table.
    mesh_kw = {}
    if "weighting" in obj:
        mesh_kw["weighting"] = _choice(obj["weighting"], f"{where}.weighting", WEIGHTINGS)
    if "crease_angle" in obj:
        mesh_kw["crease_angle"] = _call(where, as_scalar, obj["crease_angle"], f"{where}.crease_angle",
                                        minimum=0.0, exclusive=True, maximum=180.0)
    if "name" in obj:
        mesh_kw["name"] = _string(obj["name"], f"{where}.name")
    if has_shape:
        kwargs = {k: obj[k] for k in params if k in obj}
        if "center" in kwargs:
            kwargs["center"] = _call(where, as_vec3, kwargs["center"], f"{where}.center")
        kwargs.update(mesh_kw)
        mesh = _call(where, _shapes.make, shape, **kwargs)
        if normals == "computed" and mesh.normals is not None:
            # Drop the shape's exact normals: average them from the faces instead.
            mesh = _call(where, Mesh, mesh.vertices, mesh.faces, uvs=mesh.uvs, weighting=mesh.weighting,
                         crease_angle=mesh.crease_angle, name=mesh.name)
        return [(_placed(mesh, obj, where), None)]
    rel = os.path.expanduser(_string(obj["mesh"], f"{where}.mesh"))
    path = os.path.normpath(os.path.join(base_dir, rel))
    use_normals = None if normals == "auto" else False
    merge = obj.get("merge", False)
    if not isinstance(merge, bool):
        raise _Invalid(f"{where}.merge", f"expected true or false, got {_kind(merge)}")
    if _choice(obj.get("materials", "file"), f"{where}.materials", ("file", "none")) == "none":
        mesh = _call(f"{where}.mesh", Mesh.load, path, use_normals=use_normals, merge=merge, **mesh_kw)
        return [(_placed(mesh, obj, where), None)]
    from .meshfile import load_models

    models = _call(f"{where}.mesh", load_models, path, use_normals=use_normals, merge=merge, **mesh_kw)
    return [(_placed(m.mesh, obj, where), m.material) for m in models]


def _placed(mesh: Mesh, obj: dict, where: str) -> Mesh:
    """``mesh`` scaled, rotated and translated as the object says."""
    if any(k in obj for k in ("scale", "rotate", "translate")):
        s = _call(where, as_scalar, obj.get("scale", 1.0), f"{where}.scale", minimum=0.0, exclusive=True)
        r = _rotation(_call(where, as_vec3, obj.get("rotate", (0.0, 0.0, 0.0)), f"{where}.rotate"))
        t = _call(where, as_vec3, obj.get("translate", (0.0, 0.0, 0.0)), f"{where}.translate")
        n = None if mesh.normals is None else mesh.normals @ r.T  # a rotation keeps normals unit and outward
        tan = None if mesh.tangents is None else np.c_[mesh.tangents[:, :3] @ r.T, mesh.tangents[:, 3]]
        mesh = _call(where, Mesh, (mesh.vertices * s) @ r.T + t, mesh.faces, normals=n, uvs=mesh.uvs,
                     weighting=mesh.weighting, crease_angle=mesh.crease_angle, name=mesh.name,
                     colors=mesh.colors, color_mode=mesh.color_mode or "auto", tangents=tan)
    return mesh


def _without_colors(mesh: Mesh) -> Mesh:
    if mesh.colors is None:
        return mesh
    return Mesh(mesh.vertices, mesh.faces, normals=mesh.normals, uvs=mesh.uvs, weighting=mesh.weighting,
                crease_angle=mesh.crease_angle, name=mesh.name, tangents=mesh.tangents)


def _choice(value, where: str, choices) -> str:
    return _call(where, as_choice, value, where, choices)


def _bump(table, where: str, base_dir: str):
    from .heightmap import HeightMap

    bump = dict(_table(table, where))
    if "image" in bump:
        _check_keys(bump, where, _BUMP_KEYS["image"])
        path = os.path.normpath(os.path.join(base_dir, _string(bump.pop("image"), f"{where}.image")))
        return _call(where, HeightMap.from_image, path, **bump)
    if "pattern" not in bump:
        raise _Invalid(where, "needs 'image = \"path\"' or 'pattern = \"dimples\"' / 'pattern = \"wrinkles\"'")
    kind = _choice(bump.pop("pattern"), f"{where}.pattern", ("dimples", "wrinkles"))
    _check_keys(dict(bump, pattern=kind), where, _BUMP_KEYS[kind])
    return _call(where, getattr(HeightMap, kind), **bump)


def _texture(value, where: str, base_dir: str):
    """A colour map: an image path, or a table of Texture.from_image's keywords."""
    from .texture import Texture

    table = {"image": value} if isinstance(value, str) else dict(_table(value, where))
    _check_keys(table, where, _MAP_KEYS)
    if "image" not in table:
        raise _Invalid(where, "needs 'image = \"path\"'")
    path = os.path.normpath(os.path.join(base_dir, _string(table.pop("image"), f"{where}.image")))
    if "srgb" in table and not isinstance(table["srgb"], bool):
        raise _Invalid(f"{where}.srgb", f"expected true or false, got {_kind(table['srgb'])}")
    return _call(where, Texture.from_image, path, name=where, **table)


def _material(table, where: str, base_dir: str = ".", base: Material | None = None) -> Material:
    """The object's material; over ``base`` (the file's) the keys given win."""
    mat = dict(_table(table, where))
    _check_keys(mat, where, _MATERIAL_KEYS)
    if "name" in mat:
        mat["name"] = _string(mat["name"], f"{where}.name")
    if "bump" in mat:
        mat["bump"] = _bump(mat["bump"], f"{where}.bump", base_dir)
    for key in ("kd_map", "ka_map", "ks_map"):
        if key in mat:
            mat[key] = _texture(mat[key], f"{where}.{key}", base_dir)
    if base is not None:
        mat = overridden(base, mat)
    mat.setdefault("name", where)
    return _call(where, Material, **mat)


def _light(table: dict, where: str):
    if "type" not in table:
        raise _Invalid(where, "missing key 'type' (expected 'point', 'spot' or 'directional')")
    kind = _choice(table["type"], f"{where}.type", tuple(_LIGHT_KEYS))
    _check_keys(table, where, _LIGHT_KEYS[kind], f" for a {kind} light")
    kw = {k: v for k, v in table.items() if k != "type"}
    kw["name"] = _string(kw["name"], f"{where}.name") if "name" in kw else where
    if kind in ("point", "spot"):
        if "position" not in kw:
            raise _Invalid(where, "missing key 'position'")
        if kind == "spot" and "direction" not in kw:
            raise _Invalid(where, "missing key 'direction'")
        return _call(where, PointLight if kind == "point" else SpotLight, **kw)
    if "direction" not in kw:
        raise _Invalid(where, "missing key 'direction'")
    return _call(where, DirectionalLight, **kw)


def _shading(value, name: str):
    """A method name, ``"auto"``, or one method per model (a non-empty sequence)."""
    if isinstance(value, str):
        return as_choice(value, name, SHADING_CHOICES)
    if isinstance(value, (bytes, dict)) or not hasattr(value, "__iter__"):
        raise TypeError(f"{name}: expected one of {list(SHADING_CHOICES)} or one method per model, "
                        f"got {type(value).__name__}")
    names = tuple(value)
    if not names:
        raise ValueError(f"{name}: expected one method per model, got an empty list")
    return tuple(as_choice(m, f"{name}[{i}]", SHADINGS) for i, m in enumerate(names))


def _gamma(value, name: str):
    if isinstance(value, str):
        return as_choice(value, name, ("srgb",))
    return as_scalar(value, name, minimum=0.0, exclusive=True)


# How each [render] entry (and each override of one) is checked: fn(value, field name) -> value.
_RENDER_CHECKS = {
    "shading": _shading,
    "width": lambda v, name: as_int(v, name, minimum=1),
    "height": lambda v, name: as_int(v, name, minimum=1),
    "max_depth": lambda v, name: as_int(v, name, minimum=0),
    "samples": check_samples,
    "backend": lambda v, name: as_choice(v, name, BACKEND_CHOICES),
    "interpolation": lambda v, name: as_choice(v, name, INTERPOLATIONS),
    "caster": lambda v, name: as_choice(v, name, CASTER_CHOICES),
    "tolerance": lambda v, name: as_scalar(v, name, minimum=0.0, exclusive=True),
    "exposure": lambda v, name: as_scalar(v, name, minimum=0.0, exclusive=True),
    "tonemap": lambda v, name: as_choice(v, name, TONEMAPS),
    "gamma": _gamma,
}
assert tuple(_RENDER_CHECKS) == RENDER_KEYS


def check_render_options(options: dict, where: str = "") -> dict:
    """Validate ``[render]`` entries, or keyword overrides of them.

    Every front-end (scene files, :func:`raycast_shade.render_file`, the
    command line, batches and animations) checks its options here, so they
    accept the same names: choices case-insensitively (returned lower-case),
    ``shading`` as one method, ``"auto"`` or one method per model.

    Parameters
    ----------
    options : dict
        Keys among :data:`RENDER_KEYS`.
    where : str
        Prefix of the field names in messages (``"render"``: ``render.shading``).

    Returns
    -------
    dict
        The entries given, normalised (``shading`` per model as a tuple).

    Raises
    ------
    TypeError
        For an unknown key or a value of the wrong type, naming it.
    ValueError
        For a value out of range or not among the choices, naming it.
    """
    if not isinstance(options, dict):
        raise TypeError(f"{where or 'options'}: expected a table of options, got {_kind(options)}")
    out = {}
    for key, value in options.items():
        name = f"{where}.{key}" if where else key
        check = _RENDER_CHECKS.get(key)
        if check is None:
            hint = difflib.get_close_matches(str(key), RENDER_KEYS, n=1)
            tail = f"did you mean {hint[0]!r}?" if hint else f"expected some of {', '.join(RENDER_KEYS)}"
            raise TypeError(f"{where or 'options'}: unknown option {key!r} ({tail})")
        out[key] = check(value, name)
    return out


def split_options(options: dict) -> tuple:
    """Sort validated ``[render]`` entries by where they apply.

    Returns
    -------
    size : dict
        ``width``, ``height``: the camera's.
    render : dict
        Keywords of :func:`raycast_shade.render`: ``shading`` and the pipeline options.
    tone : dict
        Keywords of :func:`raycast_shade.to_uint8`: ``exposure``, ``tonemap``, ``gamma``.
    """
    size = {k: v for k, v in options.items() if k in SIZE_KEYS}
    tone = {k: v for k, v in options.items() if k in TONE_KEYS}
    render = {k: v for k, v in options.items() if k not in SIZE_KEYS + TONE_KEYS}
    return size, render, tone


def _render_options(table) -> dict:
    opts = _table(table, "render")
    _check_keys(opts, "render", RENDER_KEYS)
    return {k: _call("render", _RENDER_CHECKS[k], v, f"render.{k}") for k, v in opts.items()}


def _build(data: dict, base_dir: str):
    _check_keys(data, "", _TOP_KEYS, " at the top level")
    if "camera" not in data:
        raise _Invalid("", "missing [camera] table")
    options = _render_options(data.get("render", {}))
    camera = _camera(data["camera"], options)  # checked before the meshes load; a fitted one after
    objects = _tables(data, "object")
    if not objects:
        raise _Invalid("", "no [[object]] tables: a scene needs at least one object")
    models, per_object = [], []
    for i, obj in enumerate(objects):
        where = f"object[{i}]"
        table = _table(obj.get("material", {}), f"{where}.material")
        parts = _mesh(obj, where, base_dir)
        for mesh, file_material in parts:
            if "kd" in table or "kd_map" in table:
                mesh = _without_colors(mesh)  # the object's kd overrides the file's colours too
            models.append(Model(mesh, _material(table, f"{where}.material", base_dir, file_material)))
        per_object.append(len(parts))
    shading = options.get("shading")
    if isinstance(shading, tuple):
        if len(shading) != len(objects):
            raise _Invalid("render.shading", f"expected one method per [[object]] ({len(objects)}), "
                                             f"got {len(shading)}")
        # A file with several materials is several models: each takes its object's method.
        options["shading"] = tuple(m for m, n in zip(shading, per_object) for _ in range(n))
    lights = [_light(t, f"light[{i}]") for i, t in enumerate(_tables(data, "light"))]
    if camera is None:
        camera = _camera(data["camera"], options, models)
    ambient = _call("ambient", as_rgb, data.get("ambient", 0.1), "ambient")
    background = _call("background", as_rgb, data.get("background", 0.0), "background")
    return Scene(models, lights=lights, camera=camera, ambient=ambient, background=background), options


def scene_from_dict(data: dict, base_dir=".", source: str = "<scene>"):
    """Build a scene from an already parsed scene-file table.

    Parameters
    ----------
    data : dict
        What :func:`tomllib.load` returns for a scene file.
    base_dir : str or path-like
        Folder that relative ``mesh`` paths start from.
    source : str
        Name used at the start of error messages.

    Returns
    -------
    scene : Scene
    options : dict
        The ``[render]`` entries that were given, validated (see
        :func:`check_render_options`; :func:`split_options` sorts them).

    Raises
    ------
    SceneFileError
        For any invalid table, key or value; the message names the table.
    """
    try:
        return _build(_table(data, "scene"), os.fspath(base_dir))
    except _Invalid as exc:
        raise SceneFileError(f"{source}: {exc}") from None


def load_scene(path):
    """Read a TOML scene file.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    scene : Scene
        With the camera sized by ``[render]`` width/height when given.
    options : dict
        The validated ``[render]`` entries (only those present).

    Raises
    ------
    FileNotFoundError, OSError
        When the file cannot be read.
    SceneFileError
        For invalid TOML or an invalid scene; a ``ValueError``.

    Examples
    --------
    >>> scene, options = load_scene("examples/shapes.toml")  # doctest: +SKIP
    >>> size, kwargs, tone = split_options(options)  # doctest: +SKIP
    >>> frame = render(scene, **kwargs)  # doctest: +SKIP

    :func:`raycast_shade.render_file` does this in one call.
    """
    path = os.fspath(path)
    with open(path, "rb") as fh:
        raw = fh.read()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise SceneFileError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneFileError(f"{path}: invalid TOML: {exc}") from None
    return scene_from_dict(data, os.path.dirname(os.path.abspath(path)), source=path)


def load_for_render(path, **overrides):
    """Read a scene file and apply ``overrides`` to its ``[render]`` options.

    Every front-end that renders a file (:func:`raycast_shade.render_file`,
    ``raycast-shade render`` and ``animate``) goes through here, so they
    share one precedence: an override beats ``[render]``, which beats
    ``[camera]``.

    Parameters
    ----------
    path : str or path-like
    **overrides
        ``[render]`` entries (see :func:`check_render_options`); ``None``
        keeps the file's value.

    Returns
    -------
    scene : Scene
        Its camera sized by ``width``/``height``.
    render_kwargs : dict
        Keywords of :func:`raycast_shade.render`: ``shading`` and the
        pipeline options given (file or override).
    tone : dict
        ``exposure``, ``tonemap``, ``gamma`` given.

    Raises
    ------
    SceneFileError
        For an invalid file.
    TypeError, ValueError
        For an invalid override, naming it; checked before the file is read.
    """
    given = check_render_options({k: v for k, v in overrides.items() if v is not None})
    scene, options = load_scene(path)
    size, render_kwargs, tone = split_options({**options, **given})
    shading = render_kwargs.get("shading")
    if isinstance(shading, tuple) and len(shading) != len(scene.models):
        raise ValueError(f"shading: expected one method per [[object]] of {os.fspath(path)} "
                         f"({len(scene.models)}), got {len(shading)}")
    if size:
        scene = scene.replace(camera=scene.camera.replace(**size))
    return scene, render_kwargs, tone
