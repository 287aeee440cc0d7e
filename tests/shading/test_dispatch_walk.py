"""No frame takes a path that does not implement what it holds: a walk over every light kind,
attenuation law and reflectance model the layout registers, and every Light class.

The batched Phong kernel declares what its passes implement (``phong_fast.HANDLES``). The walk
builds a frame for each combination (lights casting shadows or not) and requires that the dispatch
takes the batched kernel only for declared codes, and that wherever it does, its image is the
general kernel's (the one evaluator) bit for bit. A new light kind or model that is not declared
therefore takes the general kernel; one that is declared but shaded as another kind fails here.

The general kernels' lean build declares its part too (``illumination.LEAN``): the walk requires that a
frame takes it only when everything it holds is declared there, and that the lean build's image is the
full build's, bit for bit."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common import layout as lay
from raycast_shade.scene.lights import Light
from raycast_shade.shading import reflectance
from raycast_shade.shading.illumination import LEAN
from raycast_shade.shading.inputs import lean_lighting, prepare
from raycast_shade.shading.jit import variant
from raycast_shade.shading.mirror_rays import NO_RAYS
from raycast_shade.shading.phong import _PHONG
from raycast_shade.shading.phong_fast import _PHONG_FAST, _PHONG_FAST_SHADOWS, HANDLES, applies
from raycast_shade.shading.shade import resolve_methods

W, H = 20, 16
CAM = rs.Camera(eye=(0.6, 0.8, 3.0), width=W, height=H, fov=45)


def _light_classes():
    """Every concrete Light class of the package, found by walking the subclasses."""
    seen, todo = [], list(Light.__subclasses__())
    while todo:
        cls = todo.pop()
        if cls not in seen:
            seen.append(cls)
            todo.extend(cls.__subclasses__())
    return seen


def _make(cls, law, shadows):
    """One light of ``cls``: its first field is where it is (a position) or where it shines (a
    direction); the law where the class has one."""
    fields = [f.name for f in dataclasses.fields(cls)]
    where = (-0.8, -1.0, -1.5) if fields[0] == "direction" else (0.8, 1.0, 1.5)
    kw = dict(shadows=shadows, intensity=4.0)
    if "attenuation" in fields:
        kw.update(attenuation=law, k=0.5)
    if "direction" in fields and fields[0] != "direction":  # aimed at the scene
        kw.update(direction=(-0.8, -1.0, -1.5))
    return cls(where, **kw)


def test_every_light_class_is_a_registered_kind_and_every_kind_has_a_class():
    kinds = {cls.kind for cls in _light_classes()}
    assert kinds == set(lay.LIGHT_KINDS.values())
    assert set(lay.MODEL_CODE.values()) == set(reflectance.MODELS)
    assert HANDLES["light_kinds"] <= set(lay.LIGHT_KINDS.values())
    assert HANDLES["attenuations"] <= set(lay.ATT_CODE.values())
    assert HANDLES["models"] <= set(lay.MODEL_CODE.values())
    assert LEAN["light_kinds"] <= set(lay.LIGHT_KINDS.values()) and LEAN["models"] <= set(lay.MODEL_CODE.values())


COMBOS = list(itertools.product(_light_classes(), lay.ATT_CODE, lay.MODEL_CODE, (False, True)))


@pytest.mark.parametrize("cls, law, model, shadows", COMBOS,
                         ids=[f"{c.__name__}-{a}-{m}-{'shadows' if s else 'lit'}" for c, a, m, s in COMBOS])
def test_the_batched_kernel_takes_only_what_it_declares_and_is_then_the_general_one(cls, law, model, shadows):
    light = _make(cls, law, shadows)
    own = dict(metallic=0.5, roughness=0.4) if model == "ggx" else dict(ks=0.5, shininess=20)  # each model's fields
    ball = rs.Model(rs.shapes.icosphere(1), rs.Material(kd=0.7, specular=model, **own))
    floor = rs.Model(rs.shapes.plane(size=3, center=(0, 0, -1.0)), rs.Material(kd=0.5))
    scene = rs.Scene([ball, floor], lights=[light], camera=CAM, ambient=0.05)
    k = prepare(scene, CAM)
    modes = resolve_methods(scene, "phong")
    row = k.lighting.lights[0]
    law_read = row[lay.LIGHT_KIND] != lay.LIGHT_DIRECTIONAL
    declared = (row[lay.LIGHT_KIND] in HANDLES["light_kinds"]
                and (not law_read or row[lay.LIGHT_ATT] in HANDLES["attenuations"])
                and lay.MODEL_CODE[model] in HANDLES["models"])
    assert applies(modes, k) == declared
    lean = row[lay.LIGHT_KIND] in LEAN["light_kinds"] and lay.MODEL_CODE[model] in LEAN["models"]
    assert (k.lighting.ext is None) == lean and (k.bumps.ext is None) == lean
    hits = rs.render(scene).hits

    def general(L, B):
        out = np.full((H, W, 3), np.nan, np.float32)
        variant(_PHONG, k)((hits.prim, hits.geom, hits.u, hits.v), k.geometry, B, L, k.colours, k.face_off,
                           k.materials, k.cam, k.background, modes, (out, np.empty((0, 0, 3), np.float32), NO_RAYS), 0)
        return out

    image = general(k.lighting, k.bumps)
    if lean:  # the lean build shades as the full one
        full = general(k.lighting._replace(ext=True), k.bumps._replace(ext=True))
        assert np.array_equal(image.view(np.uint32), full.view(np.uint32))
    if not declared:
        return
    fast = np.full((H, W, 3), np.nan, np.float32)
    kernel = _PHONG_FAST_SHADOWS if k.lighting.handle != 0 else _PHONG_FAST
    kernel(hits.prim, hits.geom, hits.u, hits.v, k.geometry, lean_lighting(k.lighting), k.face_off, k.materials,
           k.cam, k.background, modes, (fast, np.empty((0, 0, 3), np.float32), NO_RAYS))
    general = image
    assert np.array_equal(general.view(np.uint32), fast.view(np.uint32))
    assert np.nanmax(general) > 0.05  # the light reaches what the camera sees
