"""A glTF's JSON checked for the types and references its geometry is read through (issue 44, item 6).

trimesh trusts the JSON: a string where a mesh object belongs stops it with ``'str' object has no
attribute 'get'``, an accessor index past the end with a bare IndexError, an accessor reaching past
its buffer view with a NumPy message. :func:`check_gltf_structure` names the JSON path instead
(``meshes[0].primitives[1].indices``), before any reader runs: every top-level array a list of
objects; every index (node, mesh, accessor, buffer view, buffer, material, texture, image, sampler,
scene) an integer within its array; counts, offsets and enums as the specification gives them; and
every accessor within its buffer view.
"""

from __future__ import annotations

import base64
import binascii
import os
import struct
from urllib.parse import unquote

import numpy as np

from .gltfgeometry import COMPONENT_DTYPES, TYPE_WIDTHS

__all__ = ["check_gltf_structure"]

_ARRAYS = ("accessors", "animations", "buffers", "bufferViews", "cameras", "images", "materials", "meshes",
           "nodes", "samplers", "scenes", "skins", "textures")
_COMPONENTS = {k: np.dtype(v).itemsize for k, v in COMPONENT_DTYPES.items()}  # bytes per component
_TYPES = TYPE_WIDTHS
_TEXTURE_SLOTS = (("pbrMetallicRoughness", "baseColorTexture"), ("pbrMetallicRoughness", "metallicRoughnessTexture"),
                  ("normalTexture",), ("occlusionTexture",), ("emissiveTexture",))


class _Check:
    def __init__(self, js: dict, name: str):
        self.js, self.name = js, name

    def fail(self, path: str, what: str):
        raise ValueError(f"{self.name}: {path}: {what}")

    def kind(self, value, path: str, want: type, what: str):
        ok = isinstance(value, want) and not (want in (int, float, (int, float)) and isinstance(value, bool))
        if not ok:
            self.fail(path, f"expected {what}, got {_show(value)}")
        return value

    def count(self, obj: dict, key: str, path: str, low: int = 0, required: bool = False):
        if key not in obj:
            if required:
                self.fail(_at(path, key), "missing (required)")
            return None
        value = self.kind(obj[key], _at(path, key), int, "an integer")
        if value < low:
            self.fail(_at(path, key), f"expected an integer >= {low}, got {value}")
        return value

    def ref(self, obj: dict, key: str, path: str, array: str, required: bool = False):
        """``obj[key]`` as an index into the top-level ``array`` (None when absent and not required)."""
        index = self.count(obj, key, path, 0, required)
        if index is not None and index >= len(self.js.get(array, [])):
            self.fail(_at(path, key), f"{array}[{index}] does not exist (the file has {len(self.js.get(array, []))})")
        return index

    def refs(self, obj: dict, key: str, path: str, array: str):
        """``obj[key]``, a list of indices into the top-level ``array``."""
        items = self.kind(obj.get(key, []), _at(path, key), list, f"a list of {array} indices")
        for j, index in enumerate(items):
            self.ref({j: index}, j, _at(path, key), array)

    def number(self, obj, key: str, path: str):
        """``obj[key]``, when present, a JSON number (trimesh converts it with ``float``)."""
        if isinstance(obj, dict) and key in obj:
            v = obj[key]
            if not isinstance(v, (int, float)) or isinstance(v, bool):
                self.fail(f"{path}.{key}", f"expected 1 number, got {_show(v)}")

    def numbers(self, obj: dict, key: str, path: str, size: int | None = None):
        if key in obj:
            value = self.kind(obj[key], f"{path}.{key}", list, "a list of numbers")
            if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value) or (
                    size is not None and len(value) != size):
                self.fail(f"{path}.{key}", f"expected {size or 'a list of'} numbers, got {_show(value)}")


def _at(path: str, key) -> str:
    """The JSON path of ``key`` inside ``path``: ``a.b``, ``a[3]``, or the key alone at the top."""
    return f"{path}[{key}]" if isinstance(key, int) else f"{path}.{key}" if path else key


def _show(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check_gltf_structure(js: dict, name: str, file_path: str | None = None) -> None:
    """Refuse a glTF whose geometry the readers would trip over, naming the JSON path.

    Parameters
    ----------
    js : dict
        The file's JSON (its top level already known to be an object).
    name : str
        The file's name, for the messages.
    file_path : str, optional
        The file, to measure its buffers (a ``.glb``'s binary chunk, data URIs, ``.bin`` files beside it)
        against their ``byteLength``.

    Raises
    ------
    ValueError
        ``name: path: what is wrong`` (e.g. ``a.gltf: meshes[0].primitives[1].indices: accessors[7] does not
        exist (the file has 3)``).
    """
    c = _Check(js, name)
    for key in _ARRAYS:
        if key in js:
            items = c.kind(js[key], key, list, "a list of objects")
            for i, item in enumerate(items):
                c.kind(item, f"{key}[{i}]", dict, "an object")
    for key in ("asset", "extensions"):
        if key in js:
            c.kind(js[key], key, dict, "an object")
    if "version" in js.get("asset", {}):
        c.kind(js["asset"]["version"], "asset.version", str, "a string (\"2.0\")")
    if "scene" in js:
        c.ref(js, "scene", "", "scenes")
    for i, scene in enumerate(js.get("scenes", [])):
        c.refs(scene, "nodes", f"scenes[{i}]", "nodes")
    for i, node in enumerate(js.get("nodes", [])):
        path = f"nodes[{i}]"
        c.refs(node, "children", path, "nodes")
        for key, array in (("mesh", "meshes"), ("camera", "cameras"), ("skin", "skins")):
            c.ref(node, key, path, array)
        for key, size in (("matrix", 16), ("rotation", 4), ("scale", 3), ("translation", 3)):
            c.numbers(node, key, path, size)
    for i, mesh in enumerate(js.get("meshes", [])):
        prims = c.kind(mesh.get("primitives"), f"meshes[{i}].primitives", list, "a list of primitive objects")
        for j, prim in enumerate(prims):
            where = f"meshes[{i}].primitives[{j}]"
            _primitive(c, c.kind(prim, where, dict, "an object"), where)
    for i, mat in enumerate(js.get("materials", [])):
        for slot in _TEXTURE_SLOTS:
            holder, path = mat, f"materials[{i}]"
            for key in slot[:-1]:
                holder, path = c.kind(holder.get(key, {}), f"{path}.{key}", dict, "an object"), f"{path}.{key}"
            if slot[-1] in holder:
                tex = c.kind(holder[slot[-1]], f"{path}.{slot[-1]}", dict, "an object ({\"index\": ...})")
                c.ref(tex, "index", f"{path}.{slot[-1]}", "textures", required=True)
                c.count(tex, "texCoord", f"{path}.{slot[-1]}")
        _material_shapes(c, mat, f"materials[{i}]")
    for i, tex in enumerate(js.get("textures", [])):
        c.ref(tex, "sampler", f"textures[{i}]", "samplers")
        c.ref(tex, "source", f"textures[{i}]", "images")
    for i, image in enumerate(js.get("images", [])):
        c.ref(image, "bufferView", f"images[{i}]", "bufferViews")
        if "uri" in image:
            c.kind(image["uri"], f"images[{i}].uri", str, "a string")
    for i, buf in enumerate(js.get("buffers", [])):
        c.count(buf, "byteLength", f"buffers[{i}]", 1, required=True)
        if "uri" in buf:
            c.kind(buf["uri"], f"buffers[{i}].uri", str, "a string")
    if file_path is not None:
        _buffer_sizes(c, file_path)
    _node_forest(c)
    for i, view in enumerate(js.get("bufferViews", [])):
        path = f"bufferViews[{i}]"
        b = c.ref(view, "buffer", path, "buffers", required=True)
        end = (c.count(view, "byteOffset", path) or 0) + c.count(view, "byteLength", path, 1, required=True)
        if end > js["buffers"][b]["byteLength"]:
            c.fail(path, f"ends at byte {end}, past buffers[{b}].byteLength {js['buffers'][b]['byteLength']}")
        c.count(view, "byteStride", path, 4)
    for i, acc in enumerate(js.get("accessors", [])):
        _accessor(c, acc, f"accessors[{i}]")


def _buffer_sizes(c: _Check, path: str) -> None:
    """Every buffer's data there (a missing file is refused: it holds geometry) and as long as its byteLength."""
    bin_chunk = None
    if path.lower().endswith(".glb"):
        with open(path, "rb") as fh:
            fh.seek(12)
            length = struct.unpack("<I", fh.read(4))[0]
            fh.seek(20 + length)
            head = fh.read(8)
            bin_chunk = struct.unpack("<I", head[:4])[0] if len(head) == 8 and head[4:] == b"BIN\0" else None
    for i, buf in enumerate(c.js.get("buffers", [])):
        uri, where = buf.get("uri"), f"buffers[{i}]"
        if uri is None:
            have, what = bin_chunk, "the .glb's binary chunk"
            if have is None:
                c.fail(where, "no uri, and the file has no binary chunk to hold it")
        elif uri.startswith("data:"):
            try:
                have = len(base64.b64decode(uri.split(",", 1)[1] if "," in uri else "", validate=True))
            except (binascii.Error, ValueError):
                have = None
            if have is None:
                c.fail(f"{where}.uri", "not valid base64 data")
            what = "its data URI"
        else:
            full = os.path.join(os.path.dirname(os.path.abspath(path)), unquote(uri))
            if not os.path.isfile(full):
                c.fail(where, f"the file {uri} is missing (it holds the geometry: nothing can be drawn without it)")
            have, what = os.path.getsize(full), uri
        if have < buf["byteLength"]:
            c.fail(where, f"byteLength {buf['byteLength']}, but {what} holds {have} byte(s)")


def _node_forest(c: _Check) -> None:
    """Nodes form trees: no node the child of two parents, none its own ancestor (readers loop forever)."""
    parent = {}
    for i, node in enumerate(c.js.get("nodes", [])):
        for child in node.get("children", []):
            if child == i:
                c.fail(f"nodes[{i}].children", "the node lists itself as a child (nodes form trees)")
            if child in parent:
                c.fail(f"nodes[{i}].children", f"node {child} is already the child of node {parent[child]} "
                                               "(nodes form trees: one parent each, no cycles)")
            parent[child] = i
    for start in parent:
        seen, at = {start}, start
        while at in parent:
            at = parent[at]
            if at in seen:
                c.fail(f"nodes[{at}].children", "the nodes' children form a cycle (nodes form trees)")
            seen.add(at)


def _material_shapes(c: _Check, mat: dict, path: str) -> None:
    """The shapes trimesh reads a material's factors in (their ranges are the material loader's to judge)."""
    pbr = c.kind(mat.get("pbrMetallicRoughness", {}), f"{path}.pbrMetallicRoughness", dict, "an object")
    c.numbers(pbr, "baseColorFactor", f"{path}.pbrMetallicRoughness", 4)
    for key in ("metallicFactor", "roughnessFactor"):
        c.number(pbr, key, f"{path}.pbrMetallicRoughness")
    c.numbers(mat, "emissiveFactor", path, 3)
    c.number(mat, "alphaCutoff", path)
    c.number(mat.get("normalTexture"), "scale", f"{path}.normalTexture")
    c.number(mat.get("occlusionTexture"), "strength", f"{path}.occlusionTexture")
    ext = mat.get("extensions")
    sg = ext.get("KHR_materials_pbrSpecularGlossiness") if isinstance(ext, dict) else None
    if isinstance(sg, dict):  # trimesh converts it too
        at = f"{path}.extensions.KHR_materials_pbrSpecularGlossiness"
        c.numbers(sg, "diffuseFactor", at, 4)
        c.numbers(sg, "specularFactor", at, 3)
        c.number(sg, "glossinessFactor", at)
    if "alphaMode" in mat and mat["alphaMode"] not in ("OPAQUE", "MASK", "BLEND"):
        c.fail(_at(path, "alphaMode"), f"expected OPAQUE, MASK or BLEND, got {_show(mat['alphaMode'])}")
    if "doubleSided" in mat:
        c.kind(mat["doubleSided"], _at(path, "doubleSided"), bool, "true or false")


def _primitive(c: _Check, prim: dict, path: str) -> None:
    attrs = c.kind(prim.get("attributes"), f"{path}.attributes", dict, "an object of accessor indices")
    for key in attrs:
        c.ref(attrs, key, f"{path}.attributes", "accessors")
    if "POSITION" not in attrs:
        c.fail(f"{path}.attributes", "no POSITION (the primitive has no vertices to draw)")
    pos = c.js["accessors"][attrs["POSITION"]]
    quantized = "KHR_mesh_quantization" in (c.js.get("extensionsUsed") or [])
    if pos.get("type") != "VEC3" or (pos.get("componentType") != 5126 and not quantized):
        c.fail(f"{path}.attributes.POSITION", f"accessors[{attrs['POSITION']}] is {_show(pos.get('type'))} of "
                                              f"componentType {pos.get('componentType')}: positions are VEC3 "
                                              "floats (5126) without KHR_mesh_quantization")
    index = c.ref(prim, "indices", path, "accessors")
    if index is not None:
        acc = c.js["accessors"][index]
        if acc.get("type") != "SCALAR" or acc.get("componentType") not in (5121, 5123, 5125):
            c.fail(f"{path}.indices", f"accessors[{index}] is {_show(acc.get('type'))} of componentType "
                                      f"{acc.get('componentType')}: indices are SCALAR unsigned integers (5121, "
                                      "5123, 5125)")
    count = c.js["accessors"][index].get("count") if index is not None else pos.get("count")
    if prim.get("mode", 4) == 4 and isinstance(count, int) and count % 3:
        c.fail(f"{path}.indices" if index is not None else f"{path}.attributes.POSITION",
               f"{count} {'indices' if index is not None else 'vertices'} for mode 4 (triangles): not a multiple of 3")
    c.ref(prim, "material", path, "materials")
    mode = c.count(prim, "mode", path)
    if mode is not None and mode > 6:
        c.fail(f"{path}.mode", f"expected 0..6 (points .. triangle fan), got {mode}")
    for t, target in enumerate(c.kind(prim.get("targets", []), f"{path}.targets", list, "a list of objects")):
        for key in c.kind(target, f"{path}.targets[{t}]", dict, "an object of accessor indices"):
            c.ref(target, key, f"{path}.targets[{t}]", "accessors")


def _accessor(c: _Check, acc: dict, path: str) -> None:
    count = c.count(acc, "count", path, 1, required=True)
    comp = c.count(acc, "componentType", path, required=True)
    if comp not in _COMPONENTS:
        c.fail(f"{path}.componentType", f"expected one of {sorted(_COMPONENTS)}, got {comp}")
    kind = acc.get("type")
    if kind not in _TYPES:
        c.fail(f"{path}.type", f"expected one of {', '.join(_TYPES)}, got {_show(kind)}")
    offset = c.count(acc, "byteOffset", path) or 0
    c.numbers(acc, "min", path, _TYPES[kind])
    c.numbers(acc, "max", path, _TYPES[kind])
    view = c.ref(acc, "bufferView", path, "bufferViews")
    if view is None:
        return  # zeros (or sparse values): nothing to read past
    v = c.js["bufferViews"][view]
    size = _COMPONENTS[comp] * _TYPES[kind]
    stride = v.get("byteStride") or size
    end = offset + stride * (count - 1) + size
    if end > v["byteLength"]:
        c.fail(path, f"{count} {kind} of {size} byte(s) from byte {offset} end at byte {end}, past "
                     f"bufferViews[{view}].byteLength {v['byteLength']}")
