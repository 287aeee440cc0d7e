"""The ``raycast-shade`` command line and the built-in demo."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps import demo
from raycast_shade.apps.cli import main
from raycast_shade.output.imagefile import write_png as _write_png
from raycast_shade.scene.scenefile import load_scene

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"

SCENE = """\
[camera]
eye = [0.0, 0.0, 4.0]
width = 64
height = 48

[[object]]
shape = "uv_sphere"
rings = 8
segments = 12
{extra}
[[light]]
type = "point"
position = [2.0, 3.0, 4.0]
intensity = 20.0
attenuation = "inverse_square"
"""


def run(capsys, *argv):
    """``main(argv)`` in this process: (exit status, stdout, stderr)."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code, out, err, *fragments):
    assert code == 2
    assert out == ""
    assert err.startswith("raycast-shade: error: ") and err.endswith("\n")
    assert err.count("\n") == 1, err
    assert "Traceback" not in err
    for f in fragments:
        assert f in err, err


@pytest.fixture
def scene_file(tmp_path):
    def _make(extra=""):
        path = tmp_path / "scene.toml"
        path.write_text(SCENE.format(extra=extra))
        return path

    return _make


# -- demo -----------------------------------------------------------------------------


def test_demo_writes_the_three_panels(capsys, tmp_path):
    out = tmp_path / "demo.png"
    code, stdout, err = run(capsys, "demo", "-o", out, "--width", 96, "--height", 36)
    assert code == 0 and err == ""
    img = iio.imread(out)
    assert img.shape == (3 * 36 + 4, 96, 3)
    # Exactly the library's image, tone-mapped: the PNG writer loses nothing.
    np.testing.assert_array_equal(img, rs.to_uint8(demo.render_demo(96, 36)))
    lines = stdout.splitlines()
    assert len(lines) == 1 and str(out) in lines[0] and "96x112" in lines[0] and " ms" in lines[0]
    for key in ("cast", "shade", "save", "total"):
        assert f"{key} " in lines[0]


def test_demo_panels_are_flat_gouraud_phong():
    frames = demo.render_demo_frames(96, 36)
    assert [f.shading for f in frames] == list(demo.MODES)
    flat, gouraud, phong = (f.image for f in frames)
    mask = frames[0].mask
    assert mask.mean() > 0.5  # objects and floor fill the panel
    for a, b in ((flat, gouraud), (gouraud, phong), (flat, phong)):
        assert np.abs(a - b)[mask].mean() > 1e-3
    # Flat: one colour per triangle.
    hits = frames[0].hits
    key = hits.geom.astype(np.int64) * 1_000_000 + hits.prim
    for k in np.unique(key[mask])[:50]:
        colours = flat[key == k]
        assert np.ptp(colours, axis=0).max() < 1e-6


def test_demo_image_layout_and_labels():
    labelled = demo.render_demo(96, 36)
    plain = demo.render_demo(96, 36, labels=False)
    assert labelled.shape == plain.shape == (112, 96, 3) and labelled.dtype == np.float32
    assert not labelled[36:38].any() and not labelled[74:76].any()  # black gaps between panels
    diff = np.any(labelled != plain, axis=2)
    widths = []
    for i, label in enumerate(demo.LABELS):
        panel, image = diff[38 * i:38 * i + 36], labelled[38 * i:38 * i + 36]
        rows, cols = np.nonzero(panel)
        # At 36 rows (scale 1): a 10-pixel font from (3, 3), its shadow one pixel lower; nothing elsewhere.
        assert rows.min() >= 3 and rows.max() < 3 + demo.FONT_SIZE + 2, label
        assert cols.min() >= 3 and cols.max() < 3 + 8 * len(label), label  # under 8 pixels a letter
        # The strokes (a pixel wide at this size, anti-aliased): near white, several per letter.
        white = np.all(image >= 0.9, axis=2) & panel
        assert white.sum() >= 4 * len(label), label
        widths.append(cols.max() - cols.min())
    assert widths[0] < widths[2] < widths[1]  # FLAT, PHONG, GOURAUD: the text, not a fixed stamp


def test_draw_text_writes_white_letters_over_a_black_shadow():
    """On mid grey: the letters' fully covered pixels are exactly ``value``, the shadow's darken, the rest is
    untouched; ``scale`` scales the text; text at the border is clipped, not an error."""
    white = lambda im: np.all(im >= 0.9, axis=2)  # noqa: E731 - the strokes
    img = np.full((40, 120, 3), 0.5, np.float32)
    demo.draw_text(img, "PHONG", 5, 6, 1)
    changed = np.any(img != 0.5, axis=2)
    rows, cols = np.nonzero(changed)
    assert rows.min() >= 6 and cols.min() >= 5 and rows.max() < 6 + 12 and cols.max() < 5 + 40
    assert white(img).sum() > 20 and img.max() <= 1.0
    assert np.all(img[changed] < 0.5, axis=1).sum() > 10  # the shadow, down and right of the strokes
    big = np.full((80, 300, 3), 0.5, np.float32)
    demo.draw_text(big, "PHONG", 5, 6, 3, value=2.0)
    full = np.all(big == 2.0, axis=2)
    assert full.sum() > 100 and big.max() == 2.0  # at 30 pixels the strokes are fully covered: exactly value
    tall = lambda im: np.ptp(np.nonzero(white(im))[0]) + 1  # noqa: E731
    assert 6 <= tall(img) <= 8 and 19 <= tall(big) <= 22  # capitals about 7 scale tall
    edge = np.zeros((8, 8, 3), np.float32)
    demo.draw_text(edge, "GOURAUD", -3, 2, 1)
    assert edge.max() > 0.9
    with pytest.raises(ValueError, match="scale: must be >= 1"):
        demo.draw_text(edge, "X", 0, 0, 0)


def test_demo_scene_contents():
    scene = demo.demo_scene(64, 32)
    assert (scene.camera.width, scene.camera.height) == (64, 32)
    objects = scene.models[:3]
    xs = [m.mesh.bounds.mean(axis=0)[0] for m in objects]
    assert xs == sorted(xs) and min(np.diff(xs)) > 1.0  # three objects side by side
    assert all(len(m.mesh.faces) < 500 for m in objects)  # coarse on purpose
    assert all(m.material.has_specular for m in objects)
    points = [lt for lt in scene.lights if isinstance(lt, rs.PointLight)]
    dirs = [lt for lt in scene.lights if isinstance(lt, rs.DirectionalLight)]
    assert {lt.attenuation for lt in points} >= {"inverse_square", "heuristic"}
    assert dirs and np.ptp(dirs[0].color) > 0.1  # a coloured light at infinity


# -- render ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["shapes.toml", "knot.toml"])
def test_render_examples(capsys, tmp_path, name):
    out = tmp_path / "x.png"
    code, stdout, err = run(capsys, "render", EXAMPLES / name, "-o", out, "--width", 80, "--height", 60)
    assert code == 0 and err == ""
    img = iio.imread(out)
    assert img.shape == (60, 80, 3)
    assert img.mean() > 20 and img.std() > 10
    assert stdout.startswith(f"wrote {out} (80x60, phong): load ") and stdout.count("\n") == 1


def test_render_outputs_and_overrides(capsys, tmp_path, scene_file):
    path = scene_file('[object.material]\nks = 0.5\n[render]\nshading = "gouraud"\nwidth = 40\n')
    pfm, npy, png = tmp_path / "a.pfm", tmp_path / "a.npy", tmp_path / "a.png"
    code, stdout, _ = run(capsys, "render", path, "-o", pfm)
    assert code == 0 and "(40x48, gouraud)" in stdout  # [render] width beats [camera]
    code, stdout, _ = run(capsys, "render", path, "-o", npy, "--shading", "phong", "--width", 32, "--height", 24)
    assert code == 0 and "(32x24, phong)" in stdout  # the command line beats [render]
    assert rs.read_pfm(pfm).shape == (48, 40, 3)
    linear = np.load(npy)
    assert linear.shape == (24, 32, 3) and linear.dtype == np.float32
    code, _, _ = run(capsys, "render", path, "-o", png, "--shading", "phong", "--width", 32, "--height", 24,
                     "--exposure", 2, "--tonemap", "reinhard", "--gamma", 2.2)
    assert code == 0
    np.testing.assert_array_equal(iio.imread(png), rs.to_uint8(linear, exposure=2.0, tonemap="reinhard", gamma=2.2))


def test_render_choices_are_case_insensitive(capsys, tmp_path, scene_file):
    """Python takes shading="Phong"; so does the command line, and every other choice too."""
    path = scene_file('[object.material]\nks = 0.5\n')
    out = tmp_path / "a.npy"
    code, stdout, err = run(capsys, "render", path, "-o", out, "--shading", "Gouraud", "--backend", "Raster",
                            "--interpolation", "SCREEN", "--caster", "Embree")
    assert code == 0 and err == "" and "(64x48, gouraud)" in stdout
    scene, _ = load_scene(path)
    expected = rs.render(scene, "gouraud", backend="raster", interpolation="screen", caster="embree").image
    np.testing.assert_array_equal(np.load(out), expected)
    png = tmp_path / "a.png"  # tone options: 8-bit outputs only (a .npy with --tonemap is refused)
    code, stdout, err = run(capsys, "render", path, "-o", png, "--shading", "PHONG", "--tonemap", "Reinhard")
    assert code == 0 and err == ""
    frame = rs.render(scene, "phong")
    np.testing.assert_array_equal(iio.imread(png), frame.to_uint8(tonemap="reinhard"))


def test_render_default_output_name(capsys, tmp_path, scene_file, monkeypatch):
    path = scene_file()
    monkeypatch.chdir(tmp_path)
    code, stdout, _ = run(capsys, "render", path)
    assert code == 0 and (tmp_path / "scene.png").exists() and "wrote scene.png" in stdout


def test_png_writer_round_trip(tmp_path):
    rgb = np.random.default_rng(1).integers(0, 256, (7, 13, 3), dtype=np.uint8)
    _write_png(tmp_path / "r.png", rgb)
    np.testing.assert_array_equal(iio.imread(tmp_path / "r.png"), rgb)


# -- errors ---------------------------------------------------------------------------


@pytest.mark.parametrize("extra, fragments", [
    ("[object.material]\nshinyness = 3\n", ["object[0].material: unknown key 'shinyness'"]),
    ("[object.material]\nkd = -0.5\n", ["object[0].material.kd: must be >= 0"]),
    ("[object.material]\nshininess = 0\n", ["object[0].material.shininess: must be > 0"]),
    ("[object.material\n", ["invalid TOML"]),
], ids=["unknown key", "negative kd", "shininess 0", "TOML syntax"])
def test_bad_scene_file(capsys, tmp_path, scene_file, extra, fragments):
    path = scene_file(extra)
    out = tmp_path / "x.png"
    assert_one_line_error(*run(capsys, "render", path, "-o", out), str(path), *fragments)
    assert not out.exists()


def test_missing_files(capsys, tmp_path, scene_file):
    missing = tmp_path / "nope.toml"
    assert_one_line_error(*run(capsys, "render", missing, "-o", tmp_path / "x.png"), f"{missing}: No such file")
    path = scene_file().read_text().replace('shape = "uv_sphere"\nrings = 8\nsegments = 12', 'mesh = "gone.obj"')
    (tmp_path / "scene.toml").write_text(path)
    assert_one_line_error(*run(capsys, "render", tmp_path / "scene.toml", "-o", tmp_path / "x.png"),
                          "object[0].mesh: mesh file not found:", "gone.obj")


@pytest.mark.parametrize("argv, fragment", [
    (["demo", "--width", "0"], "argument --width: expected an integer > 0, got '0'"),
    (["demo", "--height", "x"], "argument --height: expected an integer > 0"),
    (["demo", "--gamma", "linear"], "argument --gamma: expected 'srgb' or a number > 0"),
    (["demo", "--exposure", "-1"], "argument --exposure: expected a finite number > 0"),
    (["demo", "--tonemap", "aces"], "argument --tonemap: invalid choice: 'aces'"),
    (["demo", "-o", "demo"], "has no extension"),
    (["demo", "-o", "demo.xyz"], "unknown image format '.xyz'"),
    (["demo", "-o", "demo.exr"], ".exr is not written; use .pfm or .npy"),
    (["demo", "-o", "no/such/folder/demo.png"], "does not exist"),
    (["render", "SCENE", "--shading", "smooth"], "argument --shading: invalid choice: 'smooth'"),
    (["render", "SCENE", "--caster", "optix"], "argument --caster: invalid choice"),
    (["render"], "the following arguments are required: SCENE.toml"),
    (["paint"], "invalid choice: 'paint'"),
    ([], "the following arguments are required: COMMAND"),
])
def test_bad_arguments(capsys, scene_file, argv, fragment):
    argv = [str(scene_file()) if a == "SCENE" else a for a in argv]
    assert_one_line_error(*run(capsys, *argv), fragment)


@pytest.mark.parametrize("output, fragment", [
    ("/proc/x.png", "output: '/proc/x.png' cannot be written"),   # a folder that refuses new files, even root's
    ("FOLDER/shelf.png", "shelf.png' is a folder, not a file"),
    ("FOLDER/x.tiff2", "unknown image format '.tiff2'"),
    ("FILE/x.png", "is not a folder"),
])
def test_render_refuses_an_unwritable_output_before_rendering(capsys, tmp_path, scene_file, monkeypatch, output,
                                                               fragment):
    def no_render(*args, **kwargs):
        raise AssertionError("rendered")

    # The module, not the function raycast_shade.render that the package's attribute of that name is.
    monkeypatch.setattr(sys.modules["raycast_shade.render"], "render_file", no_render)
    (tmp_path / "file").write_text("mine")
    (tmp_path / "shelf.png").mkdir()
    scene = scene_file()
    output = output.replace("FOLDER", str(tmp_path)).replace("FILE", str(tmp_path / "file"))
    before = sorted(p.name for p in tmp_path.iterdir())
    assert_one_line_error(*run(capsys, "render", scene, "-o", output), fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize("output, fragment", [
    ("/proc/set", "out_dir: '/proc/set' cannot be written"),
    ("FILE", "is a file, not a folder"),
    ("FILE/set", "cannot be made: "),
])
def test_views_refuse_an_unwritable_output_folder_before_rendering(capsys, tmp_path, monkeypatch, output, fragment):
    import raycast_shade.apps.views as views

    def no_render(*args, **kwargs):
        raise AssertionError("rendered")

    monkeypatch.setattr(views, "render", no_render)
    (tmp_path / "file").write_text("mine")
    output = output.replace("FILE", str(tmp_path / "file"))
    assert_one_line_error(*run(capsys, "views", EXAMPLES / "shapes.toml", "--orbit", "2", "--width", "16",
                               "--height", "12", "-o", output), fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"] and (tmp_path / "file").read_text() == "mine"


# -- info, help -----------------------------------------------------------------------


def test_info(capsys):
    from raycast_shade.visibility import embree as _embree

    code, out, err = run(capsys, "info")
    assert code == 0 and err == ""
    rows = dict(re.split(r"\s{2,}", line, maxsplit=1) for line in out.splitlines())
    assert rows["raycast_shade"] == rs.__version__
    assert rows["numpy"] == np.__version__
    assert rows["numba"] == __import__("numba").__version__
    assert rows["embree"] == _embree.embree_version()
    assert Path(rows["embree library"]).is_file()


def test_help_and_version(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0 and "examples:" in out and "raycast-shade render examples/shapes.toml" in out
    code, out, _ = run(capsys, "render", "--help")
    assert code == 0 and "--interpolation" in out and "--max-depth" in out
    code, out, _ = run(capsys, "--version")
    assert code == 0 and out.strip() == f"raycast-shade {rs.__version__}"


# -- a real process -------------------------------------------------------------------


def test_subprocess(tmp_path):
    out = tmp_path / "d.png"
    # The demo path must not import trimesh (half a second of start-up).
    code = ("import sys; from raycast_shade.apps.cli import main; "
            f"rc = main(['demo', '-o', {str(out)!r}, '--width', '48', '--height', '24']); "
            "print('trimesh' in sys.modules); sys.exit(rc)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines()[-1] == "False"
    assert iio.imread(out).shape == (76, 48, 3)

    res = subprocess.run([sys.executable, "-m", "raycast_shade", "render", str(tmp_path / "missing.toml")],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 2 and res.stdout == ""
    assert res.stderr.startswith("raycast-shade: error: ") and res.stderr.count("\n") == 1


@pytest.mark.filterwarnings("default::raycast_shade.WindingWarning")  # shown, even under -W error
def test_render_warns_in_one_line_about_inconsistent_winding(capsys, tmp_path, scene_file):
    """A mesh file whose faces disagree on their winding renders, and says why it may look wrong."""
    ico = rs.shapes.icosphere(2)
    faces = ico.faces.copy()
    faces[::5] = faces[::5, ::-1]
    lines = [f"v {x:.9f} {y:.9f} {z:.9f}" for x, y, z in ico.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    (tmp_path / "bad.obj").write_text("\n".join(lines) + "\n")
    text = scene_file().read_text().replace('shape = "uv_sphere"\nrings = 8\nsegments = 12', 'mesh = "bad.obj"')
    (tmp_path / "scene.toml").write_text(text)
    code, out, err = run(capsys, "render", tmp_path / "scene.toml", "-o", tmp_path / "x.png", "--shading", "phong")
    assert code == 0 and (tmp_path / "x.png").exists()
    assert err.startswith("raycast-shade: warning: bad.obj: ") and err.count("\n") == 1, err
    assert "wound in opposite directions" in err and "Traceback" not in err


def test_crease_angle_keeps_a_mesh_files_hard_edges(tmp_path, capsys):
    """An STL cube (no normals in the file): smoothed over its 90-degree edges, with the warning naming
    the flag; with --crease-angle 30 every face is flat, so under the mesh file's two directional
    lights and no specular term each visible face is one colour."""
    import trimesh

    path = tmp_path / "cube.stl"
    trimesh.creation.box().export(path)
    a, b = tmp_path / "smooth.png", tmp_path / "hard.png"
    code, out, err = run(capsys, "render", path, "-o", a, "--width", 64, "--height", 48)
    assert code == 0 and "edge(s) join faces at more than 60 degrees" in err and "--crease-angle 30" in err, err
    code, out, err = run(capsys, "render", path, "--crease-angle", 30, "-o", b, "--width", 64, "--height", 48)
    assert code == 0 and err == "", err
    colours = [np.unique(iio.imread(p).reshape(-1, 3), axis=0) for p in (a, b)]
    assert len(colours[1]) <= 4  # the background and at most three faces
    assert len(colours[0]) > 20  # smoothed: shades vary across each face


@pytest.mark.parametrize("argv, fragment", [
    (["--crease-angle", "0"], "argument --crease-angle: expected degrees in (0, 180], got '0'"),
    (["--crease-angle", "181"], "expected degrees in (0, 180]"),
    (["--crease-angle", "30"], "--crease-angle: for a mesh file; a scene file sets crease_angle per [[object]]"),
])
def test_crease_angle_refusals(scene_file, capsys, tmp_path, argv, fragment):
    assert_one_line_error(*run(capsys, "render", scene_file(), "-o", tmp_path / "x.png", *argv), fragment)
