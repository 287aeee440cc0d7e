"""Barycentrics stay on their triangle: no weight below 0 from rounding, so no negative pixel.

Embree's ``u, v`` (float32) and the watertight re-test's (float64 stored as float32) can leave the
triangle by a float32 ulp at edges and vertices; a Phong pixel with ``ka_colors`` on vertex colours
of 0 and 1 was -6e-8. The casters now store every pair onto the triangle
(:func:`raycast_shade.visibility.hits.convex_uv`), unchanged where it was inside.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import raycast_shade as rs
from raycast_shade.visibility.hits import convex_hits, convex_uv

F32 = st.floats(width=32, allow_nan=True, allow_infinity=True)


def _inside(u, v):
    a, b = np.float64(u), np.float64(v)
    return a >= 0.0 and b >= 0.0 and 1.0 - a - b >= 0.0


@settings(max_examples=300, deadline=None)
@given(u=F32, v=F32)
def test_convex_uv_lands_on_the_triangle_and_keeps_what_is_there(u, v):
    cu, cv = convex_uv(np.float32(u), np.float32(v))
    assert np.float32(cu) == cu and np.float32(cv) == cv  # float32 values (Numba boxes them as float)
    cu, cv = np.float32(cu), np.float32(cv)
    assert _inside(cu, cv)
    w = 1.0 - np.float64(cu) - np.float64(cv)  # as the shading kernels form it
    assert w >= 0.0 and abs(w + np.float64(cu) + np.float64(cv) - 1.0) <= 1e-12
    if _inside(u, v):
        assert (cu, cv) == (np.float32(u), np.float32(v))  # bit for bit


@settings(max_examples=200, deadline=None)
@given(u=st.floats(0.0, 1.0, width=32), v=st.floats(0.0, 1.0, width=32),
       du=st.integers(-4, 4), dv=st.integers(-4, 4))
def test_a_few_ulps_outside_moves_a_few_ulps(u, v, du, dv):
    """Rounding's strays come back to the nearest edge, not somewhere else on the triangle."""
    u32, v32 = np.float32(u), np.float32(v)
    if np.float64(u32) + np.float64(v32) > 1.0:
        return
    a = np.float32(u32 + du * np.spacing(np.float32(max(u32, 1e-30))))
    b = np.float32(v32 + dv * np.spacing(np.float32(max(v32, 1e-30))))
    cu, cv = convex_uv(a, b)
    assert abs(float(cu) - float(a)) <= 1e-6 and abs(float(cv) - float(b)) <= 1e-6


@settings(max_examples=60, deadline=None)
@given(pairs=st.lists(st.tuples(F32, F32), min_size=1, max_size=40))
def test_the_numpy_pass_is_the_kernels_helper_bit_for_bit(pairs):
    """convex_hits (NumPy, for repaired pixels and the embreex frame) and convex_uv (inlined in the
    camera kernel and cast_rays) give the same float32 bits."""
    u = np.array([p[0] for p in pairs], np.float32)
    v = np.array([p[1] for p in pairs], np.float32)
    want = [convex_uv(a, b) for a, b in zip(u, v)]
    convex_hits(u, v)
    assert u.tobytes() == np.array([a for a, _ in want], np.float32).tobytes()
    assert v.tobytes() == np.array([b for _, b in want], np.float32).tobytes()


def test_convex_hits_works_in_place_on_a_buffer():
    u = np.array([[0.5, -1e-8], [0.7, np.nan]], np.float32)
    v = np.array([[0.5, 0.25], [0.30000004, 0.1]], np.float32)
    convex_hits(u, v)
    assert u[0, 0] == 0.5 and v[0, 0] == 0.5  # inside: untouched
    assert u[0, 1] == 0.0 and v[0, 1] == np.float32(0.25)
    assert all(_inside(a, b) for a, b in zip(u.ravel(), v.ravel()))


def _coloured_plane(n):
    m = rs.shapes.plane(size=2.0, subdivisions=n, normal="+z")
    colours = (np.random.default_rng(n).random((len(m.vertices), 3)) < 0.5).astype(float)
    return rs.Mesh(m.vertices, m.faces, colors=colours, color_mode="vertex")


def _ambient_scene(mesh, camera, lights=()):
    return rs.Scene([rs.Model(mesh, rs.Material(ka=1.0, kd=0.5, ka_colors=True))], lights=list(lights),
                    camera=camera, ambient=1.0)


def _assert_clean(frame):
    img = frame.image
    assert np.isfinite(img).all() and img.min() >= 0.0, float(np.nanmin(img))
    hb = frame.hits
    hit = hb.prim >= 0
    u, v = hb.u[hit].astype(np.float64), hb.v[hit].astype(np.float64)
    w = 1.0 - u - v
    assert (u >= 0).all() and (v >= 0).all() and (w >= 0).all() and (u <= 1).all() and (v <= 1).all()
    assert np.abs(u + v + w - 1.0).max(initial=0.0) <= 1e-12


def test_rays_along_the_edges_of_a_grid_leave_no_negative_pixel():
    """The case found: an orthographic view whose centre column runs down the grid's shared edges;
    20 of its hits were outside by 6e-8, and the Phong image's minimum was -5.96e-8."""
    cam = rs.Camera(eye=(0, 0, 3), target=(0, 0, 0), up=(0, 1, 0), width=65, height=48,
                    projection="orthographic", ortho_height=2.0 * 48 / 65)
    scene = _ambient_scene(_coloured_plane(8), cam)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.NoLightsWarning)
        for shading in ("phong", "gouraud", "flat"):
            _assert_clean(rs.render(scene, shading))


@settings(max_examples=12, deadline=None, derandomize=True)
@given(n=st.sampled_from([4, 8, 16]), width=st.integers(56, 72), ortho=st.booleans(),
       dx=st.sampled_from([0.0, 0.125, 0.25]), tilt=st.floats(0.0, 0.6), shading=st.sampled_from(["phong", "gouraud"]),
       caster=st.sampled_from(["embree", "embreex"]), interpolation=st.sampled_from(["perspective", "screen"]))
def test_no_pixel_is_negative_and_every_weight_is_convex(n, width, ortho, dx, tilt, shading, caster, interpolation):
    """Random views over a plane of 0/1 vertex colours, lit and with ka_colors: grid-aligned
    orthographic views put rays along shared edges and through vertices."""
    height = 48
    eye = (dx, -3.0 * np.sin(tilt), 3.0 * np.cos(tilt))
    kw = dict(projection="orthographic", ortho_height=2.0 * height / width) if ortho else dict(fov=45)
    cam = rs.Camera(eye=eye, target=(dx, 0, 0), up=(0, 1, 0), width=width, height=height, **kw)
    scene = _ambient_scene(_coloured_plane(n), cam, [rs.PointLight((1, 2, 3))])
    _assert_clean(rs.render(scene, shading, caster=caster, interpolation=interpolation))


def test_cast_rays_through_vertices_stay_on_their_triangles():
    """Rays aimed exactly at an icosphere's vertices (the watertight re-test's float64 weights)."""
    mesh = rs.shapes.icosphere(2)
    scene = rs.Scene([rs.Model(mesh, rs.Material())], lights=[], camera=None)
    targets = mesh.vertices
    origins = targets * 3.0 + np.array([0.01, 0.02, -0.015])
    hits = rs.cast_rays(scene, origins, targets - origins)
    hit = hits.prim >= 0
    assert hit.mean() > 0.9
    u, v = hits.u[hit].astype(np.float64), hits.v[hit].astype(np.float64)
    assert (u >= 0).all() and (v >= 0).all() and (1.0 - u - v >= 0).all()


def test_mirror_bounces_read_weights_on_their_triangles():
    """A mirror facing the coloured grid, seen along the grid's axes: the bounce rays run along the
    grid's shared edges (closest_hit clamps as the camera's store does); no reflected pixel below 0."""
    grid = _coloured_plane(8)
    mirror = rs.shapes.plane(size=2.0, subdivisions=1, normal="-z")
    mirror = rs.Mesh(mirror.vertices + np.array([0.0, 0.0, 2.0]), mirror.faces)
    cam = rs.Camera(eye=(0, 0, 1.0), target=(0, 0, 2.0), up=(0, 1, 0), width=65, height=48,
                    projection="orthographic", ortho_height=2.0 * 48 / 65)
    scene = rs.Scene([rs.Model(grid, rs.Material(ka=1.0, kd=0.5, ka_colors=True)),
                      rs.Model(mirror, rs.Material(ka=0.0, kd=0.0, ks=0.0, reflectivity=1.0))],
                     lights=[], camera=cam, ambient=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.NoLightsWarning)
        frame = rs.render(scene, "phong", max_depth=1)
    img = frame.image
    assert (frame.hits.geom == 1).all()  # every pixel is the mirror ...
    assert img.max() > 0.5 and (img > 0.5).mean() > 0.2  # ... showing the grid's bright squares
    assert np.isfinite(img).all() and img.min() >= 0.0, float(img.min())


def test_the_rasterizers_weights_stay_on_their_triangles():
    """Its float64 weights, clamped, could still round past the edge in float32: n=4, width=56,
    orthographic from (0, 0, 3) gave two Phong pixels of -5.4e-8 before scan.py stored them through
    convex_uv."""
    cam = rs.Camera(eye=(0, 0, 3), target=(0, 0, 0), up=(0, 1, 0), width=56, height=48,
                    projection="orthographic", ortho_height=2.0 * 48 / 56)
    scene = _ambient_scene(_coloured_plane(4), cam, [rs.PointLight((1, 2, 3))])
    for shading in ("phong", "gouraud"):
        _assert_clean(rs.render(scene, shading, backend="raster"))
