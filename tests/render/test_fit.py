"""rs.grad and rs.fit end to end: the inverse problems the gradients are for.

Recovery: parameters rendered into a target image are found again by ``rs.fit`` from a wrong
start (relative error <= 1e-3). Photometric stereo: a sphere's normals from three directional
lights, per pixel by least squares on the rendered images, and per vertex by gradient descent
on ``rs.grad``'s normal gradients (<= 0.5 degrees). And the API's refusals.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.optimize import minimize

import raycast_shade as rs
from raycast_shade.gradients import DEFAULT_WRT, WRT
from raycast_shade.study.reference import hit_points

H, W = 36, 48


def _sphere(kd=(0.6, 0.4, 0.3), ks=0.5, shininess=20.0, position=(2.0, 3.0, 4.0), lights=None, subdivisions=2,
            **mat):
    lights = lights or [rs.PointLight(position, intensity=20.0, attenuation="inverse_square")]
    return rs.Scene([rs.Model(rs.shapes.icosphere(subdivisions), rs.Material(kd=kd, ks=ks, shininess=shininess,
                                                                             **mat))],
                    lights=lights, camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H), ambient=0.1)


def _relative(got, want):
    return float(np.max(np.abs(np.asarray(got) - want) / np.abs(want)))


def test_fit_recovers_kd_ks_shininess_and_light_position_from_a_rendered_target():
    target = rs.render(_sphere(), "phong").image
    start = _sphere(kd=(0.3, 0.3, 0.3), ks=0.2, shininess=10.0, position=(1.0, 2.0, 5.0))
    seen = []
    result = rs.fit(start, target, ("kd", "ks", "shininess", "light_position"), progress=lambda i, v: seen.append(v),
                    keep_images=True)
    assert _relative(result.values["kd"][0], (0.6, 0.4, 0.3)) <= 1e-3
    assert _relative(result.values["ks"][0], (0.5, 0.5, 0.5)) <= 1e-3
    assert _relative(result.values["shininess"], 20.0) <= 1e-3
    assert _relative(result.values["light_position"][0], (2.0, 3.0, 4.0)) <= 1e-3
    assert result.losses[-1] < 1e-6 * result.losses[0]
    assert seen == list(result.losses) and len(result.images) == len(result.losses)
    # The fitted scene renders the target.
    again = rs.render(result.scene, "phong").image
    assert np.max(np.abs(again - target)) < 1e-3


@pytest.mark.parametrize("shading", ["gouraud", "flat"])
def test_fit_recovers_a_directional_light_and_ambient_with_other_methods(shading):
    sun = rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.9)
    truth = _sphere(lights=[sun])
    target = rs.render(truth, shading).image
    start = truth.replace(lights=(rs.DirectionalLight((-0.5, -1.0, -1.0), intensity=0.5),), ambient=0.3)
    result = rs.fit(start, target, ("light_direction", "light_intensity", "ambient"), shading=shading)
    d = result.values["light_direction"][0]
    assert np.degrees(np.arccos(np.clip(np.dot(d / np.linalg.norm(d), sun.direction), -1, 1))) < 0.06
    assert _relative(result.values["light_intensity"], 0.9) <= 1e-3
    assert _relative(result.values["ambient"], 0.1) <= 1e-3


def _stereo_scenes(subdivisions, width=W, height=H):
    dirs = [(-0.3, -0.2, -1.0), (0.4, -0.3, -1.0), (0.0, 0.45, -1.0)]
    base = _sphere(kd=0.7, ks=0.0, ka=0.0, subdivisions=subdivisions,
                   lights=[rs.DirectionalLight(dirs[0])])
    base = base.replace(camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=width, height=height))
    assert base.geometry is not None  # packed now, so that the three scenes share it (and its normals)
    return [base.replace(lights=(rs.DirectionalLight(d),)) for d in dirs], dirs


def test_photometric_stereo_recovers_the_sphere_normals_by_least_squares():
    scenes, dirs = _stereo_scenes(4)
    frames = [rs.render(s, "phong") for s in scenes]
    images = np.stack([f.image[..., 0].astype(np.float64) for f in frames], -1)  # (H, W, 3 lights)
    S = -np.array([d / np.linalg.norm(d) for d in dirs])  # rows: unit vectors towards the lights
    lit = np.all(images > 1e-3, axis=-1)  # every light reaches the pixel (n.s > 0 for all three)
    assert lit.sum() > 300
    g = np.linalg.solve(S, images[lit].T).T  # kd * n
    n = g / np.linalg.norm(g, axis=1, keepdims=True)
    p = hit_points(scenes[0], frames[0].hits)[lit]
    true = p / np.linalg.norm(p, axis=1, keepdims=True)  # the sphere's own normal (centre at the origin)
    angle = np.degrees(np.arccos(np.clip(np.sum(n * true, axis=1), -1, 1)))
    assert angle.max() <= 0.5
    assert np.median(np.linalg.norm(g, axis=1)) == pytest.approx(0.7, rel=1e-4)


@pytest.mark.parametrize("shading", ["gouraud", "phong"])
def test_photometric_stereo_recovers_vertex_normals_by_gradient_descent(shading):
    """Vertex normals from three lights by L-BFGS-B on rs.grad's normal gradients, each normal kept unit
    (``n = x / |x|``: Phong renormalises its interpolated normal, so a vertex normal's length would be
    nearly free). The normals fitted are those all three lights reach at a grazing angle of at least
    14 degrees (n.s > 0.25), so that the start (about 5 degrees off) crosses no terminator: past one a
    shade is clamped at 0 and its gradient vanishes with it (with n.s > 0.1, one Gouraud vertex stayed
    1.2 degrees off). The others, held at their values, border them."""
    scenes, dirs = _stereo_scenes(2, 96, 72)
    geo = scenes[0].geometry  # shared by the three scenes (only their lights differ)
    truth = geo.normals.copy()
    targets = [rs.render(s, shading).image.astype(np.float64) for s in scenes]
    prim = rs.render(scenes[0], shading).hits.prim
    towards = -np.array([d / np.linalg.norm(d) for d in dirs])
    in_view = np.unique(geo.faces[np.unique(prim[prim >= 0])])
    free = in_view[(truth[in_view] @ towards.T).min(axis=1) > 0.25]
    assert len(free) >= 25
    rng = np.random.default_rng(3)
    start = truth[free] + 0.08 * rng.standard_normal((len(free), 3))  # about 5 degrees off
    start /= np.linalg.norm(start, axis=1, keepdims=True)

    def loss(x):
        x = x.reshape(-1, 3)
        length = np.linalg.norm(x, axis=1, keepdims=True)
        n = x / length
        geo.normals[free] = n
        value, g = 0.0, np.zeros_like(n)
        for scene, target in zip(scenes, targets):
            frame = rs.render(scene, shading)
            r = frame.image - target
            value += float(np.sum(r * r))
            g += rs.grad(scene, 2.0 * r, "normals", shading=shading, frame=frame)["normals"][free]
        g = (g - np.sum(g * n, axis=1, keepdims=True) * n) / length  # back through x / |x|
        return value, g.ravel()

    try:
        res = minimize(loss, start.ravel(), jac=True, method="L-BFGS-B",
                       options=dict(maxiter=500, ftol=1e-16, gtol=1e-14))
        fitted = res.x.reshape(-1, 3)
    finally:
        geo.normals[:] = truth
    unit = fitted / np.linalg.norm(fitted, axis=1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip(np.sum(unit * truth[free], axis=1), -1, 1)))
    start_angle = np.degrees(np.arccos(np.clip(np.sum(start * truth[free], axis=1), -1, 1)))
    assert start_angle.max() > 5.0, start_angle
    assert angle.max() <= 0.5, (np.sort(angle), res.message)
    assert np.median(angle) <= 0.01


# -- the API's refusals ------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def scene():
    return _sphere()


def test_grad_returns_every_default_name_with_its_shape(scene):
    g = rs.grad(scene, np.ones((H, W, 3)))
    assert set(g) == set(DEFAULT_WRT) and "normals" in WRT
    assert g["kd"].shape == (1, 3) and g["shininess"].shape == (1,) and g["ambient"].shape == (3,)
    assert g["light_position"].shape == (1, 3) and g["light_intensity"].shape == (1,)
    assert np.all(g["kd"] > 0)  # more diffuse light, a larger sum


def test_grad_refuses_unknown_names_listing_the_valid_ones(scene):
    with pytest.raises(ValueError, match="wrt") as e:
        rs.grad(scene, np.ones((H, W, 3)), ["kd", "glossiness"])
    assert "light_position" in str(e.value) and "glossiness" in str(e.value)


@pytest.mark.parametrize("bad, error", [(np.ones((H, W)), ValueError), (np.ones((H + 1, W, 3)), ValueError),
                                        (np.full((H, W, 3), np.nan), ValueError), (np.ones((H, W, 3), int), TypeError),
                                        ([[0.0]], TypeError)])
def test_grad_refuses_a_bad_dL_dimage(scene, bad, error):
    with pytest.raises(error, match="dL_dimage"):
        rs.grad(scene, bad)


@pytest.mark.parametrize("change, wrt, words", [
    (dict(bump=rs.HeightMap(np.linspace(0.0, 1.0, 16).reshape(4, 4), scale=0.05)), "vertices",
     "bump and normal maps: the geometry"),
    (dict(kd_map=rs.Texture(np.full((4, 4, 3), 0.5)), reflectivity=0.5), "kd", "reflectivity > 0"),
])
def test_grad_refuses_what_it_does_not_differentiate(change, wrt, words):
    mat = rs.Material(kd=0.5, ks=0.3, **change)
    mesh = rs.shapes.uv_sphere(12, 8) if "kd_map" in change or "bump" in change else rs.shapes.icosphere(1)
    scene = rs.Scene([rs.Model(mesh, mat)], lights=[rs.PointLight((2.0, 3.0, 4.0))],
                     camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H))
    with pytest.raises(ValueError, match=words):
        rs.grad(scene, np.ones((H, W, 3)), wrt)


def test_fit_refuses_mirrors_which_only_grad_differentiates():
    mat = rs.Material(kd=0.5, ks=0.3, reflectivity=0.5)
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1), mat)], lights=[rs.PointLight((2.0, 3.0, 4.0))],
                     camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=W, height=H))
    with pytest.raises(ValueError, match="reflectivity > 0"):
        rs.fit(scene, np.zeros((H, W, 3)), ("kd",))


def test_grad_refuses_foreign_or_antialiased_frames(scene):
    other = _sphere()
    with pytest.raises(ValueError, match="frame"):
        rs.grad(scene, np.ones((H, W, 3)), frame=rs.render(other))
    with pytest.raises(ValueError, match="frame: shaded with 'flat'"):
        rs.grad(scene, np.ones((H, W, 3)), shading="phong", frame=rs.render(scene, "flat"))
    with pytest.raises(ValueError, match="samples"):
        rs.grad(scene, np.ones((H, W, 3)), frame=rs.render(scene, samples=4))


def test_fit_refuses_what_it_cannot_fit(scene):
    target = np.zeros((H, W, 3))
    with pytest.raises(ValueError, match="params"):
        rs.fit(scene, target, ("kd", "roughness"))
    with pytest.raises(ValueError, match="light_direction"):
        rs.fit(scene, target, "light_direction")  # the scene has no directional light
    with pytest.raises(ValueError, match="params"):
        rs.fit(scene, target, ("light_radiance", "light_intensity"))
    with pytest.raises(ValueError, match="target"):
        rs.fit(scene, np.zeros((H, W)), "kd")
    with pytest.raises(ValueError, match="loss"):
        rs.fit(scene, target, "kd", loss="l3")


def test_fit_takes_a_loss_of_its_own():
    truth = _sphere()
    target = rs.render(truth, "phong").image.astype(np.float64)

    def l1ish(image, t):  # a smooth robust loss: sum sqrt(r^2 + eps^2)
        r = image - t
        q = np.sqrt(r * r + 1e-8)
        return float(np.sum(q)), r / q

    result = rs.fit(_sphere(kd=(0.2, 0.2, 0.2)), target, "kd", loss=l1ish)
    assert _relative(result.values["kd"][0], (0.6, 0.4, 0.3)) <= 1e-3
    assert dataclasses.is_dataclass(result) and result.evaluations >= len(result.losses) - 1


def _ball(shift=(0.0, 0.0, 0.0), eye=(0.0, 0.0, 4.0)):
    mat = rs.Material(ka=0.2, kd=(0.7, 0.5, 0.3), ks=0.3, shininess=10.0)
    return rs.Scene([rs.Model(rs.shapes.icosphere(2, radius=1.0, center=tuple(shift)), mat)],
                    camera=rs.Camera(eye=eye, target=(eye[0], eye[1], 0.0), width=48, height=36),
                    lights=[rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square")],
                    ambient=0.3, background=(0.1, 0.2, 0.3))


def test_fit_recovers_a_translation_through_the_silhouette():
    """Geometry: the sphere's translation from the anti-aliased target (16 rays per pixel), each
    evaluation rendered afresh and differentiated with the edge term (measured: to 1e-7)."""
    truth = np.array([0.15, -0.1, 0.0])
    target = rs.render(_ball(truth), "phong", samples=16).image
    res = rs.fit(_ball(), target, ("translation",), samples=16, max_iter=40)
    assert res.values["translation"].shape == (1, 3)
    assert np.allclose(res.values["translation"][0], truth, atol=1e-4)
    assert res.losses[-1] < 1e-6 * res.losses[0]
    moved = res.scene.geometry.vertices + res.scene.geometry.origin
    start = _ball().geometry.vertices + _ball().geometry.origin
    assert np.allclose(moved - start, truth, atol=1e-4)  # the fitted scene carries it


def test_fit_recovers_a_camera_offset():
    eye = np.array([0.1, 0.12, 4.2])
    target = rs.render(_ball(eye=tuple(eye)), "phong", samples=16).image
    res = rs.fit(_ball(), target, ("camera_eye",), samples=16, max_iter=40)
    assert np.allclose(res.values["camera_eye"], eye, atol=1e-3)
    assert np.allclose(res.scene.camera.eye, eye, atol=1e-3)


def test_fit_keeps_geometry_apart_from_shading_parameters():
    with pytest.raises(ValueError, match="translation"):
        rs.fit(_ball(), rs.render(_ball(), "phong").image, ("translation", "kd"))
