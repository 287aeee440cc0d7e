"""glTF ``TANGENT`` attributes, which trimesh's reader passes over, read from the file itself.

Only what a tangent needs: float ``VEC4`` accessors (the spec allows no other
type for ``TANGENT``) in a ``.glb``'s binary chunk, a data URI or a ``.bin``
file beside the ``.gltf``; strided and sparse-free views.
"""

from __future__ import annotations

import base64
import os
import struct
from urllib.parse import unquote

import numpy as np

__all__ = ["primitive_tangents"]

_TRIANGLES = (4, 5)  # GL_TRIANGLES, GL_TRIANGLE_STRIP: the primitives trimesh turns into meshes, in order
_COUNT = {"VEC3": 3, "VEC4": 4}


def _buffers(path: str, js: dict) -> list:
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


def _accessor(js: dict, buffers: list, index: int, kind: str):
    """Float accessor ``index`` of type ``kind`` as (count, n) float64, or None when it is not one."""
    acc = js["accessors"][index]
    if acc.get("componentType") != 5126 or acc.get("type") != kind or "sparse" in acc or "bufferView" not in acc:
        return None
    view = js["bufferViews"][acc["bufferView"]]
    data = buffers[view["buffer"]]
    if data is None:
        return None
    n = _COUNT[kind]
    count = int(acc["count"])
    start = int(view.get("byteOffset", 0)) + int(acc.get("byteOffset", 0))
    stride = int(view.get("byteStride", 4 * n) or 4 * n)
    raw = np.frombuffer(data, np.uint8, count=(count - 1) * stride + 4 * n, offset=start) if count else np.zeros(0)
    rows = np.lib.stride_tricks.as_strided(raw, (count, 4 * n), (stride, 1)) if count else np.zeros((0, 4 * n))
    return np.ascontiguousarray(rows).view("<f4").reshape(count, n).astype(np.float64)


def primitive_tangents(path: str, js: dict, buffers: list | None = None) -> list:
    """Per triangle primitive of the file, in trimesh's order of meshes: ``(positions (V, 3), tangents
    (V, 4))`` as float64, or ``None`` where the primitive has no (readable) ``TANGENT``. ``buffers``:
    the file's buffers already read (a file made plain in memory), else read from ``path``."""
    out = []
    for mesh in js.get("meshes", []) or []:
        for prim in mesh.get("primitives", []) or []:
            if prim.get("mode", 4) not in _TRIANGLES:
                continue
            attr = prim.get("attributes") or {}
            if "TANGENT" not in attr or "POSITION" not in attr:
                out.append(None)
                continue
            try:
                buffers = _buffers(path, js) if buffers is None else buffers
                pos = _accessor(js, buffers, attr["POSITION"], "VEC3")
                tan = _accessor(js, buffers, attr["TANGENT"], "VEC4")
            except (OSError, KeyError, IndexError, TypeError, ValueError):
                pos = tan = None
            out.append(None if pos is None or tan is None or len(pos) != len(tan) else (pos, tan))
    return out
