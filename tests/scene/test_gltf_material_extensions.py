"""glTF material extensions the loader applies itself: ``KHR_texture_transform`` (the mesh's UVs moved
at load) and ``KHR_materials_pbrSpecularGlossiness`` (read from the file, through the usual texture path)."""

from __future__ import annotations

import base64
import io
import json
import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

import raycast_shade as rs
from raycast_shade.scene.specgloss import metal_rough_of_spec_gloss
from raycast_shade.scene.texture import srgb_to_linear
from raycast_shade.scene.wrapped import apply_uv, uv_transform

W = 64  # the renders: 64 x 64 pixels over the unit quad, orthographic


def _png(image) -> str:
    buf = io.BytesIO()
    (image if isinstance(image, Image.Image) else Image.fromarray(image)).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def _quad_file(path, material, images, samplers=None):
    """A .gltf unit quad at z = 0, UVs = (x, 1 - y) (glTF's v runs down the image), one material,
    ``images`` embedded as textures 0, 1, ... (texture i shows image i)."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    nrm = np.array([[0, 0, 1]] * 4, np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blob = pos.tobytes() + uv.tobytes() + nrm.tobytes() + idx.tobytes()
    js = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "NORMAL": 2}, "indices": 3,
                                    "material": 0}]}],
        "materials": [material],
        "textures": [{"source": i, **({"sampler": 0} if samplers else {})} for i in range(len(images))],
        "images": [{"uri": _png(im)} for im in images],
        "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
                     "byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                        {"buffer": 0, "byteOffset": 80, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 128, "byteLength": 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                      {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC3"},
                      {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    }
    if samplers:
        js["samplers"] = samplers
    if any("KHR_texture_transform" in json.dumps(v) for v in (material,)):
        js["extensionsUsed"] = ["KHR_texture_transform"]
    if "KHR_materials_pbrSpecularGlossiness" in json.dumps(material):
        js.setdefault("extensionsUsed", []).append("KHR_materials_pbrSpecularGlossiness")
    path.write_text(json.dumps(js))
    return path


def _base_colour(transform=None, **extra):
    info = {"index": 0}
    if transform is not None:
        info["extensions"] = {"KHR_texture_transform": transform}
    return dict({"name": "quad", "pbrMetallicRoughness": {"baseColorTexture": info, "metallicFactor": 0.0}}, **extra)


def _image(seed=0, n=4):
    return np.random.default_rng(seed).integers(0, 256, (n, n, 3), dtype=np.uint8)


def _render(path):
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(path)
    scene = rs.Scene([model], lights=[rs.DirectionalLight((0, 0, -1), intensity=1.0)], ambient=0.2,
                     camera=rs.Camera(eye=(0.5, 0.5, 3), target=(0.5, 0.5, 0), up=(0, 1, 0),
                                      projection="orthographic", ortho_height=1.0, width=W, height=W))
    return rs.render(scene, shading="phong").image, model


# -- KHR_texture_transform ------------------------------------------------------------------------------

@pytest.mark.parametrize("transform, same_image", [
    # Offset by half the image under repeat: the image rolled by half a width (u) / height (glTF v runs down).
    ({"offset": [0.5, 0.0]}, lambda im: np.roll(im, -im.shape[1] // 2, axis=1)),
    ({"offset": [0.0, 0.25]}, lambda im: np.roll(im, -im.shape[0] // 4, axis=0)),
    # Scale 2: the image tiled twice each way.
    ({"scale": [2.0, 2.0]}, lambda im: np.tile(im, (2, 2, 1))),
    # Rotating the UVs by +90 degrees is the image turned clockwise (the spec's words; the rotation sign
    # of KhronosGroup/glTF issue 1563: its GLSL listing's transpose would give the anticlockwise turn).
    ({"rotation": math.pi / 2}, lambda im: np.rot90(im, -1)),
])
def test_a_transform_renders_as_the_untransformed_file_of_the_equivalent_image(tmp_path, transform, same_image):
    """Closed form under repeat: each transform equals an image rearranged texel for texel, so the two
    renders agree pixel for pixel (bilinear filtering and all)."""
    img = _image()
    got, model = _render(_quad_file(tmp_path / "t.gltf", _base_colour(transform), [img]))
    want, _ = _render(_quad_file(tmp_path / "r.gltf", _base_colour(), [np.ascontiguousarray(same_image(img))]))
    assert np.ptp(want) > 0.1  # the texture shows
    np.testing.assert_allclose(got, want, atol=1e-5)
    plain, _ = _render(_quad_file(tmp_path / "p.gltf", _base_colour(), [img]))
    assert np.abs(plain - got).max() > 0.05  # and the transform changed the picture


def test_offset_rotation_and_scale_compose_as_t_r_s_on_the_files_uvs(tmp_path):
    """The loaded mesh's UVs (v up) are the file's (v down) through T * R * S, plain NumPy."""
    t = {"offset": [0.3, -0.2], "rotation": 0.4, "scale": [1.5, 0.5]}
    _quad_file(tmp_path / "q.gltf", _base_colour(t), [_image()])
    (model,) = rs.load_models(tmp_path / "q.gltf")
    c, s = math.cos(0.4), math.sin(0.4)
    trs = np.array([[1, 0, 0.3], [0, 1, -0.2], [0, 0, 1]]) @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) \
        @ np.diag([1.5, 0.5, 1.0])
    xy = model.mesh.vertices[:, :2]
    file_uv = np.column_stack([xy[:, 0], 1 - xy[:, 1], np.ones(len(xy))])  # the quad's UVs as written
    g = file_uv @ trs.T
    np.testing.assert_allclose(model.mesh.uvs, np.column_stack([g[:, 0], 1 - g[:, 1]]), atol=1e-6)


@settings(max_examples=60, deadline=None)
@given(st.floats(-3, 3), st.floats(-3, 3), st.floats(-7, 7), st.floats(-4, 4).filter(lambda x: abs(x) > 1e-3),
       st.floats(-4, 4).filter(lambda x: abs(x) > 1e-3))
def test_the_uv_matrix_is_the_specs_transform_between_the_two_v_conventions(ou, ov, rot, su, sv):
    m, tex_coord = uv_transform({"index": 0, "extensions": {"KHR_texture_transform": {
        "offset": [ou, ov], "rotation": rot, "scale": [su, sv]}}}, "f")
    uv = np.random.default_rng(1).random((20, 2))
    g = np.column_stack([uv[:, 0], 1 - uv[:, 1]])  # glTF's UVs
    c, s = math.cos(rot), math.sin(rot)
    g2 = np.column_stack([c * su * g[:, 0] + s * sv * g[:, 1] + ou, -s * su * g[:, 0] + c * sv * g[:, 1] + ov])
    np.testing.assert_allclose(apply_uv(uv, m), np.column_stack([g2[:, 0], 1 - g2[:, 1]]), atol=1e-9)
    assert tex_coord == 0


def test_the_specs_example_reads_the_lower_left_quadrant():
    """KHR_texture_transform's README: offset (0, 1), rotation pi/2, scale 0.5 uses the image's lower-left
    quadrant: glTF u in [0, 0.5], v in [0.5, 1] (v down), i.e. the mesh's u, v both in [0, 0.5]."""
    m, _ = uv_transform({"extensions": {"KHR_texture_transform": {"offset": [0, 1], "rotation": math.pi / 2,
                                                                  "scale": [0.5, 0.5]}}}, "f")
    corners = apply_uv(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float), m)
    np.testing.assert_allclose(corners.min(0), [0, 0], atol=1e-12)
    np.testing.assert_allclose(corners.max(0), [0.5, 0.5], atol=1e-12)


def test_every_map_with_one_transform_shares_it_without_a_warning(tmp_path):
    t = {"offset": [0.5, 0.0], "scale": [2.0, 1.0]}
    ext = {"KHR_texture_transform": t}
    mat = {"name": "quad", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": ext},
                                                    "metallicFactor": 0.0},
           "normalTexture": {"index": 1, "extensions": ext}, "occlusionTexture": {"index": 1, "extensions": ext},
           "emissiveTexture": {"index": 0, "extensions": ext}, "emissiveFactor": [0.5, 0.5, 0.5]}
    flat = np.full((2, 2, 3), (128, 128, 255), np.uint8)
    _quad_file(tmp_path / "all.gltf", mat, [_image(), flat])
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "all.gltf")
    m = model.material
    assert all(x is not None for x in (m.kd_map, m.normal_map, m.ao_map, m.ke_map))
    xy = model.mesh.vertices[:, :2]
    np.testing.assert_allclose(model.mesh.uvs, np.column_stack([2 * xy[:, 0] + 0.5, xy[:, 1]]), atol=1e-6)


def test_maps_with_different_transforms_warn_naming_them(tmp_path):
    mat = {"name": "quad", "pbrMetallicRoughness": {"baseColorTexture": {
        "index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0]}}}, "metallicFactor": 0.0},
        "normalTexture": {"index": 0}}
    _quad_file(tmp_path / "d.gltf", mat, [_image()])
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"normalTexture transformed otherwise than baseColorTexture "
                                                     r"\(one UV set per mesh: every map drawn with baseColorTexture"):
        (model,) = rs.load_models(tmp_path / "d.gltf")
    xy = model.mesh.vertices[:, :2]
    np.testing.assert_allclose(model.mesh.uvs, np.column_stack([xy[:, 0] + 0.5, xy[:, 1]]), atol=1e-6)


def test_a_texcoord_override_naming_a_second_uv_set_the_file_lacks_is_warned(tmp_path):
    _quad_file(tmp_path / "c.gltf", _base_colour({"texCoord": 1}), [_image()])
    with pytest.warns(rs.DroppedOnLoadWarning, match=r"baseColorTexture: texCoord 1 \(the primitive has no "
                                                     r"readable TEXCOORD_1"):
        rs.load_models(tmp_path / "c.gltf")


@pytest.mark.parametrize("transform, field", [
    ({"scale": [1.0]}, "scale"), ({"offset": [0, "a"]}, "offset"), ({"rotation": float("nan")}, "rotation"),
    ({"texCoord": -1}, "texCoord"), ({"texCoord": 0.5}, "texCoord")])
def test_a_bad_transform_is_refused_naming_the_field(tmp_path, transform, field):
    path = _quad_file(tmp_path / "bad.gltf", _base_colour(transform), [_image()])
    text = path.read_text().replace("NaN", "1e999")  # JSON has no NaN: an infinite number instead
    path.write_text(text)
    with pytest.raises(ValueError, match=r"bad.gltf: materials\[0\]\.baseColorTexture\.extensions\."
                                         rf"KHR_texture_transform\.{field}"):
        rs.load_models(path)


# -- KHR_materials_pbrSpecularGlossiness -----------------------------------------------------------------

def _palette_image():
    rgb = _image(3, 4)
    return Image.fromarray(rgb).convert("P", palette=Image.Palette.ADAPTIVE, colors=8), rgb


def _spec_gloss(ext, core=None):
    return {"name": "sg", "pbrMetallicRoughness": core or {"metallicFactor": 0.0},
            "extensions": {"KHR_materials_pbrSpecularGlossiness": ext}}


def test_spec_gloss_diffuse_palette_png_is_decoded_through_the_texture_path(tmp_path):
    """kd = ka = diffuseFactor, kd_map the palette image's colours decoded from sRGB (trimesh's own conversion
    made this dark), ks = specularFactor, t = 2 / alpha^2 - 2 with alpha = (1 - glossiness)^2; no warning."""
    pal, _ = _palette_image()
    ext = {"diffuseTexture": {"index": 0}, "diffuseFactor": [0.9, 0.8, 0.7, 1.0], "specularFactor": [0.1, 0.2, 0.3],
           "glossinessFactor": 0.3}
    _quad_file(tmp_path / "sg.gltf", _spec_gloss(ext), [pal])
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "sg.gltf")
    m = model.material
    np.testing.assert_allclose(m.kd, [0.9, 0.8, 0.7])
    np.testing.assert_allclose(m.ks, [0.1, 0.2, 0.3])
    assert m.shininess == pytest.approx(2 / 0.7 ** 4 - 2)
    decoded = np.asarray(pal.convert("RGB"))
    np.testing.assert_allclose(m.kd_map.texels, srgb_to_linear(decoded[::-1] / 255), rtol=1e-6)
    assert m.ka_map is m.kd_map


def test_spec_gloss_texture_gives_ks_per_texel_and_one_exponent_named_in_the_warning(tmp_path):
    rgba = _image(5, 4)
    gloss = np.arange(16, dtype=np.uint8).reshape(4, 4) * 16  # 0 .. 240
    img = np.dstack([rgba, gloss])
    ext = {"diffuseFactor": [0.5, 0.5, 0.5, 1.0], "specularGlossinessTexture": {"index": 0},
           "glossinessFactor": 0.5}
    _quad_file(tmp_path / "sgt.gltf", _spec_gloss(ext), [img])
    with pytest.warns(rs.DroppedOnLoadWarning) as rec:
        (model,) = rs.load_models(tmp_path / "sgt.gltf")
    text = " ".join(str(w.message) for w in rec)
    g_med = 0.5 * np.median(gloss / 255)
    assert f"median glossiness {g_med:.3g}" in text and "specularGlossinessTexture" in text
    assert "metallicRoughness" not in text and "baseColorTexture" not in text  # only textures the file has
    m = model.material
    np.testing.assert_allclose(m.ks, [1.0, 1.0, 1.0])  # specularFactor's default
    np.testing.assert_allclose(m.ks_map.texels, srgb_to_linear(rgba[::-1] / 255), rtol=1e-6)
    assert m.shininess == pytest.approx(min(2 / (1 - g_med) ** 4 - 2, 4096))


def test_spec_gloss_with_pbr_reflectance_converts_a_dielectric_exactly(tmp_path):
    """Specular 0.04 grey: metallic 0, base colour = diffuse, roughness = 1 - glossiness."""
    ext = {"diffuseFactor": [0.6, 0.3, 0.2, 1.0], "specularFactor": [0.04, 0.04, 0.04], "glossinessFactor": 0.25}
    _quad_file(tmp_path / "die.gltf", _spec_gloss(ext), [_image()])
    with pytest.warns(rs.DroppedOnLoadWarning, match="converted to metallic-roughness"):
        (model,) = rs.load_models(tmp_path / "die.gltf", reflectance="pbr")
    m = model.material
    assert m.specular == "ggx" and m.metallic == pytest.approx(0.0, abs=1e-12)
    assert m.roughness == pytest.approx(0.75)
    np.testing.assert_allclose(m.kd, [0.6, 0.3, 0.2], atol=1e-12)


def test_spec_gloss_textures_with_pbr_reflectance_give_per_texel_metallic_and_roughness(tmp_path):
    diffuse = np.zeros((2, 2, 3), np.uint8)  # black diffuse: a pure metal whose base colour is the specular
    spec = np.dstack([np.full((2, 2, 3), (230, 150, 60), np.uint8), np.array([[255, 128], [0, 64]], np.uint8)])
    ext = {"diffuseTexture": {"index": 0}, "specularGlossinessTexture": {"index": 1}}
    _quad_file(tmp_path / "metal.gltf", _spec_gloss(ext), [diffuse, spec])
    with pytest.warns(rs.DroppedOnLoadWarning, match="converted to metallic-roughness"):
        (model,) = rs.load_models(tmp_path / "metal.gltf", reflectance="pbr")
    m = model.material
    mr = m.metallic_roughness_map.texels
    np.testing.assert_allclose(mr[..., 2], 1.0, atol=1e-6)  # metallic
    np.testing.assert_allclose(mr[..., 1], 1 - np.array([[255, 128], [0, 64]])[::-1] / 255, atol=1e-6)
    np.testing.assert_allclose(m.kd_map.texels, np.broadcast_to(srgb_to_linear(np.array([230, 150, 60]) / 255),
                                                                (2, 2, 3)), atol=1e-5)


@settings(max_examples=80, deadline=None)
@given(st.floats(0.05, 1.0), st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_the_conversion_inverts_the_metallic_model_for_grey_bases(b, metal, g):
    """Round trip: a grey base b and metallic m made into specular-glossiness (D = b (1 - m),
    S = 0.04 (1 - m) + b m) convert back to b and m."""
    base = np.full(3, b)
    d, s = base * (1 - metal), 0.04 * (1 - metal) + base * metal
    got_base, got_m, got_r = metal_rough_of_spec_gloss(d, s, g)
    assert float(got_m) == pytest.approx(metal, abs=1e-6)
    np.testing.assert_allclose(got_base, base, atol=1e-5)
    assert float(got_r) == pytest.approx(1 - g)


def test_spec_gloss_images_in_a_glb_buffer_view_are_read(tmp_path):
    """The extension's images are decoded from the file itself: here from a GLB's buffer view."""
    from raycast_shade.scene.gltfgeometry import glb_bytes

    _quad_file(tmp_path / "src.gltf", _spec_gloss({"diffuseTexture": {"index": 0}}), [_image(7)])
    js = json.loads((tmp_path / "src.gltf").read_text())
    blob = base64.b64decode(js["buffers"][0]["uri"].split(",", 1)[1])
    png = base64.b64decode(js["images"][0]["uri"].split(",", 1)[1])
    pad = b"\0" * (-len(blob) % 4)
    js["bufferViews"].append({"buffer": 0, "byteOffset": len(blob) + len(pad), "byteLength": len(png)})
    js["images"] = [{"bufferView": len(js["bufferViews"]) - 1, "mimeType": "image/png"}]
    binary = blob + pad + png
    binary += b"\0" * (-len(binary) % 4)
    js["buffers"] = [{"byteLength": len(binary)}]
    (tmp_path / "q.glb").write_bytes(glb_bytes(js, binary))
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "q.glb")
    np.testing.assert_allclose(model.material.kd_map.texels, srgb_to_linear(_image(7)[::-1] / 255), rtol=1e-6)


def test_a_missing_or_broken_spec_gloss_image_is_named_and_the_rest_drawn(tmp_path):
    ext = {"diffuseTexture": {"index": 0}, "specularGlossinessTexture": {"index": 1}, "specularFactor": [0.2] * 3}
    _quad_file(tmp_path / "m.gltf", _spec_gloss(ext), [_image(), _image()])
    js = json.loads((tmp_path / "m.gltf").read_text())
    js["images"] = [{"uri": "gone.png"}, {"uri": "broken.png"}]
    (tmp_path / "broken.png").write_bytes(b"not a png")
    (tmp_path / "m.gltf").write_text(json.dumps(js))
    with pytest.warns(rs.DroppedOnLoadWarning) as rec:
        (model,) = rs.load_models(tmp_path / "m.gltf")
    text = " ".join(str(w.message) for w in rec)
    assert "gone.png (images[0] of m.gltf)" in text
    assert "specularGlossinessTexture: images[1] of m.gltf: not a readable image" in text
    m = model.material
    assert m.kd_map is None and m.ks_map is None
    np.testing.assert_allclose(m.ks, [0.2, 0.2, 0.2])


def test_a_transformed_map_clamped_on_one_axis_pads_over_the_transformed_uvs(tmp_path):
    """Clamp on u, repeat on v, offset (0.5, 0): the padded image is sampled at the moved UVs, so the
    render equals the one of the image whose u runs from its middle to its clamped right edge."""
    img = _image(9, 8)
    samplers = [{"wrapS": 33071, "wrapT": 10497}]
    got, _ = _render(_quad_file(tmp_path / "c.gltf", _base_colour({"offset": [0.5, 0.0]}), [img], samplers))
    plain, _ = _render(_quad_file(tmp_path / "p.gltf", _base_colour(), [img], samplers))
    # Left half of the transformed quad (u' in [0.5, 1]) shows the right half of the plain one.
    np.testing.assert_allclose(got[:, : W // 2 - 4], plain[:, W // 2: W - 4], atol=1e-5)
    # Right half (u' beyond 1): clamped, each row the image's last column (the plain quad's right edge).
    np.testing.assert_allclose(got[:, W // 2 + 4:], np.repeat(plain[:, W - 1:], W // 2 - 4, axis=1), atol=0.02)


def test_an_unnamed_spec_gloss_material_without_a_core_texture_is_still_found(tmp_path):
    """trimesh gives the converted material a base colour texture the core JSON lacks: the material is
    matched by its diffuse texture, so the extension is read (kd_map the diffuse image, ks the factor)."""
    mat = _spec_gloss({"diffuseTexture": {"index": 0}, "specularFactor": [0.3, 0.3, 0.3]})
    del mat["name"]
    _quad_file(tmp_path / "u.gltf", mat, [_image(11)])
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(tmp_path / "u.gltf")
    np.testing.assert_allclose(model.material.ks, [0.3, 0.3, 0.3])
    np.testing.assert_allclose(model.material.kd_map.texels, srgb_to_linear(_image(11)[::-1] / 255), rtol=1e-6)
