"""Mirror surfaces: the mirrored camera, depth 0, termination, blending.

A perfect mirror (reflectivity 1, no local shade) through the plane
``(x - q).m = 0`` shows the scene as a camera mirrored in that plane sees
it: eye, target and up reflected. Reflection reverses handedness, so the
mirrored camera's image is the mirror's image flipped left to right, and
pixel ``x`` of one looks along exactly the ray of pixel ``W - 1 - x`` of the
other.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.twins import generate_rays_numpy

BACKGROUND = (0.05, 0.1, 0.2)
MIRROR_N = np.array([0.2, 0.1, 1.0]) / np.linalg.norm([0.2, 0.1, 1.0])
MIRROR_Q = np.array([0.1, -0.1, 0.0])


def reflect_point(p, q=MIRROR_Q, m=MIRROR_N):
    p = np.asarray(p, float)
    return p - 2.0 * np.dot(p - q, m) * m


def reflect_dir(d, m=MIRROR_N):
    d = np.asarray(d, float)
    return d - 2.0 * np.dot(d, m) * m


def mirror_mesh(size=8.0, subdivisions=2, q=MIRROR_Q, m=MIRROR_N):
    """A square through q facing m (a plane turned from +z onto m)."""
    base = rs.shapes.plane(size=size, subdivisions=subdivisions)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, m)
    s, c = np.linalg.norm(axis), np.dot(z, m)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + k + k @ k * ((1 - c) / s**2)
    return rs.Mesh(base.vertices @ rot.T + q, base.faces, normals=np.tile(m, (len(base.vertices), 1)), uvs=base.uvs,
                   name="mirror")


LIGHTS = [rs.PointLight((2.0, 3.0, 4.0), intensity=0.8, color=(1.0, 0.9, 0.8)),
          rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.4)]
SPHERE_MAT = rs.Material(kd=(0.8, 0.4, 0.2), ks=0.6, shininess=25)
PERFECT = rs.Material(ka=0.0, kd=0.0, ks=0.0, reflectivity=1.0, name="mirror")


def test_mirror_plane_shows_the_mirrored_camera_view():
    """Lights stay where they are (the sphere is real); only the camera is mirrored."""
    sphere = rs.shapes.icosphere(3, radius=0.5, center=(0.3, 0.2, 0.9))
    lights = LIGHTS + [rs.PointLight((0.3, 1.6, 0.25), intensity=0.6, color=(0.6, 0.8, 1.0))]  # lights the back
    # From the side: seen head-on, the real sphere would hide its own reflection.
    eye, target, up = np.array([2.0, 1.0, 2.2]), np.array([0.1, 0.1, 0.3]), np.array([0.0, 1.0, 0.0])
    cam = rs.Camera(eye=eye, target=target, up=up, width=160, height=120, fov=40)
    mirrored = rs.Camera(eye=reflect_point(eye), target=reflect_point(target), up=reflect_dir(up),
                         width=160, height=120, fov=40)
    scene = rs.Scene([rs.Model(mirror_mesh(), PERFECT), rs.Model(sphere, SPHERE_MAT)], lights=lights, camera=cam,
                     ambient=0.1, background=BACKGROUND)
    alone = rs.Scene([rs.Model(sphere, SPHERE_MAT)], lights=lights, camera=mirrored, ambient=0.1, background=BACKGROUND)
    a = rs.render(scene)
    b = rs.render(alone)
    seen = b.mask[:, ::-1]
    b_img = b.image[:, ::-1]
    mirror = a.model_id == 0
    both = mirror & seen
    assert both.sum() > 1000  # the sphere's reflection is large in view (1501 pixels)
    close = np.all(np.abs(a.image - b_img) <= 1e-3 + 1e-3 * np.abs(b_img), axis=-1)
    agreement = close[both].mean()
    assert agreement >= 0.99, agreement
    # Where the mirrored camera sees nothing, the mirror shows the background.
    empty = mirror & ~seen
    assert empty.sum() > 1000
    bg = np.all(np.abs(a.image - np.float32(BACKGROUND)) <= 1e-6, axis=-1)
    assert bg[empty].mean() >= 0.99
    # It is a flip: without flipping, most of the reflection would not match.
    unflipped = mirror & b.mask
    assert np.mean(np.abs(a.image[unflipped] - b.image[unflipped]).max(-1) > 1e-2) > 0.2


def mirror_scene_at(scale):
    """Mirror and sphere, scaled by ``scale`` and moved by about ``3 scale``."""
    shift = scale * np.array([2.0, -1.0, 3.0])

    def moved(mesh):
        return rs.Mesh(scale * mesh.vertices + shift, mesh.faces, normals=mesh.normals, name=mesh.name)

    # The sphere sits off the mirror's normal and the eye along its mirrored
    # direction, so the centre ray reaches the mirror and reflects onto the sphere.
    sphere = rs.shapes.icosphere(2, radius=0.5, center=(1.2, 0.2, 1.0))
    mirror = mirror_mesh(size=4.0, q=np.zeros(3))
    # A speck hidden behind the mirror makes the bounding box symmetric about
    # the mirror's centre, so the scene is re-centred onto it.
    both = np.concatenate([sphere.vertices, mirror.vertices])
    hi, lo = both.max(0), both.min(0)
    corner = np.where(hi > -lo, -hi, -lo)
    speck = rs.Mesh(corner - 1e-3 * np.eye(3) * np.sign(corner), [[0, 1, 2]], name="speck")  # inside the box
    assert np.dot(corner, MIRROR_N) < 0  # behind the mirror: never seen, never in the way
    sphere, mirror, speck = moved(sphere), moved(mirror), moved(speck)
    cam = rs.Camera(eye=scale * np.array([-1.5, 0.1, 2.9]) + shift, target=shift, width=81, height=61, fov=40)
    lights = [rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.8)]
    return rs.Scene([rs.Model(mirror, PERFECT), rs.Model(sphere, SPHERE_MAT), speck], lights=lights, camera=cam,
                    ambient=0.1, background=BACKGROUND)


def test_mirror_at_scale():
    """The scene scaled by 1e5 (or 1e-3) and moved away: the same picture.
    The centre pixel hits the mirror's centre vertex at the re-centred origin,
    where a fixed absolute ray offset would be lost in float32."""
    ref = rs.render(mirror_scene_at(1.0))
    assert np.allclose(mirror_scene_at(1e5).geometry.origin, [2e5, -1e5, 3e5], rtol=0, atol=1e-9 * 1e5)
    assert (ref.model_id == 0).sum() > 2000
    assert not np.any(ref.model_id == 2)
    assert ref.model_id[30, 40] == 0 and np.any(ref.image[30, 40] != np.float32(BACKGROUND))
    for scale in (1e5, 1e-3):
        frame = rs.render(mirror_scene_at(scale))
        differ = np.any(np.abs(frame.image - ref.image) > 1e-3, axis=-1)
        assert differ.sum() <= 0.002 * differ.size, (scale, differ.sum())  # silhouette pixels at most
        assert not differ[30, 40], scale  # the centre pixel reflects, not shows the mirror's own (zero) shade


def test_depth_zero_equals_no_reflective_material():
    sphere = rs.shapes.icosphere(3, radius=0.5, center=(0.3, 0.2, 1.0))
    cam = rs.Camera(eye=(0.9, 1.2, 4.0), target=(0.0, 0.0, 0.4), width=96, height=72)
    shiny = rs.Material(ka=0.2, kd=(0.5, 0.6, 0.7), ks=0.3, reflectivity=0.6)
    scene = rs.Scene([rs.Model(mirror_mesh(), shiny), rs.Model(sphere, replace(SPHERE_MAT, reflectivity=0.3))],
                     lights=LIGHTS, camera=cam, ambient=0.1, background=BACKGROUND)
    plain = rs.Scene([rs.Model(mirror_mesh(), replace(shiny, reflectivity=0.0)), rs.Model(sphere, SPHERE_MAT)],
                     lights=LIGHTS, camera=cam, ambient=0.1, background=BACKGROUND)
    for shading in rs.SHADINGS:
        a = rs.render(scene, shading, max_depth=0)
        b = rs.render(plain, shading, max_depth=3)
        np.testing.assert_array_equal(a.image, b.image)
        assert "mirror" not in a.timings
    assert np.abs(rs.render(scene, max_depth=1).image - b.image).max() > 0.05  # depth 1 does reflect


def local_bound(mat, ambient, lights):
    """Largest possible local shade (n.s, r.v <= 1, no attenuation), per channel."""
    total = sum(light.radiance for light in lights)
    return mat.ka * ambient + (mat.kd + mat.ks) * total


def test_facing_mirrors_terminate_and_converge():
    """Two parallel mirrors facing each other: every depth terminates, stays
    finite, and depth k+1 differs from depth k by at most rho^(k+1) times the
    largest local shade (the tail of the blend series)."""
    rho = 0.8
    mat = rs.Material(ka=0.3, kd=(0.3, 0.2, 0.1), ks=0.2, shininess=10, reflectivity=rho)
    lower = rs.shapes.plane(size=30.0, center=(0.0, 0.0, -1.0), normal="+z")
    upper = rs.shapes.plane(size=30.0, center=(0.0, 0.0, 1.0), normal="-z")
    lights = [rs.PointLight((0.0, 0.0, 0.0), intensity=0.5), rs.DirectionalLight((0.3, 0.2, -1.0), intensity=0.2)]
    cam = rs.Camera(eye=(0.0, 0.0, 0.3), target=(2.0, 0.5, -0.6), width=64, height=48, fov=60)
    scene = rs.Scene([rs.Model(lower, mat), rs.Model(upper, mat)], lights=lights, camera=cam, ambient=0.2,
                     background=BACKGROUND)
    bound = np.maximum(local_bound(mat, 0.2, lights), BACKGROUND).max()
    depths = [0, 1, 2, 3, 5, 8, 9, 20]
    images = {k: rs.render(scene, max_depth=k).image.astype(np.float64) for k in depths}
    for k in depths:
        assert np.all(np.isfinite(images[k])) and images[k].min() >= 0
        assert images[k].max() <= bound * (1 + 1e-6)
    # Nearly every primary ray hits a mirror (rays towards the horizon escape
    # between the finite planes).
    assert rs.render(scene).mask.mean() > 0.9
    for k in (0, 1, 2, 8):
        step = np.abs(images[k + 1] - images[k]).max()
        assert step <= rho ** (k + 1) * bound * (1 + 1e-5), (k, step)
    assert np.abs(images[1] - images[0]).max() > 1e-3  # the bounces do change the image
    # Perfect mirrors with nothing to show but each other: deep recursion still ends.
    perfect = scene.replace(models=[rs.Model(lower, PERFECT), rs.Model(upper, PERFECT)])
    deep = rs.render(perfect, max_depth=50).image
    assert np.all(np.isfinite(deep))
    on_bg = np.all(deep == np.float32(BACKGROUND), axis=-1)
    on_zero = np.all(deep == 0, axis=-1)
    assert np.all(on_bg | on_zero)  # either escaped to the background or still bouncing at depth 50


def test_reflective_sphere_shows_lit_floor_brighter_than_background():
    floor = rs.shapes.plane(size=40.0, normal="+y")
    ball = rs.shapes.icosphere(4, radius=1.0, center=(0.0, 1.5, 0.0))
    bg = (0.02, 0.02, 0.05)
    scene = rs.Scene([rs.Model(floor, rs.Material(kd=0.8, ka=0.2)), rs.Model(ball, PERFECT)],
                     lights=[rs.DirectionalLight((0.2, -1.0, 0.1), intensity=1.0)],
                     camera=rs.Camera(eye=(0.0, 2.0, 5.0), target=(0.0, 1.3, 0.0), width=96, height=72, fov=40),
                     ambient=0.1, background=bg)
    frame = rs.render(scene)
    ball_px = frame.model_id == 1
    o, d = generate_rays_numpy(scene.camera)
    d = d.reshape(frame.image.shape)
    n = frame.normal.astype(np.float64)
    r = d - 2 * np.sum(d * n, -1, keepdims=True) * n
    down = ball_px & (r[..., 1] < -0.3)  # reflected rays that reach the floor
    up = ball_px & (r[..., 1] > 0.3)  # reflected rays that leave to the sky
    assert down.sum() > 300 and up.sum() > 300
    lum = frame.image.mean(-1)
    assert lum[down].mean() > 0.15 > 5 * lum[up].mean()
    np.testing.assert_allclose(frame.image[up], np.broadcast_to(np.float32(bg), frame.image[up].shape), atol=1e-7)


@pytest.mark.parametrize("shading", ["flat", "gouraud"])
def test_mirror_in_flat_and_gouraud_reflects_phong_shading(shading):
    """Reflections are Phong-shaded at the bounce whatever the primary mode:
    the reflected part of a mirror pixel is the same as in Phong mode, the
    local part is the mode's own."""
    sphere = rs.shapes.icosphere(2, radius=0.5, center=(0.3, 0.2, 1.0))
    cam = rs.Camera(eye=(0.9, 1.2, 4.0), target=(0.0, 0.0, 0.4), width=96, height=72)
    half = rs.Material(ka=0.2, kd=0.5, ks=0.0, reflectivity=0.5)

    def render(rho, mode):
        s = rs.Scene([rs.Model(mirror_mesh(subdivisions=3), replace(half, reflectivity=rho)),
                      rs.Model(sphere, SPHERE_MAT)], lights=LIGHTS, camera=cam, ambient=0.1, background=BACKGROUND)
        return rs.render(s, mode)

    mode, phong = render(0.5, shading), render(0.5, "phong")
    mode_local, phong_local = render(0.0, shading), render(0.0, "phong")
    mirror = mode.model_id == 0
    assert mirror.sum() > 2000
    reflected_mode = mode.image[mirror] - 0.5 * mode_local.image[mirror]
    reflected_phong = phong.image[mirror] - 0.5 * phong_local.image[mirror]
    np.testing.assert_allclose(reflected_mode, reflected_phong, atol=2e-6)
    assert np.abs(mode_local.image[mirror] - phong_local.image[mirror]).max() > 1e-3  # the local parts differ
    direct = mode.model_id == 1
    assert np.abs(mode.image[direct] - phong.image[direct]).max() > 1e-3  # the sphere itself is the mode's
    # A perfect mirror has no local part: identical to Phong mode.
    perfect = rs.Scene([rs.Model(mirror_mesh(subdivisions=3), PERFECT), rs.Model(sphere, SPHERE_MAT)],
                       lights=LIGHTS, camera=cam, ambient=0.1, background=BACKGROUND)
    a, b = rs.render(perfect, shading), rs.render(perfect, "phong")
    np.testing.assert_array_equal(a.image[a.model_id == 0], b.image[b.model_id == 0])


def test_bumped_mirror_distorts_reflections_in_every_mode():
    """Mirror rays leave along the bumped normal: documented as the one place
    where a bump map acts outside Phong mode."""
    sphere = rs.shapes.icosphere(2, radius=0.5, center=(0.3, 0.2, 1.0))
    cam = rs.Camera(eye=(0.9, 1.2, 4.0), target=(0.0, 0.0, 0.4), width=96, height=72)
    bumpy = replace(PERFECT, bump=rs.HeightMap.wrinkles(resolution=128, scale=0.05))
    for shading in rs.SHADINGS:
        imgs = [rs.render(rs.Scene([rs.Model(mirror_mesh(), mat), rs.Model(sphere, SPHERE_MAT)], lights=LIGHTS,
                                   camera=cam, ambient=0.1, background=BACKGROUND), shading).image
                for mat in (PERFECT, bumpy)]
        assert np.abs(imgs[0] - imgs[1]).max() > 0.05, shading


# ---------------------------------------------------------------------------------------------
# Bounded work: a camera inside a closed mirror (issue: max_depth=10**6 never returned)


def _inside_mirror(rho):
    sphere = rs.shapes.icosphere(2, radius=2.0)
    inner = rs.shapes.icosphere(1, radius=0.3, center=(0.8, 0.0, 0.0))
    return rs.Scene([rs.Model(sphere, rs.Material(kd=0.2, ks=0.3, reflectivity=rho)),
                     rs.Model(inner, rs.Material(kd=(0.9, 0.2, 0.1)))],
                    lights=[rs.PointLight((0.0, 1.0, 0.5), intensity=1.0)],
                    camera=rs.Camera(eye=(0.0, 0.0, 0.5), target=(1.0, 0.0, 0.0), width=40, height=30), ambient=0.1)


@pytest.mark.parametrize("depth", [65, 10 ** 6, np.int64(10 ** 9)])
def test_mirror_depth_beyond_the_bound_is_refused_before_rendering(depth):
    from raycast_shade.shading.mirrors import MAX_MIRROR_DEPTH

    scene = _inside_mirror(1.0)
    with pytest.raises(ValueError, match=rf"max_depth: at most {MAX_MIRROR_DEPTH} mirror bounces"):
        rs.render(scene, max_depth=depth)
    assert not scene.has_geometry


def test_a_perfect_mirror_around_the_camera_finishes_at_the_bound():
    """rho = 1: every ray bounces to the last allowed bounce, then shows its local shade."""
    from raycast_shade.shading.mirrors import MAX_MIRROR_DEPTH

    frame = rs.render(_inside_mirror(1.0), max_depth=MAX_MIRROR_DEPTH)
    assert np.isfinite(frame.image).all() and (frame.image >= 0).all()
    assert frame.mask.all()


def test_rays_stop_once_their_weight_is_below_float32_resolution():
    """rho = 1/2: a ray's weight after d bounces is 2**-d; past 24 it stops, so any bound beyond
    that gives the same image."""
    scene = _inside_mirror(0.5)
    a = rs.render(scene, max_depth=30).image
    b = rs.render(scene, max_depth=64).image
    c = rs.render(scene, max_depth=10).image
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)  # the cut is not vacuous: 10 bounces are still visible
