"""Models from mesh files: geometry, colours, and the file's materials.

:func:`load_models` reads what a file carries through trimesh's visuals and,
for what trimesh passes over, the file itself (:mod:`.fileparse`: MTL files
with their lines, ``usemtl`` names, glTF samplers and image URIs, OFF
colours), and maps it onto the lecture's coefficients (the table is in
``docs/textures.md``):

* OBJ/MTL: ``Kd``, ``Ka``, ``Ks`` -> kd, ka, ks; ``Ns`` -> shininess;
  ``illum 0/1`` -> no specular term; ``map_Kd``, ``map_Ka``, ``map_Ks`` ->
  kd_map, ka_map, ks_map (sRGB images, with the ``-s u v`` tiling and
  ``-clamp on`` options). Every value is validated, naming the file and line.
* glTF (``PBRMaterial``), base colour ``b``, metallic ``m`` and roughness
  ``r`` (spec defaults 1; per texel where a ``metallicRoughnessTexture``
  gives them), ``alpha = r^2``: kd = b ((1 - m) + m alpha); ks = 0.04 (1 - m)
  + b m (1 - alpha); ka = b; Blinn-Phong t = 2 / alpha^2 - 2 in [1, 4096]
  (alpha of the median roughness). Sampler wrap modes (repeat, clamp,
  mirrored repeat, per axis) are honoured.
* PLY/OFF/OBJ vertex or face colours (sRGB) -> the mesh's colours.
* Where a file gives no ambient colour, ka follows the diffuse colour: ka =
  kd, ka_map = kd_map (mesh colours: see ``docs/textures.md``).

* glTF ``normalTexture`` (with its ``scale`` and sampler) -> normal_map,
  normal_scale; the primitive's ``TANGENT`` -> the mesh's tangents (computed
  from the UVs where the file has none).

What cannot be mapped (transparency beyond alpha masks, bump/displacement
maps, unknown MTL keys) is named in a
:class:`~raycast_shade.DroppedOnLoadWarning`, and so is every referenced
file that is missing.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from ..common.choices import REFLECTANCES
from ..common.validate import as_bool, as_choice
from ..common.warnings import DroppedOnLoadWarning
from .filecheck import check_mesh_file, naming_file
from .gltfgeometry import PLAIN_KEY
from .gltftangents import primitive_tangents, primitive_uvs
from .filematerial import FileContext, Wrapped, from_mtl_cached, from_pbr, from_simple, is_placeholder
from .wrapped import UV_SET
from .fileparse import off_mesh_colors
from .material import Material
from .mesh import Mesh, _instance, _is_scene, read_trimesh, use_normals_flag, visual_colors
from .normals import reversed_duplicates
from .scene import Model
from .tangents import degenerate_tangents

__all__ = ["load_models", "material_from_trimesh", "model_scene"]

def material_from_trimesh(visual, base_dir: str = ".", name: str = "material", context=None) -> tuple:
    """A trimesh visual's material as :class:`Material` keywords.

    Parameters
    ----------
    visual : trimesh visual
    base_dir : str
        Folder the file's references are relative to.
    name : str
        For a material without a name.
    context : optional
        :func:`load_models`' record of the file (its MTL, glTF JSON, decoded textures).

    Returns
    -------
    kwargs : dict
        Keywords of :class:`Material` (empty: the library's defaults). With a
        ``context``, a map may still be pending its mesh's UVs (a glTF sampler
        clamping one axis only, which :func:`load_models` resolves).
    lost : list of str
        What the material had that could not be mapped.
    """
    import trimesh

    ctx = context if context is not None else FileContext(None, base_dir=base_dir)
    mat = getattr(visual, "material", None)
    lost = []
    kw = {}
    mname = getattr(mat, "name", None) or name
    if mat is None:
        pass
    elif isinstance(mat, trimesh.visual.material.PBRMaterial):
        kw = from_pbr(mat, mname, lost, ctx)
    elif isinstance(mat, trimesh.visual.material.SimpleMaterial):
        if mname in ctx.mtl:
            kw = from_mtl_cached(ctx, mname, lost)
        elif not is_placeholder(mat):  # trimesh's grey stand-in for "no material" gives the library's default
            kw = from_simple(mat, mname, lost, ctx)
    else:
        lost.append(f"a {type(mat).__name__}")
    if context is None:  # a caller of its own: every map a Texture now (a one-axis clamp shaded as repeat)
        if UV_SET in kw:
            n, slot = kw.pop(UV_SET)
            lost.append(f"{slot}: texCoord {n} (no file to read TEXCOORD_{n} from: the mesh's UVs are used)")
        _resolve_maps(kw, None, mname, lost)
    return kw, lost


def _resolve_maps(kw: dict, uvs, name: str, lost: list):
    """Pending maps made textures for this mesh's UVs; the UVs, moved if a clamped axis was padded."""
    pending = {k: v for k, v in kw.items() if isinstance(v, Wrapped)}
    done, out_uvs = {}, None
    for k, w in pending.items():
        if id(w) not in done:
            if w.needs_uvs and uvs is not None:
                # Padded over the file's UVs; maps on one grid (the base colour's) move them alike.
                tex, new_uvs, note = w.texture(uvs)
                if new_uvs is not None:
                    if out_uvs is None:
                        out_uvs = new_uvs
                    elif not np.array_equal(new_uvs, out_uvs):
                        lost.append(f"{name}: {k} pads another grid than the other maps (shaded as repeat)")
                        tex, _, note = w.texture(None)
            else:
                tex, _, note = w.texture(None) if w.needs_uvs else w.texture(uvs)
            if note:
                lost.append(note)
            done[id(w)] = tex
        kw[k] = done[id(w)]
    return uvs if out_uvs is None else out_uvs


def load_models(path, *, merge: bool = False, use_normals: bool | None = None, reflectance: str = "phong",
                **mesh_kwargs) -> list:
    """Every mesh in a file with its own material, as :class:`Model` objects.

    An OBJ with several ``usemtl`` materials, or a glTF with several
    meshes, becomes several models (placed by the file's node transforms).
    Vertices are kept as written unless ``merge=True`` (see
    :meth:`Mesh.load`). Colours become the mesh's ``colors`` (its kd); a
    material's factor multiplies them (glTF: baseColor times ``COLOR_0``).
    Where the file gives no ambient colour, ka follows kd (and ka_map
    kd_map; on a mesh with colours ``ka=1`` and ``ka_colors=True``: the
    colours are its ka too). A face that repeats another with the opposite winding (a
    two-sided sheet) is dropped, counted in a warning: rendering lights
    every surface from the side it is seen from, and the pair would cancel
    every averaged normal around it. An image shared by several meshes is
    decoded once (one texture).

    Parameters
    ----------
    path : str or path-like
    merge : bool
        Weld coincident vertices.
    use_normals : bool, optional
        As in :meth:`Mesh.from_trimesh`.
    reflectance : {"phong", "pbr"}
        glTF materials onto the lecture's ka, kd, ks, t (``docs/textures.md``), or
        as themselves: ``Material(specular="ggx")`` (``docs/pbr.md``; other formats warn).
    **mesh_kwargs
        Further :class:`Mesh` keywords (``crease_angle``, ``weighting``);
        ``name`` prefixes the models' names.

    Returns
    -------
    list of Model

    Raises
    ------
    TypeError
        ``merge`` or ``use_normals`` not a bool (``"no"`` and 0 are refused, not
        read as flags), before the file is read.
    ValueError
        A missing or unreadable file, or a value the file gives that is not
        valid (naming the file and line, e.g. ``a.mtl:3: Kd abc``).

    Warns
    -----
    DroppedOnLoadWarning
        Naming every field of the file that has no counterpart here, every
        referenced file that is missing (MTL, images), every ``usemtl`` no
        MTL defines, and the reversed duplicate faces dropped.
    """
    import trimesh

    merge, use_normals = as_bool(merge, "merge"), use_normals_flag(use_normals)
    reflectance = as_choice(reflectance, "reflectance", REFLECTANCES)
    path = os.fspath(path)
    base = mesh_kwargs.pop("name", os.path.basename(path))
    with naming_file(path):  # a reader's IndexError or KeyError too: a ValueError naming the file
        # The file's own references and values first: a bad value is named before trimesh trips on it.
        gltf = check_mesh_file(path)
        ctx = FileContext(path, base, gltf=gltf, reflectance=reflectance)
        tm, srgb = read_trimesh(path, merge, checked=True, gltf=gltf)
        for used in dict.fromkeys(n for n, _ in ctx.usemtl):
            if used in ctx.mtl:  # every material the OBJ uses is checked, whatever trimesh made of it
                from_mtl_cached(ctx, used, [])
        if _is_scene(tm):
            items = []
            for node in tm.graph.nodes_geometry:
                transform, gname = tm.graph[node]
                g = tm.geometry.get(gname)
                if isinstance(g, trimesh.Trimesh) and len(g.faces):
                    items.append((f"{base}:{node}", g, np.asarray(transform, np.float64)))
        else:
            items = [(base, tm, np.eye(4))]
        models, twins = [], 0
        lost = [] if reflectance == "phong" or ctx.gltf is not None else [  # nothing for "pbr" to keep as itself
            f"reflectance='pbr': a {ctx.ext} file has no metallic-roughness materials (glTF's); shaded as with 'phong'"]
        for name, g, transform in items:
            kw, why = material_from_trimesh(g.visual, ctx.base_dir, name, context=ctx)
            lost += [f"{name}: {w}" for w in why]
            vertices, faces, normals, uvs = _instance(g, transform, use_normals)
            uvs = _file_uvs(ctx, tm, g, kw, name, lost, uvs)  # the UV set the material's maps read
            opaque = ctx is not None and ctx.gltf is not None and (getattr(getattr(g.visual, "material", None),
                                                                             "alphaMode", None) or "OPAQUE") == "OPAQUE"
            colors, mode = visual_colors(g, srgb, name, "ignore" if opaque else "warn")
            if colors is None and ctx.off is not None:
                colors, mode = off_mesh_colors(ctx.off, len(vertices), len(faces), name)
            if colors is not None and "kd" in kw:
                colors = colors * kw["kd"]  # kd's factor times the colours (glTF: baseColorFactor * COLOR_0)
            _drop_maps_without_uvs(kw, uvs, name, lost)
            tangents = _file_tangents(ctx, tm, g, transform, name, lost) if "normal_map" in kw else None
            if tangents is not None and any(len(bad) for bad in degenerate_tangents(tangents, normals)):
                lost.append(f"{name}: TANGENT (zero or along the normal at some vertices; tangents computed from "
                            "the UVs)")
                tangents = None
            uvs = _resolve_maps(kw, uvs, name, lost)
            dup = reversed_duplicates(faces, vertices)
            if dup.any():
                twins += int(dup.sum())
                faces = faces[~dup]
                if colors is not None and mode == "face":
                    colors = colors[~dup]
            no_ka = "ka" not in kw
            if colors is not None and (no_ka or ctx.gltf is not None):  # glTF has no ambient colour: kd's follows
                # The colours carry kd's factor; ka = (its own colour) / that factor makes ka x colour the
                # surface's ambient colour at every point (a factor 0 leaves no colour to follow).
                factor = np.broadcast_to(np.asarray(kw.get("kd", 1.0), np.float64), (3,))
                target = np.broadcast_to(np.asarray(kw.get("ka", factor), np.float64), (3,))
                if np.all(factor > 0):
                    kw["ka"], kw["ka_colors"] = target / factor, True
            if no_ka:  # the file gave no ambient colour: ka follows the diffuse colour and its texture
                kw.setdefault("ka", kw["kd"] if "kd" in kw else (1.0 if "kd_map" in kw else Material().kd))
                if "kd_map" in kw and "ka_map" not in kw:
                    kw["ka_map"] = kw["kd_map"]
            kw.setdefault("name", name)
            mesh = Mesh(vertices, faces, normals=normals, uvs=uvs, colors=colors,
                        color_mode=mode or "auto", name=name, tangents=tangents, **mesh_kwargs)
            models.append(Model(mesh, Material(**kw)))
        _warn_dropped(ctx, base, lost, twins)
        return models


def _warn_dropped(ctx, base: str, lost: list, twins: int) -> None:
    """:func:`load_models`' warnings: missing referenced files and undefined materials, then every
    part of the file not mapped (``lost``) and the reversed duplicate faces dropped (``twins``)."""
    if ctx.missing or ctx.undefined:
        parts = []
        if ctx.missing:
            parts.append("missing referenced file(s): " + "; ".join(dict.fromkeys(ctx.missing)))
        if ctx.undefined:
            parts.append("material(s) no MTL defines: " + "; ".join(ctx.undefined))
        warnings.warn(f"{base}: " + "; ".join(parts) + " (rendered with the library's default material or "
                      "without the texture)", DroppedOnLoadWarning, stacklevel=3)
    if twins:
        lost.append(f"{twins} face(s) repeating another with the opposite winding (dropped: two-sided "
                    "surfaces are lit from the side seen, and the pair cancels averaged normals)")
    if lost:
        warnings.warn(f"{base}: not mapped (no counterpart in the lecture's model): " + "; ".join(lost),
                      DroppedOnLoadWarning, stacklevel=3)


def _drop_maps_without_uvs(kw: dict, uvs, name: str, lost: list) -> None:
    """Every map dropped (named in ``lost``) from the keywords of a mesh without UVs."""
    maps = [k for k in ("kd_map", "ka_map", "ks_map", "ke_map", "ao_map", "alpha_map", "normal_map",
                        "metallic_roughness_map") if k in kw]
    if maps and uvs is None:
        lost.append(f"{name}: {', '.join(maps)} (the mesh has no UVs)")
        for k in maps:
            kw.pop(k)
        kw.pop("alpha_cutoff", None)  # no mask without its map
        kw.pop("normal_scale", None)
        kw.pop("ao_strength", None)  # likewise: no strength without its map


def _file_tangents(ctx, tm, g, transform, name: str, lost: list):
    """The glTF ``TANGENT`` of mesh ``g`` placed by ``transform`` ((V, 4), w flipped by a mirroring
    transform so the bitangent follows the mesh), or None (computed from the UVs then)."""
    if ctx is None or ctx.gltf is None or not _is_scene(tm):
        return None
    if "prims" not in ctx.cache:  # from what trimesh read: the file, or the file made plain (gltfgeometry)
        plain = tm.metadata.get(PLAIN_KEY)
        ctx.cache["prims"] = (primitive_tangents(ctx.path, plain[0], [plain[1]]) if plain is not None
                              else primitive_tangents(ctx.path, ctx.gltf))
    prims, names = ctx.cache["prims"], list(tm.geometry)
    idx = next((i for i, n in enumerate(names) if tm.geometry[n] is g), None)
    if idx is None or len(prims) != len(names) or prims[idx] is None:
        return None
    pos, tan = prims[idx]
    if pos.shape != g.vertices.shape or not np.array_equal(pos, np.asarray(g.vertices, np.float64)):
        lost.append(f"{name}: TANGENT (not matched to trimesh's vertices; tangents computed from the UVs)")
        return None
    rot = transform[:3, :3]
    return np.c_[tan[:, :3] @ rot.T, tan[:, 3] * np.sign(np.linalg.det(rot))]


def _file_uvs(ctx, tm, g, kw: dict, name: str, lost: list, uvs):
    """Mesh ``g``'s UVs: ``uvs`` (its ``TEXCOORD_0``), or where the material's maps read ``TEXCOORD_n``
    (``kw[UV_SET]``: ``(n, the slot asking)``, taken out of ``kw``) that set from the file, (V, 2) with v up
    as trimesh's UVs; where the primitive lacks it, ``uvs``, named in ``lost``."""
    if UV_SET not in kw:
        return uvs
    n, slot = kw.pop(UV_SET)
    prims, names = [], list(tm.geometry) if _is_scene(tm) else []
    if ctx.gltf is not None and names:
        key = ("uvs", n)
        if key not in ctx.cache:  # from what trimesh read: the file, or the file made plain (gltfgeometry)
            plain = tm.metadata.get(PLAIN_KEY)
            ctx.cache[key] = (primitive_uvs(ctx.path, plain[0], n, [plain[1]]) if plain is not None
                              else primitive_uvs(ctx.path, ctx.gltf, n))
        prims = ctx.cache[key]
    idx = next((i for i, k in enumerate(names) if tm.geometry[k] is g), None)
    found = prims[idx] if idx is not None and len(prims) == len(names) else None
    if found is not None and found[0].shape == g.vertices.shape and np.array_equal(found[0], g.vertices):
        return found[1]
    lost.append(f"{name}: {slot}: texCoord {n} (the primitive has no readable TEXCOORD_{n}, or it is not matched "
                "to trimesh's vertices: TEXCOORD_0 used)")
    return uvs


def model_scene(path, *, width: int = 640, height: int = 480, direction=(-0.4, -0.35, -1.0), margin: float = 0.05,
                fov: float = 45.0, ambient: float = 0.2, **load_kwargs) -> Scene:
    """A mesh file ready to render: its models, a camera framing them, a headlight and a key light.

    What ``raycast-shade render model.glb`` renders. The camera is
    :meth:`Camera.fit` along ``direction``; the headlight shines along the
    view (intensity 0.5: every visible surface lit), the key light from the
    upper left, over the viewer's shoulder (intensity 0.7); ``ambient`` is the
    ambient intensity (the file's colours show there too: ka follows kd).

    Parameters
    ----------
    path : str or path-like
        Any file :func:`raycast_shade.load_models` reads.
    width, height : int
    direction : (3,) float
        The view direction.
    margin : float
        As in :meth:`Camera.fit`.
    fov : float
    ambient : float
    **load_kwargs
        Passed to :func:`raycast_shade.load_models` (``merge``, ``crease_angle``, ...).

    Returns
    -------
    Scene
    """
    from .camera import Camera
    from .lights import DirectionalLight
    from .scene import Scene

    models = load_models(path, **load_kwargs)
    camera = Camera.fit(models, direction, margin=margin, width=width, height=height, fov=fov)
    r, u, f = camera.basis
    key = f + 0.8 * r - 0.9 * u  # from the upper left: travelling right and down
    lights = [DirectionalLight(f, intensity=0.5, name="headlight"),
              DirectionalLight(key / np.linalg.norm(key), intensity=0.7, name="key")]
    return Scene(models, lights=lights, camera=camera, ambient=ambient)
