"""OFF polygons read and triangulated by the library; OFF and binary PLY rows checked, naming line or face.

Every file here is written by its test.
"""

from __future__ import annotations

import struct
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs


def _area(mesh) -> float:
    v, f = mesh.vertices, mesh.faces
    return float(0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum())


def _shoelace(xy) -> float:
    x, y = np.asarray(xy, float).T
    return abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))) / 2


def _off(path, xy, extra_faces=(), header="OFF"):
    lines = [header, f"{len(xy)} {1 + len(extra_faces)} 0"] + [f"{x!r} {y!r} 0" for x, y in xy]
    lines.append(f"{len(xy)} " + " ".join(str(i) for i in range(len(xy))))
    lines += [f"{len(f)} " + " ".join(map(str, f)) for f in extra_faces]
    path.write_text("\n".join(lines) + "\n")
    return path


CONVEX = [(0, 0), (1, 0), (1.3, 0.8), (0.5, 1.2), (-0.3, 0.8)]
CONCAVE = [(0, 0), (2, 0), (2, 1), (1, 0.2), (0, 1)]  # an arrow notch at vertex 3: a fan from 0 spills over it


@pytest.mark.parametrize("xy, fan_right", [(CONVEX, True), (CONCAVE, False)], ids=["convex", "concave"])
def test_an_off_pentagon_loads_with_its_shoelace_area(tmp_path, xy, fan_right):
    """trimesh failed on any polygon of five vertices; a concave one fanned from vertex 0 covers more."""
    path = _off(tmp_path / "p.off", xy)
    for mesh in (rs.load_models(path)[0].mesh, rs.Mesh.load(path)):
        assert len(mesh.faces) == 3
        assert _area(mesh) == pytest.approx(_shoelace(xy), rel=1e-12)
        assert (np.cross(mesh.vertices[mesh.faces[:, 1]] - mesh.vertices[mesh.faces[:, 0]],
                         mesh.vertices[mesh.faces[:, 2]] - mesh.vertices[mesh.faces[:, 0]])[:, 2] > 0).all()
    xy = np.asarray(xy, float)
    fan = sum(_shoelace(xy[[0, i, i + 1]]) for i in range(1, 4))  # what a fan from vertex 0 would cover
    assert (fan == pytest.approx(_shoelace(xy), rel=1e-12)) == fan_right


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0.3, 1.0), min_size=5, max_size=9), st.floats(0, 2 * np.pi))
def test_star_shaped_off_polygons_cover_their_outline(tmp_path_factory, radii, turn):
    """Vertices at rising angles around the origin with random radii (concave where a radius dips): the
    triangles' area is the outline's, whatever the shape (ear clipping; a fan is right only when convex)."""
    k = len(radii)
    angles = turn + 2 * np.pi * np.arange(k) / k
    xy = np.c_[np.cos(angles), np.sin(angles)] * np.asarray(radii)[:, None]
    path = _off(tmp_path_factory.mktemp("star") / "s.off", [tuple(p) for p in xy.tolist()])
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.DroppedOnLoadWarning)
        (model,) = rs.load_models(path)
    assert len(model.mesh.faces) == k - 2
    assert _area(model.mesh) == pytest.approx(_shoelace(xy), rel=1e-9)


def test_triangles_and_quads_keep_the_faces_trimesh_gave(tmp_path):
    """Convex polygons: trimesh's own triangles in its order (triangles, quads' first halves, second halves)."""
    import trimesh

    path = tmp_path / "tq.off"
    path.write_text("OFF\n6 3 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n2 1 0\n4 0 1 2 3\n3 1 4 5\n4 1 4 5 2\n")
    ours = rs.load_models(path)[0].mesh.faces
    theirs = np.asarray(trimesh.load(path, process=False).faces)
    np.testing.assert_array_equal(ours, theirs)


def test_off_face_colours_follow_a_pentagons_triangles(tmp_path):
    path = tmp_path / "c.off"
    verts = [f"{x} {y} 0" for x, y in CONCAVE] + ["5 5 0"]
    path.write_text("OFF\n6 2 0\n" + "\n".join(verts) + "\n5 0 1 2 3 4 255 0 0\n3 0 1 5 0 0 255\n")
    (model,) = rs.load_models(path)
    colours = model.mesh.colors
    assert len(model.mesh.faces) == 4 and colours.shape == (4, 3)
    np.testing.assert_allclose(colours[0], [0, 0, 1])  # the triangle first (trimesh's order), then the pentagon's
    np.testing.assert_allclose(colours[1:], [[1, 0, 0]] * 3)


@pytest.mark.parametrize("body, match", [
    ("3 0 1 2\n3 0 2 9\n", r"bad.off:8: face 1 indexes vertex 9, but the file has 4 vertices"),
    ("3 0 1 2\n3 0 -1 2\n", r"bad.off:8: face 1 indexes vertex -1"),
    ("3 0 1 2\n2 0 1\n", r"bad.off:8: face 1: '2 0 1': expected a vertex count of 3 or more"),
    ("3 0 1 2\n4 0 1 2\n", r"bad.off:8: face 1: '4 0 1 2': expected a vertex count of 3 or more and that many"),
    ("3 0 1 2\n3 0 x 2\n", r"bad.off:8: face 1: a vertex index is not an integer"),
    ("3 0 1 2\n", r"bad.off: the header declares 2 face line\(s\), the file has 1"),
])
def test_off_rows_are_refused_naming_the_line_and_face(tmp_path, body, match):
    path = tmp_path / "bad.off"
    path.write_text("OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n" + body)
    for load in (rs.load_models, rs.Mesh.load):
        with pytest.raises(ValueError, match=match):
            load(path)


def test_an_off_vertex_without_three_numbers_is_refused_naming_its_line(tmp_path):
    path = tmp_path / "v.off"
    path.write_text("OFF\n# a comment\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n")
    with pytest.raises(ValueError, match=r"v.off:5: a vertex needs 3 coordinates"):
        rs.load_models(path)


# -- binary PLY ----------------------------------------------------------------------------------------

def _ply(path, faces, nv=4, count=None, cut=0):
    """A binary little-endian PLY: ``nv`` vertices of the unit square, ``faces`` as uchar-counted int lists
    (``count``: a list count written instead of the true one, for face 1); ``cut`` bytes cut off the end."""
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]][:nv], "<f4").tobytes()
    rows = [struct.pack("<B", count if (count is not None and k == 1) else len(f)) + np.array(f, "<i4").tobytes()
            for k, f in enumerate(faces)]
    data = head.encode() + v + b"".join(rows)
    path.write_bytes(data[:len(data) - cut])
    return path


def test_a_clean_binary_ply_loads(tmp_path):
    (model,) = rs.load_models(_ply(tmp_path / "ok.ply", [[0, 1, 2], [0, 2, 3]]))
    np.testing.assert_array_equal(model.mesh.faces, [[0, 1, 2], [0, 2, 3]])


@pytest.mark.parametrize("faces, kw, match", [
    ([[0, 1, 2], [0, 2, 7], [0, 1, 3]], {}, r"b.ply: face 1 indexes vertex 7, but the file has 4 vertices"),
    ([[0, 1, 2], [0, 2, 3], [3, 1, -2]], {}, r"b.ply: face 2 indexes vertex -2"),
    ([[0, 1, 2, 3], [0, 2, 3], [1, 2, 3], [0, 1, 9]], {}, r"b.ply: face 3 indexes vertex 9"),  # rows of two lengths
    ([[0, 1, 2], [0, 2, 3]], {"count": 2}, r"b.ply: face 1: vertex_indices: a list of 2 index"),
    ([[0, 1, 2], [0, 2, 3]], {"count": 9}, r"b.ply: face 1: vertex_indices: the list says 9 value\(s\), and the "
                                           r"file ends before them"),
    ([[0, 1, 2], [0, 2, 3]], {"cut": 2}, r"b.ply: face 1: vertex_indices: the list says 3 value\(s\), and the file "
                                         r"ends before them"),
])
def test_broken_binary_ply_faces_are_refused_naming_the_face(tmp_path, faces, kw, match):
    path = _ply(tmp_path / "b.ply", faces, **kw)
    for load in (rs.load_models, rs.Mesh.load):
        with pytest.raises(ValueError, match=match):
            load(path)


# -- mutated files: loaded, or refused in one line naming the file (the load-error property test's rule) -----

from tests.scene.test_load_errors import FUZZ, check, mutate_text  # noqa: E402

OFF_TEXT = ("OFF\n# a quad, a concave pentagon, a triangle\n8 3 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0 0\n4 0 0\n"
            "4 1 0\n3 0.2 0\n4 0 1 2 3\n5 4 5 6 7 2 200 10 10\n3 1 4 2\n")


@FUZZ
@given(data=st.data())
def test_mutated_off_files_load_or_are_refused_naming_the_file(tmp_path, data):
    path = tmp_path / "mutant.off"
    path.write_text(mutate_text(OFF_TEXT, data))
    check(path)


@FUZZ
@given(data=st.data())
def test_mutated_binary_ply_files_load_or_are_refused_naming_the_file(tmp_path, data):
    """Bytes of the body overwritten (vertex values, list counts, indices) or the file cut short."""
    path = _ply(tmp_path / "mutant.ply", [[0, 1, 2, 3], [0, 2, 3], [1, 2, 3]])
    raw = bytearray(path.read_bytes())
    body = raw.index(b"end_header\n") + len("end_header\n")
    for _ in range(data.draw(st.integers(1, 3), "edits")):
        raw[data.draw(st.integers(body, len(raw) - 1), "at")] = data.draw(st.integers(0, 255), "byte")
    if data.draw(st.booleans(), "cut"):
        raw = raw[:data.draw(st.integers(body, len(raw) - 1), "cut at")]
    path.write_bytes(bytes(raw))
    check(path)


@pytest.mark.parametrize("head", ["OFF\n4 2 0", "OFF 4 2 0", "\t  OFF4 2 0 # counts glued to the keyword", "COFF\n4 2 0"])
def test_off_counts_after_the_keyword_in_every_spelling(tmp_path, head):
    """trimesh's models/whitespace.off writes ``OFF8 6 12``: the counts follow the keyword, wherever they are."""
    path = tmp_path / "h.off"
    path.write_text(head + "\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n")
    (model,) = rs.load_models(path)
    np.testing.assert_array_equal(model.mesh.faces, [[0, 1, 2], [0, 2, 3]])
