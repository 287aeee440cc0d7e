"""render(..., terms=True): the reflectance equation's terms add up to the image in every mode,
each term has its closed form, and the shadow mask says where the shadow rays were blocked."""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.shading.terms import check_terms, compose_terms

EPS32 = float(np.finfo(np.float32).eps)
# The terms are each rounded to float32 and are non-negative, so their sum is within a few
# half-ulps of the image relative to the pixel: 3 terms + the mirror part, and the image's own rounding
# (these scenes emit nothing: the emissive term is exact zeros).
SUM_RTOL = 4 * EPS32


def _camera(w=48, h=36, eye=(0.0, 1.2, 4.0), target=(0.0, -0.3, 0.0)):
    return rs.Camera(eye=eye, target=target, width=w, height=h)


def _floor(**material):
    return rs.Model(rs.shapes.plane(6.0, subdivisions=4, center=(0.0, -1.0, 0.0), normal="+y"),
                    rs.Material(kd=0.6, ka=0.5, **material))


def lamp_scene(w=48, h=36):
    """A shiny sphere over a floor, a shadow-casting inverse-square lamp and a directional fill."""
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40)),
                     _floor()],
                    lights=[rs.PointLight((2.0, 3.0, 2.0), intensity=25.0, attenuation="inverse_square",
                                          shadows=True),
                            rs.DirectionalLight((0.3, -0.4, -1.0), intensity=0.4, color=(0.9, 0.9, 1.0))],
                    camera=_camera(w, h), ambient=0.1, background=(0.05, 0.1, 0.2))


def blinn_scene(w=48, h=36):
    """Blinn-Phong with a fractional exponent, the heuristic law, a cube casting a shadow, two shadow lights."""
    return rs.Scene([rs.Model(rs.shapes.icosphere(1, center=(-0.6, 0.0, 0.0)),
                              rs.Material(kd=0.7, ks=(0.6, 0.5, 0.4), shininess=15.5, specular="blinn")),
                     rs.Model(rs.shapes.cube(0.8, center=(0.9, -0.5, 0.3)), rs.Material(kd=(0.2, 0.6, 0.3), ks=0.3)),
                     _floor(ks=0.2, shininess=8)],
                    lights=[rs.PointLight((-1.0, 3.0, 3.0), intensity=6.0, attenuation="heuristic", k=0.5,
                                          shadows=True),
                            rs.DirectionalLight((-0.5, -1.0, -0.2), intensity=0.5, shadows=True)],
                    camera=_camera(w, h), ambient=(0.1, 0.1, 0.15))


def bump_scene(w=48, h=36):
    """A dimpled sphere (Blinn bump map), a point light without attenuation."""
    bump = rs.HeightMap.dimples(6, 0.35, resolution=64, scale=0.02, tiling=(2.0, 2.0))
    return rs.Scene([rs.Model(rs.shapes.icosphere(3), rs.Material(kd=0.8, ks=0.4, shininess=30, bump=bump))],
                    lights=[rs.PointLight((2.0, 2.0, 3.0), intensity=1.2, shadows=True)],
                    camera=_camera(w, h, eye=(0.0, 0.0, 3.2), target=(0.0, 0.0, 0.0)), ambient=0.05)


def mirror_scene(w=48, h=36):
    """A half-mirror floor under a sphere: local terms * (1 - rho) + reflected."""
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40,
                                                                  reflectivity=0.2)),
                     _floor(reflectivity=0.5)],
                    lights=[rs.PointLight((2.0, 3.0, 2.0), intensity=25.0, attenuation="inverse_square",
                                          shadows=True)],
                    camera=_camera(w, h), ambient=0.1, background=(0.3, 0.4, 0.5))


SCENES = {"lamp": lamp_scene, "blinn": blinn_scene, "bump": bump_scene, "mirror": mirror_scene}
MODES = ("flat", "gouraud", "phong")


def render_quiet(scene, shading, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.ShadingWarning)  # bump maps ignored by flat and Gouraud, on purpose
        return rs.render(scene, shading, **kwargs)


@pytest.fixture(scope="module")
def frames():
    """Every scene in every mode (and one mixed), with all terms."""
    out = {}
    for name, make in SCENES.items():
        scene = make()
        for mode in MODES:
            out[name, mode] = render_quiet(scene, mode, terms="per_light")
    scene = lamp_scene()
    out["lamp", "mixed"] = render_quiet(scene, ("gouraud", "phong"), terms="per_light")
    return out


def _rel_err(a, b):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return np.abs(a - b) / np.maximum(np.abs(b), 1e-30)


CASES = [(name, mode) for name in SCENES for mode in MODES] + [("lamp", "mixed")]


@pytest.mark.parametrize("name, mode", CASES)
def test_terms_add_up_to_the_image(frames, name, mode):
    f = frames[name, mode]
    total = compose_terms(f.terms)
    err = _rel_err(total, f.image)
    zero = f.image == 0
    assert np.all(total[zero] == 0)
    assert err[~zero].max() <= SUM_RTOL, (name, mode, err.max())


@pytest.mark.parametrize("name", list(SCENES))
def test_per_light_terms_add_up_to_the_summed_terms(frames, name):
    for mode in MODES:
        t = frames[name, mode].terms
        for term in ("diffuse", "specular"):
            per = t[f"{term}_per_light"].astype(np.float64).sum(axis=0)
            np.testing.assert_allclose(per, t[term], rtol=3 * EPS32, atol=1e-12)


def test_terms_leave_the_image_bit_identical():
    scene = mirror_scene()
    for mode in MODES:
        a = rs.render(scene, mode)
        b = rs.render(scene, mode, terms=True)
        np.testing.assert_array_equal(a.image, b.image)
        assert a.terms == {} and set(b.terms) == {"ambient", "diffuse", "specular", "emissive", "reflected",
                                                  "background", "keep", "shadow"}
        assert "terms" in b.timings


def test_ambient_is_ia_ka_on_every_hit_pixel(frames):
    for mode in MODES:
        f = frames["lamp", mode]
        ka = np.array([1.0, 0.5])[f.hits.geom[f.mask]]  # the sphere's ka = 1, the floor's 0.5
        expected = (0.1 * ka)[:, None] * np.ones(3)
        np.testing.assert_allclose(f.terms["ambient"][f.mask], expected, rtol=2 * EPS32)
        assert np.all(f.terms["ambient"][~f.mask] == 0)
        np.testing.assert_array_equal(f.terms["background"][~f.mask], np.broadcast_to(
            np.float32([0.05, 0.1, 0.2]), (int((~f.mask).sum()), 3)))


def test_flat_diffuse_of_a_plane_under_a_light_at_infinity_is_lambert():
    # One face normal (0, 0, 1), s = (0, 0.6, 0.8): I_d = Ii kd (n.s) = 2 * 0.5 * 0.8 everywhere.
    scene = rs.Scene([rs.Model(rs.shapes.plane(2.0), rs.Material(kd=0.5, ka=0.3, ks=0.7, shininess=5))],
                     lights=[rs.DirectionalLight((0.0, -0.6, -0.8), intensity=2.0)],
                     camera=rs.Camera(eye=(0.0, 0.0, 3.0), width=24, height=24), ambient=0.2)
    f = rs.render(scene, "flat", terms=True)
    m = f.mask
    assert m.sum() > 100
    np.testing.assert_allclose(f.terms["diffuse"][m], 0.8, rtol=EPS32)
    np.testing.assert_allclose(f.terms["ambient"][m], 0.06, rtol=EPS32)
    # Flat: one centre c and view vector per face: Ks Ii (r.v)^5 with r = 2 (n.s) n - s = (0, -0.6, 0.8).
    geo = scene.geometry
    for face in np.unique(f.hits.prim[m]):
        c = geo.vertices[geo.faces[face]].mean(axis=0) + geo.origin
        v = (np.array([0.0, 0.0, 3.0]) - c) / np.linalg.norm(np.array([0.0, 0.0, 3.0]) - c)
        expected = 0.7 * 2.0 * max(np.array([0.0, -0.6, 0.8]) @ v, 0.0) ** 5
        np.testing.assert_allclose(f.terms["specular"][m & (f.hits.prim == face)], expected, rtol=4 * EPS32)


def test_specular_is_zero_without_ks_and_diffuse_zero_without_kd():
    scene = lamp_scene()
    matt = scene.replace(models=(rs.Model(scene.models[0].mesh, rs.Material(kd=0.8, ks=0.0)),
                                 rs.Model(scene.models[1].mesh, rs.Material(kd=0.0, ks=0.5))))
    f = rs.render(matt, "phong", terms=True)
    sphere, floor = f.hits.geom == 0, f.hits.geom == 1
    assert np.all(f.terms["specular"][sphere] == 0) and np.all(f.terms["diffuse"][floor] == 0)
    assert f.terms["diffuse"][sphere].max() > 0 and f.terms["specular"][floor].max() > 0


def test_shadow_mask_is_zero_exactly_where_the_phong_light_is_blocked(frames):
    f = frames["lamp", "phong"]
    mask = f.terms["shadow"]
    assert mask.shape == (2,) + f.image.shape[:2]
    assert np.all(mask[1] == 1)  # the fill light casts no shadows
    shadowed = f.mask & (mask[0] == 0)
    assert shadowed.sum() > 10 and set(np.unique(mask[0])) == {0.0, 1.0}  # Phong: each pixel's own ray, 0 or 1
    # The sphere's shadow lies on the floor, and there the lamp adds nothing.
    assert np.all(f.hits.geom[shadowed & (f.hits.geom >= 0)] >= 0)
    lamp = f.terms["diffuse_per_light"][0] + f.terms["specular_per_light"][0]
    assert np.all(lamp[shadowed] == 0)
    assert np.all(lamp[f.mask & (mask[0] == 1) & (f.hits.geom == 1)].max(axis=-1) > 0)


def test_shadow_mask_per_method(frames):
    flat, gouraud = frames["blinn", "flat"], frames["blinn", "gouraud"]
    # Flat: the face centre's ray, one value per triangle.
    fm = flat.terms["shadow"][0]
    assert set(np.unique(fm)) <= {0.0, 1.0} and (fm[flat.mask] == 0).any()
    face = flat.hits.geom.astype(np.int64) * 100000 + flat.hits.prim
    for key in np.unique(face[flat.mask])[:50]:
        assert np.ptp(fm[face == key]) == 0
    # Gouraud: the vertices' rays interpolated: fractions in [0, 1], some strictly between.
    gm = gouraud.terms["shadow"]
    assert gm.min() >= 0 and gm.max() <= 1
    assert ((gm > 0.01) & (gm < 0.99)).any()
    assert np.all(gouraud.terms["shadow"][:, ~gouraud.mask] == 1)


def test_mirror_terms_keep_and_reflected(frames):
    for mode in MODES:
        f = frames["mirror", mode]
        keep, refl = f.terms["keep"], f.terms["reflected"]
        floor, sphere = f.hits.geom == 1, f.hits.geom == 0
        np.testing.assert_array_equal(keep[floor], np.float32(0.5))
        np.testing.assert_array_equal(keep[sphere], np.float32(0.8))
        assert np.all(keep[~f.mask] == 1) and np.all(refl[~f.mask] == 0)
        assert refl[floor].max() > 0
    # Without bounces the mirror part is gone and keep is 1: the local terms are the image.
    f = render_quiet(mirror_scene(), "phong", terms=True, max_depth=0)
    assert np.all(f.terms["keep"] == 1) and np.all(f.terms["reflected"] == 0)
    np.testing.assert_allclose(compose_terms(f.terms), f.image, rtol=SUM_RTOL)


def test_terms_argument_is_checked_before_rendering():
    assert check_terms(False) is None and check_terms(True) == ()
    assert check_terms("PER_LIGHT") == ("per_light",) and check_terms(["per_light"]) == ("per_light",)
    scene = lamp_scene(8, 6)
    with pytest.raises(ValueError, match="terms"):
        rs.render(scene, terms="per_pixel")
    with pytest.raises(TypeError, match="terms"):
        rs.render(scene, terms=3)
    with pytest.raises(ValueError, match="terms"):
        rs.render(scene, terms=[True])


def test_scene_without_lights_has_only_ambient():
    scene = lamp_scene(16, 12).replace(lights=())
    f = render_quiet(scene, "gouraud", terms="per_light")
    assert f.terms["shadow"].shape == (0, 12, 16) and f.terms["diffuse_per_light"].shape == (0, 12, 16, 3)
    assert np.all(f.terms["diffuse"] == 0) and np.all(f.terms["specular"] == 0)
    np.testing.assert_allclose(compose_terms(f.terms), f.image, rtol=SUM_RTOL)


def test_term_variants_share_the_frames_inputs_and_repack_nothing():
    """Each term's definition (study.variant_terms) shades a variant of the frame's kernel inputs:
    the packed arrays are the frame's own objects (nothing repacked), only the varied rows differ,
    and the compile-time flags are those a scene with those rows would have."""
    from raycast_shade.common.layout import LIGHT_SIZE, MAT_KS
    from raycast_shade.shading.inputs import prepare
    from raycast_shade.study.variant_terms import variant_inputs

    scene = lamp_scene(16, 12)
    k = prepare(scene, scene.camera)
    rows = k.materials.copy()
    rows[:, MAT_KS:MAT_KS + 3] = 0.0  # no specular anywhere
    v = variant_inputs(k, scene.geometry.origin, materials=rows, lights=())
    assert v.geometry is k.geometry and v.bumps is k.bumps and v.cam is k.cam and v.colours is k.colours
    assert v.materials is not k.materials and np.array_equal(v.materials, rows)
    assert v.lighting.lights.shape == (0, LIGHT_SIZE) and v.lighting.handle == 0 and not v.spec_on
    assert np.array_equal(v.background, [0.0, 0.0, 0.0])
    lit = variant_inputs(k, scene.geometry.origin, lights=scene.lights)
    np.testing.assert_array_equal(lit.lighting.lights, k.lighting.lights)
    assert lit.lighting.handle == k.lighting.handle != 0 and lit.spec_on == k.spec_on and lit.att_on == k.att_on
    # The terms from the frame's inputs are the terms packed afresh, bit for bit.
    from raycast_shade.shading.terms import shade_terms

    hits = rs.cast_camera(scene.geometry, scene.camera)
    a = shade_terms(scene, scene.camera, hits, "phong", per_light=True, inputs=k)
    b = shade_terms(scene, scene.camera, hits, "phong", per_light=True)
    assert set(a) == set(b)
    for name in a:
        np.testing.assert_array_equal(a[name], b[name])


def _flipped_normals_scene():
    """lamp_scene whose sphere has every third vertex normal reversed: Gouraud shades those
    corners on the spot (the stored vertex shade does not serve the face)."""
    scene = lamp_scene(32, 24)
    ico = rs.shapes.icosphere(2)
    normals = ico.normals.copy()
    normals[::3] *= -1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = rs.Mesh(ico.vertices, ico.faces, normals=normals)
    return scene.replace(models=(rs.Model(mesh, scene.models[0].material), scene.models[1]))


def _coloured_textured_scene(mode, w=32, h=24):
    """Maps on ka, kd, ks, vertex or face colours, three kinds of light (two casting shadows)."""
    from raycast_shade.scene.texture import Texture

    rng = np.random.default_rng(5)
    base = rs.shapes.uv_sphere(12, 20)
    n = len(base.vertices) if mode == "vertex" else len(base.faces)
    sphere = rs.Mesh(base.vertices, base.faces, normals=base.normals, uvs=base.uvs,
                     colors=rng.uniform(0.0, 1.0, (n, 3)), color_mode=mode)
    mats = (rs.Material(kd_map=Texture.checker(8, 4), ks=0.4, ks_map=Texture.checker(4, 4), shininess=20),
            rs.Material(ka_map=Texture.checker(4, 8), kd=0.6, ks=0.2, specular="blinn"))
    lights = [rs.PointLight((1.5, 2.5, 1.5), intensity=12.0, attenuation="inverse_square", shadows=True),
              rs.SpotLight((-1.0, 2.0, 2.5), direction=(1.0, -2.0, -2.5), intensity=4.0, attenuation="heuristic",
                           k=0.5, shadows=True, inner_angle=12.0, outer_angle=25.0),
              rs.DirectionalLight((-0.4, -1.0, -0.5), intensity=0.5)]
    return rs.Scene([rs.Model(sphere, mats[0]), rs.Model(_floor().mesh, mats[1])], lights=lights,
                    camera=_camera(w, h), ambient=(0.1, 0.05, 0.2))


@pytest.mark.parametrize("mode", ["phong", "flat", "gouraud"])
@pytest.mark.parametrize("make", [lambda: lamp_scene(32, 24), lambda: bump_scene(32, 24),
                                  lambda: _coloured_textured_scene("vertex"), lambda: _coloured_textured_scene("face"),
                                  lambda: _flipped_normals_scene()],
                         ids=["lamp", "bump", "vertex_colours_maps", "face_colours_maps", "flipped_normals"])
def test_one_pass_terms_are_the_variant_passes(make, mode):
    """The one-pass terms (shading.termshade, the image's own pass) against their definition, one
    shading pass per term, light and shadow probe: within 2 float32 ulp (measured: equal), the
    shadow masks equal, and the image the plain one, bit for bit. Gouraud's corners whose vertex
    normal points away from the face (flipped_normals) are shaded on the spot, terms too."""
    from raycast_shade.shading.inputs import prepare
    from raycast_shade.shading.shade import SampleShading
    from raycast_shade.shading.termshade import TermShading
    from raycast_shade.study.variant_terms import variant_terms

    scene = make()
    k = prepare(scene, scene.camera)
    hits = rs.cast_camera(scene.geometry, scene.camera)
    shader = TermShading(scene, scene.camera, mode, k, per_light=True)
    image = shader.shade(hits)
    np.testing.assert_array_equal(image, SampleShading(scene, scene.camera, mode, k).shade(hits))
    one = shader.terms(hits)
    many = variant_terms(scene, scene.camera, mode, hits, k, per_light=True)
    assert set(many) < set(one)
    assert (one["specular"] > 0).any() and (one["diffuse_per_light"] > 0).any()
    # Blocked pixels in every scene (Phong's bumps shadow themselves; flat's faces and Gouraud's
    # vertices do not), Gouraud's fractions in between.
    assert (one["shadow"] == 0).any() or (mode != "phong" and scene.models[0].material.bump is not None)
    if mode == "gouraud" and scene.models[0].material.bump is None:
        assert ((one["shadow"] > 0.01) & (one["shadow"] < 0.99)).any()
    np.testing.assert_array_equal(one["shadow"], many["shadow"])
    for name in ("ambient", "diffuse", "specular", "diffuse_per_light", "specular_per_light"):
        np.testing.assert_array_max_ulp(one[name], many[name], maxulp=2)


@pytest.fixture
def small_bands(monkeypatch):
    """The band path for these small frames, in bands of 16 rows (several per frame)."""
    from raycast_shade.visibility import bands

    monkeypatch.setattr(bands, "BAND_ROWS", 16)
    monkeypatch.setattr(bands, "MIN_PIXELS", 0)


def _glowing_lamp_scene():
    """lamp_scene with an emitting sphere (the emissive term written) on its coloured background."""
    scene = lamp_scene(40, 52)
    glow = rs.Model(scene.models[0].mesh, rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40, ke=(0.2, 0.1, 0.0)))
    return scene.replace(models=(glow, scene.models[1]))


@pytest.mark.usefixtures("small_bands")
@pytest.mark.parametrize("shading", ["phong", "flat", "gouraud", "mixed"])
@pytest.mark.parametrize("make", [_glowing_lamp_scene, lambda: _coloured_textured_scene("vertex", 40, 52),
                                  lambda: blinn_scene(40, 52)], ids=["glow", "textured", "blinn"])
def test_banded_terms_are_the_whole_frames_bit_for_bit(make, shading):
    """The terms are written band by band, in the image's own pass: the image and every term
    are the whole-frame path's, bit for bit, and the frame keeps no hit buffer."""
    RENDER = sys.modules["raycast_shade.render"]  # the module (rs.render is the function)
    scene = make()
    if shading == "mixed":
        shading = ("gouraud", "phong", "flat")[:len(scene.models)]
    banded = render_quiet(scene, shading, terms="per_light")
    saved = RENDER._banded
    try:
        RENDER._banded = lambda *a: False
        whole = render_quiet(scene, shading, terms="per_light")
    finally:
        RENDER._banded = saved
    assert callable(banded.__dict__["_hits"]) and not callable(whole.__dict__["_hits"])
    np.testing.assert_array_equal(banded.image, whole.image)
    np.testing.assert_array_equal(banded.image, render_quiet(scene, shading).image)
    assert list(banded.terms) == list(whole.terms)
    for name in whole.terms:
        np.testing.assert_array_equal(banded.terms[name], whole.terms[name], err_msg=name)
    assert (banded.terms["shadow"] < 1).any() and (banded.terms["specular"] > 0).any()
    np.testing.assert_allclose(compose_terms(banded.terms), banded.image, rtol=6 * EPS32, atol=1e-7)
    if make is _glowing_lamp_scene:  # both optional terms written: the emission and the background
        assert (banded.terms["emissive"][banded.hits.geom == 0][:, :2] > 0).all()
        assert (banded.terms["background"][~banded.mask] > 0).all()


@pytest.mark.parametrize("shading", ["flat", "gouraud", "mixed"])
def test_a_frame_reuses_the_last_frames_face_and_vertex_records(shading):
    """The mesh-sized face and vertex records go back to the geometry's spares when the frame
    is done, and the next terms frame of the scene writes into them: poisoned with NaN in
    between, another view's image and terms are still those of fresh records, bit for bit."""
    from raycast_shade.shading.termshade import _SPARES

    scene = _coloured_textured_scene("vertex", 40, 30)
    if shading == "mixed":
        shading = ("gouraud", "flat")
    other = scene.camera.replace(eye=(1.5, 2.0, 3.0))
    render_quiet(scene, shading, terms="per_light")
    spares = scene.geometry.memo(_SPARES, lambda _: {})
    kept = [arrays for _, arrays in spares.values()]
    assert len(kept) == (2 if isinstance(shading, tuple) else 1)
    for arrays in kept:
        for a in arrays:
            a.fill(np.nan)
    reused = render_quiet(scene, shading, camera=other, terms="per_light")
    again = [arrays for _, arrays in spares.values()]
    assert len(again) == len(kept) and all(any(a is b for b in kept) for a in again)  # the same records
    spares.clear()  # fresh records
    fresh = render_quiet(scene, shading, camera=other, terms="per_light")
    np.testing.assert_array_equal(reused.image, fresh.image)
    assert list(reused.terms) == list(fresh.terms)
    for name in fresh.terms:
        np.testing.assert_array_equal(reused.terms[name], fresh.terms[name], err_msg=name)
    assert not np.isnan(reused.terms["diffuse"]).any() and (reused.terms["diffuse"] > 0).any()
    # Another light count: its records replace the spares of the same kind, not beside them.
    render_quiet(scene.replace(lights=scene.lights[:1]), shading, terms="per_light")
    assert len(spares) == len(kept) and all(key[2] == 1 for key, _ in spares.values())
