"""The earlier classes of issue 44, each with a small file written here: OFF face and vertex colours
against the numbers in the file, OBJ vertex colours on some lines only, ``usemtl`` in a file without
``mtllib``, a ``newmtl`` without a name."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common.warnings import DroppedOnLoadWarning
from raycast_shade.scene.texture import srgb_to_linear

LOADERS = {"load_models": lambda p: rs.load_models(p)[0].mesh, "Mesh.load": rs.Mesh.load}

CUBE = ["-1 -1 -1", "1 -1 -1", "1 1 -1", "-1 1 -1", "-1 -1 1", "1 -1 1", "1 1 1", "-1 1 1"]
QUADS = [(3, 2, 1, 0), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]


def loaded(loader, path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = LOADERS[loader](path)
    return mesh, [str(w.message) for w in caught if issubclass(w.category, DroppedOnLoadWarning)]


def source_polygon(mesh, corners, triangle) -> int:
    """The polygon (index into ``corners``, vertex positions) whose vertices hold the triangle's three."""
    tri = {tuple(p) for p in mesh.vertices[triangle]}
    (k,) = [k for k, c in enumerate(corners) if tri <= {tuple(p) for p in c}]
    return k


@pytest.mark.parametrize("loader", LOADERS)
@pytest.mark.parametrize("scale, alpha", [(1.0, True), (1.0, False), (255, True), (255, False)])
def test_off_face_colours_follow_their_polygons(tmp_path, loader, scale, alpha):
    """facecube.off's layout: six quads, each with its own RGB(A); 0-1 floats or 0-255 integers."""
    rng = np.random.default_rng(7)
    rgb = rng.integers(0, 256, (6, 3)) / 255.0
    rows = []
    for quad, c in zip(QUADS, rgb):
        values = [*c, 0.75] if alpha else list(c)
        text = " ".join(f"{v:.6f}" if scale == 1.0 else str(int(round(v * 255))) for v in values)
        rows.append(f"4 {' '.join(map(str, quad))} {text}")
    path = tmp_path / "facecube.off"
    path.write_text("OFF\n8 6 12\n" + "\n".join(CUBE + rows) + "\n")
    mesh, warned = loaded(loader, path)
    assert mesh.color_mode == "face" and len(mesh.faces) == 12
    corners = [np.array([[float(x) for x in CUBE[i].split()] for i in q]) for q in QUADS]
    want = np.round(rgb, 6) if scale == 1.0 else rgb
    for t, c in zip(mesh.faces, mesh.colors):
        np.testing.assert_allclose(c, srgb_to_linear(want[source_polygon(mesh, corners, t)]), atol=1e-12)
    assert any("alpha" in w for w in warned) == alpha


@pytest.mark.parametrize("loader", LOADERS)
def test_off_vertex_colours_are_the_files_numbers(tmp_path, loader):
    path = tmp_path / "v.off"
    path.write_text("COFF\n4 2 0\n0 0 0 255 0 0 255\n1 0 0 0 128 0 255\n0 1 0 0 0 255 255\n1 1 0 10 20 30 255\n"
                    "3 0 1 2\n3 1 3 2\n")
    mesh, warned = loaded(loader, path)
    assert mesh.color_mode == "vertex" and not warned
    want = np.array([[255, 0, 0], [0, 128, 0], [0, 0, 255], [10, 20, 30]]) / 255
    for p, c in zip(mesh.vertices, mesh.colors):  # by position: the order is the reader's
        k = int(round(p[0])) + 2 * int(round(p[1]))
        np.testing.assert_allclose(c, srgb_to_linear(want[k]), atol=1e-12)


@pytest.mark.parametrize("loader", LOADERS)
def test_obj_vertex_colours_on_some_lines_only_are_warned_with_counts(tmp_path, loader):
    path = tmp_path / "vc.obj"
    path.write_text("v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 0 1\nv 1 1 0\nv 2 1 0\nf 1 2 3\nf 2 4 3\nf 2 5 4\n")
    mesh, warned = loaded(loader, path)
    assert mesh.colors is None
    assert [w for w in warned if "vc.obj: 2 of 5 vertices (v lines) have a colour" in w and "other 3 none" in w]


@pytest.mark.parametrize("loader", LOADERS)
def test_obj_vertex_colours_on_every_line_are_kept_without_a_word(tmp_path, loader):
    path = tmp_path / "all.obj"
    path.write_text("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n")
    mesh, warned = loaded(loader, path)
    assert mesh.color_mode == "vertex" and not warned
    np.testing.assert_allclose(np.sort(mesh.colors.sum(axis=0)), [1, 1, 1])


def test_usemtl_in_an_obj_without_mtllib_is_no_warning(tmp_path):
    path = tmp_path / "groups.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (model,) = rs.load_models(path)
    np.testing.assert_array_equal(model.material.kd, rs.Material().kd)  # the library's default


def test_usemtl_that_the_named_mtl_lacks_is_still_warned(tmp_path):
    (tmp_path / "m.mtl").write_text("newmtl blue\nKd 0 0 1\n")
    path = tmp_path / "lib.obj"
    path.write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n")
    with pytest.warns(DroppedOnLoadWarning, match=r"usemtl red \(lib.obj:5\)"):
        rs.load_models(path)


def test_a_newmtl_without_a_name_is_a_material_warned_by_file_and_line(tmp_path):
    (tmp_path / "m.mtl").write_text("newmtl red\nKd 1 0 0\n\nnewmtl\nKd 0 1 0\n")
    path = tmp_path / "n.obj"
    path.write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n")
    with pytest.warns(DroppedOnLoadWarning, match=r"m.mtl:4: newmtl without a name"):
        (model,) = rs.load_models(path)
    np.testing.assert_array_equal(model.material.kd, [1, 0, 0])  # red keeps its own Kd, not the next one's
    from raycast_shade.scene.fileparse import parse_mtl

    with pytest.warns(DroppedOnLoadWarning):
        mats = parse_mtl(str(tmp_path / "m.mtl"))
    assert set(mats) == {"red", ""} and mats[""].fields["kd"] == (["0", "1", "0"], 5)
