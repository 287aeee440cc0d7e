"""TOML scene files: the format, its round trip to the Python API, and its errors."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.scene.scenefile import (RENDER_KEYS, SceneFileError, check_render_options, load_scene,
                                           scene_from_dict, split_options)

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"

# One tetrahedron, counter-clockwise from outside, no normals stored.
TETRA_OBJ = """\
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
f 1 3 2
f 1 2 4
f 1 4 3
f 2 3 4
"""

MINIMAL = """\
[camera]
eye = [0.0, 0.0, 4.0]
width = 40
height = 30

[[object]]
shape = "icosphere"
subdivisions = 1
"""


@pytest.fixture
def write(tmp_path):
    """Write a scene file (and, optionally, other files next to it); return its path."""

    def _write(text, name="scene.toml", **files):
        for fname, content in files.items():
            (tmp_path / fname).write_text(content)
        path = tmp_path / name
        path.write_text(text)
        return path

    return _write


def assert_same_scene(a: rs.Scene, b: rs.Scene):
    """Every value that reaches the renderer is equal (names aside)."""
    for f in ("eye", "target", "up"):
        np.testing.assert_array_equal(getattr(a.camera, f), getattr(b.camera, f))
    for f in ("fov", "width", "height", "projection", "ortho_height"):
        assert getattr(a.camera, f) == getattr(b.camera, f), f
    np.testing.assert_array_equal(a.ambient, b.ambient)
    np.testing.assert_array_equal(a.background, b.background)
    assert len(a.models) == len(b.models)
    for ma, mb in zip(a.models, b.models):
        np.testing.assert_array_equal(ma.mesh.vertices, mb.mesh.vertices)
        np.testing.assert_array_equal(ma.mesh.faces, mb.mesh.faces)
        assert (ma.mesh.normals is None) == (mb.mesh.normals is None)
        if ma.mesh.normals is not None:
            np.testing.assert_array_equal(ma.mesh.normals, mb.mesh.normals)
        assert (ma.mesh.weighting, ma.mesh.crease_angle) == (mb.mesh.weighting, mb.mesh.crease_angle)
        np.testing.assert_array_equal(ma.material.packed(), mb.material.packed())
    assert len(a.lights) == len(b.lights)
    for la, lb in zip(a.lights, b.lights):
        assert type(la) is type(lb)
        np.testing.assert_array_equal(la.radiance, lb.radiance)
        assert la.shadows == lb.shadows
        if isinstance(la, rs.PointLight):
            np.testing.assert_array_equal(la.position, lb.position)
            assert (la.attenuation, la.k) == (lb.attenuation, lb.k)
        else:
            np.testing.assert_array_equal(la.direction, lb.direction)


# -- round trip -----------------------------------------------------------------------


def test_scene_file_equals_python_construction(write):
    path = write("""
ambient = [0.1, 0.05, 0.02]
background = 0.2

[camera]
eye = [0.5, 1.0, 5.0]
target = [0.0, 0.2, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 48
height = 32

[render]
shading = "gouraud"
exposure = 1.5
tonemap = "reinhard"
gamma = 2.2
max_depth = 2

[[object]]
shape = "icosphere"
subdivisions = 1
radius = 0.8
center = [-1.0, 0.0, 0.0]
[object.material]
kd = [0.8, 0.3, 0.2]
ka = 0.5
ks = 0.6
shininess = 40
specular = "blinn"
reflectivity = 0.25

[[object]]
shape = "cube"
size = 0.9
center = [1.0, 0.0, 0.0]
crease_angle = 45
weighting = "area"

[[light]]
type = "point"
position = [2.0, 3.0, 4.0]
intensity = 20.0
color = [1.0, 0.9, 0.8]
attenuation = "inverse_square"
shadows = true

[[light]]
type = "point"
position = [-3.0, 1.0, 2.0]
intensity = 2.0
attenuation = "heuristic"
k = 0.5

[[light]]
type = "directional"
direction = [-1.0, -0.5, -1.0]
intensity = 0.3
color = [0.3, 0.4, 1.0]
""")
    scene, options = load_scene(path)
    expected = rs.Scene(
        [
            rs.Model(rs.shapes.icosphere(1, radius=0.8, center=(-1.0, 0.0, 0.0)),
                     rs.Material(kd=(0.8, 0.3, 0.2), ka=0.5, ks=0.6, shininess=40, specular="blinn",
                                 reflectivity=0.25)),
            rs.Model(rs.shapes.cube(size=0.9, center=(1.0, 0.0, 0.0), crease_angle=45, weighting="area"),
                     rs.Material()),
        ],
        lights=[
            rs.PointLight((2.0, 3.0, 4.0), intensity=20.0, color=(1.0, 0.9, 0.8), attenuation="inverse_square",
                          shadows=True),
            rs.PointLight((-3.0, 1.0, 2.0), intensity=2.0, attenuation="heuristic", k=0.5),
            rs.DirectionalLight((-1.0, -0.5, -1.0), intensity=0.3, color=(0.3, 0.4, 1.0)),
        ],
        camera=rs.Camera(eye=(0.5, 1.0, 5.0), target=(0.0, 0.2, 0.0), up=(0.0, 1.0, 0.0), fov=40.0, width=48,
                         height=32),
        ambient=(0.1, 0.05, 0.02),
        background=0.2,
    )
    assert_same_scene(scene, expected)
    assert options == {"shading": "gouraud", "exposure": 1.5, "tonemap": "reinhard", "gamma": 2.2, "max_depth": 2}
    # Same values, same pixels.
    a = rs.render(scene, "gouraud", max_depth=2).image
    b = rs.render(expected, "gouraud", max_depth=2).image
    assert a.max() > 0.05
    np.testing.assert_array_equal(a, b)


def test_defaults_match_the_library(write):
    scene, options = load_scene(write(MINIMAL))
    assert options == {}
    expected = rs.Scene([rs.shapes.icosphere(1)], camera=rs.Camera(eye=(0.0, 0.0, 4.0), width=40, height=30))
    assert_same_scene(scene, expected)
    assert scene.lights == ()


def test_mesh_file_relative_to_scene_file_with_transform(write, tmp_path, monkeypatch):
    path = write(MINIMAL.replace('shape = "icosphere"\nsubdivisions = 1', """\
mesh = "tetra.obj"
scale = 2.0
rotate = [0.0, 0.0, 90.0]
translate = [1.0, 0.0, 0.0]
crease_angle = 30"""), **{"tetra.obj": TETRA_OBJ})
    monkeypatch.chdir(ROOT)  # not the scene's folder: the path must not depend on the cwd
    scene, _ = load_scene(path)
    mesh = scene.models[0].mesh
    raw = rs.Mesh.load(tmp_path / "tetra.obj")
    # 90 degrees about z: (x, y, z) -> (-y, x, z); then scale 2 and move by +x.
    expected = np.stack([-raw.vertices[:, 1], raw.vertices[:, 0], raw.vertices[:, 2]], 1) * 2.0 + [1.0, 0.0, 0.0]
    np.testing.assert_allclose(mesh.vertices, expected, atol=1e-12)
    np.testing.assert_array_equal(mesh.faces, raw.faces)
    assert mesh.normals is None and mesh.crease_angle == 30.0
    assert mesh.name == "tetra.obj"


def test_mesh_file_equals_mesh_load(write, tmp_path):
    path = write(MINIMAL.replace('shape = "icosphere"\nsubdivisions = 1', 'mesh = "tetra.obj"\nweighting = "uniform"'),
                 **{"tetra.obj": TETRA_OBJ})
    scene, _ = load_scene(path)
    ref = rs.Mesh.load(tmp_path / "tetra.obj", weighting="uniform")
    np.testing.assert_array_equal(scene.models[0].mesh.vertices, ref.vertices)
    np.testing.assert_array_equal(scene.models[0].mesh.prepared.normals, ref.prepared.normals)


def test_rotation_turns_exact_normals_with_the_shape(write):
    plane = 'shape = "plane"\nnormal = "+z"\nrotate = [-90, 0, 0]'
    text = MINIMAL.replace('shape = "icosphere"\nsubdivisions = 1', plane)
    scene, _ = load_scene(write(text))
    mesh = scene.models[0].mesh
    # -90 degrees about x turns +z into +y, positions and normals alike.
    np.testing.assert_allclose(mesh.normals, np.tile([0.0, 1.0, 0.0], (len(mesh.normals), 1)), atol=1e-12)
    np.testing.assert_allclose(mesh.vertices[:, 1], 0.0, atol=1e-12)


def test_computed_normals_drop_the_exact_ones(write):
    torus = 'shape = "torus"\nmajor_segments = 8\nminor_segments = 6\nnormals = "computed"\nweighting = "area"'
    text = MINIMAL.replace('shape = "icosphere"\nsubdivisions = 1', torus)
    scene, _ = load_scene(write(text))
    mesh = scene.models[0].mesh
    assert mesh.normals is None and mesh.weighting == "area"
    exact = rs.shapes.torus(major_segments=8, minor_segments=6)
    np.testing.assert_array_equal(mesh.vertices, exact.vertices)
    # Averaged normals of a coarse torus are close to, but not, the exact ones.
    dots = np.einsum("ij,ij->i", mesh.prepared.normals, exact.normals)
    assert 0.9 < float(np.median(dots)) < 1.0 - 1e-6


def test_render_size_overrides_camera_size(write):
    scene, options = load_scene(write(MINIMAL + "\n[render]\nwidth = 20\n"))
    assert (scene.camera.width, scene.camera.height) == (20, 30)
    assert options == {"width": 20}


def test_scene_from_dict():
    data = {"camera": {"eye": [0, 0, 3]}, "object": [{"shape": "torus", "major_segments": 8, "minor_segments": 4}]}
    scene, options = scene_from_dict(data)
    assert len(scene.models[0].mesh.faces) == 2 * 8 * 4
    with pytest.raises(SceneFileError, match=r"^mine: object\[0\]: unknown key 'radius' for shape 'torus'"):
        scene_from_dict({**data, "object": [{"shape": "torus", "radius": 1}]}, source="mine")


@pytest.mark.parametrize("name, models, lights", [("shapes.toml", 5, 4), ("knot.toml", 2, 3)])
def test_examples_load(name, models, lights):
    scene, options = load_scene(EXAMPLES / name)
    assert len(scene.models) == models and len(scene.lights) == lights
    assert options["shading"] == "phong"
    colours = {tuple(light.color) for light in scene.lights}
    assert len(colours) == lights  # every light has its own colour
    assert any(light.shadows for light in scene.lights)


def test_example_mesh_is_small_and_closed():
    import trimesh

    path = EXAMPLES / "meshes" / "knot.obj"
    assert path.stat().st_size < 200_000
    tm = trimesh.load(path, force="mesh")
    assert tm.is_watertight and tm.volume > 0  # closed, faces wound outwards


def test_docs_example_is_valid():
    """The complete example in docs/scene-files.md loads (mesh paths from examples/)."""
    import tomllib

    text = (ROOT / "docs" / "scene-files.md").read_text()
    blocks = re.findall(r"```toml\n(.*?)```", text, re.S)
    example = next(b for b in blocks if "[camera]" in b and "[[light]]" in b)
    scene, options = scene_from_dict(tomllib.loads(example), base_dir=EXAMPLES, source="docs")
    assert len(scene.models) == 3 and len(scene.lights) == 3
    assert scene.models[1].mesh.crease_angle == 45.0 and scene.models[1].mesh.normals is None
    assert options == {"shading": "phong", "exposure": 1.0, "tonemap": "clamp"}


# -- errors ---------------------------------------------------------------------------

ERRORS = [
    ("unknown key", MINIMAL + "[object.material]\nshinyness = 40\n",
     "object[0].material: unknown key 'shinyness' (did you mean 'shininess'?)"),
    ("negative kd", MINIMAL + "[object.material]\nkd = [0.5, -0.1, 0.2]\n",
     "object[0].material.kd: must be >= 0"),
    ("shininess 0", MINIMAL + "[object.material]\nshininess = 0\n",
     "object[0].material.shininess: must be > 0"),
    ("mesh not found", MINIMAL.replace('shape = "icosphere"\nsubdivisions = 1', 'mesh = "missing.obj"'),
     "object[0].mesh: mesh file not found: "),
    ("TOML syntax", MINIMAL + "[[light]\n", "invalid TOML: "),
    ("unknown top-level key", "camra = 1\n" + MINIMAL, "unknown key 'camra' at the top level (did you mean 'camera'?)"),
    ("table not array", MINIMAL.replace("[[object]]", "[object]"),
     "object: expected an array of tables: write [[object]]"),
    ("no camera", '[[object]]\nshape = "icosphere"\n', "missing [camera] table"),
    ("no eye", MINIMAL.replace("eye = [0.0, 0.0, 4.0]\n", ""), "camera: missing key 'eye'"),
    ("camera value", MINIMAL.replace("width = 40", "width = 40.0"), "camera.width: expected an integer, got float"),
    ("no objects", MINIMAL.split("[[object]]")[0], "no [[object]] tables"),
    ("shape and mesh", MINIMAL + 'mesh = "a.obj"\n', "object[0]: needs exactly one of 'shape'"),
    ("unknown shape", MINIMAL.replace('"icosphere"', '"sphere"'), "object[0].shape: expected one of"),
    ("shape parameter", MINIMAL + "radiu = 2.0\n", "object[0]: unknown key 'radiu' for shape 'icosphere'"),
    ("shape value", MINIMAL.replace("subdivisions = 1", "subdivisions = 12"), "object[0]: subdivisions: expected"),
    ("center", MINIMAL + 'center = [1, 2]\n', "object[0].center: expected shape (3)"),
    ("crease", MINIMAL + "crease_angle = 200\n", "object[0].crease_angle: must be <= 180"),
    ("scale", MINIMAL + "scale = 0\n", "object[0].scale: must be > 0"),
    ("light type", MINIMAL + "[[light]]\nposition = [1, 1, 1]\n", "light[0]: missing key 'type'"),
    ("light key", MINIMAL + '[[light]]\ntype = "directional"\ndirection = [0, -1, 0]\nattenuation = "none"\n',
     "light[0]: unknown key 'attenuation' for a directional light"),
    ("light value", MINIMAL + '[[light]]\ntype = "point"\nposition = [1, 1, 1]\nattenuation = "linear"\n',
     "light[0].attenuation: expected one of"),
    ("heuristic k", MINIMAL + '[[light]]\ntype = "point"\nposition = [1, 1, 1]\nattenuation = "heuristic"\nk = 0\n',
     "light[0].k: heuristic attenuation needs k > 0"),
    ("shadows", MINIMAL + '[[light]]\ntype = "point"\nposition = [1, 1, 1]\nshadows = "yes"\n',
     "light[0].shadows: expected True or False"),
    ("ambient", "ambient = -1\n" + MINIMAL, "ambient: must be >= 0"),
    ("render shading", MINIMAL + '[render]\nshading = "smooth"\n', "render.shading: expected one of"),
    ("render key", MINIMAL + "[render]\nantialias = 4\n", "render: unknown key 'antialias'"),
    ("render per object", MINIMAL + '[render]\nshading = ["flat", "phong"]\n',
     "render.shading: expected one method per [[object]] (1), got 2"),
    ("render auto per object", MINIMAL + '[render]\nshading = ["auto"]\n', "render.shading[0]: expected one of"),
    ("render backend", MINIMAL + '[render]\nbackend = "gpu"\n', "render.backend: expected one of"),
    ("render tolerance", MINIMAL + "[render]\ntolerance = 0\n", "render.tolerance: must be > 0"),
    ("render shading type", MINIMAL + "[render]\nshading = 3\n", "render.shading: expected one of"),
]


@pytest.mark.parametrize("text, message", [e[1:] for e in ERRORS], ids=[e[0] for e in ERRORS])
def test_errors_name_the_file_and_table(write, text, message):
    path = write(text)
    with pytest.raises(SceneFileError) as info:
        load_scene(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: "), msg
    assert message in msg
    assert "\n" not in msg


def test_missing_scene_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_scene(tmp_path / "nope.toml")


def test_scene_file_error_is_a_value_error():
    assert issubclass(SceneFileError, ValueError)


BUMPED = MINIMAL.replace('shape = "icosphere"', 'shape = "uv_sphere"').replace("subdivisions = 1", "rings = 8\nsegments = 16")


def test_bump_pattern_equals_python_construction(write):
    path = write(BUMPED + """
[[light]]
type = "directional"
direction = [-1.0, -1.0, -1.0]

[object.material]
ks = 0.5
[object.material.bump]
pattern = "dimples"
count = 5
radius = 0.3
resolution = 64
scale = -0.02
tiling = [2.0, 1.0]
""")
    scene, _ = load_scene(path)
    hm = scene.models[0].material.bump
    ref = rs.HeightMap.dimples(5, 0.3, resolution=64, scale=-0.02, tiling=(2.0, 1.0))
    np.testing.assert_array_equal(hm.heights, ref.heights)
    assert (hm.scale, hm.tiling, hm.wrap) == (-0.02, (2.0, 1.0), "repeat")
    # it renders, and the bump shows in Phong only
    flat = rs.render(scene, "flat").image
    plain = rs.render(scene.replace(models=(rs.Model(scene.models[0].mesh, rs.Material(ks=0.5)),)), "phong").image
    assert np.abs(rs.render(scene, "phong").image - plain).max() > 1e-3
    assert np.isfinite(flat).all()


def test_bump_image_relative_to_scene_file(write, tmp_path):
    import imageio.v3 as iio

    img = (np.add.outer(np.arange(16), np.arange(16)) * 8).astype(np.uint8)
    iio.imwrite(tmp_path / "h.png", img)
    path = write(BUMPED + """
[object.material.bump]
image = "h.png"
wrap = "clamp"
""")
    scene, _ = load_scene(path)
    ref = rs.HeightMap.from_image(tmp_path / "h.png", wrap="clamp")
    np.testing.assert_array_equal(scene.models[0].material.bump.heights, ref.heights)


@pytest.mark.parametrize("table, match", [
    ('pattern = "ripples"', r"object\[0\]\.material\.bump\.pattern"),
    ('pattern = "dimples"\nfrequency = 3', r"object\[0\]\.material\.bump: unknown key 'frequency'"),
    ("scale = 0.1", r"object\[0\]\.material\.bump: needs 'image"),
    ('image = "missing.png"', r"image not found"),
    ('pattern = "wrinkles"\noctaves = 0', r"octaves"),
])
def test_bad_bump_tables(write, table, match):
    path = write(BUMPED + "\n[object.material.bump]\n" + table + "\n")
    with pytest.raises(SceneFileError, match=match):
        load_scene(path)


def test_render_table_takes_every_option_in_any_case(write):
    text = MINIMAL + """
[[object]]
shape = "icosphere"
subdivisions = 2
[render]
shading = ["Flat", "PHONG"]
backend = "Raster"
interpolation = "Screen"
caster = "EmbreeX"
tolerance = 0.05
max_depth = 0
tonemap = "Reinhard"
gamma = "sRGB"
"""
    scene, options = load_scene(write(text))
    assert options == {"shading": ("flat", "phong"), "backend": "raster", "interpolation": "screen",
                       "caster": "embreex", "tolerance": 0.05, "max_depth": 0, "tonemap": "reinhard",
                       "gamma": "srgb"}
    size, kwargs, tone = split_options(options)
    assert size == {} and tone == {"tonemap": "reinhard", "gamma": "srgb"}
    assert kwargs == {k: options[k] for k in ("shading", "backend", "interpolation", "caster", "tolerance",
                                              "max_depth")}
    # The options are render()'s keywords as they are.
    frame = rs.render(scene, **kwargs)
    assert frame.method[frame.model_id == 0].tolist() == [0] * int((frame.model_id == 0).sum())


def test_check_render_options_is_what_the_file_checks():
    assert check_render_options({"shading": "Auto", "width": 3}) == {"shading": "auto", "width": 3}
    assert set(RENDER_KEYS) == {"shading", "width", "height", "max_depth", "samples", "backend", "interpolation",
                                "caster", "tolerance", "exposure", "tonemap", "gamma"}
    with pytest.raises(ValueError, match=r"^shading\[1\]: expected one of"):
        check_render_options({"shading": ["flat", "toon"]})
    with pytest.raises(TypeError, match="unknown option 'widht' .did you mean 'width'"):
        check_render_options({"widht": 3})
    with pytest.raises(ValueError, match="^render.gamma: must be > 0"):
        check_render_options({"gamma": -1.0}, where="render")
