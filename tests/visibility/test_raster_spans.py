"""The scan's row spans decide no pixel themselves (issue 41, item 3).

The scan skips the exact edge test where the row's roots, with error margins, make its answer
certain (:func:`raycast_shade.visibility.scan._edge_setup`). So its coverage must be exactly
the exact test's at every pixel centre: checked against a plain NumPy evaluation of the same
float64 edge functions, top-left rule included, at every pixel of the image, on random
triangles (thin slivers, near-horizontal and near-vertical edges, triangles larger than the
image, edges through pixel centres).
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.visibility.raster import coverage_count
from raycast_shade.visibility.scan import _project_ser

W, H = 48, 40


def _inside_numpy(a, b, tl, X, Y):
    e = (a[0] - X) * (b[1] - Y) - (a[1] - Y) * (b[0] - X)
    return (e > 0.0) | ((e == 0.0) & tl)


def _top_left(d):
    return d[1] < 0.0 or (d[1] == 0.0 and d[0] > 0.0)


def _coverage_numpy(px):
    """(H, W) counts of the triangles ``px`` ((T, 3, 2) pixel coordinates) over the centres."""
    Y, X = np.mgrid[0:H, 0:W] + 0.5
    count = np.zeros((H, W), np.int32)
    for p0, p1, p2 in px:
        area = (p0[0] - p2[0]) * (p1[1] - p2[1]) - (p0[1] - p2[1]) * (p1[0] - p2[0])
        if area == 0.0:
            continue
        if area < 0.0:
            p1, p2 = p2, p1
        inside = np.ones((H, W), bool)
        for a, b in ((p0, p1), (p1, p2), (p2, p0)):
            inside &= _inside_numpy(a, b, _top_left(b - a), X, Y)
        count += inside
    return count


def _check(vertices):
    """coverage_count of the triangles ``vertices`` ((T, 3, 3), in front of an orthographic
    camera) against the NumPy edge functions on their projected corners."""
    t = len(vertices)
    mesh = rs.Mesh(vertices.reshape(-1, 3), np.arange(3 * t).reshape(t, 3))
    scene = rs.Scene([rs.Model(mesh)])
    cam = rs.Camera(eye=(0.0, 0.0, 10.0), target=(0.0, 0.0, 0.0), width=W, height=H, projection="orthographic",
                    ortho_height=2.0)
    geo = scene.geometry
    right, up, fwd = cam.basis
    hw, hh = cam.half_extents()
    view = np.ascontiguousarray(np.stack([cam.eye - geo.origin, right, up, fwd]))
    verts = np.ascontiguousarray(geo.vertices)
    cs = np.empty((len(verts), 3))
    vx = np.empty((len(verts), 4))
    _project_ser(verts, view, 0.0, True, float(W), float(H), hw, hh, cs, vx)  # the rasterizer's own corners
    px = vx[geo.faces][:, :, :2]
    np.testing.assert_array_equal(coverage_count(geo, cam), _coverage_numpy(px))


_coord = st.floats(-1.6, 1.6, allow_nan=False, width=64)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(*[_coord] * 6), min_size=1, max_size=6), st.integers(0, 3))
def test_spans_keep_the_exact_tests_pixels(tris, snap):
    v = np.array([[(t[0], t[1], 0.1 * i), (t[2], t[3], 0.1 * i), (t[4], t[5], 0.1 * i)] for i, t in enumerate(tris)])
    if snap:
        # Corners on a coarse grid: edges through pixel centres, horizontal and vertical edges.
        v[:, :, :2] = np.round(v[:, :, :2] * 8.0 * snap) / (8.0 * snap)
    _check(v)


def test_spans_on_slivers_and_giants():
    eps = 1e-9
    v = np.array([
        [(-1.5, 0.0, 0.0), (1.5, eps, 0.0), (1.5, 0.0, 0.0)],  # near-horizontal sliver
        [(0.1, -1.5, 0.1), (0.1 + eps, 1.5, 0.1), (0.2, 1.5, 0.1)],  # near-vertical edge
        [(-50.0, -40.0, 0.2), (60.0, -30.0, 0.2), (0.0, 70.0, 0.2)],  # far larger than the image
        [(-1.0, 0.5, 0.3), (1.0, 0.5 + 1e-13, 0.3), (0.0, -0.9, 0.3)],  # almost horizontal top edge
        [(-1.2, -0.8, 0.4), (1.3, 0.7, 0.4), (-1.2 + 1e-7, -0.8 + 1e-7, 0.4)],  # needle
    ])
    _check(v)
