"""``dataclasses.replace`` on a Mesh: the validation runs again on what the mesh stored, which must
be accepted (a mesh without colours stores ``color_mode=None``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import raycast_shade as rs

V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.5]])
F = np.array([[0, 1, 2], [1, 3, 2]])


def test_a_mesh_without_colours_can_be_replaced():
    mesh = rs.Mesh(V, F)
    assert mesh.color_mode is None
    moved = dataclasses.replace(mesh, vertices=V + [0.25, 0.0, 0.0])
    assert np.array_equal(moved.vertices, V + [0.25, 0.0, 0.0])
    assert moved.color_mode is None and moved.colors is None
    assert np.array_equal(moved.faces, mesh.faces)


@pytest.mark.parametrize("rows, mode", [(4, "vertex"), (2, "face")])
def test_a_coloured_mesh_keeps_its_colour_mode_when_replaced(rows, mode):
    colors = np.linspace(0.1, 0.9, rows * 3).reshape(rows, 3)
    mesh = rs.Mesh(V, F, colors=colors)
    assert mesh.color_mode == mode
    moved = dataclasses.replace(mesh, vertices=V * 2.0)
    assert moved.color_mode == mode and np.array_equal(moved.colors, mesh.colors)


def test_none_is_auto_and_a_wrong_mode_is_still_refused():
    assert rs.Mesh(V, F, colors=np.full((4, 3), 0.5), color_mode=None).color_mode == "vertex"
    with pytest.raises((TypeError, ValueError), match="color_mode"):
        rs.Mesh(V, F, colors=np.full((4, 3), 0.5), color_mode="corner")
