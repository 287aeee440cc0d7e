"""The rasterizer's two passes and coarse depth test change no pixel.

The band kernel (:mod:`raycast_shade.visibility.raster_band`) draws the faces turned to the eye
first, then the others behind a per-tile depth test, and breaks depth ties by the lower face
index whatever order the faces come in. So its winners must be a plain z-buffer's that draws
the faces in index order with a strict ``<``: checked against a NumPy z-buffer on the
rasterizer's own projected corners (random soups of both windings, exact ties between
coincident faces of opposite winding), and on a closed mesh whose winding is turned inside out
(the visible faces then all come in the second pass).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.visibility.raster import rasterize
from raycast_shade.visibility.scan import _project_ser

# Coincident faces of opposite winding are the point here, not a modelling slip.
pytestmark = pytest.mark.filterwarnings("ignore:mesh.*repeat another face with the opposite winding")

W, H = 48, 40
EYE = (0.0, 0.0, 4.0)


def _top_left(d):
    return d[1] < 0.0 or (d[1] == 0.0 and d[0] > 0.0)


def _zbuffer_numpy(vx, faces):
    """(H, W) winning face per pixel centre (-1: none): the exact edge test (top-left rule),
    the depth plane of the three projected corners clamped to their keys, in face order with a
    strict ``<`` (ties to the lower index)."""
    Y, X = np.mgrid[0:H, 0:W] + 0.5
    zbuf = np.full((H, W), np.inf)
    fid = np.full((H, W), -1, np.int32)
    for f, (i0, i1, i2) in enumerate(faces):
        (x0, y0, q0), (x1, y1, q1), (x2, y2, q2) = vx[i0, [0, 1, 3]], vx[i1, [0, 1, 3]], vx[i2, [0, 1, 3]]
        p0, p1, p2 = np.array([x0, y0]), np.array([x1, y1]), np.array([x2, y2])
        area = (x0 - x2) * (y1 - y2) - (y0 - y2) * (x1 - x2)
        det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if area == 0.0 or det == 0.0:
            continue
        a1, a2 = (p1, p2) if area > 0.0 else (p2, p1)
        inside = np.ones((H, W), bool)
        for a, b in ((p0, a1), (a1, a2), (a2, p0)):
            e = (a[0] - X) * (b[1] - Y) - (a[1] - Y) * (b[0] - X)
            inside &= (e > 0.0) | ((e == 0.0) & _top_left(b - a))
        zA = ((q1 - q0) * (y2 - y0) - (q2 - q0) * (y1 - y0)) / det
        zB = ((q2 - q0) * (x1 - x0) - (q1 - q0) * (x2 - x0)) / det
        zC = q0 - zA * x0 - zB * y0
        z = np.clip(zA * X + (zB * Y + zC), min(q0, q1, q2), max(q0, q1, q2))
        win = inside & (z < zbuf)
        zbuf[win] = z[win]
        fid[win] = f
    return fid


def _check(vertices):
    """The rasterizer's winners of the triangles ``vertices`` ((T, 3, 3), in front of a
    perspective camera) against :func:`_zbuffer_numpy` on its own projected corners."""
    t = len(vertices)
    faces = np.arange(3 * t).reshape(t, 3)
    scene = rs.Scene([rs.Model(rs.Mesh(vertices.reshape(-1, 3), faces))])
    cam = rs.Camera(eye=EYE, target=(0.0, 0.0, 0.0), width=W, height=H, fov=50.0)
    geo = scene.geometry
    right, up, fwd = cam.basis
    hw, hh = cam.half_extents()
    view = np.ascontiguousarray(np.stack([cam.eye - geo.origin, right, up, fwd]))
    verts = np.ascontiguousarray(geo.vertices)
    cs = np.empty((len(verts), 3))
    vx = np.empty((len(verts), 4))
    _project_ser(verts, view, 1e-9, False, float(W), float(H), hw, hh, cs, vx)  # the rasterizer's own corners
    hits = rasterize(geo, cam)
    np.testing.assert_array_equal(hits.prim, _zbuffer_numpy(vx, geo.faces))
    return hits


_xy = st.floats(-1.8, 1.8, allow_nan=False, width=64)
_z = st.floats(-1.5, 1.5, allow_nan=False, width=64)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(*[_xy, _xy, _z] * 3), min_size=1, max_size=12),
       st.lists(st.tuples(st.integers(0, 11), _z), max_size=4))
def test_two_passes_keep_a_plain_zbuffers_winners(tris, twins):
    v = [np.array(t).reshape(3, 3) for t in tris]
    # Coincident faces of opposite winding at one depth, parallel to the image: every pixel
    # they share is an exact depth tie, which the lower index must win in either pass.
    for k, z in twins:
        flat = v[k % len(tris)].copy()
        flat[:, 2] = z
        v[k % len(tris)] = flat
        v.append(flat[[0, 2, 1]])
    _check(np.array(v))


def test_a_tie_goes_to_the_lower_face_whichever_pass_draws_it():
    tri = np.array([(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (0.0, 1.0, 0.0)])  # faces the eye (+z)
    for pair in ((tri[[0, 2, 1]], tri), (tri, tri[[0, 2, 1]])):  # the second pass's face first, then last
        hits = _check(np.array(pair))
        assert np.count_nonzero(hits.prim == 0) > 100 and not np.any(hits.prim == 1)


def test_an_inside_out_mesh_sees_the_same_faces():
    """Flipped winding puts the visible faces in the second pass, the hidden ones in the first:
    the same face and distance at every pixel, ``u`` and ``v`` trading places."""
    mesh = rs.shapes.icosphere(3)
    cam = rs.Camera(eye=(0.3, 0.5, 3.0), target=(0.0, 0.0, 0.0), width=96, height=72)
    out = rs.Mesh(mesh.vertices, mesh.faces[:, [0, 2, 1]])
    a = rasterize(rs.Scene([rs.Model(mesh)]).geometry, cam)
    b = rasterize(rs.Scene([rs.Model(out)]).geometry, cam)
    assert np.count_nonzero(a.prim >= 0) > 2000
    np.testing.assert_array_equal(a.prim, b.prim)
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_allclose(a.u, b.v, atol=1e-7)
    np.testing.assert_allclose(a.v, b.u, atol=1e-7)
