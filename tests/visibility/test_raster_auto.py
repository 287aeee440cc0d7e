"""render(backend="auto"): the rasterizer or Embree, by the measured crossover (issue 41, item 3).

The choice (:func:`choose_backend`) is checked on both sides of the threshold and on the frames
the rasterizer cannot draw; the image it gives must be exactly the chosen backend's; the
screen-box estimate of the covered pixels against closed forms and, as a bound, against the
rasterizer's own hit mask; the threshold in the code against the fit of the committed benchmark
CSV; and the command line and scene files accept the name.
"""

from __future__ import annotations

import csv
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.scene.scenefile import check_render_options
from raycast_shade.visibility.raster import AUTO_FACES_PER_PIXEL, choose_backend, covered_pixels, rasterize

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
W, H = 64, 48


def _scene(subdivisions, camera=None, **material):
    cam = camera or rs.Camera(eye=(0.3, 0.5, 3.0), target=(0.0, 0.0, 0.0), width=W, height=H, fov=45.0)
    return rs.Scene([rs.Model(rs.shapes.icosphere(subdivisions), rs.Material(**material))],
                    lights=[rs.PointLight((2.0, 3.0, 4.0))], camera=cam)


def _limit(scene):
    alpha, beta = AUTO_FACES_PER_PIXEL
    cam = scene.camera
    return alpha * cam.width * cam.height + beta * covered_pixels(scene.geometry, cam)


def test_auto_rasterizes_a_coarse_mesh_and_its_image_is_the_rasterizers():
    scene = _scene(1)  # 80 faces on a 64x48 frame
    assert len(scene.geometry.faces) <= _limit(scene)
    backend, reason = choose_backend(scene.geometry, scene.camera)
    assert backend == "raster" and "faces <=" in reason
    auto = rs.render(scene, "phong", backend="auto")
    chosen = rs.render(scene, "phong", backend="raster")
    assert "raster" in auto.timings and "cast" not in auto.timings
    np.testing.assert_array_equal(auto.image, chosen.image)
    np.testing.assert_array_equal(auto.hits.prim, chosen.hits.prim)


def test_auto_casts_a_dense_mesh_and_its_image_is_embrees():
    scene = _scene(4)  # 5,120 faces on 3,072 pixels
    assert len(scene.geometry.faces) > _limit(scene)
    assert choose_backend(scene.geometry, scene.camera)[0] == "raycast"
    auto = rs.render(scene, "phong", backend="AUTO")  # case-insensitive, as every choice
    chosen = rs.render(scene, "phong", backend="raycast")
    assert "cast" in auto.timings and "raster" not in auto.timings
    np.testing.assert_array_equal(auto.image, chosen.image)


def test_auto_is_deterministic_whatever_has_been_built():
    scene = _scene(3)
    first = choose_backend(scene.geometry, scene.camera)
    rs.render(scene, "flat", backend="raycast")  # builds the BVH
    rs.render(scene, "flat", backend="raster")
    assert choose_backend(scene.geometry, scene.camera) == first


def test_auto_casts_what_the_rasterizer_cannot_draw():
    lens = rs.Camera(eye=(0.3, 0.5, 3.0), target=(0.0, 0.0, 0.0), width=W, height=H, fov=45.0,
                     distortion=(0.1, 0.0, 0.0, 0.0))
    scene = _scene(0, camera=lens)
    backend, reason = choose_backend(scene.geometry, lens)
    assert backend == "raycast" and "distorted" in reason
    np.testing.assert_array_equal(rs.render(scene, "flat", backend="auto").image,
                                  rs.render(scene, "flat", backend="raycast").image)
    cov = np.ones((4, 4, 3))
    masked = _scene(0, alpha_map=rs.Texture(cov), alpha_cutoff=0.5)
    backend, reason = choose_backend(masked.geometry, masked.camera)
    assert backend == "raycast" and "alpha" in reason


def test_bad_backend_names_the_field():
    with pytest.raises(ValueError, match="backend"):
        rs.render(_scene(0), backend="fastest")


def test_covered_pixels_closed_forms():
    # Orthographic, looking down -z at the unit cube's bounding box [-1, 1]^3: a square of side
    # 2 / ortho_height * H pixels, centred.
    scene = _scene(0)
    cube = rs.Scene([rs.Model(rs.shapes.cube())], lights=[rs.PointLight((2.0, 3.0, 4.0))])
    lo, hi = cube.geometry.vertices.min(0), cube.geometry.vertices.max(0)
    side = float(hi[0] - lo[0])
    cam = rs.Camera(eye=(0.0, 0.0, 5.0), target=(0.0, 0.0, 0.0), width=W, height=H, projection="orthographic",
                    ortho_height=2.0 * side)
    assert covered_pixels(cube.geometry, cam) == round((side / (2.0 * side) * H) ** 2)
    # An eye inside the box: the whole image.
    inside = rs.Camera(eye=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), width=W, height=H)
    assert covered_pixels(scene.geometry, inside) == W * H
    # Looking away: the box behind the eye plane, nothing on screen.
    away = rs.Camera(eye=(0.0, 0.0, 5.0), target=(0.0, 0.0, 10.0), width=W, height=H)
    assert covered_pixels(scene.geometry, away) == 0
    far_side = rs.Camera(eye=(50.0, 0.0, 5.0), target=(50.0, 0.0, 0.0), width=W, height=H, fov=20.0)
    assert covered_pixels(scene.geometry, far_side) == 0


@settings(max_examples=25, deadline=None)
@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(1.8, 8.0), st.floats(-0.4, 0.4), st.floats(-0.3, 0.3))
def test_covered_pixels_bounds_the_rasterizers_hits(ex, ey, dist, tx, ty):
    # The bounding box holds every hit, so its screen box holds every covered pixel centre.
    d = np.array([ex, ey, 1.0])
    cam = rs.Camera(eye=tuple(dist * d / np.linalg.norm(d)), target=(tx, ty, 0.0), width=W, height=H, fov=45.0)
    scene = _scene(1, camera=cam)
    hit = int((rasterize(scene.geometry, cam).prim >= 0).sum())
    covered = covered_pixels(scene.geometry, cam)
    assert 0 <= covered <= W * H
    assert hit <= covered + W + H  # the box's border pixels, rounded


def test_threshold_is_the_committed_benchmarks_fit():
    from benchmarks.bench_raster import fitted_faces_per_pixel

    path = os.path.join(ROOT, "benchmarks", "results", "raster_crossover.csv")
    with open(path, newline="") as fh:
        rows = []
        for r in csv.DictReader(fh):
            rows.append(dict(width=int(r["width"]), height=int(r["height"]), distance=float(r["distance"]),
                             covered_pixels=int(r["covered_pixels"]),
                             crossover_triangles=float(r["crossover_triangles"]) if r["crossover_triangles"] else None))
    assert fitted_faces_per_pixel(rows) == AUTO_FACES_PER_PIXEL
    with open(os.path.join(ROOT, "docs", "raster.md"), encoding="utf-8") as fh:
        page = fh.read()
    assert f"**{AUTO_FACES_PER_PIXEL[0]}** x image pixels + **{AUTO_FACES_PER_PIXEL[1]}** x covered" in page


def test_command_line_and_scene_files_take_auto():
    from raycast_shade.apps.cli import build_parser

    args = build_parser().parse_args(["render", "scene.toml", "--backend", "auto"])
    assert args.backend == "auto"
    assert check_render_options({"backend": "Auto"})["backend"] == "auto"
    with pytest.raises(ValueError, match="backend"):
        check_render_options({"backend": "fastest"})
