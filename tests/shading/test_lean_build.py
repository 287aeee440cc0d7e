"""The lean build (``illumination.LEAN``): frames that hold nothing beyond the lecture's models compile
kernels without spot and area lights, the GGX model and normal maps, and shade exactly as the full build.

:func:`~raycast_shade.shading.inputs.extensions` decides; here it is forced to the full build and
the images compared bit for bit on the golden scenes, in every method, with mirrors and terms (on
whatever machine runs the suite: the golden hashes of other instruction sets cannot be re-made here).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common import layout as lay
from raycast_shade.shading import inputs, normals
from raycast_shade.shading.illumination import LEAN
from tests.render.golden_renders import scenes

SCENES = dict(scenes())
RENDERS = [("flat", {}), ("gouraud", {}), ("phong", {}), ("phong", dict(max_depth=3)), ("gouraud", dict(terms=True)),
           ("phong", dict(terms=True, buffers=("normal",)))]


def _full(*args):
    return True


@pytest.mark.parametrize("name", list(SCENES))
def test_a_lean_frame_is_the_full_builds_bit_for_bit(name, monkeypatch):
    scene = SCENES[name]
    assert inputs.prepare(scene, scene.camera).lighting.ext is None  # the golden scenes are all lean
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the demo's flat and Gouraud panels ignore its bump map on purpose
        lean = [rs.render(scene, m, **kw) for m, kw in RENDERS]
        monkeypatch.setattr(inputs, "extensions", _full)
        monkeypatch.setattr(normals, "extensions", _full)
        assert inputs.prepare(scene, scene.camera).lighting.ext is True
        full = [rs.render(scene, m, **kw) for m, kw in RENDERS]
    for (m, kw), a, b in zip(RENDERS, lean, full):
        assert np.array_equal(a.image.view(np.uint32), b.image.view(np.uint32)), (m, kw)
        for term in (a.terms or {}):
            assert np.array_equal(a.terms[term], b.terms[term]), (m, kw, term)
        if "buffers" in kw:
            assert np.array_equal(a.normal, b.normal)


def _rows(kind):
    lights = np.zeros((1, lay.LIGHT_SIZE))
    lights[0, lay.LIGHT_KIND] = kind
    return lights


def _materials(model):
    mats = np.zeros((2, lay.MAT_SIZE))
    mats[1, lay.MAT_MODEL] = model
    return mats


NO_MAPS = np.full(2, -1)


@pytest.mark.parametrize("kind", sorted(lay.LIGHT_KINDS.values()))
@pytest.mark.parametrize("model", sorted(lay.MODEL_CODE.values()))
def test_only_the_lectures_kinds_and_models_take_the_lean_build(kind, model):
    lean = kind in LEAN["light_kinds"] and model in LEAN["models"]
    assert inputs.extensions(_rows(kind), _materials(model), NO_MAPS, False) is (None if lean else True)
    # a normal map or a texture takes the full build whatever the lights and models
    assert inputs.extensions(_rows(kind), _materials(model), np.array([-1, 0]), False) is True
    assert inputs.extensions(_rows(kind), _materials(model), NO_MAPS, True) is True


def test_lean_holds_the_point_and_directional_lights_and_phong_and_blinn_only():
    assert LEAN["light_kinds"] == {lay.LIGHT_POINT, lay.LIGHT_DIRECTIONAL}
    assert LEAN["models"] == {lay.MODEL_PHONG, lay.MODEL_BLINN}
    assert inputs.extensions(np.zeros((0, lay.LIGHT_SIZE)), _materials(lay.MODEL_PHONG), NO_MAPS, False) is None
