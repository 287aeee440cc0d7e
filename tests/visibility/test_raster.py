"""The z-buffer rasterizer against the ray caster, and the interpolation modes.

Agreement is measured on the 8-bit images (``rs.to_uint8``) of both methods,
shaded by the very same kernels: of the pixels both cover, at least 99.9 %
must agree within 1/255, and the pixels only one covers must be at most
0.1 % of the image. The rasterizer's own guarantees (fill rule, clipping,
exact barycentrics) and the screen-space interpolation are checked against
closed forms.
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.shading.conventions import shade_flat
from raycast_shade.study.twins import to_screen_space_numpy
from raycast_shade.visibility.interpolation import provoking_vertex, to_screen_space, vertex_depths
from raycast_shade.visibility.raster import coverage_count, rasterize
from raycast_shade.shading.shade import shade

MODES = ("flat", "gouraud", "phong")
INTERPOLATIONS = ("perspective", "screen")
WIDTH, HEIGHT = 240, 180

# ----------------------------------------------------------------------------------
# scenes


def _mat(kd=(0.8, 0.4, 0.2), ks=0.6, shininess=40.0):
    return rs.Material(kd=kd, ks=ks, shininess=shininess, ka=0.5)


def _lights():
    return [rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, color=(1.0, 0.9, 0.8), attenuation="inverse_square"),
            rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.4)]


def _scene(models, lights=None):
    return rs.Scene(models, lights=_lights() if lights is None else lights, ambient=0.05)


SCENES = {
    # name: (scene factory, eye, target, ortho_height)
    "icosphere": (lambda: _scene([rs.Model(rs.shapes.icosphere(3), _mat())]), (0.3, 0.5, 3.2), (0, 0, 0), 2.6),
    "torus": (lambda: _scene([rs.Model(rs.shapes.torus(), _mat())]), (0.5, 2.0, 2.5), (0, 0, 0), 3.0),
    "cube_crease": (lambda: _scene([rs.Model(rs.shapes.cube(), _mat((0.3, 0.7, 0.9)))]), (1.6, 1.2, 2.0), (0, 0, 0),
                    2.2),
    "grazing_plane": (lambda: _scene([rs.Model(rs.shapes.plane(size=4.0, subdivisions=12, normal="+y"), _mat())],
                                     [rs.PointLight((0.5, 1.0, 0.0), intensity=3.0)]),
                      (0.0, 0.25, 3.0), (0.0, 0.0, -1.0), 1.2),
    "multi_model": (lambda: _scene([
        rs.Model(rs.shapes.icosphere(2, radius=0.6, center=(-0.8, 0.0, 0.0)), _mat()),
        rs.Model(rs.shapes.torus(0.5, 0.2, center=(0.7, 0.0, 0.0)), _mat((0.2, 0.6, 0.9), 0.4, 20.0)),
        rs.Model(rs.shapes.cube(0.7, center=(0.0, 0.1, -0.9)), _mat((0.9, 0.9, 0.3), 0.0)),
    ]), (0.4, 1.2, 3.0), (0, 0, 0), 3.0),
}


@pytest.fixture(scope="module", params=list(SCENES))
def scene_name(request):
    return request.param


def _camera(name, projection, width=WIDTH, height=HEIGHT):
    _, eye, target, oh = SCENES[name]
    return rs.Camera(eye=eye, target=target, width=width, height=height, fov=45.0, projection=projection,
                     ortho_height=oh)


_SCENE_CACHE = {}


def _get_scene(name):
    if name not in _SCENE_CACHE:
        _SCENE_CACHE[name] = SCENES[name][0]()
    return _SCENE_CACHE[name]


def agreement(scene, camera, hits_a, hits_b, mode):
    """(fraction of commonly covered pixels within 1/255, fraction of the image covered by one only)."""
    a = rs.to_uint8(shade(scene, camera, hits_a, mode)).astype(np.int16)
    b = rs.to_uint8(shade(scene, camera, hits_b, mode)).astype(np.int16)
    both = hits_a.mask & hits_b.mask
    only = hits_a.mask ^ hits_b.mask
    diff = np.abs(a - b).max(axis=2)[both]
    assert both.sum() > 0.05 * both.size, "the view must show the mesh"
    return float(np.mean(diff <= 1)), float(only.mean())


# ----------------------------------------------------------------------------------
# agreement with the ray caster


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_images_agree(scene_name, projection):
    scene = _get_scene(scene_name)
    camera = _camera(scene_name, projection)
    geo = scene.geometry
    raster = rasterize(geo, camera)
    cast = rs.cast_camera(geo, camera)
    for interp in INTERPOLATIONS:
        a, b = raster, cast
        if interp == "screen":
            a, b = to_screen_space(raster, geo, camera), to_screen_space(cast, geo, camera)
        for mode in MODES:
            within, only = agreement(scene, camera, a, b, mode)
            assert within >= 0.999, (scene_name, projection, interp, mode, within)
            assert only <= 0.001, (scene_name, projection, interp, mode, only)


def test_render_backend_raster():
    """rs.render(backend="raster") runs the rasterizer and matches the caster."""
    scene = _get_scene("multi_model").replace(camera=_camera("multi_model", "perspective"))
    for interp in INTERPOLATIONS:
        fr = rs.render(scene, "gouraud", backend="raster", interpolation=interp)
        fc = rs.render(scene, "gouraud", backend="raycast", interpolation=interp)
        assert "raster" in fr.timings and "cast" in fc.timings
        d = np.abs(rs.to_uint8(fr.image).astype(int) - rs.to_uint8(fc.image).astype(int)).max(axis=2)
        assert np.mean(d <= 1) >= 0.999


@pytest.mark.parametrize("name", ["icosphere", "torus", "cube_crease", "multi_model"])
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_coverage_matches_caster_on_closed_meshes(name, projection):
    scene = _get_scene(name)
    camera = _camera(name, projection)
    raster = rasterize(scene.geometry, camera)
    cast = rs.cast_camera(scene.geometry, camera)
    assert raster.mask.sum() > 1000
    # Both methods sample the same pixel centres of the same triangles: any
    # disagreement is float32 rounding in Embree, a handful of pixels at most.
    assert (raster.mask ^ cast.mask).sum() <= 5
    both = raster.mask & cast.mask
    same = (raster.prim[both] == cast.prim[both]) & (raster.geom[both] == cast.geom[both])
    assert same.mean() >= 0.9995


def _exact_hits(scene, camera, hits):
    """Float64 ray-triangle intersection of every hit pixel with the triangle ``hits`` names."""
    from raycast_shade.study.twins import generate_rays_numpy

    geo = scene.geometry
    o, d = generate_rays_numpy(camera, geo.origin)
    m = hits.mask.ravel()
    f = geo.face_offsets[hits.geom.ravel()[m]] + hits.prim.ravel()[m]
    p = geo.vertices[geo.faces[f]]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    dd, oo = d[m], o[m]
    pv = np.cross(dd, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    tv = oo - p[:, 0]
    u = np.einsum("ij,ij->i", tv, pv) / det
    qv = np.cross(tv, e1)
    v = np.einsum("ij,ij->i", dd, qv) / det
    t = np.einsum("ij,ij->i", e2, qv) / det
    return u, v, t


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_barycentrics_and_distance_are_exact(projection):
    """u, v are the perspective-correct barycentrics of the 3D point on the
    pixel's ray, t its distance: float64 ray-triangle intersection agrees to
    float32 rounding."""
    scene = _get_scene("torus")
    camera = _camera("torus", projection)
    hits = rasterize(scene.geometry, camera)
    u, v, t = _exact_hits(scene, camera, hits)
    m = hits.mask.ravel()
    assert np.allclose(hits.u.ravel()[m], np.clip(u, 0, 1), atol=2e-6)
    assert np.allclose(hits.v.ravel()[m], np.clip(v, 0, 1), atol=2e-6)
    assert np.allclose(hits.t.ravel()[m], t, rtol=2e-6, atol=0)
    assert np.all(np.isinf(hits.t[~hits.mask])) and np.all(hits.prim[~hits.mask] == -1)
    assert np.all(hits.geom[~hits.mask] == -1)


def test_local_prim_and_geom_ids():
    """prim is local to its model, geom the model index (as Embree reports)."""
    scene = _get_scene("multi_model")
    hits = rasterize(scene.geometry, _camera("multi_model", "perspective"))
    nfaces = np.diff(scene.geometry.face_offsets)
    assert set(np.unique(hits.geom[hits.mask])) == {0, 1, 2}
    for g in range(3):
        sel = hits.geom == g
        assert hits.prim[sel].max() < nfaces[g] and hits.prim[sel].min() >= 0


# ----------------------------------------------------------------------------------
# fill rule: no cracks, no pixel drawn twice


def _closed_views():
    yield rs.shapes.icosphere(3), (0.3, 0.5, 3.2)
    yield rs.shapes.torus(), (0.5, 2.0, 2.5)
    yield rs.shapes.cube(), (1.6, 1.2, 2.0)
    yield rs.shapes.uv_sphere(12, 24), (0.0, 0.0, 3.0)  # poles and seams on the axes


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_closed_meshes_are_covered_an_even_number_of_times(projection):
    """A ray enters a closed mesh as often as it leaves it: every pixel's
    count is even; a crack or a pixel drawn twice by one layer would make
    it odd."""
    for mesh, eye in _closed_views():
        scene = rs.Scene([mesh])
        camera = rs.Camera(eye=eye, width=WIDTH, height=HEIGHT, projection=projection, ortho_height=3.0)
        count = coverage_count(scene.geometry, camera)
        assert count.max() >= 2, mesh.name
        assert np.all(count % 2 == 0), (mesh.name, np.unique(count))
        # and the pixels covered are exactly the ones the caster hits
        cast = rs.cast_camera(scene.geometry, camera)
        assert ((count > 0) ^ cast.mask).sum() <= 5, mesh.name
    # a convex mesh: one front and one back face per pixel, never more
    count = coverage_count(rs.Scene([rs.shapes.icosphere(3)]).geometry,
                           rs.Camera(eye=(0.3, 0.5, 3.2), width=WIDTH, height=HEIGHT, projection=projection))
    assert set(np.unique(count)) == {0, 2}


def _sheet(flip=False, rotate=0):
    """A 2x2 sheet in z = 0, 8x8 cells, split along one diagonal, with its
    vertices on dyadic coordinates (exact in float)."""
    g = np.linspace(-1.0, 1.0, 9)
    xx, yy = np.meshgrid(g, g, indexing="ij")
    verts = np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], 1)
    for _ in range(rotate):
        verts = np.stack([-verts[:, 1], verts[:, 0], verts[:, 2]], 1)
    i, j = np.mgrid[0:8, 0:8]
    a = (i * 9 + j).ravel()
    b = a + 9
    faces = np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)])
    if flip:
        faces = faces[:, ::-1]
    return rs.Mesh(verts, faces, normals=np.tile([0.0, 0.0, 1.0], (len(verts), 1)))


@pytest.mark.parametrize("flip", [False, True])
@pytest.mark.parametrize("rotate", [0, 1, 2, 3])
def test_top_left_rule_with_edges_through_pixel_centres(flip, rotate):
    """Orthographic view with 32 pixels per unit and the sheet's vertices
    exactly on pixel centres: every grid edge (rows, columns, diagonals) and
    every vertex lies on pixel centres. The top-left rule must still give
    each pixel to exactly one triangle, and include the sheet's top and left
    borders but not its bottom and right ones."""
    scene = rs.Scene([_sheet(flip, rotate)])
    # X = 64 + 32 (x - ex): the sheet's x = -1 falls on X = 16.5, the centre of column 16.
    ex, ey = 0.484375, -0.484375
    camera = rs.Camera(eye=(ex, ey, 5.0), target=(ex, ey, 0.0), width=128, height=128, projection="orthographic",
                       ortho_height=4.0)
    count = coverage_count(scene.geometry, camera)
    expected = np.zeros((128, 128), np.int32)
    expected[16:80, 16:80] = 1  # centres 16.5 .. 79.5; 80.5 is on the right / bottom border
    assert np.array_equal(count, expected)
    hits = rasterize(scene.geometry, camera)
    assert np.array_equal(hits.mask, expected == 1)


def test_no_double_draw_or_crack_on_an_oblique_sheet():
    """A finely triangulated square seen obliquely: every pixel centre
    strictly inside its projected outline is covered exactly once."""
    scene = rs.Scene([rs.shapes.plane(size=2.0, subdivisions=24, normal="+z")])
    camera = rs.Camera(eye=(0.7, -1.1, 1.6), target=(0.05, 0.1, 0.0), width=WIDTH, height=HEIGHT, fov=60.0)
    count = coverage_count(scene.geometry, camera)
    assert count.max() == 1
    # the outline: the square's four corners, projected
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    corners = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float) - camera.eye
    z = corners @ fwd
    X = 0.5 * WIDTH * (1 + (corners @ right) / (z * hw))
    Y = 0.5 * HEIGHT * (1 - (corners @ up) / (z * hh))
    ys, xs = np.mgrid[0:HEIGHT, 0:WIDTH] + 0.5
    inside = np.ones((HEIGHT, WIDTH), bool)
    margin = np.ones((HEIGHT, WIDTH), bool)
    area = 0.0
    for k in range(4):
        ax, ay, bx, by = X[k], Y[k], X[(k + 1) % 4], Y[(k + 1) % 4]
        area += ax * by - bx * ay
    sign = np.sign(area)
    for k in range(4):
        ax, ay, bx, by = X[k], Y[k], X[(k + 1) % 4], Y[(k + 1) % 4]
        e = sign * ((bx - ax) * (ys - ay) - (by - ay) * (xs - ax)) / np.hypot(bx - ax, by - ay)
        inside &= e > 1e-6
        margin &= e > -1e-6
    assert inside.sum() > 5000
    assert np.all(count[inside] == 1)
    assert np.all(count[~margin] == 0)


# ----------------------------------------------------------------------------------
# near-plane clipping


def _near_cases():
    mat = _mat()
    yield ("floor", rs.Scene([rs.Model(rs.shapes.plane(size=20.0, subdivisions=10, normal="+y"), mat)],
                             lights=[rs.PointLight((0.0, 1.0, -2.0), intensity=5.0)]),
           dict(eye=(0.3, 0.2, 0.1), target=(0.3, 0.1, -3.0), fov=70.0))
    yield ("inside_sphere", rs.Scene([rs.Model(rs.shapes.icosphere(3), mat)],
                                     lights=[rs.PointLight((0.2, 0.3, 0.1), intensity=1.0)]),
           dict(eye=(0.1, 0.2, 0.3), target=(1.0, 0.3, -0.2), fov=90.0))
    yield ("torus_tube", rs.Scene([rs.Model(rs.shapes.torus(), mat)],
                                  lights=[rs.PointLight((0.2, 0.3, 0.1), intensity=1.0)]),
           dict(eye=(1.0, 0.05, 0.0), target=(1.0, 0.0, -1.0), fov=80.0))


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_near_plane_clipping(projection):
    """Camera inside or on top of a mesh: triangles that cross the eye plane
    are clipped, not projected through the eye; the result is the caster's."""
    for name, scene, kw in _near_cases():
        camera = rs.Camera(width=160, height=120, projection=projection, ortho_height=1.0, **kw)
        geo = scene.geometry
        w = vertex_depths(geo, camera)[geo.faces]
        straddle = (w.min(axis=1) < 0) & (w.max(axis=1) > 0)
        assert straddle.sum() > 0, f"{name}: no triangle crosses the eye plane"
        hits = rasterize(geo, camera)
        cast = rs.cast_camera(geo, camera)
        m = hits.mask
        assert m.sum() > 1000, name
        assert np.all(np.isfinite(hits.t[m])) and np.all(hits.t[m] >= 0), name
        assert np.all(hits.u >= 0) and np.all(hits.v >= 0) and np.all(hits.u + hits.v <= 1 + 1e-6), name
        assert (m ^ cast.mask).mean() <= 0.001, name
        both = m & cast.mask
        assert np.mean(hits.prim[both] == cast.prim[both]) >= 0.999, name
        assert np.allclose(hits.t[both], cast.t[both], rtol=1e-4, atol=1e-5 * geo.scale), name
        for mode in MODES:
            within, only = agreement(scene, camera, hits, cast, mode)
            assert within >= 0.999 and only <= 0.001, (name, mode, within, only)
            img = shade(scene, camera, hits, mode)
            assert np.all(np.isfinite(img)), (name, mode)
    # an open floor crossing the near plane: clipped quads are fanned without overlap
    name, scene, kw = next(_near_cases())
    camera = rs.Camera(width=160, height=120, projection=projection, **kw)
    assert coverage_count(scene.geometry, camera).max() == 1


def test_near_plane_parameter():
    """A near plane beyond the whole mesh clips everything; the default keeps it."""
    scene = _get_scene("icosphere")
    camera = _camera("icosphere", "perspective")
    assert rasterize(scene.geometry, camera).mask.sum() > 1000
    assert rasterize(scene.geometry, camera, near=10.0).mask.sum() == 0
    # a near plane through the sphere: only its far part remains, and the
    # caster started at the same distance sees the same thing
    hits = rasterize(scene.geometry, camera, near=3.2)
    assert hits.mask.sum() > 1000
    right, up, fwd = camera.basis
    from raycast_shade.study.twins import generate_rays_numpy

    o, d = generate_rays_numpy(camera)
    tnear = 3.2 / (d @ fwd)  # the near plane z = 3.2, as a distance along each ray
    prim, geom, u, v, t = rs.cast_rays(scene.geometry, o, d, tnear=tnear)
    cast_mask = (prim >= 0).reshape(hits.shape)
    assert (cast_mask ^ hits.mask).sum() <= 5


# ----------------------------------------------------------------------------------
# screen-space interpolation


def _single_triangle_scene(verts, normals, lights):
    mesh = rs.Mesh(np.asarray(verts, float), np.array([[0, 1, 2]]), normals=np.asarray(normals, float))
    return rs.Scene([rs.Model(mesh, rs.Material(kd=0.9, ka=0.0))], lights=lights, ambient=0.0)


def _projected(camera, points, origin=np.zeros(3)):
    right, up, fwd = camera.basis
    hw, hh = camera.half_extents()
    p = np.asarray(points, float) - camera.eye
    z = p @ fwd
    X = 0.5 * camera.width * (1 + (p @ right) / (z * hw))
    Y = 0.5 * camera.height * (1 - (p @ up) / (z * hh))
    return X, Y


def _screen_barycentrics(camera, verts):
    """2D barycentrics of every pixel centre w.r.t. the projected vertices."""
    X, Y = _projected(camera, verts)
    ys, xs = np.mgrid[0:camera.height, 0:camera.width] + 0.5
    det = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0])
    l1 = ((xs - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (ys - Y[0])) / det
    l2 = ((X[1] - X[0]) * (ys - Y[0]) - (xs - X[0]) * (Y[1] - Y[0])) / det
    return l1, l2


# Vertex 2's normal lies in the face's plane: unlit (n.s = 0) under a light
# from +y, without pointing to the far side of the face (a normal that did
# would be reflected back into the face's hemisphere, and lit).
GRAZING = ([[-1.5, 0.0, 0.5], [1.5, 0.0, 0.5], [0.0, 0.0, -12.0]],
           [[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
PARALLEL = ([[-1.0, -0.8, 0.0], [1.2, -0.6, 0.0], [0.1, 1.0, 0.0]],
            [[0.0, 0.0, 1.0], [0.8, 0.0, 0.6], [0.0, -0.6, 0.8]])


def test_screen_weights_are_scanline_gouraud():
    """On a large triangle at a grazing angle, ``screen`` weights are the 2D
    barycentrics of the projected triangle (what scanline interpolation
    along edges and spans computes), and Gouraud shading with them is the
    closed-form scanline image; ``perspective`` differs a lot."""
    verts, normals = GRAZING
    light = rs.DirectionalLight((0.0, -1.0, 0.0), intensity=1.0)  # lights vertices 0, 1; vertex 2 is tangent to the face, unlit
    scene = _single_triangle_scene(verts, normals, [light])
    camera = rs.Camera(eye=(0.0, 0.6, 2.0), target=(0.0, 0.0, -3.0), width=WIDTH, height=HEIGHT, fov=50.0)
    geo = scene.geometry
    l1, l2 = _screen_barycentrics(camera, verts)
    # the rasterizer's barycentrics are exact to float32; Embree's own float32
    # arithmetic limits the caster's
    for hits, tol in ((rasterize(geo, camera), 2e-6), (rs.cast_camera(geo, camera), 2e-4)):
        m = hits.mask
        assert m.mean() > 0.2
        scr = to_screen_space(hits, geo, camera)
        err = max(np.abs(scr.u[m] - l1[m]).max(), np.abs(scr.v[m] - l2[m]).max())
        assert err < tol, err
        # the scanline Gouraud image: vertex shades kd * max(n.s, 0) = 0.9, 0.9, 0, interpolated in 2D
        expected = 0.9 * (1.0 - l1 - l2) + 0.9 * l1
        img = shade(scene, camera, scr, "gouraud")[..., 0]
        a = rs.to_uint8(np.repeat(img[..., None], 3, 2))[..., 0].astype(int)
        b = rs.to_uint8(np.repeat(expected[..., None], 3, 2))[..., 0].astype(int)
        assert np.abs(a - b)[m].max() <= 1
        # perspective-correct Gouraud is a different image here
        persp = rs.to_uint8(shade(scene, camera, hits, "gouraud")).astype(int)
        screen = rs.to_uint8(shade(scene, camera, scr, "gouraud")).astype(int)
        d = np.abs(persp - screen).max(axis=2)[m]
        assert d.max() >= 40 and np.mean(d > 1) > 0.3, (d.max(), np.mean(d > 1))


def test_screen_equals_perspective_parallel_to_image_plane():
    """A triangle parallel to the image plane has equal vertex depths: the
    two interpolations coincide (and with an orthographic camera always)."""
    verts, normals = PARALLEL
    scene = _single_triangle_scene(verts, normals, [rs.PointLight((0.3, 0.5, 1.0), intensity=1.0)])
    geo = scene.geometry
    for projection in ("perspective", "orthographic"):
        camera = rs.Camera(eye=(0.2, 0.1, 2.5), target=(0.2, 0.1, 0.0), width=WIDTH, height=HEIGHT,
                           projection=projection, ortho_height=2.4)
        for hits in (rasterize(geo, camera), rs.cast_camera(geo, camera)):
            assert hits.mask.mean() > 0.1
            scr = to_screen_space(hits, geo, camera)
            assert np.abs(scr.u - hits.u).max() <= 1e-6 and np.abs(scr.v - hits.v).max() <= 1e-6
            for mode in ("gouraud", "phong"):
                a = rs.to_uint8(shade(scene, camera, hits, mode)).astype(int)
                b = rs.to_uint8(shade(scene, camera, scr, mode)).astype(int)
                assert np.abs(a - b).max() <= 1
    # the grazing triangle under an orthographic camera: identity too
    verts, normals = GRAZING
    scene = _single_triangle_scene(verts, normals, [rs.DirectionalLight((0.0, -1.0, 0.0))])
    camera = rs.Camera(eye=(0.0, 0.6, 2.0), target=(0.0, 0.0, -3.0), width=WIDTH, height=HEIGHT,
                       projection="orthographic", ortho_height=3.0)
    hits = rasterize(scene.geometry, camera)
    scr = to_screen_space(hits, scene.geometry, camera)
    assert hits.mask.any() and np.array_equal(scr.u, hits.u) and np.array_equal(scr.v, hits.v)


def test_screen_space_numpy_twin():
    """The Numba kernel and its plain-NumPy twin agree, including on
    triangles that cross the eye plane (which keep their 3D weights)."""
    for name, scene, kw in _near_cases():
        camera = rs.Camera(width=160, height=120, **kw)
        hits = rs.cast_camera(scene.geometry, camera)
        a = to_screen_space(hits, scene.geometry, camera)
        b = to_screen_space_numpy(hits, scene.geometry, camera)
        assert np.allclose(a.u, b.u, atol=1e-6) and np.allclose(a.v, b.v, atol=1e-6), name
        assert a.prim is hits.prim and a.t is hits.t
        geo = scene.geometry
        m = hits.mask
        f = geo.face_offsets[hits.geom[m]] + hits.prim[m]
        behind = (vertex_depths(geo, camera)[geo.faces[f]] <= 0).any(axis=1)
        if behind.any():
            assert np.array_equal(a.u[m][behind], hits.u[m][behind])
        assert np.all(a.u[m] >= 0) and np.all(a.u[m] + a.v[m] <= 1 + 1e-6)
        assert not np.array_equal(a.u[m][~behind], hits.u[m][~behind])


# ----------------------------------------------------------------------------------
# flat shading conventions


def test_flat_provoking_vertex():
    """OpenGL flat shading: each triangle takes its provoking vertex's shade,
    computed with that vertex's normal (here the closed form
    ``ka Ia + kd max(n.s, 0)`` under a directional light)."""
    mesh = rs.shapes.icosphere(2)
    s = np.array([0.3, 0.5, 1.0]) / np.linalg.norm([0.3, 0.5, 1.0])
    scene = rs.Scene([rs.Model(mesh, rs.Material(kd=0.7, ka=1.0))], lights=[rs.DirectionalLight(-s, intensity=1.0)],
                     ambient=0.1)
    camera = rs.Camera(eye=(0.2, 0.3, 3.5), width=WIDTH, height=HEIGHT)
    hits = rasterize(scene.geometry, camera)
    geo = scene.geometry
    m = hits.mask
    f = hits.prim[m]
    images = {}
    for conv, k in (("last", 2), ("first", 0)):
        img = shade_flat(scene, camera, hits, conv)
        n = geo.normals[geo.faces[f, k]]
        expected = 0.1 + 0.7 * np.maximum(n @ s, 0.0)
        assert np.allclose(img[m][:, 0], expected, atol=1e-5), conv
        images[conv] = img
    centre = shade_flat(scene, camera, hits, "centre")
    assert np.array_equal(centre, shade(scene, camera, hits, "flat"))
    assert np.abs(images["last"] - images["first"]).max() > 0.01
    assert np.abs(images["last"] - centre).max() > 0.01
    pv = provoking_vertex(hits, "last")
    assert np.all(pv.v[m] == 1) and np.all(pv.u == 0) and pv.prim is hits.prim


# ----------------------------------------------------------------------------------
# bad input


def test_bad_input_names_the_field():
    scene = _get_scene("icosphere")
    camera = _camera("icosphere", "perspective")
    hits = rasterize(scene, camera)  # a Scene is accepted for its geometry
    with pytest.raises(TypeError, match="geometry"):
        rasterize("mesh", camera)
    with pytest.raises(TypeError, match="camera"):
        rasterize(scene.geometry, "camera")
    with pytest.raises(ValueError, match="near"):
        rasterize(scene.geometry, camera, near=-1.0)
    with pytest.raises(ValueError, match="near"):
        rasterize(scene.geometry, camera, near=float("nan"))
    with pytest.raises(TypeError, match="near"):
        rasterize(scene.geometry, camera, near="far")
    with pytest.raises(TypeError, match="geometry"):
        coverage_count(None, camera)
    with pytest.raises(TypeError, match="hits"):
        to_screen_space(hits.u, scene.geometry, camera)
    with pytest.raises(ValueError, match="hits"):
        to_screen_space(hits, scene.geometry, camera.replace(width=WIDTH + 1))
    bad = rs.HitBuffer(prim=hits.prim, geom=np.where(hits.mask, 7, -1).astype(np.int32), u=hits.u, v=hits.v,
                       t=hits.t)
    with pytest.raises(ValueError, match="hits.geom"):
        to_screen_space(bad, scene.geometry, camera)
    bad = rs.HitBuffer(prim=np.where(hits.mask, 10 ** 6, -1).astype(np.int32), geom=hits.geom, u=hits.u, v=hits.v,
                       t=hits.t)
    with pytest.raises(ValueError, match="hits.prim"):
        to_screen_space_numpy(bad, scene.geometry, camera)
    with pytest.raises(ValueError, match="vertex"):
        provoking_vertex(hits, "middle")
    with pytest.raises(ValueError, match="convention"):
        shade_flat(scene, camera, hits, "provoking")
