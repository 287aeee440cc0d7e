"""Colour textures: sRGB decoding, the mip pyramid, the texel under a pixel, the footprint's
mip level in closed form, no shimmer in the distance, and every shading mode against the
NumPy reference."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.scene.texture import Texture, srgb_to_linear
from raycast_shade.shading.texture import texture_levels
from raycast_shade.study.reference import footprint_reference, shade_reference


def linear_to_srgb(c):
    """The sRGB encoding (IEC 61966-2-1), the inverse of ``srgb_to_linear``."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.maximum(c, 0.0031308) ** (1 / 2.4) - 0.055)


def test_srgb_decoding_is_the_exact_eotf():
    c = np.array([0.0, 0.04045, 0.5, 1.0])
    want = [0.0, 0.04045 / 12.92, ((0.5 + 0.055) / 1.055) ** 2.4, 1.0]
    np.testing.assert_allclose(srgb_to_linear(c), want, rtol=1e-15, atol=0)
    x = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(x)), x, atol=1e-12)
    # An image's 8-bit value 188 is linear 0.5029..., not 188/255 = 0.737.
    tex = Texture.from_array(np.full((2, 2, 3), 188, np.uint8))
    np.testing.assert_allclose(tex.texels, srgb_to_linear(188 / 255), rtol=1e-6)
    assert abs(tex.texels[0, 0, 0] - 0.5029) < 1e-4
    assert Texture.from_array(np.full((2, 2, 3), 188, np.uint8), srgb=False).texels[0, 0, 0] == np.float32(188 / 255)


def test_image_rows_are_flipped_to_v_up(tmp_path):
    import imageio.v3 as iio

    img = np.zeros((2, 3, 3), np.uint8)
    img[0] = 255  # the image's top row
    iio.imwrite(tmp_path / "t.png", img)
    tex = Texture.from_image(tmp_path / "t.png")
    assert tex.shape == (2, 3)
    np.testing.assert_array_equal(tex.texels[1], 1.0)  # top row is v = 1
    np.testing.assert_array_equal(tex.texels[0], 0.0)


def test_the_pyramid_is_a_box_filter_in_linear_space():
    rng = np.random.default_rng(1)
    t = rng.random((8, 4, 3))
    tex = Texture(t)
    pyr = tex.pyramid
    assert [p.shape[:2] for p in pyr] == [(8, 4), (4, 2), (2, 1), (1, 1)]
    np.testing.assert_allclose(pyr[1], t.reshape(4, 2, 2, 2, 3).mean(axis=(1, 3)), rtol=1e-6)
    np.testing.assert_allclose(pyr[-1][0, 0], t.mean(axis=(0, 1)), rtol=1e-6)
    # An odd length folds its last texel into the last box (3 wide there).
    row = rng.random((1, 5, 3))
    lvl1 = Texture(row).pyramid[1]
    assert lvl1.shape == (1, 2, 3)
    np.testing.assert_allclose(lvl1[0], [row[0, :2].mean(axis=0), row[0, 2:].mean(axis=0)], rtol=1e-6)
    assert len(Texture(t, filter="bilinear").pyramid) == 1


def test_texture_fields_are_checked():
    with pytest.raises(ValueError, match="texture.wrap"):
        Texture(np.zeros((2, 2, 3)), wrap="mirror")
    with pytest.raises(ValueError, match="texture.filter"):
        Texture(np.zeros((2, 2, 3)), filter="nearest")
    with pytest.raises(ValueError, match="texels: must be >= 0"):
        Texture(-np.ones((2, 2, 3)))
    with pytest.raises(ValueError, match="tiling"):
        Texture(np.zeros((2, 2, 3)), tiling=(0, 1))
    with pytest.raises(TypeError, match="m.kd_map: expected a Texture"):
        rs.Material(kd_map=np.zeros((2, 2, 3)), name="m")
    with pytest.warns(rs.DroppedOnLoadWarning, match="alpha"):
        Texture.from_array(np.full((2, 2, 4), 100, np.uint8))
    # A map's coefficient defaults to 1 (the texture's own colours); without one, 0.8 and 0.
    m = rs.Material(kd_map=Texture.checker(), ks_map=Texture.checker())
    assert m.kd.tolist() == [1.0] * 3 and m.ks.tolist() == [1.0] * 3
    assert rs.Material().kd.tolist() == [0.8] * 3 and rs.Material().ks.tolist() == [0.0] * 3


def test_a_map_needs_uvs():
    mesh = rs.Mesh(rs.shapes.plane().vertices, rs.shapes.plane().faces, name="bare")
    scene = rs.Scene([rs.Model(mesh, rs.Material(kd_map=Texture.checker(), name="m"))], camera=rs.Camera(eye=(0, 0, 3)))
    with pytest.raises(ValueError, match=r"bare.*'m' has a kd_map but the mesh has no UVs"):
        scene.geometry


def _blocks(n=8, k=4, seed=0):
    """An (n k) x (n k) texture of n x n blocks of k x k equal texels, each block its own colour."""
    colours = np.random.default_rng(seed).random((n, n, 3))
    return colours, Texture(np.repeat(np.repeat(colours, k, axis=0), k, axis=1))


def _head_on(material, size=2.0, eye_z=2.0, width=256, height=256, fov=90.0, **cam):
    """The plane z = 0 (UV (x+1)/2, (y+1)/2 for size 2) seen head on, lit head on, no ambient."""
    return rs.Scene([rs.Model(rs.shapes.plane(size=size), material)],
                    lights=[rs.DirectionalLight((0, 0, -1), intensity=1.0)], ambient=0.0,
                    camera=rs.Camera(eye=(0, 0, eye_z), target=(0, 0, 0), width=width, height=height, fov=fov, **cam))


@pytest.mark.parametrize("shading", ["phong", "gouraud"])
def test_the_texel_under_a_pixel_of_a_textured_plane(shading):
    """fov 90 from z = 2 over a 2 x 2 plane: the 256 x 256 image spans x, y in [-2, 2], so pixel
    (x, y) sees u = (sx * 2 + 1) / 2 with sx = 2 (x + 1/2) / 256 - 1. The plane is lit head on
    (n.s = 1) with no ambient: each pixel is kd there, and inside a block of equal texels the
    bilinear sample is the block's colour."""
    colours, tex = _blocks()
    scene = _head_on(rs.Material(kd_map=tex))
    frame = rs.render(scene, shading=shading)
    for bi, bj in [(0, 0), (3, 5), (7, 7), (6, 1)]:
        u, v = (bj + 0.5) / 8, (bi + 0.5) / 8  # block centre
        x = ((2 * u - 1) / 2 + 1) * 128 - 0.5
        y = (1 - (2 * v - 1) / 2) * 128 - 0.5
        xi, yi = int(round(x)), int(round(y))  # the pixel whose centre is nearest
        np.testing.assert_allclose(frame.image[yi, xi], colours[bi, bj], rtol=2e-6, atol=1e-7)
    # Every pixel agrees with the NumPy twin (bilinear across block edges included).
    ref = shade_reference(scene, scene.camera, frame.hits, shading)
    np.testing.assert_allclose(frame.image, ref, atol=2e-6)


@pytest.mark.parametrize("eye_z", [1.0, 4.0, 16.0, 50.0])
@pytest.mark.parametrize("backend", ["raycast", "raster"])
def test_the_footprint_level_on_a_plane_at_a_known_distance(eye_z, backend):
    """Head on at distance d, pixel spacing is 2 d tan(fov/2) / H in world units, so with N
    texels over a plane of size S, rho = (N / S) 2 d tan(fov/2) / H and the level is log2 rho,
    at every pixel (and the same for both visibility backends)."""
    n, size, h, fov = 256, 2.0 * eye_z, 64, 60.0  # the plane grows with d: it fills the same part of the view
    scene = _head_on(rs.Material(kd_map=Texture(np.ones((n, n, 3)))), size=size, eye_z=eye_z, width=80, height=h,
                     fov=fov)
    frame = rs.render(scene, backend=backend)
    levels = texture_levels(scene, scene.camera, frame.hits)
    hit = frame.hits.prim >= 0
    want = math.log2(n / size * 2 * eye_z * math.tan(math.radians(fov / 2)) / h)
    assert hit.sum() > 100
    np.testing.assert_allclose(levels[hit], want, rtol=0, atol=1e-9)
    assert np.isnan(levels[~hit]).all()


def test_the_footprint_on_a_tilted_plane_matches_the_numpy_twin():
    """Off-axis and tilted (the plane's normal is not the view axis), both cameras."""
    for cam in (dict(projection="perspective"), dict(projection="orthographic", ortho_height=6.0)):
        scene = rs.Scene([rs.Model(rs.shapes.plane(size=4, subdivisions=3), rs.Material(kd_map=Texture.checker(16)))],
                         camera=rs.Camera(eye=(1.5, -3.0, 2.0), target=(0.3, 0.2, 0), width=48, height=40, **cam))
        frame = rs.render(scene)
        levels = texture_levels(scene, scene.camera, frame.hits)
        duv = footprint_reference(scene, scene.camera, frame.hits)
        rho = np.max(np.linalg.norm(duv * 128.0, axis=2), axis=1)  # 16 squares x 8 texels
        hit = frame.hits.prim >= 0
        np.testing.assert_allclose(levels[hit], np.log2(rho), atol=1e-9)
        if cam["projection"] == "perspective":
            assert np.ptp(levels[hit]) > 0.5  # the footprint grows with distance
        else:
            assert np.ptp(levels[hit]) < 1e-9  # affine: one footprint over the whole plane


def test_a_distant_checkerboard_does_not_shimmer():
    """A 64 x 64 one-texel checkerboard tiled 32 times so far away that a pixel covers
    rho = 2048 / 2 * 2 d tan 30 / 64 = 148 > 64 texels: the mip level is the top one, the
    1 x 1 average 1/2, at every pixel; sampled at level 0 the same pixels are a
    random-looking mix of black and white (aliasing)."""
    board = dict(squares=64, texels_per_square=1, tiling=(32, 32))
    far = dict(size=2.0, eye_z=8.0, width=64, height=64, fov=60.0)
    mip = rs.render(_head_on(rs.Material(kd_map=Texture.checker(**board)), **far))
    plain = rs.render(_head_on(rs.Material(kd_map=Texture.checker(**board, filter="bilinear")), **far))
    hit = mip.hits.prim >= 0
    assert hit.sum() >= 100
    np.testing.assert_allclose(mip.image[hit], 0.5, atol=1e-6)
    assert np.ptp(plain.image[hit][:, 0]) > 0.3


@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong"])
def test_a_textured_sphere_matches_the_reference(shading):
    """All three modes (flat: the face centre's texel from the face-sized level; Gouraud:
    modulate; Phong: per pixel), with ka, kd and ks maps, a point light and a specular term."""
    mesh = rs.shapes.uv_sphere(rings=12, segments=18)
    rng = np.random.default_rng(3)
    mat = rs.Material(kd_map=Texture(rng.random((32, 64, 3))), ks=0.4, ks_map=Texture(rng.random((8, 8, 3))),
                      ka_map=Texture(rng.random((4, 4, 3)), wrap="clamp"), shininess=20)
    scene = rs.Scene([rs.Model(mesh, mat)], lights=[rs.PointLight((2, 3, 4), intensity=30,
                                                                  attenuation="inverse_square")],
                     ambient=0.2, camera=rs.Camera(eye=(0.4, 0.6, 3.0), width=72, height=60))
    frame = rs.render(scene, shading=shading)
    ref = shade_reference(scene, scene.camera, frame.hits, shading)
    np.testing.assert_allclose(frame.image, ref, rtol=1e-5, atol=1e-6)


def test_flat_shading_gives_each_face_one_texel():
    scene = _head_on(rs.Material(kd_map=Texture.checker(8, 4)), width=64, height=64)
    frame = rs.render(scene, shading="flat")
    face = frame.hits.prim
    for f in np.unique(face[face >= 0]):
        assert np.ptp(frame.image[face == f], axis=0).max() == 0.0


def test_gouraud_modulates_the_texture_with_interpolated_light():
    """On a plane lit by a directional light the diffuse light is the same at every vertex, so
    Gouraud's modulate equals Phong's per-pixel texture exactly (a point light would not)."""
    tex = Texture.checker(8, 4)
    scene = _head_on(rs.Material(kd_map=tex), width=64, height=64)
    g = rs.render(scene, shading="gouraud").image
    p = rs.render(scene, shading="phong").image
    np.testing.assert_allclose(g, p, atol=1e-6)
    assert np.ptp(g) > 0.5  # the checkerboard shows (the texture is not averaged per vertex)


def test_textures_reach_mirror_reflections():
    """A mirror facing a textured plane shows the texture (sampled at level 0)."""
    _, tex = _blocks(4, 2)
    wall = rs.Model(rs.shapes.plane(size=2, center=(0, 0, -1)), rs.Material(kd_map=tex))
    mirror = rs.Model(rs.shapes.plane(size=6, center=(0, 0, 2), normal="-z"), rs.Material(kd=0.0, ka=0.0,
                                                                                          reflectivity=1.0))
    scene = rs.Scene([wall, mirror], lights=[rs.DirectionalLight((0, 0, -1))], ambient=0.0,
                     camera=rs.Camera(eye=(0, 0, 1.5), target=(0, 0, 3), width=32, height=32, fov=60))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.ShadingWarning)
        img = rs.render(scene, max_depth=1).image
        off = rs.render(scene, max_depth=0).image
    assert np.ptp(img[..., 0]) > 0.2 and np.ptp(off) == 0.0
