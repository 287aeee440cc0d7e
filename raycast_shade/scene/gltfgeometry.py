"""glTF geometry trimesh reads wrong or not at all, made plain before trimesh reads the file.

trimesh 5 reads ``TRIANGLES`` and ``TRIANGLE_STRIP`` primitives with float
attributes. What it passes over would render something other than the file,
without a word: integer attributes of ``KHR_mesh_quantization`` read as raw
integers (a UV of 65535 where the file means 1), sparse accessors read as
zeros, Draco-compressed primitives read as zeros without DracoPy, triangle
fans skipped, morph targets ignored. :func:`plain_gltf` reads those parts from
the JSON and buffers itself and rewrites the file as a GLB in memory that
trimesh reads right (float attributes, ``TRIANGLES`` with explicit indices,
every buffer in one binary chunk; materials, images and nodes untouched):

* integer attributes dequantised as the spec says (``normalized``: signed
  ``max(c / (2^(b-1) - 1), -1)``, unsigned ``c / (2^b - 1)``; else the integer
  values as floats);
* sparse accessors applied;
* ``KHR_draco_mesh_compression`` decoded with DracoPy (refused with an
  install hint without it);
* strips (mode 5) as the spec's triangles ``(i, i+1, i+2)`` for even ``i``,
  ``(i+1, i, i+2)`` for odd ``i``; fans (mode 6) as ``(i+1, i+2, 0)``;
  triangles whose indices repeat (the zero-area joins of strips) dropped;
* morph targets at their default weights (the node's ``weights``, else the
  mesh's), on positions and normals (renormalised); a mesh that several
  nodes give other weights is drawn once per set of weights;
* points (mode 0) and lines (modes 1, 2, 3): skipped with a warning beside
  triangles, refused (naming the primitive) when the file has nothing else.

A file that needs none of this is left to trimesh as it is.
"""

from __future__ import annotations

import base64
import copy
import io
import json
import os
import struct
import warnings
from urllib.parse import unquote

import numpy as np

from ..common.warnings import DroppedOnLoadWarning

__all__ = ["GLTF_EXTENSIONS", "APPLIED_GLTF_EXTENSIONS", "COMPONENT_DTYPES", "TYPE_WIDTHS", "MODE_NAMES", "PLAIN_KEY", "plain_gltf", "glb_bytes",
           "load_gltf_trimesh", "warn_unapplied_extensions",
           "extension_policy_table", "strip_faces", "fan_faces", "dequantise"]

MODE_NAMES = {0: "POINTS", 1: "LINES", 2: "LINE_LOOP", 3: "LINE_STRIP", 4: "TRIANGLES", 5: "TRIANGLE_STRIP",
              6: "TRIANGLE_FAN"}

# Every glTF extension with a stated fate: "applied" (read as the spec says; a file may require it),
# "approximated" (read in part, the rest warned) or "not applied" (warned when used, refused when required).
# An extension named nowhere here is "not applied" too.
GLTF_EXTENSIONS = {
    "KHR_mesh_quantization": ("applied", "integer positions, normals, tangents and UVs dequantised as the spec says"),
    "KHR_draco_mesh_compression": ("applied", "decoded with DracoPy (`pip install raycast_shade[draco]`); "
                                              "refused with that hint without it"),
    "KHR_materials_emissive_strength": ("applied", "ke's strength"),
    "KHR_materials_pbrSpecularGlossiness": ("applied", "read by the library (its images through the usual "
                                                       "texture path): diffuse -> kd, specular -> ks, glossiness -> "
                                                       "the exponent (one per material: the median of a texture's, "
                                                       "warned); `reflectance=\"pbr\"`: converted to "
                                                       "metallic-roughness per texel (approximated, warned)"),
    "EXT_texture_webp": ("applied", "trimesh takes the WebP source, Pillow decodes it"),
    "KHR_texture_transform": ("applied", "offset, rotation, scale and `texCoord`: the mesh's UVs transformed "
                                         "at load, from the UV set the maps read (maps of one material with "
                                         "different transforms or sets: the first map's for all, warned)"),
    "KHR_materials_unlit": ("not applied", "lit as any material"),
    "KHR_materials_clearcoat": ("not applied", "no clear coat layer"),
    "KHR_materials_transmission": ("not applied", "opaque"),
    "KHR_materials_diffuse_transmission": ("not applied", "opaque"),
    "KHR_materials_volume": ("not applied", "no volume"),
    "KHR_materials_ior": ("not applied", "Blinn-Phong has no index of refraction"),
    "KHR_materials_specular": ("not applied", "the metal-roughness specular only"),
    "KHR_materials_sheen": ("not applied", "no sheen layer"),
    "KHR_materials_iridescence": ("not applied", "no thin film"),
    "KHR_materials_anisotropy": ("not applied", "isotropic highlights"),
    "KHR_materials_dispersion": ("not applied", "no dispersion"),
    "KHR_materials_variants": ("not applied", "the default material of each primitive"),
    "KHR_lights_punctual": ("not applied", "the file's lights are not read: the scene's lights are used"),
    "KHR_texture_basisu": ("not applied", "KTX2 images are not decoded"),
    "EXT_meshopt_compression": ("not applied", "compressed buffers are not decoded (refused when required)"),
    "EXT_mesh_gpu_instancing": ("not applied", "each node drawn once, not per instance"),
    "KHR_animation_pointer": ("not applied", "animations are not played: the rest pose is drawn"),
    "KHR_xmp_json_ld": ("not applied", "metadata only"),
}
APPLIED_GLTF_EXTENSIONS = frozenset(k for k, (fate, _) in GLTF_EXTENSIONS.items() if fate == "applied")

# The spec's accessor tables, the one definition the loader, the checks and the index search share.
COMPONENT_DTYPES = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
TYPE_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_VECTORS = {k: TYPE_WIDTHS[k] for k in ("SCALAR", "VEC2", "VEC3", "VEC4")}  # what geometry reads (no padded matrices)
_TRIANGLE_MODES = (4, 5, 6)
PLAIN_KEY = "raycast_shade_plain_gltf"  # in trimesh's scene metadata: (JSON, buffer) it was read from
_DRACO = "KHR_draco_mesh_compression"
_SPEC_GLOSS = "KHR_materials_pbrSpecularGlossiness"
_FLOATED = ("POSITION", "NORMAL", "TANGENT")  # and every TEXCOORD_n: what trimesh and the shading read as floats


def extension_policy_table() -> str:
    """The extension policy as the Markdown table of ``docs/files.md`` (generated from :data:`GLTF_EXTENSIONS`)."""
    rows = ["| extension | used | required | what the loader does |", "| --- | --- | --- | --- |"]
    for name, (fate, how) in sorted(GLTF_EXTENSIONS.items(), key=lambda kv: (kv[1][0] != "applied", kv[0])):
        used = {"applied": "applied", "approximated": "approximated, warned"}.get(fate, "warned")
        rows.append(f"| `{name}` | {used} | {'read' if fate == 'applied' else 'refused'} | {how} |")
    rows.append("| any other | warned | refused | named in the warning or the refusal |")
    return "\n".join(rows)


def dequantise(values: np.ndarray, normalized: bool) -> np.ndarray:
    """Accessor values as float64: integers scaled as the glTF spec says when ``normalized``.

    Parameters
    ----------
    values : (N, k) array
        As stored (int8, uint8, int16, uint16, uint32 or float32).
    normalized : bool
        The accessor's ``normalized``.

    Returns
    -------
    (N, k) float64
        Signed ``max(c / (2^(b-1) - 1), -1)``, unsigned ``c / (2^b - 1)``;
        floats and non-normalized integers as they are.
    """
    a = np.asarray(values)
    if not normalized or a.dtype.kind == "f":
        return a.astype(np.float64)
    top = float(np.iinfo(a.dtype).max)
    out = a.astype(np.float64) / top
    return np.maximum(out, -1.0) if a.dtype.kind == "i" else out


def strip_faces(indices: np.ndarray) -> np.ndarray:
    """A triangle strip's triangles with the glTF spec's winding: ``(i, i+1, i+2)`` for even ``i``,
    ``(i+1, i, i+2)`` for odd ``i`` (``indices``: (N,) int; returns (max(N-2, 0), 3) int64)."""
    idx = np.asarray(indices, np.int64).reshape(-1)
    i = np.arange(max(len(idx) - 2, 0))
    odd = (i % 2).astype(bool)
    first = np.where(odd, i + 1, i)
    second = np.where(odd, i, i + 1)
    return np.stack([idx[first], idx[second], idx[i + 2]], axis=1) if len(i) else np.zeros((0, 3), np.int64)


def fan_faces(indices: np.ndarray) -> np.ndarray:
    """A triangle fan's triangles as the glTF spec gives them: ``(i+1, i+2, 0)``
    (``indices``: (N,) int; returns (max(N-2, 0), 3) int64)."""
    idx = np.asarray(indices, np.int64).reshape(-1)
    i = np.arange(max(len(idx) - 2, 0))
    return np.stack([idx[i + 1], idx[i + 2], np.full(len(i), idx[0] if len(idx) else 0)], axis=1) \
        if len(i) else np.zeros((0, 3), np.int64)


def _buffers(path: str, js: dict) -> list:
    """The file's buffers as bytes, in order: a ``.glb``'s binary chunk, a data URI, or a file beside the
    ``.gltf`` (None for a GLB buffer the file lacks)."""
    out = []
    glb = None
    if path.lower().endswith(".glb"):
        with open(path, "rb") as fh:
            data = fh.read()
        pos = 12
        while pos + 8 <= len(data):
            length, kind = struct.unpack("<II", data[pos:pos + 8])
            if kind == 0x004E4942:  # "BIN"
                glb = data[pos + 8:pos + 8 + length]
            pos += 8 + length
    for buf in js.get("buffers", []) or []:
        uri = buf.get("uri") if isinstance(buf, dict) else None
        if uri is None:
            out.append(glb)
        elif uri.startswith("data:"):
            out.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            with open(os.path.join(os.path.dirname(os.path.abspath(path)), unquote(uri)), "rb") as fh:
                out.append(fh.read())
    return out


class _Reader:
    """The file's accessors as arrays, every error naming the file and the JSON path: the one accessor reader
    of the loader (geometry, tangents, UV sets, the index search)."""

    def __init__(self, path: str, js: dict, buffers: list | None = None):
        self.name, self.js = os.path.basename(path), js
        self.buffers = _buffers(path, js) if buffers is None else buffers

    def raw(self, index: int, where: str) -> tuple:
        """Accessor ``index`` as stored ((count, k) array) and its ``normalized`` flag."""
        try:
            acc = self.js["accessors"][index]
            dtype = np.dtype(COMPONENT_DTYPES[acc["componentType"]])
            k, count = _VECTORS[acc["type"]], int(acc["count"])
            out = (self._view(acc["bufferView"], acc.get("byteOffset", 0), count, k, dtype)
                   if "bufferView" in acc else np.zeros((count, k), dtype))
            sparse = acc.get("sparse")
            if sparse:
                out = out.copy()
                n = int(sparse["count"])
                ind, val = sparse["indices"], sparse["values"]
                rows = self._view(ind["bufferView"], ind.get("byteOffset", 0), n, 1,
                                  np.dtype(COMPONENT_DTYPES[ind["componentType"]]), packed=True).reshape(-1)
                out[rows.astype(np.int64)] = self._view(val["bufferView"], val.get("byteOffset", 0), n, k, dtype,
                                                        packed=True)
            return out, bool(acc.get("normalized", False))
        except (KeyError, IndexError, TypeError, ValueError) as exc:
            raise ValueError(f"{self.name}: {where} (accessors[{index}]): cannot be read ({type(exc).__name__}: "
                             f"{exc})") from None

    def floats(self, index: int, where: str) -> np.ndarray:
        values, normalized = self.raw(index, where)
        return dequantise(values, normalized)

    def _view(self, view_index, offset, count, k, dtype, packed=False):
        view = self.js["bufferViews"][view_index]
        data = self.buffers[view["buffer"]]
        if data is None:
            raise ValueError(f"buffer {view['buffer']} has no data")
        row = k * dtype.itemsize
        stride = row if packed else int(view.get("byteStride", row) or row)
        start = int(view.get("byteOffset", 0)) + int(offset)
        end = start + (count - 1) * stride + row if count else start
        if end > int(view.get("byteOffset", 0)) + int(view["byteLength"]) or end > len(data):
            raise ValueError(f"{count} items of {row} bytes (stride {stride}) run past bufferViews[{view_index}]")
        if not count:
            return np.zeros((0, k), dtype)
        raw = np.frombuffer(data, np.uint8, count=end - start, offset=start)
        rows = np.lib.stride_tricks.as_strided(raw, (count, row), (stride, 1))
        return np.ascontiguousarray(rows).view(dtype).reshape(count, k)


def _needs_rewrite(js: dict) -> bool:
    """Whether any primitive has what trimesh reads wrong (the common file: no, and trimesh reads it as is)."""
    accessors = js.get("accessors") or []
    for mesh in js.get("meshes") or []:
        for prim in mesh.get("primitives") or []:
            if prim.get("mode", 4) != 4 or prim.get("targets") or _DRACO in (prim.get("extensions") or {}):
                return True
            for key, a in (prim.get("attributes") or {}).items():
                if (key in _FLOATED or key.startswith("TEXCOORD_")) and isinstance(a, int) and a < len(accessors):
                    acc = accessors[a]
                    if acc.get("componentType") != 5126 or "sparse" in acc:
                        return True
    return False


def _draco_attributes(reader: _Reader, prim: dict, where: str) -> tuple:
    """A Draco primitive's attributes (name -> (N, k) array as stored) and faces ((F, 3) int64)."""
    try:
        import DracoPy
    except ImportError:
        raise ValueError(f"{reader.name}: {where} is Draco-compressed ({_DRACO}) and DracoPy is not installed: "
                         "pip install 'raycast_shade[draco]' (or DracoPy) to read it") from None
    ext = prim["extensions"][_DRACO]
    try:
        view = reader.js["bufferViews"][ext["bufferView"]]
        start = int(view.get("byteOffset", 0))
        blob = bytes(reader.buffers[view["buffer"]][start:start + int(view["byteLength"])])
        decoded = DracoPy.decode(blob)
        ids = {int(v): k for k, v in ext["attributes"].items()}
    except Exception as exc:  # DracoPy raises its own failure types
        raise ValueError(f"{reader.name}: {where}.extensions.{_DRACO}: cannot be decoded ({exc})") from None
    out = {}
    for attr in getattr(decoded, "attributes", []) or []:
        name = ids.get(int(attr["unique_id"]))
        if name is not None:
            data = np.asarray(attr["data"])
            out[name] = data.reshape(len(data), -1)
    if "POSITION" not in out:
        out["POSITION"] = np.asarray(decoded.points, np.float64).reshape(-1, 3)
    faces = getattr(decoded, "faces", None)
    faces = np.asarray(faces, np.int64).reshape(-1, 3) if faces is not None else np.zeros((0, 3), np.int64)
    return out, faces


def _draco_fallback(reader: _Reader, prim: dict) -> bool:
    """Whether a Draco primitive is read from its uncompressed fallback: DracoPy is missing, the file does
    not require the extension, and every attribute (and the indices) has a bufferView."""
    import importlib.util

    if importlib.util.find_spec("DracoPy") is not None or _DRACO in (reader.js.get("extensionsRequired") or []):
        return False
    refs = list((prim.get("attributes") or {}).values()) + ([prim["indices"]] if "indices" in prim else [])
    return all("bufferView" in reader.js["accessors"][a] for a in refs)


def _mesh_weights(js: dict, where_name: str) -> dict:
    """Per node drawing a mesh with morph targets, the weights it draws them at; meshes given several sets
    of weights copied (appended to ``js["meshes"]``, the node re-pointed)."""
    meshes = js.get("meshes") or []
    seen = {}  # (mesh, weights) -> mesh index drawing them
    weights_of = {}
    for n, node in enumerate(js.get("nodes") or []):
        m = node.get("mesh")
        if not isinstance(m, int) or m >= len(meshes):
            continue
        count = max((len(p.get("targets") or []) for p in meshes[m].get("primitives") or []), default=0)
        if not count:
            continue
        w = node.get("weights", meshes[m].get("weights", [0.0] * count))
        field = f"nodes[{n}].weights" if "weights" in node else f"meshes[{m}].weights"
        numbers = isinstance(w, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                              and np.isfinite(x) for x in w)
        if not numbers or len(w) != count:
            raise ValueError(f"{where_name}: {field}: expected {count} finite numbers (one per morph target), got {w!r}")
        key = (m, tuple(float(x) for x in w))
        if key not in seen:
            if m in weights_of:  # this mesh is drawn at other weights already: a copy of its own
                meshes.append(copy.deepcopy(meshes[m]))
                seen[key] = len(meshes) - 1
            else:
                seen[key] = m
            weights_of[seen[key]] = key[1]
        node["mesh"] = seen[key]
    for m, mesh in enumerate(meshes):
        if m not in weights_of:
            count = max((len(p.get("targets") or []) for p in mesh.get("primitives") or []), default=0)
            w = mesh.get("weights", [0.0] * count)
            weights_of[m] = tuple(float(x) for x in w) if isinstance(w, list) and len(w) == count else (0.0,) * count
    return weights_of


class _Writer:
    """New accessors in one binary blob appended after the file's buffers."""

    def __init__(self, js: dict, base: int):
        self.js, self.base, self.parts, self.size = js, base, [], 0

    def add(self, array: np.ndarray, *, indices: bool = False) -> int:
        a = np.ascontiguousarray(array, np.uint32 if indices else np.float32)
        a = a.reshape(-1, 1) if indices or a.ndim == 1 else a.reshape(len(a), a.shape[-1])
        data = a.tobytes()
        self.js["bufferViews"].append({"buffer": 0, "byteOffset": self.base + self.size, "byteLength": len(data)})
        self.parts.append(data + b"\0" * (-len(data) % 4))
        self.size += len(self.parts[-1])
        acc = {"bufferView": len(self.js["bufferViews"]) - 1, "componentType": 5125 if indices else 5126,
               "count": len(a), "type": "SCALAR" if indices else {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[
                   a.shape[1]]}
        if not indices and len(a):
            acc["min"], acc["max"] = a.min(axis=0).tolist(), a.max(axis=0).tolist()
        self.js["accessors"].append(acc)
        return len(self.js["accessors"]) - 1


def _morphed(reader, prim, weights, attrs: dict, where: str) -> None:
    """``attrs``' POSITION and NORMAL moved by the morph targets at ``weights`` (in place)."""
    for t, target in enumerate(prim.get("targets") or []):
        w = weights[t] if t < len(weights) else 0.0
        if w == 0.0:
            continue
        for key in ("POSITION", "NORMAL"):
            if key in target and key in attrs:
                delta = reader.floats(target[key], f"{where}.targets[{t}].{key}")
                if delta.shape != attrs[key].shape:
                    raise ValueError(f"{reader.name}: {where}.targets[{t}].{key}: {len(delta)} values for "
                                     f"{len(attrs[key])} vertices")
                attrs[key] = attrs[key] + w * delta
    if "NORMAL" in attrs and any(weights):
        n = attrs["NORMAL"]
        length = np.linalg.norm(n, axis=1, keepdims=True)
        attrs["NORMAL"] = np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def _triangles(reader, prim, count: int, where: str, faces=None) -> np.ndarray:
    """The primitive's triangles as (F, 3) int64 (strips and fans converted; repeated-index ones dropped)."""
    mode = prim.get("mode", 4)
    if faces is None:
        if "indices" in prim:
            idx = reader.raw(prim["indices"], f"{where}.indices")[0].reshape(-1).astype(np.int64)
        else:
            idx = np.arange(count, dtype=np.int64)
        if mode == 4:
            faces = idx[:len(idx) - len(idx) % 3].reshape(-1, 3)
        else:
            faces = strip_faces(idx) if mode == 5 else fan_faces(idx)
            faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    if len(faces) and (faces.min() < 0 or faces.max() >= count):
        bad = int(faces[(faces < 0) | (faces >= count)][0])
        raise ValueError(f"{reader.name}: {where}.indices: vertex {bad}, but the primitive's POSITION has {count} "
                         "vertices")
    return faces


def _rewrite_primitive(reader, writer, prim: dict, weights, where: str) -> None:
    """One triangle primitive made plain in place: float attributes, explicit TRIANGLES."""
    attrs = prim.get("attributes") or {}
    if "POSITION" not in attrs:
        raise ValueError(f"{reader.name}: {where}.attributes: no POSITION")
    faces, new = None, {}
    if _DRACO in (prim.get("extensions") or {}) and _draco_fallback(reader, prim):
        prim["extensions"] = {k: v for k, v in prim["extensions"].items() if k != _DRACO}
    if _DRACO in (prim.get("extensions") or {}):
        decoded, faces = _draco_attributes(reader, prim, where)
        accessors = reader.js["accessors"]
        for key, data in decoded.items():
            if key in attrs:
                new[key] = dequantise(data, bool(accessors[attrs[key]].get("normalized", False)))
        prim["extensions"] = {k: v for k, v in prim["extensions"].items() if k != _DRACO}
        empty = [k for k, a in attrs.items() if k not in new and "bufferView" not in accessors[a]
                 and "sparse" not in accessors[a]]
        if empty:  # trimesh would read zeros there
            raise ValueError(f"{reader.name}: {where}.attributes.{empty[0]}: no data (neither a bufferView nor "
                             f"in the {_DRACO} buffer)")
    for key, a in attrs.items():
        floated = key in _FLOATED or key.startswith("TEXCOORD_")
        if key not in new and floated:
            acc = reader.js["accessors"][a]
            if acc.get("componentType") != 5126 or "sparse" in acc:
                new[key] = reader.floats(a, f"{where}.attributes.{key}")
    if prim.get("targets"):
        for key in ("POSITION", "NORMAL"):
            if key in attrs and key not in new:
                new[key] = reader.floats(attrs[key], f"{where}.attributes.{key}")
        _morphed(reader, prim, weights, new, where)
        prim.pop("targets")
    count = len(new["POSITION"]) if "POSITION" in new else int(reader.js["accessors"][attrs["POSITION"]]["count"])
    for key, data in new.items():
        attrs[key] = writer.add(data)
    if prim.get("mode", 4) != 4 or faces is not None:
        prim["indices"] = writer.add(_triangles(reader, prim, count, where, faces), indices=True)
        prim["mode"] = 4


def plain_gltf(path: str, js: dict):
    """The file made plain for trimesh, or None when trimesh reads it right as it is.

    Parameters
    ----------
    path : str
    js : dict
        The file's JSON (as :func:`~raycast_shade.scene.filecheck.check_mesh_file` returns it).

    Returns
    -------
    (dict, bytes) or None
        The JSON rewritten (see the module's text) and its one buffer: every buffer of the file, then the
        new accessors (:func:`glb_bytes` makes them a GLB).

    Raises
    ------
    ValueError
        Naming the file and the JSON path: a primitive that cannot be read, a Draco primitive without
        DracoPy, morph weights of the wrong length, or no triangles at all (naming the modes found).

    Warns
    -----
    DroppedOnLoadWarning
        Naming each points or lines primitive skipped beside triangles.
    """
    name = os.path.basename(path)
    if not _needs_rewrite(js):
        return None
    js = copy.deepcopy(js)
    reader = _Reader(path, js)
    blobs, offsets, size = [], [], 0
    for data in reader.buffers:
        data = data or b""
        offsets.append(size)
        blobs.append(data + b"\0" * (-len(data) % 4))
        size += len(blobs[-1])
    weights_of = _mesh_weights(js, name)
    js.setdefault("accessors", [])
    js.setdefault("bufferViews", [])
    writer = _Writer(js, size)
    skipped, drawn = [], 0
    for m, mesh in enumerate(js.get("meshes") or []):
        kept = []
        for p, prim in enumerate(mesh.get("primitives") or []):
            where = f"meshes[{m}].primitives[{p}]"
            mode = prim.get("mode", 4)
            if mode not in _TRIANGLE_MODES:
                skipped.append(f"{where}: mode {mode} ({MODE_NAMES.get(mode, 'unknown')})")
                continue
            _rewrite_primitive(reader, writer, prim, weights_of.get(m, ()), where)
            kept.append(prim)
            drawn += 1
        mesh["primitives"] = kept
    if not drawn:
        raise ValueError(f"{name}: {'; '.join(skipped) or 'no primitives'}: holds no triangles (points and lines "
                         "are not drawn)")
    if skipped:
        warnings.warn(f"{name}: skipped {'; '.join(skipped)} (points and lines are not drawn; the triangles are)",
                      DroppedOnLoadWarning, stacklevel=4)
    for view in js["bufferViews"][:len(js["bufferViews"]) - len(writer.parts)]:
        view["byteOffset"] = offsets[view["buffer"]] + int(view.get("byteOffset", 0))
        view["buffer"] = 0
    for key in ("extensionsUsed", "extensionsRequired"):  # what is left for trimesh is plain glTF
        if key in js:
            js[key] = [e for e in js[key] if e not in (_DRACO, "KHR_mesh_quantization")]
    binary = b"".join(blobs + writer.parts)
    js["buffers"] = [{"byteLength": len(binary)}]
    return js, binary


def glb_bytes(js: dict, binary: bytes) -> bytes:
    """A GLB of ``js`` whose one buffer is ``binary``."""
    text = json.dumps(js, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<II", len(text), 0x4E4F534A) + text
            + struct.pack("<II", len(binary), 0x004E4942) + binary)


def warn_unapplied_extensions(js: dict, name: str) -> None:
    """One :class:`DroppedOnLoadWarning` naming every extension the file uses that is not applied."""
    used = js.get("extensionsUsed") or []
    if not isinstance(used, list):
        raise ValueError(f"{name}: extensionsUsed: expected a list of extension names, got {used!r}")
    missed = [f"{e} ({GLTF_EXTENSIONS[e][1] if e in GLTF_EXTENSIONS else 'not known here'})"
              for e in dict.fromkeys(used) if e not in APPLIED_GLTF_EXTENSIONS]
    if missed:
        warnings.warn(f"{name}: glTF extension(s) not applied: {'; '.join(missed)}", DroppedOnLoadWarning,
                      stacklevel=4)


def _for_trimesh(js: dict):
    """A copy of ``js`` without ``KHR_materials_pbrSpecularGlossiness``, or None when no material has it.

    trimesh converts that extension to metallic-roughness texel by texel (seconds for 2048 x 2048
    maps), and :mod:`.specgloss` then reads the extension from the file itself and discards the
    result. Each such material keeps its name and, where its ``pbrMetallicRoughness`` has no
    ``baseColorTexture``, gets its diffuse texture there (an image trimesh merely opens, as its
    conversion's result had one), so the loader matches trimesh's material to the file's as before
    (by name, then by whether it is textured).
    """
    mats = js.get("materials")
    if not isinstance(mats, list) or not any(isinstance(m, dict) and _SPEC_GLOSS in (m.get("extensions") or {})
                                             for m in mats):
        return None
    out = dict(js)
    out["materials"] = []
    for m in mats:
        ext = (m.get("extensions") or {}) if isinstance(m, dict) else {}
        if not isinstance(ext, dict) or _SPEC_GLOSS not in ext:
            out["materials"].append(m)
            continue
        m = dict(m, extensions={k: v for k, v in ext.items() if k != _SPEC_GLOSS})
        diffuse = ext[_SPEC_GLOSS].get("diffuseTexture") if isinstance(ext[_SPEC_GLOSS], dict) else None
        core = m.get("pbrMetallicRoughness") if isinstance(m.get("pbrMetallicRoughness"), dict) else {}
        if "baseColorTexture" not in core and isinstance(diffuse, dict):  # as trimesh's conversion gave it
            m["pbrMetallicRoughness"] = dict(core, baseColorTexture=diffuse)
        out["materials"].append(m)
    for key in ("extensionsUsed", "extensionsRequired"):
        if isinstance(out.get(key), list):
            out[key] = [e for e in out[key] if e != _SPEC_GLOSS]
    return out


def _glb_with_json(path: str, js: dict) -> bytes:
    """The GLB file at ``path`` with its JSON chunk replaced by ``js`` (its binary chunk kept)."""
    with open(path, "rb") as fh:
        data = fh.read()
    chunks, pos = [], 12
    while pos + 8 <= len(data):
        length, kind = struct.unpack("<II", data[pos:pos + 8])
        if kind != 0x4E4F534A:  # every chunk but the JSON, as it is
            chunks.append(data[pos:pos + 8 + length])
        pos += 8 + length
    text = json.dumps(js, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    rest = b"".join(chunks)
    return (struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + len(rest))
            + struct.pack("<II", len(text), 0x4E4F534A) + text + rest)


def load_gltf_trimesh(path: str, js: dict):
    """trimesh's scene of a glTF file, with what it reads wrong made plain first (:func:`plain_gltf`) and the
    ``KHR_materials_pbrSpecularGlossiness`` it would convert in vain left out of the JSON it reads."""
    import trimesh

    warn_unapplied_extensions(js, os.path.basename(path))
    plain = plain_gltf(path, js)
    light = _for_trimesh(plain[0] if plain is not None else js)
    resolver = trimesh.resolvers.FilePathResolver(os.path.abspath(path))
    if plain is not None:
        tm = trimesh.load(io.BytesIO(glb_bytes(light or plain[0], plain[1])), file_type="glb", resolver=resolver,
                          process=False)
        tm.metadata[PLAIN_KEY] = plain  # what trimesh read: the loader's TANGENT reader reads the same
    elif light is None:
        tm = trimesh.load(path, process=False)
    elif path.lower().endswith(".glb"):
        tm = trimesh.load(io.BytesIO(_glb_with_json(path, light)), file_type="glb", resolver=resolver, process=False)
    else:
        tm = trimesh.load(io.BytesIO(json.dumps(light).encode("utf-8")), file_type="gltf", resolver=resolver,
                          process=False)
    return tm
