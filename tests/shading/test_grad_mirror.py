"""``rs.grad`` through one mirror bounce against central differences in float64.

A reflective pixel is ``(1 - rho) local + rho R``. The oracle: ``local`` by the NumPy twin of the
kernels (``study.reference.shade_reference``, no mirrors), ``R`` by the twin's evaluator
(``illuminate_reference``) at each bounce's point, shading normal and view, or the background on a
miss. The bounces (where each mirror ray lands) are the gradient kernel's own, held as the gradient
holds them (they depend on the geometry, not on the materials or lights); the oracle's image is
first checked to be ``rs.render``'s, so they are the renderer's bounces. Steps 1e-5 (1e-4 for the
shininess); relative error <= 1e-4 (test_grad_fd.py's rule).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.shading.grad_frame import PARTS
from raycast_shade.shading.grad_mirror import mirror_vjp
from raycast_shade.shading.grad_terms import layout
from raycast_shade.study.reference import _lights, _materials, illuminate_reference, shade_reference
from raycast_shade.visibility.accel import embree_accel

from . import test_grad_fd
from .test_grad_fd import H, RTOL, W, _check_family

BACKGROUND = (0.2, 0.3, 0.4)


def _mirror_scene(floor_ks=0.3):
    sphere = rs.Material(kd=(0.6, 0.4, 0.3), ka=(0.5, 0.6, 0.7), ks=(0.5, 0.4, 0.6), shininess=20.0)
    floor = rs.Material(kd=(0.3, 0.5, 0.4), ka=0.2, ks=floor_ks, shininess=9.0, reflectivity=0.4, name="floor")
    models = [rs.Model(rs.shapes.icosphere(2), sphere),
              rs.Model(rs.shapes.plane(6.0, 4, center=(0.0, -1.0, 0.0), normal="+y"), floor)]
    lights = [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square"),
              rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.5, color=(1.0, 0.8, 0.6))]
    return rs.Scene(models, lights=lights, ambient=(0.1, 0.12, 0.08), background=BACKGROUND,
                    camera=rs.Camera(eye=(0.0, 0.5, 4.5), target=(0.0, -0.6, 0.0), width=W, height=H))


def _bounces(scene, frame):
    """Each reflective pixel's bounce (H, W, 10) as the gradient kernel finds it."""
    inputs = frame.inputs
    amb, lb, size = layout(len(scene.models), inputs.lighting.lights.shape[0])
    zero = np.zeros(frame.image.shape)
    out = mirror_vjp(frame.hits, inputs, zero, zero, (np.int64(amb), np.int64(lb)), size,
                     int(embree_accel(scene.geometry).handle), float(scene.geometry.scale), PARTS, want_points=True)
    assert not np.any(out[2]), "one bounce: no mirror ray should meet another mirror"
    return out[3]


def _oracle(scene, frame, shading, bounces):
    """The image: the twin's local shade, blended with the twin's shade at the held bounces."""
    hits = frame.hits
    methods = [shading] * len(scene.models) if isinstance(shading, str) else list(shading)
    image = shade_reference(scene, scene.camera, hits, methods[0])
    for m, method in enumerate(methods[1:], start=1):  # the twin takes one method: per model, its pixels
        image = np.where((hits.geom == m)[..., None], shade_reference(scene, scene.camera, hits, method), image)
    rho = np.array([m.material.reflectivity for m in scene.models])[np.maximum(hits.geom, 0)]
    rho = np.where(hits.prim >= 0, rho, 0.0)
    ys, xs = np.nonzero(rho > 0)
    b = bounces[ys, xs]
    R = np.broadcast_to(np.asarray(BACKGROUND, float), (len(ys), 3)).copy()
    hit = b[:, 9] >= 0
    geo = scene.geometry
    R[hit] = illuminate_reference(b[hit, 0:3], b[hit, 3:6], b[hit, 6:9], b[hit, 9].astype(int), _materials(scene),
                                  _lights(scene, geo.origin), np.asarray(scene.ambient, float) * np.ones(3),
                                  frame.inputs.lighting.dmin)
    r = rho[ys, xs][:, None]
    image[ys, xs] = (1.0 - r) * image[ys, xs] + r * R
    return image


@pytest.fixture(scope="module")
def weights():
    return np.random.default_rng(3).standard_normal((H, W, 3))


def _moved_reflectivity(scene, delta):
    models = list(scene.models)
    mat = models[1].material
    models[1] = dataclasses.replace(models[1], material=dataclasses.replace(mat, reflectivity=mat.reflectivity + delta))
    return scene.replace(models=tuple(models))


@pytest.mark.parametrize("shading", ["phong", ["phong", "gouraud"], ["phong", "flat"]])
def test_mirror_bounce_gradients_match_central_differences(shading, weights, monkeypatch):
    scene = _mirror_scene()
    frame = rs.render(scene, shading)
    bounces = _bounces(scene, frame)
    assert np.count_nonzero(bounces[..., 9] == 0) > 20, "the floor should reflect the sphere"
    assert np.count_nonzero(bounces[..., 9] == -1) > 0, "and the background"
    np.testing.assert_allclose(_oracle(scene, frame, shading, bounces), frame.image, rtol=2e-6, atol=1e-6)
    wrt = ("ka", "kd", "ks", "shininess", "reflectivity", "ambient", "light_position", "light_direction",
           "light_radiance")
    g = rs.grad(scene, weights, wrt, shading=shading, frame=frame)
    # The families' differences through the oracle (test_grad_fd's checks, its loss swapped for the oracle's).
    monkeypatch.setattr(test_grad_fd, "_loss", lambda s, hits, sh, w: float(np.sum(w * _oracle(s, frame, sh, bounces))))
    for name in ("ka", "kd", "ks", "shininess", "ambient", "light_radiance"):
        _check_family(scene, frame, shading, weights, g, name)
    _check_family(scene, frame, shading, weights, g, "light_position", skip_rows=(1,))
    _check_family(scene, frame, shading, weights, g, "light_direction", skip_rows=(0,))
    assert g["reflectivity"][0] == 0.0  # the sphere is no mirror
    h = 1e-5
    diff = (np.sum(weights * _oracle(_moved_reflectivity(scene, h), frame, shading, bounces))
            - np.sum(weights * _oracle(_moved_reflectivity(scene, -h), frame, shading, bounces))) / (2.0 * h)
    assert abs(g["reflectivity"][1] - diff) <= RTOL * abs(diff), (g["reflectivity"][1], diff)


def test_mirror_scenes_give_the_geometry_and_refuse_nested_bounces(weights):
    scene = _mirror_scene()
    g = rs.grad(scene, weights, ("normals", "vertices", "camera_eye"))  # checked: tests/shading/test_grad_geomirror.py
    assert all(np.any(g[name] != 0.0) for name in g)
    models = list(scene.models)
    models[0] = dataclasses.replace(models[0], material=dataclasses.replace(models[0].material, reflectivity=0.5))
    both = scene.replace(models=tuple(models))
    for wrt in ("kd", "vertices"):
        with pytest.raises(ValueError, match="meets another reflective surface"):
            rs.grad(both, weights, wrt)
    one = rs.render(both, max_depth=1)  # the last bounce shows its local shade: one bounce, differentiated
    assert np.any(rs.grad(both, weights, "reflectivity", frame=one)["reflectivity"] != 0.0)
