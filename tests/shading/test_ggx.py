"""The GGX reflectance model (glTF 2.0 metallic-roughness, ``Material(specular="ggx")``): the kernel's
terms against the float64 twin (:mod:`raycast_shade.study.ggx`), closed forms, energy, the units
(``E = pi Ii``), rendered pixels against the shading twin, the material's checks and glTF loading."""

from __future__ import annotations

import base64
import io
import json
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

import raycast_shade as rs
from raycast_shade.common import layout as lay
from raycast_shade.common.warnings import DroppedOnLoadWarning
from raycast_shade.shading import reflectance
from raycast_shade.study.ggx import ggx_parts_numpy, ggx_terms_numpy
from raycast_shade.study.reference import shade_reference


@njit(cache=False)
def _terms_many(n, S, v, c, p):
    """The kernel's GGX terms (through the dispatchers) for each row of S: (N, 6) diffuse | specular."""
    out = np.zeros((S.shape[0], 6))
    for i in range(S.shape[0]):
        s = (S[i, 0], S[i, 1], S[i, 2])
        ndots = n[0] * s[0] + n[1] * s[1] + n[2] * s[2]
        if ndots <= 0.0:
            continue
        ndots = min(ndots, 1.0)
        d = reflectance._diffuse(lay.MODEL_GGX, n, s, v, ndots, c, p, np.bool_(True))
        t = reflectance._specular(lay.MODEL_GGX, n, s, v, ndots, c, p, np.bool_(True))
        out[i, 0], out[i, 1], out[i, 2] = d
        out[i, 3], out[i, 4], out[i, 5] = t
    return out


def _coef(base, metal_map=1.0, rough_map=1.0):
    """The kernel's 12-tuple: ka, kd (the base colour), ks (the map's scales: -, roughness, metallic), ke."""
    return (0.0, 0.0, 0.0, *map(float, base), 1.0, float(rough_map), float(metal_map), 0.0, 0.0, 0.0)


def _kernel(n, S, v, base, metallic, roughness, maps=(1.0, 1.0)):
    out = _terms_many(tuple(map(float, n)), np.ascontiguousarray(S, np.float64), tuple(map(float, v)),
                      _coef(base, *maps), (32.0, float(metallic), float(roughness)))
    return out[:, :3], out[:, 3:]


def _unit(a):
    a = np.asarray(a, np.float64)
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


unit3 = st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda a: np.linalg.norm(a) > 0.1).map(_unit)
unit01 = st.floats(0.0, 1.0)


@settings(max_examples=150, deadline=None)
@given(n=unit3, s=unit3, v=unit3, base=st.tuples(unit01, unit01, unit01), metallic=unit01, roughness=unit01,
       maps=st.tuples(unit01, unit01))
def test_the_kernels_terms_are_the_float64_twins(n, s, v, base, metallic, roughness, maps):
    """Any directions and factors, the metallicRoughness map's scales included: the kernel's diffuse and
    specular terms are the twin's written from the spec, to float64 rounding: relative 1e-12, but for the
    peak of a smooth lobe, where D's ``(n.h)^2 (alpha^2 - 1) + 1`` cancels to ``alpha^2`` (the rounding of
    ``n.h`` grows by ``1 / alpha^2``: 16 ulps over alpha^2)."""
    if n @ s <= 1e-9:
        s = -s if -(n @ s) > 1e-9 else _unit(n + 0.5 * s)
    d, t = _kernel(n, s[None], v, base, metallic, roughness, (maps[1], maps[0]))
    gd, gt = ggx_terms_numpy(n[None], s[None], v[None], np.array([base], np.float64),
                             np.array([metallic * maps[1]]), np.array([roughness * maps[0]]))
    np.testing.assert_allclose(d, gd, rtol=1e-12, atol=1e-15)
    a2 = max(roughness * maps[0], 0.045) ** 4
    np.testing.assert_allclose(t, gt, rtol=1e-12 + 16 * np.finfo(float).eps / a2, atol=1e-15)


def test_head_on_the_terms_are_the_closed_form_and_fresnel_is_f0():
    """n = s = v: v.h = 1, so F = F0 = mix(0.04, base, m); D = 1 / (pi alpha^2), V = 1/4: the pixel per unit
    light is (1 - F0)(1 - m) base + F0 / (4 alpha^2) (E = pi Ii cancels the spec's 1/pi)."""
    n = np.array([0.0, 0.0, 1.0])
    base = np.array([0.9, 0.5, 0.1])
    for m, r in ((0.0, 0.5), (1.0, 0.3), (0.4, 1.0), (0.7, 0.8)):
        d, t = _kernel(n, n[None], n, base, m, r)
        f0 = 0.04 * (1 - m) + base * m
        np.testing.assert_allclose(d[0], (1 - f0) * (1 - m) * base, rtol=1e-14)
        np.testing.assert_allclose(t[0], f0 / (4 * r ** 4), rtol=1e-13)
    d, t = _kernel(n, n[None], n, base, 1.0, 0.5)
    assert np.all(d == 0.0)  # a metal has no diffuse term
    np.testing.assert_allclose(t[0] / t[0].sum(), base / base.sum(), rtol=1e-13)  # coloured by its base
    d, t = _kernel(n, n[None], n, base, 0.0, 0.5)
    assert t[0, 0] == t[0, 1] == t[0, 2]  # a dielectric's highlight is white (F0 = 0.04 on every channel)


def test_roughness_one_and_grazing_fresnel_in_closed_form():
    """alpha = 1: D = 1/pi whatever h, so the specular term is F (n.s) / (2 ((n.s) + (n.v))); and Schlick's F
    tends to 1 at grazing v.h (s = v grazing the surface)."""
    rng = np.random.default_rng(3)
    n = np.array([0.0, 0.0, 1.0])
    S = _unit(rng.normal(size=(200, 3)) + [0, 0, 1.5])
    v = _unit([0.3, -0.2, 0.8])
    base = np.array([0.2, 0.6, 1.0])
    _, t = _kernel(n, S, v, base, 0.0, 1.0)
    lit = S[:, 2] > 0
    h = _unit(S + v)
    F = 0.04 + 0.96 * (1 - np.clip(h @ v, 0, 1)) ** 5
    want = F * S[:, 2] / (2 * (S[:, 2] + v[2]))
    np.testing.assert_allclose(t[lit, 0], want[lit], rtol=1e-12)
    g = _unit([1.0, 0.0, 1e-9])  # grazing: v.h = 1 but the half vector lies along the surface
    opposite = _unit([-1.0, 0.0, 1e-3])
    _, t = _kernel(n, opposite[None], g, base, 0.0, 0.5)
    d, _ = _kernel(n, opposite[None], g, base, 0.0, 0.5)
    assert np.all(d[0] < 1e-3 * base)  # (1 - F) -> 0 as v.h -> 0: F -> 1


def test_the_distribution_is_normalised_and_the_lobe_never_creates_energy():
    """Exact: the Trowbridge-Reitz D integrates to 1 over the projected hemisphere of h, and a white metal of
    roughness 1 seen head-on reflects 1 - ln 2 of the light (D = 1/pi, V = 1 / (2 (n.s + 1)): the albedo is
    int_0^1 mu / (mu + 1) d(mu)). Bounds: the kernel's white metal never reflects more than arrives, for any
    roughness and view, and a smooth one loses little (Smith's single scattering). A white dielectric head-on
    stays <= 1; at grazing views the spec's Fresnel mix is not energy-conserving (docs/pbr.md), which the
    kernel shares with the twin (test above)."""
    th = np.linspace(0, np.pi / 2, 400001)
    for r in (0.3, 0.6, 1.0):
        hs = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], 1)
        D, _, _ = ggx_parts_numpy(np.tile([0, 0, 1.0], (len(th), 1)), hs, hs, np.full(len(th), r))
        total = 2 * np.pi * np.trapezoid(D * np.cos(th) * np.sin(th), th)
        assert total == pytest.approx(1.0, abs=2e-6)
    # Quadrature over the hemisphere of s, uniform in u = sin^2(theta) and phi: cos(theta) d(omega) uniform.
    nu, nphi = 600, 400
    u = (np.arange(nu) + 0.5) / nu
    phi = 2 * np.pi * (np.arange(nphi) + 0.5) / nphi
    ct, st_ = np.sqrt(1 - u), np.sqrt(u)
    S = np.stack([np.outer(st_, np.cos(phi)).ravel(), np.outer(st_, np.sin(phi)).ravel(),
                  np.repeat(ct, nphi)], 1)
    d_omega = np.pi / (nu * nphi) / np.repeat(ct, nphi)
    n = np.array([0.0, 0.0, 1.0])
    albedo = {}
    for m, r, tv in [(m, r, tv) for m in (0.0, 1.0) for r in (0.3, 0.6, 1.0) for tv in (0.0, 1.0, 1.4)]:
        v = np.array([np.sin(tv), 0.0, np.cos(tv)])
        d, t = _kernel(n, S, v, np.ones(3), m, r)
        albedo[m, r, tv] = float(((d + t)[:, 0] * d_omega).sum() / np.pi)  # the terms are pi f (n.s)
    assert albedo[1.0, 1.0, 0.0] == pytest.approx(1.0 - np.log(2.0), abs=1e-4)
    assert all(0.25 < a <= 1.0 for (m, _, _), a in albedo.items() if m == 1.0)
    assert albedo[1.0, 0.3, 0.0] > 0.98
    assert all(0.95 < albedo[0.0, r, 0.0] <= 1.0 for r in (0.3, 0.6, 1.0))


def _plane_scene(material, intensity=1.5, ambient=0.0):
    """A plane facing +z, an orthographic camera and a directional light both straight above it."""
    cam = rs.Camera(eye=(0, 0, 4), target=(0, 0, 0), up=(0, 1, 0), width=16, height=12,
                    projection="orthographic", ortho_height=1.0)
    light = rs.DirectionalLight((0, 0, -1), intensity=intensity)
    return rs.Scene([rs.Model(rs.shapes.plane(size=4.0), material)], lights=[light], camera=cam,
                    ambient=ambient), cam


def test_units_a_light_of_intensity_ii_gives_the_lectures_lambert_and_the_closed_form():
    """Head-on, every pixel is Ia ka + Ii ((1 - F0)(1 - m) base + F0 / (4 alpha^2)): the glTF BRDF under the
    irradiance pi Ii. A rough white dielectric thus shows 0.96 Ii + 0.01 Ii (the lecture's white Lambert:
    Ii), and a metal's pixel has no diffuse part."""
    for base, m, r in (((1.0, 1.0, 1.0), 0.0, 1.0), ((0.8, 0.4, 0.2), 0.0, 0.5), ((0.9, 0.6, 0.3), 1.0, 0.6)):
        mat = rs.Material(kd=base, ka=0.5, specular="ggx", metallic=m, roughness=r)
        scene, cam = _plane_scene(mat, intensity=1.5, ambient=0.2)
        img = rs.render(scene).image
        base = np.array(base)
        f0 = 0.04 * (1 - m) + base * m
        want = 0.2 * 0.5 + 1.5 * ((1 - f0) * (1 - m) * base + f0 / (4 * r ** 4))
        np.testing.assert_allclose(img.reshape(-1, 3), np.broadcast_to(want, (img.size // 3, 3)), rtol=2e-7)
    assert want[0] > want[2]  # the metal's highlight has its colour


@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong"])
def test_rendered_pixels_are_the_shading_twins(shading):
    """A GGX sphere beside a Phong one, a point and a spot light: every method's pixels against
    :func:`shade_reference` (float64; the image is float32)."""
    cam = rs.Camera(eye=(0.4, 0.6, 4.0), width=64, height=48, fov=40)
    models = [rs.Model(rs.shapes.icosphere(2, center=(-0.6, 0, 0), radius=0.55),
                       rs.Material(kd=(0.9, 0.6, 0.2), specular="ggx", metallic=0.6, roughness=0.35)),
              rs.Model(rs.shapes.icosphere(2, center=(0.6, 0, 0), radius=0.55),
                       rs.Material(kd=0.6, ks=0.4, shininess=30))]
    lights = [rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square"),
              rs.DirectionalLight((1, -0.5, -1), intensity=0.4, color=(0.5, 0.7, 1.0))]
    scene = rs.Scene(models, lights=lights, camera=cam, ambient=0.05)
    frame = rs.render(scene, shading)
    ref = shade_reference(scene, cam, frame.hits, shading)
    hit = frame.hits.prim >= 0
    assert hit.sum() > 500
    err = np.abs(frame.image - ref)[hit].max()
    assert err <= 2e-6 * max(1.0, ref[hit].max()), err


def test_the_material_refuses_what_its_model_would_ignore():
    with pytest.raises(ValueError, match=r"m\.ks: specular='ggx' has no ks"):
        rs.Material(name="m", specular="ggx", ks=0.5)
    with pytest.raises(ValueError, match=r"m\.shininess"):
        rs.Material(name="m", specular="ggx", shininess=10)
    with pytest.raises(ValueError, match=r"m\.metallic: given with specular='phong'"):
        rs.Material(name="m", metallic=1.0)
    with pytest.raises(ValueError, match=r"m\.roughness"):
        rs.Material(name="m", specular="blinn", roughness=0.2)
    with pytest.raises(ValueError, match=r"m\.roughness"):
        rs.Material(name="m", specular="ggx", roughness=1.5)
    srgb = rs.Texture.from_array(np.full((2, 2, 3), 128, np.uint8))
    with pytest.raises(ValueError, match=r"m\.metallic_roughness_map.*srgb=False"):
        rs.Material(name="m", specular="ggx", metallic_roughness_map=srgb)
    with pytest.raises(TypeError, match=r"m\.metallic_roughness_map"):
        rs.Material(name="m", specular="ggx", metallic_roughness_map="mr.png")
    lin = rs.Texture.from_array(np.full((2, 2, 3), 128, np.uint8), srgb=False)
    mat = rs.Material(specular="ggx", metallic_roughness_map=lin)
    assert mat.maps[lay.TEXMAP_KS] is lin and mat.has_specular


def _png_uri(rgb):
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.asarray(rgb, np.uint8)).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def _write_gltf(path, mr_texel=(0, 128, 255)):
    """A textured quad whose material is metallic-roughness: base colour factor, factors and a 2 x 2
    metallicRoughnessTexture of one texel value (R unused, G roughness, B metallic)."""
    pos = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    nor = np.tile(np.array([0, 0, 1], np.float32), (4, 1))
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    blob = pos.tobytes() + nor.tobytes() + uv.tobytes() + idx.tobytes()
    views = [dict(buffer=0, byteOffset=0, byteLength=48), dict(buffer=0, byteOffset=48, byteLength=48),
             dict(buffer=0, byteOffset=96, byteLength=32), dict(buffer=0, byteOffset=128, byteLength=12)]
    acc = [dict(bufferView=0, componentType=5126, count=4, type="VEC3", min=[-1, -1, 0], max=[1, 1, 0]),
           dict(bufferView=1, componentType=5126, count=4, type="VEC3"),
           dict(bufferView=2, componentType=5126, count=4, type="VEC2"),
           dict(bufferView=3, componentType=5123, count=6, type="SCALAR")]
    doc = dict(asset=dict(version="2.0"), scene=0, scenes=[dict(nodes=[0])], nodes=[dict(mesh=0)],
               meshes=[dict(primitives=[dict(attributes=dict(POSITION=0, NORMAL=1, TEXCOORD_0=2), indices=3,
                                             material=0)])],
               materials=[dict(name="brass", pbrMetallicRoughness=dict(
                   baseColorFactor=[0.9, 0.7, 0.3, 1.0], metallicFactor=0.8, roughnessFactor=0.6,
                   metallicRoughnessTexture=dict(index=0)))],
               textures=[dict(source=0)], images=[dict(uri=_png_uri(np.tile(mr_texel, (2, 2, 1))))],
               buffers=[dict(byteLength=len(blob),
                             uri="data:application/octet-stream;base64," + base64.b64encode(blob).decode())],
               bufferViews=views, accessors=acc)
    path.write_text(json.dumps(doc))
    return path


def test_load_models_keeps_a_gltf_material_as_itself_with_reflectance_pbr(tmp_path):
    path = _write_gltf(tmp_path / "quad.gltf")
    with pytest.warns(DroppedOnLoadWarning, match="metallicRoughnessTexture: per-texel kd and ks"):
        phong = rs.load_models(path)[0].material
    assert phong.specular == "blinn"  # the default mapping is unchanged
    with warnings.catch_warnings():
        warnings.simplefilter("error", DroppedOnLoadWarning)  # nothing of the material is lost
        mat = rs.load_models(path, reflectance="pbr")[0].material
    assert mat.specular == "ggx" and (mat.metallic, mat.roughness) == (0.8, 0.6)
    np.testing.assert_allclose(mat.kd, [0.9, 0.7, 0.3], atol=0.5 / 255)  # trimesh keeps the factor in 8 bits
    texel = mat.metallic_roughness_map.texels[0, 0]
    np.testing.assert_allclose(texel[1:], [128 / 255, 1.0], atol=1e-6)  # linear: not decoded from sRGB
    # The quad head-on under a unit light: the closed form with m = 0.8 * 1, r = 0.6 * 128/255.
    scene, _ = _plane_scene(mat, intensity=1.0)
    model = rs.load_models(path, reflectance="pbr")[0]
    cam = rs.Camera(eye=(0, 0, 4), target=(0, 0, 0), width=8, height=6, projection="orthographic",
                    ortho_height=1.0)
    img = rs.render(rs.Scene([model], lights=[rs.DirectionalLight((0, 0, -1))], camera=cam, ambient=0.0)).image
    m, r, base = 0.8, 0.6 * 128 / 255, mat.kd
    f0 = 0.04 * (1 - m) + base * m
    np.testing.assert_allclose(img[3, 4], (1 - f0) * (1 - m) * base + f0 / (4 * r ** 4), rtol=1e-5)
    with pytest.raises(ValueError, match="reflectance"):
        rs.load_models(path, reflectance="ggx")


def test_reflectance_pbr_on_a_file_without_metallic_roughness_says_so(tmp_path):
    obj = tmp_path / "tri.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.warns(DroppedOnLoadWarning, match="reflectance='pbr'"):
        models = rs.load_models(obj, reflectance="pbr")
    assert models[0].material.specular == "phong"


def test_the_cli_renders_a_gltf_with_reflectance_pbr(tmp_path, capsys):
    """``raycast-shade render FILE --reflectance pbr``: glTF's own BRDF (the metal's highlight takes its base
    colour, so the image differs from the Phong mapping's); a scene file refuses the flag on one line."""
    import imageio.v3 as iio

    from raycast_shade.apps.cli import main

    path = _write_gltf(tmp_path / "quad.gltf")
    outs = []
    for extra in ([], ["--reflectance", "PBR"]):
        out = tmp_path / f"q{len(outs)}.png"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DroppedOnLoadWarning)  # the Phong mapping's approximation note
            assert main(["render", str(path), "-o", str(out), "--width", "32", "--height", "24", *extra]) == 0
        outs.append(iio.imread(out).astype(int))
    assert np.abs(outs[0] - outs[1]).max() > 10
    toml = tmp_path / "s.toml"
    toml.write_text('[[object]]\nshape = "icosphere"\n')
    assert main(["render", str(toml), "-o", str(tmp_path / "s.png"), "--reflectance", "pbr"]) != 0
    err = capsys.readouterr().err
    assert "--reflectance: for a mesh file; a scene file gives each [[object]] its material" in err


def test_explain_refuses_a_ggx_pixel_by_name():
    """rs.explain writes out the lecture's terms: on a GGX pixel it says so rather than mislabel it Blinn."""
    scene, _ = _plane_scene(rs.Material(name="brass", kd=0.8, specular="ggx", metallic=1.0))
    frame = rs.render(scene)
    with pytest.raises(ValueError, match="brass.*specular='ggx'"):
        rs.explain(frame, 8, 6)
