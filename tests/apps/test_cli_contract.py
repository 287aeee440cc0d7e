"""The command line's error contract (issue 17): for every front-end subcommand and every
class of bad input, one line ``raycast-shade: error: ...`` on stderr, exit status 2,
never a traceback; and the output path is checked before anything renders.

The Python API's side of the contract is in test_input_contract.py.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.cli import main

SCENE = """\
[camera]
eye = [0.0, 0.0, 4.0]
width = 24
height = 16
{camera}

[[object]]
{object}
[object.material]
{material}

[[light]]
type = "{light_type}"
{light}
"""

DEFAULTS = dict(camera="", object='shape = "icosphere"\nsubdivisions = 1', material="", light_type="point",
                light="position = [2.0, 3.0, 4.0]")

# (scene-file parts, a fragment of the message). Each is a class of issue 17.
BAD_SCENES = {
    # 4. silently accepted, silently altered
    "kd_booleans": (dict(material="kd = [true, false, true]"), "object[0].material.kd: expected numbers, got booleans"),
    "ks_boolean": (dict(material="ks = true"), "object[0].material.ks: expected numbers, got a boolean"),
    "subdivisions_true": (dict(object='shape = "icosphere"\nsubdivisions = true'), "subdivisions: expected an integer, got bool"),
    "subdivisions_2_7": (dict(object='shape = "icosphere"\nsubdivisions = 2.7'), "subdivisions: expected an integer, got float"),
    "position_boolean": (dict(light="position = [true, 3.0, 4.0]"), "light[0].position: expected numbers, got booleans"),
    "nan_vertex_mesh": (dict(object='mesh = "nan.ply"'), "1 vertex(es) with non-finite coordinates (NaN or inf), used by 1 face(s)"),
    # 7. unclear errors: wrong types name the key, huge plans give the figure
    "major_radius_string": (dict(object='shape = "torus"\nmajor_radius = "1"'), "major_radius: expected a number, got str"),
    "segments_6_5": (dict(object='shape = "cylinder"\nsegments = 6.5'), "segments: expected an integer, got float"),
    "segments_1e12": (dict(object='shape = "cylinder"\nsegments = 1000000000000'), "for the mesh; the limit is"),
    "heightmap_huge": (dict(object='shape = "plane"', material='[object.material.bump]\npattern = "dimples"\nresolution = 100000'),
                       "heightmap.resolution: 100000 x 100000 texels need about"),
    "camera_huge": (dict(camera="", object='shape = "icosphere"\nsubdivisions = 1'), None),  # sized on the command line
    "light_name_int": (dict(light="position = [2.0, 3.0, 4.0]\nname = 5"), "light[0].name: expected a string, got int"),
}


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "nan.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n1 nan 0\n3 0 1 2\n3 1 3 2\n")
    (tmp_path / "good.toml").write_text(SCENE.format(**DEFAULTS))
    for name, (parts, _) in BAD_SCENES.items():
        (tmp_path / f"{name}.toml").write_text(SCENE.format(**{**DEFAULTS, **parts}))
    (tmp_path / "folder.png").mkdir()
    (tmp_path / "afile").write_text("x")
    return tmp_path


def run(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_contract(code, out, err, fragment=None):
    assert code == 2, (code, out, err)
    assert "Traceback" not in err and "Traceback" not in out
    assert err.startswith("raycast-shade: error: ") and err.endswith("\n") and err.count("\n") == 1, err
    if fragment:
        assert fragment in err, err


BIG = ["--width", "1000000", "--height", "1000000"]
HUGE_FRAME = "camera.width x camera.height: 1000000 x 1000000 pixels need about 47 TB for a frame"
# views counts its default buffers too (zdepth, normal, ids, mask: 25 bytes a pixel), less the frame's own normals
# (12: frame.normal is the normal buffer)
HUGE_VIEWS = "camera.width x camera.height: 1000000 x 1000000 pixels need about 60 TB for a frame"

# (subcommand argv, fragment). Scene-file classes are added below for render and animate.
CASES = [
    # demo: 4 (empty output), 7 (huge frame), 8 (folder, missing folder, parent is a file), argument types
    (["demo", "-o", ""], "argument -o/--output: expected a path, got an empty string"),
    (["demo", *BIG, "-o", "d.png"], HUGE_FRAME),
    (["demo", "-o", "folder.png"], "output: 'folder.png' is a folder, not a file"),
    (["demo", "-o", "missing/d.png"], "does not exist"),
    (["demo", "-o", "afile/d.png"], "is not a folder"),
    (["demo", "-o", "d.exr"], ".exr is not written"),
    (["demo", "--width", "2.5"], "argument --width"),
    (["demo", "--width", "true"], "argument --width"),
    (["demo", "--exposure", "nan"], "argument --exposure"),
    (["demo", "--exposure", "-1"], "argument --exposure"),
    (["demo", "--gamma", "0"], "argument --gamma"),
    (["demo", "--exposure", "2", "-o", "d.pfm"], "--exposure: tone options apply to 8-bit outputs"),
    # render: 4 (empty output, tolerance in a mode that does not use it), 7 (huge frame), 8 (outputs)
    (["render", "good.toml", "-o", ""], "argument -o/--output: expected a path, got an empty string"),
    (["render", "good.toml", "--tolerance", "nan", "-o", "x.png"], "--tolerance: expected a finite number > 0, got 'nan'"),
    (["render", "good.toml", "--tolerance", "-1", "-o", "x.png"], "--tolerance: expected a finite number > 0, got '-1'"),
    (["render", "good.toml", "--tolerance", "0", "--shading", "flat", "-o", "x.png"], "--tolerance: expected a finite number > 0, got '0'"),
    (["render", "good.toml", *BIG, "-o", "x.png"], HUGE_FRAME),
    (["render", "good.toml", "-o", "folder.png"], "output: 'folder.png' is a folder, not a file"),
    (["render", "good.toml", "-o", "missing/x.png"], "does not exist"),
    (["render", "good.toml", "-o", "afile/x.png"], "is not a folder"),
    (["render", "good.toml", "--max-depth", "2.5"], "argument --max-depth"),
    (["render", "good.toml", "--width", "0"], "argument --width"),
    (["render", "missing.toml", "-o", "x.png"], "missing.toml"),
    (["render", "good.toml", "--exposure", "2", "-o", "x.pfm"], "--exposure: tone options apply to 8-bit outputs"),
    (["render", "good.toml", "--tonemap", "reinhard", "-o", "x.npy"], "--tonemap: tone options apply to 8-bit"),
    # animate: 4 (empty output), 7 (huge frame), argument types
    (["animate", "good.toml", "-o", "", "--no-progress"], "argument -o/--output: expected a path, got an empty string"),
    (["animate", "good.toml", *BIG, "--frames", "2", "--no-progress", "-o", "a.gif"], HUGE_FRAME),
    (["animate", "good.toml", "--frames", "2.5"], "argument --frames"),
    (["animate", "good.toml", "--frames", "0"], "argument --frames"),
    (["animate", "good.toml", "-o", "a.exr", "--no-progress"], "a.exr"),
    (["animate", "good.toml", "--fps", "nan", "--no-progress"], "argument --fps"),
    # views: buffer names, orbit count, huge frame, an output folder that is a file
    (["views", "good.toml", "--orbit", "2", "--buffers", "depth,foo", "-o", "set"], "unknown buffer 'foo'"),
    (["views", "good.toml", "--orbit", "0", "-o", "set"], "argument --orbit"),
    (["views", "good.toml", "--orbit", "2.5", "-o", "set"], "argument --orbit"),
    (["views", "good.toml", "--orbit", "2", *BIG, "-o", "set"], HUGE_VIEWS),
    (["views", "good.toml", "--orbit", "2", "-o", "afile"], "afile"),
    (["views", "kd_booleans.toml", "--orbit", "2", "-o", "set"], "expected numbers, got booleans"),
    (["views", "missing.toml", "--orbit", "2", "-o", "set"], "missing.toml"),
    (["views", "good.toml", "--orbit", "2", "--compression", "lzma", "-o", "set"], "argument --compression"),
    # info takes no arguments
    (["info", "--bogus"], "unrecognized arguments: --bogus"),
    (["info", "extra"], "unrecognized arguments: extra"),
]
for _name, (_parts, _fragment) in BAD_SCENES.items():
    _extra = BIG if _name == "camera_huge" else []
    _fragment = _fragment or HUGE_FRAME
    CASES.append((["render", f"{_name}.toml", *_extra, "-o", "x.png"], _fragment))
    CASES.append((["animate", f"{_name}.toml", *_extra, "--frames", "2", "--no-progress", "-o", "a.gif"], _fragment))


@pytest.mark.parametrize("argv, fragment", CASES, ids=[" ".join(a) for a, _ in CASES])
def test_every_bad_input_is_one_line_and_exit_2(capsys, workdir, argv, fragment):
    code, out, err = run(capsys, argv)
    assert_contract(code, out, err, fragment)
    assert not (workdir / "x.png").exists() and not (workdir / "a.gif").exists()


@pytest.mark.parametrize("argv", [
    ["render", "good.toml", "-o", "folder.png"],
    ["render", "good.toml", "-o", "missing/x.png"],
    ["render", "good.toml", "-o", "afile/x.pfm"],
    ["render", "good.toml", "-o", "ro/x.png"],
])
def test_unwritable_outputs_are_refused_before_rendering(capsys, workdir, monkeypatch, argv):
    """`-o d.png` for a folder, or a read-only place, failed only after rendering."""
    import os

    (workdir / "ro").mkdir()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if os.fspath(p).endswith("/ro") else real(p, mode))

    def no_render(*a, **k):
        raise AssertionError("rendered before checking the output")

    monkeypatch.setattr(sys.modules["raycast_shade.render"], "render", no_render)
    monkeypatch.setattr(sys.modules["raycast_shade.scene.scenefile"], "load_scene", no_render)
    code, out, err = run(capsys, argv)
    assert_contract(code, out, err, "output: ")


def test_demo_output_is_checked_before_rendering(capsys, workdir, monkeypatch):
    from raycast_shade.apps import demo

    def no_render(*a, **k):
        raise AssertionError("rendered before checking the output")

    monkeypatch.setattr(demo, "render_demo_frames", no_render)
    assert_contract(*run(capsys, ["demo", "-o", "folder.png"]), "is a folder")


@pytest.mark.parametrize("object_, light", [
    ('shape = "icosphere"\nsubdivisions = 1', 'position = [2.0, 3.0, 4.0]'),
    ('shape = "icosphere"\nsubdivisions = 1\ncenter = [0, 0, 0]', 'position = [2, 3, 4]\nintensity = 1'),
])
@pytest.mark.parametrize("camera", ["up = [0.0, 1e-200, 0.0]", "up = [0.0, 1e300, 0.0]", ""])
def test_valid_extremes_are_taken(capsys, workdir, object_, light, camera):
    """Refused though valid (class 6): tiny and huge up vectors, integer coordinates."""
    (workdir / "ok.toml").write_text(SCENE.format(**{**DEFAULTS, "camera": camera, "object": object_, "light": light}))
    code, out, err = run(capsys, ["render", "ok.toml", "-o", "ok.png"])
    assert code == 0, err
    assert (workdir / "ok.png").exists()


def test_huge_light_directions_still_light_the_scene(capsys, workdir):
    """DirectionalLight((1e308, 1e308, 0)) was normalised to zero: the image was black."""
    images = []
    for d in ("[-1e308, -1e308, -1e308]", "[-1.0, -1.0, -1.0]"):
        (workdir / "d.toml").write_text(SCENE.format(**{**DEFAULTS, "light_type": "directional",
                                                         "light": f"direction = {d}"}))
        assert run(capsys, ["render", "d.toml", "-o", "d.pfm"])[0] == 0
        images.append(rs.read_pfm(workdir / "d.pfm"))
    assert images[1].max() > 0.1
    np.testing.assert_allclose(images[0], images[1], rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("argv, fragment", [
    (["render", "camera_huge.toml", *BIG, "-o", "x.png"], HUGE_FRAME),
    (["demo", "-o", "folder.png"], "is a folder, not a file"),
    (["animate", "kd_booleans.toml", "--frames", "2", "--no-progress", "-o", "a.gif"], "expected numbers, got booleans"),
    (["info", "--bogus"], "unrecognized arguments"),
    (["views", "kd_booleans.toml", "--orbit", "2", "-o", "set"], "expected numbers, got booleans"),
], ids=["render", "demo", "animate", "info", "views"])
def test_the_contract_holds_in_a_real_process(workdir, argv, fragment):
    res = subprocess.run([sys.executable, "-m", "raycast_shade", *argv], capture_output=True, text=True, timeout=600,
                         cwd=workdir)
    assert_contract(res.returncode, res.stdout, res.stderr, fragment)


# Issue 45: mesh files given to ``render MODEL``, refused on one line before anything renders or is written.
_QUAD = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
_PLY = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 3\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
        "3 0 1 2\n3 2 1 0\n3 0 1 7\n")
BAD_MESH_FILES = {
    "truncated.obj": (_QUAD + "f 1 2 3\nf 2 4", "truncated.obj:6: 'f 2 4': a face needs at least 3 vertices"),
    "zero.obj": (_QUAD + "f 0 1 2\n", "zero.obj:5: 'f 0 1 2': vertex index 0"),
    "range.obj": (_QUAD + "f 1 2 9\n", "range.obj:5: 'f 1 2 9': vertex index 9, but the file has 4"),
    "obj.glb": (_QUAD + "f 1 2 3\n", "obj.glb: not a binary glTF (.glb) file"),
    "obj.stl": (_QUAD + "f 1 2 3\n", "obj.stl: not an STL file"),
    "obj.txt": (_QUAD + "f 1 2 3\n", "obj.txt: the extension .txt names no mesh format"),
    "objfile": (_QUAD + "f 1 2 3\n", "objfile: without an extension"),
    "range.ply": (_PLY, "range.ply:15: face 2 indexes vertex 7"),
    "list.gltf": ("[1, 2, 3]", "list.gltf: a glTF file is a JSON object"),
}


def _mesh_files(folder):
    import zipfile

    from tests.scene.test_mesh_file_checks import triangles_glb

    cases = dict(BAD_MESH_FILES)
    for name, text in ((n, t) for n, (t, _) in BAD_MESH_FILES.items()):
        (folder / name).write_text(text)
    (folder / "range.glb").write_bytes(triangles_glb([[0, 1, 2], [0, 1, 5]]))
    cases["range.glb"] = (None, "range.glb: meshes[0].primitives[1].indices: entry 2 is vertex 5")
    for ext in ("EXT_meshopt_compression", "KHR_texture_basisu", "XYZ_unknown"):
        (folder / f"{ext}.glb").write_bytes(triangles_glb([[0, 1, 2]], required=[ext]))
        cases[f"{ext}.glb"] = (None, f"{ext}.glb: extensionsRequired[0]: the file requires {ext}")
    with zipfile.ZipFile(folder / "inner.zip", "w") as z:
        z.writestr("a.obj", _QUAD + "f 1 2 3\n")
    with zipfile.ZipFile(folder / "nested.zip", "w") as z:
        z.write(folder / "inner.zip", "inner.zip")
    cases["nested.zip"] = (None, "nested.zip: holds the archive 'inner.zip'")
    return cases


_MESH_NAMES = [*BAD_MESH_FILES, "range.glb", "EXT_meshopt_compression.glb", "KHR_texture_basisu.glb",
               "XYZ_unknown.glb", "nested.zip"]


@pytest.mark.parametrize("name", _MESH_NAMES)
def test_a_bad_mesh_file_is_one_line_and_exit_2_before_anything_is_written(capsys, workdir, name):
    fragment = _mesh_files(workdir)[name][1]
    code, out, err = run(capsys, ["render", name, "-o", "x.png"])
    assert_contract(code, out, err, fragment)
    assert not (workdir / "x.png").exists()


def test_a_bad_mesh_file_is_refused_in_a_real_process(workdir):
    import os
    import pathlib

    _mesh_files(workdir)
    here = str(pathlib.Path(rs.__file__).parents[1])  # this checkout's package, whatever is installed
    res = subprocess.run([sys.executable, "-m", "raycast_shade", "render", "zero.obj", "-o", "x.png"],
                         capture_output=True, text=True, timeout=600, cwd=workdir,
                         env={**os.environ, "PYTHONPATH": here})
    assert_contract(res.returncode, res.stdout, res.stderr, "zero.obj:5: 'f 0 1 2': vertex index 0")
    assert not (workdir / "x.png").exists()
