"""Every writer's output path is checked before any work: ``animate`` (command line and Python),
``write_animation`` and ``Animation.save``, batches' ``out_dir``, and the explorer's saves.

A missing folder, a file where a folder goes, a folder where a file goes, an unwritable place
(``/proc``, which refuses new files even to root, or ``os.access`` denied) and an extension the
format does not have: one ``ValueError`` (one ``raycast-shade: error:`` line, exit 2) naming the
argument, nothing written, no scene loaded and no frame rendered.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps import animate as animate_module
from raycast_shade.apps.animate import animate, write_animation
from raycast_shade.apps.batch import driver, render_batch
from raycast_shade.apps.movie import Animation
from tests.apps.test_cli_contract import assert_contract, run, workdir  # noqa: F401 - the fixture


def _no_work(*a, **k):
    raise AssertionError("worked before checking the output")


@pytest.fixture
def guarded(monkeypatch):
    """Loading a scene file or rendering a frame fails the test."""
    monkeypatch.setattr(sys.modules["raycast_shade.scene.scenefile"], "load_for_render", _no_work)
    monkeypatch.setattr(animate_module, "iter_batch", _no_work)
    monkeypatch.setattr(animate_module, "render_batch", _no_work)


def _listing(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


@pytest.mark.parametrize("output, fragment", [
    ("missing/a.gif", "folder"),  # a missing folder
    ("afile/a.gif", "is not a folder"),  # a file where the folder goes
    ("afile/frames/", "cannot be made: "),  # frames under a file
    ("afile", "'afile' is a file, not a folder"),  # a name without extension is a frames folder
    ("/proc/a.gif", "cannot be written"),  # unwritable, even for root
    ("ro/a.mp4", "cannot be written (no write permission"),
    ("ro/frames/", "cannot be written (no write permission"),
    ("a.png", "expected .gif"),  # an extension that is not the format's
    ("a.jpg", "expected .gif"),
])
def test_animate_checks_its_output_before_loading_or_rendering(capsys, workdir, monkeypatch, guarded, output,
                                                               fragment):
    (workdir / "ro").mkdir()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if os.fspath(p).endswith("/ro") else real(p, mode))
    before = _listing(workdir)
    code, out, err = run(capsys, ["animate", "good.toml", "--frames", "2", "--no-progress", "-o", output])
    assert_contract(code, out, err, "output: ")
    assert fragment in err, err
    assert _listing(workdir) == before  # nothing written, not even the probe


def test_the_default_output_is_checked_too(capsys, workdir, monkeypatch, guarded):
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if os.fspath(p) == str(workdir) else real(p, mode))
    assert_contract(*run(capsys, ["animate", "good.toml", "--frames", "2", "--no-progress"]),
                    "output: 'good_camera.gif' cannot be written")


def _scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(1), rs.Material())], lights=[rs.PointLight((2, 3, 4))],
                    camera=rs.Camera(eye=(0, 0, 4), width=16, height=12))


@pytest.mark.parametrize("output", ["missing/a.gif", "afile/a.mp4", "/proc/a.gif", "afile", "a.bmp"])
def test_python_animate_refuses_before_any_frame(workdir, monkeypatch, guarded, output):
    with pytest.raises(ValueError, match=r"^output: "):
        animate(_scene(), output, frames=2)


def test_write_animation_checks_before_drawing_a_frame(workdir):
    drawn = []

    def images():
        drawn.append(1)
        yield np.zeros((4, 4, 3), np.uint8)

    for output in ("missing/a.gif", "/proc/a.mp4", "afile/a.gif"):
        with pytest.raises(ValueError, match=r"^output: "):
            write_animation(images(), output)
    assert drawn == []
    anim = Animation(np.zeros((2, 4, 4, 3), np.uint8))
    with pytest.raises(ValueError, match=r"^output: .*does not exist"):
        anim.save("missing/a.gif")
    assert anim.save("ok.gif") == 2 and (workdir / "ok.gif").stat().st_size > 0  # the valid neighbour writes


@pytest.mark.parametrize("out_dir, fragment", [("afile", "is a file, not a folder"),
                                               ("afile/sub", "cannot be made: "),
                                               ("/proc/frames", "cannot be written")])
def test_a_batch_out_dir_is_checked_before_any_frame(workdir, monkeypatch, out_dir, fragment):
    monkeypatch.setattr(driver, "plan_batch", _no_work)  # the first step of the work
    cams = [_scene().camera] * 2
    with pytest.raises(ValueError, match=r"^out_dir: ") as info:
        render_batch(_scene(), cams, out_dir=out_dir)
    assert fragment in str(info.value)


def test_a_missing_batch_folder_is_still_made(workdir):
    paths = render_batch(_scene(), [_scene().camera], out_dir="new/frames")
    assert [os.path.basename(p) for p in paths] == ["frame_00000.png"] and os.path.isfile(paths[0])


def test_the_explorers_save_places_are_checked(workdir):
    pytest.importorskip("ipywidgets")
    from raycast_shade.apps.explore import Explorer

    with pytest.raises(ValueError, match=r"^save_dir: 'afile' is a file, not a folder"):
        Explorer(_scene(), save_dir="afile")
    with pytest.raises(TypeError, match=r"^save_dir: expected a path, got NoneType"):
        Explorer(_scene(), save_dir=None)
    ex = Explorer(_scene(), save_dir="shots/new")  # made on the first save
    for path, fragment in (("folder.png", "is a folder, not a file"), ("missing/x.png", "does not exist"),
                           ("/proc/x.png", "cannot be written")):
        with pytest.raises(ValueError, match=r"^path: ") as info:
            ex.save(path)
        assert fragment in str(info.value)
    assert ex.save() == os.path.join("shots/new", "explorer_001.png")
    assert (workdir / "shots/new/explorer_001.png").stat().st_size > 0
