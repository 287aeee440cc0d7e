"""One light interface and one function per reflectance model: lights pack themselves, one
kernel helper reads any light row, the model registry is what the kernels dispatch on, and the
3-vector helpers of the hit-point record do plain vector arithmetic."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

import raycast_shade as rs
from raycast_shade.common import layout as lay
from raycast_shade.scene.lights import Light
from raycast_shade.shading import records, reflectance
from raycast_shade.shading.illumination import _light_at

ORIGIN = np.array([0.25, -0.5, 1.0])
LIGHTS = [rs.PointLight((1.0, 2.0, 3.0), 5.0, color=(1.0, 0.5, 0.25), attenuation="inverse_square", shadows=True),
          rs.PointLight((-1.0, 0.5, 2.0), 2.0, attenuation="heuristic", k=0.5),
          rs.DirectionalLight((0.0, -1.0, -1.0), 0.7, shadows=True),
          rs.SpotLight((0.0, 0.0, 4.0), direction=(0.0, 0.2, -1.0), intensity=3.0, exponent=2.0, inner_angle=10,
                       outer_angle=25, attenuation="inverse_square")]


@njit(cache=False)
def _light_at_all(lights, p, dmin, att_on):
    n = lights.shape[0]
    s = np.empty((n, 3))
    rest = np.empty((n, 3))
    for i in range(n):
        si, d, att, cone = _light_at(lights, i, 0, (p[0], p[1], p[2]), dmin, att_on, np.bool_(True))
        s[i, 0], s[i, 1], s[i, 2] = si
        rest[i, 0], rest[i, 1], rest[i, 2] = d, att, cone
    return s, rest


def test_every_light_kind_is_a_light_that_packs_itself():
    """The scene's rows are the lights' own ``pack``, each kind under its LIGHT_KIND code."""
    scene = rs.Scene([rs.shapes.cube()], lights=LIGHTS)
    origin = scene.geometry.origin
    rows = scene.packed_lights()
    assert rows.shape == (len(LIGHTS), lay.LIGHT_SIZE)
    for light, row in zip(LIGHTS, rows):
        assert isinstance(light, Light)
        np.testing.assert_array_equal(row, light.pack(origin))
        assert row[lay.LIGHT_KIND] == type(light).kind
    assert [type(light).kind for light in LIGHTS] == [lay.LIGHT_POINT, lay.LIGHT_POINT, lay.LIGHT_DIRECTIONAL,
                                                      lay.LIGHT_SPOT]


def test_a_scene_takes_any_light_and_refuses_anything_else():
    with pytest.raises(TypeError, match=r"scene.lights\[1\]"):
        rs.Scene([rs.shapes.cube()], lights=[LIGHTS[0], (1.0, 2.0, 3.0)])


@pytest.mark.parametrize("att_on", [False, True])
def test_one_helper_gives_any_lights_direction_distance_attenuation_and_cone(att_on):
    """``_light_at`` against the lights' own definitions, evaluated in NumPy."""
    p = np.array([0.1, 0.3, -0.2])
    rows = np.array([light.pack(ORIGIN) for light in LIGHTS])
    dmin = 1e-6
    s, rest = _light_at_all(rows, p, dmin, att_on)
    for i, light in enumerate(LIGHTS):
        d, att, cone = rest[i]
        if isinstance(light, rs.DirectionalLight):
            np.testing.assert_allclose(s[i], -light.direction, rtol=0, atol=1e-15)
            assert d == np.inf and att == 1.0 and cone == 1.0
            continue
        to = light.position - ORIGIN - p
        dist = np.linalg.norm(to)
        np.testing.assert_allclose(s[i], to / dist, rtol=1e-14)
        assert d == pytest.approx(dist, rel=1e-14)
        law = {"none": 1.0, "inverse_square": 1.0 / dist ** 2, "heuristic": 1.0 / (dist + light.k)}
        assert att == pytest.approx(law[light.attenuation] if att_on else 1.0, rel=1e-14)
        if isinstance(light, rs.SpotLight):
            assert cone == pytest.approx(float(light.falloff(-(s[i] @ light.direction))), rel=1e-12)
            assert 0.0 < cone < 1.0  # this point is between the spot's cones
        else:
            assert cone == 1.0


def test_a_light_on_the_point_gives_no_light():
    row = rs.PointLight((1.0, 1.0, 1.0), attenuation="inverse_square").pack(np.zeros(3))[None]
    s, rest = _light_at_all(row, np.ones(3), 1e-6, True)
    assert rest[0, 0] == 0.0  # the caller skips d == 0: no direction, no light


@njit(cache=False)
def _terms(model, n, s, v, ndots, c, p):
    return (reflectance._diffuse(model, n, s, v, ndots, c, p, np.bool_(True)),
            reflectance._specular(model, n, s, v, ndots, c, p, np.bool_(True)))


@njit(cache=False)
def _own_terms(n, s, v, ndots, c, p):
    """Every registered function's terms, in :data:`MODELS`' order (the registry's functions are
    dispatchers: a kernel cannot call through a dict, so each is called by name here)."""
    return ((reflectance._lambert(n, s, v, ndots, c, p), reflectance._phong(n, s, v, ndots, c, p)),
            (reflectance._lambert(n, s, v, ndots, c, p), reflectance._blinn(n, s, v, ndots, c, p)),
            (reflectance._ggx_diffuse(n, s, v, ndots, c, p), reflectance._ggx_specular(n, s, v, ndots, c, p)))


def _unit(rng):
    a = rng.normal(size=3)
    return a / np.linalg.norm(a)


def test_the_kernels_dispatch_every_registered_model_to_its_own_function():
    """Each code of MODELS reaches its diffuse function in ``_diffuse`` and its specular one in
    ``_specular``, and the lecture's models return the lecture's terms: Lambert ``kd n . s``, Phong
    ``ks max(r . v, 0)^t``, Blinn ``ks max(n . h / |h|, 0)^t`` (GGX: tests/shading/test_ggx.py)."""
    assert set(reflectance.MODELS) == {lay.MODEL_PHONG, lay.MODEL_BLINN, lay.MODEL_GGX}
    order = [reflectance._phong, reflectance._blinn, reflectance._ggx_specular]
    rng = np.random.default_rng(7)
    c = tuple(float(x) for x in rng.uniform(0.1, 1.0, 12))
    p = (7.0, 0.3, 0.6)
    seen = 0
    for _ in range(40):
        n, s, v = (tuple(_unit(rng)) for _ in range(3))
        ndots = float(np.dot(n, s))
        if ndots <= 0:
            continue
        own = _own_terms(n, s, v, ndots, c, p)
        for code, pair in reflectance.MODELS.items():
            k = order.index(pair.specular)
            got = _terms(code, n, s, v, ndots, c, p)
            if code == lay.MODEL_GGX:  # fast-math (reassoc, contract) may round the inlined copies apart
                assert np.ravel(got) == pytest.approx(np.ravel(own[k]), rel=1e-13)
                assert np.ravel(got) != pytest.approx(np.ravel(own[0]), rel=1e-6)
            else:
                assert got == own[k]
        lam, phong = own[0]
        blinn = own[1][1]
        assert lam == pytest.approx(np.array(c[3:6]) * ndots, abs=1e-15)
        r = 2 * ndots * np.array(n) - np.array(s)
        h = np.array(s) + np.array(v)
        for term, cos in ((phong, r @ v), (blinn, np.dot(n, h) / np.linalg.norm(h))):
            assert term == pytest.approx(np.array(c[6:9]) * max(min(cos, 1.0), 0.0) ** 7, abs=1e-14)
        seen += 1
    assert seen > 10


def test_a_materials_specular_choice_packs_the_model_code():
    assert rs.Material(specular="phong").packed()[lay.MAT_MODEL] == lay.MODEL_PHONG
    assert rs.Material(specular="blinn").packed()[lay.MAT_MODEL] == lay.MODEL_BLINN
    row = rs.Material(specular="ggx", metallic=0.25, roughness=0.75).packed()
    assert row[lay.MAT_MODEL] == lay.MODEL_GGX
    assert (row[lay.MAT_METALLIC], row[lay.MAT_ROUGHNESS]) == (0.25, 0.75)
    assert np.all(row[lay.MAT_KS:lay.MAT_KS + 3] == 1.0)  # the map's scale: metallic, roughness as given


@njit(cache=False)
def _vec_ops(a, b):
    n, length = records.normalize(a)
    f, sign = records.face_forward(a, b)
    return records.dot(a, b), n, length, f, sign, records.reflect_into(a, b)


# Components 0 or of magnitude 1e-150 and more: below about 1.5e-154 a square is subnormal, and
# float64's normalize loses digits there (normalizing (0, 0, 4.6e-157) gave a norm of 1 - 4.4e-12);
# a shading vector is never that short.
finite = st.floats(-1e3, 1e3, allow_nan=False).filter(lambda x: x == 0.0 or abs(x) >= 1e-150)
vec = st.tuples(finite, finite, finite)


@settings(max_examples=60, deadline=None)
@given(vec, vec)
def test_the_record_helpers_are_vector_arithmetic(a, b):
    d, n, length, f, sign, refl = _vec_ops(a, b)
    a_, b_ = np.array(a), np.array(b)
    scale = np.linalg.norm(a_) * np.linalg.norm(b_)
    assert abs(d - a_ @ b_) <= 1e-12 * scale  # the shading flags allow fused multiply-adds
    assert length == pytest.approx(np.linalg.norm(a_), rel=1e-12, abs=1e-300)
    if length > 0:
        assert math.isclose(np.linalg.norm(n), 1.0, rel_tol=1e-12)
    else:
        assert n == a
    assert (sign == 1.0) == (d >= 0.0)
    np.testing.assert_array_equal(f, a_ * sign)
    if d < 0.0:
        np.testing.assert_allclose(refl, a_ - 2.0 * d * b_, rtol=1e-12, atol=1e-12 * scale * np.linalg.norm(b_))
    else:
        assert refl == a
