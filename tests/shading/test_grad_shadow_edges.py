"""Shadow outlines' edge term (shading/grad_shadow_edges.py): ``rs.grad(..., edges=True)`` against
central finite differences of the anti-aliased image, and its parts against closed forms.

The scene: a triangle (flat-shaded, so its vertices' gradients need no vertex normals) 0.7 to 0.9
above a Phong plane (whose shadow is per pixel), a point, spot or directional light casting
shadows, a camera looking down, 64x48. The oracle: the box-filtered image as 16x16 sub-pixel rays
(the scene rendered 16 times larger, blocks averaged), central differences with steps of 0.02,
under a smooth loss weight. The gradients: 16 edge samples per pixel of outline, interior over
the 16 anti-aliasing samples. Measured (point light): light position within 0.3% of the family's
largest component, vertices within 0.8%, camera eye 0.8%; the interior alone is 12% off for the
light and has the wrong sign for some vertices. Tolerance: 3% of the family's largest component.
"""

from __future__ import annotations

import warnings

import numba
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import raycast_shade as rs
from raycast_shade.gradients import rotate_camera
from raycast_shade.common.layout import CAM_EYE, LIGHT_SIZE, LIGHT_VEC
from raycast_shade.shading.grad_edges import edge_topology, screen_points
from raycast_shade.shading.grad_shadow_edges import light_silhouettes, plane_hit_vjp, screen_jacobians, shadow_edge_vjp
from raycast_shade.shading.inputs import prepare

W_, H_ = 64, 48
K = 16
STEP = 0.02
RTOL = 0.03
SHADING = ("phong", "flat")  # the plane, the occluder
LIGHT = (1.2, 0.9, 3.0)
TRI = np.array([[-0.6, -0.4, 0.8], [0.3, -0.5, 0.9], [-0.2, 0.45, 0.7]])


def _scene(move=None, light=LIGHT, kind="point", eye=(0.1, -0.2, 3.4), plane_z=0.0, shadows=True, camera=None):
    tri = TRI.copy()
    if move is not None:
        tri[move[0], move[1]] += move[2]
    plane = rs.Mesh(np.array([[-3.0, -3.0, plane_z], [3.0, -3.0, plane_z], [3.0, 3.0, plane_z], [-3.0, 3.0, plane_z]]),
                    [[0, 1, 2], [0, 2, 3]])
    if kind == "point":
        lamp = rs.PointLight(light, intensity=12.0, attenuation="inverse_square", shadows=shadows)
    elif kind == "spot":
        lamp = rs.SpotLight(light, direction=(-0.35, -0.25, -1.0), intensity=12.0, attenuation="inverse_square",
                            shadows=shadows)
    else:
        lamp = rs.DirectionalLight(light, shadows=shadows)
    eye = np.asarray(eye, np.float64)
    camera = camera or rs.Camera(eye=tuple(eye), target=tuple(eye - (0.1, -0.2, 3.4)), up=(0.0, 1.0, 0.0), width=W_,
                                 height=H_)
    return rs.Scene([rs.Model(plane, rs.Material(ka=0.2, kd=(0.8, 0.7, 0.6), ks=0.0)),
                     rs.Model(rs.Mesh(tri, [[0, 1, 2]]), rs.Material(ka=0.2, kd=(0.3, 0.5, 0.8), ks=0.0))],
                    camera=camera, lights=[lamp], ambient=0.2, background=(0.1, 0.1, 0.1))


def anti_aliased(scene, shading=SHADING):
    """The box-filtered image as a K x K grid of sub-pixel rays, float64."""
    cam = scene.camera
    big = scene.replace(camera=cam.replace(width=cam.width * K, height=cam.height * K))
    img = rs.render(big, shading).image.astype(np.float64)
    return img.reshape(cam.height, K, cam.width, K, 3).mean(axis=(1, 3))


@pytest.fixture(scope="module")
def weights():
    yy, xx = np.mgrid[0:H_, 0:W_] + 0.5
    return np.stack([np.cos(0.15 * xx + c) * np.sin(0.11 * yy + 1.0) + 0.5 for c in range(3)], axis=-1)


def _fd(make, weights, step=STEP):
    up = np.sum(weights * anti_aliased(make(step)))
    down = np.sum(weights * anti_aliased(make(-step)))
    return float(up - down) / (2.0 * step)


def _agree(got, want, top, what):
    assert abs(got - want) <= RTOL * top, f"{what}: edge sampling {got!r}, finite difference {want!r}"


def _grad(scene, weights, wrt, edges=True, shading=SHADING):
    return rs.grad(scene, weights, wrt, shading=shading, edges=edges, edge_density=16.0, samples=16)


def test_point_light_occluder_receiver_and_camera(weights):
    """The light's position, the occluder's vertices, the receiver's height and the camera's eye."""
    scene = _scene()
    wrt = ("vertices", "light_position", "camera_eye")
    g, interior = _grad(scene, weights, wrt), _grad(scene, weights, wrt, edges=False)
    fd_light = [_fd(lambda h: _scene(light=tuple(np.add(LIGHT, h * np.eye(3)[c]))), weights) for c in range(3)]
    top = max(abs(v) for v in fd_light)
    for c in range(3):
        _agree(g["light_position"][0, c], fd_light[c], top, f"light_position[{c}]")
    # without the outline the light's gradient is 12% (of the largest) off: the term makes it agree
    assert np.max(np.abs(interior["light_position"][0] - fd_light)) > 3 * RTOL * top
    moves = [(0, 0), (1, 1), (2, 2), (1, 0)]
    fd_tri = [_fd(lambda h: _scene(move=(i, c, h)), weights) for i, c in moves]
    top = max(abs(v) for v in fd_tri)
    for (i, c), want in zip(moves, fd_tri):
        _agree(g["vertices"][4 + i, c], want, top, f"occluder vertex {i}[{c}]")
    want = _fd(lambda h: _scene(plane_z=h), weights)
    _agree(g["vertices"][:4, 2].sum(), want, abs(want), "receiver z")
    assert abs(interior["vertices"][:4, 2].sum() - want) > 3 * RTOL * abs(want)
    want = _fd(lambda h: _scene(eye=(0.1 + h, -0.2, 3.4)), weights)
    _agree(g["camera_eye"][0], want, abs(want), "camera_eye[0]")


def test_spot_and_directional_lights(weights):
    g = _grad(_scene(kind="spot"), weights, ("vertices", "light_position"))
    fd_light = [_fd(lambda h: _scene(light=tuple(np.add(LIGHT, h * np.eye(3)[c])), kind="spot"), weights)
                for c in range(2)]
    top = max(abs(v) for v in fd_light)
    for c in range(2):
        _agree(g["light_position"][0, c], fd_light[c], top, f"spot light_position[{c}]")
    want = _fd(lambda h: _scene(move=(0, 0, h), kind="spot"), weights)
    _agree(g["vertices"][4, 0], want, abs(want), "spot: occluder vertex 0[0]")
    # a unit direction: its tangent gradient is then the derivative along a tangent step
    d = np.array([-0.4, -0.3, -1.0]) / np.linalg.norm([-0.4, -0.3, -1.0])
    tangent = np.cross(d, [0.0, 0.0, 1.0])
    tangent /= np.linalg.norm(tangent)
    g = _grad(_scene(kind="dir", light=tuple(d)), weights, ("vertices", "light_direction"))
    want = _fd(lambda h: _scene(kind="dir", light=tuple(d + h * tangent)), weights, 0.01)
    _agree(float(g["light_direction"][0] @ tangent), want, abs(want), "light_direction along a tangent")
    want = _fd(lambda h: _scene(move=(1, 1, h), kind="dir", light=tuple(d)), weights)
    _agree(g["vertices"][5, 1], want, abs(want), "directional: occluder vertex 1[1]")


def test_orthographic_camera(weights):
    """An orthographic camera: its own projection Jacobian, and the rotation about its eye."""
    cam = rs.Camera(eye=(0.1, -0.2, 3.4), target=(0.1, -0.2, 0.0), width=W_, height=H_, projection="orthographic",
                    ortho_height=2.5)
    g = _grad(_scene(camera=cam), weights, ("light_position", "camera_rotation"))
    want = _fd(lambda h: _scene(light=tuple(np.add(LIGHT, (h, 0.0, 0.0))), camera=cam), weights)
    _agree(g["light_position"][0, 0], want, abs(want), "orthographic light_position[0]")
    want = _fd(lambda h: _scene(camera=rotate_camera(cam, (0.0, 0.0, h))), weights, 3e-3)
    _agree(g["camera_rotation"][2], want, abs(want), "orthographic camera_rotation[2]")


def test_no_jump_without_a_hard_outline(weights):
    """A flat receiver is shadowed per face: no outline jumps, the term is exactly 0, as for a light
    that casts no shadows. A Gouraud receiver is shadowed per vertex: its colours are continuous,
    and the samples' two sides differ only by the colour's slope across 2e-3 pixel (1e-5 here)."""
    for shading, shadows in ((("flat", "flat"), True), (SHADING, False), (("gouraud", "flat"), True)):
        scene = _scene(shadows=shadows)
        with_edges = rs.grad(scene, weights, ("light_position",), shading=shading, edges=True)
        without = rs.grad(scene, weights, ("light_position",), shading=shading)
        if shading[0] == "gouraud":
            np.testing.assert_allclose(with_edges["light_position"], without["light_position"], rtol=1e-4)
        else:
            assert np.array_equal(with_edges["light_position"], without["light_position"]), (shading, shadows)
    with_edges = rs.grad(_scene(), weights, ("light_position",), shading=SHADING, edges=True)
    without = rs.grad(_scene(), weights, ("light_position",), shading=SHADING)
    assert not np.allclose(with_edges["light_position"], without["light_position"], rtol=0.05)


def test_light_position_alone_is_not_warned(weights):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rs.grad(_scene(), weights, ("light_position",), shading=SHADING, edges=True)
    with pytest.warns(UserWarning, match="light_position"):
        rs.grad(_scene(), weights, ("kd",), shading=SHADING, edges=True)


def test_deterministic_across_runs_and_threads(weights):
    scene = _scene()
    runs = []
    for threads in (1, 2, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        try:
            runs.append(rs.grad(scene, weights, ("vertices", "light_position", "camera_rotation"), shading=SHADING,
                                edges=True, seed=3))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for other in runs[1:]:
        for name in runs[0]:
            assert np.array_equal(runs[0][name], other[name]), name
    other_seed = rs.grad(scene, weights, ("light_position",), shading=SHADING, edges=True, seed=4)
    assert not np.array_equal(other_seed["light_position"], runs[0]["light_position"])


def test_area_lights_are_named_and_skipped():
    scene = _scene().replace(lights=[rs.AreaLight((0.5, 0.5, 3.0), u=(0.25, 0.0, 0.0), v=(0.0, 0.25, 0.0),
                                                  samples=4, shadows=True, name="panel")])
    inputs = prepare(scene, scene.camera)
    gimg = np.ones((H_, W_, 3))
    with pytest.warns(UserWarning, match="'panel'"):
        gv, gc, gl, n = shadow_edge_vjp(scene, scene.camera, inputs, gimg, SHADING)
    assert n == 0 and not np.any(gv) and not np.any(gc) and not np.any(gl)


def test_cube_outline_under_a_light_above():
    """A unit cube lit from straight above: the shadow's outline is the top face's four sides
    (the top's diagonal joins two lit faces; the sides and bottom face away)."""
    cube = rs.shapes.cube(1.0)
    verts, faces = np.asarray(cube.vertices, np.float64), np.asarray(cube.faces, np.int64)
    top = verts[:, 2].max()
    row = np.zeros(LIGHT_SIZE)  # a point light's row (kind 0)
    row[LIGHT_VEC:LIGHT_VEC + 3] = (0.0, 0.0, 10.0)
    edges = light_silhouettes(verts, faces, edge_topology(verts, faces), row)
    assert edges.shape == (4, 2)
    ends = verts[edges]
    assert np.all(ends[:, :, 2] == top)
    assert np.allclose(np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1), np.ptp(verts[:, 0]))


vec3 = st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 3).map(np.array)


@settings(max_examples=40, deadline=None)
@given(g=vec3, o=vec3, d=vec3, a=vec3, b=vec3, c=vec3)
def test_plane_hit_vjp_matches_differences(g, o, d, a, b, c):
    """``plane_hit_vjp`` against central differences of the ray-plane point, written out plainly."""
    V = [np.array([0.0, 0.0, -2.0]) + a, np.array([1.5, 0.0, -2.0]) + b, np.array([0.0, 1.5, -2.0]) + c]
    o = o + np.array([0.0, 0.0, 3.0])
    d = d + np.array([0.0, 0.0, -2.0])

    def hit(x):
        oo, dd, v0, v1, v2 = x[0:3], x[3:6], x[6:9], x[9:12], x[12:15]
        n = np.cross(v1 - v0, v2 - v0)
        return oo + ((v0 - oo) @ n) / (dd @ n) * dd

    x = np.concatenate([o, d, *V])
    n = np.cross(V[1] - V[0], V[2] - V[0])
    if abs(d @ n) < 0.2 * np.linalg.norm(d) * np.linalg.norm(n):
        return  # near-grazing: differences are ill-conditioned there
    want = np.array([(g @ hit(x + 1e-6 * e) - g @ hit(x - 1e-6 * e)) / 2e-6 for e in np.eye(15)])
    got = np.concatenate([p[0] for p in plane_hit_vjp(g[None], o[None], d[None], V[0][None], V[1][None], V[2][None])])
    assert np.allclose(got, want, rtol=1e-5, atol=1e-6 * (1.0 + np.abs(want).max()))


@pytest.mark.parametrize("ortho", [False, True])
def test_screen_jacobians_match_differences(ortho):
    cam = rs.Camera(eye=(0.3, -0.2, 4.0), target=(0.0, 0.1, 0.0), width=W_, height=H_,
                    projection="orthographic" if ortho else "perspective")
    scene = rs.Scene([rs.Model(rs.Mesh(TRI, [[0, 1, 2]]))], camera=cam, lights=[rs.PointLight(LIGHT)])
    c = prepare(scene, cam).cam
    q = np.random.default_rng(1).normal(size=(5, 3)) * 0.5 + [0.0, 0.0, -4.0]
    J = screen_jacobians(c, q)
    p = q + c[CAM_EYE:CAM_EYE + 3]
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-6
        xp, yp, _ = screen_points(c, p + e)
        xm, ym, _ = screen_points(c, p - e)
        assert np.allclose(J[:, 0, k], (xp - xm) / 2e-6, rtol=1e-5, atol=1e-6)
        assert np.allclose(J[:, 1, k], (yp - ym) / 2e-6, rtol=1e-5, atol=1e-6)
