"""rs.diagnose: the variant shader is our renderer, each candidate is the mistake it names, and the
diagnosis is a classifier that finds them (docs/diagnose.md)."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.diagnose import Diagnoser
from raycast_shade.study.diagnose import Mistake, catalogue, encode, shade_variant
from raycast_shade.visibility.rays import subpixel_camera

W, H = 96, 72


def _sphere(**cam):
    return rs.Scene([rs.Model(rs.shapes.icosphere(3), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
                    lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")],
                    camera=rs.Camera(eye=(0, 0, 4), width=W, height=H, **cam), ambient=0.1)


def _torus():
    return rs.Scene([rs.Model(rs.shapes.torus(), rs.Material(kd=(0.2, 0.6, 0.3), ks=0.4, shininess=20,
                                                             specular="blinn"))],
                    lights=[rs.PointLight((2, 2, 3), intensity=6, attenuation="heuristic", k=1.0),
                            rs.DirectionalLight((-1, -1, -1), intensity=0.3, color=(0.2, 0.4, 1.0))],
                    camera=rs.Camera(eye=(0, 2.5, 3), width=W, height=H), ambient=0.05)


def _plane_two_lights():
    """A plane and a cube on it, lit by a point light with no attenuation and a spot light."""
    plane = rs.Model(rs.shapes.plane(size=3.0, subdivisions=8, normal="+y"),
                     rs.Material(kd=(0.5, 0.5, 0.7), ks=0.3, shininess=15))
    cube = rs.Model(rs.shapes.cube(0.8, center=(0, 0.4, 0)), rs.Material(kd=(0.9, 0.7, 0.2), ks=0.6, shininess=60))
    return rs.Scene([plane, cube],
                    lights=[rs.PointLight((1.5, 2, 1.5), intensity=0.8),
                            rs.SpotLight((-1, 2.5, 1), direction=(0.4, -1, -0.3), intensity=9,
                                         attenuation="inverse_square", exponent=4, inner_angle=25, outer_angle=40)],
                    camera=rs.Camera(eye=(0.5, 2.5, 3.5), target=(0, 0, 0), width=W, height=H), ambient=0.08)


SCENES = {"sphere": _sphere, "torus": _torus, "plane": _plane_two_lights}


@pytest.fixture(scope="module")
def scenes():
    return {k: f() for k, f in SCENES.items()}


# -- the variant shader is our renderer ---------------------------------------------------------------
@pytest.mark.parametrize("name", list(SCENES))
@pytest.mark.parametrize("method", ["flat", "gouraud", "phong"])
def test_correct_variant_reproduces_render(scenes, name, method):
    scene = scenes[name]
    frame = rs.render(scene, method)
    ours = shade_variant(scene, scene.camera, frame.hits, method, Mistake())
    assert frame.mask.sum() > 500
    np.testing.assert_allclose(ours, frame.image, atol=1e-5, rtol=0)


def test_orthographic_camera_reproduces_render():
    scene = _sphere(projection="orthographic", ortho_height=2.5)
    frame = rs.render(scene, "phong")
    np.testing.assert_allclose(shade_variant(scene, scene.camera, frame.hits, "phong"), frame.image, atol=1e-5)


def _variant(scene, method, mistake, hits=None):
    hits = hits if hits is not None else rs.render(scene, method).hits
    return shade_variant(scene, scene.camera, hits, method, mistake)


def test_method_and_2d_candidates_are_our_other_renders(scenes):
    scene = scenes["sphere"]
    hits = rs.render(scene, "phong").hits
    for other in ("flat", "gouraud"):
        np.testing.assert_allclose(_variant(scene, "phong", Mistake(method=other), hits),
                                   rs.render(scene, other).image, atol=1e-5)
    screen = rs.render(scene, "gouraud", interpolation="screen").image
    np.testing.assert_allclose(_variant(scene, "gouraud", Mistake(screen=True), hits), screen, atol=1e-5)


def test_term_candidates_are_our_render_of_a_changed_scene(scenes):
    scene = scenes["torus"]
    hits = rs.render(scene, "phong").hits
    no_amb = rs.render(scene.replace(ambient=0.0), "phong").image
    np.testing.assert_allclose(_variant(scene, "phong", Mistake(no_ambient=True), hits), no_amb, atol=1e-5)
    matte = [rs.Model(m.mesh, rs.Material(kd=m.material.kd, ks=0.0, shininess=m.material.shininess))
             for m in scene.models]
    np.testing.assert_allclose(_variant(scene, "phong", Mistake(no_specular=True), hits),
                               rs.render(scene.replace(models=matte), "phong").image, atol=1e-5)
    phong = [rs.Model(m.mesh, rs.Material(kd=m.material.kd, ks=m.material.ks, shininess=m.material.shininess,
                                          specular="phong")) for m in scene.models]
    np.testing.assert_allclose(_variant(scene, "phong", Mistake(specular="swap"), hits),
                               rs.render(scene.replace(models=phong), "phong").image, atol=1e-5)


@pytest.mark.parametrize("law", ["none", "heuristic"])
def test_attenuation_candidates_are_our_render_with_that_law(scenes, law):
    scene = scenes["sphere"]
    changed = scene.replace(lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation=law, k=1.0)])
    np.testing.assert_allclose(_variant(scene, "phong", Mistake(law=law)), rs.render(changed, "phong").image,
                               atol=1e-5)


def test_inverse_law_and_eye_distance_by_hand(scenes):
    """1/d and the eye's distance have no counterpart in our renderer: checked against the hand-made ratio."""
    scene = scenes["sphere"]
    frame = rs.render(scene, "phong")
    base = _variant(scene, "phong", Mistake(no_ambient=True), frame.hits)
    inv = _variant(scene, "phong", Mistake(no_ambient=True, law="inverse"), frame.hits)
    from raycast_shade.study.reference import hit_points

    pts = hit_points(scene, frame.hits)
    d_light = np.linalg.norm(pts - np.array([2.0, 3.0, 4.0]), axis=2)
    m = frame.mask
    np.testing.assert_allclose(inv[m], (base * d_light[..., None])[m], rtol=1e-9, atol=1e-12)
    eye = _variant(scene, "phong", Mistake(no_ambient=True, eye_distance=True), frame.hits)
    d_eye = np.linalg.norm(pts - scene.camera.eye, axis=2)
    np.testing.assert_allclose(eye[m], (base * (d_light / d_eye)[..., None] ** 2)[m], rtol=1e-9, atol=1e-12)


def test_half_pixel_candidate_is_our_render_through_the_corners(scenes):
    scene = scenes["plane"]
    corner = subpixel_camera(scene.camera, -0.5, -0.5)
    hits = rs.cast_camera(scene.geometry, scene.camera, offset=(-0.5, -0.5))
    np.testing.assert_allclose(_variant(scene, "phong", Mistake(half_pixel=True), hits),
                               rs.render(scene, "phong", camera=corner).image, atol=1e-5)


def test_light_in_camera_space_moves_the_light_with_the_camera(scenes):
    scene = scenes["sphere"]
    cam = scene.camera
    view = cam.view_matrix()  # world -> camera (OpenGL axes)
    world = np.linalg.solve(view, np.array([2.0, 3.0, 4.0, 1.0]))[:3]
    moved = scene.replace(lights=[rs.PointLight(world, intensity=20, attenuation="inverse_square")])
    np.testing.assert_allclose(_variant(scene, "phong", Mistake(light_in_camera=True)), rs.render(moved, "phong").image,
                               atol=1e-5)


def test_encodings_are_our_tone_mapping(scenes):
    scene = scenes["torus"]
    img = rs.render(scene, "phong").image
    assert np.array_equal(np.rint(encode(img) * 255), rs.to_uint8(img))
    assert np.array_equal(np.rint(encode(img, Mistake(encoding="linear")) * 255), rs.to_uint8(img, gamma=1.0))
    twice = rs.to_uint8(rs.to_uint8(img) / 255.0)
    assert np.abs(np.rint(encode(img, Mistake(encoding="double")) * 255) - twice).max() <= 1
    flipped = encode(img, Mistake(flip=True, bgr=True))
    assert np.array_equal(flipped, encode(img)[::-1, :, ::-1])


def test_unnormalised_vectors_by_hand():
    """One flat triangle facing the eye under a directional and a point light: n.s with |s| = d."""
    mesh = rs.Mesh(np.array([[-1.0, -1, 0], [1, -1, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    scene = rs.Scene([rs.Model(mesh, rs.Material(kd=0.5, ks=0.0))], lights=[rs.PointLight((0, 0, 3), intensity=0.1)],
                     camera=rs.Camera(eye=(0, 0, 5), width=W, height=H), ambient=0.0)
    hits = rs.render(scene, "phong").hits
    ok = _variant(scene, "phong", Mistake(), hits)
    raw = _variant(scene, "phong", Mistake(raw_s=True), hits)
    from raycast_shade.study.reference import hit_points

    p = hit_points(scene, hits)
    d = np.linalg.norm(p - np.array([0.0, 0, 3]), axis=2)
    m = hits.prim >= 0
    np.testing.assert_allclose(raw[m], (ok * d[..., None])[m], rtol=1e-9)  # n.(L - p) = d n.s


# -- the catalogue --------------------------------------------------------------------------------------
def test_catalogue_names_are_unique_and_every_candidate_has_a_slide(scenes):
    for method in ("flat", "gouraud", "phong"):
        cands = catalogue(method, scenes["plane"])
        names = [c.name for c in cands]
        assert len(names) == len(set(names))
        assert cands[0].correct and cands[0].mistake == Mistake()
        assert all(c.slide and c.text for c in cands)
    assert "n-unnormalised" in [c.name for c in catalogue("phong", scenes["sphere"])]
    assert "n-unnormalised" not in [c.name for c in catalogue("gouraud", scenes["sphere"])]
    # the scene's own law is no mistake
    assert "attenuation-inverse_square" not in [c.name for c in catalogue("phong", scenes["sphere"])]


def test_mistake_refuses_unknown_values():
    with pytest.raises(ValueError, match="Mistake.law"):
        Mistake(law="1/d^3")
    with pytest.raises(ValueError, match="Mistake.method"):
        Mistake(method="toon")


# -- the classifier -------------------------------------------------------------------------------------
def _student(diag, cand, rng, sigma=1.0):
    """The candidate's image as a student's 8-bit PNG would hold it, with noise."""
    img = diag.images[cand.name]
    return np.clip(np.rint(img + rng.normal(0.0, sigma, img.shape)), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("name,method", [("sphere", "phong"), ("torus", "gouraud"), ("plane", "phong"),
                                         ("plane", "flat")])
def test_every_candidate_is_diagnosed_as_itself(scenes, name, method):
    diag = Diagnoser(scenes[name], method)
    rng = np.random.default_rng(25)
    right, total = 0, 0
    for cand in diag.candidates:
        for _ in range(2):
            d = diag(_student(diag, cand, rng))
            total += 1
            if cand.correct:
                assert d.matches, (cand.name, d.verdict)
                right += 1
            else:
                right += cand.name in d.group
    assert right / total >= 0.95, (right, total)


def test_a_correct_image_matches_in_every_case(scenes):
    rng = np.random.default_rng(7)
    for name, scene in scenes.items():
        for method in ("flat", "gouraud", "phong"):
            frame = rs.render(scene, method)
            noisy = np.clip(frame.image + rng.normal(0, 0.002, frame.image.shape), 0, None)
            d = rs.diagnose(rs.to_uint8(noisy), scene, method)
            assert d.matches and d.best.correct, (name, method, d.verdict)


def _student_shader(scene, hits, *, ambient=True, normalise_s=True, normalise_r=True, gamma=True):
    """An independent Phong shader as a student writes it from the lecture: one point light, no attenuation
    factor other than the scene's 1/d^2, interpolated vertex normals, Phong's r (written for the sphere scene)."""
    geo = scene.geometry
    mat = scene.models[0].material
    light = scene.lights[0]
    m = hits.prim >= 0
    tri = geo.faces[hits.prim[m]]
    w = np.stack([1 - hits.u[m] - hits.v[m], hits.u[m], hits.v[m]], 1).astype(np.float64)
    p = np.einsum("nk,nkc->nc", w, geo.vertices[tri]) + geo.origin
    n = np.einsum("nk,nkc->nc", w, geo.normals[tri])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    L = light.position - p
    d = np.linalg.norm(L, axis=1, keepdims=True)
    s = L / d if normalise_s else L
    v = scene.camera.eye - p
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    ns = np.sum(n * s, axis=1, keepdims=True)
    r = 2 * ns * n - s
    if normalise_r:
        r /= np.linalg.norm(r, axis=1, keepdims=True)
    rv = np.clip(np.sum(r * v, axis=1, keepdims=True), 0, None)
    spec = np.where(ns > 0, rv ** mat.shininess, 0.0)
    colour = light.intensity / d ** 2 * (mat.kd * np.clip(ns, 0, None) + mat.ks * spec)
    if ambient:
        colour = colour + scene.ambient * mat.ka
    img = np.zeros(hits.shape + (3,))
    img[m] = colour
    img = np.clip(img, 0, 1)
    if gamma:
        img = np.where(img <= 0.0031308, 12.92 * img, 1.055 * img ** (1 / 2.4) - 0.055)
    return np.rint(img * 255).astype(np.uint8)


@pytest.mark.parametrize("kwargs,expected", [({}, "correct"), ({"ambient": False}, "no-ambient"),
                                             ({"gamma": False}, "no-srgb"),
                                             ({"normalise_s": False, "normalise_r": False}, "s-unnormalised"),
                                             # r = r/|r| undoes |s| in the highlight; the diffuse term is then
                                             # Ii kd n.s d / d^2: exactly the 1/d law (docs/diagnose.md)
                                             ({"normalise_s": False}, "attenuation-inverse"),
                                             ({"ambient": False, "gamma": False}, "no-srgb+no-ambient")])
def test_an_independent_student_shader_is_diagnosed(scenes, kwargs, expected):
    scene = scenes["sphere"]
    img = _student_shader(scene, rs.render(scene, "phong").hits, **kwargs)
    d = rs.diagnose(img, scene, "phong")
    assert d.best.name == expected, d.verdict
    assert d.matches == (expected == "correct")
    assert f"({d.pixel[0]}, {d.pixel[1]})" in d.verdict and d.explanation.startswith(f"pixel ({d.pixel[0]},")


def test_result_shows_verdict_map_and_scores(scenes):
    scene = scenes["sphere"]
    diag = Diagnoser(scene, "phong")
    img = _student(diag, next(c for c in diag.candidates if c.name == "no-ambient"), np.random.default_rng(1))
    d = diag(img)
    assert d.best.name == "no-ambient" and not d.matches and d.explained
    assert "no-ambient" in str(d) and "Reflectance equation with ambient light" in d.verdict
    assert "<table>" in d._repr_html_()
    assert d.map.shape == (H, W) and np.isnan(d.map[d.weights == 0]).all()
    assert np.nanmax(d.map) < 6  # the noise, not the mistake
    assert set(d.scores) == {c.name for c in diag.candidates}
    x, y = d.pixel
    assert d.weights[y, x] == 1
    with pytest.raises(Exception):
        d.best = None  # frozen


def test_silhouette_anti_aliasing_is_not_held_against_the_image(scenes):
    scene = scenes["sphere"]
    aa = rs.render(scene, "phong", samples=16).image
    d = rs.diagnose(rs.to_uint8(aa), scene, "phong")
    assert d.matches, d.verdict


def test_encoding_auto_accepts_linear(scenes):
    scene = scenes["torus"]
    lin = rs.to_uint8(rs.render(scene, "phong").image, gamma=1.0)
    assert rs.diagnose(lin, scene, "phong").best.name == "no-srgb"
    d = rs.diagnose(lin, scene, "phong", encoding="auto")
    assert d.matches and d.best.name == "correct-linear"
    d = rs.diagnose(lin, scene, "phong", encoding="linear")
    assert d.matches and d.best.name == "correct"


# -- refusals --------------------------------------------------------------------------------------------
def test_refusals(scenes, tmp_path):
    scene = scenes["sphere"]
    good = rs.to_uint8(rs.render(scene, "phong").image)
    with pytest.raises(ValueError, match="is 48x72 pixels but the scene's camera renders 96x72"):
        rs.diagnose(good[:, :48], scene)
    with pytest.raises(ValueError, match="blank"):
        rs.diagnose(np.zeros_like(good), scene)
    bad = tmp_path / "student.png"
    bad.write_text("not a png")
    with pytest.raises(ValueError, match="not an image file"):
        rs.diagnose(bad, scene)
    with pytest.raises(ValueError, match="no such file"):
        rs.diagnose(tmp_path / "missing.png", scene)
    with pytest.raises(ValueError, match="method"):
        rs.diagnose(good, scene, "toon")
    with pytest.raises(ValueError, match="encoding"):
        rs.diagnose(good, scene, encoding="gamma22")
    with pytest.raises(ValueError, match="RGB"):
        rs.diagnose(good[..., 0], scene)
    shadowed = scene.replace(lights=[rs.PointLight((2, 3, 4), intensity=20, shadows=True)])
    with pytest.raises(ValueError, match=r"lights\[0\].shadows"):
        rs.diagnose(good, shadowed)
    textured = scene.replace(models=[rs.Model(rs.shapes.uv_sphere(16, 32), rs.Material(kd_map=rs.Texture.checker()))])
    with pytest.raises(ValueError, match="colour maps"):
        rs.diagnose(good, textured)


SCENE_TOML = """
ambient = 0.1
[camera]
eye = [0, 0, 4]
width = 96
height = 72
[[object]]
shape = "icosphere"
subdivisions = 3
[object.material]
kd = [0.8, 0.3, 0.2]
ks = 0.5
shininess = 40
[[light]]
type = "point"
position = [2, 3, 4]
intensity = 20
attenuation = "inverse_square"
"""


def test_cli(tmp_path, capsys):
    from raycast_shade.apps.cli import main
    from raycast_shade.output.imagefile import write_png
    from raycast_shade.scene.scenefile import load_scene

    path = tmp_path / "scene.toml"
    path.write_text(SCENE_TOML)
    scene = load_scene(str(path))[0]
    img = rs.to_uint8(rs.render(scene, "gouraud").image)
    write_png(str(tmp_path / "student.png"), img)
    assert main(["diagnose", str(path), str(tmp_path / "student.png"), "--map", str(tmp_path / "map.png")]) == 0
    out = capsys.readouterr().out
    assert "Best explained by 'gouraud-shading'" in out and "pixel (" in out
    assert (tmp_path / "map.png").stat().st_size > 0
    assert main(["diagnose", str(path), str(tmp_path / "student.png"), "--method", "gouraud"]) == 0
    assert "Matches our gouraud shading" in capsys.readouterr().out
    (tmp_path / "small.png").write_bytes(b"")
    write_png(str(tmp_path / "small.png"), img[:10])
    assert main(["diagnose", str(path), str(tmp_path / "small.png")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error:" in err and "96x72" in err
    assert main(["diagnose", str(path), str(tmp_path / "nope.png")]) == 2
    assert "no such file" in capsys.readouterr().err


@pytest.mark.parametrize("weighting", ["uniform", "area"])
def test_weighting_candidates_are_our_render_of_the_mesh_so_weighted(weighting):
    ico = rs.shapes.icosphere(2)
    verts = ico.vertices * np.array([1.0, 0.7, 1.2])  # an ellipsoid: the weightings disagree
    mat = rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40)
    light = rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")

    def scene(w):
        return rs.Scene([rs.Model(rs.Mesh(verts, ico.faces, weighting=w), mat)], lights=[light],
                        camera=rs.Camera(eye=(0, 0, 4), width=W, height=H), ambient=0.1)

    angle, other = scene("angle"), scene(weighting)
    for method in ("gouraud", "phong"):
        want = rs.render(other, method).image
        got = _variant(angle, method, Mistake(normals=weighting))
        np.testing.assert_allclose(got, want, atol=1e-5)
        assert np.abs(rs.render(angle, method).image - want).max() > 1e-3  # the candidate is not the correct image


def test_face_normal_candidate_is_our_render_of_the_split_mesh():
    ico = rs.shapes.icosphere(2)
    mat = rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40)
    light = rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")
    cam = rs.Camera(eye=(0, 0, 4), width=W, height=H)
    smooth = rs.Scene([rs.Model(rs.Mesh(ico.vertices, ico.faces), mat)], lights=[light], camera=cam, ambient=0.1)
    split = rs.Scene([rs.Model(rs.Mesh(ico.vertices, ico.faces, crease_angle=1.0), mat)], lights=[light], camera=cam,
                     ambient=0.1)  # every vertex split per face: its normal is the face's
    np.testing.assert_allclose(_variant(smooth, "phong", Mistake(normals="face")), rs.render(split, "phong").image,
                               atol=1e-5)


def test_phong_2d_interpolation_is_our_screen_space_render(scenes):
    scene = scenes["plane"]
    np.testing.assert_allclose(_variant(scene, "phong", Mistake(screen=True)),
                               rs.render(scene, "phong", interpolation="screen").image, atol=1e-5)


from hypothesis import given, settings, strategies as st  # noqa: E402

from raycast_shade.study.diagnose.variant import decode  # noqa: E402


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3), st.sampled_from(["srgb", "linear", "double"]),
       st.booleans())
def test_decode_inverts_encode(rgb, encoding, bgr):
    m = Mistake(encoding=encoding, bgr=bgr)
    x = np.array(rgb).reshape(1, 1, 3)
    np.testing.assert_allclose(decode(encode(x, m) * 255.0, m), x, atol=1e-9)


def test_docs_list_every_candidate(scenes):
    import pathlib

    doc = (pathlib.Path(__file__).resolve().parents[2] / "docs" / "diagnose.md").read_text(encoding="utf-8")
    names = set()
    for scene in scenes.values():
        for method in ("flat", "gouraud", "phong"):
            for encoding in ("srgb", "linear", "auto"):
                names |= {c.name for c in catalogue(method, scene, encoding)}
    missing = sorted(n for n in names if f"| `{n}` |" not in doc)
    assert not missing, missing


def test_a_mistake_outside_the_catalogue_is_not_explained(scenes):
    scene = scenes["sphere"]
    green = scene.replace(models=[rs.Model(scene.models[0].mesh, rs.Material(kd=(0.1, 0.8, 0.2), ks=0.5,
                                                                            shininess=40))])
    d = rs.diagnose(rs.to_uint8(rs.render(green, "phong").image), scene, "phong")
    assert not d.explained and not d.matches and d.status in ("cannot-tell", "not-a-render")
    assert d.verdict.startswith(("Cannot tell", "Not a render of this scene"))


def test_inputs_camera_float_and_alpha(scenes):
    scene = scenes["torus"]
    cam = rs.Camera(eye=(0, 3, 2.5), width=80, height=60)
    img = rs.to_uint8(rs.render(scene, "flat", camera=cam).image)
    assert rs.diagnose(img, scene, "flat", camera=cam).matches
    assert rs.diagnose(img / 255.0, scene, "flat", camera=cam).matches  # float display values
    rgba = np.concatenate([img, np.full(img.shape[:2] + (1,), 255, np.uint8)], axis=2)
    assert rs.diagnose(rgba, scene, "flat", camera=cam).matches
    rgba[0, 0, 3] = 0
    with pytest.raises(ValueError, match="transparent"):
        rs.diagnose(rgba, scene, "flat", camera=cam)
    with pytest.raises(ValueError, match="tolerance"):
        rs.diagnose(img, scene, "flat", camera=cam, tolerance=-1)


def test_jpeg_images_are_diagnosed(scenes, tmp_path):
    """A student's JPEG (quality 90): its block artefacts are a few levels; the diagnosis holds."""
    import imageio.v3 as iio

    diag = Diagnoser(scenes["sphere"], "phong")
    right = 0
    for cand in diag.candidates:
        path = tmp_path / "student.jpg"
        iio.imwrite(path, np.clip(np.rint(diag.images[cand.name]), 0, 255).astype(np.uint8), quality=90)
        d = diag(path)
        right += d.matches if cand.correct else cand.name in d.group
        if cand.correct:
            assert d.matches, d.verdict
    assert right / len(diag.candidates) >= 0.95


def test_vector_slips_by_hand(scenes):
    """n.s unclamped, r reversed, t cos, ungated specular and v unnormalised, re-derived per pixel from our
    shading normals: each candidate is the slip it names."""
    from raycast_shade.study.reference import hit_points

    scene = scenes["sphere"]
    hits = rs.render(scene, "phong").hits
    m = hits.prim >= 0
    n = rs.shading_normals(scene, scene.camera, hits, "phong").astype(np.float64)[m]
    p = hit_points(scene, hits)[m]
    light = np.array([2.0, 3.0, 4.0])
    L = light - p
    d = np.linalg.norm(L, axis=1, keepdims=True)
    s = L / d
    e = scene.camera.eye - p
    v = e / np.linalg.norm(e, axis=1, keepdims=True)
    ns = np.sum(n * s, axis=1, keepdims=True)
    Ii = 20.0 / d ** 2
    kd, ks, t = np.array([0.8, 0.3, 0.2]), 0.5, 40.0

    def spec(r, vv, f=lambda c: c ** t, gate=ns > 0):
        c = np.clip(np.sum(r * vv, axis=1, keepdims=True), 0, None)
        return np.where(gate & (c > 0), f(np.minimum(c, 1.0) if f is not None else c), 0.0)

    r = 2 * ns * n - s
    base = 0.1 + Ii * kd * np.clip(ns, 0, None)
    cases = {
        Mistake(unclamped=True): 0.1 + Ii * kd * ns + Ii * ks * spec(r, v),
        Mistake(r_sign=True): base + Ii * ks * spec(-r, v),
        Mistake(linear_shininess=True): base + Ii * ks * spec(r, v, f=lambda c: t * c),
        Mistake(ungated=True): base + Ii * ks * spec(2 * ns * n - s, v, gate=np.ones_like(ns, bool)),
    }
    for mistake, want in cases.items():
        got = _variant(scene, "phong", mistake, hits)[m]
        np.testing.assert_allclose(got, want, atol=2e-5, err_msg=str(mistake.changes()))
    # v = e - p unnormalised: the cosine grows by |e - p| (about 3 here), and is no longer clipped at 1
    c_raw = np.clip(np.sum(r * e, axis=1, keepdims=True), 0, None)
    want = base + Ii * ks * np.where((ns > 0) & (c_raw > 0), c_raw ** t, 0.0)
    np.testing.assert_allclose(_variant(scene, "phong", Mistake(raw_v=True), hits)[m], want, rtol=1e-5, atol=2e-5)
