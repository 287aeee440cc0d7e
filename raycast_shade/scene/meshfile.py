"""Models from mesh files: geometry, colours, and the file's materials.

:func:`load_models` reads what a file carries through trimesh's visuals and
maps it onto the lecture's coefficients (the table is in ``docs/textures.md``):

* OBJ/MTL (``SimpleMaterial``): ``Kd``, ``Ka``, ``Ks`` -> kd, ka, ks;
  ``Ns`` -> shininess; ``illum 0/1`` -> no specular term; ``map_Kd``,
  ``map_Ka``, ``map_Ks`` -> kd_map, ka_map, ks_map (sRGB images, with the
  ``-s u v`` scale and ``-clamp on`` options).
* glTF (``PBRMaterial``), metallic ``m`` and roughness ``r`` (spec defaults
  1): kd = baseColor (1 - m); ks = 0.04 (1 - m) + baseColor m (F0, the
  Fresnel reflectance at normal incidence); Blinn-Phong with
  t = 2 / alpha^2 - 2, alpha = r^2, clamped to [1, 4096];
  ``baseColorTexture`` -> kd_map (and ks_map where m > 0); ``COLOR_0``
  (linear) -> the mesh's vertex colours, times kd's factor.
* PLY/OFF/OBJ vertex or face colours (sRGB bytes) -> the mesh's colours.

What cannot be mapped (normal, occlusion, emissive and metallic-roughness
textures, emission, transparency, bump/displacement maps, unknown MTL keys)
is named in a :class:`~raycast_shade.DroppedOnLoadWarning`.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..common.warnings import DroppedOnLoadWarning
from .material import Material
from .mesh import Mesh, _instance, _is_scene, read_trimesh, visual_colors
from .scene import Model
from .texture import Texture

__all__ = ["load_models", "material_from_trimesh"]

# MTL keys with no effect in the file's own model when they hold these values.
_MTL_HARMLESS = {"d": 1.0, "tr": 0.0, "ke": 0.0}
_MTL_TEXTURES = ("map_kd", "map_ka", "map_ks")
_MAX_SHININESS = 4096.0  # repeated squaring's limit (shading.illumination._power)


def _rgb(value) -> np.ndarray:
    v = np.atleast_1d(np.asarray(value, np.float64)).ravel()
    return np.repeat(v[:1], 3) if v.size == 1 else v[:3]


def _numbers(tokens):
    try:
        return [float(t) for t in tokens]
    except (TypeError, ValueError):
        return None


def _mtl_texture(tokens, base_dir: str, where: str, lost: list):
    """A texture from the tokens after ``map_Kd`` (options then a file name)."""
    tokens = list(tokens)
    kw, i = {}, 0
    while i < len(tokens) - 1 and tokens[i].startswith("-"):
        opt = tokens[i].lower()
        if opt == "-s":
            nums = []
            i += 1
            while i < len(tokens) - 1 and _numbers([tokens[i]]) is not None and len(nums) < 3:
                nums.append(float(tokens[i]))
                i += 1
            if len(nums) >= 2:
                kw["tiling"] = (nums[0], nums[1])
            continue
        if opt == "-clamp" and i + 1 < len(tokens) - 1:
            kw["wrap"] = "clamp" if tokens[i + 1].lower() == "on" else "repeat"
            i += 2
            continue
        lost.append(f"{where} option {tokens[i]}")
        i += 2
    path = os.path.join(base_dir, " ".join(tokens[i:]))
    try:
        return Texture.from_image(path, **kw)
    except ValueError as exc:
        lost.append(f"{where} ({exc})")
        return None


def _from_simple(mat, base_dir: str, name: str, lost: list) -> Material:
    """OBJ/MTL: the raw values trimesh keeps in ``kwargs`` (its RGBA fields are 8-bit)."""
    raw = dict(getattr(mat, "kwargs", {}) or {})
    kw = {"name": name}
    for key in ("kd", "ka", "ks"):
        if key in raw:
            kw[key] = np.clip(_rgb(raw.pop(key)), 0.0, None)
    if "ns" in raw:
        ns = float(np.atleast_1d(raw.pop("ns"))[0])
        if ns > 0:
            kw["shininess"] = min(ns, _MAX_SHININESS)
        else:
            lost.append(f"Ns {ns:g} (the shininess must be > 0; kept {Material().shininess:g})")
    illum = raw.pop("illum", None)
    if illum is not None:
        code = int(float(illum[0]))
        if code in (0, 1):
            kw["ks"] = 0.0  # colour (and ambient) only: no highlight
        elif code != 2:
            lost.append(f"illum {code} (reflection/refraction models; shaded as illum 2)")
    raw.pop("ni", None)  # refraction index: only meaningful with transparency, reported there
    image = getattr(mat, "image", None)
    if image is not None:
        kw["kd_map"] = Texture.from_array(np.asarray(image), srgb=True, name=f"{name}.map_Kd")
        raw.pop("map_kd", None)
    for key in ("map_ka", "map_ks"):
        if key in raw:
            tex = _mtl_texture(raw.pop(key), base_dir, key, lost)
            if tex is not None:
                kw[key[4:] + "_map"] = tex
    for key, value in raw.items():
        nums = _numbers(value) if isinstance(value, (list, tuple)) else None
        if key in _MTL_HARMLESS and nums and all(n == _MTL_HARMLESS[key] for n in nums):
            continue
        shown = " ".join(map(str, value)) if isinstance(value, (list, tuple)) else value
        lost.append(f"{key} {shown}".strip())
    return kw


def _from_pbr(mat, name: str, lost: list) -> dict:
    """glTF metallic-roughness onto kd, ks, t (see the module docstring)."""
    base = np.asarray(getattr(mat, "baseColorFactor", None) if mat.baseColorFactor is not None
                      else [255, 255, 255, 255])
    base = base.astype(np.float64) / 255.0 if base.dtype.kind in "ui" else base.astype(np.float64)
    if base.size == 4 and base[3] < 1.0:
        lost.append(f"baseColorFactor alpha {base[3]:g} (transparency)")
    base = base[:3]
    m = 1.0 if mat.metallicFactor is None else float(mat.metallicFactor)
    r = 1.0 if mat.roughnessFactor is None else float(mat.roughnessFactor)
    alpha = max(r * r, 1e-6)
    kw = {"name": name, "kd": base * (1.0 - m), "ks": 0.04 * (1.0 - m) + base * m, "specular": "blinn",
          "shininess": float(np.clip(2.0 / alpha ** 2 - 2.0, 1.0, _MAX_SHININESS))}
    tex = getattr(mat, "baseColorTexture", None)
    if tex is not None:
        t = Texture.from_array(np.asarray(tex), srgb=True, name=f"{name}.baseColorTexture")
        kw["kd_map"] = t
        if m > 0:
            kw["ks_map"] = t
    for field in ("normalTexture", "occlusionTexture", "emissiveTexture", "metallicRoughnessTexture"):
        if getattr(mat, field, None) is not None:
            lost.append(field)
    emissive = getattr(mat, "emissiveFactor", None)
    if emissive is not None and np.any(np.asarray(emissive, np.float64) > 0):
        lost.append(f"emissiveFactor {np.round(np.asarray(emissive, np.float64), 4).tolist()}")
    mode = getattr(mat, "alphaMode", None)
    if mode not in (None, "OPAQUE"):
        lost.append(f"alphaMode {mode}")
    return kw


def material_from_trimesh(visual, base_dir: str = ".", name: str = "material") -> tuple:
    """A trimesh visual's material as :class:`Material` keywords.

    Returns
    -------
    kwargs : dict
        Keywords of :class:`Material` (empty: the library's defaults).
    lost : list of str
        What the material had that could not be mapped.
    """
    import trimesh

    mat = getattr(visual, "material", None)
    lost = []
    if mat is None:
        return {}, lost
    mname = getattr(mat, "name", None) or name
    if isinstance(mat, trimesh.visual.material.PBRMaterial):
        return _from_pbr(mat, mname, lost), lost
    if isinstance(mat, trimesh.visual.material.SimpleMaterial):
        return _from_simple(mat, base_dir, mname, lost), lost
    lost.append(f"a {type(mat).__name__}")
    return {}, lost


def load_models(path, *, merge: bool = False, use_normals: bool | None = None, **mesh_kwargs) -> list:
    """Every mesh in a file with its own material, as :class:`Model` objects.

    An OBJ with several ``usemtl`` materials, or a glTF with several
    meshes, becomes several models (placed by the file's node transforms).
    Vertices are kept as written unless ``merge=True`` (see
    :meth:`Mesh.load`). Colours become the mesh's ``colors`` (its kd); a
    material's factor multiplies them (glTF: baseColor times ``COLOR_0``).

    Parameters
    ----------
    path : str or path-like
    merge : bool
        Weld coincident vertices.
    use_normals : bool, optional
        As in :meth:`Mesh.from_trimesh`.
    **mesh_kwargs
        Further :class:`Mesh` keywords (``crease_angle``, ``weighting``);
        ``name`` prefixes the models' names.

    Returns
    -------
    list of Model

    Warns
    -----
    DroppedOnLoadWarning
        Naming every field of the file that has no counterpart here.
    """
    import trimesh

    tm, srgb = read_trimesh(path, merge)
    base = mesh_kwargs.pop("name", os.path.basename(os.fspath(path)))
    base_dir = os.path.dirname(os.path.abspath(os.fspath(path)))
    if _is_scene(tm):
        items = []
        for node in tm.graph.nodes_geometry:
            transform, gname = tm.graph[node]
            g = tm.geometry.get(gname)
            if isinstance(g, trimesh.Trimesh) and len(g.faces):
                items.append((f"{base}:{node}", g, np.asarray(transform, np.float64)))
    else:
        items = [(base, tm, np.eye(4))]
    models, lost = [], []
    for name, g, transform in items:
        kw, why = material_from_trimesh(g.visual, base_dir, name)
        lost += [f"{name}: {w}" for w in why]
        vertices, faces, normals, uvs = _instance(g, transform, use_normals)
        colors, mode = visual_colors(g, srgb, name)
        if colors is not None and "kd" in kw:
            colors = colors * kw["kd"]  # kd's factor times the colours (glTF: baseColorFactor * COLOR_0)
        maps = [k for k in ("kd_map", "ka_map", "ks_map") if k in kw]
        if maps and uvs is None:
            lost.append(f"{name}: {', '.join(maps)} (the mesh has no UVs)")
            for k in maps:
                kw.pop(k)
        mesh = Mesh(vertices, faces, normals=normals, uvs=uvs, colors=colors,
                    color_mode=mode or "auto", name=name, **mesh_kwargs)
        models.append(Model(mesh, Material(**kw) if kw else Material(name=name)))
    if lost:
        warnings.warn(f"{base}: not mapped (no counterpart in the lecture's model): " + "; ".join(lost),
                      DroppedOnLoadWarning, stacklevel=2)
    return models
