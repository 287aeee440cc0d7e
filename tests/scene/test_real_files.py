"""Real files look as their authors meant: each silent defect class of issue 22 rebuilt in a small file.

Every test writes its own file; PIL, trimesh and NumPy are the oracles.
"""

from __future__ import annotations

import io
import json
import warnings
import zipfile

import numpy as np
import pytest
import trimesh
from PIL import Image

import raycast_shade as rs
from raycast_shade.scene.normals import reversed_duplicates
from raycast_shade.scene.texture import Texture, srgb_to_linear

QUAD_OBJ = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"


def _messages(record) -> str:
    return " | ".join(str(w.message) for w in record)


# -- textures ------------------------------------------------------------------------------------

@pytest.mark.parametrize("mode", ["P", "L", "LA", "I;16", "I", "1", "RGBA", "CMYK", "PA"])
def test_pil_images_are_decoded_by_mode_as_pil_converts_them(mode):
    rng = np.random.default_rng(1)
    rgb = Image.fromarray(rng.integers(0, 256, (5, 7, 3), dtype=np.uint8))
    if mode == "I;16":
        img = Image.fromarray(rng.integers(0, 65536, (5, 7), dtype=np.uint16))
    elif mode == "I":
        img = Image.fromarray(rng.integers(0, 65536, (5, 7), dtype=np.uint16)).convert("I")
    elif mode == "PA":
        img = rgb.convert("P").convert("PA")
    else:
        img = rgb.convert(mode)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.DroppedOnLoadWarning)
        tex = Texture.from_array(img)
    if mode in ("I;16", "I"):
        expect = np.repeat((np.asarray(img, np.float64) / 65535)[..., None], 3, axis=2)
    else:
        expect = np.asarray(img.convert("RGB"), np.float64) / 255
    np.testing.assert_allclose(tex.texels, srgb_to_linear(expect[::-1]), atol=1e-6)


def test_a_palette_png_in_a_glb_shows_its_colours_not_its_indices(tmp_path):
    """The Duck's defect: trimesh hands the image in mode "P"; the texels must be the palette's colours."""
    yellow = np.zeros((8, 8, 3), np.uint8)
    yellow[...] = (250, 200, 20)
    yellow[:4, :4] = (30, 60, 200)
    pal = Image.fromarray(yellow).convert("P", palette=Image.Palette.ADAPTIVE, colors=4)
    assert pal.mode == "P"
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=np.random.default_rng(0).random((8, 2)),
                                               material=trimesh.visual.material.PBRMaterial(
                                                   baseColorTexture=pal, metallicFactor=0.0))
    box.export(tmp_path / "duck.glb")
    (model,) = rs.load_models(tmp_path / "duck.glb")
    np.testing.assert_allclose(model.material.kd_map.texels,
                               srgb_to_linear(np.asarray(pal.convert("RGB"))[::-1] / 255), atol=1e-6)
    assert model.material.kd_map.texels.max() > 0.9  # not indices over 255


def test_from_array_refuses_floats_outside_the_unit_range_and_wide_integers_outside_bytes():
    with pytest.raises(ValueError, match=r"must lie in \[0, 1\], got -0.5..1.5"):
        Texture.from_array(np.array([[[-0.5, 0.2, 1.5]]]), name="t")
    hdr = Texture.from_array(np.array([[[0.5, 2.0, 4.0]]]), srgb=False)  # linear data may exceed 1
    assert hdr.texels.max() == 4.0
    # An int64 0..255 array is 8-bit values (not black): the same texels as uint8.
    a = np.random.default_rng(2).integers(0, 256, (3, 4, 3))
    assert a.dtype == np.int64
    np.testing.assert_array_equal(Texture.from_array(a).texels, Texture.from_array(a.astype(np.uint8)).texels)
    with pytest.raises(ValueError, match=r"int64 pixels must lie in 0..255.*0..300"):
        Texture.from_array(np.array([[[0, 300, 5]]]), name="t")
    with pytest.raises(ValueError, match="finite"):
        Texture.from_array(np.array([[[np.nan, 0.0, 0.0]]]), srgb=False)


@pytest.mark.parametrize("shape", [(3, 5), (1, 7), (7, 1), (1, 1), (6, 10), (1000, 3)])
def test_mip_pyramids_of_any_size_reach_one_texel(shape):
    tex = Texture(np.random.default_rng(3).random(shape + (3,)))
    levels = tex.pyramid
    h, w = shape
    for k, lvl in enumerate(levels):
        assert lvl.shape[:2] == (max(1, h >> k), max(1, w >> k))
    assert levels[-1].shape[:2] == (1, 1)
    assert len(levels) == 1 + max(h, w).bit_length() - 1


# -- glTF samplers -------------------------------------------------------------------------------

def _gltf_quad(path, image: np.ndarray, uvs, samplers: list, images_uri=None, material_extra=None):
    """A .gltf with one quad per sampler (each its own material and texture), image embedded or a URI."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    uv = np.asarray(uvs, np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blob = pos.tobytes() + uv.tobytes() + idx.tobytes()
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    png = buf.getvalue()
    import base64

    img = {"uri": images_uri} if images_uri else {"uri": "data:image/png;base64," + base64.b64encode(png).decode()}
    n = len(samplers)
    js = {
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": list(range(n))}],
        "nodes": [{"mesh": i, "translation": [2.0 * i, 0, 0]} for i in range(n)],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": i}]}
                   for i in range(n)],
        "materials": [dict({"name": f"m{i}", "pbrMetallicRoughness": {"baseColorTexture": {"index": i},
                                                                      "metallicFactor": 0.0}},
                           **(material_extra or {})) for i in range(n)],
        "textures": [{"source": 0, "sampler": i} for i in range(n)],
        "samplers": [{"wrapS": s, "wrapT": t} for s, t in samplers],
        "images": [img],
        "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                     "byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                        {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                      {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    }
    path.write_text(json.dumps(js))


def _sampled(model, u, v):
    """The material's kd map at (u, v) of the model's first face's UV set, NumPy bilinear (repeat or clamp)."""
    tex = model.material.kd_map
    t = tex.texels.astype(np.float64)
    h, w = t.shape[:2]
    x = u * tex.tiling[0] * w - 0.5
    y = v * tex.tiling[1] * h - 0.5
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    fx, fy = x - x0, y - y0

    def at(i, j):
        if tex.wrap == "clamp":
            return t[min(max(i, 0), h - 1), min(max(j, 0), w - 1)]
        return t[i % h, j % w]
    return ((1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1))
            + fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1)))


def _reference(texels, u, v, wrap_s, wrap_t):
    """The glTF sampler's texel at (u, v), nearest (texel centre lookups only)."""
    h, w = texels.shape[:2]

    def fold(c, n, mode):
        if mode == "repeat":
            return int(np.floor((c % 1.0) * n))
        if mode == "clamp":
            return int(np.clip(np.floor(c * n), 0, n - 1))
        period = c % 2.0
        m = period if period < 1.0 else 2.0 - period
        return int(np.clip(np.floor(m * n), 0, n - 1))
    return texels[fold(v, h, wrap_t), fold(u, w, wrap_s)]


REPEAT, CLAMP, MIRROR = 10497, 33071, 33648


def test_gltf_sampler_wrap_modes_are_honoured_per_axis(tmp_path):
    """TextureSettingsTest's failure: clamp and mirrored repeat rendered as repeat. Texel centres
    sampled anywhere over UVs in [-1.5, 2.5] match the spec's fold of the image, per axis."""
    rng = np.random.default_rng(5)
    img = rng.integers(0, 256, (4, 6, 3), dtype=np.uint8)
    uvs = [[-1.5, -1.5], [2.5, -1.5], [2.5, 2.5], [-1.5, 2.5]]
    combos = [(REPEAT, REPEAT), (CLAMP, CLAMP), (MIRROR, MIRROR), (REPEAT, CLAMP), (CLAMP, REPEAT),
              (MIRROR, CLAMP), (REPEAT, MIRROR)]
    _gltf_quad(tmp_path / "s.gltf", img, uvs, combos)
    models = rs.load_models(tmp_path / "s.gltf")
    assert len(models) == len(combos)
    lin = srgb_to_linear(img[::-1] / 255)  # row 0 at v = 0
    names = {"10497": "repeat", "33071": "clamp", "33648": "mirror"}
    for model in models:
        i = int(model.material.name[1:])
        ws, wt = (names[str(c)] for c in combos[i])
        mesh_uv = model.mesh.uvs  # possibly moved onto a padded image
        # trimesh turns glTF's (s, t) into (u, v) = (s, 1 - t); every fold is symmetric under v -> 1 - v.
        p0, p2 = np.array([-1.5, 2.5]), np.array([2.5, -1.5])
        scale = (mesh_uv[2] - mesh_uv[0]) / (p2 - p0)
        for a in np.linspace(0.02, 0.98, 9):
            for b in np.linspace(0.03, 0.97, 7):
                true = p0 + (p2 - p0) * np.array([a, b])
                # Snap to a texel centre of the file's image, so bilinear = nearest.
                cu = (np.floor(true[0] * 6) + 0.5) / 6
                cv = (np.floor(true[1] * 4) + 0.5) / 4
                at = mesh_uv[0] + (np.array([cu, cv]) - p0) * scale
                got = _sampled(model, at[0], at[1])
                want = _reference(lin, cu, cv, ws, wt)
                np.testing.assert_allclose(got, want, atol=1e-6, err_msg=f"{ws}/{wt} at {cu, cv}")


def test_a_missing_gltf_image_is_named(tmp_path):
    _gltf_quad(tmp_path / "m.gltf", np.zeros((2, 2, 3), np.uint8), [[0, 0], [1, 0], [1, 1], [0, 1]],
               [(REPEAT, REPEAT)], images_uri="nothere.png")
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"missing referenced file\(s\): nothere.png \(images\[0\]"):
        rs.load_models(tmp_path / "m.gltf")


def test_no_transparency_warning_on_opaque_gltf_materials(tmp_path):
    """alphaMode OPAQUE (the default) ignores alpha: base alpha 0.99 and an RGBA texture say nothing;
    MASK keeps the texture's alpha and the cutoff, silently (it is mapped, see tests/visibility/test_alpha.py)."""
    img = np.full((2, 2, 4), 200, np.uint8)
    img[..., 3] = 10
    _gltf_quad(tmp_path / "o.gltf", img, [[0, 0], [1, 0], [1, 1], [0, 1]], [(REPEAT, REPEAT)],
               material_extra={"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0,
                                                        "baseColorFactor": [1, 1, 1, 0.99]}})
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        rs.load_models(tmp_path / "o.gltf")
    _gltf_quad(tmp_path / "k.gltf", img, [[0, 0], [1, 0], [1, 1], [0, 1]], [(REPEAT, REPEAT)],
               material_extra={"alphaMode": "MASK", "alphaCutoff": 0.3})
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "k.gltf")
    assert model.material.alpha_cutoff == 0.3
    np.testing.assert_allclose(model.material.alpha_map.texels, 10 / 255, rtol=1e-6)


# -- glTF metallic-roughness ---------------------------------------------------------------------

def test_metallic_roughness_texture_is_mapped_per_texel_so_base_colours_show(tmp_path):
    """No metallicFactor (spec default 1) with a metallicRoughnessTexture: per texel
    kd = b ((1 - m) + m a), ks = 0.04 (1 - m) + b m (1 - a), a = r^2; ka follows the base colour."""
    rng = np.random.default_rng(6)
    base = rng.integers(0, 256, (4, 4, 3), dtype=np.uint8)
    mr = rng.integers(0, 256, (4, 4, 3), dtype=np.uint8)
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=rng.random((8, 2)), material=trimesh.visual.material.PBRMaterial(
        baseColorTexture=Image.fromarray(base), metallicRoughnessTexture=Image.fromarray(mr)))
    box.export(tmp_path / "mr.glb")
    with pytest.warns(rs.DroppedOnLoadWarning, match="metallicRoughnessTexture: per-texel"):
        (model,) = rs.load_models(tmp_path / "mr.glb")
    mat = model.material
    b = srgb_to_linear(base[::-1] / 255)
    m = mr[::-1, :, 2:3] / 255
    a = (mr[::-1, :, 1:2] / 255) ** 2
    np.testing.assert_allclose(mat.kd_map.texels, b * ((1 - m) + m * a), atol=1e-6)
    np.testing.assert_allclose(mat.ks_map.texels, 0.04 * (1 - m) + b * m * (1 - a), atol=1e-6)
    np.testing.assert_allclose(mat.ka_map.texels, b, atol=1e-6)
    assert mat.kd.tolist() == [1.0] * 3 and mat.specular == "blinn"
    r_med = np.median(mr[..., 1] / 255)
    assert mat.shininess == pytest.approx(np.clip(2 / r_med ** 4 - 2, 1, 4096), rel=1e-6)


def test_a_metal_without_texture_keeps_its_colour_in_kd_by_its_roughness(tmp_path):
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(material=trimesh.visual.material.PBRMaterial(
        baseColorFactor=[0.9, 0.5, 0.1, 1.0], roughnessFactor=0.6))
    box.export(tmp_path / "metal.glb")
    (model,) = rs.load_models(tmp_path / "metal.glb")
    b = np.round(np.array([0.9, 0.5, 0.1]) * 255) / 255  # trimesh keeps 8-bit factors
    a = 0.6 ** 2
    np.testing.assert_allclose(model.material.kd, b * a, atol=2e-3)
    np.testing.assert_allclose(model.material.ks, b * (1 - a), atol=2e-3)
    np.testing.assert_allclose(model.material.ka, b, atol=2e-3)


# -- OBJ / MTL -----------------------------------------------------------------------------------

def test_obj_missing_mtl_missing_map_and_undefined_usemtl_are_named(tmp_path):
    (tmp_path / "a.mtl").write_text("newmtl wood\nKd 1 1 1\nmap_Kd nothere.png\n")
    (tmp_path / "a.obj").write_text("mtllib gone.mtl\nmtllib a.mtl\n" + QUAD_OBJ
                                    + "usemtl wood\nf 1/1 2/2 3/3\nusemtl ghost\nf 1/1 3/3 4/4\n")
    with pytest.warns(rs.DroppedOnLoadWarning) as record:
        models = rs.load_models(tmp_path / "a.obj")
    text = _messages(record)
    assert "gone.mtl (mtllib, a.obj:1)" in text
    assert "nothere.png (map_kd, a.mtl:3)" in text
    assert "usemtl ghost (a.obj:" in text
    # The undefined material is the library's default, not trimesh's 2x2 grey placeholder texture.
    ghost = [m for m in models if m.material.name != "wood"][0].material
    assert ghost.kd_map is None and ghost.kd.tolist() == [0.8] * 3


@pytest.mark.parametrize("line, match", [
    ("Kd abc 1 1", r"a.mtl:2: Kd abc 1 1: expected 1 or 3 numbers"),
    ("Kd -0.5 0 0", r"a.mtl:2: Kd -0.5 0 0: reflectances must be >= 0"),
    ("Ks 1 1", r"a.mtl:2: Ks 1 1: expected 1 or 3 numbers \(r g b\), got 2"),
    ("Ns abc", r"a.mtl:2: Ns abc: expected a number"),
    ("Ka nan nan nan", r"a.mtl:2: Ka nan nan nan: the values must be finite"),
    ("map_Kd -clamp maybe t.png", r"a.mtl:2: map_kd: -clamp expects on or off"),
])
def test_mtl_values_are_validated_naming_file_and_line(tmp_path, line, match):
    (tmp_path / "a.mtl").write_text(f"newmtl m\n{line}\n")
    (tmp_path / "a.obj").write_text("mtllib a.mtl\n" + QUAD_OBJ + "usemtl m\nf 1/1 2/2 3/3\n")
    with pytest.raises(ValueError, match=match):
        rs.load_models(tmp_path / "a.obj")


def test_map_kd_options_are_honoured_and_a_non_image_is_named(tmp_path):
    Image.fromarray(np.full((2, 2, 3), 128, np.uint8)).save(tmp_path / "t.png")
    (tmp_path / "junk.png").write_text("not an image")
    (tmp_path / "a.mtl").write_text("newmtl m\nmap_Kd -s 2 3 -clamp on t.png\nnewmtl j\nmap_Kd junk.png\n")
    (tmp_path / "a.obj").write_text("mtllib a.mtl\n" + QUAD_OBJ + "usemtl m\nf 1/1 2/2 3/3\nusemtl j\nf 1/1 3/3 4/4\n")
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"map_kd junk.png at a.mtl:4: not a readable image"):
        models = {m.material.name: m.material for m in rs.load_models(tmp_path / "a.obj")}
    assert models["m"].kd_map.tiling == (2.0, 3.0) and models["m"].kd_map.wrap == "clamp"
    assert models["j"].kd_map is None


def test_uvs_without_a_material_use_the_default_not_trimesh_placeholder(tmp_path):
    """A PLY with UVs and no texture: trimesh invents a 2x2 grey (100) image; the model keeps kd 0.8."""
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(uv=np.random.default_rng(7).random((8, 2)))
    box.export(tmp_path / "uv.ply")
    assert b"s" in (tmp_path / "uv.ply").read_bytes()[:400]  # the UVs are in the file
    (model,) = rs.load_models(tmp_path / "uv.ply")
    assert model.mesh.uvs is not None
    assert model.material.kd_map is None and model.material.kd.tolist() == [0.8] * 3


def test_ambient_follows_the_diffuse_colour_where_the_file_gives_none(tmp_path):
    Image.fromarray(np.full((2, 2, 3), 90, np.uint8)).save(tmp_path / "t.png")
    (tmp_path / "a.mtl").write_text("newmtl plain\nKd 0.2 0.4 0.6\nnewmtl tex\nKd 0.5 0.5 0.5\nmap_Kd t.png\n"
                                    "newmtl own\nKd 0.2 0.4 0.6\nKa 0.1 0.1 0.1\n")
    (tmp_path / "a.obj").write_text("mtllib a.mtl\n" + QUAD_OBJ + "usemtl plain\nf 1/1 2/2 3/3\n"
                                    "usemtl tex\nf 1/1 3/3 4/4\nusemtl own\nf 2/2 3/3 4/4\n")
    mats = {m.material.name: m.material for m in rs.load_models(tmp_path / "a.obj")}
    assert mats["plain"].ka.tolist() == mats["plain"].kd.tolist() and mats["plain"].ka_map is None
    assert mats["tex"].ka.tolist() == [0.5] * 3 and mats["tex"].ka_map is mats["tex"].kd_map
    assert mats["own"].ka.tolist() == [0.1] * 3 and mats["own"].ka_map is None  # the file's Ka, exact
    # Explicit Material(ka=...) stays exact.
    assert rs.Material(ka=0.3, kd=0.9).ka.tolist() == [0.3] * 3


# -- geometry ------------------------------------------------------------------------------------

def test_reversed_duplicate_faces_are_named_and_dropped_on_load(tmp_path):
    """A sheet given twice with opposite windings cancels every averaged normal: a Mesh warns
    (WindingWarning naming the pairs), load_models drops the later face of each pair, counted."""
    grid = rs.shapes.plane(subdivisions=3)
    v, f = grid.vertices, grid.faces
    faces = np.concatenate([f, f[:, ::-1]])
    assert reversed_duplicates(faces).sum() == len(f)
    assert not reversed_duplicates(np.concatenate([f, f])).any()  # same winding: not a reversed pair
    # The same with each copy on vertices of its own (as files write it).
    v2 = np.concatenate([v, v])
    f2 = np.concatenate([f, f[:, ::-1] + len(v)])
    assert reversed_duplicates(f2, v2).sum() == len(f) and not reversed_duplicates(f2).any()
    with pytest.warns(rs.WindingWarning, match=f"{len(f)} face\\(s\\) repeat another face with the opposite"):
        rs.Mesh(v2, f2).prepared
    trimesh.Trimesh(v2, f2, process=False).export(tmp_path / "sheet.obj")
    with pytest.warns(rs.DroppedOnLoadWarning, match=f"{len(f)} face\\(s\\) repeating another"):
        (model,) = rs.load_models(tmp_path / "sheet.obj")
    assert len(model.mesh.faces) == len(f)
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.WindingWarning)
        prepared = model.mesh.prepared
    # Clean averaged normals: every used one is the plane's +-z (none cancelled to zero).
    used = np.unique(prepared.faces)
    np.testing.assert_allclose(np.abs(prepared.normals[used, 2]), 1.0, atol=1e-12)


def test_off_colours_are_kept(tmp_path):
    (tmp_path / "c.off").write_text("OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
                                    "3 0 1 2 255 0 0\n3 0 2 3 0 128 255\n")
    (model,) = rs.load_models(tmp_path / "c.off")
    assert model.mesh.color_mode == "face"
    np.testing.assert_allclose(model.mesh.colors, srgb_to_linear(np.array([[255, 0, 0], [0, 128, 255]]) / 255))
    (tmp_path / "v.off").write_text("COFF\n3 1 0\n0 0 0 1.0 0 0 1.0\n1 0 0 0 1.0 0 1.0\n0 1 0 0 0 1.0 1.0\n3 0 1 2\n")
    (model,) = rs.load_models(tmp_path / "v.off")
    assert model.mesh.color_mode == "vertex"
    np.testing.assert_allclose(model.mesh.colors, np.eye(3))
    (tmp_path / "bad.off").write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 9 9 abc\n")
    with pytest.raises(ValueError, match=r"bad.off:6: face colour values must be numbers"):
        rs.load_models(tmp_path / "bad.off")


def test_a_zipped_stl_is_welded_like_the_same_stl_on_disk(tmp_path):
    trimesh.creation.icosphere(subdivisions=2).export(tmp_path / "ico.stl")
    with zipfile.ZipFile(tmp_path / "ico.zip", "w") as z:
        z.write(tmp_path / "ico.stl", "ico.stl")
    disk = rs.Mesh.load(tmp_path / "ico.stl")
    (zipped,) = rs.load_models(tmp_path / "ico.zip")
    assert len(zipped.mesh.vertices) == len(disk.vertices) == 162


def test_one_texture_shared_by_three_meshes_is_decoded_once(tmp_path):
    img = Image.fromarray(np.random.default_rng(8).integers(0, 256, (8, 8, 3), dtype=np.uint8))
    mat = trimesh.visual.material.PBRMaterial(baseColorTexture=img, metallicFactor=0.0)
    scene = trimesh.Scene()
    for i in range(3):
        b = trimesh.creation.box()
        b.apply_translation((2.0 * i, 0, 0))
        b.visual = trimesh.visual.TextureVisuals(uv=np.random.default_rng(i).random((8, 2)), material=mat)
        scene.add_geometry(b, geom_name=f"b{i}")
    scene.export(tmp_path / "three.glb")
    models = rs.load_models(tmp_path / "three.glb")
    assert len(models) == 3
    assert len({id(m.material.kd_map) for m in models}) == 1  # one Texture: decoded once, packed once
    packed = rs.Scene(models, camera=rs.Camera(eye=(2, 0, 8), target=(2, 0, 0), width=8, height=8)).geometry
    assert len(packed.tex_info) == 1


def test_a_missing_optional_reader_names_the_pip_package(tmp_path, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_lxml(name, *args, **kwargs):
        if name.split(".")[0] == "lxml":
            raise ModuleNotFoundError("No module named 'lxml'", name="lxml")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_lxml)
    (tmp_path / "x.3mf").write_bytes(b"PK\x05\x06" + b"\0" * 18)  # an empty zip
    with pytest.raises(ImportError, match=r"pip install lxml") as info:
        rs.Mesh.load(tmp_path / "x.3mf")
    assert isinstance(info.value, ValueError)  # reported like any bad input (the CLI: one line, exit 2)


# -- built-in shapes' UVs ------------------------------------------------------------------------

def _uv_signed_areas(mesh):
    uv = mesh.uvs[mesh.faces]
    keep = np.ptp(uv[:, :, 0], axis=1) < 0.5  # faces across a seam wrap around
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    return (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])[keep]


@pytest.mark.parametrize("make", [
    lambda: rs.shapes.uv_sphere(8, 16), lambda: rs.shapes.icosphere(2), lambda: rs.shapes.torus(),
    *[(lambda n=n: rs.shapes.plane(subdivisions=3, normal=n)) for n in ("+x", "-x", "+y", "-y", "+z", "-z")]])
def test_shape_uvs_read_unmirrored_from_outside(make):
    """Faces are counter-clockwise seen from outside; so must their UVs be (u right, v up, positive
    area), or an image reads mirrored."""
    mesh = make()
    area = _uv_signed_areas(mesh)
    assert len(area) > 0 and (area > 0).all(), mesh.name


def test_sphere_images_read_upright():
    for mesh in (rs.shapes.uv_sphere(8, 16), rs.shapes.icosphere(2)):
        north = mesh.vertices[:, 1] > 0.99
        south = mesh.vertices[:, 1] < -0.99
        assert mesh.uvs[north, 1].min() > 0.9 and mesh.uvs[south, 1].max() < 0.1


def test_a_scene_file_kd_override_carries_a_following_ka_along(tmp_path):
    from raycast_shade.scene.scenefile import load_scene

    (tmp_path / "a.mtl").write_text("newmtl red\nKd 0.8 0.1 0.1\nnewmtl own\nKd 0.8 0.1 0.1\nKa 0.05 0.05 0.05\n")
    (tmp_path / "a.obj").write_text("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl red\nf 1 2 3\n")
    (tmp_path / "b.obj").write_text("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl own\nf 1 2 3\n")
    base = '[camera]\neye = [0.5, 0.5, 3]\n[[object]]\nmesh = "{}"\n[object.material]\nkd = 0.3\n'
    for obj, ka in (("a.obj", [0.3] * 3), ("b.obj", [0.05] * 3)):
        (tmp_path / "s.toml").write_text(base.format(obj))
        scene, _ = load_scene(tmp_path / "s.toml")
        assert scene.models[0].material.ka.tolist() == ka


@pytest.mark.parametrize("extra, match", [
    ({"pbrMetallicRoughness": {"metallicFactor": -0.5}}, r"materials\[0\].pbrMetallicRoughness.metallicFactor: "
                                                         r"expected 1 number\(s\) in \[0, 1\], got -0.5"),
    ({"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1]}}, r"baseColorFactor: expected 4 number"),
    ({"pbrMetallicRoughness": {"roughnessFactor": "abc"}}, r"roughnessFactor: expected 1 number"),
    ({"alphaMode": "CUTOUT"}, r"materials\[0\].alphaMode: expected OPAQUE, MASK or BLEND"),
])
def test_gltf_material_factors_are_validated_naming_the_field(tmp_path, extra, match):
    _gltf_quad(tmp_path / "f.gltf", np.zeros((2, 2, 3), np.uint8), [[0, 0], [1, 0], [1, 1], [0, 1]],
               [(REPEAT, REPEAT)], material_extra=extra)
    with pytest.raises(ValueError, match="f.gltf: .*" + match):
        rs.load_models(tmp_path / "f.gltf")


def test_a_missing_gltf_buffer_is_an_error_naming_it(tmp_path):
    _gltf_quad(tmp_path / "b.gltf", np.zeros((2, 2, 3), np.uint8), [[0, 0], [1, 0], [1, 1], [0, 1]],
               [(REPEAT, REPEAT)])
    js = json.loads((tmp_path / "b.gltf").read_text())
    js["buffers"][0]["uri"] = "gone.bin"
    (tmp_path / "b.gltf").write_text(json.dumps(js))
    with pytest.raises(ValueError, match=r"b.gltf: buffers\[0\]: the file gone.bin is missing"):
        rs.load_models(tmp_path / "b.gltf")


def test_mesh_load_drops_reversed_duplicates_too_keeping_face_colours_aligned(tmp_path):
    grid = rs.shapes.plane(subdivisions=2)
    f = grid.faces
    faces = np.concatenate([f, f[:, ::-1]])
    colours = np.zeros((len(faces), 4), np.uint8)
    colours[:, 3] = 255
    colours[:, 0] = np.arange(len(faces)) * 10  # a face's colour says which face it is
    tm = trimesh.Trimesh(grid.vertices, faces, process=False)
    tm.visual.face_colors = colours
    tm.export(tmp_path / "sheet.ply")
    with pytest.warns(rs.DroppedOnLoadWarning, match=f"dropped {len(f)} face"):
        mesh = rs.Mesh.load(tmp_path / "sheet.ply")
    assert len(mesh.faces) == len(f) and mesh.color_mode == "face"
    np.testing.assert_allclose(mesh.colors[:, 0], srgb_to_linear(np.arange(len(f)) * 10 / 255))


def test_a_one_axis_clamp_with_a_metallic_roughness_texture_moves_every_map_alike(tmp_path):
    """kd_map, ks_map (baked per texel) and ka_map (the base colour) share the base grid: one UV set."""
    import base64

    rng = np.random.default_rng(9)
    base, mr = (rng.integers(0, 256, (4, 6, 3), dtype=np.uint8) for _ in range(2))
    _gltf_quad(tmp_path / "c.gltf", base, [[-0.5, 0], [1.5, 0], [1.5, 1], [-0.5, 1]], [(CLAMP, REPEAT)])
    js = json.loads((tmp_path / "c.gltf").read_text())
    buf = io.BytesIO()
    Image.fromarray(mr).save(buf, format="PNG")
    js["images"].append({"uri": "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()})
    js["textures"].append({"source": 1, "sampler": 0})
    js["materials"][0]["pbrMetallicRoughness"] = {"baseColorTexture": {"index": 0},
                                                  "metallicRoughnessTexture": {"index": 1}}
    (tmp_path / "c.gltf").write_text(json.dumps(js))
    with pytest.warns(rs.DroppedOnLoadWarning) as record:
        (model,) = rs.load_models(tmp_path / "c.gltf")
    assert "pads another grid" not in _messages(record)
    mat = model.material
    assert mat.kd_map.shape == mat.ks_map.shape == mat.ka_map.shape and mat.kd_map.shape[1] > 6  # padded in u
    # At the file's texel centres along u (inside and beyond [0, 1]), the base colour at the moved UV is
    # the clamped file texel; v (repeat) is untouched: trimesh's v = 1 - t.
    lin = srgb_to_linear(base[::-1] / 255)  # row 0 at v = 0
    u0, u1 = model.mesh.uvs[0, 0], model.mesh.uvs[1, 0]
    ka = rs.Model(model.mesh, rs.Material(kd_map=mat.ka_map))
    for j in range(-3, 9):
        u_file = (j + 0.5) / 6
        u = u0 + (u_file + 0.5) / 2.0 * (u1 - u0)
        for i in range(4):
            got = _sampled(ka, u, (i + 0.5) / 4)
            np.testing.assert_allclose(got, lin[i, min(max(j, 0), 5)], atol=1e-6)
    np.testing.assert_allclose(model.mesh.uvs[:, 1], [1, 1, 0, 0])


def test_gltf_emission_is_mapped_factor_texture_and_strength(tmp_path):
    """emissiveFactor -> ke, emissiveTexture -> ke_map (sRGB), KHR_materials_emissive_strength scales ke;
    a texture without a factor emits nothing, as the spec's default factor 0 says; nothing is warned."""
    img = np.zeros((4, 4, 3), np.uint8)
    img[...] = (200, 100, 50)
    extra = {"emissiveFactor": [1.0, 0.5, 0.25], "emissiveTexture": {"index": 0},
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}}}
    _gltf_quad(tmp_path / "e.gltf", img, [[0, 0], [1, 0], [1, 1], [0, 1]], [(10497, 10497)], material_extra=extra)
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "e.gltf")
    mat = model.material
    np.testing.assert_allclose(mat.ke, [3.0, 1.5, 0.75])
    np.testing.assert_allclose(mat.ke_map.texels, srgb_to_linear(np.full((4, 4, 3), [200, 100, 50]) / 255.0),
                               atol=1e-6)
    _gltf_quad(tmp_path / "t.gltf", img, [[0, 0], [1, 0], [1, 1], [0, 1]], [(10497, 10497)],
               material_extra={"emissiveTexture": {"index": 0}})
    (model,) = rs.load_models(tmp_path / "t.gltf")
    assert not model.material.has_emission and model.material.ke_map is None
    _gltf_quad(tmp_path / "bad.gltf", img, [[0, 0], [1, 0], [1, 1], [0, 1]], [(10497, 10497)],
               material_extra={"extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": -1}}})
    with pytest.raises(ValueError, match=r"materials\[0\].extensions.KHR_materials_emissive_strength"):
        rs.load_models(tmp_path / "bad.gltf")


def test_mtl_ke_and_map_ke_are_read(tmp_path):
    Image.fromarray(np.full((2, 2, 3), 255, np.uint8)).save(tmp_path / "glow.png")
    (tmp_path / "a.mtl").write_text("newmtl lamp\nKd 0.1 0.1 0.1\nKe 1 0.8 0.2\nmap_Ke glow.png\n")
    (tmp_path / "a.obj").write_text("mtllib a.mtl\n" + QUAD_OBJ + "usemtl lamp\nf 1/1 2/2 3/3\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "a.obj")
    assert model.material.ke.tolist() == [1.0, 0.8, 0.2] and model.material.ke_map is not None
    (tmp_path / "b.mtl").write_text("newmtl lamp\nKe -1 0 0\n")
    (tmp_path / "b.obj").write_text("mtllib b.mtl\n" + QUAD_OBJ + "usemtl lamp\nf 1/1 2/2 3/3\n")
    with pytest.raises(ValueError, match="b.mtl:2: Ke -1 0 0"):
        rs.load_models(tmp_path / "b.obj")


def test_gltf_occlusion_texture_is_mapped_linear_with_its_strength(tmp_path):
    img = np.zeros((4, 4, 3), np.uint8)
    img[..., 0] = 64  # red: occlusion (linear, not sRGB-decoded)
    _gltf_quad(tmp_path / "o.gltf", img, [[0, 0], [1, 0], [1, 1], [0, 1]], [(10497, 10497)],
               material_extra={"occlusionTexture": {"index": 0, "strength": 0.7}})
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "o.gltf")
    assert model.material.ao_strength == 0.7
    np.testing.assert_allclose(model.material.ao_map.texels[..., 0], 64 / 255, atol=1e-6)
    _gltf_quad(tmp_path / "bad.gltf", img, [[0, 0], [1, 0], [1, 1], [0, 1]], [(10497, 10497)],
               material_extra={"occlusionTexture": {"index": 0, "strength": 2}})
    with pytest.raises(ValueError, match=r"materials\[0\].occlusionTexture.strength"):
        rs.load_models(tmp_path / "bad.gltf")
