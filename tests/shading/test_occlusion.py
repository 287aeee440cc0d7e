"""Ambient occlusion (``ao_map``, ``ao_strength``): the red channel scales the ambient term per texel.

Closed forms on a plane lit by the ambient term alone: a constant map ``ao`` gives
``Ia ka (1 + s (ao - 1))`` in every method; a random map agrees with the NumPy twin, changes only
the ``ambient`` term of ``terms=True`` (diffuse and specular are those without the map), and the
terms still add up to the image.
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.shading.terms import compose_terms
from raycast_shade.study.reference import shade_reference

from tests.conftest import down_camera

IA = np.array([0.4, 0.3, 0.2])
KA = np.array([0.9, 0.6, 0.5])
EPS32 = float(np.finfo(np.float32).eps)


def _scene(material, lights=()):
    plane = rs.shapes.plane(size=2.0, subdivisions=3)
    return rs.Scene([rs.Model(plane, material)], lights=list(lights), camera=down_camera(width=33, height=25),
                    ambient=tuple(IA))


def _map(value=None):
    rng = np.random.default_rng(5)
    texels = rng.uniform(0.0, 1.0, (6, 5, 3)) if value is None else np.full((3, 3, 3), value)
    return rs.Texture(texels, name="ao")  # float texels are taken as linear


@pytest.mark.parametrize("strength", [1.0, 0.5, 0.0])
@pytest.mark.parametrize("shading", rs.SHADINGS)
def test_a_constant_occlusion_scales_the_ambient_term(shading, strength):
    with pytest.warns(rs.NoLightsWarning):
        frame = rs.render(_scene(rs.Material(ka=KA, ao_map=_map(0.25), ao_strength=strength)), shading)
    seen = frame.hits.prim >= 0
    expected = IA * KA * (1.0 + strength * (0.25 - 1.0))
    np.testing.assert_allclose(frame.image[seen], np.broadcast_to(expected, (seen.sum(), 3)), rtol=2 * EPS32)


@pytest.mark.parametrize("shading", rs.SHADINGS)
def test_an_occlusion_map_matches_the_twin_and_touches_only_the_ambient_term(shading):
    lights = [rs.PointLight((0.5, 0.3, 2.0), attenuation="none")]
    occluded = _scene(rs.Material(ka=KA, kd=0.5, ks=0.3, ao_map=_map(), ao_strength=0.8), lights)
    plain = _scene(rs.Material(ka=KA, kd=0.5, ks=0.3), lights)
    frame = rs.render(occluded, shading, terms=True)
    base = rs.render(plain, shading, terms=True)
    seen = frame.hits.prim >= 0
    ref = shade_reference(occluded, occluded.camera, frame.hits, shading)
    np.testing.assert_allclose(frame.image[seen], ref[seen], rtol=4 * EPS32, atol=1e-7)
    amb = frame.terms["ambient"][seen].astype(np.float64)
    assert np.all(amb <= IA * KA * (1 + 1e-6)) and np.all(amb >= IA * KA * 0.2 * (1 - 1e-6))
    assert np.ptp(amb[:, 0]) > 0.05  # per texel, not one value
    for term in ("diffuse", "specular"):
        np.testing.assert_allclose(frame.terms[term], base.terms[term], rtol=4 * EPS32, atol=1e-7, err_msg=term)
    np.testing.assert_allclose(compose_terms(frame.terms), frame.image, rtol=5 * EPS32, atol=1e-7)


def test_explain_shows_the_occlusion():
    frame = rs.render(_scene(rs.Material(ka=KA, ao_map=_map(0.25), ao_strength=0.5),
                             [rs.PointLight((0, 0, 2.0))]), "phong")
    e = frame.explain(16, 12)
    assert "occlusion 1 + s (ao - 1) = 1 + 0.5 x (0.25 - 1) = 0.625" in str(e)
    np.testing.assert_allclose(e.total, frame.image[12, 16], rtol=2 * EPS32)


def test_ao_strength_is_validated():
    with pytest.raises(ValueError, match="m.ao_strength"):
        rs.Material(name="m", ao_strength=1.5)
    with pytest.raises(TypeError, match="m.ao_map: expected a Texture"):
        rs.Material(name="m", ao_map=0.5)
