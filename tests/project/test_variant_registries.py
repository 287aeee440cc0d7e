"""Variants chosen by name are looked up in registries, one small function per variant
(``render.py``'s ``_BACKENDS`` and ``_WEIGHTS``), with one entry per choice that
``common/choices.py`` offers: a choice without its variant, or a variant no choice reaches,
fails here rather than at a user's render."""

from __future__ import annotations

import importlib
import itertools

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common.choices import BACKENDS, INTERPOLATIONS
from raycast_shade.visibility.cast import cast_camera
from raycast_shade.visibility.interpolation import to_screen_space
from raycast_shade.visibility.raster import rasterize
from tests.conftest import small_scene

render_module = importlib.import_module("raycast_shade.render")  # rs.render is the function


def test_one_entry_per_choice():
    assert list(render_module._BACKENDS) == list(BACKENDS)
    assert list(render_module._WEIGHTS) == list(INTERPOLATIONS)


def _same(a, b):
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_each_variant_is_the_function_it_names():
    scene = small_scene()
    geo, cam = scene.geometry, scene.camera
    _same(render_module._BACKENDS["raycast"][1](geo, cam, "auto", None), cast_camera(geo, cam))
    _same(render_module._BACKENDS["raster"][1](geo, cam, "auto", None), rasterize(geo, cam))
    hits = rasterize(geo, cam)
    assert render_module._WEIGHTS["perspective"](hits, geo, cam) is hits
    _same(render_module._WEIGHTS["screen"](hits, geo, cam), to_screen_space(hits, geo, cam))


@pytest.mark.parametrize("backend, interpolation", list(itertools.product(BACKENDS, INTERPOLATIONS)))
def test_render_sees_through_the_registries(monkeypatch, backend, interpolation):
    """render() takes the hit buffer from the backend's entry and its weights from the
    interpolation's, and times the visibility under the entry's key."""
    calls = []
    key, see = render_module._BACKENDS[backend]
    weights = render_module._WEIGHTS[interpolation]
    monkeypatch.setitem(render_module._BACKENDS, backend,
                        (key, lambda *a: calls.append(backend) or see(*a)))
    monkeypatch.setitem(render_module._WEIGHTS, interpolation,
                        lambda *a: calls.append(interpolation) or weights(*a))
    frame = rs.render(small_scene(), backend=backend, interpolation=interpolation)
    assert calls == [backend, interpolation]
    assert key in frame.timings and frame.mask.any()
