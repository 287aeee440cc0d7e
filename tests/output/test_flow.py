"""Optical flow against closed forms and against projecting the points.

* A plane seen by two cameras (or moved by a rigid transform before one camera) maps pixels by
  the homography ``H = K_b (R_rel + t_rel n_a^T / d_a) K_a^-1``: the forward and backward flows
  are that map, and its inverse, to 1e-9 px (measured 4e-14) over every pixel that sees the plane.
* A sphere before a plane, the camera moved: every pixel's flow is where OpenCV
  (``cv2.projectPoints``) puts its point; the occlusion mask agrees with what the second view
  actually shows there (its model id and depth).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.output.flow import move_model, optical_flow, surface_points
from raycast_shade.visibility.cast import cast_camera

W, H = 64, 48
K = np.array([[60.0, 0.0, 31.2], [0.0, 62.0, 24.3], [0.0, 0.0, 1.0]])
TOL_PX = 1e-9  # measured: 4e-14 px


def _look(eye, target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)):
    """OpenCV (R, t) of a camera at ``eye`` looking at ``target``."""
    eye = np.asarray(eye, float)
    z = np.asarray(target, float) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, -np.asarray(up, float))
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    return R, -R @ eye


def _rotation(axis, degrees):
    return cv2.Rodrigues(np.asarray(axis, float) / np.linalg.norm(axis) * np.radians(degrees))[0]


@pytest.fixture(scope="module")
def plane_scene():
    return rs.Scene([rs.Model(rs.shapes.plane(size=30.0, subdivisions=3))], lights=[rs.PointLight((0, 0, 5))],
                    camera=rs.Camera(eye=(0, 0, 5), width=W, height=H))


def _homography(Ra, ta, Rb, tb, n=np.array([0.0, 0.0, 1.0]), d0=0.0):
    """Pixels of camera A to camera B for points on the plane n . X = d0 (world)."""
    n_a = Ra @ n
    d_a = d0 + n_a @ ta
    R_rel = Rb @ Ra.T
    t_rel = tb - R_rel @ ta
    return K @ (R_rel + np.outer(t_rel, n_a) / d_a) @ np.linalg.inv(K)


def _apply(Hm, pix):
    q = np.c_[pix, np.ones(len(pix))] @ Hm.T
    return q[:, :2] / q[:, 2:]


def _pixels():
    jj, ii = np.mgrid[0:H, 0:W]
    return np.stack([ii.ravel(), jj.ravel()], axis=-1).astype(float)


def _check_against_homography(out, Hm):
    m = out["mask"].ravel()
    pix = _pixels()
    expect = _apply(Hm, pix[m]) - pix[m]
    err = np.abs(out["flow"].reshape(-1, 2)[m] - expect).max()
    assert m.sum() > 0.9 * W * H and err < TOL_PX, err
    assert not out["occluded"].any()  # a plane alone hides nothing
    land = _apply(Hm, pix[m])
    outside = (land[:, 0] <= -0.5) | (land[:, 0] >= W - 0.5) | (land[:, 1] <= -0.5) | (land[:, 1] >= H - 0.5)
    assert np.array_equal(out["outside"].ravel()[m], outside)
    return err


def test_flow_between_two_cameras_is_the_planes_homography(plane_scene):
    Ra, ta = _look((0.5, -1.0, 6.0), (0.2, 0.1, 0.0))
    Rb, tb = _look((-1.5, 0.5, 5.0), (0.0, -0.3, 0.0))
    a = rs.Camera.from_opencv(K, Ra, ta, W, H)
    b = rs.Camera.from_opencv(K, Rb, tb, W, H)
    forward = optical_flow(plane_scene, a, camera_b=b)
    backward = optical_flow(plane_scene, b, camera_b=a)
    _check_against_homography(forward, _homography(Ra, ta, Rb, tb))
    _check_against_homography(backward, _homography(Rb, tb, Ra, ta))
    assert np.abs(forward["scene_flow"]).max() == 0.0  # the scene stood still
    assert forward["outside"].sum() > 20  # part of A's view leaves B's


def test_flow_of_a_moved_model_is_the_homography_of_the_moved_camera(plane_scene):
    Ra, ta = _look((0.5, -1.0, 6.0), (0.2, 0.1, 0.0))
    cam = rs.Camera.from_opencv(K, Ra, ta, W, H)
    M = np.eye(4)
    M[:3, :3] = _rotation((0.3, 1.0, 0.2), 12.0)
    M[:3, 3] = (0.4, -0.2, 0.3)
    moved = move_model(plane_scene, 0, M)
    out = optical_flow(plane_scene, cam, moved)
    # Moving the plane by M before the camera (R, t) is the camera (R M_R, R M_t + t) before the plane.
    Hm = _homography(Ra, ta, Ra @ M[:3, :3], Ra @ M[:3, 3] + ta)
    _check_against_homography(out, Hm)
    pts = rs.render(plane_scene, camera=cam, buffers=("position", "mask")).buffers
    m = out["mask"]
    moved_pts = pts["position"][m].astype(np.float64) @ M[:3, :3].T + M[:3, 3]
    assert np.allclose(out["scene_flow"][m], moved_pts - pts["position"][m], atol=2e-5)
    back = optical_flow(moved, cam, plane_scene)
    _check_against_homography(back, np.linalg.inv(Hm))


@pytest.fixture(scope="module")
def occluding_scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(3), name="ball"),
                     rs.Model(rs.shapes.plane(size=12.0, center=(0, 0, -1.5)), name="wall")],
                    lights=[rs.PointLight((2, 3, 4))], camera=rs.Camera(eye=(0, 0, 5), width=W, height=H))


def test_flow_lands_where_opencv_projects_the_point_and_occlusion_is_what_b_shows(occluding_scene):
    scene = occluding_scene
    Ra, ta = _look((0.0, 0.3, 5.0))
    Rb, tb = _look((2.2, 0.0, 4.5), (0.0, 0.2, 0.0))
    a = rs.Camera.from_opencv(K, Ra, ta, W, H)
    b = rs.Camera.from_opencv(K, Rb, tb, W, H)
    out = optical_flow(scene, a, camera_b=b)
    A = rs.render(scene, camera=a, buffers=("position", "model_id"))
    B = rs.render(scene, camera=b, buffers=("zdepth", "model_id"))
    m = out["mask"]
    pts = A.buffers["position"][m].astype(np.float64)
    uv, _ = cv2.projectPoints(pts, cv2.Rodrigues(Rb)[0], tb, K, None)
    land = _pixels()[m.ravel()] + out["flow"][m]
    # the float32 position buffer puts the points ~2e-5 px off the exact ones the flow uses...
    assert np.abs(uv.reshape(-1, 2) - land).max() < 1e-3
    # ...which OpenCV projects onto the flow's end to 1e-9 px (measured 2e-14).
    exact, _, sel = surface_points(scene, a, cast_camera(scene.geometry, a))
    uv_exact, _ = cv2.projectPoints(exact, cv2.Rodrigues(Rb)[0], tb, K, None)
    assert np.abs(uv_exact.reshape(-1, 2) - (_pixels()[sel] + out["flow"].reshape(-1, 2)[sel])).max() < TOL_PX
    seen = m & ~out["occluded"] & ~out["outside"]
    hidden = m & out["occluded"]
    assert seen.sum() > 1000 and hidden.sum() > 50
    z_point = (pts @ Rb.T + tb)[:, 2]
    px = np.rint(land).astype(int)
    inside = ~out["outside"][m]
    idx = np.flatnonzero(inside)
    zb = B.buffers["zdepth"][px[idx, 1], px[idx, 0]]
    mb = B.buffers["model_id"][px[idx, 1], px[idx, 0]]
    ma = A.buffers["model_id"][m][idx]
    occ = out["occluded"][m][idx]
    # Away from B's outlines (pixels whose 3x3 neighbourhood shows one model), where rounding a
    # landing point to its pixel centre cannot cross onto another surface:
    ids = np.pad(B.buffers["model_id"], 1, mode="edge")
    edge = np.zeros((H, W), bool)
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            edge |= ids[dy:dy + H, dx:dx + W] != B.buffers["model_id"]
    calm = ~edge[px[idx, 1], px[idx, 0]]
    # seen points: B shows the same model at about their depth (a pixel's width of slope aside);
    agree = (mb == ma) & (np.abs(zb - z_point[idx]) < 0.05 * z_point[idx])
    assert agree[~occ & calm].all() and agree[~occ].mean() > 0.98, agree[~occ].mean()
    # hidden points: B shows the ball, nearer.
    assert (occ & calm).sum() > 50
    assert (zb[occ & calm] < 0.97 * z_point[idx][occ & calm]).all() and (mb[occ & calm] == 0).all()


def test_flow_into_a_distorted_camera_follows_its_lens(occluding_scene):
    dist = [0.09, -0.02, 0.004, -0.001]
    Ra, ta = _look((0.0, 0.3, 5.0))
    Rb, tb = _look((1.0, 0.0, 4.8))
    a = rs.Camera.from_opencv(K, Ra, ta, W, H)
    b = rs.Camera.from_opencv(K, Rb, tb, W, H, dist=dist, fisheye=True)
    out = optical_flow(occluding_scene, a, camera_b=b)
    A = rs.render(occluding_scene, camera=a, buffers=("position",))
    m = out["mask"]
    uv, _ = cv2.fisheye.projectPoints(A.buffers["position"][m].astype(np.float64).reshape(-1, 1, 3),
                                      cv2.Rodrigues(Rb)[0], tb, K, np.array(dist))
    assert np.abs(uv.reshape(-1, 2) - (_pixels()[m.ravel()] + out["flow"][m])).max() < 1e-3


def test_flow_checks_its_arguments(plane_scene, occluding_scene):
    cam = plane_scene.camera
    with pytest.raises(ValueError, match="scene_b, camera_b: give B's scene"):
        optical_flow(plane_scene, cam)
    with pytest.raises(ValueError, match="scene_b: expected the same models"):
        optical_flow(plane_scene, cam, occluding_scene)
    other = plane_scene.replace(models=[rs.Model(rs.shapes.plane(size=30.0, subdivisions=2))])
    with pytest.raises(ValueError, match="scene_b.models\\[0\\]: other triangles"):
        optical_flow(plane_scene, cam, other)
    with pytest.raises(TypeError, match="camera_b: expected a Camera"):
        optical_flow(plane_scene, cam, camera_b="b")
    with pytest.raises(ValueError, match="matrix: last row"):
        move_model(plane_scene, 0, np.ones((4, 4)))
    with pytest.raises(ValueError, match="matrix: its 3x3 part is singular"):
        move_model(plane_scene, 0, np.diag([1.0, 0.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="index"):
        move_model(plane_scene, 3, np.eye(4))
