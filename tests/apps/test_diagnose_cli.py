"""raycast-shade diagnose --map: the path is checked before the scene loads or anything renders
(issue 45): one line, exit status 2, nothing written."""

from __future__ import annotations

import os

import numpy as np
import pytest

from raycast_shade.apps.cli import main
from raycast_shade.output.imagefile import write_png

SCENE_TOML = """
ambient = 0.1
[camera]
eye = [0, 0, 4]
width = 32
height = 24
[[object]]
shape = "icosphere"
subdivisions = 2
[[light]]
type = "point"
position = [2, 3, 4]
"""


@pytest.fixture()
def files(tmp_path, monkeypatch):
    """A scene file and a (non-blank) student image; loading the scene or diagnosing fails the test."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE_TOML)
    student = tmp_path / "student.png"
    write_png(str(student), np.random.default_rng(0).integers(0, 256, (24, 32, 3), dtype=np.uint8))

    def boom(*args, **kwargs):
        raise RuntimeError("work began before --map was checked")  # printed by main, exit 2

    monkeypatch.setattr("raycast_shade.scene.scenefile.load_for_render", boom)
    monkeypatch.setattr("raycast_shade.apps.diagnose.diagnose", boom)
    return scene, student


def _listing(folder):
    return sorted(os.listdir(folder))


@pytest.mark.parametrize("where, match", [
    ("missing/map.png", "does not exist"),
    ("afolder", "is a folder"),
    ("afolder.png", "is a folder"),
    ("map.jpg", "written as PNG"),
    ("map", "written as PNG"),
    ("", "empty path"),
])
def test_bad_map_path_is_refused_before_any_work(files, tmp_path, capsys, where, match):
    scene, student = files
    (tmp_path / "afolder").mkdir()
    (tmp_path / "afolder.png").mkdir()
    before = _listing(tmp_path)
    target = str(tmp_path / where) if where else ""
    assert main(["diagnose", str(scene), str(student), "--map", target]) == 2
    captured = capsys.readouterr()
    err = captured.err
    assert err.count("\n") == 1 and "error: --map:" in err and match in err, err
    assert "Traceback" not in err and captured.out == ""
    assert _listing(tmp_path) == before and _listing(tmp_path / "afolder") == _listing(tmp_path / "afolder.png") == []


def test_map_under_a_file_is_refused(files, tmp_path, capsys):
    scene, student = files
    assert main(["diagnose", str(scene), str(student), "--map", str(student / "map.png")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error: --map:" in err


def test_good_map_path_goes_on_to_the_work(files, tmp_path, capsys):
    """A writable .png path (any case) passes the check; the work then begins (here: the stub)."""
    scene, student = files
    for name in ("map.png", "MAP.PNG"):
        assert main(["diagnose", str(scene), str(student), "--map", str(tmp_path / name)]) == 2
        assert "work began before --map was checked" in capsys.readouterr().err
    assert not (tmp_path / "map.png").exists()
