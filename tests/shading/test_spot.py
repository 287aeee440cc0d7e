"""Spot lights (Warn's model): the falloff on a plane against its closed form, the cone's edges,
attenuation and shadows as point lights have them, the NumPy twin, scene files and checks."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common import layout as lay
from raycast_shade.scene.scenefile import SceneFileError, scene_from_dict
from raycast_shade.study.reference import shade_reference

H_LIGHT = 2.0
KD = 0.6
INTENSITY = 1.5


def _plane_scene(spot, size=6.0, width=96, height=96, models=()):
    plane = rs.Model(rs.shapes.plane(size=size, subdivisions=8), rs.Material(kd=KD, ka=0.0))
    cam = rs.Camera(eye=(0, 0, 5), target=(0, 0, 0), width=width, height=height, projection="orthographic",
                    ortho_height=size)
    return rs.Scene([plane, *models], lights=[spot], camera=cam, ambient=0.0)


def _closed_form(spot, p):
    """kd I cos^n(a) smoothstep(cos a) cos(incidence) for points p (N, 3) on z = 0 under a spot at
    (0, 0, h) pointing down: both angles are atan(r / h)."""
    r = np.hypot(p[:, 0], p[:, 1])
    c = H_LIGHT / np.hypot(r, H_LIGHT)
    ci, co = np.cos(np.radians(spot.inner_angle)), np.cos(np.radians(spot.outer_angle))
    t = np.clip((c - co) / (ci - co), 0, 1) if ci > co else (c > co).astype(float)
    smooth = t * t * (3 - 2 * t)
    return np.where(c > co, KD * INTENSITY * c ** spot.exponent * smooth * c, 0.0)


@pytest.mark.parametrize("shading", ["phong", "flat"])
@pytest.mark.parametrize("exponent, inner, outer", [(4.0, 20.0, 35.0), (0.0, 25.0, 25.0), (2.5, 0.0, 50.0)])
def test_falloff_on_a_plane_is_the_closed_form(exponent, inner, outer, shading):
    spot = rs.SpotLight((0, 0, H_LIGHT), (0, 0, -1), intensity=INTENSITY, exponent=exponent, inner_angle=inner,
                        outer_angle=outer)
    scene = _plane_scene(spot)
    frame = rs.render(scene, shading, buffers=("position",))
    mask = frame.hits.prim >= 0
    assert mask.all()
    if shading == "phong":
        p = frame.buffers["position"][mask].astype(np.float64)
    else:  # flat: the model is evaluated at each face's centre
        geo = scene.geometry
        f = geo.face_offsets[frame.hits.geom[mask]] + frame.hits.prim[mask]
        p = geo.vertices[geo.faces[f]].mean(axis=1) + geo.origin
    expect = _closed_form(spot, p)
    got = frame.image[mask].astype(np.float64)
    for c in range(3):
        np.testing.assert_allclose(got[:, c], expect, atol=2e-6)
    r = np.hypot(p[:, 0], p[:, 1])
    a = np.degrees(np.arctan2(r, H_LIGHT))
    assert np.all(got[a > outer + 1e-9] == 0.0)  # none outside the outer cone
    if inner > 0:
        assert got[a < inner - 1e-9, 0].min() > 0.0


def test_a_wide_uniform_spot_is_a_point_light_bit_for_bit():
    """n = 0 and both cones at 90 degrees: the factor is 1 below the light, so the kernels' arithmetic
    is the point light's (attenuation, shadows and all)."""
    kw = dict(intensity=4.0, color=(1.0, 0.8, 0.6), attenuation="inverse_square", shadows=True)
    box = rs.Model(rs.shapes.cube(size=0.6, center=(0.5, 0.2, 0.3)), rs.Material(kd=0.5, ks=0.3, shininess=20))
    spot = rs.SpotLight((0.2, 0.1, 2.5), (0, 0, -1), exponent=0.0, inner_angle=90.0, outer_angle=90.0, **kw)
    point = rs.PointLight((0.2, 0.1, 2.5), **kw)
    for shading in ("flat", "gouraud", "phong"):
        a = rs.render(_plane_scene(spot, models=[box]), shading).image
        b = rs.render(_plane_scene(point, models=[box]), shading).image
        assert np.array_equal(a, b), shading


def test_spot_attenuates_and_casts_shadows_like_a_point_light():
    occluder = rs.Model(rs.shapes.plane(size=0.8, center=(0, 0, 1.0)), rs.Material(kd=0.5))
    base = dict(position=(0, 0, H_LIGHT), direction=(0, 0, -1), intensity=INTENSITY, exponent=1.0,
                inner_angle=30.0, outer_angle=40.0)
    plain = rs.render(_plane_scene(rs.SpotLight(**base))).image
    frame = rs.render(_plane_scene(rs.SpotLight(**base, shadows=True), models=[occluder]))
    # The occluder (0.8 wide at z = 1, halfway to the light) shadows a 1.6-wide square of the floor;
    # the floor between 0.4 and 0.8 from the axis is seen past it, in the shadow (16 pixels per unit).
    ring = (slice(40, 56), slice(57, 60))
    assert np.all(frame.hits.geom[ring] == 0)
    assert np.all(frame.image[ring] == 0.0) and plain[ring].min() > 0.5
    spot = rs.SpotLight(**base, attenuation="heuristic", k=0.5)
    frame = rs.render(_plane_scene(spot), buffers=("position",))
    p = frame.buffers["position"].reshape(-1, 3).astype(np.float64)
    d = np.linalg.norm(p - [0, 0, H_LIGHT], axis=1)
    np.testing.assert_allclose(frame.image.reshape(-1, 3)[:, 0], _closed_form(spot, p) / (d + 0.5), atol=2e-6)


def test_kernels_match_the_numpy_twin():
    spot = rs.SpotLight((0.4, -0.3, 1.5), (-0.2, 0.1, -1), intensity=2.0, color=(1, 0.5, 0.2), exponent=3.0,
                        inner_angle=15.0, outer_angle=30.0, attenuation="inverse_square")
    sphere = rs.Model(rs.shapes.icosphere(2, radius=0.4, center=(0, 0, 0.4)), rs.Material(kd=0.7, ks=0.4))
    scene = _plane_scene(spot, models=[sphere])
    for shading in ("flat", "gouraud", "phong"):
        frame = rs.render(scene, shading)
        ref = shade_reference(scene, scene.camera, frame.hits, shading)
        np.testing.assert_allclose(frame.image, ref, atol=2e-5, rtol=1e-5)


def test_exact_renderer_takes_the_cone():
    from raycast_shade.study.analytic import render_exact, Sphere  # noqa: F401 - the exact primitives

    spot = rs.SpotLight((0, 0, 3), (0, 0, -1), exponent=2.0, inner_angle=5.0, outer_angle=10.0)
    plain = rs.PointLight((0, 0, 3))
    cam = rs.Camera(eye=(0, 0, 6), width=40, height=40)
    sphere = (Sphere((0, 0, 0), 1.0), rs.Material(kd=0.8))
    a = render_exact([sphere], cam, [spot], ambient=0.0).image
    b = render_exact([sphere], cam, [plain], ambient=0.0).image
    assert a.max() > 0 and (a < b - 1e-3).any() and (a <= b + 1e-12).all()


def test_packed_row():
    spot = rs.SpotLight((1, 2, 3), (0, 0, -2), exponent=5.0, inner_angle=10.0, outer_angle=20.0, shadows=True)
    rows = _plane_scene(spot).packed_lights()
    assert rows.shape == (1, lay.LIGHT_SIZE)
    row = rows[0]
    assert row[lay.LIGHT_KIND] == lay.LIGHT_SPOT and row[lay.LIGHT_SHADOWS] == 1.0
    np.testing.assert_array_equal(row[lay.LIGHT_AXIS:lay.LIGHT_AXIS + 3], [0, 0, -1])
    assert row[lay.LIGHT_COS_INNER] == np.cos(np.radians(10.0))
    assert row[lay.LIGHT_COS_OUTER] == np.cos(np.radians(20.0))
    assert row[lay.LIGHT_EXPONENT] == 5.0


@pytest.mark.parametrize("kw, exc, match", [
    (dict(inner_angle=30.0, outer_angle=20.0), ValueError, "spot_light.inner_angle: must be <= outer_angle"),
    (dict(outer_angle=91.0), ValueError, "spot_light.outer_angle: must be <= 90"),
    (dict(inner_angle=-1.0), ValueError, "spot_light.inner_angle: must be >= 0"),
    (dict(exponent=-0.5), ValueError, "spot_light.exponent: must be >= 0"),
    (dict(direction=(0, 0, 0)), ValueError, "spot_light.direction"),
    (dict(exponent="2"), TypeError, "spot_light.exponent"),
])
def test_bad_spots_are_refused(kw, exc, match):
    with pytest.raises(exc, match=match):
        rs.SpotLight((0, 0, 1), **kw)


def test_a_spot_is_a_point_light_everywhere():
    spot = rs.SpotLight((0, 0, 0), (0, 1, 0))
    assert isinstance(spot, rs.PointLight)
    import dataclasses

    moved = dataclasses.replace(spot, position=(1, 2, 3))
    assert isinstance(moved, rs.SpotLight) and np.array_equal(moved.direction, spot.direction)
    scene = rs.Scene([rs.shapes.icosphere(1)], lights=[spot], camera=rs.Camera(eye=(0, 0, 4), width=8, height=6))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rs.render(scene)
    assert any(issubclass(w.category, rs.LightInsideWarning) for w in caught)


def test_scene_files_take_spots():
    base = {"camera": {"eye": [0, 0, 3], "width": 8, "height": 6}, "object": [{"shape": "icosphere"}]}
    light = {"type": "spot", "position": [0, 0, 3], "direction": [0, 0, -1], "exponent": 2, "inner_angle": 10,
             "outer_angle": 20, "intensity": 2.0, "shadows": True}
    scene, _ = scene_from_dict(dict(base, light=[light]))
    spot = scene.lights[0]
    assert isinstance(spot, rs.SpotLight) and spot.exponent == 2.0 and spot.outer_angle == 20.0 and spot.shadows
    assert spot.name == "light[0]"
    with pytest.raises(SceneFileError, match=r"light\[0\]: missing key 'direction'"):
        scene_from_dict(dict(base, light=[{k: v for k, v in light.items() if k != "direction"}]))
    with pytest.raises(SceneFileError, match=r"light\[0\].inner_angle: must be <= outer_angle"):
        scene_from_dict(dict(base, light=[dict(light, inner_angle=30)]))
    with pytest.raises(SceneFileError, match="unknown key 'cone'"):
        scene_from_dict(dict(base, light=[dict(light, cone=3)]))
