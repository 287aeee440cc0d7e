"""Emission ``ke`` (and ``ke_map``): an added term of the reflectance equation, whatever the lights.

Closed forms on a plane: with no light and no ambient every seen pixel is ``ke`` exactly; with
lights, adding ``ke`` adds exactly ``ke`` (to float32 rounding) in every method; a ``ke_map``
multiplies ``ke`` per point as the NumPy twin computes it; ``terms=True`` has an ``emissive``
term equal to it, and the terms still add up to the image.
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.shading.terms import compose_terms
from raycast_shade.study.reference import shade_reference

from tests.conftest import down_camera

KE = np.array([0.3, 0.15, 0.6])
EPS32 = float(np.finfo(np.float32).eps)


def _scene(material, lights=(), ambient=0.0):
    plane = rs.shapes.plane(size=2.0, subdivisions=3)
    return rs.Scene([rs.Model(plane, material)], lights=list(lights), camera=down_camera(width=33, height=25),
                    ambient=ambient)


def _texture():
    return rs.Texture(np.random.default_rng(3).uniform(0.0, 1.0, (4, 5, 3)), name="glow")


@pytest.mark.parametrize("shading", rs.SHADINGS)
def test_emission_alone_is_ke_exactly(shading):
    with pytest.warns(rs.NoLightsWarning):
        frame = rs.render(_scene(rs.Material(kd=0.7, ke=KE)), shading)
    seen = frame.hits.prim >= 0
    assert seen.any()
    np.testing.assert_array_equal(frame.image[seen], np.broadcast_to(KE.astype(np.float32), (seen.sum(), 3)))


@pytest.mark.parametrize("shading", rs.SHADINGS)
def test_emission_adds_ke_to_the_lit_image(shading):
    lights = [rs.PointLight((0.5, 0.3, 2.0), attenuation="none"), rs.DirectionalLight((0.2, -0.1, -1.0))]
    plain = rs.render(_scene(rs.Material(kd=0.6, ks=0.4), lights, ambient=0.1), shading)
    glow = rs.render(_scene(rs.Material(kd=0.6, ks=0.4, ke=KE), lights, ambient=0.1), shading)
    seen = plain.hits.prim >= 0
    diff = glow.image[seen].astype(np.float64) - plain.image[seen]
    np.testing.assert_allclose(diff, np.broadcast_to(KE, diff.shape), atol=4 * EPS32 * glow.image.max())


@pytest.mark.parametrize("shading", rs.SHADINGS)
def test_an_emission_map_matches_the_numpy_twin_and_the_terms_add_up(shading):
    tex = _texture()
    scene = _scene(rs.Material(kd=0.5, ks=0.2, ke=KE, ke_map=tex), [rs.PointLight((0.5, 0.3, 2.0))], ambient=0.05)
    frame = rs.render(scene, shading, terms=True)
    seen = frame.hits.prim >= 0
    ref = shade_reference(scene, scene.camera, frame.hits, shading)
    np.testing.assert_allclose(frame.image[seen], ref[seen], rtol=4 * EPS32, atol=1e-7)
    # The emissive term is the emission alone: ke times the map, so it varies over the plane.
    em = frame.terms["emissive"][seen].astype(np.float64)
    assert np.all(em <= KE + 1e-6) and np.ptp(em[:, 0]) > 0.05
    with pytest.warns(rs.NoLightsWarning):  # the same emission with nothing else
        lit = rs.render(scene.replace(lights=(), ambient=0.0), shading)
    np.testing.assert_allclose(em, lit.image[seen], rtol=2 * EPS32, atol=1e-9)
    np.testing.assert_allclose(compose_terms(frame.terms), frame.image, rtol=6 * EPS32, atol=1e-7)
    np.testing.assert_allclose(frame.terms["ambient"][seen], 0.05, rtol=EPS32)  # Ia ka (ka = 1): no emission in it


def test_explain_names_the_emission_and_adds_it():
    scene = _scene(rs.Material(kd=0.5, ke=KE), [rs.PointLight((0.5, 0.3, 2.0))], ambient=0.05)
    for shading in rs.SHADINGS:
        frame = rs.render(scene, shading)
        e = frame.explain(16, 12)
        np.testing.assert_allclose(e.emissive, KE)
        np.testing.assert_allclose(e.total, frame.image[12, 16], rtol=2 * EPS32)
        text = str(e)
        assert "+ ke" in text and "emissive ke = (0.3, 0.15, 0.6)" in text
    plain = str(rs.render(_scene(rs.Material(kd=0.5), [rs.PointLight((0, 0, 2.0))]), "phong").explain(16, 12))
    assert "ke" not in plain.replace("kd", "").replace("ks", "").split("(Ia =")[0]


def test_ke_is_validated_defaulted_and_packed():
    from raycast_shade.common.layout import MAT_KE

    assert rs.Material().ke.tolist() == [0.0] * 3 and not rs.Material().has_emission
    assert rs.Material(ke_map=_texture()).ke.tolist() == [1.0] * 3  # a map's factor defaults to 1
    assert rs.Material(ke=2.5).ke.tolist() == [2.5] * 3  # brighter than white is legal
    np.testing.assert_array_equal(rs.Material(ke=KE).packed()[MAT_KE:MAT_KE + 3], KE)
    with pytest.raises(ValueError, match="m.ke"):
        rs.Material(name="m", ke=-0.1)
    with pytest.raises(TypeError, match="m.ke_map: expected a Texture"):
        rs.Material(name="m", ke_map="glow.png")


def test_an_emission_map_needs_uvs():
    mesh = rs.Mesh(np.eye(3), np.array([[0, 1, 2]]))
    scene = rs.Scene([rs.Model(mesh, rs.Material(ke_map=_texture()))], lights=[rs.PointLight((1, 1, 1))],
                     camera=down_camera())
    with pytest.raises(ValueError, match="ke_map but the mesh has no UVs"):
        scene.geometry
