"""Every front-end accepts the same choices and renders them the same.

The front-ends: a scene file's ``[render]`` table (through ``rs.render_file``),
``rs.render_file`` keyword overrides, ``raycast-shade render``,
``raycast-shade animate``, ``render_batch`` and ``animate``. Each renders a
small two-object scene with one option spelled as a user might (any case,
"auto", one method per model) and must give exactly the image of
``rs.render`` with the canonical (lower-case) value. A bad name gets a
ValueError naming the field from Python, and the command line's one-line
error with exit status 2.
"""

from __future__ import annotations

import argparse

import imageio.v3 as iio
import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps import animate as anim
from raycast_shade.apps import batch
from raycast_shade.apps.cli import build_parser, main
from raycast_shade.common import choices
from raycast_shade.scene.scenefile import SceneFileError, load_scene

SCENE = """\
ambient = 0.05
[camera]
eye = [0.0, 0.6, 4.0]
width = 24
height = 18

[[object]]
shape = "icosphere"
subdivisions = 2
translate = [-0.7, 0.0, 0.0]
[object.material]
ks = 0.6
shininess = 30
reflectivity = 0.4

[[object]]
shape = "icosphere"
subdivisions = 1
scale = 0.6
translate = [0.8, 0.0, 0.0]

[[light]]
type = "point"
position = [2.0, 3.0, 4.0]
intensity = 20.0
attenuation = "inverse_square"
"""

# (option, as given, as rs.render takes it); every entry of choices.py that a front-end names.
CASES = [("shading", s, s) for s in choices.SHADING_CHOICES] + [
    ("shading", "Phong", "phong"),
    ("shading", "GOURAUD", "gouraud"),
    ("shading", "Auto", "auto"),
    ("shading", ("flat", "Phong"), ("flat", "phong")),
] + [("backend", b, b) for b in choices.BACKENDS] + [
    ("backend", "Raster", "raster"),
] + [("interpolation", i, i) for i in choices.INTERPOLATIONS] + [
    ("interpolation", "SCREEN", "screen"),
] + [("caster", c, c) for c in choices.CASTER_CHOICES] + [
    ("caster", "Embree", "embree"),
    ("max_depth", 0, 0),
    ("max_depth", 1, 1),
]
IDS = [f"{k}={v if isinstance(v, (str, int)) else ','.join(v)}" for k, v, _ in CASES]


@pytest.fixture(scope="module")
def scene_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("frontends") / "two.toml"
    path.write_text(SCENE)
    return path


def _toml(value) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return str(value)


def _flag(key, value) -> list:
    text = ",".join(value) if isinstance(value, tuple) else str(value)
    return [f"--{key.replace('_', '-')}", text]


def via_scene_file(path, tmp, key, value):
    file = tmp / "with_render.toml"
    file.write_text(SCENE + f"\n[render]\n{key} = {_toml(value)}\n")
    return rs.render_file(file).image


def via_render_file(path, tmp, key, value):
    return rs.render_file(path, **{key: value}).image


def via_cli_render(path, tmp, key, value):
    out = tmp / "out.npy"
    assert main(["render", str(path), "-o", str(out)] + _flag(key, value)) == 0
    return np.load(out)


def via_render_batch(path, tmp, key, value):
    scene, _ = load_scene(path)
    kw = {key: value}
    (image,) = batch.render_batch(scene, shading=kw.pop("shading", "phong"), run=rs.RunOptions(progress=False), **kw)
    return image


def via_animate(path, tmp, key, value):
    scene, _ = load_scene(path)
    kw = {key: value}
    anim.animate(scene, str(tmp / "seq") + "/", frames=1, shading=kw.pop("shading", "phong"),
                 run=rs.RunOptions(progress=False), **kw)
    return iio.imread(tmp / "seq" / "frame_00000.png")


def via_cli_animate(path, tmp, key, value):
    out = tmp / "cli_seq"
    assert main(["animate", str(path), "--frames", "1", "--no-progress", "-o", f"{out}/"] + _flag(key, value)) == 0
    return iio.imread(out / "frame_00000.png")


FRONTENDS = [via_scene_file, via_render_file, via_cli_render, via_render_batch, via_animate, via_cli_animate]
# Animations write 8-bit PNG frames from the orbit's first camera.
EIGHT_BIT = {via_animate, via_cli_animate}


@pytest.mark.parametrize("frontend", FRONTENDS, ids=lambda f: f.__name__[4:])
@pytest.mark.parametrize("key, given, canonical", CASES, ids=IDS)
def test_every_frontend_accepts_every_choice(scene_path, tmp_path, capsys, frontend, key, given, canonical):
    scene, _ = load_scene(scene_path)
    camera = anim.orbit_cameras(scene.camera, 1)[0] if frontend in EIGHT_BIT else scene.camera
    kw = {key: canonical}
    expected = rs.render(scene, kw.pop("shading", "phong"), camera=camera, **kw).image
    got = frontend(scene_path, tmp_path, key, given)
    capsys.readouterr()
    if frontend in EIGHT_BIT:
        np.testing.assert_array_equal(got, rs.to_uint8(expected))
    else:
        assert got.dtype == np.float32
        np.testing.assert_array_equal(got, expected)


def test_the_cases_tell_the_options_apart(scene_path):
    """The matrix above is not vacuous: each option changes this scene's image."""
    scene, _ = load_scene(scene_path)
    base = rs.render(scene, "phong").image
    for kw in ({"shading": "flat"}, {"backend": "raster", "interpolation": "screen", "shading": "gouraud"},
               {"max_depth": 0}, {"shading": ("flat", "phong")}):
        kw = dict(kw)
        assert not np.array_equal(rs.render(scene, kw.pop("shading", "phong"), **kw).image, base), kw


# -- bad names -------------------------------------------------------------------------------------------

BAD = [("shading", "toon"), ("shading", ("flat", "toon")), ("backend", "gpu"), ("interpolation", "cubic"),
       ("caster", "optix"), ("tonemap", "aces")]


def _assert_one_line_error(code, out, err, *fragments):
    assert code == 2 and out == ""
    assert err.startswith("raycast-shade: error: ") and err.count("\n") == 1 and "Traceback" not in err
    for f in fragments:
        assert f in err, err


@pytest.mark.parametrize("command", ["render", "animate"])
@pytest.mark.parametrize("key, bad", BAD, ids=[f"{k}={v}" for k, v in BAD])
def test_cli_rejects_a_bad_name_in_one_line(scene_path, tmp_path, capsys, command, key, bad):
    out = tmp_path / ("x.png" if command == "render" else "x.gif")
    code = main([command, str(scene_path), "-o", str(out)] + _flag(key, bad))
    _assert_one_line_error(code, *capsys.readouterr(), f"argument --{key}: invalid choice: 'toon'"
                           if key == "shading" else f"argument --{key}: invalid choice: {bad!r}")
    assert not out.exists()


@pytest.mark.parametrize("command", ["render", "animate"])
@pytest.mark.parametrize("key, bad", BAD, ids=[f"{k}={v}" for k, v in BAD])
def test_cli_rejects_a_bad_name_in_the_scene_file(tmp_path, capsys, command, key, bad):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE + f"\n[render]\n{key} = {_toml(bad)}\n")
    code = main([command, str(path), "-o", str(tmp_path / ("x.png" if command == "render" else "x.gif"))])
    _assert_one_line_error(code, *capsys.readouterr(), str(path), f"render.{key}", "toon" if key == "shading"
                           else bad)


@pytest.mark.parametrize("key, bad", BAD, ids=[f"{k}={v}" for k, v in BAD])
def test_python_frontends_name_the_bad_field(scene_path, tmp_path, key, bad):
    scene, _ = load_scene(scene_path)
    with pytest.raises(ValueError, match=rf"^{key}"):
        rs.render_file(scene_path, **{key: bad})
    tone = {key: bad} if key == "tonemap" else None
    kw = {} if key in ("shading", "tonemap") else {key: bad}
    shading = bad if key == "shading" else "phong"
    with pytest.raises(ValueError, match=rf"^{key}"):
        batch.render_batch(scene, shading=shading, tone=tone, run=rs.RunOptions(progress=False), **kw)
    with pytest.raises(ValueError, match=rf"^{key}"):
        anim.animate(scene, tmp_path / "a.gif", frames=1, shading=shading, tone=tone,
                     run=rs.RunOptions(progress=False), **kw)
    path = tmp_path / "bad.toml"
    path.write_text(SCENE + f"\n[render]\n{key} = {_toml(bad)}\n")
    with pytest.raises(SceneFileError, match=rf"render\.{key}"):
        load_scene(path)


def test_one_method_per_model_must_count_the_models(scene_path, tmp_path, capsys):
    scene, _ = load_scene(scene_path)
    three = ("flat", "phong", "gouraud")
    with pytest.raises(ValueError, match="shading: expected one method per"):
        rs.render_file(scene_path, shading=three)
    with pytest.raises(ValueError, match="shading: expected one method per model"):
        batch.render_batch(scene, shading=three, run=rs.RunOptions(progress=False))
    with pytest.raises(ValueError, match="shading: expected one method per model"):
        anim.animate(scene, tmp_path / "a.gif", frames=1, shading=three, run=rs.RunOptions(progress=False))
    path = tmp_path / "three.toml"
    path.write_text(SCENE + '\n[render]\nshading = ["flat", "phong", "gouraud"]\n')
    with pytest.raises(SceneFileError, match=r"render\.shading: expected one method per \[\[object\]\] \(2\), got 3"):
        load_scene(path)
    code = main(["render", str(scene_path), "-o", str(tmp_path / "x.png"), "--shading", "flat,phong,gouraud"])
    _assert_one_line_error(code, *capsys.readouterr(), "shading: expected one method per [[object]]")


def test_cli_choices_come_from_choices_py():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    want = {"--backend": choices.BACKEND_CHOICES, "--interpolation": choices.INTERPOLATIONS,
            "--caster": choices.CASTER_CHOICES, "--tonemap": choices.TONEMAPS}
    for command in ("render", "animate"):
        actions = {s: a for a in sub.choices[command]._actions for s in a.option_strings}
        for flag, values in want.items():
            assert tuple(actions[flag].choices) == values, (command, flag)
    animate_actions = {s: a for a in sub.choices["animate"]._actions for s in a.option_strings}
    assert tuple(animate_actions["--orbit"].choices) == choices.ORBITS
    demo_actions = {s: a for a in sub.choices["demo"]._actions for s in a.option_strings}
    assert tuple(demo_actions["--tonemap"].choices) == choices.TONEMAPS


# -- render_file -----------------------------------------------------------------------------------------

RENDER_TABLE = """
[render]
shading = "Gouraud"
width = 20
height = 14
max_depth = 1
exposure = 1.5
tonemap = "Reinhard"
gamma = 2.2
"""


def test_render_file_equals_load_scene_and_render(tmp_path):
    path = tmp_path / "opts.toml"
    path.write_text(SCENE + RENDER_TABLE)
    frame = rs.render_file(path)
    scene, options = load_scene(path)
    assert options["shading"] == "gouraud" and (scene.camera.width, scene.camera.height) == (20, 14)
    explicit = rs.render(scene, "gouraud", max_depth=1)
    np.testing.assert_array_equal(frame.image, explicit.image)
    assert frame.image.shape == (14, 20, 3) and frame.shading == "gouraud"
    assert frame.tone == {"exposure": 1.5, "tonemap": "reinhard", "gamma": 2.2}
    assert not np.array_equal(explicit.image, rs.render(scene, "gouraud", max_depth=0).image)  # max_depth counts
    # Saving honours the file's tone options; keywords given to save() win.
    tone = dict(exposure=1.5, tonemap="reinhard", gamma=2.2)
    frame.save(tmp_path / "a.png")
    np.testing.assert_array_equal(iio.imread(tmp_path / "a.png"), rs.to_uint8(explicit.image, **tone))
    frame.save(tmp_path / "b.png", gamma=1.0)
    np.testing.assert_array_equal(iio.imread(tmp_path / "b.png"), rs.to_uint8(explicit.image, **dict(tone, gamma=1.0)))
    np.testing.assert_array_equal(frame.to_uint8(), rs.to_uint8(explicit.image, **tone))
    assert rs.render(scene).tone == {}  # render() itself carries no tone


def test_render_file_overrides_beat_the_file(tmp_path):
    path = tmp_path / "opts.toml"
    path.write_text(SCENE + RENDER_TABLE)
    frame = rs.render_file(path, shading="flat", width=12, max_depth=0, exposure=None, gamma="sRGB")
    scene, _ = load_scene(path)
    np.testing.assert_array_equal(frame.image, rs.render(scene, "flat", camera=scene.camera.replace(width=12),
                                                         max_depth=0).image)
    assert frame.image.shape == (14, 12, 3)
    assert frame.tone == {"exposure": 1.5, "tonemap": "reinhard", "gamma": "srgb"}  # None kept the file's exposure
    with pytest.raises(TypeError, match="unknown option 'shadng'.*'shading'"):
        rs.render_file(path, shadng="flat")
    with pytest.raises(ValueError, match="width: must be >= 1"):
        rs.render_file(path, width=0)


def test_cli_render_is_render_file(tmp_path, capsys):
    path = tmp_path / "opts.toml"
    path.write_text(SCENE + RENDER_TABLE)
    assert main(["render", str(path), "-o", str(tmp_path / "cli.png"), "--shading", "flat,Phong"]) == 0
    assert "(20x14, flat,phong)" in capsys.readouterr().out
    frame = rs.render_file(path, shading=("flat", "phong"))
    np.testing.assert_array_equal(iio.imread(tmp_path / "cli.png"), frame.to_uint8())


def test_animate_takes_max_depth_from_the_scene_file(tmp_path, capsys):
    """The animate command used to drop [render] max_depth; now it is the file's unless overridden."""
    path = tmp_path / "deep.toml"
    path.write_text(SCENE + "\n[render]\nmax_depth = 0\n")
    assert main(["animate", str(path), "--frames", "1", "--no-progress", "-o", f"{tmp_path / 'a'}/"]) == 0
    assert main(["animate", str(path), "--frames", "1", "--no-progress", "--max-depth", "2",
                 "-o", f"{tmp_path / 'b'}/"]) == 0
    capsys.readouterr()
    scene, _ = load_scene(path)
    camera = anim.orbit_cameras(scene.camera, 1)[0]
    for folder, depth in (("a", 0), ("b", 2)):
        expected = rs.to_uint8(rs.render(scene, camera=camera, max_depth=depth).image)
        np.testing.assert_array_equal(iio.imread(tmp_path / folder / "frame_00000.png"), expected)
    assert not np.array_equal(iio.imread(tmp_path / "a" / "frame_00000.png"),
                              iio.imread(tmp_path / "b" / "frame_00000.png"))
