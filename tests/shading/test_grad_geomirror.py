"""Geometry (vertices, camera pose) and vertex-normal gradients through one mirror bounce
(shading/grad_mirror.py's ``mirror_scatter``) against central finite differences in float64.

The oracle, plain NumPy over the NumPy twin: each pixel's camera hit on its (held) triangle
(test_grad_geometry's ``exact_hits``), the local shade by ``shade_reference``; for a reflective
pixel, the mirror ray ``r = -v + 2 (v.n) n`` about the mirror's interpolated, renormalised normal
from the hit point, its exact hit on the bounce's (held) triangle, and the twin's evaluator
(``illuminate_reference``) there with the bounce's interpolated normal, seen along ``-r``. The mirror
is a plane whose vertex normals are tilted at random (so its interpolated normal, and the reflected
ray, turn as a hit slides). The oracle is first checked to be ``rs.render``'s image. Steps 1e-6;
relative error <= 1e-4 (test_grad_geometry's rule).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.gradients import rotate_camera
from raycast_shade.shading.grad_frame import PARTS
from raycast_shade.shading.grad_mirror import mirror_vjp
from raycast_shade.shading.grad_terms import layout
from raycast_shade.shading.mirror_rays import _offset
from raycast_shade.study.reference import _lights, _materials, illuminate_reference, shade_reference
from raycast_shade.visibility.accel import embree_accel
from raycast_shade.visibility.rays import camera_frame

from .test_grad_geometry import RTOL, STEP, exact_hits

H, W = 40, 48
BACKGROUND = (0.2, 0.3, 0.4)
GEOMETRY = ("vertices", "camera_eye", "camera_rotation")


def _mirror_scene(camera=None):
    sphere = rs.Material(kd=(0.6, 0.4, 0.3), ka=(0.5, 0.6, 0.7), ks=(0.5, 0.4, 0.6), shininess=20.0)
    floor = rs.Material(kd=(0.3, 0.5, 0.4), ka=0.2, ks=0.3, shininess=9.0, reflectivity=0.6, name="mirror")
    plane = rs.shapes.plane(6.0, 4, center=(0.0, -1.0, 0.0), normal="+y")
    tilt = np.random.default_rng(9).normal(0.0, 0.15, plane.vertices.shape)
    normals = plane.normals + tilt
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    models = [rs.Model(rs.shapes.icosphere(2), sphere), rs.Model(rs.Mesh(plane.vertices, plane.faces, normals=normals),
                                                                floor)]
    lights = [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
              rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6))]
    camera = camera or rs.Camera(eye=(0.3, 0.5, 4.5), target=(0.0, -0.6, 0.0), width=W, height=H)
    return rs.Scene(models, lights=lights, ambient=(0.1, 0.12, 0.08), background=BACKGROUND, camera=camera)


def _unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def _shading_normal(geo, face, bary, view):
    """The forward pass's shading normal: interpolated, renormalised, turned with the face to the viewer."""
    tri = geo.faces[face]
    g = geo.face_normals[face]
    sgn = np.where(np.einsum("ij,ij->i", g, view) < 0.0, -1.0, 1.0)[:, None]
    g = g * sgn
    n = sgn * _unit(np.einsum("ik,ikc->ic", bary, geo.normals[tri]))
    c = np.einsum("ij,ij->i", n, g)[:, None]
    return np.where(c < 0.0, n - 2.0 * c * g, n), g


def _ray_hit(o, d, P):
    """Exact hits of rays ``o + t d`` on triangles ``P`` (N, 3, 3): points and barycentrics (N, 3)."""
    e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    x = np.linalg.solve(np.stack([-d, e1, e2], axis=-1), (o - P[:, 0])[..., None])[..., 0]
    return o + x[:, :1] * d, np.stack([1.0 - x[:, 1] - x[:, 2], x[:, 1], x[:, 2]], axis=-1)


def oracle(scene, frame, bounce_faces, shading="phong", push=None):
    """The image with every pixel's triangle and every bounce's triangle held (NumPy, float64), and
    the mirror rays' pushes off the surface (``push``: the scene's own by default); returns both."""
    hits = exact_hits(scene, frame.hits)
    methods = [shading] * len(scene.models) if isinstance(shading, str) else list(shading)
    image = shade_reference(scene, scene.camera, hits, methods[0])
    for m, method in enumerate(methods[1:], start=1):  # the twin takes one method: per model, its pixels
        image = np.where((hits.geom == m)[..., None], shade_reference(scene, scene.camera, hits, method), image)
    geo = scene.geometry
    cam = camera_frame(scene.camera, geo.origin)
    rho = np.array([m.material.reflectivity for m in scene.models])[np.maximum(hits.geom, 0)]
    rho = np.where(hits.prim >= 0, rho, 0.0)
    miss = (rho > 0) & (bounce_faces < 0)  # the background, seen in the mirror
    image[miss] = (1.0 - rho[miss, None]) * image[miss] + rho[miss, None] * np.asarray(BACKGROUND)
    ys, xs = np.nonzero((rho > 0) & (bounce_faces >= 0))
    face = geo.face_offsets[hits.geom[ys, xs]] + hits.prim[ys, xs]
    bary = np.stack([1.0 - hits.u[ys, xs] - hits.v[ys, xs], hits.u[ys, xs], hits.v[ys, xs]], axis=-1)
    p = np.einsum("ik,ikc->ic", bary, geo.vertices[geo.faces[face]])
    v = _unit(cam[0:3] - p)
    n, g = _shading_normal(geo, face, bary, v)
    r = -v + 2.0 * np.einsum("ij,ij->i", v, n)[:, None] * n
    c = np.einsum("ij,ij->i", r, g)[:, None]
    r = np.where(c < 0.0, r - 2.0 * c * g, r)
    fq = bounce_faces[ys, xs]
    if push is None:  # the forward's origin: the hit pushed off along the face's normal (a step held)
        unit = float(geo.scale)
        o = np.array([[_offset(p[i, c], g[i, c], unit) for c in range(3)] for i in range(len(p))]).reshape(-1, 3)
        push = o - p
    q, bq = _ray_hit(p + push, r, geo.vertices[geo.faces[fq]])
    nq, _ = _shading_normal(geo, fq, bq, -r)
    R = illuminate_reference(q, nq, -r, geo.face_model[fq], _materials(scene), _lights(scene, geo.origin),
                             np.asarray(scene.ambient, float) * np.ones(3), frame.inputs.lighting.dmin)
    k = rho[ys, xs][:, None]
    image[ys, xs] = (1.0 - k) * image[ys, xs] + k * R
    return image, push


def _bounce_faces(scene, frame):
    """The packed face each mirror ray meets, as the gradient kernel finds it (-1: none, or no mirror)."""
    inputs = frame.inputs
    amb, lb, size = layout(len(scene.models), inputs.lighting.lights.shape[0])
    zero = np.zeros(frame.image.shape)
    out = mirror_vjp(frame.hits, inputs, zero, zero, (np.int64(amb), np.int64(lb)), size,
                     int(embree_accel(scene.geometry).handle), float(scene.geometry.scale), PARTS, want_points=True)
    assert not np.any(out[2])
    return out[3][..., 10].astype(np.int64)


def _moved_vertex(scene, row, col, delta):
    """``scene`` with packed vertex ``row`` moved (its model's mesh rebuilt, normals kept)."""
    geo = scene.geometry
    m = int(np.searchsorted(geo.vertex_offsets, row, side="right") - 1)
    model = scene.models[m]
    verts = np.array(model.mesh.vertices, float)
    verts[row - geo.vertex_offsets[m], col] += delta
    models = list(scene.models)
    models[m] = dataclasses.replace(model, mesh=rs.Mesh(verts, model.mesh.faces, normals=model.mesh.normals))
    return scene.replace(models=tuple(models))


def _refined(scene, shading):
    """The frame with its barycentrics replaced by the exact hits' (as test_grad_geotex.refined)."""
    frame = rs.render(scene, shading)
    exact = exact_hits(scene, frame.hits)
    hit = frame.hits.prim >= 0
    frame.hits.u[hit] = exact.u[hit]
    frame.hits.v[hit] = exact.v[hit]
    return frame


@pytest.mark.parametrize("shading", ["phong", ["flat", "phong"]])
def test_geometry_and_normals_through_one_mirror_bounce_match_central_differences(shading):
    scene = _mirror_scene()
    frame = rs.render(scene, shading)
    faces = _bounce_faces(scene, frame)
    geo = scene.geometry
    assert np.count_nonzero(geo.face_model[np.maximum(faces, 0)][faces >= 0] == 0) > 30  # the sphere in the mirror
    image, push = oracle(scene, frame, faces, shading)
    np.testing.assert_allclose(image, frame.image, atol=2e-5)
    frame = _refined(scene, shading)
    weights = np.random.default_rng(11).standard_normal(frame.image.shape)
    loss = lambda s: float(np.sum(weights * oracle(s, frame, faces, shading, push)[0]))  # noqa: E731
    g = rs.grad(scene, weights, GEOMETRY + ("normals",), shading=shading, frame=frame)
    tops = {name: float(np.max(np.abs(g[name]))) for name in GEOMETRY + ("normals",)}
    # vertices of the mirror's pixels' triangles and of the triangles seen in it
    mirror_px = (frame.hits.geom == 1) & (faces >= 0)
    seen = np.unique(geo.faces[faces[mirror_px]])
    under = np.unique(geo.faces[geo.face_offsets[1] + frame.hits.prim[mirror_px]])
    rng = np.random.default_rng(3)
    checks = [("vertices", (int(i), c)) for i in np.concatenate([rng.choice(seen, 4, replace=False),
                                                               rng.choice(under, 4, replace=False)]) for c in range(3)]
    checks += [(name, c) for name in ("camera_eye", "camera_rotation") for c in range(3)]
    checks += [("normals", (int(i), c)) for i in rng.choice(under, 2, replace=False) for c in range(3)]
    cam = scene.camera
    for name, index in checks:
        if name == "vertices":
            make = lambda h: _moved_vertex(scene, index[0], index[1], h)  # noqa: E731
        elif name == "camera_eye":
            e = np.eye(3)[index]
            make = lambda h: scene.replace(camera=cam.replace(eye=tuple(np.array(cam.eye) + h * e),  # noqa: E731
                                                              target=tuple(np.array(cam.target) + h * e)))
        elif name == "camera_rotation":
            e = np.eye(3)[index]
            make = lambda h: scene.replace(camera=rotate_camera(cam, h * e))  # noqa: E731
        if name == "normals":
            normals = geo.normals
            keep = normals[index]
            fd = []
            for h in (STEP, -STEP):
                normals[index] = keep + h
                fd.append(loss(scene))
            normals[index] = keep
        else:
            fd = [loss(make(STEP)), loss(make(-STEP))]
        fd = (fd[0] - fd[1]) / (2 * STEP)
        scale = max(abs(fd), 1e-2 * tops[name])
        assert abs(g[name][index] - fd) <= RTOL * scale, f"{name}{index}: kernel {g[name][index]!r}, fd {fd!r}"
