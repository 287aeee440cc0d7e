"""glTF maps reading TEXCOORD_1, spec-gloss materials kept from trimesh's conversion, OBJ trailing comments.

Every file here is written by its test.
"""

from __future__ import annotations

import base64
import io
import json
import warnings

import numpy as np
import pytest
from PIL import Image

import raycast_shade as rs
from raycast_shade.scene import gltfgeometry

W = 48  # the renders: W x W pixels over the unit quad, orthographic

# A unit quad at z = 0; glTF's v runs down the image.
_POS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
_UV_PLAIN = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
_UV_TURNED = np.array([[1, 1], [1, 0], [0, 0], [0, 1]], np.float32)  # the image turned a quarter


def _png(rgb) -> str:
    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def _quad(path, material, uv_sets, image):
    """A .gltf quad whose primitive has the given UV sets (TEXCOORD_0, TEXCOORD_1, ...), one material and
    ``image`` as textures 0 and 1."""
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    parts = [_POS.tobytes(), *(uv.tobytes() for uv in uv_sets), idx.tobytes()]
    views, at = [], 0
    for p in parts:
        views.append({"buffer": 0, "byteOffset": at, "byteLength": len(p)})
        at += len(p)
    blob = b"".join(parts)
    accessors = [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0],
                  "max": [1, 1, 0]}]
    accessors += [{"bufferView": 1 + k, "componentType": 5126, "count": 4, "type": "VEC2"} for k in range(len(uv_sets))]
    accessors.append({"bufferView": len(parts) - 1, "componentType": 5123, "count": 6, "type": "SCALAR"})
    attributes = {"POSITION": 0, **{f"TEXCOORD_{k}": 1 + k for k in range(len(uv_sets))}}
    js = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
          "meshes": [{"primitives": [{"attributes": attributes, "indices": len(accessors) - 1, "material": 0}]}],
          "materials": [material], "textures": [{"source": 0}, {"source": 0}], "images": [{"uri": _png(image)}],
          "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                       "byteLength": len(blob)}],
          "bufferViews": views, "accessors": accessors}
    if "KHR_" in json.dumps(material):
        js["extensionsUsed"] = sorted({k for k in ("KHR_texture_transform", "KHR_materials_pbrSpecularGlossiness")
                                       if k in json.dumps(material)})
    path.write_text(json.dumps(js))
    return path


def _image(seed=0):
    return np.random.default_rng(seed).integers(0, 256, (4, 4, 3), dtype=np.uint8)


def _base(info, **extra):
    return dict({"name": "quad", "pbrMetallicRoughness": {"baseColorTexture": info, "metallicFactor": 0.0}}, **extra)


def _render(path, strict=True):
    with warnings.catch_warnings():
        if strict:
            warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(path)
    scene = rs.Scene([model], lights=[rs.DirectionalLight((0, 0, -1), intensity=1.0)], ambient=0.2,
                     camera=rs.Camera(eye=(0.5, 0.5, 3), target=(0.5, 0.5, 0), up=(0, 1, 0),
                                      projection="orthographic", ortho_height=1.0, width=W, height=W))
    return rs.render(scene, shading="phong").image, model


# -- texCoord: the UV set a map reads ----------------------------------------------------------------------

@pytest.mark.parametrize("info", [{"index": 0, "texCoord": 1},  # the textureInfo's own texCoord
                                  {"index": 0, "extensions": {"KHR_texture_transform": {"texCoord": 1}}}])
def test_a_map_reading_texcoord_1_is_drawn_with_that_set(tmp_path, info):
    """The render equals the one of the same file whose TEXCOORD_0 holds the second set's values, and
    differs from the first set's (the sets turn the image a quarter apart)."""
    img = _image(1)
    got, model = _render(_quad(tmp_path / "two.gltf", _base(info), [_UV_PLAIN, _UV_TURNED], img))
    want, _ = _render(_quad(tmp_path / "ref.gltf", _base({"index": 0}), [_UV_TURNED], img))
    first, _ = _render(_quad(tmp_path / "first.gltf", _base({"index": 0}), [_UV_PLAIN], img))
    np.testing.assert_array_equal(got, want)
    assert np.abs(got - first).max() > 0.1
    np.testing.assert_allclose(model.mesh.uvs, np.c_[_UV_TURNED[:, 0], 1 - _UV_TURNED[:, 1]])


def test_texcoord_1_that_the_primitive_lacks_is_warned_naming_the_map_and_the_file(tmp_path):
    path = _quad(tmp_path / "one.gltf", _base({"index": 0, "texCoord": 1}), [_UV_PLAIN], _image())
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"one.gltf.*baseColorTexture: texCoord 1 \(the primitive has no "
                                                     r"readable TEXCOORD_1.*TEXCOORD_0 used"):
        (model,) = rs.load_models(path)
    np.testing.assert_allclose(model.mesh.uvs, np.c_[_UV_PLAIN[:, 0], 1 - _UV_PLAIN[:, 1]])


def test_maps_of_one_material_reading_different_sets_are_named(tmp_path):
    mat = _base({"index": 0}, emissiveTexture={"index": 1, "texCoord": 1}, emissiveFactor=[1, 1, 1])
    path = _quad(tmp_path / "mixed.gltf", mat, [_UV_PLAIN, _UV_TURNED], _image())
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"mixed.gltf: materials\[0\]: emissiveTexture \(TEXCOORD_1\) read "
                                                     r"another UV set than baseColorTexture \(TEXCOORD_0\)"):
        (model,) = rs.load_models(path)
    np.testing.assert_allclose(model.mesh.uvs, np.c_[_UV_PLAIN[:, 0], 1 - _UV_PLAIN[:, 1]])


def test_a_normal_map_alone_on_texcoord_1_reads_that_set(tmp_path):
    """Every map of the material (here only the normal map) on set 1: the mesh's UVs are set 1."""
    flat = np.full((4, 4, 3), (128, 128, 255), np.uint8)
    mat = {"name": "n", "pbrMetallicRoughness": {"metallicFactor": 0.0}, "normalTexture": {"index": 0, "texCoord": 1}}
    path = _quad(tmp_path / "n.gltf", mat, [_UV_PLAIN, _UV_TURNED], flat)
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(path)
    assert model.material.normal_map is not None
    np.testing.assert_allclose(model.mesh.uvs, np.c_[_UV_TURNED[:, 0], 1 - _UV_TURNED[:, 1]])


# -- KHR_materials_pbrSpecularGlossiness: trimesh's own conversion skipped --------------------------------------

def _spec_gloss(named=True):
    ext = {"diffuseTexture": {"index": 0}, "diffuseFactor": [0.9, 0.8, 0.7, 1.0], "specularFactor": [0.2, 0.3, 0.4],
           "glossinessFactor": 0.4}
    mat = {"extensions": {"KHR_materials_pbrSpecularGlossiness": ext}}
    return dict(mat, name="sg") if named else mat


@pytest.mark.parametrize("named", [True, False])
def test_trimesh_is_handed_no_spec_gloss_and_the_material_is_the_same(tmp_path, monkeypatch, named):
    """The JSON trimesh reads holds no KHR_materials_pbrSpecularGlossiness (its per-texel conversion, which the
    loader discards, is skipped), and the loaded material is the one loaded with trimesh converting it."""
    import trimesh

    path = _quad(tmp_path / "sg.gltf", _spec_gloss(named), [_UV_PLAIN], _image(4))
    handed = []
    real = trimesh.load

    def spy(obj, *args, **kwargs):
        handed.append(obj.getvalue() if isinstance(obj, io.BytesIO) else open(obj, "rb").read())
        return real(obj, *args, **kwargs)

    monkeypatch.setattr(trimesh, "load", spy)
    (fast,) = rs.load_models(path)
    assert handed and b"KHR_materials_pbrSpecularGlossiness" not in handed[-1]
    monkeypatch.setattr(gltfgeometry, "_for_trimesh", lambda js: None)  # trimesh converts, as before
    (slow,) = rs.load_models(path)
    assert b"KHR_materials_pbrSpecularGlossiness" in handed[-1]
    a, b = fast.material, slow.material
    for field in ("kd", "ka", "ks", "shininess"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    np.testing.assert_array_equal(a.kd_map.texels, b.kd_map.texels)
    np.testing.assert_allclose(a.kd, [0.9, 0.8, 0.7])


def test_a_glb_with_spec_gloss_keeps_its_binary_chunk(tmp_path):
    """A GLB's JSON is rewritten for trimesh, its binary chunk (the geometry) kept: the same mesh."""
    src = _quad(tmp_path / "sg.gltf", _spec_gloss(), [_UV_PLAIN], _image(5))
    js = json.loads(src.read_text())
    blob = base64.b64decode(js["buffers"][0]["uri"].split(",", 1)[1])
    js["buffers"] = [{"byteLength": len(blob)}]
    pad = blob + b"\0" * (-len(blob) % 4)
    (tmp_path / "sg.glb").write_bytes(gltfgeometry.glb_bytes(js, pad))
    (a,), (b,) = rs.load_models(src), rs.load_models(tmp_path / "sg.glb")
    np.testing.assert_array_equal(a.mesh.vertices, b.mesh.vertices)
    np.testing.assert_array_equal(a.mesh.uvs, b.mesh.uvs)
    np.testing.assert_array_equal(a.material.kd_map.texels, b.material.kd_map.texels)


# -- OBJ: a comment after a statement ----------------------------------------------------------------------

def test_an_obj_comment_after_a_face_or_vertex_is_a_comment(tmp_path):
    """The OBJ spec lets a comment follow a statement; the faces read are those written before it."""
    path = tmp_path / "c.obj"
    path.write_text("v 0 0 0 # origin\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 # x\nf 2 4 3\t#tab\nf 1 2 4#tight\n")
    (model,) = rs.load_models(path)
    np.testing.assert_array_equal(model.mesh.faces, [[0, 1, 2], [1, 3, 2], [0, 1, 3]])
    np.testing.assert_array_equal(model.mesh.vertices[0], [0, 0, 0])
    (mesh,) = [rs.Mesh.load(path)]
    assert len(mesh.faces) == 3


def test_an_obj_face_index_out_of_range_before_a_comment_is_refused_with_its_line(tmp_path):
    path = tmp_path / "bad.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # fine\nf 1 2 9 # not\n")
    with pytest.raises(ValueError, match=r"bad.obj:5: .*vertex index 9, but the file has 3"):
        rs.load_models(path)
