"""Interior geometry gradients (shading/grad_geometry.py): ``rs.grad(..., wrt=("vertices", "camera_eye",
"camera_rotation"))`` against central finite differences in float64.

The oracle is the renderer with each pixel's triangle held fixed: the perturbed scene's exact
ray-triangle hits (Möller-Trumbore in plain NumPy, float64, each pixel keeping the frame's
triangle), shaded by the NumPy twin of the kernels (``study.reference.shade_reference``). The loss
is ``sum(W * I)`` with a fixed random ``W``; steps 1e-6 (positions, eye) and 1e-6 rad; every checked
component agrees to a relative 1e-4 (of the family's largest where the component is within 1% of it).
"""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.gradients import rotate_camera
from raycast_shade.study.reference import shade_reference
from raycast_shade.visibility.rays import camera_frame

H, W = 36, 48
STEP = 1e-6
RTOL = 1e-4


def _scene(specular="phong", camera=None):
    material = rs.Material(kd=(0.6, 0.4, 0.3), ka=(0.5, 0.6, 0.7), ks=(0.5, 0.4, 0.6), shininess=20.0,
                           specular=specular)
    lights = [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
              rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6))]
    camera = camera or rs.Camera(eye=(0.3, 0.2, 4.0), target=(0.0, 0.1, 0.0), width=W, height=H)
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), material)], lights=lights, camera=camera,
                    ambient=(0.1, 0.12, 0.08))


def _moved_vertex(scene, row, col, delta):
    model = scene.models[0]
    verts = np.array(model.mesh.vertices, float)
    verts[row, col] += delta
    mesh = rs.Mesh(verts, model.mesh.faces, normals=model.mesh.normals)
    return scene.replace(models=(dataclasses.replace(model, mesh=mesh),))


def exact_hits(scene, hits):
    """The pixels' hits on the frame's triangles (held) in the scene as it is now: plain NumPy."""
    geo = scene.geometry
    cam = camera_frame(scene.camera, geo.origin)
    h, w = hits.prim.shape
    ys, xs = np.mgrid[0:h, 0:w]
    sx = 2.0 * (xs + 0.5) / w - 1.0
    sy = 1.0 - 2.0 * (ys + 0.5) / h
    right, up, fwd = cam[3:6], cam[6:9], cam[9:12]
    if cam[12] != 0.0:
        o = cam[0:3] + sx[..., None] * right + sy[..., None] * up
        d = np.broadcast_to(fwd, o.shape)
    else:
        d = fwd + sx[..., None] * right + sy[..., None] * up
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        o = np.broadcast_to(cam[0:3], d.shape)
    mask = hits.prim >= 0
    face = geo.face_offsets[np.maximum(hits.geom, 0)] + np.maximum(hits.prim, 0)
    P = geo.vertices[geo.faces[face]]
    e1, e2 = P[..., 1, :] - P[..., 0, :], P[..., 2, :] - P[..., 0, :]
    M = np.stack([-d, e1, e2], axis=-1)
    M[~mask] = np.eye(3)
    x = np.linalg.solve(M, (o - P[..., 0, :])[..., None])[..., 0]
    u = np.where(mask, x[..., 1], 0.0)
    v = np.where(mask, x[..., 2], 0.0)
    return SimpleNamespace(prim=hits.prim, geom=hits.geom, u=u, v=v, t=np.where(mask, x[..., 0], np.inf),
                           shape=hits.prim.shape)


def _loss(scene, hits, shading, weights):
    return float(np.sum(weights * shade_reference(scene, scene.camera, exact_hits(scene, hits), shading)))


def _fd(make, hits, shading, weights):
    return (_loss(make(STEP), hits, shading, weights) - _loss(make(-STEP), hits, shading, weights)) / (2 * STEP)


def _check(got, fd, top, what):
    scale = max(abs(fd), 1e-2 * top)
    assert abs(got - fd) <= RTOL * scale, f"{what}: kernel {got!r}, finite difference {fd!r}"


@pytest.fixture(scope="module")
def weights():
    return np.random.default_rng(11).standard_normal((H, W, 3))


def _vertices_seen(scene, frame, k=8, seed=3):
    """``k`` vertices of triangles the frame sees (some gradient to check), chosen by a fixed seed."""
    seen = np.unique(scene.geometry.faces[frame.hits.prim[frame.hits.prim >= 0]])
    return np.random.default_rng(seed).choice(seen, k, replace=False)


ORTHO = rs.Camera(eye=(0.3, 0.2, 4.0), target=(0.0, 0.1, 0.0), width=W, height=H, projection="orthographic",
                  ortho_height=2.6)


@pytest.mark.parametrize("shading,specular,camera", [("phong", "phong", None), ("phong", "blinn", None),
                                                     ("gouraud", "phong", None), ("flat", "phong", None),
                                                     ("phong", "phong", ORTHO), ("flat", "blinn", ORTHO)])
def test_vertex_and_camera_gradients_match_finite_differences(shading, specular, camera, weights):
    scene = _scene(specular, camera)
    assert scene.geometry.vertices.shape[0] == len(scene.models[0].mesh.vertices)  # rows are the mesh's
    frame = rs.render(scene, shading)
    # the oracle's image at the unperturbed scene is the frame's (float32 rounding)
    ref = shade_reference(scene, scene.camera, exact_hits(scene, frame.hits), shading)
    assert np.allclose(ref, frame.image, atol=1e-4)
    g = rs.grad(scene, weights, ("vertices", "camera_eye", "camera_rotation"), shading=shading, frame=frame)
    assert g["vertices"].shape == (scene.geometry.vertices.shape[0], 3)
    top = float(np.max(np.abs(g["vertices"])))
    assert top > 0
    for i in _vertices_seen(scene, frame):
        for c in range(3):
            fd = _fd(lambda h: _moved_vertex(scene, i, c, h), frame.hits, shading, weights)
            _check(g["vertices"][i, c], fd, top, f"vertex {i}[{c}]")
    cam = scene.camera
    top_e = float(np.max(np.abs(g["camera_eye"])))
    top_r = float(np.max(np.abs(g["camera_rotation"])))
    # flat shading under an orthographic camera: a face's shade does not depend on the eye
    assert (top_e == 0.0) == (shading == "flat" and camera is not None)
    # flat shading under a perspective camera: a face's shade does not depend on the camera's turn
    assert (top_r == 0.0) == (shading == "flat" and camera is None)
    for c in range(3):
        e = np.zeros(3)
        e[c] = 1.0
        fd = _fd(lambda h: scene.replace(camera=cam.replace(eye=tuple(np.array(cam.eye) + h * e),
                                                              target=tuple(np.array(cam.target) + h * e))),
                 frame.hits, shading, weights)
        _check(g["camera_eye"][c], fd, max(top_e, 1.0), f"camera_eye[{c}]")
        fd = _fd(lambda h: scene.replace(camera=rotate_camera(cam, h * e)), frame.hits, shading, weights)
        _check(g["camera_rotation"][c], fd, max(top_r, 1.0), f"camera_rotation[{c}]")


def test_geometry_gradients_are_deterministic_across_threads(weights):
    """Every method in one frame (three spheres), with a shadowing light: bit-identical on 1 and 2
    threads and run to run."""
    import numba

    material = rs.Material(kd=0.6, ks=0.4, shininess=15.0)
    models = [rs.Model(rs.shapes.icosphere(2, radius=0.6, center=(x, 0.0, 0.0)), material) for x in (-1.3, 0.0, 1.3)]
    scene = rs.Scene(models, lights=[rs.PointLight((1.0, 3.0, 3.0), intensity=15.0, shadows=True)],
                     camera=rs.Camera(eye=(0.0, 0.5, 4.0), width=W, height=H))
    shading = ("flat", "gouraud", "phong")
    frame = rs.render(scene, shading)
    runs = []
    for threads in (1, 2, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        try:
            runs.append(rs.grad(scene, weights, ("vertices", "camera_eye", "camera_rotation", "kd"), shading=shading,
                                frame=frame))
        finally:
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert np.any(runs[0]["vertices"] != 0.0)
    for other in runs[1:]:
        for name in runs[0]:
            assert np.array_equal(runs[0][name], other[name]), name
