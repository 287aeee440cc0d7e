"""Honest resumes of view sets: the plan is written first, a folder of another plan is refused
(saying what differs) or replaced on request, and only views whose files match the plan are kept.

The three stale cases of issue 26 (more views, another buffer, another size), a killed run, a
view killed between its files, 0-byte and corrupted files, view files without a plan, and a huge
camera refused before anything is written. "Equal to a fresh run" compares every file byte for
byte.
"""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest

import raycast_shade as rs
import raycast_shade.apps.views as views
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.cli import main
from raycast_shade.apps.viewplan import PLAN_FORMAT
from raycast_shade.apps.views import INDEX_NAME, PLAN_NAME, render_views
from raycast_shade.output.bufferfile import load_npz

W, H = 24, 18


@pytest.fixture(scope="module")
def scene():
    s = rs.Scene([rs.Model(rs.shapes.icosphere(1)), rs.Model(rs.shapes.plane(size=4.0, center=(0, 0, -1.2)))],
                 lights=[rs.PointLight((2, 3, 4), intensity=20)],
                 camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=W, height=H))
    rs.render(s, buffers=("zdepth",))
    return s


@pytest.fixture
def counted(monkeypatch):
    """Counts the renders of render_views (its module's own ``render``)."""
    calls = []
    real = views.render

    def render(scene, *args, **kwargs):
        calls.append(kwargs["camera"])
        return real(scene, *args, **kwargs)

    monkeypatch.setattr(views, "render", render)
    return calls


def _stamps(folder):
    return {n: os.stat(folder / n).st_mtime_ns for n in sorted(os.listdir(folder))}


def _same_set(a, b):
    """The two folders hold the same files, byte for byte (npz, EXR, PNG, records, plan and index)."""
    names = sorted(os.listdir(a))
    assert names == sorted(os.listdir(b))
    for name in names:
        if os.path.isdir(a / name):
            _same_set(a / name, b / name)
        else:
            assert (a / name).read_bytes() == (b / name).read_bytes(), name


@pytest.mark.parametrize("case", ["more views", "another buffer", "another size"])
def test_a_folder_of_another_plan_is_refused_then_replaced(scene, tmp_path, case):
    cams = orbit_cameras(scene.camera, 4)
    render_views(scene, cams, tmp_path / "set", files=rs.ViewFiles(buffers=["zdepth"]))
    before = _stamps(tmp_path / "set")
    buffers = ["zdepth"]
    if case == "more views":
        cams, expect = orbit_cameras(scene.camera, 6), ["4 views -> 6", "camera of 3 of the 4 shared views"]
    elif case == "another buffer":
        buffers, expect = ["zdepth", "position"], ['buffers ["zdepth"] -> ["zdepth", "position"]']
    else:
        cams = [c.replace(width=2 * W, height=2 * H) for c in cams]
        expect = [f"size {W}x{H} -> {2 * W}x{2 * H}", "camera of 4 of the 4 shared views"]
    with pytest.raises(ValueError, match="holds another view set") as info:
        render_views(scene, cams, tmp_path / "set", files=rs.ViewFiles(buffers=buffers))
    for words in expect:
        assert words in str(info.value)
    assert "overwrite=True" in str(info.value)
    assert _stamps(tmp_path / "set") == before  # nothing written, nothing removed
    render_views(scene, cams, tmp_path / "set", overwrite=True, files=rs.ViewFiles(buffers=buffers))
    render_views(scene, cams, tmp_path / "fresh", files=rs.ViewFiles(buffers=buffers))
    _same_set(tmp_path / "set", tmp_path / "fresh")
    index = json.load(open(tmp_path / "set" / INDEX_NAME))
    for view, cam in zip(index["views"], cams):
        npz = load_npz(tmp_path / "set" / view["files"]["npz"])
        assert set(npz) == set(buffers) | {"K", "R", "t"}  # no float image unless asked
        assert npz["zdepth"].shape == (cam.height, cam.width)
        assert np.array_equal(npz["K"], cam.K) and np.array_equal(view["K"], cam.K)


def test_overwrite_keeps_only_the_views_that_match(scene, tmp_path, counted):
    cams = orbit_cameras(scene.camera, 4)
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))
    more = orbit_cameras(scene.camera, 8)  # every other camera is one of the 4
    counted.clear()
    render_views(scene, more, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]), overwrite=True)
    # View i of 8 matches view i of 4 only where the camera is the same: view 0 alone.
    assert len(counted) == 7
    assert all(c is not more[0] for c in counted)


def test_a_killed_run_resumes_where_it_stopped(scene, tmp_path, monkeypatch):
    cams = orbit_cameras(scene.camera, 5)
    real = views.render
    counted = []

    def killed_at_third(scene, *args, **kwargs):
        if len(counted) == 2:
            raise KeyboardInterrupt
        counted.append(kwargs["camera"])
        return real(scene, *args, **kwargs)

    monkeypatch.setattr(views, "render", killed_at_third)
    with pytest.raises(KeyboardInterrupt):
        render_views(scene, cams, tmp_path / "set",
                     files=rs.ViewFiles(buffers=["zdepth", "id"], formats=["npz", "depth_png"]))
    assert not (tmp_path / "set" / INDEX_NAME).exists() and (tmp_path / "set" / PLAN_NAME).exists()
    done = _stamps(tmp_path / "set")
    monkeypatch.undo()
    calls = []
    monkeypatch.setattr(views, "render", lambda s, *a, **k: (calls.append(k["camera"]), real(s, *a, **k))[1])
    render_views(scene, cams, tmp_path / "set",
                 files=rs.ViewFiles(buffers=["zdepth", "id"], formats=["npz", "depth_png"]))
    assert calls == cams[2:]
    after = _stamps(tmp_path / "set")
    assert all(after[n] == t for n, t in done.items() if n.startswith(("view_00000", "view_00001")))
    render_views(scene, cams, tmp_path / "fresh",
                 files=rs.ViewFiles(buffers=["zdepth", "id"], formats=["npz", "depth_png"]))
    _same_set(tmp_path / "set", tmp_path / "fresh")


def test_a_view_killed_between_its_files_is_rendered_again(scene, tmp_path, counted, monkeypatch):
    cams = orbit_cameras(scene.camera, 3)
    real = views.write_hashed  # every file of a view but a non-PNG image goes through it

    def fail_on_view_1(path, *args, **kwargs):
        if "view_00001_depth" in os.fspath(path):
            raise OSError("disk full")
        return real(path, *args, **kwargs)

    monkeypatch.setattr(views, "write_hashed", fail_on_view_1)
    with pytest.raises(OSError, match="disk full"):
        render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"], formats=["npz", "depth_png"]))
    assert (tmp_path / "view_00001.npz").exists() and not (tmp_path / "view_00001.json").exists()
    monkeypatch.setattr(views, "write_hashed", real)
    counted.clear()
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"], formats=["npz", "depth_png"]))
    assert counted == cams[1:]  # view 1 (npz but no record) and view 2 (never reached)


@pytest.mark.parametrize("damage", ["empty", "same size", "record gone", "file gone"])
def test_damaged_views_are_rendered_again(scene, tmp_path, counted, damage):
    cams = orbit_cameras(scene.camera, 3)
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth", "normal"]))
    target = tmp_path / "view_00001.npz"
    if damage == "empty":
        target.write_bytes(b"")
    elif damage == "same size":
        data = bytearray(target.read_bytes())
        data[len(data) // 2] ^= 0xFF
        target.write_bytes(bytes(data))
    elif damage == "record gone":
        os.remove(tmp_path / "view_00001.json")
    else:
        os.remove(target)
    counted.clear()
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth", "normal"]))
    assert counted == [cams[1]]
    fresh = rs.render(scene, camera=cams[1], buffers=("zdepth", "normal"))
    assert np.array_equal(load_npz(target)["normal"], fresh.buffers["normal"])
    counted.clear()
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth", "normal"]))
    assert counted == []  # all intact now


def test_view_files_without_a_plan_are_refused(scene, tmp_path):
    (tmp_path / "view_00000.npz").write_bytes(b"from elsewhere")
    with pytest.raises(ValueError, match="1 view set file \\(e.g. view_00000.npz\\) but no plan.json"):
        render_views(scene, orbit_cameras(scene.camera, 2), tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))
    assert sorted(os.listdir(tmp_path)) == ["view_00000.npz"]
    (tmp_path / "notes.txt").write_text("mine")
    render_views(scene, orbit_cameras(scene.camera, 2), tmp_path, files=rs.ViewFiles(buffers=["zdepth"]),
                 overwrite=True)
    assert (tmp_path / "notes.txt").read_text() == "mine"  # not a view set file: left alone
    assert load_npz(tmp_path / "view_00000.npz")["zdepth"].shape == (H, W)


def test_an_unreadable_plan_is_refused(scene, tmp_path):
    (tmp_path / PLAN_NAME).write_text("{not json")
    with pytest.raises(ValueError, match="plan.json cannot be read"):
        render_views(scene, orbit_cameras(scene.camera, 2), tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))


@pytest.mark.parametrize("edit, fragment", [
    (lambda plan: [plan], "plan.json holds a JSON list, not an object"),
    (lambda plan: {**plan, "format": "mine"}, 'plan.json has format "mine"'),
    (lambda plan: {**plan, "settings": [["buffers", "zdepth"]]}, "plan.json's 'settings' is not a JSON object"),
    (lambda plan: {**plan, "views": {"0": plan["views"][0]}}, "plan.json's 'views' is not a JSON list"),
    (lambda plan: {**plan, "views": [plan["views"][0], 7]}, "plan.json's views[1] is not a JSON object"),
    (lambda plan: {**plan, "views": [{**v, "camera": "edited"} for v in plan["views"]]},
     "the camera of 2 of the 2 shared views differs"),
])
def test_a_plan_edited_by_hand_is_refused_saying_what_is_wrong(scene, tmp_path, counted, edit, fragment):
    cams, files = orbit_cameras(scene.camera, 2), rs.ViewFiles(buffers=["zdepth"])
    render_views(scene, cams, tmp_path, files=files)
    plan = json.load(open(tmp_path / PLAN_NAME))
    (tmp_path / PLAN_NAME).write_text(json.dumps(edit(plan)))
    before, counted[:] = _stamps(tmp_path), []
    with pytest.raises(ValueError, match="out_dir: .* holds another view set: " + re.escape(fragment)):
        render_views(scene, cams, tmp_path, files=files)
    assert counted == [] and _stamps(tmp_path) == before  # nothing rendered, nothing written
    render_views(scene, cams, tmp_path, files=files, overwrite=True)  # replaced on request
    assert json.load(open(tmp_path / PLAN_NAME)) == plan


def test_a_deleted_plan_or_a_folder_in_its_place_is_refused_before_any_view(scene, tmp_path, counted):
    cams, files = orbit_cameras(scene.camera, 2), rs.ViewFiles(buffers=["zdepth"])
    render_views(scene, cams, tmp_path, files=files)
    (tmp_path / PLAN_NAME).unlink()
    before, counted[:] = _stamps(tmp_path), []
    with pytest.raises(ValueError, match="out_dir: .*but no plan.json \\(deleted\\?\\)"):
        render_views(scene, cams, tmp_path, files=files)
    (tmp_path / PLAN_NAME).mkdir()
    before = _stamps(tmp_path)
    with pytest.raises(ValueError, match="out_dir: .*plan.json' is a folder where the view set writes a file"):
        render_views(scene, cams, tmp_path, files=files, overwrite=True)
    assert counted == [] and _stamps(tmp_path) == before  # even with overwrite: no view file deleted


def test_cli_names_an_edited_plan_in_one_line(tmp_path, capsys):
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    args = ["views", os.path.join(root, "examples", "shapes.toml"), "--buffers", "zdepth", "--width", "16",
            "--height", "12", "--orbit", "2", "-o", str(tmp_path)]
    assert main(args) == 0
    (tmp_path / PLAN_NAME).write_text(json.dumps({"format": PLAN_FORMAT, "settings": [], "views": []}))
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "plan.json's 'settings' is not a JSON object" in err and "Traceback" not in err


def test_a_huge_third_camera_is_refused_before_anything_is_written(scene, tmp_path, counted):
    cams = orbit_cameras(scene.camera, 3)
    cams[2] = cams[2].replace(width=10**6, height=10**6)
    with pytest.raises(ValueError, match="cameras\\[2\\]: camera.width x camera.height"):
        render_views(scene, cams, tmp_path / "set", files=rs.ViewFiles(buffers=["zdepth"]))
    assert counted == [] and not (tmp_path / "set").exists()


def test_cli_refuses_another_plan_in_one_line_and_overwrites_on_request(tmp_path, capsys):
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    toml = os.path.join(root, "examples", "shapes.toml")
    args = ["views", toml, "--buffers", "zdepth", "--width", "16", "--height", "12", "-o", str(tmp_path)]
    assert main(args + ["--orbit", "2"]) == 0
    capsys.readouterr()
    assert main(args + ["--orbit", "3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "2 views -> 3" in err and "--overwrite" in err and "Traceback" not in err
    assert main(args + ["--orbit", "3", "--overwrite"]) == 0
    assert len(json.load(open(tmp_path / INDEX_NAME))["views"]) == 3


def test_an_export_asked_later_renders_nothing_again(scene, tmp_path, counted):
    cams = orbit_cameras(scene.camera, 3)
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]))
    counted.clear()
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth"]), exports=["coco", "nerfstudio"])
    assert counted == []
    coco = json.load(open(tmp_path / "coco_instances.json"))
    assert len(coco["images"]) == 3 and len(coco["annotations"]) >= 3
    assert len(json.load(open(tmp_path / "transforms.json"))["frames"]) == 3


def test_overwrite_removes_only_the_other_plans_files(scene, tmp_path):
    render_views(scene, orbit_cameras(scene.camera, 3), tmp_path, files=rs.ViewFiles(buffers=["zdepth"]),
                 exports=["nerfstudio"])
    (tmp_path / "view_00001.txt").write_text("my notes")  # named like a view file, but not the plan's
    render_views(scene, orbit_cameras(scene.camera, 2), tmp_path, files=rs.ViewFiles(buffers=["zdepth"]),
                 overwrite=True)
    names = set(os.listdir(tmp_path))
    assert "view_00001.txt" in names and "view_00002.npz" not in names and "view_00002.json" not in names
    assert "transforms.json" not in names  # a set-level file of the other plan
    assert len(json.load(open(tmp_path / INDEX_NAME))["views"]) == 2


_KILLED_RUN = """
import sys, time
import raycast_shade as rs
import raycast_shade.apps.views as views
from raycast_shade.apps.animate import orbit_cameras
real = views.render
def slow(*a, **k):
    time.sleep(0.3)  # room to be killed between views
    return real(*a, **k)
views.render = slow
s = rs.Scene([rs.Model(rs.shapes.icosphere(1)), rs.Model(rs.shapes.plane(size=4.0, center=(0, 0, -1.2)))],
             lights=[rs.PointLight((2, 3, 4), intensity=20)], camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=24, height=18))
views.render_views(s, orbit_cameras(s.camera, 10), sys.argv[1], buffers=["zdepth", "id"], formats=["npz", "exr"])
"""


def test_a_process_killed_with_sigkill_resumes_to_the_same_set(scene, tmp_path, counted):
    import signal
    import subprocess
    import sys
    import time

    folder = tmp_path / "set"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (os.path.dirname(os.path.dirname(
        os.path.abspath(views.__file__))), os.environ.get("PYTHONPATH")) if p))
    proc = subprocess.Popen([sys.executable, "-c", _KILLED_RUN, str(folder)], env=env)
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and proc.poll() is None:
            # Records only: a view's record is written through a temporary beside it whose name
            # also ends in .json (".view_00002.json.<hex>.tmp.json"), so counting every .json
            # file could kill the run before its third record is in place.
            if folder.exists() and len([n for n in os.listdir(folder) if n.startswith("view_")
                                        and n.endswith(".json")]) >= 3:
                break  # three records: a few views done
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == -signal.SIGKILL and not (folder / INDEX_NAME).exists()
    done = len([n for n in os.listdir(folder) if n.startswith("view_") and n.endswith(".json")])
    assert 3 <= done < 10
    cams = orbit_cameras(scene.camera, 10)
    render_views(scene, cams, folder, files=rs.ViewFiles(buffers=["zdepth", "id"], formats=["npz", "exr"]))
    assert len(counted) == 10 - done  # only the views without a record
    render_views(scene, cams, tmp_path / "fresh", files=rs.ViewFiles(buffers=["zdepth", "id"], formats=["npz", "exr"]))
    _same_set(folder, tmp_path / "fresh")


def test_the_index_alone_re_renders_a_distorted_view_bit_for_bit(scene, tmp_path):
    K, R, t = scene.camera.to_opencv()
    cams = [rs.Camera.from_opencv(K, R, t, W, H, dist=[-0.2, 0.05, 0.001, 0.0, 0.01]),
            rs.Camera.from_opencv(K, R, t + [0.3, 0, 0], W, H, dist=[0.05, -0.01, 0.0, 0.0], fisheye=True)]
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=["zdepth", "id"], float_image=True))
    for view in json.load(open(tmp_path / INDEX_NAME))["views"]:
        cam = rs.Camera.from_opencv(view["K"], view["R"], view["t"], view["width"], view["height"],
                                    dist=view["distortion"], fisheye=view["distortion_model"] == "fisheye")
        again = rs.render(scene, camera=cam, buffers=("zdepth", "id"))
        saved = load_npz(tmp_path / view["files"]["npz"])
        assert all(np.array_equal(saved[k], again.buffers[k]) for k in again.buffers)
        assert np.array_equal(saved["image"], again.image)
