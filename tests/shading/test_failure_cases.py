"""Where the shading methods fail: cases 1-4, 6 (given normals), 7, 8 and 11 of
the catalogue of ``docs/failure-cases.md``.

The catalogue's cases live by concept: this file holds the methods' own errors
and the orientation rule; ``tests/scene/test_failure_cases.py`` the averaged
normals (5, 6), ``tests/visibility/test_failure_cases.py`` the hits (6, 9, 10)
and ``tests/render/test_failure_cases.py`` the property test over random,
degenerate scenes. Every test keeps its case number in its name. The scenes
come from :mod:`raycast_shade.study.failure_scenes`, which the figure script
(``docs/figures/failure_cases.py``) draws and measures too; each test asserts
what the project guarantees there: finite, non-negative output, the documented
fallback, or the measured size of an error that belongs to the method itself.

A bug this catalogue found is fixed: Gouraud lit a corner whose vertex normal
points to the far side of its face from behind (now reflected into the face's
hemisphere, Phong's rule at the vertex; case 3/6).
"""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.study import failure_scenes as fs
from raycast_shade.study.analytic import Plane, Sphere, exact_for_scene
from raycast_shade.study.metrics import angular_step, compare, convergence_order, highlight_position, normal_angles, rmse
from raycast_shade.study.reference import illuminate_reference, shade_reference

from tests.conftest import RTOL32, assert_sane, hit_buffer, render_all


# ==========================================================================================
# 1. Gouraud misses a highlight inside a large triangle; Mach bands at its edges
# ==========================================================================================
def test_1_gouraud_loses_a_highlight_inside_a_large_triangle():
    """The mirror point of the light, (0.18, 0.12, 0), lies inside one of the
    two triangles: the continuous peak is Ks Ii = 1. Phong reproduces the
    exact image (measured max error 1.0e-6, peak 0.99704 = the exact image's
    brightest pixel); Gouraud evaluates the highlight only at the corners,
    where (r.v)^64 underflows to 0: it loses 100% of the peak (measured
    Gouraud peak 0.0). Flat, evaluated at the centroids, loses it too (6.6e-6)."""
    scene = fs.highlight_plane_scene()
    exact = exact_for_scene(scene, [Plane(size=4.0)])
    f = render_all(scene)
    both = exact.mask & f["phong"].mask
    peak = exact.image[both].max()
    assert peak > 0.99  # the pixel grid samples the continuous peak of 1 closely
    assert abs(f["phong"].image.max() - peak) < 1e-5
    assert np.abs(f["phong"].image - exact.image)[both].max() < 1e-5
    hx = highlight_position(exact.image, both)
    assert np.hypot(*(highlight_position(f["phong"].image, both) - hx)) < 0.05
    assert f["gouraud"].image.max() < 0.01 * peak
    assert f["flat"].image.max() < 0.01 * peak
    # More vertices bring it back: with a vertex every 0.25 the nearest corner sees part of it.
    fine = rs.render(fs.highlight_plane_scene(16), "gouraud").image.max()  # measured 0.62
    assert 0.3 * peak < fine <= 1.0 + 1e-6


def _tube_row(segments, shading, width=128):
    """The middle row of a diffuse tube under a directional light, and the
    exact intensity along that row."""
    scene = fs.tube_scene(segments, width=width)
    row = rs.render(scene, shading).image[8, :, 0].astype(np.float64)
    x = (np.arange(width) + 0.5) / width * 2.0 - 1.0
    s = -scene.lights[0].direction
    exact = np.maximum(0.0, x * s[0] + np.sqrt(1.0 - x**2) * s[2])
    return x, row, exact


@pytest.mark.parametrize("segments", [6, 12])
def test_1_gouraud_mach_bands_are_kinks_at_the_vertex_columns(segments):
    """Mach bands: the eye exaggerates a jump in the *slope* of the intensity.
    Across a tube, Gouraud's intensity is piecewise linear in x: its second
    difference is zero inside each column of triangles and concentrated in a
    kink at each vertex column. Measured max |second difference| against the
    exact image's (|x| < 0.6): Gouraud 12.1x (6 segments), 5.9x (12); Phong
    5.8x and 3.0x; flat, which jumps in value, 953x and 480x. Inside the
    columns Gouraud's median is 1.5e-4 of the exact curvature, Phong's 0.6."""
    x, exact_row, exact = _tube_row(segments, "phong")
    inner = np.abs(x) < 0.6
    d2_exact = np.abs(np.diff(exact[inner], 2)).max()
    d2 = {}
    for shading in rs.SHADINGS:
        _, row, _ = _tube_row(segments, shading)
        assert np.isfinite(row).all()
        d2[shading] = np.abs(np.diff(row[inner], 2))
    g = d2["gouraud"]
    assert g.max() > 4.0 * d2_exact  # a kink, not a curve
    assert np.median(g) < 0.01 * d2_exact  # straight between the kinks
    # The kinks sit on the vertex columns x = sin(theta_k).
    th = np.linspace(-0.45 * np.pi, 0.45 * np.pi, segments + 1)
    xi = x[inner][1:-1]  # the centre pixel of each second difference
    pitch = x[1] - x[0]
    kinks = xi[g > 0.5 * g.max()]
    assert len(kinks) > 0
    assert np.min(np.abs(kinks[:, None] - np.sin(th)[None, :]), axis=1).max() < 1.5 * pitch
    # Phong: curved inside the triangles, with weaker kinks; flat: steps.
    assert 0.2 * d2_exact < np.median(d2["phong"]) < 2.0 * d2_exact
    assert d2["phong"].max() < 0.75 * g.max()
    assert d2["flat"].max() > 20.0 * g.max()



# ==========================================================================================
# 2. Flat shading's facets on a curved surface
# ==========================================================================================
def test_2_flat_facets_converge_only_linearly():
    """Icosphere levels 1-4 against the exact sphere (interior RMSE, diffuse,
    96 x 96): flat shading's error falls like the angular step (fitted order
    1.03; RMSE 0.064 at level 1 to 0.0076 at level 4), Gouraud's and Phong's
    like its square (1.92, 1.98). The normal error of flat shading is the
    facet's tilt, a fixed fraction of the step (measured mean angle / step
    0.286, 0.275, 0.271, 0.271 over the levels)."""
    steps, errors, ratio = [], {m: [] for m in rs.SHADINGS}, []
    exact = None
    for level in (1, 2, 3, 4):
        scene = fs.facet_sphere_scene(level)
        if exact is None:
            exact = exact_for_scene(scene, [Sphere()])
        steps.append(angular_step(scene.models[0].mesh))
        for shading in rs.SHADINGS:
            frame = rs.render(scene, shading)
            c = compare(exact, frame, use_ssim=False)
            errors[shading].append(c.rmse_interior)
            if shading == "flat":
                ratio.append(np.radians(c.mean_angle) / steps[-1])
    p_flat, _ = convergence_order(steps, errors["flat"])
    assert 0.85 < p_flat < 1.15
    for shading in ("gouraud", "phong"):
        assert convergence_order(steps, errors[shading])[0] > 1.7
    assert errors["flat"][-1] > 5 * errors["phong"][-1]
    assert np.ptp(ratio) < 0.25 * np.mean(ratio)



# ==========================================================================================
# 3. Interpolated normals that cancel
# ==========================================================================================
def test_3_zero_normals_supplied_by_the_user_fall_back_to_the_face_normal():
    """Vertex normals of exactly zero (a file's missing normals): the
    interpolated normal is zero everywhere, and every mode shades with the
    geometric normal. Under an orthographic eye and a directional light the
    flat shade is exact per face, so Gouraud and Phong reproduce it
    (measured max difference 0)."""
    f = render_all(fs.zero_normals_scene())
    for shading in rs.SHADINGS:
        assert_sane(f[shading])
    for shading in ("gouraud", "phong"):
        np.testing.assert_allclose(f[shading].normal, f["flat"].normal, atol=1e-6)
        np.testing.assert_allclose(f[shading].image, f["flat"].image, rtol=1e-5, atol=1e-6)


def test_3_opposite_vertex_normals_are_turned_to_the_face():
    """A grid whose vertex normals alternate +z and -z (a checkerboard): the
    interpolated normal is +-z or zero. Phong negates nothing (the grid is
    seen from its front) and reflects -z across the tangent plane to +z: the
    normal buffer is the face normal everywhere, and the image is flat
    shading's (measured max difference 0). Gouraud: see
    ``test_3_6_gouraud_orients_corner_normals_like_phong``."""
    scene = fs.checker_normals_scene()
    flat = rs.render(scene, "flat")
    phong = rs.render(scene, "phong")
    assert_sane(phong)
    np.testing.assert_allclose(phong.normal[phong.mask], np.tile([0.0, 0.0, 1.0], (phong.mask.sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(phong.image, flat.image, rtol=1e-5, atol=1e-6)
    assert_sane(rs.render(scene, "gouraud"))


def test_3_exact_cancellation_uses_the_face_normal_and_stays_finite():
    """Tangent vertex normals n0 = n2 = +x, n1 = -x on a face with normal +z:
    the interpolated normal (1 - 2 u) x vanishes on the line u = 1/2, where
    the pixel falls back to the face normal; either side it is -x or +x. The
    shading normal is discontinuous across that line (the data is), and
    finite everywhere."""
    verts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    normals = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    cam = rs.Camera(eye=(0.3, 0.3, 3.0), target=(0.3, 0.3, 0.0), width=3, height=1)
    scene = fs.scene([rs.Model(rs.Mesh(verts, [[0, 1, 2]], normals=normals), rs.Material(kd=0.7, ks=0.5))],
                   [rs.PointLight((2.0, 0.3, 1.0), intensity=3.0, attenuation="inverse_square")], cam, ambient=0.1)
    hits = hit_buffer([[0.4999, 0.5, 0.5001]], [[0.25, 0.25, 0.25]])
    nbuf = rs.shading_normals(scene, cam, hits, "phong")
    np.testing.assert_allclose(nbuf[0], [[1, 0, 0], [0, 0, 1], [-1, 0, 0]], atol=1e-6)
    for shading in rs.SHADINGS:
        img = rs.shade(scene, cam, hits, shading)
        assert np.isfinite(img).all() and img.min() >= 0.1 * 0.999
        np.testing.assert_allclose(img, shade_reference(scene, cam, hits, shading), rtol=RTOL32)
    # The light is on the +x side: lit left of the line, ambient plus face-normal light on it, dark right of it.
    img = rs.shade(scene, cam, hits, "phong")[0, :, 0]
    assert img[0] > img[1] > img[2] == pytest.approx(0.1, rel=1e-6)



# ==========================================================================================
# 4. Shading normals facing away from the viewer at coarse silhouettes
# ==========================================================================================
@pytest.mark.parametrize("level", [0, 1])
def test_4_coarse_silhouette_normals_stay_on_the_faces_side(level):
    """A coarse sphere seen from close by: near the silhouette the interpolated
    exact normals point away from the eye (n.v < 0) on faces that face it.
    What is guaranteed is n.g >= 0 for the geometric normal g turned to the
    viewer (the reflection rule), not n.v >= 0: the rule leaves those normals
    alone, since they lie on the face's side (measured: 122 of 2714 pixels at
    level 0, 32 of 3420 at level 1; min n.g 0.80 and 0.94). Flipping them
    towards the eye instead (faceforward on n.v) is worse than keeping them:
    RMSE against the exact sphere 0.074 (kept) vs 0.121 (flipped) at level 0."""
    scene = fs.silhouette_scene(level)
    mat = scene.models[0].material
    exact = exact_for_scene(scene, [Sphere()])
    flat = rs.render(scene, "flat")
    for shading in ("gouraud", "phong"):
        frame = rs.render(scene, shading)
        assert_sane(frame)
        assert fs.dot(frame.normal, flat.normal)[frame.mask].min() >= -1e-6
    phong = rs.render(scene, "phong")
    raw, g, v, p = fs.raw_normals(scene, phong)
    n = phong.normal[phong.mask].astype(np.float64)
    away = fs.dot(raw, v) < 0
    assert away.sum() > 0.005 * len(raw)  # the case is provoked
    assert fs.dot(raw, g).min() > 0  # convex, exact normals: all on the face's side ...
    np.testing.assert_allclose(n, raw, atol=2e-6)  # ... so the rule changes nothing
    assert (fs.dot(n, v) < 0).sum() == away.sum()
    # Faceforward against the eye: the naive alternative, measured against the exact sphere.
    naive = np.where(away[:, None], -raw, raw)
    geo = scene.geometry
    lights = [(False, np.array([0.5, 3.0, 0.5]) - geo.origin, np.ones(3), "none", 1.0)]
    mats = (np.array([mat.ka]), np.array([mat.kd]), np.array([mat.ks]), np.array([mat.shininess]), np.array([False]))
    naive_img = np.zeros_like(exact.image)
    naive_img[phong.mask] = illuminate_reference(p, naive, v, np.zeros(len(p), int), mats, lights,
                                                 np.asarray(scene.ambient), 1e-6 * geo.scale)
    both = exact.mask & phong.mask
    assert rmse(exact.image, phong.image, both) < rmse(exact.image, naive_img, both)


def test_4_a_normal_field_tipping_past_the_tangent_plane_stays_continuous():
    """Given vertex normals that turn from +z through +x to 150 degrees from
    the face normal (inconsistent data, or a coarse fold): the interpolated
    normal crosses the tangent plane inside triangles. Reflecting it across
    the tangent plane keeps the normal buffer continuous (measured largest
    angle between neighbouring pixels 2.1 degrees, the field's own step
    ~2 degrees); negating it, the naive rule, jumps by up to 178 degrees."""
    scene = fs.tipping_field_scene()
    frame = rs.render(scene, "phong")
    assert_sane(frame)
    raw, g, v, _ = fs.raw_normals(scene, frame)
    assert (fs.dot(raw, g) < -0.5).sum() > 0.1 * len(raw)  # many pixels needed the rule
    n = frame.normal.astype(np.float64)
    m = frame.mask
    step_x = normal_angles(n[:, 1:], n[:, :-1], m[:, 1:] & m[:, :-1])
    step_y = normal_angles(n[1:], n[:-1], m[1:] & m[:-1])
    assert max(step_x.max(), step_y.max()) < 5.0
    assert n[m][:, 2].min() >= -1e-6  # n.g >= 0, g = +z
    # The naive rule, per pixel: negate where n.g < 0.
    neg = raw.copy()
    neg[fs.dot(raw, g) < 0] *= -1
    naive = np.zeros_like(n)
    naive[m] = neg
    assert normal_angles(naive[:, 1:], naive[:, :-1], m[:, 1:] & m[:, :-1]).max() > 120.0



# ==========================================================================================
# 6. Inconsistent winding with given normals (the orientation rule)
# ==========================================================================================
def test_6_inconsistent_winding_with_given_normals_mirrors_phongs_tilt():
    """The same sphere with its exact normals given. A wrongly wound face seen
    from outside has its front inside: Phong negates the interpolated normal
    with the face, then reflects it across the tangent plane, which gives
    back the face-normal component but mirrors the tangential one. On those
    faces the normal is exactly the exact normal's mirror image (checked
    below), an error of twice the angle between exact and face normal:
    measured RMSE 0.021 (vs 0.0030 consistent), p95 normal error 6.5 degrees.
    Gouraud: see the test below."""
    ico, bad, sel = fs.flipped_sphere(normals=True)
    scene = fs.sphere_scene(bad)
    frame = rs.render(scene, "phong")
    assert_sane(frame)
    raw, g, v, _ = fs.raw_normals(scene, frame)  # raw = sgn * interpolated exact normal
    face = frame.hits.prim[frame.mask]
    flipped = sel[face]
    assert flipped.mean() > 0.2
    n = frame.normal[frame.mask].astype(np.float64)
    exact_n = -raw[flipped]  # the outward exact normal (sgn = -1 on these faces)
    mirrored = 2.0 * fs.dot(exact_n, g[flipped])[:, None] * g[flipped] - exact_n
    np.testing.assert_allclose(n[flipped], mirrored, atol=2e-6)
    np.testing.assert_allclose(n[~flipped], raw[~flipped], atol=2e-6)
    exact = exact_for_scene(scene, [Sphere()])
    good = rs.render(fs.sphere_scene(ico), "phong")
    both = exact.mask & frame.mask
    e_bad, e_good = rmse(exact.image, frame.image, both), rmse(exact.image, good.image, both)
    assert e_good < 0.005 and e_bad < 0.05


def test_3_6_gouraud_orients_corner_normals_like_phong():
    """Gouraud and Phong agree at the vertices for consistent data (see
    test_shading_modes), and for inconsistent data too: the +-z checkerboard
    grid under Gouraud is the flat (= Phong) image, and on the 30%-flipped
    sphere with given normals the Gouraud RMSE against the exact sphere is
    0.023 (0.0115 consistent; measured by docs/figures/failure_cases.py).
    Before the fix: 0.92 off flat, RMSE 0.251 (CHANGELOG.md)."""
    scene = fs.checker_normals_scene()
    np.testing.assert_allclose(rs.render(scene, "gouraud").image, rs.render(scene, "flat").image, rtol=1e-5, atol=1e-6)
    # At the corners of every wrongly wound face, Gouraud = Phong.
    _, bad, sel = fs.flipped_sphere(normals=True)
    scene = fs.sphere_scene(bad)
    faces = np.flatnonzero(sel)[:64]
    for k, (u, v) in enumerate([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]):
        hits = rs.HitBuffer(prim=faces[None, :].astype(np.int32), geom=np.zeros((1, len(faces)), np.int32),
                            u=np.full((1, len(faces)), u, np.float32), v=np.full((1, len(faces)), v, np.float32),
                            t=np.ones((1, len(faces)), np.float32))
        np.testing.assert_allclose(rs.shade(scene, scene.camera, hits, "gouraud"),
                                   rs.shade(scene, scene.camera, hits, "phong"), rtol=1e-5, atol=1e-6)



# ==========================================================================================
# 7. Extreme shininess; cosines that round past 1
# ==========================================================================================
@pytest.mark.parametrize("specular", ["phong", "blinn"])
@pytest.mark.parametrize("shininess", [0.5, 1e6])
def test_7_extreme_shininess_is_finite_and_zero_where_it_must_be(shininess, specular):
    """t = 0.5 (a lobe wider than the hemisphere, infinitely steep at c = 0)
    and t = 1e6 (a highlight far below a pixel): finite and non-negative, and
    with no specular light wherever n.s <= 0 (only ambient there, exactly),
    however large the lobe."""
    scene = fs.shininess_scene(shininess, specular)
    s = -scene.lights[0].direction
    for shading in rs.SHADINGS:
        frame = rs.render(scene, shading)
        assert_sane(frame)
        if shading == "gouraud":
            continue  # interpolated colours: not zero at a pixel, only at the vertices
        dark = (fs.dot(frame.normal.astype(np.float64), s) <= -1e-6) & frame.mask
        assert dark.sum() > 100
        np.testing.assert_allclose(frame.image[dark], 0.1, rtol=1e-6)
        lit = (fs.dot(frame.normal.astype(np.float64), s) > 1e-3) & frame.mask
        assert (frame.image[lit] > 0.1).all()


def test_7_a_needle_highlight_is_one_pixel_in_phong_and_a_star_in_gouraud():
    """t = 1e6 on a plane whose mirror point of the light is both a pixel
    centre and a vertex of the mesh (4 x 4 grid). Phong: the exact image, one
    pixel at Ks Ii = 1 (measured difference from the exact image 1e-104).
    Gouraud: the vertex gets the full highlight and every triangle around it
    interpolates it linearly: the needle becomes a star of 2389 lit pixels,
    exactly the pixels of the triangles that share the vertex."""
    scene = fs.needle_scene()
    mesh = scene.models[0].mesh
    exact = exact_for_scene(scene, [Plane(size=4.0)])
    f = render_all(scene)
    for shading in rs.SHADINGS:
        assert_sane(f[shading])
    assert (exact.image[..., 0] > 1e-3).sum() == 1
    assert f["phong"].image[24, 32, 0] == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(f["phong"].image, exact.image, atol=1e-6)
    centre = int(np.flatnonzero(np.all(np.abs(mesh.vertices) < 1e-12, axis=1))[0])
    star = np.isin(f["gouraud"].hits.prim, np.flatnonzero((mesh.faces == centre).any(axis=1)))
    lit = f["gouraud"].image[..., 0] > 0
    np.testing.assert_array_equal(lit, star & f["gouraud"].mask)
    assert lit.sum() > 1000
    assert f["flat"].image.max() == 0.0  # no centroid sees it


def test_7_cosines_that_round_past_one_are_clamped():
    """n.s, r.v and n.h are computed from unit vectors and round to 1 + 2^-52
    about 1 time in 5 when all are aligned: then c^t with t = 1e300 would be
    inf without the clamp to [0, 1] (at t = 1e6, (1 + 2^-52)^t is only
    1 + 2e-10: the clamp matters from t ~ 1e16). Tilted planes lit and seen
    along their normal, every mode and both specular models: finite, at
    most Ia ka + Ii (kd + Ks), at least the diffuse part; the specular is
    either all there (c rounds to 1) or gone (c rounds below 1, and
    c^1e300 = 0)."""
    rng = np.random.default_rng(0)
    past_one = 0
    for _ in range(24):
        n = fs.unit(rng.normal(size=3))
        s = fs.unit(-(-n))  # the light direction as DirectionalLight stores it, negated
        r = 2.0 * (n @ s) * n - s
        past_one += (n @ s > 1.0) or (r @ n > 1.0) or (n @ fs.unit(s + n) > 1.0)
        a = fs.unit(np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0]))
        b = np.cross(n, a)
        verts = 2.0 * np.array([-a - b, a - b, a + b, -a + b])
        mesh = rs.Mesh(verts, [[0, 1, 2], [0, 2, 3]], normals=np.tile(n, (4, 1)))
        cam = rs.Camera(eye=3.0 * n, target=(0.0, 0.0, 0.0), up=a, width=5, height=5,
                        projection="orthographic", ortho_height=1.0)
        for specular in ("phong", "blinn"):
            mat = rs.Material(kd=0.25, ka=0.5, ks=1.0, shininess=1e300, specular=specular)
            scene = fs.scene([rs.Model(mesh, mat)], [rs.DirectionalLight(-n)], cam, ambient=0.2)
            for shading in rs.SHADINGS:
                img = rs.render(scene, shading).image
                assert np.isfinite(img).all()
                assert img.max() <= 0.2 * 0.5 + 0.25 + 1.0 + 1e-6
                assert img.min() >= 0.2 * 0.5 + 0.25 * 0.999
                spec = img - (0.2 * 0.5 + 0.25)
                assert ((np.abs(spec) < 1e-5) | (np.abs(spec - 1.0) < 1e-5)).all()
    assert past_one > 0  # the case is exercised (in float64 NumPy; the kernels round alike)



# ==========================================================================================
# 8. A point light on a vertex or inside the mesh, each attenuation law
# ==========================================================================================
@pytest.mark.parametrize("shadows", [False, True])
@pytest.mark.parametrize("attenuation", ["none", "inverse_square", "heuristic"])
def test_8_point_light_on_a_vertex_or_inside_the_mesh(attenuation, shadows):
    """A light inside a closed sphere lights its inside only: seen from
    outside every mode shows ambient light, exactly (two-sided lighting turns
    the normal to the eye, away from the light). A light on a vertex: flat
    and Gouraud show ambient light too, but the Phong facets next to the
    vertex lie inside the true sphere, and their interpolated normals see
    the light above their horizon: it leaks onto them, finitely (measured
    peak 2081 with inverse-square, 0.32 without attenuation, 0.53 heuristic;
    the inverse-square peak depends on how close a pixel lands to the
    vertex, bounded by Ii (kd + Ks) / dmin^2), and only onto faces that share
    the vertex. From inside, everything is
    finite and lit."""
    ico, vertex = fs.LIGHT_SPHERE, fs.LIGHT_VERTEX
    for where, pos in fs.light_positions().items():
        scene = fs.light_sphere_scene(pos, attenuation, shadows)
        for shading in rs.SHADINGS:
            frame = rs.render(scene, shading)
            assert_sane(frame)
            hit = frame.image[frame.mask]
            if where != "vertex" or shading != "phong":
                np.testing.assert_allclose(hit, 0.1, rtol=1e-6)
            else:
                leak = (frame.image[..., 0] > 0.1 + 1e-6) & frame.mask
                assert leak.any()
                ring = np.flatnonzero((ico.faces == vertex).any(axis=1))
                assert np.isin(frame.hits.prim[leak], ring).all()
                dmin = 1e-6 * scene.geometry.scale
                bound = 0.1 + 2.0 * (0.7 + 0.5) * (1.0 / dmin**2 if attenuation == "inverse_square" else 1.0)
                assert hit.max() <= bound
            frame_in = rs.render(scene.replace(camera=fs.INSIDE_CAMERA), shading)
            assert_sane(frame_in)
            assert frame_in.mask.all() and frame_in.image.max() > 0.2


def test_8_light_exactly_at_the_shaded_point_contributes_nothing():
    """d = 0: no direction to the light, so no light, in every law (not
    0 * inf). A hit buffer placed exactly on the vertex under the light."""
    ico = rs.shapes.icosphere(2)
    f0 = 11
    corner = ico.faces[f0, 1]  # (u, v) = (1, 0) is corner 1
    cam = rs.Camera(eye=ico.vertices[corner] * 3.0, target=(0.0, 0.0, 0.0), width=3, height=1)
    for attenuation in ("none", "inverse_square", "heuristic"):
        light = rs.PointLight(ico.vertices[corner], intensity=2.0, attenuation=attenuation)
        scene = fs.scene([rs.Model(ico, rs.Material(kd=0.7, ks=0.5))], [light], cam, ambient=0.1)
        hits = hit_buffer([[1.0, 1.0, 1.0]], [[0.0, 0.0, 0.0]], prim=f0)
        for shading in ("gouraud", "phong"):
            img = rs.shade(scene, cam, hits, shading)
            np.testing.assert_allclose(img, 0.1, rtol=1e-6)



# ==========================================================================================
# 11. Grazing view and grazing light
# ==========================================================================================
@pytest.mark.parametrize("shading", rs.SHADINGS)
def test_11_lambert_term_goes_to_zero_continuously_at_grazing_light(shading):
    """A directional light at elevation e above a plane: every pixel is
    kd sin(e), down to e = 1e-7 rad, and 0 at e <= 0 (the light then lights
    the other side). No jump at the horizon."""
    for e in (1e-1, 1e-2, 1e-4, 1e-7, 0.0, -1e-7, -1e-2):
        frame = rs.render(fs.grazing_light_scene(e), shading)
        assert_sane(frame)
        expected = 0.8 * max(0.0, float(np.sin(e)))
        np.testing.assert_allclose(frame.image[frame.mask], expected, rtol=1e-6, atol=1e-12)


def test_11_terminator_on_a_sphere_fades_to_zero():
    """Grazing light on a curved surface: at the terminator of a Phong-shaded
    sphere the lit pixels next to unlit ones are dim (measured at most 0.012
    of kd), so the Lambert term reaches 0 without a step; Gouraud's too
    (0.020). Flat shading steps by whole facets (0.085)."""
    scene = fs.terminator_scene()
    edge = {}
    for shading in rs.SHADINGS:
        frame = rs.render(scene, shading)
        assert_sane(frame)
        img = frame.image[..., 0]
        m = frame.mask
        dark = m & (img == 0)
        near_dark = np.zeros_like(dark)
        near_dark[:, 1:] |= dark[:, :-1]
        near_dark[:, :-1] |= dark[:, 1:]
        near_dark[1:] |= dark[:-1]
        near_dark[:-1] |= dark[1:]
        border = m & ~dark & near_dark
        assert border.sum() > 20
        edge[shading] = img[border].max()
    assert edge["phong"] < 0.05 and edge["gouraud"] < 0.05
    assert edge["flat"] > 2 * edge["phong"]


@pytest.mark.parametrize("projection", ["orthographic", "perspective"])
def test_11_grazing_view_of_a_plane_is_exact(projection):
    """The eye 5 to 0.0005 degrees above a plane, zoomed so the plane fills
    the image: Embree's hits and the shading at them match the exact plane
    (same coverage, measured max error 2.3e-7 orthographic, 1.4e-7 perspective)."""
    for deg in (5.0, 0.05, 0.0005):
        scene = fs.grazing_view_scene(deg, projection)
        exact = exact_for_scene(scene, [Plane(size=4.0)])
        frame = rs.render(scene, "phong")
        assert_sane(frame)
        np.testing.assert_array_equal(frame.mask, exact.mask)
        assert frame.mask.mean() > 0.5
        np.testing.assert_allclose(frame.image, exact.image, atol=1e-6)


def test_11_the_specular_term_switches_off_at_grazing_light():
    """The lecture's model has no n.s factor on the specular term, and no
    specular where n.s <= 0: with the eye in the mirror direction of a
    grazing light, the highlight is near Ks just above the horizon and 0
    just below it. A jump of the model (measured 0.50 = Ks between light
    elevations +-1e-3 rad), not of its evaluation: both sides match the
    NumPy reference."""
    values = []
    for e in (1e-3, -1e-3):
        scene = fs.specular_switch_scene(e)  # the light from -x, grazing
        frame = rs.render(scene, "phong")
        assert_sane(frame)
        np.testing.assert_allclose(frame.image, shade_reference(scene, scene.camera, frame.hits, "phong"), rtol=1e-5,
                                   atol=1e-7)
        values.append(frame.image[frame.mask].max())
    assert values[0] > 0.4 and values[1] == 0.0

