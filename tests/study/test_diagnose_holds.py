"""rs.diagnose never guesses (issue 46): a verdict only where the explanation holds in every region, the
background not scored (and said so), "cannot tell" with the reason otherwise, "not a render of this
scene" for a photograph; the new candidates (specular-times-kd, light-reversed, light-object-space) are
our renderer with that slip."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from benchmarks.diagnose_outside import photograph, student_image
from raycast_shade.apps import diagnose as app
from raycast_shade.apps.diagnose import Diagnoser
from raycast_shade.study.diagnose import Mistake, catalogue, shade_variant
from raycast_shade.study.diagnose.holds import PIXEL_TOL, departure, holds, margin, regions

W, H = 96, 72


def _torus():
    """The issue's torus: a point light and a directional one, Phong asked."""
    return rs.Scene([rs.Model(rs.shapes.torus(major_segments=32, minor_segments=16),
                              rs.Material(kd=(0.2, 0.6, 0.3), ks=0.5, shininess=30))],
                    lights=[rs.PointLight((2, 2, 3), intensity=14, attenuation="inverse_square"),
                            rs.DirectionalLight((-1, -0.6, -0.4), intensity=0.7, color=(1.0, 0.85, 0.6))],
                    camera=rs.Camera(eye=(0, 2.2, 3), width=W, height=H), ambient=0.06)


def _prism_scene():
    """A cube off the origin under one point light (object space differs from world space)."""
    return rs.Scene([rs.Model(rs.shapes.cube(1.0, center=(0.5, 0.0, 0.0)),
                              rs.Material(kd=(0.7, 0.7, 0.3), ks=0.3, shininess=10))],
                    lights=[rs.PointLight((1.0, 2.0, 2.5), intensity=1.0)],
                    camera=rs.Camera(eye=(1.8, 1.2, 3.0), target=(0.5, 0, 0), width=W, height=H), ambient=0.07)


@pytest.fixture(scope="module")
def torus():
    scene = _torus()
    return scene, Diagnoser(scene, "phong")


def _without(monkeypatch, name):
    """The catalogue without ``name``: what the diagnosis had before issue 46."""
    real = app.catalogue
    monkeypatch.setattr(app, "catalogue", lambda *a, **k: tuple(c for c in real(*a, **k) if c.name != name))


# -- the new candidates are our renderer with the slip ---------------------------------------------------
def test_specular_times_kd_is_our_render_with_ks_times_kd(torus):
    scene, diag = torus
    model = scene.models[0]
    tinted = rs.Material(kd=model.material.kd, ks=model.material.ks * model.material.kd, shininess=30)
    want = rs.render(scene.replace(models=[rs.Model(model.mesh, tinted)]), "phong").image
    got = shade_variant(scene, scene.camera, diag.frame.hits, "phong", Mistake(kd_specular=True))
    np.testing.assert_allclose(got, want, atol=1e-5)


def test_light_reversed_is_our_render_with_the_direction_negated(torus):
    scene, diag = torus
    point, sun = scene.lights
    flipped = rs.DirectionalLight(-np.asarray(sun.direction), intensity=sun.intensity, color=sun.color)
    want = rs.render(scene.replace(lights=[point, flipped]), "phong").image
    got = shade_variant(scene, scene.camera, diag.frame.hits, "phong", Mistake(light_reversed=True))
    np.testing.assert_allclose(got, want, atol=1e-5)
    assert np.abs(got - diag.frame.image).max() > 0.05  # the candidate is not the correct image


def test_light_object_space_is_our_render_with_the_light_moved_by_the_centre():
    scene = _prism_scene()
    moved = scene.replace(lights=[rs.PointLight((1.5, 2.0, 2.5), intensity=1.0)])  # + the cube's centre
    hits = rs.render(scene, "flat").hits
    got = shade_variant(scene, scene.camera, hits, "flat", Mistake(light_object=True))
    np.testing.assert_allclose(got, rs.render(moved, "flat").image, atol=1e-5)
    names = [c.name for c in catalogue("flat", scene)]
    assert "light-object-space" in names and "light-reversed" not in names  # no directional or spot light
    assert "light-object-space" not in [c.name for c in catalogue("phong", _torus())]  # centred: no change


def test_mistake_light_index_is_checked():
    with pytest.raises(ValueError, match="Mistake.light"):
        Mistake(light=-2)
    with pytest.raises(ValueError, match="Mistake.light"):
        Mistake(light=True)


# -- the two confident wrong verdicts of the issue -------------------------------------------------------
@pytest.mark.parametrize("slip,kwargs,before", [("specular-times-kd", dict(tint="kd"), "n-unnormalised"),
                                                ("light-reversed", dict(reverse=True), "half-pixel")])
def test_issue_slips_are_named_and_without_their_candidate_not_guessed(torus, monkeypatch, slip, kwargs, before):
    scene, diag = torus
    rng = np.random.default_rng(46)
    img = student_image(scene, diag.frame.hits, "phong", rng, **kwargs)  # the independent shader
    d = diag(img)
    assert d.status == "explained" and d.best.name == slip, d.verdict
    _without(monkeypatch, slip)  # the catalogue of before: the closest candidate must not be named
    d = Diagnoser(scene, "phong")(img)
    assert d.status == "cannot-tell" and not d.explained and not d.matches, d.verdict
    assert d.verdict.startswith("Cannot tell: the closest candidate is")
    assert "Best explained by" not in d.verdict
    x, y = d.pixel
    assert d.map[y, x] > PIXEL_TOL  # the pixel shown is where the closest candidate fails
    assert f"({x}, {y})" in d.verdict


def test_one_rms_would_have_passed_the_regional_slip(torus, monkeypatch):
    """The reason the old verdict was wrong: the frame's RMS is within the old 6-level fit."""
    scene, _ = torus
    img = student_image(scene, rs.render(scene, "phong").hits, "phong", np.random.default_rng(3), tint="kd")
    _without(monkeypatch, "specular-times-kd")
    d = Diagnoser(scene, "phong")(img)
    assert d.scores[d.best.name] < 6.0 and d.status == "cannot-tell", d.verdict


# -- the background, photographs -------------------------------------------------------------------------
def test_correct_image_on_grey_background_matches_and_says_the_background_is_not_scored(torus):
    scene, diag = torus
    img = rs.to_uint8(diag.frame.image)
    img[~diag.frame.mask] = 128
    d = diag(img)
    assert d.matches and d.best.correct, d.verdict
    x, y = d.pixel
    assert diag.frame.mask[y, x] and d.pixel != (0, 0)
    n_bg = int((~diag.frame.mask).sum())
    assert f"not scored: {n_bg} background pixels (the scene does not cover them)" in d.verdict
    assert np.isnan(d.map[~diag.frame.mask]).all()


@pytest.mark.parametrize("resize", [False, True])
def test_a_photograph_is_not_a_render_of_this_scene(torus, resize):
    scene, diag = torus
    img = photograph((H, W), np.random.default_rng(5))
    if resize:
        from PIL import Image

        img = np.asarray(Image.fromarray(img).resize((W // 3, H // 3)).resize((W, H)))
    d = diag(img)
    assert d.status == "not-a-render" and not d.explained, d.verdict
    assert d.verdict.startswith("Not a render of this scene") and "told apart" not in d.verdict


def test_slip_outside_the_catalogue_is_not_named(torus):
    scene, diag = torus
    img = student_image(scene, diag.frame.hits, "phong", np.random.default_rng(2), tint=(1.0, 0.2, 0.8))
    d = diag(img)
    assert d.status in ("cannot-tell", "not-a-render") and not d.explained, d.verdict


# -- the pieces ------------------------------------------------------------------------------------------
def test_holds_fails_one_region_that_the_frame_quantile_passes():
    label = np.zeros((40, 40), int)
    lit = np.zeros((1, 40, 40), bool)
    lit[0, :4, :4] = True  # a 16-pixel region: 1% of the frame
    reg = regions(label, lit, np.zeros((40, 40), bool))
    assert len(np.unique(reg)) == 2
    dep = np.full((40, 40), 1.0)
    dep[:4, :4] = 20.0  # 16 / 1600 = 1% of the pixels: the 99th percentile is still within the tolerance
    ok, facts = holds(dep, reg)
    assert facts["q99"] <= PIXEL_TOL and not ok
    assert facts["region_size"] == 16 and facts["region_median"] == 20.0 and facts["pixel"][0] < 4
    dep[:4, :4] = 1.0
    assert holds(dep, reg)[0]


def test_departure_and_margin():
    a = np.zeros((2, 2, 3))
    b = a.copy()
    b[0, 0] = (1.0, -5.0, 2.0)
    d = departure(a, b, np.array([[True, True], [True, False]]), reach=0)
    assert d[0, 0] == 5.0 and d[0, 1] == 0.0 and np.isnan(d[1, 1])
    student = np.zeros((3, 3, 3))
    student[0, 0, 1] = 7.0
    image = np.zeros((3, 3, 3))
    image[1, 1, 1] = 4.0  # within one pixel of (0, 0): only 7 - 4 departs there
    image[2, 2, 0] = 9.0  # two pixels away: the image's own value departs from the student's 0 at (2, 2)
    d = departure(student, image, np.ones((3, 3), bool))
    assert d[0, 0] == 3.0 and d[2, 2] == 0.0 and d[0, 2] == 0.0
    far = departure(np.full((3, 3, 3), 9.0), image, np.ones((3, 3), bool))
    assert far[0, 0] == 9.0 and far[2, 2] == 9.0  # channel 2 holds 0 everywhere near both
    assert margin(0.0, 100.0) == 100.0 and margin(1e6, 100.0) == pytest.approx(4 * 2 * 1.5 * 1e3)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(method=st.sampled_from(["flat", "gouraud", "phong"]), kd=st.tuples(*[st.floats(0.05, 0.95)] * 3),
       ks=st.floats(0.0, 0.8), shininess=st.floats(2.0, 80.0), light=st.tuples(st.floats(-3, 3), st.floats(0.5, 3),
                                                                                st.floats(1, 4)),
       ambient=st.floats(0.0, 0.2), sun=st.booleans())
def test_our_own_render_always_matches(method, kd, ks, shininess, light, ambient, sun):
    """The identity: our render of any such scene, written as 8 bits, is never diagnosed as a slip."""
    lights = [rs.PointLight(light, intensity=12.0, attenuation="inverse_square")]
    if sun:
        lights.append(rs.DirectionalLight((-1, -0.5, -1), intensity=0.5))
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=kd, ks=ks, shininess=shininess))],
                     lights=lights, camera=rs.Camera(eye=(0, 0, 3.5), width=64, height=48), ambient=ambient)
    d = rs.diagnose(rs.to_uint8(rs.render(scene, method).image), scene, method)
    assert d.status == "matches" and d.best.correct, d.verdict
