"""RunOptions, the one record of the execution options (issue 40, part 5): each field refused by name,
the deprecated flat keywords of the four front ends (they warn and render what the record renders), a flat
keyword that contradicts the record, and the command line building the records from its flags."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps import animate as anim
from raycast_shade.apps import views
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.batch import ProcessPool, iter_batch, render_batch
from raycast_shade.apps.batch.run import RunOptions


@pytest.fixture(scope="module")
def scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=0.7, ks=0.4))],
                    lights=[rs.PointLight((2, 3, 4), intensity=20)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=24, height=18))


def test_the_record_is_public_frozen_and_normalised():
    assert rs.RunOptions is RunOptions and rs.ViewFiles is views.ViewFiles and "RunOptions" in rs.__all__
    run = RunOptions(executor="DASK", transfer="Disk", workers=np.int64(2))
    assert (run.executor, run.transfer, run.workers) == ("dask", "disk", 2) and type(run.workers) is int
    with pytest.raises(dataclasses.FrozenInstanceError):
        run.workers = 3
    assert RunOptions() == RunOptions(workers=None, scheduler=None, executor="auto", retries=2, resume=True,
                                      numba_threads=None, per_task=None, progress=True, window=None,
                                      transfer="auto")


@pytest.mark.parametrize("field, value, error, match", [
    ("workers", 0, ValueError, "workers: expected an integer >= 1 or None, got 0"),
    ("workers", 2.0, ValueError, "workers: expected an integer >= 1 or None, got 2.0"),
    ("workers", True, ValueError, "workers: expected an integer >= 1 or None, got True"),
    ("scheduler", 8786, TypeError, "scheduler: expected a scheduler address"),
    ("scheduler", "", ValueError, "scheduler: an empty address"),
    ("executor", "threads", ValueError, "executor: expected one of"),
    ("executor", None, TypeError, "executor: expected one of"),
    ("retries", -1, ValueError, "retries: expected an integer >= 0, got -1"),
    ("retries", "2", ValueError, "retries: expected an integer >= 0, got '2'"),
    ("resume", 1, TypeError, "resume: expected True or False"),
    ("numba_threads", 0, ValueError, "numba_threads: expected an integer >= 1 or None, got 0"),
    ("per_task", 0, ValueError, "per_task: expected an integer >= 1 or None, got 0"),
    ("per_task", True, ValueError, "per_task: expected an integer >= 1 or None, got True"),
    ("progress", None, TypeError, "progress: expected True or False"),
    ("window", 0, ValueError, "window: expected an integer >= 1 or None, got 0"),
    ("transfer", "ftp", ValueError, "transfer: expected one of"),
    ("transfer", 3, TypeError, "transfer: expected one of"),
])
def test_the_record_refuses_bad_values_naming_the_field(field, value, error, match):
    with pytest.raises(error, match=match):
        RunOptions(**{field: value})


def test_the_record_refuses_fields_that_contradict_each_other():
    with pytest.raises(ValueError, match="workers.*scheduler.*not both"):
        RunOptions(workers=2, scheduler="tcp://host:8786")
    with pytest.raises(ValueError, match="executor='serial'"):
        RunOptions(executor="serial", workers=2)
    with pytest.raises(ValueError, match="scheduler: executor='processes'"):
        RunOptions(executor="processes", scheduler="tcp://host:8786")
    with pytest.raises(ValueError, match="executor: a ProcessPool has its own workers"):
        RunOptions(executor=ProcessPool(2), workers=2)  # not started: nothing to close
    assert RunOptions(executor="dask", workers=2).workers == 2


def test_deprecated_batch_keywords_warn_and_render_what_the_record_renders(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 3)
    by_record = render_batch(scene, cams, shading="flat", run=RunOptions(progress=False, per_task=2, retries=0))
    with pytest.warns(DeprecationWarning) as caught:
        flat = render_batch(scene, cams, shading="flat", progress=False, frames_per_task=2, retries=0)
    assert all(np.array_equal(a, b) for a, b in zip(by_record, flat)) and len(flat) == 3
    messages = sorted(str(w.message) for w in caught)
    assert [m.split(" is deprecated")[0] for m in messages] == ["frames_per_task=", "progress=", "retries="]
    assert "pass run=RunOptions(per_task=...) instead" in messages[0]
    assert {w.filename for w in caught} == {__file__}  # pointed at the caller's line, not the package's
    with pytest.warns(DeprecationWarning) as caught:  # iter_batch's warnings come with its first frame
        paths = list(iter_batch(scene, cams[:1], shading="flat", out_dir=tmp_path, pattern="f_{:d}.npy",
                                progress=False, resume=False))
    assert sorted(str(w.message).split(" is")[0] for w in caught) == ["progress=", "resume="]
    assert {w.filename for w in caught} == {__file__}
    assert np.array_equal(np.load(paths[0]), by_record[0])


def test_a_flat_keyword_contradicting_the_record_is_refused_and_one_agreeing_only_warns(scene):
    with pytest.raises(ValueError, match=r"run: workers=2 is given besides run.workers=3; pass it in one place"), \
            pytest.warns(DeprecationWarning):
        render_batch(scene, run=RunOptions(workers=3), workers=2)
    with pytest.raises(ValueError, match=r"run: views_per_task=4 is given besides run.per_task=2"), \
            pytest.warns(DeprecationWarning):
        rs.render_views(scene, [scene.camera], "unused", run=RunOptions(per_task=2), views_per_task=4)
    with pytest.warns(DeprecationWarning, match="progress="):
        got = render_batch(scene, run=RunOptions(progress=False), progress=False)
    assert np.array_equal(got[0], rs.render(scene).image)


def test_a_bad_deprecated_keyword_is_refused_by_its_old_name_and_new_field(scene):
    with pytest.raises(ValueError, match=r"frames_per_task \(run.per_task\): expected an integer >= 1 or None, got 0"), \
            pytest.warns(DeprecationWarning):
        render_batch(scene, frames_per_task=0)
    with pytest.raises(TypeError, match="run: expected a RunOptions"):
        render_batch(scene, run={"workers": 2})
    with pytest.raises(TypeError, match="unexpected keyword argument 'views_per_task'"):
        render_batch(scene, views_per_task=2)  # a view set's keyword: never a batch's


def test_deprecated_view_keywords_warn_and_write_what_the_records_write(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 2)
    files = rs.ViewFiles(buffers=["zdepth"], image=None, compression="none")
    rs.render_views(scene, cams, tmp_path / "record", files=files, run=RunOptions(retries=0, per_task=1))
    with pytest.warns(DeprecationWarning) as caught:
        rs.render_views(scene, cams, tmp_path / "flat", buffers=["zdepth"], image=None, compression="none",
                        retries=0, views_per_task=1)
    assert sorted(str(w.message).split("=")[0] for w in caught) == \
        ["buffers", "compression", "image", "retries", "views_per_task"]
    for name in ("plan.json", "view_00000.npz", "view_00001.npz", "view_00001.json"):
        assert (tmp_path / "record" / name).read_bytes() == (tmp_path / "flat" / name).read_bytes(), name
    with pytest.raises(ValueError, match="run.executor: render_views renders in this process or on Dask"):
        rs.render_views(scene, cams, tmp_path / "pool", files=files, run=RunOptions(executor="processes"))
    assert not (tmp_path / "pool").exists()


def test_deprecated_animate_keywords_warn_and_write_what_the_record_writes(scene, tmp_path):
    anim.animate(scene, tmp_path / "record" / "", frames=2, run=RunOptions(progress=False, resume=False))
    with pytest.warns(DeprecationWarning, match=r"pass run=RunOptions\(progress=\.\.\.\)"):
        anim.animate(scene, tmp_path / "flat" / "", frames=2, progress=False)
    for i in range(2):
        name = f"frame_{i:05d}.png"
        assert (tmp_path / "record" / name).read_bytes() == (tmp_path / "flat" / name).read_bytes(), name


SCENE = """\
[camera]
eye = [0.0, 0.0, 4.0]
width = 16
height = 12

[[object]]
shape = "icosphere"
subdivisions = 1

[[light]]
type = "point"
position = [2.0, 3.0, 4.0]
"""


def test_the_command_line_builds_the_records_from_its_flags(tmp_path, monkeypatch, capsys):
    from raycast_shade.apps.cli import main

    scene_file = tmp_path / "s.toml"
    scene_file.write_text(SCENE)
    seen = {}

    def fake_animate(scene, output, **kw):
        seen["animate"] = kw
        return {"output": str(output), "kind": "frames", "frames": 2, "seconds": 1.0}

    def fake_views(scene, cameras, out_dir, **kw):
        seen["views"] = kw
        return str(out_dir)

    monkeypatch.setattr(anim, "animate", fake_animate)
    monkeypatch.setattr(views, "render_views", fake_views)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # the command line passes no flat keyword
        assert main(["animate", str(scene_file), "--frames", "2", "-o", str(tmp_path / "f") + "/", "--workers", "2",
                     "--executor", "DASK", "--frames-per-task", "3", "--no-progress"]) == 0
        assert main(["views", str(scene_file), "--orbit", "2", "-o", str(tmp_path / "v"), "--buffers", "zdepth",
                     "--formats", "npz,depth_png", "--image", "none", "--scheduler", "tcp://host:8786"]) == 0
    assert seen["animate"]["run"] == RunOptions(workers=2, executor="dask", per_task=3, progress=False)
    assert seen["views"]["run"] == RunOptions(scheduler="tcp://host:8786")
    assert seen["views"]["files"] == rs.ViewFiles(buffers=("zdepth",), formats=("npz", "depth_png"), image=None)
    flat = set(anim.FLAT_RUN_KEYWORDS) | set(views.FLAT_RUN_KEYWORDS) | set(views.FLAT_FILE_KEYWORDS)
    assert not flat & (set(seen["animate"]) | set(seen["views"]))
