"""The reflectance equation against closed forms on a plane.

A plane ``z = 0`` with normal ``+z`` under a point light at height ``h``:
at horizontal distance ``r`` from the foot of the light, ``d = sqrt(r^2 + h^2)``
and ``cos(theta) = h / d``, so Lambert gives

* inverse square: ``I = kd Ii h / (r^2 + h^2)^(3/2)``,
* heuristic:      ``I = kd Ii (h / d) / (d + k)``,
* none:           ``I = kd Ii h / d``.

Each pixel's true hit point comes from intersecting its camera ray with the
plane in float64, so the only error left is float32 rounding (hit-buffer
barycentrics and the float32 image).
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.reference import hit_points, shade_reference

from tests.conftest import RTOL32, camera_rays, down_camera, lit_scene, plane_hits

KD = np.array([0.7, 0.5, 0.3])
COLOR = np.array([1.0, 0.8, 0.6])
II = 4.0
H = 1.5
K = 0.7
LIGHT_XY = np.array([0.3, -0.2])


def lambert(points, light, normal_sign=1.0, attenuation="inverse_square", k=K):
    """Closed-form Lambert intensity (RGB) under a point light, plane z = 0.

    points : (..., 3); returns (..., 3).
    """
    h = normal_sign * (light[2] - points[..., 2])  # height of the light on the lit side
    r2 = (points[..., 0] - light[0]) ** 2 + (points[..., 1] - light[1]) ** 2
    if attenuation == "inverse_square":
        scalar = h / (r2 + h * h) ** 1.5
    elif attenuation == "heuristic":
        d = np.sqrt(r2 + h * h)
        scalar = (h / d) / (d + k)
    else:
        scalar = h / np.sqrt(r2 + h * h)
    return np.maximum(scalar, 0.0)[..., None] * (KD * COLOR * II)


def plane_scene(camera, attenuation="inverse_square", light_z=H, ambient=0.0, ka=0.0, **material):
    light = rs.PointLight((*LIGHT_XY, light_z), intensity=II, color=COLOR, attenuation=attenuation, k=K)
    mat = rs.Material(kd=KD, ka=ka, **material)
    return lit_scene(rs.shapes.plane(size=8.0, subdivisions=3), mat, [light], camera, ambient)


def corner_points(scene, hits):
    """World positions (N, 3, 3) of the corners of the triangle each hit pixel sees, and its barycentrics (N, 3)."""
    geo = scene.geometry
    mask = hits.mask
    face = geo.face_offsets[hits.geom[mask]] + hits.prim[mask]
    corners = geo.vertices[geo.faces[face]] + geo.origin
    u = hits.u[mask].astype(np.float64)
    v = hits.v[mask].astype(np.float64)
    return corners, np.stack([1 - u - v, u, v], 1)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
@pytest.mark.parametrize("attenuation", ["inverse_square", "heuristic", "none"])
def test_lambert_point_light_phong_matches_closed_form(projection, attenuation):
    cam = down_camera(projection=projection, ortho_height=2.5)
    scene = plane_scene(cam, attenuation)
    frame = rs.render(scene, "phong")
    points, t = plane_hits(cam)
    assert frame.mask.all()
    # The hit buffer's distance is the analytic one (orthographic: from the image plane).
    np.testing.assert_allclose(frame.hits.t, t, rtol=RTOL32)
    expected = lambert(points, np.array([*LIGHT_XY, H]), attenuation=attenuation)
    assert expected.min() > 0.01  # every pixel is lit: a real comparison everywhere
    np.testing.assert_allclose(frame.image, expected, rtol=RTOL32, atol=0)


def test_lambert_reads_the_same_from_the_hit_buffer():
    """The hit points the shader uses (barycentrics) are the analytic ones."""
    cam = down_camera(eye=(0.4, -0.3, 2.5), target=(0.1, 0.0, 0.0))
    scene = plane_scene(cam)
    frame = rs.render(scene, "phong")
    exact, _ = plane_hits(cam)
    from_hits = hit_points(scene, frame.hits)
    np.testing.assert_allclose(from_hits, exact, atol=2e-6)
    np.testing.assert_allclose(frame.image, lambert(from_hits, np.array([*LIGHT_XY, H])), rtol=RTOL32)


@pytest.mark.parametrize("side", [1.0, -1.0], ids=["front", "back"])
@pytest.mark.parametrize("attenuation", ["inverse_square", "heuristic"])
def test_flat_and_gouraud_closed_form(side, attenuation):
    """Flat: the closed form at each face's centroid. Gouraud: the closed form
    at the three corners, interpolated with the barycentrics. The back side is
    lit by a light on its own side, with the negated normal."""
    cam = down_camera(eye=(0.2, 0.1, 3.0 * side), target=(0.0, 0.0, 0.0))
    scene = plane_scene(cam, attenuation, light_z=side * H)
    light = np.array([*LIGHT_XY, side * H])
    flat = rs.render(scene, "flat")
    gouraud = rs.render(scene, "gouraud")
    corners, bary = corner_points(scene, flat.hits)
    assert len(bary) == cam.width * cam.height
    centroid = corners.mean(axis=1)
    np.testing.assert_allclose(flat.image[flat.mask], lambert(centroid, light, side, attenuation), rtol=RTOL32)
    at_corners = lambert(corners, light, side, attenuation)  # (N, 3 corners, 3 channels)
    expected = np.einsum("nk,nkc->nc", bary, at_corners)
    np.testing.assert_allclose(gouraud.image[gouraud.mask], expected, rtol=RTOL32)
    # Phong on the back side too.
    phong = rs.render(scene, "phong")
    np.testing.assert_allclose(phong.image, lambert(plane_hits(cam)[0], light, side, attenuation), rtol=RTOL32)


@pytest.mark.parametrize("side", [1.0, -1.0], ids=["front", "back"])
def test_light_on_the_far_side_leaves_only_ambient(side):
    """Two-sided lighting: the side the viewer sees is lit only by lights on its side."""
    cam = down_camera(eye=(0.0, 0.0, 3.0 * side))
    scene = plane_scene(cam, light_z=-side * H, ambient=0.25, ka=(0.4, 0.6, 0.8))
    for shading in rs.SHADINGS:
        frame = rs.render(scene, shading)
        np.testing.assert_allclose(frame.image, np.broadcast_to([0.1, 0.15, 0.2], frame.image.shape), rtol=1e-6)


@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong"])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_directional_light_at_angles(shading, projection):
    """kd Ii cos(angle) + Ia ka: 0 degrees gives kd Ii, 45 gives kd Ii / sqrt 2, 90 gives ambient only."""
    cam = down_camera(projection=projection)
    ambient = 0.2
    ka = 0.5
    cases = [((0.0, 0.0, -1.0), 1.0), ((1.0, 0.0, -1.0), 1.0 / np.sqrt(2.0)),
             ((0.0, -1.0, -1.0), 1.0 / np.sqrt(2.0)), ((1.0, 0.0, 0.0), 0.0), ((0.0, 1.0, 0.0), 0.0)]
    for direction, cosine in cases:
        light = rs.DirectionalLight(direction, intensity=II, color=COLOR)
        scene = lit_scene(rs.shapes.plane(size=8.0, subdivisions=2), rs.Material(kd=KD, ka=ka), [light], cam, ambient)
        frame = rs.render(scene, shading)
        assert frame.mask.all()
        expected = ambient * ka + KD * COLOR * II * cosine
        np.testing.assert_allclose(frame.image, np.broadcast_to(expected, frame.image.shape), rtol=1e-6, atol=1e-7)


def test_ambient_and_coloured_light_per_channel():
    """Each channel is Ia ka + Ii color kd cos, independently."""
    cam = down_camera(width=9, height=7)
    light = rs.DirectionalLight((0.0, 0.0, -1.0), intensity=2.0, color=(1.0, 0.0, 0.5))
    mat = rs.Material(kd=(0.2, 0.9, 0.4), ka=(0.0, 1.0, 0.5))
    scene = lit_scene(rs.shapes.plane(size=8.0), mat, [light], cam, ambient=(0.3, 0.2, 0.1))
    frame = rs.render(scene, "phong")
    expected = np.array([0.3 * 0.0 + 2.0 * 1.0 * 0.2, 0.2 * 1.0 + 0.0, 0.1 * 0.5 + 2.0 * 0.5 * 0.4])
    np.testing.assert_allclose(frame.image, np.broadcast_to(expected, frame.image.shape), rtol=1e-6)


# -- specular -------------------------------------------------------------------------------------
def mirror_point(eye, light):
    """Where the plane z = 0 reflects ``light`` into ``eye`` (both above it)."""
    s = eye[2] / (eye[2] + light[2])
    image = np.array([light[0], light[1], -light[2]])
    return eye + s * (image - eye)


@pytest.mark.parametrize("specular", ["phong", "blinn"])
@pytest.mark.parametrize("eye, light", [((0.4, -2.0, 3.0), (-0.5, 0.7, 2.0)), ((-0.6, 0.3, 2.5), (0.8, 0.2, 4.0))])
def test_highlight_sits_at_the_mirror_point(specular, eye, light):
    eye = np.array(eye)
    light = np.array(light)
    cam = rs.Camera(eye=eye, target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov=60.0, width=121, height=101)
    mat = rs.Material(kd=0.0, ka=0.0, ks=1.0, shininess=200.0, specular=specular)
    scene = lit_scene(rs.shapes.plane(size=12.0, subdivisions=4), mat, [rs.PointLight(light, intensity=1.0)], cam)
    frame = rs.render(scene, "phong")
    img = frame.image[..., 0]
    y, x = np.unravel_index(np.argmax(img), img.shape)
    assert 0 < x < cam.width - 1 and 0 < y < cam.height - 1
    # The peak of (r.v)^t or (n.h)^t is 1, reached exactly at the mirror point (the
    # nearest pixel centre is within half a pixel of it).
    assert 0.9 < img[y, x] <= 1.0 + 1e-6
    points, _ = plane_hits(cam)
    footprint = max(np.linalg.norm(points[y, x + 1] - points[y, x - 1]), np.linalg.norm(points[y + 1, x] - points[y - 1, x])) / 2
    m = mirror_point(eye, light)
    assert np.linalg.norm(points[y, x] - m) <= footprint
    # And the image is the closed form ks (r.v)^t everywhere.
    v = eye - points
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    s = light - points
    s /= np.linalg.norm(s, axis=-1, keepdims=True)
    n = np.array([0.0, 0.0, 1.0])
    if specular == "phong":
        c = np.einsum("...i,...i->...", 2 * s[..., 2:3] * n - s, v)
    else:
        h = (s + v) / np.linalg.norm(s + v, axis=-1, keepdims=True)
        c = h[..., 2]
    np.testing.assert_allclose(img, np.clip(c, 0, 1) ** 200.0, atol=2e-5)


def test_intensity_does_not_depend_on_viewer_distance():
    """The lecture's question: moving the eye back along its view line leaves
    the intensity of the surface point it looks at unchanged (only the
    direction to the eye enters), specular term included."""
    mat = rs.Material(kd=0.6, ka=0.3, ks=0.8, shininess=12.0)
    lights = [rs.PointLight((0.5, 0.5, 1.2), intensity=2.0, attenuation="inverse_square"),
              rs.PointLight((-1.0, 0.2, 0.7), intensity=1.0, attenuation="heuristic", k=0.3)]
    mesh = rs.shapes.plane(size=6.0, subdivisions=3)
    direction = np.array([0.3, -0.5, 1.0]) / np.linalg.norm([0.3, -0.5, 1.0])
    for target in [(0.0, 0.0, 0.0), (0.37, -0.21, 0.0), (-0.8, 0.55, 0.0)]:
        target = np.array(target)
        values = []
        for distance in (1.5, 4.0, 12.0, 40.0):
            cam = rs.Camera(eye=target + distance * direction, target=target, width=21, height=21, fov=20.0)
            frame = rs.render(lit_scene(mesh, mat, lights, cam, ambient=0.1), "phong")
            hit = hit_points(frame.scene, frame.hits)[10, 10]
            np.testing.assert_allclose(hit, target, atol=2e-6 * distance)
            values.append(frame.image[10, 10])
        values = np.array(values)
        assert values[0, 0] > 0.1
        np.testing.assert_allclose(values, np.broadcast_to(values[0], values.shape), rtol=1e-5)


def test_orthographic_image_does_not_depend_on_viewer_distance():
    """Orthographic: the whole image is unchanged when the eye moves back."""
    mat = rs.Material(kd=0.6, ka=0.3, ks=0.8, shininess=12.0)
    light = rs.PointLight((0.5, 0.5, 1.2), intensity=2.0, attenuation="inverse_square")
    mesh = rs.shapes.icosphere(2)
    images = []
    for distance in (3.0, 30.0):
        cam = rs.Camera(eye=(0.0, 0.0, distance), width=48, height=40, projection="orthographic", ortho_height=2.4)
        frame = rs.render(lit_scene(mesh, mat, [light], cam), "phong")
        images.append(frame.image)
    assert images[0].max() > 0.5
    np.testing.assert_allclose(images[1], images[0], atol=1e-5)


# -- singular lights --------------------------------------------------------------------------------
@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong"])
def test_light_exactly_on_the_surface(shading):
    """A light at a vertex of the plane, and one inside a face: the light lies
    in the plane, so n.s = 0 everywhere and only ambient remains; at the vertex
    itself d = 0 and the light contributes nothing. Output finite and >= 0."""
    mesh = rs.shapes.plane(size=4.0, subdivisions=2)  # has a vertex at the origin
    cam = down_camera(width=40, height=30)
    for position in [(0.0, 0.0, 0.0), (0.25, 0.1, 0.0), (1.0, 1.0, 0.0)]:
        light = rs.PointLight(position, intensity=5.0, attenuation="inverse_square")
        scene = lit_scene(mesh, rs.Material(kd=0.8, ka=0.5, ks=0.5), [light], cam, ambient=0.2)
        frame = rs.render(scene, shading)
        assert np.isfinite(frame.image).all()
        np.testing.assert_allclose(frame.image, 0.1, rtol=1e-6)


@pytest.mark.parametrize("shading", ["flat", "gouraud", "phong"])
def test_light_just_above_a_vertex_is_clamped_and_finite(shading):
    """A hair above a vertex the inverse-square law is clamped at
    d = 1e-6 * scene size: huge but finite, and exactly what the reference computes."""
    mesh = rs.shapes.plane(size=4.0, subdivisions=2)
    cam = down_camera(width=40, height=30)
    light = rs.PointLight((0.0, 0.0, 1e-9), intensity=5.0, attenuation="inverse_square")
    scene = lit_scene(mesh, rs.Material(kd=0.8, ka=0.5, ks=0.5), [light], cam, ambient=0.2)
    frame = rs.render(scene, shading)
    assert np.isfinite(frame.image).all() and frame.image.min() >= 0.0
    ref = shade_reference(scene, cam, frame.hits, shading)
    np.testing.assert_allclose(frame.image, ref, rtol=1e-5)
    if shading == "gouraud":
        dmin = 1e-6 * scene.geometry.scale
        # The vertex under the light really gets the clamped term kd Ii / dmin^2 (not zero, not inf).
        assert frame.image.max() > 0.25 * 5.0 * 0.8 / dmin**2


def test_pixel_rays_are_unit_and_through_pixel_centres():
    """Sanity of the helper used above: the centre ray of an odd image is the view axis."""
    cam = rs.Camera(eye=(1.0, 2.0, 3.0), target=(0.5, 0.0, 0.0), width=11, height=9)
    o, d = camera_rays(cam)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, rtol=1e-12)
    axis = (cam.target - cam.eye) / np.linalg.norm(cam.target - cam.eye)
    np.testing.assert_allclose(d[4, 5], axis, atol=1e-12)


@pytest.mark.parametrize("t", [1.0, 2.0, 5.0, 40.0, 200.0, 4096.0, 7.5, 0.3, 5000.0])
def test_specular_power_matches_pow(t):
    """Whole shininess values are raised by repeated squaring: within a few
    ulps per squaring of ``c ** t`` (the error of ``pow`` of a rounded cosine
    is of the same order); other values go to ``pow`` itself."""
    from raycast_shade.shading.illumination import _power

    c = np.linspace(0.0, 1.0, 1001)
    got = np.array([_power(x, t) for x in c])
    np.testing.assert_allclose(got, c**t, rtol=t * 4.5e-16 + 1e-15, atol=1e-300)
    assert _power(0.5, 40.0) == 2.0**-40  # squaring a power of two is exact
    assert _power(1.0, t) == 1.0 and _power(0.0, t) == 0.0
