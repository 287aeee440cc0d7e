"""render_batch and iter_batch with their frame options passed whole (``options=BatchOptions``)."""

from __future__ import annotations

import os

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.batch import BatchOptions, iter_batch, render_batch
from raycast_shade.apps.batch.options import check_options


@pytest.fixture(scope="module")
def scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(2), rs.Material(kd=0.7, ks=0.4))],
                    lights=[rs.PointLight((2, 3, 4), intensity=20)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=24, height=18))


def test_options_passed_whole_render_what_the_keyword_arguments_render(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 2)
    kw = dict(shading="flat", tone={"exposure": 1.5}, max_depth=0)
    run = rs.RunOptions(progress=False, resume=False)
    by_keywords = render_batch(scene, cams, run=run, **kw)
    options = check_options("flat", {"max_depth": 0}, {"exposure": 1.5}, False)
    whole = render_batch(scene, cams, run=run, options=options)
    assert all(np.array_equal(a, b) for a, b in zip(by_keywords, whole))
    assert np.array_equal(whole[0], rs.render(scene, "flat", camera=cams[0], max_depth=0).image)
    # written files: the tone options travel in the object too
    render_batch(scene, cams, out_dir=tmp_path / "a", run=run, **kw)
    list(iter_batch(scene, cams, out_dir=tmp_path / "b", run=run, options=options))
    for i in range(2):
        name = f"frame_{i:05d}.png"
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_the_resume_of_options_is_the_runs_unless_run_says_otherwise(scene, tmp_path):
    cams = orbit_cameras(scene.camera, 2)
    keep = check_options("phong", {}, None, True)
    again = check_options("phong", {}, None, False)
    first = render_batch(scene, cams, out_dir=tmp_path, run=rs.RunOptions(progress=False))
    for p in first:  # a resumed run leaves these alone; one that renders again rewrites them
        os.utime(p, ns=(1, 1))
    render_batch(scene, cams, out_dir=tmp_path, options=keep, run=rs.RunOptions(progress=False))
    assert [os.stat(p).st_mtime_ns for p in first] == [1, 1]
    render_batch(scene, cams, out_dir=tmp_path, options=again)  # no run: the options' resume=False holds
    assert len(first) == 2 and all(os.stat(p).st_mtime_ns > 1 for p in first)
    with pytest.raises(ValueError, match=r"options: resume=False in options but True in run.*run.resume"):
        render_batch(scene, cams, out_dir=tmp_path, options=again, run=rs.RunOptions(progress=False))


def test_options_refuse_a_keyword_given_besides_them_and_bad_contents(scene):
    options = check_options("phong", {}, None, True)
    for extra in (dict(shading="flat"), dict(tone={"gamma": 2.2}), dict(max_depth=1)):
        name = next(iter(extra))
        with pytest.raises(ValueError, match=f"options: {name} is given both in options and as a keyword"):
            render_batch(scene, run=rs.RunOptions(progress=False), options=options, **extra)
    # resume is the run's now; the deprecated keyword still may not contradict the options
    with pytest.raises(ValueError, match="options: resume=True in options but False in run"), \
            pytest.warns(DeprecationWarning, match=r"run=RunOptions\(resume=\.\.\.\)"):
        render_batch(scene, options=options, resume=False)
    with pytest.raises(TypeError, match="options: expected a BatchOptions"):
        render_batch(scene, run=rs.RunOptions(progress=False), options={"shading": "flat"})
    with pytest.raises(ValueError, match="shading"):
        render_batch(scene, run=rs.RunOptions(progress=False),
                     options=BatchOptions(shading="toon"))  # made by hand: checked again
    with pytest.raises(TypeError, match="options.render_kwargs: expected a dict"):
        render_batch(scene, run=rs.RunOptions(progress=False), options=BatchOptions(render_kwargs=[("max_depth", 1)]))
