"""Vision conventions: cameras as OpenCV / OpenGL matrices, named buffers, buffer files.

The projections are checked against OpenCV itself (cv2.projectPoints), the
z-depth against closed forms, the matrices by round trips.
"""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.output.bufferfile import load_npz, read_depth_png, read_exr, save_npz, write_depth_png, write_exr
from raycast_shade.output.buffers import BUFFER_NAMES, check_buffers
from raycast_shade.shading.normals import shading_normals

W, H = 96, 72
BACKENDS = ("raycast", "raster")


def _rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    R, _ = cv2.Rodrigues(q[1:] * 2.0 * np.arccos(np.clip(q[0], -1, 1)) / max(np.linalg.norm(q[1:]), 1e-12))
    return R


def _looking_at_origin(rng, distance=4.0):
    """(R, t) of a camera at ``distance`` from the origin, looking at it, rolled at random."""
    eye = rng.normal(size=3)
    eye *= distance / np.linalg.norm(eye)
    z = -eye / np.linalg.norm(eye)
    x = np.cross(z, rng.normal(size=3))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye


# Cameras with fx != fy and principal points off the centre (OpenCV pixels).
INTRINSICS = [
    np.array([[110.0, 0.0, 40.3], [0.0, 80.0, 41.7], [0.0, 0.0, 1.0]]),
    np.array([[70.0, 0.0, 60.0], [0.0, 95.5, 28.25], [0.0, 0.0, 1.0]]),
    np.array([[90.0, 0.0, 47.5], [0.0, 90.0, 35.5], [0.0, 0.0, 1.0]]),  # square pixels, centred
]


@pytest.fixture(scope="module")
def sphere():
    mesh = rs.shapes.icosphere(2)
    scene = rs.Scene([rs.Model(mesh)], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                     camera=rs.Camera(eye=(0, 0, 4), width=W, height=H))
    return mesh, scene


def test_k_round_trips_exactly():
    rng = np.random.default_rng(1)
    for K in INTRINSICS:
        R, t = _looking_at_origin(rng)
        cam = rs.Camera.from_opencv(K, R, t, W, H)
        assert np.array_equal(cam.K, K)
        assert np.array_equal(cam.to_opencv()[0], K)


def test_rt_round_trip():
    rng = np.random.default_rng(2)
    for _ in range(50):
        R, t = _rotation(rng), rng.normal(size=3) * 5
        K2, R2, t2 = rs.Camera.from_opencv(INTRINSICS[0], R, t, W, H).to_opencv()
        assert np.abs(R2 - R).max() < 1e-14
        assert np.abs(t2 - t).max() < 1e-13 * max(1.0, np.abs(t).max())


def test_camera_without_intrinsics_has_centred_k():
    cam = rs.Camera(eye=(0, 0, 4), fov=50.0, width=W, height=H)
    f = 0.5 * H / np.tan(np.radians(25.0))
    np.testing.assert_allclose(cam.K, [[f, 0, W / 2 - 0.5], [0, f, H / 2 - 0.5], [0, 0, 1]], rtol=1e-14)
    # and that K, with the camera's own R, t, makes an equivalent camera
    same = rs.Camera.from_opencv(*cam.to_opencv(), W, H)
    assert same.fov == pytest.approx(50.0, rel=1e-13)
    assert same.principal_offset() == pytest.approx((0.0, 0.0), abs=1e-15)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("k", range(len(INTRINSICS)))
def test_opencv_projected_vertices_land_on_their_faces(sphere, backend, k):
    mesh, scene = sphere
    rng = np.random.default_rng(10 + k)
    R, t = _looking_at_origin(rng)
    K = INTRINSICS[k]
    cam = rs.Camera.from_opencv(K, R, t, W, H)
    frame = rs.render(scene, camera=cam, backend=backend, buffers=("triangle_id",))
    tri = frame.buffers["triangle_id"]
    uv, _ = cv2.projectPoints(mesh.vertices, cv2.Rodrigues(R)[0], t, K, None)
    uv = uv.reshape(-1, 2)
    eye = -R.T @ t
    to_eye = eye - mesh.vertices
    facing = np.einsum("ij,ij->i", mesh.vertices, to_eye) / np.linalg.norm(to_eye, axis=1) > 0.3  # unit sphere
    px = np.rint(uv).astype(int)
    inside = (px[:, 0] >= 0) & (px[:, 0] < W) & (px[:, 1] >= 0) & (px[:, 1] < H)
    checked = np.flatnonzero(facing & inside)
    assert len(checked) > 20
    faces_of = [set(np.flatnonzero((mesh.faces == i).any(axis=1))) for i in range(len(mesh.vertices))]
    wrong = [i for i in checked if tri[px[i, 1], px[i, 0]] not in faces_of[i]]
    assert wrong == []


@pytest.mark.parametrize("k", range(len(INTRINSICS)))
def test_opengl_projection_reproduces_opencv_pixels(sphere, k):
    mesh, _ = sphere
    R, t = _looking_at_origin(np.random.default_rng(20 + k))
    K = INTRINSICS[k]
    cam = rs.Camera.from_opencv(K, R, t, W, H)
    V, P = cam.view_matrix(), cam.projection_matrix(0.1, 100.0)
    clip = (P @ V @ np.c_[mesh.vertices, np.ones(len(mesh.vertices))].T).T
    ndc = clip[:, :3] / clip[:, 3:]
    u = (ndc[:, 0] + 1.0) * W / 2.0 - 0.5  # OpenGL's pixel centres at +0.5, OpenCV's at integers
    v = (1.0 - ndc[:, 1]) * H / 2.0 - 0.5
    uv, _ = cv2.projectPoints(mesh.vertices, cv2.Rodrigues(R)[0], t, K, None)
    np.testing.assert_allclose(np.c_[u, v], uv.reshape(-1, 2), atol=1e-9)
    z = (R @ mesh.vertices.T).T[:, 2] + t[2]
    n, f = 0.1, 100.0
    np.testing.assert_allclose(ndc[:, 2], (f + n) / (f - n) - 2 * f * n / ((f - n) * z), atol=1e-12)
    back = rs.Camera.from_opengl(V, P, W, H)
    K2, R2, t2 = back.to_opencv()
    np.testing.assert_allclose(K2, K, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(R2, R, atol=1e-14)
    np.testing.assert_allclose(t2, t, atol=1e-13)


def test_orthographic_projection_matrix_round_trip():
    R, t = _looking_at_origin(np.random.default_rng(3))
    K = np.array([[20.0, 0.0, 50.2], [0.0, 30.0, 30.1], [0.0, 0.0, 1.0]])
    cam = rs.Camera.from_opencv(K, R, t, W, H, projection="orthographic")
    assert cam.ortho_height == pytest.approx(H / 30.0)
    P = cam.projection_matrix(0.0, 10.0)
    p = np.array([0.3, -0.2, 0.1])
    clip = P @ cam.view_matrix() @ np.r_[p, 1.0]
    xc = R @ p + t
    assert (clip[0] + 1) * W / 2 - 0.5 == pytest.approx(K[0, 0] * xc[0] + K[0, 2], abs=1e-10)
    assert (1 - clip[1]) * H / 2 - 0.5 == pytest.approx(K[1, 1] * xc[1] + K[1, 2], abs=1e-10)
    back = rs.Camera.from_opengl(cam.view_matrix(), P, W, H)
    assert back.orthographic
    np.testing.assert_allclose(back.K, K, atol=1e-12)


def _tilted_plane_scene():
    # The plane z = 0.3 x + 0.2 y (normal (-0.3, -0.2, 1)), 6 units across.
    mesh = rs.shapes.plane(size=6.0, subdivisions=3)
    v = mesh.vertices.copy()
    v[:, 2] = 0.3 * v[:, 0] + 0.2 * v[:, 1]
    mesh = rs.Mesh(v, mesh.faces)
    return rs.Scene([rs.Model(mesh)], lights=[rs.PointLight((0, 0, 5), intensity=20)],
                    camera=rs.Camera(eye=(0, 0, 4), width=W, height=H))


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("projection", ("perspective", "orthographic"))
def test_zdepth_of_a_tilted_plane_is_its_closed_form(backend, projection):
    scene = _tilted_plane_scene()
    R, t = _looking_at_origin(np.random.default_rng(4), distance=5.0)
    R, t = R, t
    K = INTRINSICS[0] if projection == "perspective" else np.array([[25.0, 0, 40.0], [0, 20.0, 30.0], [0, 0, 1]])
    cam = rs.Camera.from_opencv(K, R, t, W, H, projection=projection)
    frame = rs.render(scene, camera=cam, backend=backend, buffers=("zdepth", "position", "mask"))
    z, mask = frame.buffers["zdepth"], frame.buffers["mask"]
    assert mask.mean() > 0.5
    # A pixel (i, j) sees camera-space points c + s a with a = ((i - cx)/fx, (j - cy)/fy, 1), c = 0
    # (perspective: z = s) or a = (0, 0, 1), c = ((i - cx)/fx, (j - cy)/fy, 0) (orthographic).
    j, i = np.mgrid[0:H, 0:W]
    xn, yn = (i - K[0, 2]) / K[0, 0], (j - K[1, 2]) / K[1, 1]
    n_world, d_world = np.array([-0.3, -0.2, 1.0]), 0.0  # plane n . x = d
    n_cam = R @ n_world  # n . x_world = n_cam . (x_cam - t)
    d_cam = d_world + n_cam @ t
    if projection == "perspective":
        expect = d_cam / (n_cam[0] * xn + n_cam[1] * yn + n_cam[2])
    else:
        expect = (d_cam - n_cam[0] * xn - n_cam[1] * yn) / n_cam[2]
    np.testing.assert_allclose(z[mask], expect[mask], rtol=3e-6, atol=3e-6)
    p = frame.buffers["position"][mask]
    np.testing.assert_allclose(p[:, 2], 0.3 * p[:, 0] + 0.2 * p[:, 1], atol=2e-6)


def test_backends_agree_with_intrinsics(sphere):
    _, scene = sphere
    R, t = _looking_at_origin(np.random.default_rng(5))
    cam = rs.Camera.from_opencv(INTRINSICS[1], R, t, W, H)
    a = rs.render(scene, camera=cam, buffers=("zdepth", "triangle_id"))
    b = rs.render(scene, camera=cam, backend="raster", buffers=("zdepth", "triangle_id"))
    same = a.buffers["triangle_id"] == b.buffers["triangle_id"]
    assert same.mean() > 0.995
    both = same & a.mask
    np.testing.assert_allclose(a.buffers["zdepth"][both], b.buffers["zdepth"][both], rtol=1e-5)
    np.testing.assert_allclose(a.depth[both], b.depth[both], rtol=1e-5)


def test_buffers_are_consistent(sphere):
    _, scene = sphere
    R, t = _looking_at_origin(np.random.default_rng(6))
    K = INTRINSICS[0]
    cam = rs.Camera.from_opencv(K, R, t, W, H)
    frame = rs.render(scene, camera=cam, buffers=BUFFER_NAMES)
    b = frame.buffers
    assert tuple(b) == BUFFER_NAMES
    for name, buf in b.items():
        assert buf.shape[:2] == (H, W), name
        assert buf.dtype == {"model_id": np.int32, "triangle_id": np.int32, "semantic_id": np.int32,
                             "mask": np.bool_}.get(name, np.float32)
    m = b["mask"]
    assert np.array_equal(m, frame.mask) and np.array_equal(b["depth"], frame.depth)
    # The buffer is the shading normals computed apart from the shading, and frame.normal is it.
    np.testing.assert_array_equal(b["normal"], shading_normals(scene, cam, frame.hits, frame.shading))
    assert frame.normal is b["normal"]
    np.testing.assert_allclose(b["normal_camera"][m], b["normal"][m] @ R.T, atol=1e-6)
    np.testing.assert_allclose(b["face_normal_camera"][m], b["face_normal"][m] @ R.T, atol=1e-6)
    assert np.all(b["barycentric"][m] >= 0) and np.allclose(b["barycentric"][m].sum(axis=1), 1.0, atol=1e-6)
    # Unproject z-depth through K: the world point, on the unit sphere, where the position buffer is.
    j, i = np.mgrid[0:H, 0:W]
    rays = np.stack([(i - K[0, 2]) / K[0, 0], (j - K[1, 2]) / K[1, 1], np.ones((H, W))], axis=-1)
    pts = ((rays * b["zdepth"][..., None])[m] - t) @ R
    np.testing.assert_allclose(pts, b["position"][m], atol=2e-5)
    r = np.linalg.norm(b["position"][m], axis=1)
    assert np.all(r < 1.0 + 1e-5) and np.all(r > 0.98)  # the inscribed icosphere
    # camera-space normals face the camera: n . (point - eye) < 0, i.e. the camera z of n is mostly < 0
    assert np.mean(b["normal_camera"][m][:, 2] < 0) > 0.99
    assert np.all(b["model_id"][m] == 0) and np.all(b["model_id"][~m] == -1)


def test_frame_carries_only_what_is_asked(sphere):
    _, scene = sphere
    assert rs.render(scene).buffers == {}
    frame = rs.render(scene, buffers=["zdepth", "id"])
    assert list(frame.buffers) == ["zdepth", "model_id", "triangle_id"]


def test_unknown_buffer_names_list_the_valid_ones(sphere):
    _, scene = sphere
    with pytest.raises(ValueError, match="buffers: unknown buffer 'opacity'.*zdepth.*position"):
        rs.render(scene, buffers=("zdepth", "opacity"))
    with pytest.raises(TypeError, match="buffers"):
        check_buffers([1])
    assert check_buffers("ZDepth, id,zdepth") == ("zdepth", "model_id", "triangle_id")


@pytest.mark.parametrize("kwargs, match", [
    (dict(fx=100.0), "camera.fy: intrinsics need all"),
    (dict(fx=-1.0, fy=1.0, cx=0.0, cy=0.0), "camera.fx: must be > 0"),
    (dict(fx=1.0, fy=1.0, cx=float("nan"), cy=0.0), "camera.cx: must be finite"),
])
def test_bad_intrinsics_are_named(kwargs, match):
    with pytest.raises(ValueError, match=match):
        rs.Camera(eye=(0, 0, 4), **kwargs)


def test_bad_matrices_are_named():
    R, t = np.eye(3), np.array([0.0, 0.0, 4.0])
    K = INTRINSICS[0].copy()
    K[0, 1] = 0.5
    with pytest.raises(ValueError, match="K: skew"):
        rs.Camera.from_opencv(K, R, t, W, H)
    with pytest.raises(ValueError, match="R: a reflection"):
        rs.Camera.from_opencv(INTRINSICS[0], np.diag([1.0, 1.0, -1.0]), t, W, H)
    with pytest.raises(ValueError, match="R: not orthonormal"):
        rs.Camera.from_opencv(INTRINSICS[0], 2 * R, t, W, H)
    with pytest.raises(ValueError, match="t: expected shape"):
        rs.Camera.from_opencv(INTRINSICS[0], R, [0, 0], W, H)
    cam = rs.Camera.from_opencv(INTRINSICS[0], R, t, W, H)
    with pytest.raises(ValueError, match="near, far"):
        cam.projection_matrix(0.0, 10.0)
    with pytest.raises(ValueError, match="projection: last row"):
        rs.Camera.from_opengl(cam.view_matrix(), np.eye(4) * 2, W, H)


def _edited(matrix, **cells):
    out = matrix.copy()
    for key, value in cells.items():
        out[int(key[1]), int(key[2])] = value
    return out


@pytest.mark.parametrize("edit, match", [
    (lambda V, P: (V * np.array([[2.0], [2.0], [2.0], [1.0]]), P), "view: the rotation view\\[:3, :3\\] is not orthonormal"),
    (lambda V, P: (np.diag([1.0, 1.0, -1.0, 1.0]) @ V, P), "view: view\\[:3, :3\\] is a reflection"),
    (lambda V, P: (V, _edited(P, m00=-P[0, 0])), "projection: P\\[0, 0\\] and P\\[1, 1\\] .* must be > 0"),
    (lambda V, P: (V, _edited(P, m11=0.0)), "projection: P\\[0, 0\\] and P\\[1, 1\\] .* must be > 0"),
    (lambda V, P: (V, _edited(P, m00=1e308)), "projection: must be finite"),  # K = P * width / 2 overflows
])
def test_from_opengl_names_view_and_projection_not_r_and_k(edit, match):
    cam = rs.Camera.from_opencv(INTRINSICS[0], np.eye(3), [0.0, 0.0, 4.0], W, H)
    view, projection = edit(cam.view_matrix(), cam.projection_matrix(0.1, 10.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning on the way
        with pytest.raises(ValueError, match=match) as info:
            rs.Camera.from_opengl(view, projection, W, H)
    assert not str(info.value).startswith(("K:", "R:", "t:"))


def test_buffer_files_round_trip(sphere, tmp_path):
    _, scene = sphere
    frame = rs.render(scene, buffers=BUFFER_NAMES)
    save_npz(tmp_path / "v.npz", frame.buffers, image=frame.image, camera=frame.camera, atomic=True)
    npz = load_npz(tmp_path / "v.npz")
    write_exr(tmp_path / "v.exr", frame.buffers, image=frame.image, atomic=True)
    exr = read_exr(tmp_path / "v.exr")
    for name, buf in frame.buffers.items():
        assert np.array_equal(npz[name], buf), name
        assert exr[name].dtype == buf.dtype and np.array_equal(exr[name], buf), name
    assert np.array_equal(exr["image"], frame.image) and np.array_equal(npz["image"], frame.image)
    assert np.array_equal(npz["K"], frame.camera.K)
    z = frame.buffers["zdepth"]
    write_depth_png(tmp_path / "d.png", z, atomic=True)
    mm = cv2.imread(str(tmp_path / "d.png"), cv2.IMREAD_UNCHANGED)
    assert mm.dtype == np.uint16 and mm.shape == (H, W)
    assert np.array_equal(mm, np.rint(z.astype(np.float64) * 1000).astype(np.uint16))
    assert np.abs(read_depth_png(tmp_path / "d.png") - z).max() <= 0.0005 + 1e-7
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.png", "v.exr", "v.npz"]  # no temporaries left


def test_depth_png_out_of_range_is_no_depth(tmp_path):
    write_depth_png(tmp_path / "d.png", np.array([[0.0, 1.0, 65.6, np.inf]]))
    assert read_depth_png(tmp_path / "d.png").tolist() == [[0.0, 1.0, 0.0, 0.0]]
