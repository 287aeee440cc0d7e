"""Tangent-space normal maps (Material.normal_map): closed forms on planes, the identity map,
tangents computed from UVs, and validation."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.scene.tangents import vertex_tangents
from tests.conftest import down_camera, plane_hits

LIGHT = np.array([0.3, -0.45, -1.0])  # from the light to the scene


def constant_map(rgb):
    return rs.Texture(np.full((4, 4, 3), rgb, np.float32), name="nmap")


def plane_scene(mesh, cam, **mat):
    material = rs.Material(kd=0.7, ka=0.0, **mat)
    return rs.Scene([rs.Model(mesh, material)], lights=[rs.DirectionalLight(LIGHT)], camera=cam, ambient=0.0)


def expected_normal(rgb, scale, t, b, n):
    """The closed form n' = normalize(T (2r-1) s + B (2g-1) s + N (2b-1)) from the float32 texel."""
    r, g, bl = (np.float64(np.float32(c)) for c in rgb)
    a = np.array(t) * (2 * r - 1) * scale + np.array(b) * (2 * g - 1) * scale + np.array(n) * (2 * bl - 1)
    return a / np.linalg.norm(a)


def test_flat_map_equals_no_map():
    """(0.5, 0.5, 1) is the unbent normal: the same images within one ulp, Phong and mirrors alike."""
    cam = rs.Camera(eye=(0.4, 0.6, 3.5), width=96, height=72)
    sphere = rs.shapes.uv_sphere(24, 48)
    scenes = [rs.Scene([rs.Model(sphere, rs.Material(kd=(0.7, 0.6, 0.5), ks=0.4, shininess=20, normal_map=nm))],
                       lights=[rs.PointLight((1.0, 2.0, 4.0))], camera=cam, ambient=0.1)
              for nm in (constant_map((0.5, 0.5, 1.0)), None)]
    with_map, without = (rs.render(s) for s in scenes)
    assert with_map.mask.sum() > 1000
    np.testing.assert_array_equal(with_map.mask, without.mask)
    np.testing.assert_array_max_ulp(with_map.image, without.image, maxulp=1)
    np.testing.assert_array_max_ulp(with_map.normal, without.normal, maxulp=1)


@pytest.mark.parametrize("rgb, scale", [((0.8, 0.5, 0.9), 1.0), ((0.3, 0.75, 0.85), 1.0),
                                        ((0.7, 0.2, 0.6), 0.5), ((0.6, 0.6, 0.7), 2.5)])
def test_constant_tilt_on_plane_shades_as_closed_form(rgb, scale):
    """A plane with u along +x, v along +y: T = +x, B = +y, N = +z; Lambert under a directional
    light gives kd max(0, n'.s) exactly."""
    cam = down_camera(eye=(0.0, 0.0, 3.0))
    frame = rs.render(plane_scene(rs.shapes.plane(2.0), cam, normal_map=constant_map(rgb), normal_scale=scale))
    n = expected_normal(rgb, scale, (1, 0, 0), (0, 1, 0), (0, 0, 1))
    s = -LIGHT / np.linalg.norm(LIGHT)
    assert frame.mask.sum() > 1000
    np.testing.assert_allclose(frame.normal[frame.mask], np.broadcast_to(n, (frame.mask.sum(), 3)), atol=2e-7)
    np.testing.assert_allclose(frame.image[frame.mask], 0.7 * max(0.0, n @ s), rtol=2e-6)


def test_mirrored_uvs_keep_the_bump_on_the_same_side():
    """u running along -x mirrors the UV map: T = -x, w = -1, so B = w (N x T) is still +y and
    the green channel still tilts the normal towards +y."""
    cam = down_camera(eye=(0.0, 0.0, 3.0))
    plane = rs.shapes.plane(2.0)
    uv = np.array(plane.uvs)
    mirrored = rs.Mesh(plane.vertices, plane.faces, normals=plane.normals, uvs=np.c_[1.0 - uv[:, 0], uv[:, 1]])
    rgb = (0.8, 0.7, 0.8)
    frame = rs.render(plane_scene(mirrored, cam, normal_map=constant_map(rgb)))
    n = expected_normal(rgb, 1.0, (-1, 0, 0), (0, 1, 0), (0, 0, 1))
    np.testing.assert_allclose(frame.normal[frame.mask], np.broadcast_to(n, (frame.mask.sum(), 3)), atol=2e-7)


def test_given_tangents_are_used_as_written():
    """Tangents along +y with w = -1 (B = -(z x y) = +x): red tilts towards +y, green towards +x."""
    cam = down_camera(eye=(0.0, 0.0, 3.0))
    plane = rs.shapes.plane(2.0)
    tangents = np.tile([0.0, 1.0, 0.0, -1.0], (len(plane.vertices), 1))
    mesh = rs.Mesh(plane.vertices, plane.faces, normals=plane.normals, uvs=plane.uvs, tangents=tangents)
    rgb = (0.8, 0.35, 0.8)
    frame = rs.render(plane_scene(mesh, cam, normal_map=constant_map(rgb)))
    n = expected_normal(rgb, 1.0, (0, 1, 0), (1, 0, 0), (0, 0, 1))
    np.testing.assert_allclose(frame.normal[frame.mask], np.broadcast_to(n, (frame.mask.sum(), 3)), atol=2e-7)


@pytest.mark.parametrize("seed", range(4))
def test_vertex_tangents_match_the_uv_axes(seed):
    """uv = A (x, y) on the plane z = 0: T is along dP/du = A^-1's first column, w the sign of det A."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(2, 2))
    A[0, 0] += 2.0 * np.sign(A[0, 0])  # well conditioned
    x, y = np.meshgrid(np.linspace(-1, 1, 5), np.linspace(-1, 1, 4))
    verts = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    idx = np.arange(x.size).reshape(x.shape)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], -1).reshape(-1, 4)
    faces = np.r_[quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]
    uvs = verts[:, :2] @ A.T
    normals = np.tile([0.0, 0.0, 1.0], (len(verts), 1))
    t = vertex_tangents(verts, faces, uvs, normals)
    pu = np.linalg.inv(A)[:, 0]
    expected = np.r_[pu / np.linalg.norm(pu), 0.0]
    np.testing.assert_allclose(t[:, :3], np.broadcast_to(expected, (len(verts), 3)), atol=1e-12)
    np.testing.assert_array_equal(t[:, 3], np.sign(np.linalg.det(A)))


def test_vertex_tangents_are_orthogonal_unit_on_a_sphere():
    sphere = rs.shapes.uv_sphere(12, 24)
    p = sphere.prepared
    t = vertex_tangents(p.vertices, p.faces, p.uvs, p.normals)
    assert np.all(np.isfinite(t))
    np.testing.assert_allclose(np.linalg.norm(t[:, :3], axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.sum(t[:, :3] * p.normals, axis=1), 0.0, atol=1e-12)
    assert set(np.unique(t[:, 3])) <= {-1.0, 1.0}


@pytest.mark.parametrize("shading", ["flat", "gouraud"])
def test_normal_map_warns_in_flat_and_gouraud(shading):
    cam = down_camera()
    scene = plane_scene(rs.shapes.plane(2.0), cam, normal_map=constant_map((0.8, 0.5, 0.9)))
    with pytest.warns(rs.BumpIgnoredWarning, match="normal map"):
        frame = rs.render(scene, shading)
    plain = rs.render(plane_scene(rs.shapes.plane(2.0), cam), shading)
    np.testing.assert_array_equal(frame.image, plain.image)  # ignored, as the warning says


def test_validation():
    with pytest.raises(TypeError, match="normal_map"):
        rs.Material(normal_map=np.ones((2, 2, 3)))
    with pytest.raises(ValueError, match="normal_scale"):
        rs.Material(normal_scale=float("nan"))
    plane = rs.shapes.plane(2.0)
    with pytest.raises(ValueError, match="tangents"):
        rs.Mesh(plane.vertices, plane.faces, tangents=np.zeros((len(plane.vertices), 3)))
    with pytest.raises(ValueError, match="handedness"):
        rs.Mesh(plane.vertices, plane.faces, tangents=np.tile([1.0, 0, 0, 0.5], (len(plane.vertices), 1)))
    bare = rs.Mesh(plane.vertices, plane.faces)
    scene = rs.Scene([rs.Model(bare, rs.Material(normal_map=constant_map((0.5, 0.5, 1.0))))],
                     lights=[rs.DirectionalLight(LIGHT)], camera=down_camera())
    with pytest.raises(ValueError, match=r"normal_map but the mesh has no UVs"):
        rs.render(scene)


@pytest.mark.parametrize("wrap, scale", [("repeat", 1.0), ("clamp", 0.6), ("repeat", -1.5)])
def test_numpy_twin_and_explain_agree_with_the_kernel(wrap, scale):
    """A random normal map (every direction, some bent past the horizon) on a sphere and a floor."""
    from raycast_shade.study.reference import shade_reference, shading_normals_reference

    rng = np.random.default_rng(7)
    nmap = rs.Texture(rng.uniform(0, 1, (9, 7, 3)), wrap=wrap, tiling=(2.0, 1.5), name="random normals")
    sphere = rs.shapes.uv_sphere(16, 32)
    floor = rs.shapes.plane(6.0)
    floor = rs.Mesh(np.asarray(floor.vertices) - [0, 0, 1.0], floor.faces, normals=floor.normals, uvs=floor.uvs)
    mats = [rs.Material(kd=(0.7, 0.5, 0.3), ks=0.4, shininess=15, normal_map=nmap, normal_scale=scale),
            rs.Material(kd=0.6, normal_map=nmap)]
    cam = rs.Camera(eye=(1.5, -3.0, 2.5), target=(0, 0, -0.3), width=48, height=36)
    scene = rs.Scene([rs.Model(sphere, mats[0]), rs.Model(floor, mats[1])],
                     lights=[rs.PointLight((2.0, -1.0, 3.0)), rs.DirectionalLight((-0.3, 0.5, -1.0), intensity=0.4)],
                     camera=cam, ambient=0.1)
    frame = rs.render(scene, "phong")
    seen = frame.hits.prim >= 0
    assert seen.sum() > 800
    ref = shade_reference(scene, cam, frame.hits, "phong")
    np.testing.assert_allclose(frame.image[seen], ref[seen], rtol=1e-5, atol=1e-6)
    nref = shading_normals_reference(scene, cam, frame.hits, "phong")
    np.testing.assert_allclose(frame.normal[seen], nref[seen], atol=1e-6)
    plain = shading_normals_reference(rs.Scene([rs.Model(sphere, rs.Material()), rs.Model(floor, rs.Material())],
                                               lights=scene.lights, camera=cam), cam, frame.hits, "phong")
    assert np.abs(nref[seen] - plain[seen]).max() > 0.3  # the map does bend the normals
    ys, xs = np.nonzero(seen)
    for i in rng.choice(len(xs), 6, replace=False):
        e = frame.explain(int(xs[i]), int(ys[i]))
        np.testing.assert_allclose(e.total, frame.image[ys[i], xs[i]], rtol=1e-5, atol=1e-6)
        assert "normal map" in e.shades[0].normal_note
