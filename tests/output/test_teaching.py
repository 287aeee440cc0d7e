"""For the lecture hall and the notebook: frames that show themselves, figures,
exact overlays, warnings for silent pitfalls, trimesh input, auto's reasons."""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys
import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.output import overlays
from raycast_shade.scene.pitfalls import closed, sharp_edges, winding_number
from raycast_shade.study.overlay_reference import distances_numpy

LIGHT = rs.DirectionalLight((0.3, -0.4, -1.0), intensity=0.9)


@contextlib.contextmanager
def quiet():
    """Every ShadingWarning is an error inside the block."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", rs.ShadingWarning)
        yield


@pytest.fixture(scope="module")
def frame():
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1), rs.Material(kd=(0.8, 0.3, 0.2), ks=0.5, shininess=40))],
                     lights=[rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, attenuation="inverse_square")],
                     camera=rs.Camera(eye=(0.0, 0.0, 3.5), width=64, height=48))
    return rs.render(scene, "gouraud")


# -- frames that show themselves ----------------------------------------------------------------------------

def test_repr_is_one_short_line_with_size_shading_and_timings(frame):
    text = repr(frame)
    assert "\n" not in text and len(text) < 160, text
    assert text.startswith("Frame(64x48, shading='gouraud'") and "ms:" in text and "total" in text
    assert f"total {frame.timings['total'] * 1e3:.1f}" in text


def test_repr_png_decodes_to_the_8_bit_image_with_each_pixel_a_square(frame, tmp_path):
    import imageio.v3 as iio

    data = frame._repr_png_()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    shown = iio.imread(io.BytesIO(data))
    s = shown.shape[1] // 64
    assert s >= 2 and shown.shape == (48 * s, 64 * s, 3) and 64 * s >= 480  # legible, an integer scale
    np.testing.assert_array_equal(shown[::s, ::s], frame.to_uint8())
    np.testing.assert_array_equal(shown, np.repeat(np.repeat(frame.to_uint8(), s, 0), s, 1))
    frame.save(tmp_path / "f.png")
    assert (tmp_path / "f.png").read_bytes() == frame.show(scale=1)._repr_png_()  # the bytes save writes


# -- figures ------------------------------------------------------------------------------------------------

def test_montage_has_one_titled_axes_per_image(frame):
    pytest.importorskip("matplotlib")
    fig = rs.figures.montage([frame, frame.image, frame.image * 0.5], ["a", "b", "c"])
    assert [ax.get_title() for ax in fig.axes] == ["a", "b", "c"]
    np.testing.assert_array_equal(fig.axes[0].images[0].get_array(), frame.to_uint8())
    assert rs.figures.montage([frame]).axes[0].get_title() == "gouraud"
    fig.savefig(io.BytesIO(), format="png")  # renders (Agg) without pyplot


@pytest.mark.parametrize("signed", [True, False])
def test_difference_is_a_luminance_heatmap_with_a_colour_bar(frame, signed):
    pytest.importorskip("matplotlib")
    other = frame.image * np.float32(0.5)
    fig = rs.figures.difference(frame, other, signed=signed)
    assert len(fig.axes) == 2  # the heatmap and its colour bar
    im = fig.axes[0].images[0]
    assert im.colorbar is not None and im.colorbar.ax is fig.axes[1]
    expected = frame.image.astype(np.float64) @ rs.figures.LUMINANCE - other.astype(np.float64) @ rs.figures.LUMINANCE
    np.testing.assert_allclose(im.get_array(), expected if signed else np.abs(expected))
    lo, hi = im.get_clim()
    if signed:
        assert lo == -hi == -np.abs(expected).max()
    else:
        assert lo == 0.0 and hi == expected.max()
    with pytest.raises(ValueError, match="b: expected the shape"):
        rs.figures.difference(frame, other[:10])


def test_profile_plots_each_channel_of_the_row(frame):
    pytest.importorskip("matplotlib")
    fig = rs.figures.profile(frame, 24)
    (ax,) = fig.axes
    assert len(ax.lines) == 3
    for c, line in enumerate(ax.lines):
        np.testing.assert_array_equal(line.get_xdata(), np.arange(64))
        np.testing.assert_array_equal(line.get_ydata(), frame.image[24, :, c])
    # The triangle edges crossed by the row are marked.
    tri = frame.hits.prim[24]
    assert len(ax.collections) == 1 and len(ax.collections[0].get_segments()) == np.count_nonzero(tri[1:] != tri[:-1])
    with pytest.raises(ValueError, match="row"):
        rs.figures.profile(frame, 48)


@pytest.mark.parametrize("columns, error, match", [
    ((40, 10), ValueError, "columns: \\(40, 10\\) selects no column of the image, 64 pixels wide"),
    ((10, 10), ValueError, "selects no column of the image, 64 pixels wide"),
    ((0, 100), ValueError, "columns: \\(0, 100\\) reaches beyond the image, 64 pixels wide"),
    (slice(70, None), ValueError, "reaches beyond the image, 64 pixels wide"),
    (slice(0, 10, -1), ValueError, "columns: the step must be >= 1"),
    ((0.5, 10), TypeError, "columns: expected integer bounds"),
    ((True, 10), TypeError, "columns: expected integer bounds"),
    ([0, 10], TypeError, "columns: expected a slice or \\(start, stop\\)"),
    ((1, 2, 3), TypeError, "columns: expected a slice or \\(start, stop\\)"),
])
def test_profile_refuses_columns_outside_the_row_naming_them_and_the_width(frame, columns, error, match):
    pytest.importorskip("matplotlib")
    with pytest.raises(error, match=match):
        rs.figures.profile(frame, 24, columns=columns)


@pytest.mark.parametrize("columns, expect", [((10, 20), np.arange(10, 20)), ((-4, None), np.arange(60, 64)),
                                             (slice(0, 64, 8), np.arange(0, 64, 8)), (np.int64(5), None)])
def test_profile_takes_columns_within_the_row(frame, columns, expect):
    pytest.importorskip("matplotlib")
    if expect is None:  # a lone number is not a range of columns
        with pytest.raises(TypeError, match="columns"):
            rs.figures.profile(frame, 24, columns=columns)
        return
    (ax,) = rs.figures.profile(frame, 24, columns=columns).axes
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), expect)
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), frame.image[24, expect, 0])


def test_missing_matplotlib_names_the_notebook_extra(frame, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)  # makes the import fail
    from raycast_shade.common.extras import MissingExtraError

    with pytest.raises(MissingExtraError, match=r"pip install 'raycast_shade\[notebook\]'"):
        rs.figures.montage([frame])


def test_package_import_loads_neither_matplotlib_nor_trimesh():
    code = "import sys, raycast_shade as rs; print('matplotlib' in sys.modules, 'trimesh' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=True)
    assert out.stdout.split() == ["False", "False"]


# -- overlays -----------------------------------------------------------------------------------------------

W, H = 80, 60
TRIANGLE = np.array([[-1.1, -0.62, 0.0], [0.93, -0.81, 0.0], [0.17, 0.88, 0.0]])


def _triangle_frame(camera):
    mesh = rs.Mesh(TRIANGLE, [[0, 1, 2]], normals=np.tile([0.0, 0.0, 1.0], (3, 1)))
    return rs.render(rs.Scene([rs.Model(mesh)], lights=[LIGHT], camera=camera), "phong")


def _pixel_distances(q):
    """(H, W, 3) distance from each pixel centre to the line of each edge, and (H, W, 3) to each
    corner, of a triangle with projected corners ``q`` (3, 2) in pixels; plus the inside mask."""
    ys, xs = np.mgrid[0:H, 0:W]
    c = np.stack([xs + 0.5, ys + 0.5], axis=-1)
    lines, corners, sides = [], [], []
    for k in range(3):
        a, b = q[k], q[(k + 1) % 3]
        e = b - a
        cross = e[0] * (c[..., 1] - a[1]) - e[1] * (c[..., 0] - a[0])
        lines.append(np.abs(cross) / np.hypot(*e))
        sides.append(np.sign(cross))
        corners.append(np.hypot(c[..., 0] - a[0], c[..., 1] - a[1]))
    inside = (sides[0] == sides[1]) & (sides[1] == sides[2])
    return np.stack(lines, -1), np.stack(corners, -1), inside


def _closed_form_check(frame, q, width=2.5, radius=4.0):
    lines, corners, inside = _pixel_distances(q)
    edge = lines.min(axis=-1)
    clear = np.all(np.abs(lines) > 1e-6, axis=-1)  # no pixel centre on an edge line: inside is unambiguous
    np.testing.assert_array_equal(frame.mask[clear], inside[clear])
    img = frame.overlay(wireframe=True, width=width, color=(1.0, 0.0, 1.0))
    drawn = np.all(img == [1.0, 0.0, 1.0], axis=-1)
    want = inside & (edge < width / 2)
    ok = clear & (np.abs(edge - width / 2) > 1e-6)
    np.testing.assert_array_equal(drawn[ok], want[ok])
    assert want[ok].sum() > 50 and (inside & ~want)[ok].sum() > 100  # lines and an untouched middle
    np.testing.assert_array_equal(img[~drawn], frame.image[~drawn])
    dots = np.all(frame.overlay(wireframe=False, vertices=True, radius=radius) == 1.0, axis=-1)
    near = corners.min(axis=-1)
    ok = clear & (np.abs(near - radius) > 1e-6)
    np.testing.assert_array_equal(dots[ok], (inside & (near < radius))[ok])
    assert dots.sum() > 10


def test_wireframe_and_vertices_from_straight_above_orthographic():
    """The edge pixels are exactly those inside the triangle whose centre lies within
    width/2 of a projected edge line; the dots those within radius of a corner."""
    cam = rs.Camera(eye=(0.0, 0.0, 5.0), width=W, height=H, projection="orthographic", ortho_height=2.0)
    frame = _triangle_frame(cam)
    hw, hh = 1.0 * W / H, 1.0
    q = np.stack([(TRIANGLE[:, 0] / hw + 1) * W / 2, (1 - TRIANGLE[:, 1] / hh) * H / 2], axis=1)
    _closed_form_check(frame, q)


def test_wireframe_and_vertices_in_perspective():
    """The same under a pinhole camera: the corners project to f x / z."""
    cam = rs.Camera(eye=(0.1, -0.2, 3.0), target=(0.1, -0.2, 0.0), fov=45.0, width=W, height=H)
    frame = _triangle_frame(cam)
    t = np.tan(np.radians(45.0) / 2)
    rel = TRIANGLE - cam.eye
    z = -rel[:, 2]
    q = np.stack([(rel[:, 0] / (z * t * W / H) + 1) * W / 2, (1 - rel[:, 1] / (z * t)) * H / 2], axis=1)
    _closed_form_check(frame, q)


def test_normal_glyphs_seen_end_on_are_dots_at_the_vertices():
    """Normals pointing at an orthographic camera project to points: a glyph of width w
    is the pixels within w/2 of the projected vertex, drawn even off the triangle."""
    cam = rs.Camera(eye=(0.0, 0.0, 5.0), width=W, height=H, projection="orthographic", ortho_height=2.0)
    frame = _triangle_frame(cam)
    q = np.stack([(TRIANGLE[:, 0] / (W / H) + 1) * W / 2, (1 - TRIANGLE[:, 1]) * H / 2], axis=1)
    _, corners, _ = _pixel_distances(q)
    mask = overlays.normal_glyphs(frame, length=0.3, width=5.0)
    near = corners.min(axis=-1)
    ok = np.abs(near - 2.5) > 1e-6
    np.testing.assert_array_equal(mask[ok], (near < 2.5)[ok])
    img = frame.overlay(wireframe=False, normals=True, width=5.0, color=0.25, length=0.3)
    np.testing.assert_array_equal(np.all(img == np.float32(0.25), axis=-1), mask)


def test_normal_glyphs_point_along_the_projected_normal():
    """Normals along +x seen from above: each glyph is the pixels within width/2 of the
    segment from the projected vertex to length * (pixels per unit) right of it."""
    cam = rs.Camera(eye=(0.0, 0.0, 5.0), width=W, height=H, projection="orthographic", ortho_height=2.0)
    mesh = rs.Mesh(TRIANGLE, [[0, 1, 2]], normals=np.tile([1.0, 0.0, 0.0], (3, 1)))
    frame = rs.render(rs.Scene([rs.Model(mesh)], lights=[LIGHT], camera=cam), "phong")
    mask = overlays.normal_glyphs(frame, length=0.25, width=2.0)
    q = np.stack([(TRIANGLE[:, 0] / (W / H) + 1) * W / 2, (1 - TRIANGLE[:, 1]) * H / 2], axis=1)
    ys, xs = np.mgrid[0:H, 0:W]
    cx, cy = xs + 0.5, ys + 0.5
    dist = np.full((H, W), np.inf)
    for x0, y0 in q:  # a horizontal segment from x0 to x0 + 0.25 H / 2
        dx = np.clip(cx, x0, x0 + 0.25 * H / 2) - cx
        dist = np.minimum(dist, np.hypot(dx, cy - y0))
    ok = np.abs(dist - 1.0) > 1e-6
    np.testing.assert_array_equal(mask[ok], (dist < 1.0)[ok])
    assert mask.sum() > 3 * 2 * 7


def test_overlay_kernel_matches_its_numpy_twin_on_a_perspective_scene(frame):
    edge, corner = overlays.distances(frame)
    e2, c2 = distances_numpy(frame)
    np.testing.assert_array_equal(np.isinf(edge), ~frame.mask)
    np.testing.assert_allclose(edge[frame.mask], e2[frame.mask], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(corner[frame.mask], c2[frame.mask], rtol=1e-9, atol=1e-9)


def test_overlay_rejects_bad_arguments(frame):
    with pytest.raises(ValueError, match="width"):
        frame.overlay(width=0)
    with pytest.raises(ValueError, match="color"):
        frame.overlay(color=(1, 2))
    with pytest.raises(ValueError, match="image: expected shape"):
        frame.overlay(image=np.zeros((2, 2, 3)))


@pytest.mark.parametrize("value, error, match", [
    (np.nan, ValueError, "image: non-finite value at index \\(3, 4, 1\\)"),
    (np.inf, ValueError, "image: non-finite value at index \\(3, 4, 1\\)"),
    (-0.25, ValueError, "image: a linear image, >= 0; got -0.25 at index \\(3, 4, 1\\)"),
])
def test_overlay_refuses_nan_or_negative_images_naming_them(frame, value, error, match):
    image = frame.image.copy()
    image[3, 4, 1] = value
    with pytest.raises(error, match=match):
        frame.overlay(image=image)
    with pytest.raises(TypeError, match="image: expected numbers"):
        frame.overlay(image=np.full(frame.image.shape, "x"))
    with pytest.raises(TypeError, match="wireframe: expected True or False"):
        frame.overlay(wireframe="no")
    assert np.all(frame.overlay(image=np.zeros_like(frame.image), wireframe=False) == 0.0)  # a dark picture


# -- warnings for silent pitfalls ---------------------------------------------------------------------------

def _scene(models, lights=(LIGHT,)):
    return rs.Scene(models, lights=lights, camera=rs.Camera(eye=(0.0, 0.5, 4.0), width=32, height=24))


def test_the_family_shares_one_base():
    for cls in (rs.WindingWarning, rs.NoLightsWarning, rs.LightInsideWarning, rs.BumpIgnoredWarning,
                rs.ColourRangeWarning, rs.CreaseWarning, rs.DroppedOnLoadWarning):
        assert issubclass(cls, rs.ShadingWarning) and issubclass(cls, UserWarning)


def test_no_lights_warns_at_render():
    scene = _scene([rs.shapes.icosphere(1)], lights=())
    with pytest.warns(rs.NoLightsWarning, match="add a PointLight or DirectionalLight"):
        rs.render(scene, "flat")
    with quiet():
        rs.render(scene.replace(lights=[LIGHT]), "flat")


def test_point_light_inside_a_closed_mesh_warns():
    ball = rs.shapes.icosphere(2)
    with pytest.warns(rs.LightInsideWarning, match=r"inside the closed mesh scene.models\[0\].*move the light"):
        rs.render(_scene([ball], [rs.PointLight((0.1, 0.2, 0.0), name="bulb")]), "phong")
    bowl = rs.Mesh(ball.vertices, ball.faces[ball.vertices[ball.faces].mean(axis=1)[:, 2] > 0], normals=ball.normals)
    ring = rs.shapes.torus(1.0, 0.3, 24, 12)
    with quiet():
        rs.render(_scene([ball], [rs.PointLight((0.0, 0.0, 3.0))]), "phong")  # outside
        rs.render(_scene([bowl], [rs.PointLight((0.0, 0.0, 0.5))]), "phong")  # open mesh: not tested
        rs.render(_scene([ring], [rs.PointLight((0.0, 0.0, 0.0))]), "phong")  # in the hole, inside the box


def test_winding_number_and_closedness():
    ball = rs.shapes.icosphere(2)
    assert closed(ball.faces, len(ball.vertices))
    assert not closed(ball.faces[1:], len(ball.vertices))
    assert not closed(np.vstack([ball.faces[:1, ::-1], ball.faces[1:]]), len(ball.vertices))  # one face turned
    assert winding_number(ball.vertices, ball.faces, (0.2, -0.1, 0.3)) == pytest.approx(1.0, abs=1e-9)
    assert winding_number(ball.vertices, ball.faces[:, ::-1], (0.0, 0.0, 0.0)) == pytest.approx(-1.0, abs=1e-9)
    assert winding_number(ball.vertices, ball.faces, (0.0, 2.0, 0.0)) == pytest.approx(0.0, abs=1e-9)


def test_bump_map_that_the_method_ignores_warns_unless_silenced():
    sphere = rs.shapes.uv_sphere(12, 24)
    mat = rs.Material(kd=0.7, ks=0.3, bump=rs.HeightMap.dimples(4, 0.3, resolution=32))
    scene = _scene([rs.Model(sphere, mat), rs.shapes.icosphere(1, center=(2.0, 0.0, 0.0))])
    for method in ("flat", "gouraud", ("gouraud", "phong")):
        with pytest.warns(rs.BumpIgnoredWarning, match=r"scene.models\[0\].*shading='phong'"):
            rs.render(scene, method)
    with quiet():
        for method in ("phong", "auto", ("phong", "flat")):
            rs.render(scene, method)
        with warnings.catch_warnings():  # the documented way to show the pitfall on purpose
            warnings.simplefilter("ignore", rs.BumpIgnoredWarning)
            rs.render(scene, "gouraud")


@pytest.mark.parametrize("values,warns", [
    (dict(kd=(255, 128, 0)), True), (dict(ka=3.0), True), (dict(ks=(2.0, 2.0, 2.0)), True),
    (dict(kd=(0.8, 0.3, 0.2), ks=1.0), False), (dict(ks=1.5), False), (dict(kd=1.0, ka=1.0), False),
    (dict(kd=1e30), False),  # not a byte: a saturation test, say
])
def test_colours_that_look_like_bytes_warn(values, warns):
    if warns:
        field = next(iter(values))
        with pytest.warns(rs.ColourRangeWarning, match=rf"did you mean {field}=.*\({field}/255\)"):
            rs.Material(**values)
    else:
        with quiet():
            rs.Material(**values)


def test_averaging_across_sharp_edges_warns_with_the_count():
    cube = rs.shapes.cube(crease_angle=None)
    with pytest.warns(rs.CreaseWarning, match=r"cube: 12 edge\(s\) join faces at more than 60 degrees.*crease_angle=30"):
        cube.prepared  # noqa: B018
    with quiet():
        rs.shapes.cube().prepared  # noqa: B018 - crease 30 by default
        rs.Mesh(cube.vertices, cube.faces, normals=np.ones((8, 3))).prepared  # noqa: B018 - normals given
        ico = rs.shapes.icosphere(0)  # dihedral turn 41.8 degrees: a coarse curve, not a crease
        rs.Mesh(ico.vertices, ico.faces).prepared  # noqa: B018
    fn = rs.Mesh(cube.vertices, cube.faces, crease_angle=30).prepared.face_normals
    assert sharp_edges(cube.vertices, cube.faces, fn) == 12
    assert sharp_edges(cube.vertices, cube.faces, fn, degrees=95.0) == 0


def test_trimesh_annulus_warns_without_a_crease_angle():
    trimesh = pytest.importorskip("trimesh")
    tm = trimesh.creation.annulus(r_min=0.5, r_max=1.0, height=0.3)
    with pytest.warns(rs.CreaseWarning, match="crease_angle"):
        rs.Mesh.from_trimesh(tm).prepared  # noqa: B018
    with quiet():
        rs.Mesh.from_trimesh(tm, crease_angle=30).prepared  # noqa: B018


def test_what_a_load_drops_is_reported():
    trimesh = pytest.importorskip("trimesh")
    ball = trimesh.creation.icosphere(1)
    plain = trimesh.creation.box()
    ball.vertex_normals  # noqa: B018 - in trimesh's cache: counts as given
    ball.vertex_normals = ball.vertices / np.linalg.norm(ball.vertices, axis=1, keepdims=True)
    scene = trimesh.Scene()
    scene.add_geometry(ball, geom_name="ball")
    scene.add_geometry(plain, geom_name="box")
    scene.add_geometry(trimesh.PointCloud(np.eye(3)), geom_name="points")
    with pytest.warns(rs.DroppedOnLoadWarning) as rec:
        mesh = rs.Mesh.from_trimesh(scene, crease_angle=30, name="two")
    text = str(rec[0].message)
    assert text.startswith("two: dropped ") and "'points' (PointCloud" in text and "vertex normals" in text
    assert mesh.normals is None and len(mesh.faces) == len(ball.faces) + len(plain.faces)
    with quiet():
        rs.Mesh.from_trimesh(ball)


def test_demo_and_examples_fire_no_shading_warning():
    import glob
    import os

    from raycast_shade.apps.demo import render_demo_frames
    from raycast_shade.scene.scenefile import load_scene

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    with quiet():
        frames = render_demo_frames(96, 32)  # flat and Gouraud ignore the egg's bumps on purpose
        assert [f.shading for f in frames] == ["flat", "gouraud", "phong"]
        for path in sorted(glob.glob(os.path.join(root, "examples", "*.toml"))):
            scene, _ = load_scene(path)
            small = scene.camera.replace(width=32, height=24)
            for method in rs.SHADINGS:
                rs.render(scene, method, camera=small)


# -- trimesh input --------------------------------------------------------------------------------------------

def test_scene_and_model_accept_a_trimesh():
    trimesh = pytest.importorskip("trimesh")
    tm = trimesh.creation.icosphere(2)
    ref = rs.render(_scene([rs.Mesh.from_trimesh(tm)]), "gouraud").image
    for models in ([tm], tm, [rs.Model(tm, rs.Material())], [(tm, rs.Material())]):
        scene = _scene(models)
        assert isinstance(scene.models[0].mesh, rs.Mesh)
        np.testing.assert_array_equal(rs.render(scene, "gouraud").image, ref)
    with pytest.raises(TypeError, match="trimesh.Trimesh"):
        rs.Scene([object()])


# -- auto's reasons --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("tolerance", [0.1, 0.03, 0.01, 0.003, 0.001, 1e-4])
def test_auto_never_blames_highlights_without_a_specular_term(tolerance):
    models = [rs.Model(rs.shapes.icosphere(k, center=(2.5 * k - 2.5, 0.0, 0.0)), rs.Material(kd=0.8, ks=0.0))
              for k in (0, 1, 2, 3)]
    scene = rs.Scene(models, lights=[rs.PointLight((0.0, 3.0, 4.0), intensity=1.0)],
                     camera=rs.Camera(eye=(0.0, 0.0, 9.0), width=160, height=60))
    for d in rs.choose_methods(scene, scene.camera, tolerance):
        assert "highlight" not in d.reason, d.reason


def test_auto_names_the_diffuse_term_when_it_needs_phong():
    scene = _scene([rs.Model(rs.shapes.icosphere(3), rs.Material(kd=0.8))], [rs.PointLight((2.0, 3.0, 4.0))])
    (d,) = rs.choose_methods(scene, scene.camera, 0.02)
    assert d.method == "phong" and d.reason.startswith("diffuse shading turns too fast"), d.reason
    shiny = scene.replace(models=[rs.Model(rs.shapes.icosphere(3), rs.Material(kd=0.8, ks=0.5, shininess=40))])
    (d,) = rs.choose_methods(shiny, shiny.camera, 0.02)
    assert "highlight" in d.reason, d.reason


def test_a_double_sided_sheet_is_not_a_crease():
    plane = rs.shapes.plane(size=2.0, subdivisions=2)
    faces = np.vstack([plane.faces, plane.faces[:, ::-1]])
    fn = rs.Mesh(plane.vertices, faces, normals=plane.normals).prepared.face_normals
    assert sharp_edges(plane.vertices, faces, fn) == 0
