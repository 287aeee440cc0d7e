"""Where averaged vertex normals fail: cases 5 and 6 (zero-area faces, duplicate
vertices, inconsistent winding with computed normals) of the catalogue of
``docs/failure-cases.md`` (the other cases: ``tests/shading/test_failure_cases.py``).

The scenes come from :mod:`raycast_shade.study.failure_scenes`; every test keeps
its case number in its name.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study import failure_scenes as fs
from raycast_shade.study.metrics import normal_angles, rmse

from tests.conftest import assert_sane, render_all


# ==========================================================================================
# 5. Averaged normals across hard creases: a cube turns into a blob
# ==========================================================================================
def test_5_a_cube_becomes_a_blob_when_the_crease_angle_reaches_its_edges():
    """The cube's faces meet at 90 degrees. With a crease angle below that,
    every corner keeps its face's normal, and Gouraud and Phong reproduce the
    flat image, exact here (orthographic eye, directional light): measured
    difference 0. Above it, the corners average three faces into the cube's
    diagonal: a blob, measured RMSE against the flat image 0.175 (Gouraud),
    0.188 (Phong), mean normal error 36 degrees. At exactly 90 degrees the
    decision is rounding's (cos 90 deg = 6e-17 > 0): the cube stays a cube."""
    flat = rs.render(fs.cube_scene(30.0), "flat")
    for crease in (30.0, 60.0, 89.0):
        scene = fs.cube_scene(crease)
        assert len(scene.geometry.vertices) == 24
        for shading in ("gouraud", "phong"):
            frame = rs.render(scene, shading)
            np.testing.assert_allclose(frame.image, flat.image, rtol=2e-6, atol=1e-7)
    for crease in (91.0, 120.0, 180.0, None):
        scene = fs.cube_scene(crease)
        assert len(scene.geometry.vertices) == 8
        for shading in ("gouraud", "phong"):
            frame = rs.render(scene, shading)
            assert_sane(frame)
            both = flat.mask & frame.mask
            assert rmse(flat.image, frame.image, both) > 0.1
            assert normal_angles(flat.normal, frame.normal, both).mean() > 25.0


def test_5_the_crease_angle_trades_facets_against_blobs():
    """A 16-sided cylinder (side faces 22.5 degrees apart, rims at 90): a
    crease below 22.5 degrees facets the side, one above 90 rounds the rims,
    one between gets both right. Mean normal error against the ideal
    cylinder, caps / side, degrees (measured): crease 15 -> 0 / 5.7,
    60 -> 0 / 5e-7, 120 -> 32.3 / 23.4."""
    errors = {}
    for crease in (15.0, 60.0, 120.0):
        scene = fs.cylinder_scene(crease)
        frame = rs.render(scene, "phong")
        assert_sane(frame)
        raw, g, v, p = fs.raw_normals(scene, frame)
        ideal = fs.ideal_cylinder_normals(p)
        ideal *= np.where(fs.dot(ideal, g) < 0, -1.0, 1.0)[:, None]  # the face's side, as the rule
        cap = np.abs(ideal[:, 1]) > 0.5
        n = frame.normal[frame.mask].astype(np.float64)
        errors[crease] = (normal_angles(ideal[cap], n[cap]).mean(), normal_angles(ideal[~cap], n[~cap]).mean())
    assert errors[15.0][0] < 0.01 and errors[15.0][1] > 2.0  # sharp rims, faceted side
    assert errors[60.0][0] < 0.01 and errors[60.0][1] < 0.5  # both right
    assert errors[120.0][0] > 5.0 and errors[120.0][1] > 5.0  # rounded rims



# ==========================================================================================
# 6. Zero-area faces, duplicate vertices, inconsistent winding with computed normals
# ==========================================================================================
def test_6_zero_area_faces_change_nothing():
    """Zero-area faces (a repeated index, three collinear points, three
    coincident points, a vertex used by nothing else) carry no normal, are
    left out of every average, and are never hit: the image is the clean
    mesh's, in every mode (measured difference 0)."""
    for clean in (rs.shapes.plane(size=2.0, subdivisions=8), rs.shapes.icosphere(2, radius=0.9)):
        v, f = clean.vertices, clean.faces
        nv = len(v)
        extra = np.array([[0.1, 0.1, 0.9], [0.1, 0.1, 0.9], [0.3, 0.3, 0.9], [0.5, 0.5, 0.9], v[3], v[3]])
        dirty_f = np.vstack([f, [[0, 0, 1], [nv, nv + 1, nv + 2], [nv, nv + 2, nv + 3], [5, 5, 5],
                                 [nv + 4, nv + 5, 3], [f[0, 0], f[0, 1], f[0, 0]]]])
        dirty = rs.Mesh(np.vstack([v, extra]), dirty_f)
        a = render_all(fs.lamp_scene(rs.Mesh(v, f)))
        b = render_all(fs.lamp_scene(dirty))
        for shading in rs.SHADINGS:
            assert_sane(b[shading])
            np.testing.assert_array_equal(a[shading].mask, b[shading].mask)
            assert (b[shading].hits.prim < len(f)).all()
            np.testing.assert_allclose(b[shading].image, a[shading].image, rtol=1e-6, atol=1e-7)


def test_6_duplicate_vertices_split_the_average_like_a_crease():
    """An unwelded mesh (every face with its own three vertices, as STL files
    store them): each vertex averages one face, so computed normals are the
    face normals and Gouraud and Phong shade facets (normal buffer = flat's).
    The project does not weld; welding first (trimesh's merge_vertices)
    gives back the smooth image. A double-sided sheet (every face repeated
    with the opposite winding) averages to zero normals, which fall back to
    the face normal: it renders as the one-sided sheet, with a WindingWarning."""
    import trimesh

    ico = rs.shapes.icosphere(2, radius=0.9)
    soup_v = ico.vertices[ico.faces].reshape(-1, 3)
    soup = rs.Mesh(soup_v, np.arange(len(soup_v)).reshape(-1, 3))
    welded = rs.Mesh(ico.vertices, ico.faces)
    s = render_all(fs.lamp_scene(soup))
    for shading in ("gouraud", "phong"):
        assert_sane(s[shading])
        np.testing.assert_allclose(s[shading].normal, s["flat"].normal, atol=1e-6)
    tm = trimesh.Trimesh(soup_v, np.arange(len(soup_v)).reshape(-1, 3), process=False)
    tm.merge_vertices()
    assert len(tm.vertices) == len(ico.vertices)
    w = rs.render(fs.lamp_scene(welded), "phong")
    m = rs.render(fs.lamp_scene(rs.Mesh(tm.vertices, tm.faces)), "phong")
    np.testing.assert_allclose(m.image, w.image, rtol=1e-5, atol=1e-6)
    assert np.abs(s["phong"].image - w.image).max() > 0.05
    # Double-sided sheet.
    plane = rs.shapes.plane(size=2.0, subdivisions=4)
    sheet = rs.Mesh(plane.vertices, np.vstack([plane.faces, plane.faces[:, ::-1]]))
    # Four faces to an edge: no winding conflict, but the reversed duplicates are named.
    with pytest.warns(rs.WindingWarning, match=f"{len(plane.faces)} face\\(s\\) repeat another face with the opposite"):
        assert (sheet.prepared.normals == 0).all()
    one = render_all(fs.lamp_scene(rs.Mesh(plane.vertices, plane.faces)))
    two = render_all(fs.lamp_scene(sheet))
    for shading in rs.SHADINGS:
        assert_sane(two[shading])
        np.testing.assert_allclose(two[shading].image, one[shading].image, rtol=1e-5, atol=1e-6)


def test_6_inconsistent_winding_with_computed_normals_needs_repair():
    """30% of an icosphere's faces wound the wrong way. Flat shading is
    two-sided and does not care (identical image). Computed vertex normals
    are plain averages of the right-hand face normals (the documented
    definition), so at a vertex where windings disagree they cancel: Phong
    and Gouraud stay finite but are wrong (measured RMSE against the exact
    sphere: Phong 0.141 vs 0.0030 consistent, Gouraud 0.100 vs 0.0114; normal
    error p95 69 degrees). The remedy is to fix the winding before building
    the Mesh (trimesh.repair.fix_winding), which restores the image. The
    Mesh says so: a WindingWarning when its normals are computed."""
    import trimesh

    ico, bad, _ = fs.flipped_sphere()
    good = render_all(fs.sphere_scene(rs.Mesh(ico.vertices, ico.faces)))
    with pytest.warns(rs.WindingWarning, match="trimesh.repair.fix_winding"):
        bad.prepared  # noqa: B018
    broken = render_all(fs.sphere_scene(bad))
    np.testing.assert_allclose(broken["flat"].image, good["flat"].image, rtol=1e-6, atol=1e-7)
    for shading in rs.SHADINGS:
        assert_sane(broken[shading])
    tm = trimesh.Trimesh(bad.vertices, bad.faces, process=False)
    assert not tm.is_winding_consistent
    trimesh.repair.fix_winding(tm)
    assert tm.is_winding_consistent
    fixed = render_all(fs.sphere_scene(rs.Mesh(tm.vertices, tm.faces)))
    for shading in rs.SHADINGS:
        np.testing.assert_allclose(fixed[shading].image, good[shading].image, rtol=1e-5, atol=1e-5)

