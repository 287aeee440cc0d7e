"""Face normals, averaged vertex normals (uniform / area / angle) and crease splitting."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.scene.normals import face_normals, vertex_normals

SQ3 = 1.0 / np.sqrt(3.0)


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def brute_force_normals(vertices, faces, weighting, cancelled=False):
    """Vertex normals by explicit loops over faces (no crease), an independent twin.

    With ``cancelled``, also a mask of the vertices whose weighted sum (nearly)
    cancels, e.g. a face and its reverse: there the direction is rounding
    noise, which the twin and the kernel need not share.
    """
    out = np.zeros_like(vertices, dtype=float)
    wsum = np.zeros(len(vertices))
    for f in faces:
        p = vertices[f]
        cross = np.cross(p[1] - p[0], p[2] - p[0])
        area2 = np.linalg.norm(cross)
        if area2 == 0:
            continue
        n = cross / area2
        for k in range(3):
            if weighting == "uniform":
                w = 1.0
            elif weighting == "area":
                w = area2 / 2
            else:
                a = p[(k + 1) % 3] - p[k]
                b = p[(k + 2) % 3] - p[k]
                w = np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))
            out[f[k]] += w * n
            wsum[f[k]] += w
    length = np.linalg.norm(out, axis=1, keepdims=True)
    normals = np.divide(out, length, out=np.zeros_like(out), where=length > 0)
    return (normals, length[:, 0] <= 1e-9 * wsum) if cancelled else normals


# Two triangles at the origin: A in z = 0 (area 2, 45 degrees at the origin),
# B in x = 0 (area 1/2, 90 degrees at the origin).
TENT_V = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 1, 0], [0, 0, 1]], float)
TENT_F = np.array([[0, 1, 2], [0, 3, 4]])


@pytest.mark.parametrize("weighting, expected", [
    ("uniform", _unit([1, 0, 1])),          # normals +z and +x, equal weight
    ("area", _unit([0.5, 0, 2])),           # weights 1/2 (B) and 2 (A)
    ("angle", _unit([np.pi / 2, 0, np.pi / 4])),  # weights 90 (B) and 45 (A) degrees
])
def test_weightings_on_a_known_vertex(weighting, expected):
    fn, areas = face_normals(TENT_V, TENT_F)
    np.testing.assert_allclose(fn, [[0, 0, 1], [1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(areas, [2.0, 0.5])
    _, _, n, _ = vertex_normals(TENT_V, TENT_F, weighting)
    np.testing.assert_allclose(n[0], expected, atol=1e-12)
    # Vertices of one face only take that face's normal.
    np.testing.assert_allclose(n[1:3], [[0, 0, 1]] * 2, atol=1e-15)
    np.testing.assert_allclose(n[3:5], [[1, 0, 0]] * 2, atol=1e-15)


def test_angle_weighting_gives_cube_corners_the_diagonal():
    """Each corner of a triangulated cube meets three quads; whatever the
    split, the angles per quad sum to 90 degrees, so the angle-weighted normal
    is (+-1, +-1, +-1) / sqrt 3. Counting triangles (uniform, area) is biased by
    the triangulation."""
    cube = rs.shapes.cube(crease_angle=None)
    v = cube.vertices
    _, _, n, _ = vertex_normals(v, cube.faces, "angle")
    np.testing.assert_allclose(n, np.sign(v) * SQ3, atol=1e-12)
    for weighting in ("uniform", "area"):
        _, _, nu, _ = vertex_normals(v, cube.faces, weighting)
        assert np.abs(nu - np.sign(v) * SQ3).max() > 0.1
        np.testing.assert_allclose(nu, brute_force_normals(v, cube.faces, weighting), atol=1e-12)
    # The mesh's prepared normals use the same code path.
    np.testing.assert_allclose(cube.prepared.normals, n, atol=1e-15)


@pytest.mark.parametrize("weighting", ["uniform", "area", "angle"])
def test_weightings_match_brute_force_on_a_torus(weighting):
    t = rs.shapes.torus(1.0, 0.4, 12, 7)
    _, _, n, _ = vertex_normals(t.vertices, t.faces, weighting)
    np.testing.assert_allclose(n, brute_force_normals(t.vertices, t.faces, weighting), atol=1e-12)
    # Close to the exact normals of the torus, away from its (unwelded) seams.
    interior = np.all((t.uvs > 0) & (t.uvs < 1), axis=1)
    assert interior.sum() == 11 * 6
    assert np.einsum("ij,ij->i", n, t.normals)[interior].min() > 0.97


@pytest.mark.parametrize("weighting", ["uniform", "area", "angle"])
@pytest.mark.parametrize("crease", [None, 30.0])
def test_zero_area_faces_do_not_poison_the_average(weighting, crease):
    """Degenerate faces (repeated index, collinear corners) add nothing: every
    real face sees the same corner normals as without them, all finite."""
    cube = rs.shapes.cube(crease_angle=None)
    v = np.vstack([cube.vertices, 0.5 * (cube.vertices[0] + cube.vertices[1])])  # vertex 8: midpoint of an edge
    clean = cube.faces
    dirty = np.vstack([clean, [[0, 0, 7], [3, 5, 3], [0, 8, 1], [1, 8, 0]]])
    fn, areas = face_normals(v, dirty)
    assert (fn[12:] == 0).all() and (areas[12:] == 0).all()
    vc, fc, nc, _ = vertex_normals(v[:8], clean, weighting, crease)
    vd, fd, nd, _ = vertex_normals(v, dirty, weighting, crease)
    assert np.isfinite(nd).all()
    # Corner normals of the twelve real faces, and their positions, unchanged.
    np.testing.assert_allclose(nd[fd[:12]], nc[fc], atol=1e-12)
    np.testing.assert_array_equal(vd[fd[:12]], vc[fc])
    if crease is None:
        np.testing.assert_allclose(nd[:8], nc, atol=1e-12)
        np.testing.assert_array_equal(nd[8], 0.0)  # only on zero-area faces: no normal at all
    # A Mesh built with them renders finite.
    mesh = rs.Mesh(v, dirty, weighting=weighting, crease_angle=crease)
    cam = rs.Camera(eye=(2.0, 1.5, 2.5), width=24, height=18)
    scene = rs.Scene([mesh], lights=[rs.PointLight((1, 2, 3), 5.0, attenuation="inverse_square")], camera=cam)
    for shading in rs.SHADINGS:
        img = rs.render(scene, shading).image
        assert np.isfinite(img).all() and img.min() >= 0 and img.max() > 0.2


def test_crease_splits_the_cube_into_24_vertices():
    cube = rs.shapes.cube()  # crease 30
    prep = cube.prepared
    assert len(cube.vertices) == 8
    assert len(prep.vertices) == 24 and len(prep.faces) == 12
    # Every corner normal is its own face's normal (hard edges), and axis-aligned.
    np.testing.assert_allclose(prep.normals[prep.faces], np.repeat(prep.face_normals[:, None], 3, 1), atol=1e-12)
    assert np.all(np.sort(np.abs(prep.normals), axis=1)[:, :2] == 0)
    # Positions are copies of the original corners, and every face keeps its corners.
    np.testing.assert_array_equal(prep.vertices[prep.faces], cube.vertices[cube.faces])
    # Without the crease, nothing is split.
    assert len(rs.shapes.cube(crease_angle=None).prepared.vertices) == 8
    # Faces at exactly the crease angle share a normal ("split where they differ by
    # more"): at 90 degrees the cube's faces all meet within it, just above they split.
    assert len(rs.shapes.cube(crease_angle=90.0).prepared.vertices) == 8
    assert len(rs.shapes.cube(crease_angle=89.999).prepared.vertices) == 24


def test_crease_keeps_a_cylinder_side_smooth_and_its_rims_sharp():
    """trimesh's 32-segment cylinder: 2 cap centres + 2 x 32 rim vertices; each
    rim vertex splits into a cap copy and a side copy: 130 vertices."""
    cyl = rs.shapes.cylinder(segments=32)
    prep = cyl.prepared
    assert len(cyl.vertices) == 66
    assert len(prep.vertices) == 2 + 2 * 32 * 2
    n = prep.normals
    cap = np.abs(np.abs(n[:, 1]) - 1) < 1e-12
    side = np.abs(n[:, 1]) < 1e-12
    assert cap.sum() == 2 + 2 * 32 and side.sum() == 2 * 32
    radial = prep.vertices[side][:, [0, 2]]
    np.testing.assert_allclose(n[side][:, [0, 2]], radial / np.linalg.norm(radial, axis=1, keepdims=True), atol=1e-12)


@pytest.mark.parametrize("fold_degrees", [20.0, 40.0, 100.0])
def test_crease_threshold_on_a_folded_pair(fold_degrees):
    """Two triangles sharing an edge, their normals fold_degrees apart: the
    shared edge's vertices are split exactly when the crease angle is smaller."""
    a = np.radians(fold_degrees)
    v = np.array([[0, 0, 0], [1, 0, 0], [0.5, -1, 0], [0.5, np.cos(a), np.sin(a)]], float)
    f = np.array([[0, 1, 3], [1, 0, 2]])
    fn, _ = face_normals(v, f)
    np.testing.assert_allclose(np.degrees(np.arccos(fn[0] @ fn[1])), fold_degrees, atol=1e-9)
    merged = vertex_normals(v, f, "angle", fold_degrees + 1.0)
    split = vertex_normals(v, f, "angle", fold_degrees - 1.0)
    assert len(merged[0]) == 4 and len(split[0]) == 6
    np.testing.assert_allclose(merged[2][0], _unit(fn[0] + fn[1]), atol=1e-12)
    np.testing.assert_allclose(split[2][split[1][0]], [fn[0]] * 3, atol=1e-12)
    np.testing.assert_allclose(split[2][split[1][1]], [fn[1]] * 3, atol=1e-12)


def test_face_normals_right_hand_rule_and_degenerate_zero():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 1], [0, 1, 3], [0, 0, 2]])
    n, area = face_normals(v, f)
    np.testing.assert_array_equal(n, [[0, 0, 1], [0, 0, -1], [0, 0, 0], [0, 0, 0]])
    np.testing.assert_allclose(area, [0.5, 0.5, 0, 0])


def test_given_normals_are_normalised_and_zero_kept():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    normals = np.array([[0, 0, 2.0], [0, 3.0, 4.0], [0, 0, 0]])
    prep = rs.Mesh(v, [[0, 1, 2]], normals=normals, crease_angle=10.0).prepared
    np.testing.assert_allclose(prep.normals, [[0, 0, 1], [0, 0.6, 0.8], [0, 0, 0]])
    assert len(prep.vertices) == 3  # given normals: the crease is ignored


@pytest.mark.parametrize("mesh", [rs.shapes.icosphere(2, radius=2.0, center=(1, 2, 3)),
                                  rs.shapes.uv_sphere(6, 10, radius=2.0, center=(1, 2, 3)),
                                  rs.shapes.torus(1.0, 0.3, 10, 6)], ids=["icosphere", "uv_sphere", "torus"])
def test_procedural_shapes_have_exact_outward_normals(mesh):
    prep = mesh.prepared
    np.testing.assert_allclose(np.linalg.norm(prep.normals, axis=1), 1.0, atol=1e-12)
    # Faces wound counter-clockwise from outside: face normal agrees with the vertex normals.
    corner_mean = prep.normals[prep.faces].mean(axis=1)
    assert np.einsum("ij,ij->i", prep.face_normals, corner_mean).min() > 0.8
    if mesh.name.startswith(("icosphere", "uv_sphere")):
        np.testing.assert_allclose(prep.normals, (prep.vertices - (1, 2, 3)) / 2.0, atol=1e-12)


def test_uvs_follow_split_vertices():
    cube = rs.shapes.cube(crease_angle=None)
    uvs = np.arange(16, dtype=float).reshape(8, 2)
    mesh = rs.Mesh(cube.vertices, cube.faces, uvs=uvs, crease_angle=30.0)
    prep = mesh.prepared
    assert len(prep.uvs) == 24
    # Every split copy carries its source vertex's UV.
    src = [int(np.flatnonzero((cube.vertices == p).all(1))[0]) for p in prep.vertices]
    np.testing.assert_array_equal(prep.uvs, uvs[src])


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), nv=st.integers(3, 12), nf=st.integers(1, 20),
       weighting=st.sampled_from(["uniform", "area", "angle"]),
       crease=st.one_of(st.none(), st.floats(1.0, 180.0)))
@example(seed=1699, nv=4, nf=3, weighting="angle", crease=None)  # a face and its reverse cancel at 2 vertices
def test_vertex_normals_random_meshes(seed, nv, nf, weighting, crease):
    """Any mesh (degenerate faces and repeated indices included): normals are
    unit or zero, split vertices copy their sources, faces keep their corners."""
    rng = np.random.default_rng(seed)
    v = rng.integers(-3, 4, size=(nv, 3)).astype(float)  # small integer grid: many degeneracies
    f = rng.integers(0, nv, size=(nf, 3))
    vs, fs, n, source = vertex_normals(v, f, weighting, crease)
    assert np.isfinite(n).all()
    length = np.linalg.norm(n, axis=1)
    assert np.all((np.abs(length - 1) < 1e-12) | (length == 0))
    np.testing.assert_array_equal(vs, v[source])
    np.testing.assert_array_equal(source[fs], f)
    if crease is None:
        want, cancelled = brute_force_normals(v, f, weighting, cancelled=True)
        np.testing.assert_allclose(n[~cancelled], want[~cancelled], atol=1e-9)
    elif crease < 90.0:
        # Below 90 degrees a real face's corners average only faces leaning its
        # way, so their normals never point against it.
        fn, _ = face_normals(v, f)
        good = np.any(fn != 0, axis=1)
        assert (np.einsum("ijk,ik->ij", n[fs[good]], fn[good]) > 0).all()


# -- winding consistency ----------------------------------------------------------------------------
def _expected_conflicts(faces, flipped):
    """Edges whose two faces disagree on being flipped (closed surface: two faces per edge)."""
    edges = np.sort(np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1), axis=2).reshape(-1, 2)
    owner = np.repeat(np.arange(len(faces)), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    pairs = owner[order].reshape(-1, 2)  # each undirected edge twice, adjacent after the sort
    assert (edges[order][0::2] == edges[order][1::2]).all()
    return int((flipped[pairs[:, 0]] != flipped[pairs[:, 1]]).sum())


@pytest.mark.parametrize("fraction", [0.0, 0.05, 0.3, 1.0])
def test_winding_conflicts_counts_edges_between_flipped_and_kept_faces(fraction):
    ico = rs.shapes.icosphere(3)
    rng = np.random.default_rng(3)
    flipped = rng.random(len(ico.faces)) < fraction
    faces = ico.faces.copy()
    faces[flipped] = faces[flipped][:, ::-1]
    got = rs.winding_conflicts(ico.vertices, faces)
    assert got == _expected_conflicts(ico.faces, flipped)
    assert (got == 0) == (fraction in (0.0, 1.0))  # all flipped is consistent again


def test_built_in_shapes_are_consistently_wound():
    for mesh in (rs.shapes.cube(), rs.shapes.cylinder(), rs.shapes.icosphere(2), rs.shapes.plane(subdivisions=3),
                 rs.shapes.torus(), rs.shapes.uv_sphere()):
        assert rs.winding_conflicts(mesh.vertices, mesh.faces) == 0, mesh.name


def test_winding_conflicts_ignore_duplicates_and_zero_area_faces():
    plane = rs.shapes.plane(subdivisions=2)
    v, f = plane.vertices, plane.faces
    # An exact duplicate of a face and a zero-area face against the grain: no conflict.
    degenerate = np.array([[f[0, 1], f[0, 0], f[0, 1]]])
    assert rs.winding_conflicts(v, np.vstack([f, f[:1], degenerate])) == 0
    # One face turned over inside the grid: each of its 3 edges conflicts.
    g = f.copy()
    g[3] = g[3, ::-1]
    interior = _expected_conflicts_open(f, 3)
    assert interior == 3
    assert rs.winding_conflicts(v, g) == interior


def test_winding_conflicts_leave_non_manifold_edges_alone():
    """Three faces on one edge (a fin on a sheet): two of them must traverse it
    the same way whatever the winding, so it is not counted; the open edges
    around a conflicting pair still are."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]], float)
    fin = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])  # edge 0-1: 0->1 twice, 1->0 once
    assert rs.winding_conflicts(v, fin) == 0
    pair = np.array([[0, 1, 2], [0, 1, 3]])  # two faces, both 0 -> 1: one conflicting edge
    assert rs.winding_conflicts(v, pair) == 1
    assert rs.winding_conflicts(v, np.array([[0, 1, 2], [1, 0, 3]])) == 0


def _expected_conflicts_open(faces, face):
    """Edges face ``face`` shares with another face (open surface)."""
    e = {tuple(sorted((faces[face, k], faces[face, (k + 1) % 3]))) for k in range(3)}
    shared = 0
    for i in range(len(faces)):
        if i != face:
            shared += len(e & {tuple(sorted((faces[i, k], faces[i, (k + 1) % 3]))) for k in range(3)})
    return shared


def test_mesh_warns_about_inconsistent_winding_only_when_it_computes_normals():
    import warnings

    ico = rs.shapes.icosphere(2)
    faces = ico.faces.copy()
    faces[::7] = faces[::7, ::-1]
    with pytest.warns(rs.WindingWarning, match=r"bad: \d+ edge\(s\) join faces wound in opposite directions"):
        rs.Mesh(ico.vertices, faces, name="bad").prepared  # noqa: B018
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rs.Mesh(ico.vertices, faces, normals=ico.normals).prepared  # noqa: B018 - normals given: no average
        rs.Mesh(ico.vertices, ico.faces).prepared  # noqa: B018


def _random_mesh(seed, nv=60, nf=200):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(nv, 3))
    v[:5] = v[0]  # coincident points: zero-area faces
    v[5:10] = v[10] + np.outer(np.linspace(0, 1, 5), [1.0, 2.0, 3.0])  # collinear points
    f = rng.integers(0, nv, size=(nf, 3))
    f[:10, 2] = f[:10, 0]  # repeated indices
    return v, f


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("weighting", ["uniform", "area", "angle"])
def test_face_kernel_matches_numpy_twins(seed, weighting):
    from raycast_shade.scene.normals import _WEIGHT_CODE, _faces_kernel
    from raycast_shade.study.twins import corner_weights_numpy, face_normals_numpy

    v, f = _random_mesh(seed)
    fn, areas, w = _faces_kernel(v, f, _WEIGHT_CODE[weighting])
    fn_np, areas_np = face_normals_numpy(v, f)
    np.testing.assert_array_equal(fn == 0, fn_np == 0)  # the same faces are degenerate
    np.testing.assert_allclose(fn, fn_np, rtol=0, atol=1e-15)
    np.testing.assert_allclose(areas, areas_np, rtol=1e-15, atol=0)
    np.testing.assert_allclose(w, corner_weights_numpy(v, f, fn_np, areas_np, weighting), rtol=1e-14, atol=0)
    assert (fn == 0).all(axis=1).sum() >= 10


@pytest.mark.parametrize("seed", range(3))
def test_accumulated_normals_match_bincount(seed):
    from raycast_shade.scene.normals import _accumulate_kernel

    v, f = _random_mesh(seed)
    rng = np.random.default_rng(seed)
    fn, w = rng.normal(size=(len(f), 3)), rng.random((len(f), 3))
    want = np.zeros((len(v), 3))
    for k in range(3):  # np.bincount sums in input order: the kernel must too, bit for bit
        for c in range(3):
            want[:, c] += np.bincount(f[:, k], weights=fn[:, c] * w[:, k], minlength=len(v))
    np.testing.assert_array_equal(_accumulate_kernel(f, fn, w, len(v)), want)


def test_corners_by_vertex_is_a_stable_argsort():
    from raycast_shade.scene.normals import _corners_by_vertex

    v, f = _random_mesh(5, nv=40, nf=300)
    flat = f.ravel()
    order, starts, dest, third = _corners_by_vertex(f, 45)  # 5 unreferenced vertices at the end
    np.testing.assert_array_equal(order, np.argsort(flat, kind="stable"))
    np.testing.assert_array_equal(np.diff(starts), np.bincount(flat, minlength=45))
    assert starts[0] == 0 and starts[-1] == len(flat)
    face, k = np.divmod(order, 3)  # each corner's next and third vertex around its face
    np.testing.assert_array_equal(dest, f[face, (k + 1) % 3])
    np.testing.assert_array_equal(third, f[face, (k + 2) % 3])


@pytest.mark.parametrize("crease", [None, 30.0])
def test_prepared_face_normals_are_those_of_the_split_mesh(crease):
    """Mesh.prepared computes face normals once, before any split: they must be the split mesh's."""
    cube = rs.shapes.cube()
    p = rs.Mesh(cube.vertices, cube.faces, crease_angle=crease).prepared
    assert len(p.vertices) == (8 if crease is None else 24)
    np.testing.assert_array_equal(p.face_normals, face_normals(p.vertices, p.faces)[0])
