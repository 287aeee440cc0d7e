"""The buffers' one-pass kernel (raycast_shade.output.buffers): each buffer against a plain-NumPy float64
reference from the same hit buffer, and ``position`` on the pixel's own ray at any angle."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common.bufferspec import BUFFERS, KERNEL_BUFFERS, REGISTRY
from raycast_shade.output.buffers import BUFFER_BYTES, BUFFER_NAMES, buffer_bytes, compute_buffers
from tests.conftest import camera_rays

W, H = 96, 72
K = np.array([[90.0, 0.0, 47.0], [0.0, 85.0, 36.5], [0.0, 0.0, 1.0]])


def _grazing_scene(projection="perspective"):
    """A 200 x 200 floor seen from 0.05 above it, the horizon 0.1 px above a row of pixel centres:
    rays meet it up to 89.93 degrees off its normal."""
    v = np.array([[-100.0, -100.0, 0.0], [100.0, -100.0, 0.0], [100.0, 100.0, 0.0], [-100.0, 100.0, 0.0]])
    floor = rs.Mesh(v, np.array([[0, 1, 2], [0, 2, 3]]))
    R = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # looking along +y, z up
    eye = np.array([0.0, -2.0, 0.05])
    Kg = K.copy()
    Kg[1, 2] = 35.9
    if projection == "orthographic":  # pitched 0.006 down from 0.5 above the floor
        eye[2] = 0.5
        c, s = np.cos(0.006), np.sin(0.006)
        R = np.array([[1.0, 0.0, 0.0], [0.0, -s, -c], [0.0, c, -s]])
    cam = rs.Camera.from_opencv(Kg, R, -R @ eye, W, H, projection=projection)
    return rs.Scene([rs.Model(floor)], lights=[rs.PointLight((0, 0, 5), intensity=20)], camera=cam), cam


def _two_spheres():
    a = rs.shapes.icosphere(2)
    b = rs.Mesh(a.vertices * 0.5 + np.array([1.1, 0.3, 0.3]), a.faces)
    return rs.Scene([rs.Model(a, name="a"), rs.Model(b, name="b")], lights=[rs.PointLight((0, 0, 5), intensity=20)])


def _reprojection_error(camera, position, mask, dist=None):
    """Pixels between each position's OpenCV projection (orthographic: K times camera x, y) and its
    pixel centre (float64)."""
    Kc, R, t = camera.to_opencv()
    j, i = np.mgrid[0:camera.height, 0:camera.width]
    pts = position[mask].astype(np.float64)
    if camera.orthographic:
        c = pts @ R.T + t
        return np.hypot(Kc[0, 0] * c[:, 0] + Kc[0, 2] - i[mask], Kc[1, 1] * c[:, 1] + Kc[1, 2] - j[mask])
    rvec = cv2.Rodrigues(R)[0]
    proj = cv2.projectPoints(pts, rvec, t, Kc, None if dist is None else np.array(dist))[0].reshape(-1, 2)
    return np.hypot(proj[:, 0] - i[mask], proj[:, 1] - j[mask])


@pytest.mark.parametrize("backend", ("raycast", "raster"))
@pytest.mark.parametrize("projection", ("perspective", "orthographic"))
def test_position_is_the_float64_point_on_the_ray_at_grazing_angles(backend, projection):
    scene, cam = _grazing_scene(projection)
    frame = rs.render(scene, camera=cam, backend=backend, buffers=("position", "mask"))
    p, m = frame.buffers["position"], frame.buffers["mask"]
    o, d = camera_rays(cam)
    cosine = np.abs(d[..., 2])
    assert m.mean() > 0.4 and cosine[m].min() < (1.5e-3 if projection == "perspective" else 6.1e-3)  # grazing indeed
    s = -o[..., 2] / d[..., 2]  # the floor z = 0, in float64
    expect = o + s[..., None] * d
    np.testing.assert_allclose(p[m], expect[m].astype(np.float32), rtol=3e-7, atol=1e-9)
    assert np.all(p[~m] == 0.0)
    assert _reprojection_error(cam, p, m).max() < 1e-3


def test_position_of_a_distorted_camera_reprojects_through_the_lens():
    scene = _two_spheres()
    R = np.eye(3)
    dist = (0.12, -0.05, 0.001, 0.002, 0.01)
    cam = rs.Camera.from_opencv(K, R, np.array([0.0, 0.0, 3.5]), W, H, dist=dist)
    frame = rs.render(scene, camera=cam, buffers=("position", "zdepth", "mask"))
    b = frame.buffers
    m = b["mask"]
    assert m.mean() > 0.2
    assert _reprojection_error(cam, b["position"], m, dist).max() < 1e-3
    # z-depth is the camera z of the same point (to float32 rounding of t).
    z = (b["position"][m].astype(np.float64) @ R.T + np.array([0.0, 0.0, 3.5]))[:, 2]
    np.testing.assert_allclose(b["zdepth"][m], z, rtol=2e-6)


def _numpy_buffers(scene, camera, hits, shading_n):
    """The buffers by plain NumPy float64 arithmetic over whole-frame arrays (the kernel's reference)."""
    geo = scene.geometry
    mask = hits.prim >= 0
    _, d = camera_rays(camera)
    fwd = camera.basis[2]
    R = camera.to_opencv()[1]
    face = np.where(mask, geo.face_offsets[np.maximum(hits.geom, 0)] + hits.prim, 0)
    n = geo.face_normals[face]
    back = (n[..., 0] * d[..., 0] + n[..., 1] * d[..., 1] + n[..., 2] * d[..., 2]) > 0.0
    fn = np.where(mask[..., None], np.where(back[..., None], -n, n), 0.0)
    u, v = hits.u.astype(np.float64), hits.v.astype(np.float64)
    rot = lambda a: a[..., :1] * R[:, 0] + a[..., 1:2] * R[:, 1] + a[..., 2:] * R[:, 2]  # noqa: E731
    out = {"depth": np.where(mask, hits.t, 0.0),
           "zdepth": np.where(mask, hits.t.astype(np.float64) * (d[..., 0] * fwd[0] + d[..., 1] * fwd[1]
                                                                  + d[..., 2] * fwd[2]), 0.0),
           "normal": shading_n, "normal_camera": rot(shading_n.astype(np.float64)),
           "face_normal": fn, "face_normal_camera": rot(fn),
           "barycentric": np.where(mask[..., None], np.stack([1.0 - u - v, u, v], axis=-1), 0.0),
           "model_id": hits.geom, "triangle_id": hits.prim, "mask": mask,
           "semantic_id": np.where(mask, hits.geom, -1)}  # the models' names are distinct
    return {k: (a.astype(np.float32) if a.dtype.kind == "f" else a) for k, a in out.items()}


@pytest.mark.parametrize("backend", ("raycast", "raster"))
def test_every_other_buffer_is_its_numpy_reference_bit_for_bit(backend):
    scene = _two_spheres()
    R = cv2.Rodrigues(np.array([0.05, -0.05, 0.02]))[0]
    cam = rs.Camera.from_opencv(K, R, np.array([0.1, -0.2, 3.5]), W, H)
    names = [n for n in BUFFER_NAMES if n not in ("position", "coverage")]
    frame = rs.render(scene, camera=cam, backend=backend, buffers=names)
    expect = _numpy_buffers(scene, cam, frame.hits, rs.shading_normals(scene, cam, frame.hits))
    assert frame.mask.mean() > 0.2 and len(np.unique(frame.buffers["model_id"])) == 3
    for name in names:
        got = frame.buffers[name]
        assert got.dtype == expect[name].dtype and got.shape == expect[name].shape, name
        np.testing.assert_array_equal(got, expect[name], err_msg=name)


def test_only_the_asked_buffers_are_made_and_the_byte_table_matches_them():
    scene = _two_spheres()
    cam = rs.Camera(eye=(0, 0, 4), width=W, height=H)
    frame = rs.render(scene, camera=cam)
    for name in BUFFER_NAMES:
        out = compute_buffers(scene, cam, frame.hits, [name])
        assert list(out) == [name]
        assert out[name].nbytes == W * H * BUFFER_BYTES[name], name
    assert buffer_bytes("id, mask") == 9


@pytest.mark.parametrize("ahead", (False, True))
def test_a_band_of_rows_gives_the_whole_frames_rows(ahead):
    """The kernel over rows y0..y1 of the hits (as the banded path would call it) writes those rows,
    with the gathers prefetched (``ahead``, a large mesh's path) or not."""
    from raycast_shade.output import buffers as B
    from raycast_shade.scene.projection import extrinsics
    from raycast_shade.visibility.rays import camera_frame

    scene = _two_spheres()
    cam = rs.Camera.from_opencv(K, np.eye(3), np.array([0.1, -0.2, 3.5]), W, H, dist=(0.05, -0.01, 0.0, 0.0, 0.0))
    frame = rs.render(scene, camera=cam)
    names = ("zdepth", "position", "face_normal_camera", "mask")
    geo, (y0, y1) = scene.geometry, (20, 47)
    from raycast_shade.visibility.distortion import ray_directions

    names += ("face_normal",) if ahead else ()
    whole = compute_buffers(scene, cam, frame.hits, names)
    out = {name: np.empty(BUFFERS[name].shape(y1 - y0, W), BUFFERS[name].dtype) for name in names}
    h = frame.hits
    B._buffers_kernel((camera_frame(cam, geo.origin), cam.basis[2].copy(), extrinsics(cam)[0],
                       ray_directions(cam)[0], y0),
                      tuple(np.ascontiguousarray(a[y0:y1]) for a in (h.prim, h.geom, h.u, h.v, h.t)),
                      (geo.vertices, geo.faces, geo.face_normals, geo.face_offsets, geo.origin, ahead),
                      (np.empty((0, 0, 3), np.float32), np.zeros(2, np.int32)),
                      tuple(out.get(b.name, np.empty(b.shape(0, 0), b.dtype)) for b in KERNEL_BUFFERS))
    for name in names:
        np.testing.assert_array_equal(out[name], whole[name][y0:y1], err_msg=name)


def test_every_buffer_is_defined_once_in_the_registry():
    """The names, the byte table, the kernel's outputs and the module table all come from REGISTRY."""
    from raycast_shade.output import buffers as B

    assert BUFFER_NAMES == tuple(b.name for b in REGISTRY) and len(set(BUFFER_NAMES)) == len(REGISTRY)
    assert BUFFER_BYTES == {b.name: np.dtype(b.dtype).itemsize * max(b.channels, 1) for b in REGISTRY}
    assert [b.name for b in KERNEL_BUFFERS] == [n for n in BUFFER_NAMES if n != "coverage"]
    doc = B.__doc__
    rows = [line.split()[0].strip("`") for line in doc.splitlines() if line.startswith("``") and "(H, W" in line]
    assert rows == list(BUFFER_NAMES)
    for b in REGISTRY:
        assert " ".join(b.doc.split()[:4]) in " ".join(doc.split()), b.name


@pytest.mark.parametrize("lens", ("pinhole", "orthographic", "distorted"))
def test_zdepth_alone_is_the_zdepth_made_with_the_other_ray_buffers(lens):
    """z-depth asked alone comes from a vectorised row of rays, with position or face normals from
    each hit pixel's own ray: the same rays, the same float64 arithmetic, the same bits."""
    scene = _two_spheres()
    R = cv2.Rodrigues(np.array([0.05, -0.05, 0.02]))[0]
    kw = dict(orthographic=dict(projection="orthographic"), distorted=dict(dist=(0.1, -0.03, 0.001, 0.002, 0.0)),
              pinhole={})[lens]
    Kc = np.array([[30.0, 0.0, 47.0], [0.0, 30.0, 36.5], [0.0, 0.0, 1.0]]) if lens == "orthographic" else K
    cam = rs.Camera.from_opencv(Kc, R, np.array([0.1, -0.2, 3.5]), W, H, **kw)
    alone = rs.render(scene, camera=cam, buffers=("zdepth",)).buffers["zdepth"]
    mixed = rs.render(scene, camera=cam, buffers=("zdepth", "position", "face_normal")).buffers
    m = mixed["position"].any(axis=-1)
    assert 0.1 < m.mean() < 0.95
    np.testing.assert_array_equal(alone, mixed["zdepth"])
    assert np.all(alone[m] > 0) and np.all(alone[~m] == 0)
