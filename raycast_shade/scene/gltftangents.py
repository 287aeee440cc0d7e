"""glTF ``TANGENT`` attributes and UV sets after the first, which trimesh's reader passes over, read
from the file itself.

Only what a tangent needs: float ``VEC4`` accessors (the spec allows no other
type for ``TANGENT``), read by the loader's one accessor reader
(:mod:`.gltfgeometry`'s), without sparse rows.
"""

from __future__ import annotations

import numpy as np

from .gltfgeometry import _Reader

__all__ = ["primitive_tangents", "primitive_uvs"]

_TRIANGLES = (4, 5)  # GL_TRIANGLES, GL_TRIANGLE_STRIP: the primitives trimesh turns into meshes, in order


def _floats(reader: _Reader, index: int, kind: str, where: str):
    """Float accessor ``index`` of type ``kind`` as (count, n) float64, or None when it is not one
    (the spec allows only float ``VEC3`` positions and ``VEC4`` tangents)."""
    acc = reader.js["accessors"][index]
    if acc.get("componentType") != 5126 or acc.get("type") != kind or "sparse" in acc or "bufferView" not in acc:
        return None
    return reader.floats(index, where)


def primitive_tangents(path: str, js: dict, buffers: list | None = None) -> list:
    """Per triangle primitive of the file, in trimesh's order of meshes: ``(positions (V, 3), tangents
    (V, 4))`` as float64, or ``None`` where the primitive has no (readable) ``TANGENT``. ``buffers``:
    the file's buffers already read (a file made plain in memory), else read from ``path``."""
    out, reader = [], None
    for mesh in js.get("meshes", []) or []:
        for prim in mesh.get("primitives", []) or []:
            if prim.get("mode", 4) not in _TRIANGLES:
                continue
            attr = prim.get("attributes") or {}
            if "TANGENT" not in attr or "POSITION" not in attr:
                out.append(None)
                continue
            try:
                reader = _Reader(path, js, buffers) if reader is None else reader
                pos = _floats(reader, attr["POSITION"], "VEC3", "POSITION")
                tan = _floats(reader, attr["TANGENT"], "VEC4", "TANGENT")
            except (OSError, KeyError, IndexError, TypeError, ValueError):
                pos = tan = None
            out.append(None if pos is None or tan is None or len(pos) != len(tan) else (pos, tan))
    return out


def primitive_uvs(path: str, js: dict, uv_set: int, buffers: list | None = None) -> list:
    """Per triangle primitive of the file, in trimesh's order of meshes: ``(positions (V, 3), uvs (V, 2))``
    as float64, the UVs ``TEXCOORD_<uv_set>`` with v flipped as trimesh flips ``TEXCOORD_0`` (v up), or
    ``None`` where the primitive has no (readable) such set. ``buffers`` as :func:`primitive_tangents`'."""
    out, reader, key = [], None, f"TEXCOORD_{int(uv_set)}"
    for mesh in js.get("meshes", []) or []:
        for prim in mesh.get("primitives", []) or []:
            if prim.get("mode", 4) not in _TRIANGLES:
                continue
            attr = prim.get("attributes") or {}
            if key not in attr or "POSITION" not in attr:
                out.append(None)
                continue
            try:
                reader = _Reader(path, js, buffers) if reader is None else reader
                pos = _floats(reader, attr["POSITION"], "VEC3", "POSITION")
                uv = reader.floats(attr[key], key) if js["accessors"][attr[key]].get("type") == "VEC2" else None
            except (OSError, KeyError, IndexError, TypeError, ValueError):
                pos = uv = None
            if pos is None or uv is None or len(pos) != len(uv):
                out.append(None)
            else:
                out.append((pos, np.c_[uv[:, 0], 1.0 - uv[:, 1]]))
    return out
