"""``rs.grad``'s ``light_spot``: a spot light's cone angles against central differences in float64.

The loss is ``sum(W * I)`` over the frame's hit buffer, differenced on the NumPy twin of the kernels
(``study.reference.shade_reference``, itself checked against ``rs.render`` in test_grad_fd.py) with
steps of 1e-4 degrees; relative error <= 1e-4. Warn's factor is C1 in the angles at both cone edges
(the smooth step's slope is 0 there), so pixels on either side of an edge need no exclusion; the hard
edge (``inner_angle == outer_angle``) is a jump, whose derivative is 0 almost everywhere.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study.reference import shade_reference

from .test_grad_fd import H, RTOL, W, _scene

STEP = 1e-4  # degrees


def _spot_scene(inner=8.0, outer=18.0):
    """A Phong sphere lit by a spot light whose cone edges both cross it, a point light beside it."""
    lights = [rs.PointLight((-3.0, 1.0, 2.0), intensity=4.0, attenuation="heuristic", k=1.5),
              rs.SpotLight((0.5, 2.5, 3.0), direction=(-0.2, -0.8, -1.0), intensity=6.0, exponent=3.0,
                           inner_angle=inner, outer_angle=outer, attenuation="inverse_square"),
              rs.SpotLight((-1.0, -2.0, 3.0), direction=(0.3, 0.6, -1.0), intensity=5.0, exponent=1.0,
                           inner_angle=3.0, outer_angle=25.0, color=(0.8, 1.0, 0.9))]
    return _scene("phong", lights)


def _loss(scene, hits, shading, weights):
    return float(np.sum(weights * shade_reference(scene, scene.camera, hits, shading)))


def _moved(scene, row, col, delta):
    lights = list(scene.lights)
    light = lights[row]
    name = ("inner_angle", "outer_angle")[col]
    lights[row] = dataclasses.replace(light, **{name: getattr(light, name) + delta})
    return scene.replace(lights=tuple(lights))


@pytest.fixture(scope="module")
def weights():
    return np.random.default_rng(11).standard_normal((H, W, 3))


@pytest.mark.parametrize("shading", ["phong", "gouraud", "flat"])
def test_spot_angle_gradients_match_central_differences(shading, weights):
    scene = _spot_scene()
    frame = rs.render(scene, shading)
    g = rs.grad(scene, weights, "light_spot", shading=shading, frame=frame)["light_spot"]
    assert g.shape == (3, 2)
    assert np.all(g[0] == 0.0)  # a point light has no cone
    for row in (1, 2):
        for col in (0, 1):
            up = _loss(_moved(scene, row, col, STEP), frame.hits, shading, weights)
            down = _loss(_moved(scene, row, col, -STEP), frame.hits, shading, weights)
            fd = (up - down) / (2.0 * STEP)
            assert abs(fd) > 1e-3, "the cone's edge should cross the sphere"
            assert abs(g[row, col] - fd) <= RTOL * abs(fd), f"light {row}, angle {col}: {g[row, col]} vs {fd}"


def test_a_hard_edged_spot_has_no_angle_gradient_and_the_others_are_unchanged(weights):
    """``inner == outer``: the factor jumps at the edge (the derivative there is a Dirac the hit buffer
    cannot see), and is ``cos^n`` inside: 0 for both angles."""
    scene = _spot_scene(inner=14.0, outer=14.0)
    frame = rs.render(scene, "phong")
    g = rs.grad(scene, weights, ("light_spot", "light_position"), frame=frame)
    assert np.all(g["light_spot"][1] == 0.0) and np.any(g["light_spot"][2] != 0.0)
    assert np.any(g["light_position"][1] != 0.0)
