"""Warnings name the user's line (issue 46: the lecture's CreaseWarning was attributed to functools.py:1001,
the cached_property that computed the normals)."""

from __future__ import annotations

import warnings

import raycast_shade as rs
from raycast_shade.common.stack import user_stacklevel


def _cube():
    box = rs.shapes.cube(1.2, crease_angle=None)
    return rs.Mesh(box.vertices, box.faces, weighting="uniform")


def _recorded(action):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        action()
    return [(w.category, w.filename) for w in caught]


def test_a_property_warning_names_the_line_that_read_the_property():
    mesh = _cube()
    assert _recorded(lambda: mesh.prepared) == [(rs.CreaseWarning, __file__)]


def test_a_warning_from_inside_render_names_the_render_call():
    scene = rs.Scene([rs.Model(_cube(), rs.Material(kd=0.5))], lights=[rs.DirectionalLight((-1.0, -1.0, -1.0))],
                     camera=rs.Camera(eye=(1.5, 1.25, 1.8), target=(0.0, 0.0, 0.0), width=8, height=6))
    assert (rs.CreaseWarning, __file__) in _recorded(lambda: rs.render(scene, "gouraud"))


def test_outside_the_package_the_level_is_the_caller():
    assert user_stacklevel() == 1  # called from a test: this very frame is already the user's
