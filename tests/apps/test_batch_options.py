"""render_batch and iter_batch with their frame options passed whole (``options=BatchOptions``)."""

from __future__ import annotations

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
    kw = dict(shading="flat", tone={"exposure": 1.5}, resume=False, max_depth=0)
    by_keywords = render_batch(scene, cams, progress=False, **kw)
    options = check_options("flat", {"max_depth": 0}, {"exposure": 1.5}, False)
    whole = render_batch(scene, cams, progress=False, options=options)
    assert all(np.array_equal(a, b) for a, b in zip(by_keywords, whole))
    assert np.array_equal(whole[0], rs.render(scene, "flat", camera=cams[0], max_depth=0).image)
    # written files: the tone options travel in the object too
    render_batch(scene, cams, out_dir=tmp_path / "a", progress=False, **kw)
    list(iter_batch(scene, cams, out_dir=tmp_path / "b", progress=False, options=options))
    for i in range(2):
        name = f"frame_{i:05d}.png"
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_options_refuse_a_keyword_given_besides_them_and_bad_contents(scene):
    options = check_options("phong", {}, None, True)
    for extra in (dict(shading="flat"), dict(tone={"gamma": 2.2}), dict(resume=False), dict(max_depth=1)):
        name = next(iter(extra))
        with pytest.raises(ValueError, match=f"options: {name} is given both in options and as a keyword"):
            render_batch(scene, progress=False, options=options, **extra)
    with pytest.raises(TypeError, match="options: expected a BatchOptions"):
        render_batch(scene, progress=False, options={"shading": "flat"})
    with pytest.raises(ValueError, match="shading"):
        render_batch(scene, progress=False, options=BatchOptions(shading="toon"))  # made by hand: checked again
    with pytest.raises(TypeError, match="options.render_kwargs: expected a dict"):
        render_batch(scene, progress=False, options=BatchOptions(render_kwargs=[("max_depth", 1)]))
