"""rs.explore: the widget model driven from Python, no browser. After each change the image
widget holds exactly the PNG of raycast_shade.render of the scene the controls describe."""

from __future__ import annotations

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
    methods = list(rs.SHADINGS) if v["shading"] == SIDE_BY_SIDE else [v["shading"]]
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
    ex = rs.explore(_scene(16, 12).replace(lights=()))
    assert len(ex.scene().lights) == 1 and bytes(ex.image.value) == reference_png(ex)


def test_importing_the_package_does_not_import_ipywidgets():
    code = ("import sys, raycast_shade as rs; assert 'ipywidgets' not in sys.modules; "
            "assert callable(rs.explore) and 'ipywidgets' not in sys.modules")  # imported by the first call
    subprocess.run([sys.executable, "-c", code], check=True)
