"""OBJ polygons: non-convex ones ear-clipped in their plane, convex ones as trimesh always split them.

The references are closed forms and plain NumPy: the shoelace area of the outline in its plane,
Newell's vector area, a crossing-number point-in-polygon test; trimesh's own reader for the
convex faces (which must come out bit for bit as before).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.common.warnings import DroppedOnLoadWarning
from raycast_shade.scene.polygons import ear_clip_obj


def obj_text(points, faces, extra: str = "") -> str:
    """An OBJ of ``points`` (N, 3) and ``faces`` (lists of 0-based indices)."""
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(points, np.float64).tolist()]
    lines += ["f " + " ".join(str(i + 1) for i in f) for f in faces]
    return extra + "\n".join(lines) + "\n"


def load(tmp_path, text: str, name: str = "poly.obj"):
    path = tmp_path / name
    path.write_text(text)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = rs.Mesh.load(path)
    return mesh, [str(w.message) for w in caught if issubclass(w.category, DroppedOnLoadWarning)]


def triangle_areas(mesh):
    v = mesh.vertices[mesh.faces]
    return np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]) / 2  # (T, 3) vector areas


def shoelace(xy) -> float:
    x, y = np.asarray(xy, np.float64).T
    return float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2


def inside(p, xy) -> bool:
    """Crossing-number test of the 2-D point ``p`` against the closed outline ``xy``."""
    x, y = np.asarray(xy, np.float64).T
    x2, y2 = np.roll(x, -1), np.roll(y, -1)
    crosses = ((y > p[1]) != (y2 > p[1])) & (p[0] < x + (p[1] - y) * (x2 - x) / np.where(y2 == y, 1, y2 - y))
    return bool(np.count_nonzero(crosses) % 2)


def placed(xy, rotation, offset):
    """2-D outline points placed in 3-D: z = 0, then rotated and moved."""
    xy = np.asarray(xy, np.float64)
    return np.c_[xy, np.zeros(len(xy))] @ rotation.T + offset


L_SHAPE = [(2, 0), (2, 1), (1, 1), (1, 2), (0, 2), (0, 0)]  # reflex vertex at (1, 1)


def test_an_l_shaped_hexagon_covers_its_own_area_not_the_fan_from_a_reflex_vertex(tmp_path):
    # Written from the reflex vertex: its fan covers 3.5 (spilling over the notch), the L covers 3.
    order = [2, 3, 4, 5, 0, 1]
    mesh, warned = load(tmp_path, obj_text(placed(L_SHAPE, np.eye(3), 0), [order]))
    areas = triangle_areas(mesh)
    assert len(mesh.faces) == 4 and not warned
    assert np.linalg.norm(areas, axis=1).sum() == pytest.approx(3.0, rel=1e-12)
    np.testing.assert_allclose(areas.sum(axis=0), [0, 0, 3.0], atol=1e-12)  # wound as written: +z
    for tri in mesh.vertices[mesh.faces]:
        assert inside(tri[:, :2].mean(axis=0), L_SHAPE)


def keyhole(n: int = 16, r_out: float = 1.0, r_in: float = 0.5):
    """A ring around a hole as one outline: out along a bridge, around the hole backwards, and back
    (the bridge's two vertices written twice), as exporters write a face with a hole."""
    t = 2 * np.pi * np.arange(n) / n
    outer = np.c_[r_out * np.cos(t), r_out * np.sin(t)]
    inner = np.c_[r_in * np.cos(t), r_in * np.sin(t)]
    points = np.r_[outer, inner]
    ring = list(range(n)) + [0, n] + [n + i for i in range(n - 1, 0, -1)] + [n]
    return points, ring


def test_a_keyhole_ring_with_its_bridge_written_twice_covers_the_annulus(tmp_path):
    points, ring = keyhole()
    rot = trimesh.transformations.rotation_matrix(0.7, [1, 2, 3])[:3, :3]
    mesh, warned = load(tmp_path, obj_text(placed(points, rot, [3, -1, 2]), [ring]))
    outline = shoelace(points[ring])  # the bridge's two passes cancel: outer polygon minus inner
    n = 16
    polygon_area = n / 2 * np.sin(2 * np.pi / n) * (1.0 - 0.25)
    assert outline == pytest.approx(polygon_area, rel=1e-12)
    areas = triangle_areas(mesh)
    assert np.linalg.norm(areas, axis=1).sum() == pytest.approx(outline, rel=1e-9)
    np.testing.assert_allclose(areas.sum(axis=0), rot @ [0, 0, outline], atol=1e-9)
    assert not warned
    back = (mesh.vertices[mesh.faces].mean(axis=1) - [3, -1, 2]) @ rot  # centroids in the ring's plane
    assert np.all(np.hypot(back[:, 0], back[:, 1]) > 0.5 * np.cos(np.pi / n) - 1e-12)  # none in the hole


@settings(max_examples=40, deadline=None)
@given(radii=st.lists(st.floats(0.2, 1.0), min_size=5, max_size=12),
       angle=st.floats(0, np.pi), axis=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda a: np.linalg.norm(a) > 0.1),
       start=st.integers(0, 11))
def test_star_shaped_polygons_in_any_plane_cover_their_shoelace_area(tmp_path_factory, radii, angle, axis, start):
    k = len(radii)
    t = 2 * np.pi * np.arange(k) / k
    xy = np.c_[np.cos(t), np.sin(t)] * np.asarray(radii)[:, None]
    order = list(np.roll(np.arange(k), start % k))
    rot = trimesh.transformations.rotation_matrix(angle, axis)[:3, :3]
    path = tmp_path_factory.mktemp("star") / "star.obj"
    path.write_text(obj_text(placed(xy, rot, [1, 2, 3]), [order]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a planar simple polygon: no warning at all
        mesh = rs.Mesh.load(path)
    areas = triangle_areas(mesh)
    outline = shoelace(xy)
    assert len(mesh.faces) == k - 2
    assert np.linalg.norm(areas, axis=1).sum() == pytest.approx(outline, rel=1e-9)
    np.testing.assert_allclose(areas.sum(axis=0), rot @ [0, 0, outline], atol=1e-9)


def test_files_of_convex_polygons_load_bit_for_bit_as_trimesh_splits_them(tmp_path):
    # Quads, a convex hexagon, a square with a straight (collinear) vertex on one side: fans all.
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    hexagon = [(np.cos(a) + 3, np.sin(a)) for a in np.linspace(0, 2 * np.pi, 7)[:-1]]
    straight = [(5, 0), (6, 0), (7, 0), (7, 1), (5, 1)]
    pts = placed(square + hexagon + straight, np.eye(3), 0)
    for faces in ([[0, 1, 2, 3]], [[0, 1, 2, 3], list(range(4, 10)), list(range(10, 15))]):
        path = tmp_path / f"convex{len(faces)}.obj"
        path.write_text(obj_text(pts, faces))
        assert ear_clip_obj(path.read_bytes(), path.name) is None
        mine = rs.Mesh.load(path)
        theirs = trimesh.load(path, process=False)
        np.testing.assert_array_equal(mine.faces, theirs.faces)
        np.testing.assert_array_equal(mine.vertices, theirs.vertices)


def test_convex_faces_next_to_a_concave_one_keep_their_triangles(tmp_path):
    square = placed([(5, 0), (6, 0), (6, 1), (5, 1)], np.eye(3), 0)
    pts = np.r_[placed(L_SHAPE, np.eye(3), 0), square]
    text = obj_text(pts, [[6, 7, 8, 9], [2, 3, 4, 5, 0, 1], [7, 8, 9, 6]])
    mesh, _ = load(tmp_path, text)
    fan = trimesh.load(tmp_path / "poly.obj", process=False)
    tri = {tuple(sorted(map(tuple, t))) for t in mesh.vertices[mesh.faces] if t[:, 0].min() >= 5}
    want = {tuple(sorted(map(tuple, t))) for t in fan.vertices[fan.faces] if t[:, 0].min() >= 5}
    assert tri == want and len(tri) == 4


@pytest.mark.parametrize("face, points, why", [
    ([0, 1, 2, 3], [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)], "no area"),
    ([0, 1, 1, 2], [(0, 0, 0), (1, 0, 0), (1, 1, 0)], "a vertex repeated next to itself"),
    ([0, 1, 2, 3], [(0, 0, 0), (1, 0, 0), (1, 1, 0.5), (0, 1, 0)], "not planar"),
    ([0, 1, 2, 3, 4], [(0, 0, 0), (2, 2, 0), (2, 0, 0), (0, 2, 0), (1, 3, 0)], "crosses itself"),
])
def test_degenerate_polygons_are_warned_naming_the_file_and_line(tmp_path, face, points, why):
    text = "# a comment\n" + obj_text(points, [[0, 1, 2] if len(points) == 3 else [0, 1, 2], face])
    mesh, warned = load(tmp_path, text, "degenerate.obj")
    line = 2 + len(points) + 1  # the comment, the vertices, the first face, then this one
    assert len(warned) == 1 and f"degenerate.obj: 1 degenerate polygon(s)" in warned[0], warned
    assert f"line {line} ({why}" in warned[0], warned
    assert len(mesh.faces) >= 2
