"""Exact lens distortion, checked against OpenCV itself.

* ``cv2.projectPoints`` (``cv2.fisheye.projectPoints``) with the same coefficients puts every
  visible vertex in a pixel whose hit triangle is one of the vertex's own triangles;
* each pixel's ray, projected by OpenCV, lands on that pixel's centre (to 1e-6 px), and on the
  centre moved by a sub-pixel offset for the anti-aliasing samples;
* ``cv2.undistortPoints`` (``cv2.fisheye.undistortPoints``), run to convergence, gives each
  pixel's ray back (to 1e-9 in normalised coordinates, i.e. 1e-6 px at these focal lengths);
* the buffers are those of the distorted image (position and zdepth agree, ids come from the
  distorted rays), a zero distortion is the pinhole bit for bit, and what cannot be inverted
  stays empty.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.visibility.cast import cast_camera
from raycast_shade.visibility.distortion import distort, ray_directions

W, H = 96, 72
K = np.array([[70.0, 0.0, 47.2], [0.0, 72.0, 35.9], [0.0, 0.0, 1.0]])
LENSES = {
    "barrel": ([-0.28, 0.09, 0.0012, -0.0009, -0.012], False),
    "pincushion": ([0.22, 0.05, -0.002, 0.001], False),
    "fisheye": ([0.08, -0.03, 0.006, -0.001], True),
}
CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 500, 1e-15)


def _pose(seed, distance=3.2):
    rng = np.random.default_rng(seed)
    eye = rng.normal(size=3)
    eye *= distance / np.linalg.norm(eye)
    z = -eye / np.linalg.norm(eye)
    x = np.cross(z, rng.normal(size=3))
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    return R, -R @ eye


def _project(points, R, t, dist, fisheye):
    rvec = cv2.Rodrigues(R)[0]
    if fisheye:
        uv, _ = cv2.fisheye.projectPoints(np.asarray(points, np.float64).reshape(-1, 1, 3), rvec, t, K,
                                          np.asarray(dist, np.float64))
    else:
        uv, _ = cv2.projectPoints(np.asarray(points, np.float64), rvec, t, K, np.asarray(dist, np.float64))
    return uv.reshape(-1, 2)


def _centres(w=W, h=H):
    jj, ii = np.mgrid[0:h, 0:w]
    return np.stack([ii.ravel(), jj.ravel()], axis=-1).astype(np.float64)


@pytest.fixture(scope="module")
def sphere():
    mesh = rs.shapes.icosphere(3)
    return mesh, rs.Scene([rs.Model(mesh)], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                          camera=rs.Camera(eye=(0, 0, 4), width=W, height=H))


@pytest.mark.parametrize("lens", LENSES)
@pytest.mark.parametrize("seed", [1, 2])
def test_opencv_projected_vertices_land_on_their_own_triangles(sphere, lens, seed):
    mesh, scene = sphere
    dist, fisheye = LENSES[lens]
    R, t = _pose(seed, distance=2.2)  # the sphere fills the view, out to where the lens bends most
    cam = rs.Camera.from_opencv(K, R, t, W, H, dist=dist, fisheye=fisheye)
    tri = rs.render(scene, camera=cam, buffers=("triangle_id",)).buffers["triangle_id"]
    uv = _project(mesh.vertices, R, t, dist, fisheye)
    eye = -R.T @ t
    to_eye = eye - mesh.vertices
    facing = np.einsum("ij,ij->i", mesh.vertices, to_eye) / np.linalg.norm(to_eye, axis=1) > 0.3
    px = np.rint(uv).astype(int)
    inside = (px[:, 0] >= 0) & (px[:, 0] < W) & (px[:, 1] >= 0) & (px[:, 1] < H)
    checked = np.flatnonzero(facing & inside)
    assert len(checked) > 80
    faces_of = [set(np.flatnonzero((mesh.faces == i).any(axis=1))) for i in range(len(mesh.vertices))]
    assert [i for i in checked if tri[px[i, 1], px[i, 0]] not in faces_of[i]] == []
    # Through the pinhole, many of these vertices fall in other pixels: the check sees the lens.
    pin = np.rint(_project(mesh.vertices[checked], R, t, np.zeros(4), False)).astype(int)
    assert (pin != px[checked]).any(axis=1).sum() > 10


@pytest.mark.parametrize("lens", LENSES)
@pytest.mark.parametrize("offset", [None, (0.25, -0.375)])
def test_each_ray_projects_onto_its_pixel(lens, offset):
    dist, fisheye = LENSES[lens]
    R, t = _pose(3)
    cam = rs.Camera.from_opencv(K, R, t, W, H, dist=dist, fisheye=fisheye)
    target = _centres()
    if offset is not None:
        from raycast_shade.visibility.rays import subpixel_camera

        cam = subpixel_camera(cam, *offset)
        target = target + offset
    d, ok = ray_directions(cam)
    assert ok.all()
    uv = _project(cam.eye + 2.5 * d, R, t, dist, fisheye)
    assert np.abs(uv - target).max() < 1e-6


@pytest.mark.parametrize("lens", LENSES)
def test_undistort_points_gives_our_rays_back(lens):
    dist, fisheye = LENSES[lens]
    R, t = _pose(4)
    cam = rs.Camera.from_opencv(K, R, t, W, H, dist=dist, fisheye=fisheye)
    d, ok = ray_directions(cam)
    d_cam = d @ R.T
    ours = d_cam[:, :2] / d_cam[:, 2:]
    pix = _centres().reshape(-1, 1, 2)
    if fisheye:
        theirs = cv2.fisheye.undistortPoints(pix, K, np.array(dist), criteria=CRITERIA)
    else:
        theirs = cv2.undistortPoints(pix, K, np.array(dist), criteria=CRITERIA)
    err = np.abs(theirs.reshape(-1, 2) - ours).max()
    assert ok.all() and err < 1e-9, err


def test_buffers_are_the_distorted_images(sphere):
    _, scene = sphere
    dist, _ = LENSES["barrel"]
    R, t = _pose(5)
    cam = rs.Camera.from_opencv(K, R, t, W, H, dist=dist)
    frame = rs.render(scene, camera=cam, buffers=("zdepth", "position", "mask", "depth"))
    b = frame.buffers
    m = b["mask"]
    assert m.sum() > 500
    p_cam = b["position"].astype(np.float64) @ R.T + t
    assert np.allclose(p_cam[m][:, 2], b["zdepth"][m], rtol=2e-6, atol=0)
    uv = _project(b["position"][m].astype(np.float64), R, t, dist, False)
    assert np.abs(uv - _centres()[m.ravel()]).max() < 2e-3  # float32 positions: ~1e-4 px
    pinhole = rs.render(scene, camera=rs.Camera.from_opencv(K, R, t, W, H), buffers=("mask",)).buffers["mask"]
    assert (pinhole != m).sum() > 50  # the barrel lens shows the sphere smaller


def test_zero_distortion_is_the_pinhole_bit_for_bit(sphere):
    _, scene = sphere
    R, t = _pose(6)
    pin = rs.render(scene, camera=rs.Camera.from_opencv(K, R, t, W, H), buffers=("zdepth", "id"))
    zero = rs.render(scene, camera=rs.Camera.from_opencv(K, R, t, W, H, dist=np.zeros((1, 5))), buffers=("zdepth", "id"))
    assert np.array_equal(pin.image, zero.image)
    assert all(np.array_equal(pin.buffers[k], zero.buffers[k]) for k in pin.buffers)


def test_pixels_beyond_the_fold_have_no_ray(sphere):
    """k1 = -0.6 folds the model at r = 0.745 (x_d = r (1 - 0.6 r^2) peaks at 0.4969): wider pixels
    are not the image of any direction; they stay empty, the rest still project onto their pixel."""
    _, scene = sphere
    Kw = np.array([[30.0, 0.0, 47.5], [0.0, 30.0, 35.5], [0.0, 0.0, 1.0]])
    with pytest.warns(rs.LensFoldWarning, match=r"folds at undistorted radius 0\.7454 \(distorted 0\.4969"):
        cam = rs.Camera.from_opencv(Kw, np.eye(3), [0, 0, 1.5], W, H, dist=[-0.6, 0, 0, 0])
    d, ok = ray_directions(cam)
    xd = (_centres() - [47.5, 35.5]) / 30.0
    rd = np.hypot(xd[:, 0], xd[:, 1])
    assert not ok[rd > 0.497].any() and ok[rd < 0.496].all() and (~ok).sum() > 100
    x, y = distort(cam, d[ok, 0] / d[ok, 2], d[ok, 1] / d[ok, 2])
    assert np.abs(np.stack([x, y], -1) - xd[ok]).max() < 1e-12
    hits = cast_camera(scene.geometry, cam)
    assert (hits.prim.ravel()[~ok] == -1).all() and np.isinf(hits.t.ravel()[~ok]).all()


@pytest.mark.parametrize("kwargs, error, match", [
    ({"dist": [0.1, 0.2, 0.3]}, ValueError, "the opencv model takes .* got 3 values"),
    ({"dist": [0.1] * 5, "fisheye": True}, ValueError, "the fisheye model takes \\(k1, k2, k3, k4\\), got 5"),
    ({"dist": "0.1,0.2,0,0"}, TypeError, "camera.distortion: expected coefficients"),
    ({"dist": [0.1, np.nan, 0, 0]}, ValueError, "camera.distortion: non-finite"),
    ({"dist": [True, 0, 0, 0]}, TypeError, "camera.distortion: expected numbers"),
    ({"dist": [0.1, 0, 0, 0], "fisheye": 1}, TypeError, "fisheye: expected True or False"),
    ({"dist": [0.1, 0, 0, 0], "projection": "orthographic"}, ValueError, "needs a perspective camera"),
])
def test_bad_distortion_is_named(kwargs, error, match):
    with pytest.raises(error, match=match):
        rs.Camera.from_opencv(K, np.eye(3), [0, 0, 4], W, H, **kwargs)


def test_what_cannot_be_distorted_says_so(sphere):
    _, scene = sphere
    cam = rs.Camera.from_opencv(K, np.eye(3), [0, 0, 4], W, H, dist=[0.1, 0, 0, 0])
    with pytest.raises(ValueError, match="the rasterizer draws pinhole cameras only"):
        rs.render(scene, camera=cam, backend="raster")
    with pytest.raises(ValueError, match="an OpenGL projection matrix cannot hold lens distortion"):
        cam.projection_matrix(0.1, 10.0)
