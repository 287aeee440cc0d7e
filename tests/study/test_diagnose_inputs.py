"""rs.diagnose refuses by name what it would otherwise judge wrongly (issue 45): float images out of
[0, 1] and non-finite alpha before anything renders, a scene of which nothing is in view, normal maps;
and the emission ``ke`` is part of every candidate, so our own render of an emissive scene matches."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.study.diagnose import Mistake, shade_variant

W, H = 96, 72


def _sphere(**mat):
    material = rs.Material(**{"kd": (0.8, 0.3, 0.2), "ks": 0.5, "shininess": 40, **mat})
    return rs.Scene([rs.Model(rs.shapes.icosphere(3), material)],
                    lights=[rs.PointLight((2, 3, 4), intensity=20, attenuation="inverse_square")],
                    camera=rs.Camera(eye=(0, 0, 4), width=W, height=H), ambient=0.1)


@pytest.fixture(scope="module")
def scene():
    return _sphere()


@pytest.fixture()
def no_render(monkeypatch):
    """Any render or cast from diagnose fails the test: the refusal must come first."""
    def boom(*args, **kwargs):
        raise AssertionError("rendered before the input was refused")

    monkeypatch.setattr("raycast_shade.apps.diagnose.render", boom)
    monkeypatch.setattr("raycast_shade.apps.diagnose.cast_camera", boom)


def _good_float():
    rng = np.random.default_rng(0)
    return rng.uniform(0.0, 1.0, (H, W, 3))


@pytest.mark.parametrize("scale, match", [(255.0, r"float values up to 25\d.*divide by 255"),
                                          (1.02, r"float values up to 1\.02.*clip it to \[0, 1\]")])
def test_float_image_above_one_is_refused_before_rendering(scene, no_render, scale, match):
    with pytest.raises(ValueError, match=r"^image: " + match):
        rs.diagnose(_good_float() * scale, scene)


def test_negative_float_image_is_refused(scene, no_render):
    img = _good_float()
    img[3, 4, 1] = -0.25
    with pytest.raises(ValueError, match=r"^image: float values down to -0\.25"):
        rs.diagnose(img, scene)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_alpha_is_refused(scene, no_render, bad):
    rgba = np.concatenate([_good_float(), np.ones((H, W, 1))], axis=2)
    rgba[5, 6, 3] = bad
    with pytest.raises(ValueError, match=r"^image: has non-finite alpha channel"):
        rs.diagnose(rgba, scene)
    rgba[5, 6, 3] = 1.0
    rgba[1, 1, 0] = bad
    with pytest.raises(ValueError, match=r"^image: has non-finite pixels"):
        rs.diagnose(rgba, scene)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(value=st.one_of(st.floats(1.0, 1e30, exclude_min=True), st.floats(-1e30, 0.0, exclude_max=True)),
       y=st.integers(0, H - 1), x=st.integers(0, W - 1), dtype=st.sampled_from([np.float32, np.float64]))
def test_any_float_out_of_range_is_refused(scene, no_render, value, y, x, dtype):
    """One pixel out of [0, 1] anywhere, either float type: refused, never scored."""
    img = _good_float().astype(dtype)
    img[y, x, 2] = value
    if not np.isfinite(img[y, x, 2]) or not (img[y, x, 2] > 1 or img[y, x, 2] < 0):
        return  # float32 rounded it to inf (non-finite: refused elsewhere) or back into [0, 1]
    with pytest.raises(ValueError, match=r"^image: float values (up|down) to .*a float image is in \[0, 1\]"):
        rs.diagnose(img, scene)


def test_valid_float_edges_are_accepted(scene):
    """0 and 1 exactly are in range: our own image as floats still matches."""
    img = rs.to_uint8(rs.render(scene, "phong").image) / 255.0
    assert img.max() == 1.0 or img.min() == 0.0
    assert rs.diagnose(img, scene, "phong").matches


def test_nothing_in_view_cannot_be_told(scene, no_render):
    """The model behind the camera: refused before anything renders (its bounds are out of view)."""
    behind = scene.replace(camera=rs.Camera(eye=(0, 0, 4), target=(0, 0, 8), width=W, height=H))
    student = np.random.default_rng(1).integers(0, 256, (H, W, 3), dtype=np.uint8)  # not blank
    with pytest.raises(ValueError, match=r"^scene: nothing of the scene is in view.*cannot tell"):
        rs.diagnose(student, behind, "phong")


def test_nothing_in_view_through_a_hole_cannot_be_told(scene):
    """Bounds in view but no pixel on the model (looking up through a torus): the cast decides."""
    ring = rs.Model(rs.shapes.torus(3.0, 0.2), rs.Material(kd=0.7))
    cam = rs.Camera(eye=(0, -2, 0), target=(0, 0, 0), up=(0, 0, 1), fov=30, width=W, height=H)
    hole = scene.replace(models=[ring], camera=cam)
    assert not rs.render(hole, "phong").mask.any()
    student = np.random.default_rng(1).integers(0, 256, (H, W, 3), dtype=np.uint8)
    with pytest.raises(ValueError, match=r"^scene: nothing of the scene is in view.*cannot tell"):
        rs.diagnose(student, hole, "phong")


def test_normal_map_is_refused_by_name(scene):
    nmap = rs.Texture(np.full((4, 4, 3), (0.7, 0.5, 0.9), np.float32), name="nmap")
    mapped = scene.replace(models=[rs.Model(rs.shapes.uv_sphere(16, 32),
                                            rs.Material(kd=0.7, normal_map=nmap))])
    with pytest.raises(ValueError, match=r"models\[0\]\.material\.normal_map: diagnose does not model normal maps"):
        rs.diagnose(rs.to_uint8(rs.render(scene, "phong").image), mapped, "phong")


def test_emission_map_is_refused_by_name(scene):
    emissive = scene.replace(models=[rs.Model(rs.shapes.uv_sphere(16, 32),
                                              rs.Material(kd=0.7, ke_map=rs.Texture.checker()))])
    with pytest.raises(ValueError, match=r"models\[0\]\.material\.ke_map: diagnose does not model colour maps"):
        rs.diagnose(rs.to_uint8(rs.render(scene, "phong").image), emissive, "phong")


@pytest.mark.parametrize("method", ["flat", "gouraud", "phong"])
def test_variant_adds_the_emission_as_the_renderer(method):
    scene = _sphere(ke=(0.3, 0.05, 0.6))
    frame = rs.render(scene, method)
    np.testing.assert_allclose(shade_variant(scene, scene.camera, frame.hits, method, Mistake()), frame.image,
                               atol=1e-5, rtol=0)


@settings(max_examples=8, deadline=None)
@given(ke=st.tuples(*[st.floats(0.0, 1.5)] * 3).filter(lambda k: max(k) > 0.01),
       method=st.sampled_from(["flat", "gouraud", "phong"]))
def test_our_emissive_render_is_never_called_a_mistake(ke, method):
    """The identity the diagnosis rests on: our own image of the scene is the correct candidate."""
    scene = _sphere(ke=ke)
    d = rs.diagnose(rs.to_uint8(rs.render(scene, method).image), scene, method)
    assert d.matches and d.best.correct, d.verdict
    assert d.verdict.startswith(f"Matches our {method} shading")
