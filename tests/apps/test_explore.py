"""rs.explore: the widget model driven from Python, no browser. After each change the image
widget holds exactly the PNG of raycast_shade.render of the scene the controls describe."""

from __future__ import annotations

import dataclasses
import io
import subprocess
import sys
import warnings

import numpy as np
import pytest

import raycast_shade as rs

pytest.importorskip("ipywidgets")

from raycast_shade.apps.explore import SIDE_BY_SIDE, Explorer  # noqa: E402
from raycast_shade.output.imagefile import png_bytes  # noqa: E402


def reference_png(explorer: Explorer) -> bytes:
    """The PNG :func:`raycast_shade.render` makes of the explorer's scene and controls: a fresh
    render, which the widget must hold exactly."""
    v = explorer.values()
    scene = explorer.scene()
    fresh = rs.Scene(scene.models, lights=scene.lights, camera=explorer.camera, ambient=scene.ambient,
                     background=scene.background)
    methods = explorer.methods()
    panels = []
    for method in methods:
        frame = rs.render(fresh, method, interpolation=v["interpolation"], max_depth=explorer.max_depth)
        panels.append(rs.to_uint8(frame.overlay(wireframe=True) if v["wireframe"] else frame.image))
    return png_bytes(np.concatenate(panels, axis=1) if len(panels) > 1 else panels[0])


def _scene(w=40, h=30):
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=(0.8, 0.4, 0.2), ks=0.4, shininess=20)),
                     rs.Model(rs.shapes.plane(5.0, center=(0.0, -1.0, 0.0), normal="+y"),
                              rs.Material(kd=0.5, reflectivity=0.3))],
                    lights=[rs.PointLight((2.0, 3.0, 2.0), intensity=20.0, attenuation="inverse_square",
                                          shadows=True)],
                    camera=rs.Camera(eye=(0.0, 1.0, 4.0), target=(0.0, -0.3, 0.0), width=w, height=h), ambient=0.1)


@pytest.fixture(scope="module")
def explorer():
    return rs.explore(_scene())


def _decoded(data):
    import imageio.v3 as iio

    return iio.imread(io.BytesIO(bytes(data)))


CHANGES = [("azimuth", 40.0), ("elevation", 10.0), ("distance", 3.0), ("intensity", 5.0), ("ka", 0.3),
           ("kd", 0.5), ("ks", 0.9), ("t", 80.0), ("attenuation", "heuristic"), ("k", 0.5),
           ("specular", "blinn"), ("interpolation", "screen"), ("shading", "gouraud"), ("shading", "flat"),
           ("wireframe", True), ("shading", SIDE_BY_SIDE), ("attenuation", "none")]


def test_every_control_rerenders_exactly_the_render_of_the_changed_scene(explorer):
    before = bytes(explorer.image.value)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.ShadingWarning)
        for name, value in CHANGES:
            explorer.controls[name].value = value
            shown = bytes(explorer.image.value)
            assert shown != before, name  # the change reached the image
            assert shown == reference_png(explorer), name
            before = shown


def test_the_png_is_the_render_of_the_scene_the_controls_describe():
    ex = Explorer(_scene(), max_depth=2)
    ex.controls["azimuth"].value = 90.0
    ex.controls["elevation"].value = 0.0
    ex.controls["distance"].value = 2.5
    ex.controls["ks"].value = 0.0
    scene = ex.scene()
    centre = scene.geometry.origin
    np.testing.assert_allclose(scene.lights[0].position, centre + [2.5, 0.0, 0.0], atol=1e-12)
    assert scene.lights[0].shadows and scene.lights[0].attenuation == "inverse_square"
    mat = scene.models[0].material
    assert np.all(mat.ks == 0) and mat.shininess == 20
    np.testing.assert_allclose(mat.kd, [0.8, 0.4, 0.2], rtol=1e-15)  # kd keeps its tint
    fresh = rs.Scene(scene.models, lights=scene.lights, camera=scene.camera, ambient=0.1)
    frame = rs.render(fresh, "phong", max_depth=2)
    np.testing.assert_array_equal(_decoded(ex.image.value), frame.to_uint8())
    assert ex.frame.explain(20, 15).method == "phong"


def test_side_by_side_is_three_frames_wide(explorer):
    explorer.controls["shading"].value = SIDE_BY_SIDE
    assert _decoded(explorer.image.value).shape == (30, 120, 3)
    explorer.controls["shading"].value = "phong"
    assert _decoded(explorer.image.value).shape == (30, 40, 3)


def test_a_material_change_reuses_the_packed_geometry(explorer):
    explorer.controls["ka"].value = 0.7
    a = explorer.scene()
    explorer.controls["ka"].value = 0.2
    b = explorer.scene()
    base = explorer.base.geometry
    assert a.geometry.vertices is base.vertices and b.geometry.faces is base.faces
    assert a.geometry.materials[0, 0] == 0.7 and b.geometry.materials[0, 0] == 0.2
    assert base.materials[0, 0] == 1.0  # the explored scene itself is untouched


def test_bad_arguments():
    with pytest.raises(TypeError, match="scene"):
        rs.explore("scene.toml")
    with pytest.raises(ValueError, match="model"):
        rs.explore(_scene(), model=2)
    with pytest.raises(ValueError, match="camera"):
        rs.explore(_scene().replace(camera=None))


def test_scene_without_lights_gets_one():
    with pytest.warns(UserWarning, match="no lights"):
        ex = rs.explore(_scene(16, 12).replace(lights=()))
    assert len(ex.scene().lights) == 1 and bytes(ex.image.value) == reference_png(ex)


def test_importing_the_package_does_not_import_ipywidgets():
    code = ("import sys, raycast_shade as rs; assert 'ipywidgets' not in sys.modules; "
            "assert callable(rs.explore) and 'ipywidgets' not in sys.modules")  # imported by the first call
    subprocess.run([sys.executable, "-c", code], check=True)


# -- the scene it was given, exactly (issue 23) ----------------------------------------------------------------

def _fresh_png(scene, method="phong", max_depth=3):
    from raycast_shade.output.imagefile import png_bytes

    return png_bytes(rs.render(scene, method, max_depth=max_depth).to_uint8())


def _given(material=None, light=None):
    import dataclasses

    base = _scene(24, 18)
    models = list(base.models)
    if material is not None:
        models[0] = rs.Model(models[0].mesh, dataclasses.replace(models[0].material, **material))
    return base.replace(models=models, lights=[light] if light is not None else base.lights)


SPOT = rs.SpotLight(position=(1.0, 3.0, 1.0), direction=(-0.2, -1.0, -0.3), intensity=8.0, exponent=4,
                    inner_angle=20, outer_angle=35, shadows=True, color=(1.0, 0.9, 0.7))
GIVEN = [dict(material=dict(ks=1.5)), dict(material=dict(shininess=5000.0)), dict(material=dict(shininess=0.5)),
         dict(material=dict(kd=(1.5, 0.6, 0.3))), dict(material=dict(ka=(0.1, 0.2, 0.4), ks=(0.9, 0.5, 0.1))),
         dict(light=rs.PointLight((2.0, 3.0, 2.0), intensity=1e5, attenuation="inverse_square")),
         dict(light=rs.PointLight((0.5, 4.0, 0.5), intensity=3.0, attenuation="heuristic", k=250.0)),
         dict(light=rs.PointLight((0.0, 6.0, 0.0), intensity=30.0)),  # straight above: elevation 90
         dict(light=SPOT), dict(light=rs.DirectionalLight((-0.3, -1.0, -0.5), intensity=0.9))]


@pytest.mark.parametrize("given", GIVEN, ids=lambda g: str(g)[:60])
def test_the_explorer_starts_on_exactly_the_scene_it_was_given(given):
    scene = _given(**given)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", rs.ShadingWarning)
        ex = Explorer(scene)
        assert bytes(ex.image.value) == _fresh_png(scene)
    shown = ex.scene()
    assert type(shown.lights[0]) is type(scene.lights[0])
    for f in dataclasses.fields(scene.lights[0]):
        np.testing.assert_array_equal(getattr(shown.lights[0], f.name), getattr(scene.lights[0], f.name), f.name)
    mat, given_mat = shown.models[0].material, scene.models[0].material
    for field in ("ka", "kd", "ks", "shininess", "specular"):
        np.testing.assert_array_equal(getattr(mat, field), getattr(given_mat, field))
    for c in ex.controls.values():  # every value inside its control's range
        if hasattr(c, "min"):
            lo, hi = (10.0 ** c.min, 10.0 ** c.max) if isinstance(c, __import__("ipywidgets").FloatLogSlider) \
                else (c.min, c.max)
            assert lo <= c.value <= hi


def test_a_value_no_slider_can_show_is_refused_and_depth_is_bounded():
    with pytest.raises(ValueError, match="intensity"):
        Explorer(_given(light=rs.PointLight((2.0, 3.0, 2.0), intensity=0.0)))
    mirror = rs.Scene([rs.Model(rs.shapes.icosphere(1, radius=3.0), rs.Material(kd=0.0, reflectivity=1.0))],
                      lights=[rs.PointLight((0.0, 0.5, 0.0), intensity=1.0)],
                      camera=rs.Camera(eye=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), width=8, height=6))
    with pytest.raises(ValueError, match="max_depth"):
        Explorer(mirror, max_depth=10**6)  # refused at once, as render refuses it
    with pytest.raises(ValueError, match="max_depth"):
        rs.render(mirror, max_depth=10**6)


def test_a_spot_light_turns_with_its_position_and_a_directional_light_stays_directional():
    ex = Explorer(_given(light=SPOT))
    centre = ex.centre

    def aim(light):
        to_centre = (centre - light.position) / np.linalg.norm(centre - light.position)
        return float(np.dot(light.direction / np.linalg.norm(light.direction), to_centre))

    before = aim(ex.scene().lights[0])
    ex.controls["azimuth"].value = ex.controls["azimuth"].value + 90.0
    ex.controls["elevation"].value = 30.0
    moved = ex.scene().lights[0]
    assert isinstance(moved, rs.SpotLight) and moved.outer_angle == SPOT.outer_angle
    assert aim(moved) == pytest.approx(before, abs=1e-12)
    assert bytes(ex.image.value) == reference_png(ex)
    sun = Explorer(_given(light=rs.DirectionalLight((-0.3, -1.0, -0.5), intensity=0.9)))
    assert sun.controls["distance"].disabled and sun.controls["attenuation"].disabled
    sun.controls["azimuth"].value = 0.0
    sun.controls["elevation"].value = 45.0
    light = sun.scene().lights[0]
    assert isinstance(light, rs.DirectionalLight)
    np.testing.assert_allclose(light.direction, -np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0), atol=1e-12)


def test_orbit_light_turns_a_spot_light_with_it():
    from raycast_shade.apps.animate import orbit_light

    scene = _given(light=SPOT)
    centre = scene.geometry.origin
    for s in orbit_light(scene, 5, axis=(0.0, 1.0, 0.0), center=centre):
        light = s.lights[0]
        to_centre = (centre - light.position) / np.linalg.norm(centre - light.position)
        d = light.direction / np.linalg.norm(light.direction)
        d0 = SPOT.direction / np.linalg.norm(SPOT.direction)
        c0 = (centre - SPOT.position) / np.linalg.norm(centre - SPOT.position)
        assert np.dot(d, to_centre) == pytest.approx(np.dot(d0, c0), abs=1e-12)
        assert np.linalg.norm(light.position - centre) == pytest.approx(np.linalg.norm(SPOT.position - centre))


# -- the lecture-hall widget: size, labels, reset, save, click ----------------------------------------------

def test_size_fits_and_panels_are_labelled():
    ex = Explorer(_scene(40, 30))
    assert ex.image.layout.width == "440px"
    assert [t.value for t in ex.titles.children] == [
        "<div style='text-align:center;font-weight:bold;font-size:14px;background:#ffe000;width:440px'>"
        "Phong: pixel (20, 15) explained</div>"]
    ex.controls["shading"].value = SIDE_BY_SIDE
    assert ex.image.layout.width == "960px"  # three panels of 320: legible side by side (issue 46)
    assert ["flat" in t.value for t in ex.titles.children] == [True, False, False]
    assert "Gouraud" in ex.titles.children[1].value and "Phong" in ex.titles.children[2].value
    small = Explorer(_scene(40, 30), width=200)
    assert small.image.layout.width == "200px"
    small.controls["shading"].value = SIDE_BY_SIDE
    assert small.image.layout.width == "600px"  # a width below 320 is each panel's
    assert Explorer(_scene(40, 30), width=20).image.layout.width == "40px"  # never below the frame's size
    with pytest.raises(ValueError, match="width"):
        Explorer(_scene(40, 30), width=4)
    assert all(c.layout.width in ("216px", "105px") for c in ex.controls.values())  # two columns within 440 px


def test_reset_returns_to_the_scene_and_save_writes_the_picture(tmp_path):
    ex = Explorer(_scene(24, 18), save_dir=tmp_path)
    start = bytes(ex.image.value)
    for name, value in CHANGES[:8]:
        ex.controls[name].value = value
    assert bytes(ex.image.value) != start
    ex.reset()
    assert bytes(ex.image.value) == start and ex.values() == ex.initial
    ex.buttons["save"].click()
    assert (tmp_path / "explorer_001.png").read_bytes() == start
    assert ex.save() == str(tmp_path / "explorer_002.png")
    assert "saved" in ex.status.value
    with pytest.raises(ValueError, match="png"):
        ex.save(tmp_path / "x.jpg")


def test_a_click_explains_the_pixel_under_the_mouse_beside_the_image():
    ex = Explorer(_scene(40, 30))
    ex.controls["shading"].value = SIDE_BY_SIDE
    # a click at display (x, y) on the 660x165 picture: the middle panel (Gouraud), pixel (10, 20)
    ex.width = 220
    ex.update()
    ex.click({"relativeX": 220 + 10 * 5.5 + 3, "relativeY": 20 * 5.5 + 2, "boundingRectWidth": 660,
              "boundingRectHeight": 165})
    assert (ex.pixel["panel"].value, ex.pixel["x"].value, ex.pixel["y"].value) == (1, 10, 20)
    text = ex.explanation.value
    assert "Gouraud panel, pixel (10, 20)" in text
    assert _printout(text) == _expected("Gouraud panel, pixel (10, 20)", str(ex.frames[1].explain(10, 20)))
    ex.controls["azimuth"].value = -60.0  # the explanation follows the controls
    assert _printout(ex.explanation.value) == _expected("Gouraud panel, pixel (10, 20)",
                                                        str(ex.frames[1].explain(10, 20)))
    ex.pixel["x"].value = 5
    assert "pixel (5, 20)" in ex.explanation.value


def _printout(value):
    """(lines, bold lines) of the printout's HTML, as the browser shows them."""
    import html
    import re

    bold = re.findall(r"<span class='rs-explorer-total'>(.*?)</span>", value, flags=re.S)
    assert len(bold) == 1, value
    return (html.unescape(re.sub(r"<[^>]+>", "", value)).split("\n"), html.unescape(bold[0]).split("\n"))


def _expected(head, text):
    """The head, then explain()'s result (its "total I" line and the clipping lines after it), then the rest."""
    lines = text.split("\n")
    k = [i for i, line in enumerate(lines) if line.startswith("total I = ")]
    k = k[0] if k else 0
    return [head] + lines[k:] + lines[:k], lines[k:]


def test_the_printout_keeps_every_line_with_the_result_first_in_bold():
    ex = Explorer(_scene(40, 30))
    frame = ex.frame
    lit = np.argwhere(frame.model_id >= 0)[0]
    ex.explain(int(lit[1]), int(lit[0]))
    text = str(frame.explain(int(lit[1]), int(lit[0])))
    lines, bold = _printout(ex.explanation.value)
    assert sorted(lines[1:]) == sorted(text.split("\n"))  # nothing dropped, nothing added
    assert bold == [line for line in text.split("\n") if line.startswith("total I = ")] and lines[1] == bold[0]
    empty = np.argwhere(frame.model_id < 0)[0]  # background: its two lines are all result
    ex.explain(int(empty[1]), int(empty[0]))
    lines, bold = _printout(ex.explanation.value)
    assert bold == lines[1:] == str(frame.explain(int(empty[1]), int(empty[0]))).split("\n") and len(bold) == 2
    ex.controls["intensity"].value = 1000.0  # clipped: the lines saying so stay with the result
    lit_now = np.argwhere(ex.frame.image.max(-1) > 1.0)[0]
    ex.explain(int(lit_now[1]), int(lit_now[0]))
    lines, bold = _printout(ex.explanation.value)
    assert len(bold) == 3 and "above 1: shown clipped" in bold[1] and lines[1:4] == bold


def test_side_by_side_the_printout_stands_under_the_panels_above_the_controls():
    ex = Explorer(_scene(40, 30))
    body = ex.widget.children[1]
    left = body.children[0]
    assert list(body.children) == [left, ex.explanation] and ex.image in left.children[1].children
    assert ex.explanation.layout.flex == "1 1 660px" and ex.explanation.layout.width is None  # fills the row
    ex.controls["shading"].value = SIDE_BY_SIDE
    assert list(body.children) == [left] and list(left.children[:3]) == [ex.titles, left.children[1], ex.explanation]
    assert ex.explanation.layout.width == f"{3 * ex.panel_width()}px" == ex.image.layout.width
    ex.controls["shading"].value = "flat"  # back beside the picture
    assert list(body.children) == [left, ex.explanation] and ex.explanation not in left.children


def test_changes_from_two_threads_leave_one_consistent_state():
    """The kernel may deliver a browser-side change on another thread while a cell sets controls."""
    import threading

    ex = Explorer(_scene(24, 18))

    def browser_side():
        for a in (10.0, 20.0, 30.0, 40.0):
            ex.controls["azimuth"].value = a

    t = threading.Thread(target=browser_side)
    t.start()
    for shading in (SIDE_BY_SIDE, "gouraud", SIDE_BY_SIDE):
        ex.controls["shading"].value = shading
    t.join()
    ex.controls["wireframe"].value = True  # one more update after both threads are done
    assert len(ex.titles.children) == len(ex.frames) == 3
    assert ex.image.layout.width == f"{len(ex.frames) * ex.panel_width()}px"
    assert bytes(ex.image.value) == reference_png(ex)


def test_a_value_the_browser_snaps_to_its_slider_grid_keeps_the_scene_s_field():
    """The browser's log slider snaps shininess 40 to 10**1.6 = 39.81 and sends it back; that is the start."""
    ex = Explorer(_scene(24, 18))
    start = bytes(ex.image.value)
    ex.controls["t"].value = 10 ** 1.6  # what JupyterLab sends back for t = 20 -> here: a value off the grid
    snapped = 10 ** (round(np.log10(ex.initial["t"]) / ex.controls["t"].step) * ex.controls["t"].step)
    ex.controls["t"].value = snapped
    ex.controls["azimuth"].value = round(ex.initial["azimuth"])  # the linear slider's grid: whole degrees
    assert ex.scene().models[0].material.shininess == 20.0 and bytes(ex.image.value) == start
    np.testing.assert_array_equal(ex.scene().lights[0].position, ex.base.lights[0].position)
    ex.controls["t"].value = 10 ** (np.log10(ex.initial["t"]) + ex.controls["t"].step)  # one step: a change
    assert ex.scene().models[0].material.shininess != 20.0 and bytes(ex.image.value) != start


# -- for the back row (issue 46, item 3) --------------------------------------------------------------------

def _rings(ex):
    import re

    return [(float(a), float(b), float(w), "explained" in cls) for cls, a, b, w in re.findall(
        r"class='(rs-mark[^']*)' style='position:absolute;left:([0-9.-]+)px;top:([0-9.-]+)px;width:([0-9.]+)px",
        ex.marks.value)]


def test_the_explained_pixel_is_ringed_in_every_panel_and_its_panel_named():
    ex = Explorer(_scene(40, 30))
    ex.controls["shading"].value = SIDE_BY_SIDE
    ex.explain(10, 20, panel=1)
    rings = _rings(ex)
    s = 320 / 40  # display pixels per image pixel
    assert len(rings) == 3 and [r[3] for r in rings] == [False, True, False]
    for p, (left, top, w, _) in enumerate(rings):  # each ring centred on pixel (10, 20) of its panel
        assert left + w / 2 == pytest.approx(p * 320 + 10.5 * s) and top + w / 2 == pytest.approx(20.5 * s)
    assert [("explained" in t.value) for t in ex.titles.children] == [False, True, False]
    assert "Gouraud: pixel (10, 20) explained" in ex.titles.children[1].value
    start = bytes(ex.image.value)
    ex.explain(3, 4, panel=2)  # the rings move; the picture is untouched (the rings are drawn over it)
    assert bytes(ex.image.value) == start and [r[3] for r in _rings(ex)] == [False, False, True]


def test_the_printout_is_legible_wrapped_at_spaces_and_has_no_scroll_bar_of_its_own():
    from raycast_shade.apps.explore_view import CSS

    ex = Explorer(_scene(40, 30))
    assert "font-size: 14px" in CSS and "word-break: normal" in CSS and "overflow-wrap: normal" in CSS
    assert "white-space: pre-wrap" in CSS  # breaks at spaces only, never inside s_i
    assert ex.explanation.layout.height is None and ex.explanation.layout.overflow is None
    assert "rs-explorer-text" in ex.explanation._dom_classes and "<pre>" in ex.explanation.value


def test_switching_to_side_by_side_keeps_explaining_the_same_method():
    ex = Explorer(_scene(40, 30))
    ex.controls["shading"].value = "gouraud"
    ex.explain(12, 14)
    ex.controls["shading"].value = SIDE_BY_SIDE
    assert ex.pixel["panel"].value == 1 and "Gouraud panel, pixel (12, 14)" in ex.explanation.value
    assert "no longer on screen" not in ex.explanation.value
    ex.explain(12, 14, panel=2)  # Phong, then back to one method that is not Phong: said, not silent
    ex.controls["shading"].value = "flat"
    assert ex.pixel["panel"].value == 0 and "Flat panel" not in ex.explanation.value
    assert "Phong is no longer on screen: now explaining the flat panel" in ex.explanation.value
    ex.controls["shading"].value = SIDE_BY_SIDE  # the flat panel was explained last: it stays
    assert ex.pixel["panel"].value == 0 and "flat panel, pixel (12, 14)" in ex.explanation.value
    assert "no longer on screen" not in ex.explanation.value  # the note went with the change it explained
