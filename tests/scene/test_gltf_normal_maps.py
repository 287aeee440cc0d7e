"""glTF normalTexture (+ scale, sampler) and TANGENT: loaded and mapped, on small files written here."""

from __future__ import annotations

import base64
import io
import json
import warnings

import numpy as np
import pytest
from PIL import Image

import raycast_shade as rs
from tests.conftest import down_camera

TEXEL = (204, 140, 230)  # a normal tilted towards +T and a little towards +B


def _quad(path, tangents=None, scale=None, sampler=(10497, 10497)):
    """A unit quad in z = 0 (normal +z, glTF UVs u along +x, v along +y) with a constant normal map."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    nrm = np.tile(np.float32([0, 0, 1]), (4, 1))
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    parts = [pos, nrm, uv] + ([np.asarray(tangents, np.float32)] if tangents is not None else []) + [idx]
    blob, views, offset = b"", [], 0
    for a in parts:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": a.nbytes})
        blob += a.tobytes()
        offset += a.nbytes
    accessors = [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0],
                  "max": [1, 1, 0]},
                 {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                 {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}]
    attributes = {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}
    if tangents is not None:
        accessors.append({"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC4"})
        attributes["TANGENT"] = 3
    accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": 6, "type": "SCALAR"})
    buf = io.BytesIO()
    Image.fromarray(np.full((4, 4, 3), TEXEL, np.uint8)).save(buf, format="PNG")
    normal = {"index": 0} if scale is None else {"index": 0, "scale": scale}
    js = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": len(accessors) - 1, "material": 0}]}],
        "materials": [{"name": "m", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                                                             "metallicFactor": 0.0, "roughnessFactor": 1.0},
                       "normalTexture": normal}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": sampler[0], "wrapT": sampler[1]}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()}],
        "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                     "byteLength": len(blob)}],
        "bufferViews": views, "accessors": accessors,
    }
    path.write_text(json.dumps(js))


def _render_normals(model):
    cam = down_camera(eye=(0.5, 0.5, 2.0), target=(0.5, 0.5, 0.0), width=41, height=41)
    scene = rs.Scene([model], lights=[rs.DirectionalLight((0.0, 0.0, -1.0))], camera=cam, ambient=0.0)
    frame = rs.render(scene, "phong")
    assert frame.mask.sum() > 500
    return frame.normal[frame.mask]


def _expected(t, b, scale=1.0):
    r, g, bl = (np.float64(np.float32(c / 255.0)) for c in TEXEL)
    a = np.array(t) * (2 * r - 1) * scale + np.array(b) * (2 * g - 1) * scale + np.array([0, 0, 1.0]) * (2 * bl - 1)
    return a / np.linalg.norm(a)


def test_normal_texture_and_tangent_are_loaded_and_mapped(tmp_path):
    """TANGENT along +y with w = -1: B = -(z x y) = +x; the file's frame is used as written."""
    tangents = np.tile([0.0, 1.0, 0.0, -1.0], (4, 1))
    _quad(tmp_path / "n.gltf", tangents=tangents, scale=0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "n.gltf")
    mat = model.material
    assert mat.normal_scale == 0.5
    np.testing.assert_allclose(mat.normal_map.texels, np.broadcast_to(np.float32(TEXEL) / 255, (4, 4, 3)),
                               atol=1e-7)  # linear: not sRGB-decoded
    np.testing.assert_array_equal(model.mesh.tangents, tangents)
    n = _render_normals(model)
    np.testing.assert_allclose(n, np.broadcast_to(_expected((0, 1, 0), (1, 0, 0), 0.5), n.shape), atol=2e-7)


def test_without_tangent_the_frame_follows_the_uvs(tmp_path):
    """No TANGENT: computed from the UVs. u runs along +x; glTF's v runs along +y, so the image's
    "up" (green, decreasing v) is -y in the world."""
    _quad(tmp_path / "n.gltf")
    (model,) = rs.load_models(tmp_path / "n.gltf")
    assert model.mesh.tangents is None and model.material.normal_scale == 1.0
    n = _render_normals(model)
    np.testing.assert_allclose(n, np.broadcast_to(_expected((1, 0, 0), (0, -1, 0)), n.shape), atol=2e-7)


def test_normal_texture_sampler_is_honoured(tmp_path):
    _quad(tmp_path / "n.gltf", sampler=(33071, 33071))
    (model,) = rs.load_models(tmp_path / "n.gltf")
    assert model.material.normal_map.wrap == "clamp"


def test_bad_normal_scale_names_the_field(tmp_path):
    _quad(tmp_path / "n.gltf", scale="big")
    with pytest.raises(ValueError, match="normalTexture.scale"):
        rs.load_models(tmp_path / "n.gltf")


def test_inspect_shows_the_normal_map_as_mapped(tmp_path):
    from raycast_shade.apps.inspect import format_report, inspect_file

    _quad(tmp_path / "n.gltf", tangents=np.tile([1.0, 0.0, 0.0, 1.0], (4, 1)), scale=0.5)
    report = inspect_file(tmp_path / "n.gltf")
    (model,) = report["models"]
    assert model["tangents"] == "file"
    assert ("normalTexture", "texture 0") == model["fields"][-1][:2] and model["fields"][-1][2] == "mapped"
    assert any(m[0] == "normal_map" for m in model["maps"])
    text = format_report(report)
    assert "tangents file" in text and "mapped       normalTexture" in text
    _quad(tmp_path / "c.gltf")
    assert inspect_file(tmp_path / "c.gltf")["models"][0]["tangents"] == "from UVs"


def test_placing_a_mesh_moves_its_tangents(tmp_path):
    """A scene file's rotate turns the file's tangents with the mesh (w kept: a rotation keeps handedness)."""
    from raycast_shade.scene.scenefile import _placed

    tangents = np.tile([1.0, 0.0, 0.0, -1.0], (4, 1))
    _quad(tmp_path / "n.gltf", tangents=tangents)
    (model,) = rs.load_models(tmp_path / "n.gltf")
    moved = _placed(model.mesh, {"rotate": [0.0, 0.0, 90.0], "scale": 2.0}, "object[0]")
    np.testing.assert_allclose(moved.tangents, np.tile([0.0, 1.0, 0.0, -1.0], (4, 1)), atol=1e-12)
