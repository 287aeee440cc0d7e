"""Blinn bump mapping: closed forms on planes, robustness, and what it leaves alone.

A height map ``B(u, v)`` moves the normal as if the surface were displaced by
``scale * B`` along its front normal. On a plane the displaced surface is
again a plane, so the bumped normal has a closed form: with ``u = x / s``
across a plane of side ``s`` (normal ``+z``) and ``B = u``, the displaced
surface is ``z = scale * x / s`` and the normal is tilted towards ``-x`` by
``atan(scale / s)``. Blinn's perturbation is exact for a plane (its
second-order term ``Bu Bv (n x n)`` vanishes), so the only error left is the
float32 normal buffer.
"""

from __future__ import annotations

import math

import imageio.v3 as iio
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.scene.heightmap import tangent_frames

from tests.conftest import down_camera, plane_hits

RES = 64  # texels of the baked linear height maps (central differences are exact on them)


def linear_map(fn, scale, resolution=RES):
    return rs.HeightMap.from_function(fn, resolution=resolution, wrap="clamp", scale=scale)


def angle(a, b):
    """Angle (rad) between unit vectors along the last axis, float64."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def plane_uv(camera, size):
    """(H, W, 2) analytic UVs of the ``plane(size)`` (normal +z) under every pixel."""
    p, _ = plane_hits(camera)
    return (p[..., :2] + size / 2) / size


def interior(uv, margin=0.05):
    """Pixels well inside the UV square: clamping never reaches their differences."""
    return np.all((uv > margin) & (uv < 1 - margin), axis=-1)


def bump_scene(mesh, heightmap, camera, lights=None, ambient=0.1, **mat):
    lights = lights if lights is not None else [rs.PointLight((1.0, 2.0, 4.0), intensity=1.0)]
    material = rs.Material(kd=(0.7, 0.6, 0.5), ks=0.4, shininess=20, bump=heightmap, **mat)
    return rs.Scene([rs.Model(mesh, material)], lights=lights, camera=camera, ambient=ambient)


# ----------------------------------------------------------------------------------
# closed forms


def test_constant_height_leaves_image_unchanged():
    cam = rs.Camera(eye=(0.4, 0.6, 3.5), width=96, height=72)
    sphere = rs.shapes.icosphere(3)
    flat = rs.HeightMap(np.full((8, 8), 0.7), scale=3.0)
    with_bump = rs.render(bump_scene(sphere, flat, cam))
    without = rs.render(bump_scene(sphere, None, cam))
    assert with_bump.mask.sum() > 1000
    np.testing.assert_array_equal(with_bump.mask, without.mask)
    # Bu = Bv = 0: only the renormalisation of area * n rounds differently.
    np.testing.assert_allclose(with_bump.image, without.image, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(with_bump.normal, without.normal, rtol=0, atol=2e-7)


@pytest.mark.parametrize("size, scale", [(2.0, 0.5), (7.5, 3.0), (2.0, -1.3)])
def test_height_linear_in_u_tilts_normal_by_analytic_angle(size, scale):
    cam = down_camera(eye=(0.0, 0.0, 1.6 * size), width=81, height=61)
    hm = linear_map(lambda u, v: u, scale)
    frame = rs.render(bump_scene(rs.shapes.plane(size), hm, cam))
    inside = interior(plane_uv(cam, size)) & frame.mask
    assert inside.sum() > 1000
    tilt = math.atan(scale / size)
    expected = np.array([-math.sin(tilt), 0.0, math.cos(tilt)])  # z = scale x / s
    err = angle(frame.normal[inside], expected)
    assert err.max() < 2e-6, err.max()  # float32 normals
    measured = np.arctan2(-frame.normal[inside][:, 0], frame.normal[inside][:, 2])
    np.testing.assert_allclose(measured, tilt, atol=2e-6)


def test_height_linear_in_v_tilts_towards_minus_y():
    size, scale = 3.0, 0.8
    cam = down_camera(eye=(0.0, 0.0, 5.0))
    frame = rs.render(bump_scene(rs.shapes.plane(size), linear_map(lambda u, v: v, scale), cam))
    inside = interior(plane_uv(cam, size)) & frame.mask
    tilt = math.atan(scale / size)
    assert angle(frame.normal[inside], [0.0, -math.sin(tilt), math.cos(tilt)]).max() < 2e-6


def sheared_plane(size=2.0, n=4, shear=0.6, flip_u=False):
    """A +z plane whose UVs are a sheared (and optionally mirrored) affine map of x, y."""
    s = np.linspace(-size / 2, size / 2, n + 1)
    xx, yy = np.meshgrid(s, s, indexing="ij")
    verts = np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], 1)
    i, j = np.mgrid[0:n, 0:n]
    a = (i * (n + 1) + j).ravel()
    b = a + n + 1
    faces = np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)])
    v0 = verts[faces[:, 0]]
    nz = np.cross(verts[faces[:, 1]] - v0, verts[faces[:, 2]] - v0)[:, 2]
    faces = np.where((nz < 0)[:, None], faces[:, ::-1], faces)  # face +z
    # u = 0.5 + (x + shear y) / (3 size): stays inside (0.1, 0.9) on the plane.
    sign = -1.0 if flip_u else 1.0
    u = 0.5 + sign * (verts[:, 0] + shear * verts[:, 1]) / (3 * size)
    v = 0.5 + verts[:, 1] / (2 * size)
    return rs.Mesh(verts, faces, normals=np.tile([0.0, 0.0, 1.0], (len(verts), 1)), uvs=np.stack([u, v], 1)), sign


@pytest.mark.parametrize("flip_u", [False, True], ids=["sheared", "sheared-mirrored"])
def test_sheared_uvs_match_displaced_plane(flip_u):
    """Any affine UV map: the displaced surface is z = scale u(x, y), whose
    normal is (-scale du/dx, -scale du/dy, 1), whatever the handedness of the map."""
    size, scale, shear = 2.0, 0.9, 0.6
    mesh, sign = sheared_plane(size, shear=shear, flip_u=flip_u)
    cam = down_camera(eye=(0.0, 0.0, 2.5))
    frame = rs.render(bump_scene(mesh, linear_map(lambda u, v: u, scale), cam))
    n = frame.normal[frame.mask]
    assert len(n) > 1000
    assert np.all(np.isfinite(n))
    np.testing.assert_allclose(np.linalg.norm(n.astype(np.float64), axis=1), 1.0, atol=1e-6)
    grad = sign * np.array([1.0, shear]) / (3 * size)
    expected = np.array([-scale * grad[0], -scale * grad[1], 1.0])
    assert angle(n, expected).max() < 2e-6


def test_bump_sign_follows_front_normal_on_sphere():
    """The built-in spheres' UV map is left-handed (u grows eastwards, v
    southwards); a height rising with u must still lean the normal away
    from the rise (west), as a real displacement outwards would."""
    scale = 0.1
    cam = rs.Camera(eye=(0.0, 0.0, 4.0), width=33, height=33, fov=6)
    sphere = rs.shapes.icosphere(5)
    bumped = rs.render(bump_scene(sphere, linear_map(lambda u, v: u, scale, 256), cam))
    plain = rs.render(bump_scene(sphere, None, cam))
    c = (16, 16)
    # d(height)/dx at the front of a unit sphere: scale * du/dphi * dphi/dx = scale / (2 pi)
    lean = bumped.normal[c][0] - plain.normal[c][0]
    assert lean < 0
    np.testing.assert_allclose(lean, -scale / (2 * math.pi), rtol=0.05)


def test_dimples_are_dents_on_both_plane_orientations():
    """A dimple's near rim faces away from its centre's side: on its +x half the normal leans +x."""
    hm = rs.HeightMap.dimples(count=1, radius=0.45, resolution=128, scale=0.5)
    for normal, eye in (("+z", (0.0, 0.0, 3.0)), ("-z", (0.0, 0.0, -3.0))):
        cam = rs.Camera(eye=eye, width=65, height=65, fov=30)
        frame = rs.render(bump_scene(rs.shapes.plane(2.0, normal=normal), hm, cam))
        n = frame.normal
        # Pixel columns of world x > 0 (seen from -z the image is mirrored in x).
        right = slice(40, 50) if normal == "+z" else slice(15, 25)
        assert np.mean(n[28:37, right, 0]) < -0.05, normal  # a cup: normals lean towards its centre


# ----------------------------------------------------------------------------------
# robustness


def test_degenerate_uvs_stay_finite_and_unit():
    """All three UVs equal, or collinear, or nearly collinear: finite unit normals."""
    verts = np.array([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [0, 0, 0.3]])
    faces = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    uvs = np.array([[0.3, 0.3], [0.3, 0.3], [0.5, 0.5], [0.7, 0.7], [0.3, 0.3 + 1e-13]])
    # face 0: all three equal (to 1e-13); faces 1-3: collinear on the diagonal
    mesh = rs.Mesh(verts, faces, uvs=uvs)
    hm = rs.HeightMap.wrinkles(resolution=64, scale=2.0)
    tan = tangent_frames(verts, faces, uvs, np.cross(verts[faces[:, 1]] - verts[faces[:, 0]],
                                                    verts[faces[:, 2]] - verts[faces[:, 0]]))
    assert np.all(np.isfinite(tan))
    cam = rs.Camera(eye=(0.2, 0.3, 3.0), width=64, height=64, fov=50)
    frame = rs.render(bump_scene(mesh, hm, cam))
    n = frame.normal[frame.mask].astype(np.float64)
    assert len(n) > 1000
    assert np.all(np.isfinite(n)) and np.all(np.isfinite(frame.image))
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-6)
    # turned to the viewer, as every shading normal is
    assert np.all(n[:, 2] > 0)


def test_tangent_frames_fallback_is_in_plane_and_scaled():
    verts = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [5, 5, 5]])
    faces = np.array([[0, 1, 2], [3, 3, 3]])  # a UV-degenerate face and a zero-area face
    uvs = np.zeros((4, 2))
    fn = np.array([[0.0, 0, 1], [0, 0, 0]])
    tan = tangent_frames(verts, faces, uvs, fn)
    pu, pv = tan[:, :3], tan[:, 3:]
    assert np.all(np.isfinite(tan))
    assert abs(pu[0] @ fn[0]) < 1e-12 and abs(pv[0] @ fn[0]) < 1e-12  # in the face's plane
    np.testing.assert_allclose(np.linalg.norm(np.cross(pu[0], pv[0])), 4.0)  # scaled like the edges (2 x 2)
    assert np.linalg.norm(np.cross(pu[1], pv[1])) > 0


# ----------------------------------------------------------------------------------
# what bump mapping leaves alone


def test_silhouettes_and_depth_unchanged():
    cam = rs.Camera(eye=(0.5, 0.8, 3.2), width=120, height=90)
    sphere = rs.shapes.uv_sphere(24, 48)
    hm = rs.HeightMap.wrinkles(resolution=128, scale=0.3)
    for shading in rs.SHADINGS:
        a = rs.render(bump_scene(sphere, hm, cam), shading)
        b = rs.render(bump_scene(sphere, None, cam), shading)
        np.testing.assert_array_equal(a.mask, b.mask)
        np.testing.assert_array_equal(a.depth, b.depth)
        np.testing.assert_array_equal(a.prim_id, b.prim_id)
    # ... while the Phong image does change: the bump is real
    assert np.abs(a.image - b.image).max() > 0.05


@pytest.mark.parametrize("shading", ["flat", "gouraud"])
def test_bump_applies_in_phong_only(shading):
    cam = rs.Camera(eye=(0.5, 0.8, 3.2), width=96, height=72)
    sphere = rs.shapes.uv_sphere(16, 32)
    hm = rs.HeightMap.dimples(count=6, resolution=128, scale=0.2)
    scene, plain = bump_scene(sphere, hm, cam), bump_scene(sphere, None, cam)
    np.testing.assert_array_equal(rs.render(scene, shading).image, rs.render(plain, shading).image)
    np.testing.assert_array_equal(rs.render(scene, shading).normal, rs.render(plain, shading).normal)
    assert np.abs(rs.render(scene, "phong").image - rs.render(plain, "phong").image).max() > 0.02


# ----------------------------------------------------------------------------------
# height maps from images, and validation


def test_from_image_grey_png(tmp_path):
    img = np.array([[0, 64, 128], [255, 32, 16]], np.uint8)  # top row first
    path = tmp_path / "grey.png"
    iio.imwrite(path, img)
    hm = rs.HeightMap.from_image(path, scale=0.1)
    np.testing.assert_allclose(hm.heights, img[::-1] / 255.0, atol=1e-7)  # row 0 is v = 0: the bottom row
    assert hm.scale == 0.1


def test_from_image_rgb_png_uses_luminance(tmp_path):
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    path = tmp_path / "rgb.png"
    iio.imwrite(path, img)
    hm = rs.HeightMap.from_image(path)
    lum = img.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722]) / 255.0
    np.testing.assert_allclose(hm.heights, lum[::-1], atol=1e-6)
    # and an RGBA file ignores alpha
    rgba = np.concatenate([img, np.full((5, 7, 1), 7, np.uint8)], axis=2)
    iio.imwrite(tmp_path / "rgba.png", rgba)
    np.testing.assert_allclose(rs.HeightMap.from_image(tmp_path / "rgba.png").heights, lum[::-1], atol=1e-6)


def test_from_image_16_bit(tmp_path):
    img = np.array([[0, 65535], [32768, 1000]], np.uint16)
    iio.imwrite(tmp_path / "h16.png", img)
    np.testing.assert_allclose(rs.HeightMap.from_image(tmp_path / "h16.png").heights, img[::-1] / 65535.0, atol=1e-7)


def test_validation_errors(tmp_path):
    with pytest.raises(ValueError, match="wrap"):
        rs.HeightMap(np.zeros((4, 4)), wrap="mirror")
    with pytest.raises(ValueError, match="2x2"):
        rs.HeightMap(np.zeros((1, 1)))
    with pytest.raises(ValueError, match="2x2"):
        rs.HeightMap(np.zeros((1, 8)))
    with pytest.raises(ValueError, match="tiling"):
        rs.HeightMap(np.zeros((4, 4)), tiling=(1.0, 0.0))
    with pytest.raises(ValueError, match="not found"):
        rs.HeightMap.from_image(tmp_path / "missing.png")
    (tmp_path / "junk.png").write_bytes(b"not a png")
    with pytest.raises(ValueError, match="cannot read"):
        rs.HeightMap.from_image(tmp_path / "junk.png")
    with pytest.raises(TypeError, match="bump"):
        rs.Material(bump=np.zeros((4, 4)))


def test_bump_on_mesh_without_uvs_names_the_model():
    bare = rs.Mesh([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], name="bare_triangle")
    mat = rs.Material(bump=rs.HeightMap.wrinkles(resolution=16), name="rough")
    scene = rs.Scene([rs.Model(rs.shapes.plane(), rs.Material()), rs.Model(bare, mat)],
                     camera=rs.Camera(eye=(0, 0, 3), width=8, height=8))
    with pytest.raises(ValueError, match=r"models\[1\] \(bare_triangle\).*'rough'.*no UVs"):
        rs.render(scene)
