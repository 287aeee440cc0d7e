"""Edge sampling (shading/grad_edges.py): ``rs.grad(..., edges=True)`` against central finite
differences of the anti-aliased image.

The oracle: the box-filtered image as a 16x16 grid of sub-pixel rays (the scene rendered at 16 times
the size, each 16x16 block averaged), differenced with steps of 0.02 world units (0.3 pixel) and
3e-3 rad, under a smooth loss weight ``W`` (a random one makes the loss jump from pixel to pixel,
and its differences need steps far below a pixel). The edge samples: 16 per pixel of edge length.
Measured: the two agree within 1.7% of the family's largest component (rotation), 1% for the
rest; the finite differences themselves move by up to 2.5% between steps 0.01 and 0.03. Tolerance:
4% of the family's largest component.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.gradients import rotate_camera

W_, H_ = 64, 48
K = 16
STEP = 0.02
RTOL = 0.04
GEOM = ("vertices", "camera_eye", "camera_rotation")


def _camera():
    return rs.Camera(eye=(0.2, 0.1, 4.0), target=(0.0, 0.0, 0.0), width=W_, height=H_)


def _triangle(camera=None, shift=(0.0, 0.0, 0.0), move=None):
    v = np.array([[-1.0, -0.8, 0.0], [1.2, -0.5, 0.2], [-0.1, 1.0, -0.1]]) + np.asarray(shift)
    if move is not None:
        v[move[0], move[1]] += move[2]
    material = rs.Material(ka=0.2, kd=(0.7, 0.5, 0.3), ks=0.0)
    return rs.Scene([rs.Model(rs.Mesh(v, [[0, 1, 2]]), material)], camera=camera or _camera(), ambient=0.3,
                    lights=[rs.DirectionalLight((-0.3, -0.4, -1.0))], background=(0.1, 0.2, 0.3))


def _sphere(shift=(0.0, 0.0, 0.0)):
    material = rs.Material(ka=0.2, kd=(0.7, 0.5, 0.3), ks=0.3, shininess=10.0)
    return rs.Scene([rs.Model(rs.shapes.icosphere(3, radius=1.2, center=tuple(shift)), material)], camera=_camera(),
                    lights=[rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square")],
                    ambient=0.3, background=(0.1, 0.2, 0.3))


def anti_aliased(scene, shading):
    """The box-filtered image as a K x K grid of sub-pixel rays, float64."""
    cam = scene.camera
    big = scene.replace(camera=cam.replace(width=cam.width * K, height=cam.height * K))
    img = rs.render(big, shading).image.astype(np.float64)
    return img.reshape(cam.height, K, cam.width, K, 3).mean(axis=(1, 3))


@pytest.fixture(scope="module")
def weights():
    yy, xx = np.mgrid[0:H_, 0:W_] + 0.5
    return np.stack([np.cos(0.15 * xx + c) * np.sin(0.11 * yy + 1.0) + 0.5 for c in range(3)], axis=-1)


def _fd(make, weights, shading, step=STEP):
    up = np.sum(weights * anti_aliased(make(step), shading))
    down = np.sum(weights * anti_aliased(make(-step), shading))
    return float(up - down) / (2.0 * step)


def _agree(got, want, top, what):
    assert abs(got - want) <= RTOL * top, f"{what}: edge sampling {got!r}, finite difference {want!r}"


def test_triangle_over_background_vertices_and_camera(weights):
    """Flat, Lambert under a directional light: a translation moves only the outline (interior 0)."""
    scene = _triangle()
    g = rs.grad(scene, weights, GEOM, shading="flat", edges=True, edge_density=16.0)
    interior = rs.grad(scene, weights, GEOM, shading="flat")
    assert np.all(interior["vertices"].sum(axis=0) == pytest.approx(0.0, abs=1e-9))  # translation: no interior
    top = float(np.max(np.abs(g["vertices"].sum(axis=0))))
    for c in range(3):
        e = np.eye(3)[c]
        _agree(g["vertices"][:, c].sum(), _fd(lambda h: _triangle(shift=h * e), weights, "flat"), top, f"shift[{c}]")
    top = float(np.max(np.abs(g["vertices"])))
    for i, c in [(1, 0), (2, 1), (0, 2)]:
        _agree(g["vertices"][i, c], _fd(lambda h: _triangle(move=(i, c, h)), weights, "flat"), top, f"vertex {i}[{c}]")
    cam = scene.camera
    top_e = float(np.max(np.abs(g["camera_eye"])))
    top_r = float(np.max(np.abs(g["camera_rotation"])))
    for c in range(3):
        e = np.eye(3)[c]
        moved = lambda h: _triangle(cam.replace(eye=tuple(np.array(cam.eye) + h * e),  # noqa: E731
                                                target=tuple(np.array(cam.target) + h * e)))
        _agree(g["camera_eye"][c], _fd(moved, weights, "flat"), top_e, f"camera_eye[{c}]")
        turned = lambda h: _triangle(rotate_camera(cam, h * e))  # noqa: E731
        _agree(g["camera_rotation"][c], _fd(turned, weights, "flat", 3e-3), top_r, f"camera_rotation[{c}]")


@pytest.mark.parametrize("shading", ["phong", "flat"])
def test_sphere_silhouette_translation(shading, weights):
    """A sphere moved: its silhouette (and, flat, every face's edges) plus the interior, averaged over
    16 sub-pixel samples like the image's."""
    g = rs.grad(_sphere(), weights, ("vertices",), shading=shading, edges=True, edge_density=16.0, samples=16)
    total = g["vertices"].sum(axis=0)
    top = float(np.max(np.abs(total)))
    for c in range(3):
        e = np.eye(3)[c]
        _agree(total[c], _fd(lambda h: _sphere(h * e), weights, shading), top, f"{shading} shift[{c}]")


def test_hidden_edges_add_nothing(weights):
    """A triangle wholly behind an opaque quad: its edges are sampled, but no sample sees them."""
    tri = np.array([[-0.5, -0.4, -1.0], [0.5, -0.3, -1.0], [0.0, 0.5, -1.0]])
    wall = rs.Mesh(np.array([[-1.5, -1.5, 0.5], [1.5, -1.5, 0.5], [1.5, 1.5, 0.5], [-1.5, 1.5, 0.5]]),
                   [[0, 1, 2], [0, 2, 3]])
    material = rs.Material(ka=0.2, kd=0.6, ks=0.0)
    scene = rs.Scene([rs.Model(rs.Mesh(tri, [[0, 1, 2]]), material), rs.Model(wall, material)], camera=_camera(),
                     lights=[rs.DirectionalLight((0.0, 0.0, -1.0))], background=(0.1, 0.2, 0.3))
    frame = rs.render(scene, "flat")
    assert not np.any(frame.hits.geom == 0)  # the triangle is not seen
    g = rs.grad(scene, weights, ("vertices",), shading="flat", frame=frame, edges=True)
    assert np.all(g["vertices"][:3] == 0.0)
    assert np.any(g["vertices"][3:] != 0.0)  # the wall's own outline counts


def test_deterministic_across_runs_and_threads(weights):
    scene = _sphere()
    frame = rs.render(scene, "phong")
    runs = []
    for threads in (1, 2, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        try:
            runs.append(rs.grad(scene, weights, GEOM, frame=frame, edges=True))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for other in runs[1:]:
        for name in GEOM:
            assert np.array_equal(runs[0][name], other[name]), name


def test_bad_edge_options_are_named(weights):
    scene = _triangle()
    with pytest.raises(ValueError, match="edge_density"):
        rs.grad(scene, weights, ("vertices",), edges=True, edge_density=0.0)
    with pytest.raises(TypeError, match="edges"):
        rs.grad(scene, weights, ("vertices",), edges=1)
    frame = rs.render(scene, "phong", samples=4)
    with pytest.raises(ValueError, match="samples"):
        rs.grad(scene, weights, ("vertices",), frame=frame)


def test_samples_average_the_sub_pixel_gradients(weights):
    """``samples=4``: the gradient of the 4-ray image ``render(samples=4)`` gives; the image is linear
    in kd and ks, so central differences (step 0.05) are exact up to float32 storage."""
    scene = _sphere()
    frame = rs.render(scene, "phong", samples=4)
    g = rs.grad(scene, weights, ("kd", "ks"), frame=frame, samples=4)

    def loss(kd0):
        mat = scene.models[0].material
        kd = np.array(mat.kd, float)
        kd[0] = kd0
        moved = scene.replace(models=(rs.Model(scene.models[0].mesh, rs.Material(ka=mat.ka, kd=tuple(kd), ks=mat.ks,
                                                                               shininess=mat.shininess)),))
        return float(np.sum(weights * rs.render(moved, "phong", samples=4).image))

    fd = (loss(0.75) - loss(0.65)) / 0.1
    assert g["kd"][0, 0] == pytest.approx(fd, rel=1e-3)
    one = rs.grad(scene, weights, ("kd",))["kd"][0, 0]  # the pixel centres' differs: the samples count
    assert abs(one - fd) > 1e-3 * abs(fd)


def test_edges_without_geometry_say_they_change_nothing():
    """edges=True only moves vertices and the camera: asked with shading parameters alone, a warning
    names that, and the gradients are edges=False's."""
    scene = _sphere()
    weights = np.ones((scene.camera.height, scene.camera.width, 3))
    plain = rs.grad(scene, weights, ("kd",))
    with pytest.warns(UserWarning, match=r"edges=True: the edge term moves only the geometry"):
        with_edges = rs.grad(scene, weights, ("kd",), edges=True)
    np.testing.assert_array_equal(with_edges["kd"], plain["kd"])
