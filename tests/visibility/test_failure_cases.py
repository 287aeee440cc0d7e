"""Where finding the hits could fail: cases 6 (slivers), 9 (rays through exact
vertices and edges) and 10 (far from the origin) of the catalogue of
``docs/failure-cases.md`` (the other cases: ``tests/shading/test_failure_cases.py``).

A bug this catalogue found is fixed: rays through shared vertices could slip
between triangles (case 9, :mod:`raycast_shade.visibility.cast`). The scenes come
from :mod:`raycast_shade.study.failure_scenes`; every test keeps its case number
in its name.
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study import failure_scenes as fs
from raycast_shade.study.reference import hit_points
from raycast_shade.study.twins import isolated_misses_numpy

from tests.conftest import assert_sane, camera_rays, plane_hits, render_all


# ==========================================================================================
# 6. Sliver triangles
# ==========================================================================================
def test_6_slivers_are_hit_and_shaded_like_any_triangle():
    """A square as 2000 slivers (smallest corner angle 0.014 degrees, aspect
    ~1e-3) against the same square as an 8 x 8 grid: no pixel changes
    coverage and the normals are the same. Phong evaluates at the hit point
    rebuilt from Embree's float32 barycentrics, whose error grows with the
    aspect ratio (about eps32 x length / width): measured max position error
    2.1e-7 (grid), 4.1e-5 (200 slivers), 2.9e-4 (2000), 2.7e-3 (20000),
    while o + t d stays within 5.5e-7; the Phong image differs by 3.6e-6,
    3.2e-5 and 3.7e-4. Flat and Gouraud evaluate at centroids and at corners
    up to 2.8 apart, and under a near point light they show it: max
    difference 0.68 (flat) and 0.58 (Gouraud), the methods' sampling."""
    grid = rs.Mesh(rs.shapes.plane(size=2.0, subdivisions=8).vertices, rs.shapes.plane(size=2.0, subdivisions=8).faces)
    fan = fs.sliver_fan(2000)
    p = fan.vertices[fan.faces]
    ang = [np.degrees(np.arctan2(np.linalg.norm(np.cross(p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]), axis=1),
                                 fs.dot(p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]))) for k in range(3)]
    assert min(a.min() for a in ang) < 0.02
    a = render_all(fs.lamp_scene(grid))
    b = render_all(fs.lamp_scene(fan))
    for shading in rs.SHADINGS:
        assert_sane(b[shading])
        np.testing.assert_array_equal(a[shading].mask, b[shading].mask)
        np.testing.assert_allclose(b[shading].normal, a[shading].normal, atol=1e-6)
    np.testing.assert_allclose(b["phong"].image, a["phong"].image, rtol=0, atol=1e-4)
    exact_p, _ = plane_hits(fs.LAMP_CAMERA)
    p_bary = hit_points(b["phong"].scene, b["phong"].hits)
    o, d = camera_rays(fs.LAMP_CAMERA)
    p_ray = o + b["phong"].hits.t[..., None].astype(np.float64) * d
    m = b["phong"].mask
    assert np.linalg.norm(p_bary - exact_p, axis=-1)[m].max() < 1e-3
    assert np.linalg.norm(p_ray - exact_p, axis=-1)[m].max() < 2e-6
    assert np.abs(b["flat"].image - a["flat"].image).max() > 0.1
    assert np.abs(b["gouraud"].image - a["gouraud"].image).max() > 0.1



# ==========================================================================================
# 9. Rays through exact vertices and edges; rays from inside a closed mesh
# ==========================================================================================
@pytest.mark.parametrize("step", [1, 2, 3])
@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.5, 0.5), (1 / 3, 1 / 7)])
def test_9_no_holes_where_rays_pass_exactly_through_vertices_and_edges(step, offset):
    """A flat grid whose vertices sit exactly on pixel centres every ``step``
    pixels (so with step 2 the edge midpoints are pixel centres too, and the
    alternating diagonals pass through them), under an orthographic eye with
    a power-of-two pixel pitch: every ray meets a vertex or an edge shared by
    up to eight triangles. Counted misses: 0 of 12288, for every step and
    offset (Embree's robust, watertight intersector)."""
    frame = rs.render(fs.pixel_grid_scene(step, offset), "flat")
    assert (~frame.mask).sum() == 0


@pytest.mark.parametrize("step", [1, 2, 3])
@pytest.mark.parametrize("caster", ["embree", "embreex"])
@pytest.mark.parametrize("eye, fov", [((0.3, -1.2, 2.5), 50.0), ((3.0, -40.0, 50.0), 2.0)], ids=["near", "far"])
def test_9_no_holes_in_a_grid_of_perspective_rays(step, caster, eye, fov):
    """The same under a perspective eye, the hard case: the vertices of a grid
    in z = 0 are put where the pixel rays meet the plane, so each ray passes
    (to rounding) through a vertex or an edge. Embree's robust mode alone
    leaves holes at vertices (measured misses with step 1 / 2 / 3 pixels:
    55 / 8 / 4 of 12288, and 136 with a distant narrow-angle eye); the
    caster re-casts such isolated misses (raycast_shade.visibility.cast): 0 misses."""
    cam = fs.pixel_ray_camera(eye, fov)
    grid = fs.grid_at_pixel_rays(cam, step)
    frame = rs.render(fs.scene(grid, [rs.DirectionalLight((0.0, 0.0, -1.0))], cam), "flat", caster=caster)
    assert (~frame.mask).sum() == 0


def test_9_hole_filling_moves_nothing_else():
    """The re-cast touches only misses between hits, by at most 1e-2 pixel:
    a pixel-wide gap between two squares stays open (its rays pass 0.5 pixel
    from either square), a real pinhole in a mesh (a missing face) stays a
    hole, and every other pixel is the plain packet cast's."""
    w, h, pitch = 64, 48, 1.0 / 16.0
    left = rs.shapes.plane(size=1.0, center=(-0.5, 0.0, 0.0))  # up to x = 0
    right = rs.shapes.plane(size=1.0, center=(0.5 + pitch, 0.0, 0.0))  # from x = one pixel

    cam = rs.Camera(eye=(0.0, 0.0, 3.0), width=w, height=h, projection="orthographic", ortho_height=h * pitch)
    scene = fs.scene([rs.Model(left), rs.Model(right)], [rs.DirectionalLight((0.0, 0.0, -1.0))], cam)
    hits = rs.cast_camera(scene.geometry, cam)
    gap = ~hits.mask[18:30, 32]  # the column between the squares: centres at x = pitch / 2
    assert gap.all() and hits.mask[18:30, 31].all() and hits.mask[18:30, 33].all()
    assert isolated_misses_numpy(hits.prim)[18:30, 32].all()  # candidates, re-cast, still misses
    # A grid with one cell's two faces removed: a real hole of 4 x 4 pixels; it stays.
    xs = (np.arange(-2, w + 6, 4) - w / 2) * pitch
    ys = (np.arange(-2, h + 6, 4) - h / 2) * pitch
    grid = fs.grid_mesh(xs, ys)
    holed = rs.Mesh(grid.vertices, np.delete(grid.faces, [40, 40 + len(grid.faces) // 2], axis=0))
    a = rs.cast_camera(fs.scene(grid, camera=cam).geometry, cam)
    b = rs.cast_camera(fs.scene(holed, camera=cam).geometry, cam)
    assert a.mask.all() and (~b.mask).sum() == 16
    np.testing.assert_allclose(a.t[b.mask], b.t[b.mask], rtol=1e-6)


@pytest.mark.parametrize("mesh", [rs.shapes.icosphere(0), rs.shapes.icosphere(3), rs.shapes.uv_sphere(16, 32)],
                         ids=["icosphere0", "icosphere3", "uv_sphere16x32"])
def test_9_no_holes_from_inside_a_closed_sphere(mesh):
    """The eye at the centre of a closed sphere, looking at vertices (with an
    odd image, the centre pixel's ray passes exactly through the vertex;
    the uv sphere's poles join 32 triangles): every ray must hit. 0 misses
    of 3185 per view, 24 or 26 views per mesh (12 or 13 vertices,
    perspective with a 150 degree field and orthographic)."""
    misses = 0
    cameras = fs.inside_cameras(mesh)
    assert len(cameras) >= 24
    for cam in cameras:
        frame = rs.render(fs.scene(mesh, [rs.DirectionalLight((0.0, 0.0, -1.0))], cam), "flat")
        misses += int((~frame.mask).sum())
        assert frame.hits.t[frame.mask].min() > 0.5 * 0.79  # the icosahedron's inradius is 0.79
    assert misses == 0



# ==========================================================================================
# 10. The same scene far from the origin
# ==========================================================================================
@pytest.mark.parametrize("shift, tol", [(1e3, 1e-6), (1e5, 1e-6), (1e7, 1e-5)])
def test_10_translated_scene_renders_the_same(shift, tol):
    """Three models with shadows from two lights, moved by shift * (1, -0.7,
    0.4). The scene is re-centred in float64 before Embree's float32 and the
    shadow offsets scale with the scene, so no pixel changes triangle and
    the images agree to the stated tolerance: 1e-6 up to 1e5, 1e-5 at 1e7
    (measured max difference: 0 at 1e3 and 1e5, 1.0e-6 at 1e7). Without
    re-centring, the float32 vertices alone would move by up to 2^-7 at 1e5:
    measured image RMSE 0.012, max 0.56 (docs/figures/failure_cases.py)."""
    base = fs.far_scene((0.0, 0.0, 0.0))
    moved = fs.far_scene(shift * np.array([1.0, -0.7, 0.4]))
    for shading in rs.SHADINGS:
        a = rs.render(base, shading)
        b = rs.render(moved, shading)
        assert_sane(b)
        np.testing.assert_array_equal(a.hits.prim, b.hits.prim)
        np.testing.assert_array_equal(a.hits.geom, b.hits.geom)
        np.testing.assert_allclose(b.image, a.image, rtol=0, atol=tol)
        np.testing.assert_allclose(b.hits.t[a.mask], a.hits.t[a.mask], rtol=1e-5)
    assert a.image.max() > 0.5 and (a.image[a.mask] < 0.06).mean() > 0.05  # lit, with shadows

