"""The input contract of hit buffers given to ``shade``, ``shading_normals`` and the
rasterizer's screen-space step: barycentrics outside their triangle beyond float32
rounding are refused with their count (issue 17, class 4; the scene's side:
``tests/scene/test_input_contract.py``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import raycast_shade as rs
from raycast_shade.visibility.hits import BARYCENTRIC_SLACK
from raycast_shade.visibility.interpolation import to_screen_space

EPS32 = float(np.finfo(np.float32).eps)
FAST = settings(max_examples=60, deadline=None)


# =====================================================================================================
# 4. Silently accepted: barycentrics outside their triangle
# =====================================================================================================
@pytest.fixture(scope="module")
def hit_scene():
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=[rs.PointLight((2.0, 3.0, 4.0))],
                     camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=8, height=6))
    return scene, rs.cast_camera(scene.geometry, scene.camera)


def _with_uv(hits, u, v):
    return rs.HitBuffer(prim=hits.prim, geom=hits.geom, u=np.asarray(u, np.float32), v=np.asarray(v, np.float32),
                        t=hits.t)


@pytest.mark.parametrize("u, v", [
    (-1e-3, 0.2), (0.2, -1e-3), (0.6, 0.6), (1.5, 0.0), (0.0, 1.0 + 1e-5), (-0.5, 1.5), (-1.0, -1.0),
    (-10 * EPS32, 0.5), (0.5, 0.5 + 10 * EPS32),
])
def test_shade_refuses_barycentrics_outside_the_triangle(hit_scene, u, v):
    """u < 0, v < 0 or u + v > 1 beyond float32 rounding extrapolated the triangle's normals and
    UVs; the count is named."""
    scene, hits = hit_scene
    n = int(hits.mask.sum())
    bad = _with_uv(hits, np.where(hits.mask, u, 0), np.where(hits.mask, v, 0))
    for call in (lambda: rs.shade(scene, scene.camera, bad, "phong"),
                 lambda: rs.shading_normals(scene, scene.camera, bad),
                 lambda: to_screen_space(bad, scene.geometry, scene.camera)):
        with pytest.raises(ValueError, match=rf"hits.u, hits.v: {n} hit pixel\(s\) lie outside their triangle"):
            call()


@pytest.mark.parametrize("u, v", [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (-EPS32, 0.5), (0.5, 0.5 + 2 * EPS32),
                                  (1.0 + 4 * EPS32, -3 * EPS32), (1 / 3, 1 / 3)])
def test_barycentrics_within_rounding_of_the_triangle_are_shaded(hit_scene, u, v):
    scene, hits = hit_scene
    ok = _with_uv(hits, np.where(hits.mask, u, 0), np.where(hits.mask, v, 0))
    assert np.isfinite(rs.shade(scene, scene.camera, ok, "phong")).all()


@given(u=st.lists(st.floats(-2, 2, width=32), min_size=48, max_size=48),
       v=st.lists(st.floats(-2, 2, width=32), min_size=48, max_size=48))
@FAST
def test_the_outside_count_is_exact(hit_scene, u, v):
    """Property: the named count is the number of hit pixels outside the slack, in float64."""
    scene, hits = hit_scene
    u = np.asarray(u, np.float32).reshape(6, 8)
    v = np.asarray(v, np.float32).reshape(6, 8)
    a, b = u.astype(np.float64), v.astype(np.float64)
    outside = hits.mask & ((a < -BARYCENTRIC_SLACK) | (b < -BARYCENTRIC_SLACK) | (a + b > 1 + BARYCENTRIC_SLACK))
    buf = _with_uv(hits, u, v)
    if outside.sum():
        with pytest.raises(ValueError, match=rf"{int(outside.sum())} hit pixel\(s\) lie outside"):
            rs.shade(scene, scene.camera, buf, "gouraud")
    else:
        rs.shade(scene, scene.camera, buf, "gouraud")


def test_the_casters_own_barycentrics_pass(hit_scene):
    """What the casters and the rasterizer emit is within the slack (measured: 1.5 eps at most)."""
    scene, _ = hit_scene
    for backend in ("raycast", "raster"):
        hits = rs.render(scene, "flat", backend=backend).hits
        assert np.isfinite(rs.shade(scene, scene.camera, hits, "phong")).all()
    assert 4 * EPS32 <= BARYCENTRIC_SLACK <= 16 * EPS32

