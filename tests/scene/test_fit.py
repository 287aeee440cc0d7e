"""Camera.fit frames what it is given: closed-form checks, hypothesis over random point sets."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs


def _ndc(camera, points):
    """Each point's position in the frame: (x, y) in [-1, 1] at the edges, NumPy from the camera's basis."""
    r, u, f = camera.basis
    hx, hy = camera.half_extents()
    q = np.asarray(points, np.float64) - camera.eye
    if camera.orthographic:
        return q @ r / hx, q @ u / hy, q @ f
    z = q @ f
    return q @ r / (z * hx), q @ u / (z * hy), z


def _centre(points):
    p = np.asarray(points, np.float64)
    return 0.5 * (p.min(axis=0) + p.max(axis=0))


def _check(camera, points, margin):
    x, y, z = _ndc(camera, points)
    keep = 1.0 - margin
    assert (z > 0).all()
    assert np.abs(x).max() <= keep + 1e-6 and np.abs(y).max() <= keep + 1e-6
    # The tighter axis touches the margin on both sides; the other is centred.
    tx = np.isclose(x.max(), keep, atol=1e-6) and np.isclose(x.min(), -keep, atol=1e-6)
    ty = np.isclose(y.max(), keep, atol=1e-6) and np.isclose(y.min(), -keep, atol=1e-6)
    near = np.isclose(z.min(), 0.01 * np.abs(np.asarray(points) - _centre(points)).max(), rtol=1e-6)
    assert tx or ty or near  # or the eye is as near as fit allows (wide fields of view)
    if camera.orthographic:
        assert np.isclose(x.max(), -x.min()) and np.isclose(y.max(), -y.min())


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(3, 40), margin=st.floats(0.0, 0.5),
       aspect=st.sampled_from([(64, 48), (48, 64), (50, 50), (200, 20)]), fov=st.floats(5.0, 120.0),
       ortho=st.booleans(), scale=st.sampled_from([1e-3, 1.0, 1e4]), offset=st.floats(-1e3, 1e3))
def test_every_point_inside_with_the_margin_and_the_extreme_one_touching(seed, n, margin, aspect, fov, ortho, scale,
                                                                          offset):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n, 3)) * scale * rng.uniform(0.2, 3.0, 3) + offset
    direction = rng.normal(size=3)
    if abs(direction[1]) > 0.95 * np.linalg.norm(direction):
        direction[0] += 1.0
    cam = rs.Camera.fit(pts, direction, margin=margin, width=aspect[0], height=aspect[1], fov=fov,
                        projection="orthographic" if ortho else "perspective")
    _check(cam, pts, margin)
    np.testing.assert_allclose(cam.basis[2], direction / np.linalg.norm(direction), atol=1e-12)


def test_bounds_scene_model_and_mesh_are_framed_by_their_corners_and_vertices():
    sphere = rs.shapes.uv_sphere(8, 16, radius=0.5, center=(3.0, 1.0, -2.0))
    scene = rs.Scene([rs.Model(sphere, rs.Material())])
    for what in (scene, scene.models[0], sphere, [scene.models[0]]):
        cam = rs.Camera.fit(what, (0, 0, -1), margin=0.1, width=40, height=30)
        _check(cam, sphere.vertices, 0.1)
    box = np.array([[-1.0, -2.0, -3.0], [1.0, 2.0, 3.0]])
    cam = rs.Camera.fit(box, (1, -1, -1), margin=0.0)
    corners = np.array([[x, y, z] for x in box[:, 0] for y in box[:, 1] for z in box[:, 2]])
    _check(cam, corners, 0.0)


def test_a_fitted_render_shows_the_model_touching_the_margin():
    sphere = rs.shapes.uv_sphere(16, 32)
    cam = rs.Camera.fit(sphere, (0, 0, -1), margin=0.25, width=64, height=64, fov=40)
    scene = rs.Scene([rs.Model(sphere, rs.Material())], lights=[rs.DirectionalLight((0, 0, -1))], camera=cam)
    mask = rs.render(scene).mask
    rows, cols = np.nonzero(mask)
    # The sphere's vertices reach 0.75 of the half-size: pixels 8 .. 55 (its silhouette lies within them).
    assert rows.min() >= 8 and rows.max() <= 55 and cols.min() >= 8 and cols.max() <= 55
    assert rows.min() <= 10 and cols.max() >= 53


@pytest.mark.parametrize("bad, match", [
    (np.zeros((3, 3)), "the points coincide"),
    ("abc", "expected a Scene"),
    (np.array([[np.nan, 0, 0], [1, 1, 1]]), "finite"),
])
def test_bad_input_is_refused(bad, match):
    with pytest.raises((ValueError, TypeError), match=match):
        rs.Camera.fit(bad)
    with pytest.raises(ValueError, match="margin"):
        rs.Camera.fit(np.eye(3), margin=1.0)
    with pytest.raises(ValueError, match="parallel to up"):
        rs.Camera.fit(np.eye(3), direction=(0, -1, 0))


def test_a_camera_that_sees_nothing_warns_and_its_image_is_empty():
    sphere = rs.shapes.uv_sphere(8, 16)
    light = [rs.DirectionalLight((0, 0, -1))]
    away = rs.Scene([rs.Model(sphere, rs.Material())], lights=light,
                    camera=rs.Camera(eye=(0, 0, 5), target=(0, 0, 10), width=16, height=16))
    with pytest.warns(rs.EmptyViewWarning, match=r"sees none of the scene.*Camera.fit"):
        frame = rs.render(away)
    assert not frame.mask.any()
    fitted = away.replace(camera=rs.Camera.fit(away, (0, 0, 1), width=16, height=16))
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.EmptyViewWarning)
        assert rs.render(fitted).mask.any()


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), ortho=st.booleans())
def test_outside_view_is_a_bound_never_wrong_when_it_warns(seed, ortho):
    """Where outside_view says the box is out of view, no ray hits it (both projections)."""
    from raycast_shade.scene.pitfalls import outside_view

    rng = np.random.default_rng(seed)
    box = rs.shapes.cube(size=float(rng.uniform(0.2, 2.0)), center=rng.uniform(-4, 4, 3))
    cam = rs.Camera(eye=rng.uniform(-3, 3, 3), target=rng.uniform(-3, 3, 3) + 0.1, width=12, height=10,
                    fov=float(rng.uniform(10, 100)), projection="orthographic" if ortho else "perspective",
                    ortho_height=float(rng.uniform(0.5, 4)))
    if outside_view(cam, box.bounds):
        scene = rs.Scene([rs.Model(box, rs.Material())], lights=[rs.DirectionalLight((0, 0, -1))], camera=cam)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            assert not rs.render(scene).mask.any()


def test_fit_in_a_scene_file_frames_the_objects(tmp_path):
    from raycast_shade.scene.scenefile import SceneFileError, load_scene

    body = '[[object]]\nshape = "uv_sphere"\ncenter = [5.0, 2.0, -3.0]\nradius = 0.5\n'
    (tmp_path / "a.toml").write_text('[camera]\nfit = true\ndirection = [0, 0, -1]\nmargin = 0.2\nwidth = 40\n'
                                     'height = 30\n' + body)
    scene, _ = load_scene(tmp_path / "a.toml")
    assert scene.camera.width == 40
    _check(scene.camera, scene.models[0].mesh.vertices, 0.2)
    (tmp_path / "b.toml").write_text('[camera]\nfit = true\neye = [0, 0, 5]\n' + body)
    with pytest.raises(SceneFileError, match=r"camera.eye: not with fit = true"):
        load_scene(tmp_path / "b.toml")
    (tmp_path / "c.toml").write_text('[camera]\neye = [0, 0, 5]\nmargin = 0.1\n' + body)
    with pytest.raises(SceneFileError, match=r"camera.margin: only with fit = true"):
        load_scene(tmp_path / "c.toml")
    (tmp_path / "d.toml").write_text('[camera]\nfit = "yes"\n' + body)
    with pytest.raises(SceneFileError, match=r"camera.fit: expected true or false"):
        load_scene(tmp_path / "d.toml")


def test_cli_renders_a_mesh_file_framed_and_inspects_it(tmp_path, capsys):
    import trimesh
    from PIL import Image

    from raycast_shade.apps.cli import main

    box = trimesh.creation.box()
    rng = np.random.default_rng(0)
    img = Image.fromarray(rng.integers(0, 256, (4, 4, 3), dtype=np.uint8)).convert("P")
    box.visual = trimesh.visual.TextureVisuals(uv=rng.random((8, 2)), material=trimesh.visual.material.PBRMaterial(
        baseColorTexture=img, metallicFactor=0.0, name="painted"))
    box.export(tmp_path / "box.glb")
    out = tmp_path / "box.png"
    assert main(["render", str(tmp_path / "box.glb"), "-o", str(out), "--width", "48", "--height", "32",
                 "--shading", "gouraud"]) == 0
    assert "48x32, gouraud" in capsys.readouterr().out
    pixels = np.asarray(Image.open(out))
    assert pixels.shape == (32, 48, 3)
    lit = pixels.max(axis=2) > 0
    # Framed: the box's silhouette reaches within the 5% margin of the frame's tighter axis, and no further.
    rows = np.flatnonzero(lit.any(axis=1))
    assert rows.min() <= 3 and rows.max() >= 28 and not lit[0].any() and not lit[-1].any()
    assert main(["inspect", str(tmp_path / "box.glb")]) == 0
    text = capsys.readouterr().out
    assert "8 vertices, 12 faces, UVs yes" in text and "material painted" in text
    assert "texture painted.baseColorTexture: 4x4 P" in text
    assert "mapped       baseColorTexture" in text
    assert main(["inspect", str(tmp_path / "nothere.glb")]) == 2
    assert main(["render", str(tmp_path / "box.glb"), "--shading", "flat,phong"]) == 2
