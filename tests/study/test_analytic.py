"""The exact renderer (raycast_shade.study.analytic) against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.analytic import Plane, Sphere, Torus, exact_for_scene, intersect, render_exact
from raycast_shade.study.twins import generate_rays_numpy


def _centre_camera(n=33, **kw):
    """Odd size, so the centre pixel's ray is exactly the view axis."""
    return rs.Camera(eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), width=n, height=n, fov=35.0, **kw)


def test_sphere_centre_pixel_head_on_directional_light():
    # Light from the camera's side: at the centre n = s = v = r = +z, so
    # I = ka Ia + Ii (kd * 1 + ks * 1^t) per channel.
    mat = rs.Material(kd=(0.6, 0.5, 0.4), ka=(0.3, 0.2, 0.1), ks=0.25, shininess=20.0)
    ambient = (0.2, 0.4, 0.5)
    ii = 1.5
    f = render_exact([(Sphere(radius=1.0), mat)], _centre_camera(), [rs.DirectionalLight((0, 0, -1), intensity=ii)],
                     ambient)
    c = 16
    expected = np.array([0.3 * 0.2, 0.2 * 0.4, 0.1 * 0.5]) + ii * (np.array([0.6, 0.5, 0.4]) + 0.25)
    np.testing.assert_allclose(f.image[c, c], expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(f.point[c, c], [0.0, 0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(f.normal[c, c], [0.0, 0.0, 1.0], atol=1e-12)
    assert f.depth[c, c] == pytest.approx(3.0, abs=1e-12)
    assert f.mask[c, c] and not f.mask[0, 0] and f.model_id[c, c] == 0 and f.model_id[0, 0] == -1
    assert np.all(f.image[~f.mask] == 0.0)


def test_sphere_centre_pixel_diffuse_only():
    # The closed form: ka Ia + kd Ii (no specular).
    mat = rs.Material(kd=0.7, ka=0.5, ks=0.0)
    f = render_exact([(Sphere(), mat)], _centre_camera(), [rs.DirectionalLight((0, 0, -1), intensity=2.0)], 0.3)
    np.testing.assert_allclose(f.image[16, 16], 0.5 * 0.3 + 0.7 * 2.0, atol=1e-12)


def test_sphere_pixels_match_hand_formula_with_point_light():
    # Independent closed form per pixel: ray-sphere roots, n = (p - c) / R,
    # inverse-square point light, Lambert + Phong specular written out here.
    centre = np.array([0.2, -0.1, 0.3])
    radius = 0.9
    cam = rs.Camera(eye=(0.5, 0.8, 4.0), target=(0.1, 0.0, 0.0), width=40, height=30, fov=40.0)
    light_pos = np.array([2.0, 3.0, 4.0])
    kd, ka, ks, t, ia, ii = 0.65, 0.4, 0.35, 12.0, 0.15, 9.0
    mat = rs.Material(kd=kd, ka=ka, ks=ks, shininess=t)
    f = render_exact([(Sphere(centre, radius), mat)], cam,
                     [rs.PointLight(light_pos, intensity=ii, attenuation="inverse_square")], ia)
    o, d = generate_rays_numpy(cam)
    q = o - centre
    b = np.einsum("ij,ij->i", q, d)
    c = np.einsum("ij,ij->i", q, q) - radius**2
    disc = b * b - c
    hit = disc >= 0
    assert np.array_equal(hit.reshape(30, 40), f.mask)
    tt = -b[hit] - np.sqrt(disc[hit])
    p = o[hit] + tt[:, None] * d[hit]
    n = (p - centre) / radius
    v = -d[hit]
    s = light_pos - p
    dist = np.linalg.norm(s, axis=1)
    s /= dist[:, None]
    ns = np.einsum("ij,ij->i", n, s)
    r = 2 * ns[:, None] * n - s
    rv = np.clip(np.einsum("ij,ij->i", r, v), 0, 1)
    lit = ns > 0
    expected = ka * ia + np.where(lit, ii / dist**2 * (kd * np.clip(ns, 0, 1) + ks * rv**t), 0.0)
    np.testing.assert_allclose(f.image[f.mask][:, 0], expected, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(f.point[f.mask], p, atol=1e-12)
    assert lit.any() and (~lit).any()  # both sides of the terminator are covered


def test_blinn_centre_pixel_and_off_axis_light():
    # Blinn-Phong: with s at 60 degrees from v (= n at the centre), h bisects
    # them, so the specular cosine is cos(30 deg).
    ang = np.radians(60.0)
    s = np.array([np.sin(ang), 0.0, np.cos(ang)])
    mat = rs.Material(kd=0.5, ka=0.0, ks=0.8, shininess=10.0, specular="blinn")
    f = render_exact([(Sphere(), mat)], _centre_camera(), [rs.DirectionalLight(-s)], 0.0)
    expected = 0.5 * np.cos(ang) + 0.8 * np.cos(ang / 2) ** 10
    np.testing.assert_allclose(f.image[16, 16], expected, atol=1e-12)


def test_camera_inside_sphere_sees_the_far_wall_facing_it():
    cam = rs.Camera(eye=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), width=9, height=9, fov=60.0)
    f = render_exact([(Sphere(radius=2.0), rs.Material(kd=1.0, ka=0.0))], cam,
                     [rs.PointLight((0.0, 0.0, 0.0), intensity=1.0)], 0.0)
    assert f.mask.all()
    np.testing.assert_allclose(f.depth, 2.0, atol=1e-12)
    np.testing.assert_allclose(f.normal[4, 4], [0.0, 0.0, 1.0], atol=1e-12)  # turned to the viewer
    np.testing.assert_allclose(f.image[..., 0], 1.0, atol=1e-12)  # light at the eye: n.s = 1 everywhere


@pytest.mark.parametrize("centre", [(0.0, 0.0, 0.0), (1.5, -2.0, 0.25)])
def test_torus_hits_known_points_along_axes(centre):
    big, small = 1.0, 0.4
    tor = Torus(centre, big, small)
    c = np.asarray(centre)
    origins = c + np.array([
        [5.0, 0.0, 0.0],    # along -x onto the outer equator: x = R + r
        [0.0, 0.0, 5.0],    # along -z: z = R + r
        [big, 5.0, 0.0],    # straight down onto the top circle: y = r
        [0.0, 0.0, 0.0],    # from the centre of the hole along +x: inner equator x = R - r
        [0.0, 5.0, 0.0],    # down the axis, through the hole: a miss
        [-5.0, 0.0, 0.0],   # along +x: first the far outer side, x = -(R + r)
    ])
    dirs = np.array([[-1, 0, 0], [0, 0, -1], [0, -1, 0], [1, 0, 0], [0, -1, 0], [1, 0, 0]], float)
    t, idx = intersect([tor], origins, dirs)
    expected = [5.0 - (big + small), 5.0 - (big + small), 5.0 - small, big - small, np.inf, 5.0 - (big + small)]
    np.testing.assert_allclose(t, expected, rtol=0, atol=1e-12)
    assert idx.tolist() == [0, 0, 0, 0, -1, 0]


def test_torus_normals_and_image_at_known_points():
    # Orthographic view straight down: the pixel over (R, 0) sees the top of
    # the tube, normal +y; its shade under a light from above is ka Ia + kd Ii.
    big, small = 1.0, 0.4
    cam = rs.Camera(eye=(0.0, 5.0, 0.0), target=(0.0, 0.0, 0.0), up=(0.0, 0.0, -1.0), width=51, height=51,
                    projection="orthographic", ortho_height=3.0)
    mat = rs.Material(kd=0.6, ka=0.5, ks=0.0)
    f = render_exact([(Torus(major_radius=big, minor_radius=small), mat)], cam,
                     [rs.DirectionalLight((0, -1, 0), intensity=1.0)], 0.2)
    # Pixel centres: x = (col + 0.5) * 3/51 - 1.5 and z = (row + 0.5) * 3/51 - 1.5, so
    # (row, col) = (25, 42) looks down at (x, z) = (R, 0): the top of the tube, normal +y.
    row, col = 25, 42
    p = f.point[row, col]
    rho = np.hypot(p[0], p[2])
    assert np.hypot(rho - big, p[1]) == pytest.approx(small, abs=1e-12)
    n_exact = np.array([p[0] - big * p[0] / rho, p[1], p[2] - big * p[2] / rho]) / small
    np.testing.assert_allclose(f.normal[row, col], n_exact, atol=1e-10)
    np.testing.assert_allclose(f.normal[row, col], [0.0, 1.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(f.image[row, col, 0], 0.5 * 0.2 + 0.6 * n_exact[1], atol=1e-10)
    assert not f.mask[25, 25]  # the hole


def test_torus_agrees_with_a_quartic_solve_on_random_rays():
    rng = np.random.default_rng(7)
    big, small = 1.0, 0.35
    centre = np.array([0.3, -0.2, 0.1])
    n = 400
    o = rng.normal(size=(n, 3))
    o = 4.0 * o / np.linalg.norm(o, axis=1, keepdims=True) + centre
    d = rng.uniform(-1.4, 1.4, size=(n, 3)) + centre - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, _ = intersect([Torus(centre, big, small)], o, d)
    P = np.polynomial.polynomial
    ref = np.full(n, np.inf)
    grazing = np.zeros(n, bool)
    for i in range(n):
        q = o[i] - centre
        k = q @ q + big**2 - small**2
        lhs = P.polymul([k, 2 * (q @ d[i]), 1.0], [k, 2 * (q @ d[i]), 1.0])
        rad = P.polyadd(P.polymul([q[0], d[i, 0]], [q[0], d[i, 0]]), P.polymul([q[2], d[i, 2]], [q[2], d[i, 2]]))
        roots = np.roots(P.polysub(lhs, 4 * big**2 * rad)[::-1])
        real = roots[np.abs(roots.imag) < 1e-7].real
        real = real[real > 0]
        if real.size:
            ref[i] = real.min()
        grazing[i] = np.any((np.abs(roots.imag) > 0) & (np.abs(roots.imag) < 1e-3))  # near-tangent: ambiguous
    ok = ~grazing
    assert np.array_equal(np.isfinite(t[ok]), np.isfinite(ref[ok]))
    both = ok & np.isfinite(ref)
    assert both.sum() > 50
    np.testing.assert_allclose(t[both], ref[both], rtol=0, atol=1e-8)


def test_plane_orthographic_square_and_back_face():
    # A 2 x 2 square in z = 0 facing -z, seen from +z: two-sided lighting
    # turns the normal to the viewer; every covered pixel is ka Ia + kd cos.
    cam = rs.Camera(eye=(0.0, 0.0, 3.0), width=40, height=40, projection="orthographic", ortho_height=4.0)
    light = rs.DirectionalLight((0.0, -0.6, -0.8))
    f = render_exact([(Plane(size=2.0, normal="-z"), rs.Material(kd=0.5, ka=1.0))], cam, [light], 0.1)
    xs = (np.arange(40) + 0.5) * 0.1 - 2.0  # pixel centres in world units
    inside = np.abs(xs) <= 1.0
    assert np.array_equal(f.mask, inside[:, None] & inside[None, :])
    np.testing.assert_allclose(f.normal[f.mask], np.tile([0.0, 0.0, 1.0], (f.mask.sum(), 1)))
    np.testing.assert_allclose(f.image[f.mask], 0.1 + 0.5 * 0.8, atol=1e-12)


def test_nearest_of_several_surfaces_wins():
    cam = _centre_camera(n=21)
    front = (Sphere((0.0, 0.0, 1.0), 0.5), rs.Material(kd=1.0, ka=0.0))
    back = (Plane((0.0, 0.0, -1.0), size=10.0), rs.Material(kd=0.2, ka=0.0))
    f = render_exact([back, front], cam, [rs.DirectionalLight((0, 0, -1))], 0.0)
    assert f.model_id[10, 10] == 1 and f.depth[10, 10] == pytest.approx(2.5, abs=1e-12)
    assert f.model_id[0, 0] == 0 and f.image[0, 0, 0] == pytest.approx(0.2, abs=1e-12)


def test_tessellation_converges_to_the_exact_image():
    # The icosphere is inscribed: the exact disc covers every mesh pixel, and
    # Phong on a fine mesh is within a small error of the exact image.
    mat = rs.Material(kd=0.6, ks=0.4, shininess=16.0)
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(5), mat)], lights=[rs.PointLight((3.0, 4.0, 5.0))],
                     camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=64, height=64, fov=35.0), ambient=0.1)
    ex = exact_for_scene(scene, [Sphere()])
    fr = rs.render(scene, "phong")
    assert not np.any(fr.mask & ~ex.mask)
    both = fr.mask & ex.mask
    err = np.abs(fr.image[both] - ex.image[both])
    assert np.sqrt(np.mean(err**2)) < 1e-3
    assert ex.image[both].max() > 0.5  # a real image, not two blanks


def test_refuses_what_it_does_not_model():
    cam = _centre_camera(n=9)
    with pytest.raises(ValueError, match="shadow"):
        render_exact([Sphere()], cam, [rs.PointLight((0, 0, 5), shadows=True)])
    with pytest.raises(ValueError, match="mirror"):
        render_exact([(Sphere(), rs.Material(reflectivity=0.5))], cam, [rs.PointLight((0, 0, 5))])
    with pytest.raises(TypeError):
        render_exact(["not a surface"], cam)
    with pytest.raises(ValueError):
        Torus(major_radius=0.3, minor_radius=0.5)
    with pytest.raises(ValueError):
        Plane(normal="up")
    with pytest.raises(ValueError):
        exact_for_scene(rs.Scene([rs.shapes.icosphere(1)], camera=cam), [Sphere(), Sphere()])
