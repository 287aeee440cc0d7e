"""``raycast-shade inspect FILE``: what a mesh file holds, and what each part became.

:func:`inspect_file` loads the file the way :func:`raycast_shade.load_models`
does and reports, per mesh, its counts and attributes; per material, each
field the file gives and its fate: **mapped** (exactly, onto the lecture's
coefficients), **approximated** (mapped, with the approximation named) or
**dropped** (no counterpart: the loader's warning names it too); the
textures with their sizes and colour types (PIL modes), and glTF samplers
and extensions (``extensionsUsed`` with each one's fate, ``extensionsRequired``).
"""

from __future__ import annotations

import os
import warnings

import numpy as np

__all__ = ["inspect_file", "format_report", "register_cli", "run_cli"]

_GLTF_MAPPED = {"baseColorFactor": "kd, ka (x (1 - m + m a)), ks (metal part)", "baseColorTexture": "kd_map, ka_map",
                "metallicFactor": "kd/ks split", "roughnessFactor": "shininess t = 2/a^2 - 2, a = r^2",
                "doubleSided": "double_sided (back faces drawn two-sided; SingleSidedWarning where the camera sees them)",
                "emissiveFactor": "ke (times KHR_materials_emissive_strength)", "emissiveTexture": "ke_map",
                "occlusionTexture": "ao_map (red channel, linear) and ao_strength: scales ka per texel",
                "alphaCutoff": "alpha_cutoff (with alphaMode MASK)",
                "normalTexture": "normal_map (linear, tangent space) and normal_scale; TANGENT or tangents from UVs"}
_GLTF_APPROX = {"metallicRoughnessTexture": "per-texel kd and ks; one exponent from the median roughness"}
_MTL_MAPPED = {"kd": "kd", "ka": "ka", "ks": "ks", "ns": "shininess", "illum": "0/1: ks = 0; 2: as is",
               "map_kd": "kd_map", "map_ka": "ka_map", "map_ks": "ks_map", "ke": "ke", "map_ke": "ke_map"}


def _image_info(image) -> str:
    if image is None:
        return "none"
    if hasattr(image, "mode"):
        return f"{image.size[0]}x{image.size[1]} {image.mode}"
    a = np.asarray(image)
    return f"{a.shape[1]}x{a.shape[0]} {a.dtype}"


def _gltf_fields(js: dict, notes: list) -> list:
    """``(field, value, fate, how)`` rows of a glTF material's JSON."""
    rows = []
    flat = dict(js.get("pbrMetallicRoughness") or {})
    flat.update({k: v for k, v in js.items() if k not in ("pbrMetallicRoughness", "name", "extras")})
    for key, value in flat.items():
        shown = f"texture {value.get('index')}" if isinstance(value, dict) and "index" in value else value
        if key == "emissiveFactor" and not any(np.asarray(value, float) > 0):
            rows.append((key, value, "mapped", "zero: nothing emitted"))
        elif key in _GLTF_MAPPED:
            rows.append((key, shown, "mapped", _GLTF_MAPPED[key]))
        elif key in _GLTF_APPROX:
            rows.append((key, shown, "approximated", _GLTF_APPROX[key]))
        elif key == "alphaMode":
            rows.append((key, value, "approximated" if value == "BLEND" else "mapped",
                         {"OPAQUE": "opaque", "MASK": "alpha_map: rays pass where alpha < cutoff"}.get(
                             value, "as MASK at cutoff 0.5")))
        else:
            rows.append((key, shown, "dropped", "no counterpart in the lecture's model"))
    return rows


def _extensions(header: dict) -> dict:
    """A glTF's ``extensionsUsed`` (each with its fate, as ``docs/files.md``'s policy gives it) and
    ``extensionsRequired``."""
    from ..scene.gltfgeometry import GLTF_EXTENSIONS

    used = [e for e in header.get("extensionsUsed") or [] if isinstance(e, str)]
    return {"used": [(e, GLTF_EXTENSIONS.get(e, ("not applied", ""))[0]) for e in used],
            "required": [e for e in header.get("extensionsRequired") or [] if isinstance(e, str)]}


def inspect_file(path) -> dict:
    """What ``path`` holds and what :func:`raycast_shade.load_models` made of it.

    Returns
    -------
    dict
        ``file``, ``format``; ``models``: one dict per loaded model (``name``,
        ``vertices``, ``faces``, ``uvs``, ``normals``, ``colors``,
        ``material`` (its coefficients), ``maps`` (name, size, wrap, tiling),
        ``fields``: ``(field, value, fate, how)`` rows); ``textures``: the
        images the file holds (size and PIL mode); ``samplers`` (glTF); ``extensions`` (glTF: ``used``,
        ``(name, fate)`` pairs, and ``required``, names);
        ``notes``: every warning the loader gave.
    """
    from ..scene import fileparse
    from ..scene.filematerial import is_placeholder
    import trimesh

    from ..scene.mesh import read_trimesh
    from ..scene.meshfile import load_models

    path = os.fspath(path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        models = load_models(path)
        tm, _ = read_trimesh(path)
    notes = list(dict.fromkeys(str(w.message) for w in caught))  # read twice: each warning once
    ext = os.path.splitext(path)[1].lower()
    report = {"file": path, "format": ext.lstrip(".") or "?", "models": [], "textures": [], "samplers": [],
              "notes": notes}
    header = fileparse.gltf_header(path) if ext in (".gltf", ".glb") else None
    mtl = {}
    if ext == ".obj":
        for f in fileparse.obj_mtl_files(path):
            mtl.update(fileparse.parse_mtl(f))
    geoms = list(tm.geometry.values()) if isinstance(tm, trimesh.Scene) else [tm]
    seen = {}
    for g in geoms:
        mat = getattr(getattr(g, "visual", None), "material", None)
        for attr in ("image", "baseColorTexture", "metallicRoughnessTexture", "normalTexture", "emissiveTexture",
                     "occlusionTexture"):
            img = getattr(mat, attr, None)
            if img is not None and id(img) not in seen:
                seen[id(img)] = True
                info = _image_info(img)
                if attr == "image" and is_placeholder(mat):
                    info += " (trimesh's stand-in for no material: not used)"
                report["textures"].append((f"{getattr(mat, 'name', None) or '?'}.{attr}", info))
    if header:
        report["extensions"] = _extensions(header)
        names = {10497: "repeat", 33071: "clamp", 33648: "mirrored repeat"}
        for i, smp in enumerate(header.get("samplers", []) or []):
            report["samplers"].append((i, names.get(smp.get("wrapS", 10497), "?"),
                                       names.get(smp.get("wrapT", 10497), "?"), "mapped"))
    gltf_mats = {m.get("name"): m for m in (header or {}).get("materials", []) or [] if isinstance(m, dict)}
    for model in models:
        mesh, mat = model.mesh, model.material
        rows = []
        if mat.name in mtl:
            for key, (tokens, line) in mtl[mat.name].fields.items():
                value = " ".join(tokens)
                where = f"{os.path.basename(mtl[mat.name].path)}:{line}"
                named = [n for n in notes if f"at {where}" in n or f"({where})" in n or f", {where})" in n]
                if named:  # the loader's warning names this line: dropped, or kept otherwise
                    fate, how = ("approximated" if key in _MTL_MAPPED else "dropped"), "see the warning"
                elif key in _MTL_MAPPED:
                    fate, how = "mapped", _MTL_MAPPED[key]
                else:
                    fate, how = "mapped", "no effect (the value changes nothing)"  # d 1, Tr 0, Ke 0, Ni
                rows.append((f"{key} ({where})", value, fate, how))
        elif mat.name in gltf_mats:
            rows = _gltf_fields(gltf_mats[mat.name], notes)
        maps = [(field, m.name, f"{m.shape[1]}x{m.shape[0]}", m.wrap, m.tiling)
                for field, m in (("kd_map", mat.kd_map), ("ka_map", mat.ka_map), ("ks_map", mat.ks_map),
                                 ("normal_map", mat.normal_map))
                if m is not None]
        report["models"].append({
            "name": mesh.name, "vertices": len(mesh.vertices), "faces": len(mesh.faces),
            "uvs": mesh.uvs is not None, "normals": mesh.normals is not None, "colors": mesh.color_mode,
            "tangents": "file" if mesh.tangents is not None else ("from UVs" if mat.normal_map is not None else None),
            "material": {"name": mat.name, "kd": mat.kd.round(4).tolist(), "ka": mat.ka.round(4).tolist(),
                         "ks": mat.ks.round(4).tolist(), "shininess": round(float(mat.shininess), 3),
                         "specular": mat.specular},
            "maps": maps, "fields": rows})
    return report


def format_report(report: dict) -> str:
    """The report as plain text, one item a line."""
    out = [f"{report['file']} ({report['format']}): {len(report['models'])} model(s)"]
    for m in report["models"]:
        out.append(f"  model {m['name']}: {m['vertices']} vertices, {m['faces']} faces, "
                   f"UVs {'yes' if m['uvs'] else 'no'}, file normals {'yes' if m['normals'] else 'no'}, "
                   f"colours {m['colors'] or 'none'}"
                   + (f", tangents {m['tangents']}" if m.get("tangents") else ""))
        mat = m["material"]
        out.append(f"    material {mat['name']}: kd {mat['kd']} ka {mat['ka']} ks {mat['ks']} "
                   f"t {mat['shininess']} ({mat['specular']})")
        for field, name, size, wrap, tiling in m["maps"]:
            out.append(f"    {field}: {name} {size}, wrap {wrap}, tiling {list(tiling)}")
        for field, value, fate, how in m["fields"]:
            out.append(f"    {fate:<12} {field} = {value}: {how}")
    ext = report.get("extensions")
    if ext:
        out.append("  extensionsUsed: " + (", ".join(f"{e} ({fate})" for e, fate in ext["used"]) or "none"))
        out.append("  extensionsRequired: " + (", ".join(ext["required"]) or "none"))
    for name, info in report["textures"]:
        out.append(f"  texture {name}: {info}")
    for i, s, t, fate in report["samplers"]:
        out.append(f"  sampler {i}: wrapS {s}, wrapT {t} ({fate})")
    for n in report["notes"]:
        out.append(f"  warning: {n}")
    return "\n".join(out)


def register_cli(subparsers):
    """Add the ``inspect`` command to the ``raycast-shade`` parser."""
    p = subparsers.add_parser(
        "inspect", help="what a mesh file holds and what each field became",
        description="Load a mesh file as render does and list its meshes (counts, UVs, normals, colours), "
                    "materials (each field: mapped, approximated or dropped), textures (size, colour type) "
                    "and samplers.")
    p.add_argument("file", metavar="FILE", help="mesh file (OBJ, glTF/GLB, PLY, OFF, STL, ...)")


def run_cli(ns) -> int:
    """Run ``raycast-shade inspect``; errors are raised for the caller to print on one line."""
    if not os.path.exists(ns.file):
        raise ValueError(f"{ns.file}: file not found")
    print(format_report(inspect_file(ns.file)))
    return 0
