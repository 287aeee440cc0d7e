"""Area lights: one sample is a point light at the centre bit for bit, the kernels' samples are the
NumPy twin's, and the soft shadow of an edge is the closed-form fraction of the emitter it uncovers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

import raycast_shade as rs
from raycast_shade.common import layout as lay
from raycast_shade.shading.illumination import _light_point

CAM = rs.Camera(eye=(0.4, 0.6, 3.4), width=40, height=30, fov=40)


def _scene(light, reflectivity=0.0):
    ball = rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))
    floor = rs.Model(rs.shapes.plane(size=4, subdivisions=2, center=(0, 0, -1.0)),
                     rs.Material(kd=0.6, ks=0.2, specular="blinn", reflectivity=reflectivity))
    return rs.Scene([ball, floor], lights=[light, rs.DirectionalLight((0.2, -0.3, -1.0), intensity=0.2)],
                    camera=CAM, ambient=0.05)


@pytest.mark.parametrize("shadows", [False, True])
@pytest.mark.parametrize("shape", ["rectangle", "disc"])
def test_one_sample_is_the_point_light_at_the_centre_bit_for_bit(shape, shadows):
    """Every shading method, the terms pass and a mirror bounce: the same bits as a PointLight."""
    kw = dict(intensity=12.0, color=(1.0, 0.9, 0.8), attenuation="inverse_square", shadows=shadows)
    point = rs.PointLight((1.5, 2.0, 2.5), **kw)
    area = rs.AreaLight((1.5, 2.0, 2.5), u=(0.8, 0.0, 0.0), v=(0.0, 0.6, -0.3), shape=shape, samples=1, **kw)
    for shading in ("phong", "flat", "gouraud"):
        a, b = rs.render(_scene(point), shading), rs.render(_scene(area), shading)
        assert np.array_equal(a.image, b.image), shading
    a, b = rs.render(_scene(point), terms=True), rs.render(_scene(area), terms=True)
    for name in a.terms:
        assert np.array_equal(a.terms[name], b.terms[name]), name
    a, b = rs.render(_scene(point, 0.4)), rs.render(_scene(area, 0.4))
    assert np.array_equal(a.image, b.image)


@njit(cache=False)
def _points(rows, i, n):
    out = np.empty((n, 3))
    for j in range(n):
        out[j, 0], out[j, 1], out[j, 2] = _light_point(rows, i, j, np.bool_(True))
    return out


@pytest.mark.parametrize("shape", ["rectangle", "disc"])
@pytest.mark.parametrize("samples", [1, 7, 64])
def test_the_kernels_samples_are_the_numpy_twins_and_lie_on_the_emitter(shape, samples):
    light = rs.AreaLight((0.5, -1.0, 2.0), u=(2.0, 0.0, 0.0), v=(0.0, 0.0, 1.0), shape=shape, samples=samples)
    origin = np.array([0.25, 0.5, -0.75])
    got = _points(light.pack(origin)[None], 0, samples) + origin
    want = light.sample_points()
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)
    # In the emitter's own coordinates: x along u, z along v, y the plane's.
    rel = want - light.position
    np.testing.assert_allclose(rel[:, 1], 0.0, atol=1e-15)
    a, b = rel[:, 0] / (1.0 if shape == "rectangle" else 2.0), rel[:, 2] / (0.5 if shape == "rectangle" else 1.0)
    if shape == "rectangle":
        assert np.all(np.abs(a) <= 1.0) and np.all(np.abs(b) <= 1.0)
        # Stratified along u: one sample in each of the N columns.
        cols = np.floor((rel[:, 0] + 1.0) / 2.0 * samples).astype(int)
        assert sorted(cols) == list(range(samples))
    else:
        assert np.all(a * a + b * b <= 1.0 + 1e-12)
    if samples == 1:
        assert np.array_equal(want[0], light.position)


def _visible_fraction(shape, c, size):
    """The closed form: the fraction of the emitter with x >= c (x along its first axis).
    A disc of radius ``size``: the circular segment's area over the disc's; a rectangle of
    width ``2 size``: a strip."""
    d = min(max(c / size, -1.0), 1.0)
    if shape == "disc":
        return (math.acos(d) - d * math.sqrt(1.0 - d * d)) / math.pi
    return (1.0 - d) / 2.0


@pytest.mark.parametrize("shape", ["disc", "rectangle"])
def test_the_soft_shadow_of_an_edge_is_the_closed_form_fraction_of_the_emitter(shape):
    """A half-plane occluder (x <= 0 at height h) under an emitter (centre at height H, facing
    down, half-width R along x): a floor point at x0 sees the emitter's part with
    x >= -x0 (H - h) / h. The terms' shadow mask (the unblocked fraction of the samples) follows
    the closed form within the lattice's discrepancy, and the image is the plain-NumPy sum over the
    samples it leaves visible."""
    R, H, h, n = 0.5, 2.0, 1.0, 1024
    if shape == "disc":
        light = rs.AreaLight.disc((0.0, 0.0, H), (0.0, 0.0, -1.0), R, samples=n, shadows=True)
    else:
        light = rs.AreaLight((0.0, 0.0, H), u=(2 * R, 0.0, 0.0), v=(0.0, 2 * R, 0.0), samples=n, shadows=True)
    floor = rs.Mesh(np.array([[-3.0, -3.0, 0.0], [3.0, -3.0, 0.0], [3.0, 3.0, 0.0], [-3.0, 3.0, 0.0]]),
                    np.array([[0, 1, 2], [0, 2, 3]]))
    blocker = rs.Mesh(np.array([[-9.0, -9.0, h], [0.0, -9.0, h], [0.0, 9.0, h], [-9.0, 9.0, h]]),
                      np.array([[0, 1, 2], [0, 2, 3]]))
    cam = rs.Camera(eye=(0.32, 0.0, 5.0), target=(0.32, 0.0, 0.0), width=48, height=8,
                    projection="orthographic", ortho_height=0.1)
    scene = rs.Scene([rs.Model(floor, rs.Material(kd=0.8)), rs.Model(blocker, rs.Material(kd=0.1))],
                     lights=[light], camera=cam, ambient=0.0)
    frame = rs.render(scene, terms=True, buffers=("position",))
    pos = frame.buffers["position"]
    on_floor = np.abs(pos[..., 2]) < 1e-6
    assert on_floor.sum() > 300  # the camera sees the floor beside the blocker
    x0 = pos[..., 0][on_floor]
    mask = frame.terms["shadow"][0][on_floor]
    want = np.array([_visible_fraction(shape, -x * (H - h) / h, R) for x in x0])
    assert np.abs(mask - want).max() < 0.01
    assert mask.min() < 0.55 and mask.max() == 1.0  # the penumbra from half the light to all of it
    # The image: the NumPy sum over the samples the closed-form geometry leaves visible.
    q = light.sample_points()
    p = pos[on_floor].astype(np.float64)
    to = q[None, :, :] - p[:, None, :]
    dist = np.linalg.norm(to, axis=2)
    cos = to[..., 2] / dist
    cross = p[:, None, 0] + (q[None, :, 0] - p[:, None, 0]) * (h / H)  # where the way crosses z = h
    expected = 0.8 * (cos * (cross >= 0.0)).sum(axis=1) / n
    got = frame.image[on_floor][:, 0]
    assert np.abs(got - expected).max() < 2e-3  # a sample's share is 1e-3: at most one ray on the edge
    assert np.median(np.abs(got - expected)) < 1e-6


def test_an_area_light_refuses_bad_geometry_by_name():
    with pytest.raises(ValueError, match=r"lamp.u, lamp.v: .*perpendicular"):
        rs.AreaLight((0, 0, 1), u=(1, 0, 0), v=(1, 1, 0), name="lamp")
    with pytest.raises(ValueError, match=r"area_light.u"):
        rs.AreaLight((0, 0, 1), u=(0, 0, 0))
    with pytest.raises(ValueError, match=r"area_light.samples: must be <= 4096"):
        rs.AreaLight((0, 0, 1), samples=5000)
    with pytest.raises(TypeError, match=r"area_light.samples"):
        rs.AreaLight((0, 0, 1), samples=2.5)
    with pytest.raises(ValueError, match=r"area_light.shape"):
        rs.AreaLight((0, 0, 1), shape="triangle")
    with pytest.raises(ValueError, match=r"area_light.radius"):
        rs.AreaLight.disc((0, 0, 1), (0, 0, -1), 0.0)


def test_an_area_light_packs_its_axes_samples_and_shape():
    rect = rs.AreaLight((1, 2, 3), u=(2, 0, 0), v=(0, 4, 0), samples=9)
    row = rect.pack(np.zeros(3))
    assert row[lay.LIGHT_KIND] == lay.LIGHT_AREA == lay.LIGHT_KINDS["area"]
    np.testing.assert_array_equal(row[lay.LIGHT_EDGE_U:lay.LIGHT_EDGE_U + 3], [1, 0, 0])  # half-edges
    np.testing.assert_array_equal(row[lay.LIGHT_EDGE_V:lay.LIGHT_EDGE_V + 3], [0, 2, 0])
    assert row[lay.LIGHT_SAMPLES] == 9 and row[lay.LIGHT_SHAPE] == lay.AREA_RECTANGLE
    disc = rs.AreaLight.disc((0, 0, 0), (0, 0, 1), 2.0, samples=3)
    row = disc.pack(np.zeros(3))
    assert row[lay.LIGHT_SHAPE] == lay.AREA_DISC
    assert np.linalg.norm(row[lay.LIGHT_EDGE_U:lay.LIGHT_EDGE_U + 3]) == pytest.approx(2.0, rel=1e-15)
    assert disc.area == pytest.approx(4 * math.pi, rel=1e-15) and rect.area == pytest.approx(8.0, rel=1e-15)
    assert rs.PointLight((0, 0, 1)).pack(np.zeros(3))[lay.LIGHT_SAMPLES] == 1.0


def test_explain_lists_each_sample_and_adds_up_to_the_pixel():
    """explain walks the same samples (each its own term, 1/N of the light in ``att``): its total is
    the pixel, in the shade and in the penumbra, where some samples are blocked and some lit."""
    light = rs.AreaLight((1.0, 1.5, 2.0), u=(1.2, 0.0, 0.0), v=(0.0, 0.0, 1.2), samples=9, intensity=8.0,
                         attenuation="inverse_square", shadows=True)
    frame = rs.render(_scene(light))
    kinds = set()
    for y in range(0, 30, 3):
        for x in range(0, 40, 3):
            if frame.hits.prim[y, x] < 0:
                continue
            e = frame.explain(x, y)
            np.testing.assert_allclose(e.total, frame.image[y, x], rtol=1e-5, atol=1e-7)
            terms = [t for t in e.shades[0].lights if t.index == 0]
            assert [t.sample for t in terms] == list(range(9)) and {t.samples for t in terms} == {9}
            kinds.add(tuple(sorted({t.shadow for t in terms})))
    assert ("blocked", "lit") in kinds  # a penumbra pixel was explained
    assert "area sample 3 of 9" in str(frame.explain(20, 28))


def test_the_numpy_twin_and_the_exact_renderer_sum_the_same_samples():
    """Without shadow rays (which they do not model), the float64 twins evaluate an area light as
    its samples: the kernels' image within float32 rounding."""
    from raycast_shade.study.reference import shade_reference

    light = rs.AreaLight.disc((1.0, 1.5, 2.0), (-0.4, -0.6, -0.8), 0.8, samples=7, intensity=8.0,
                              attenuation="heuristic", k=0.5)
    scene = _scene(light)
    frame = rs.render(scene, "phong")
    ref = shade_reference(scene, scene.camera, frame.hits, "phong")
    np.testing.assert_allclose(frame.image, ref, rtol=2e-6, atol=2e-7)
    point = rs.render(_scene(rs.PointLight((1.0, 1.5, 2.0), intensity=8.0, attenuation="heuristic", k=0.5)))
    assert np.abs(point.image - frame.image).max() > 1e-3  # the samples are not the centre
