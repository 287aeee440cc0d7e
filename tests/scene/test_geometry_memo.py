"""A scene's packed geometry: built once on first read, kept in a private slot (no ``__dict__``
access), shared by ``replace`` when the models stay, and given by ``replace(geometry=...)``
to a variant of the scene (``shading/terms.py``'s material variants)."""

from __future__ import annotations

import pickle
import threading

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.scene import scene as scene_module
from tests.conftest import small_scene


def test_geometry_is_built_on_first_read_and_kept():
    scene = small_scene()
    assert not scene.has_geometry
    geo = scene.geometry
    assert scene.has_geometry and scene.geometry is geo


def test_replace_keeps_the_geometry_unless_the_models_change():
    scene = small_scene()
    fresh = scene.replace(ambient=0.3)
    assert not fresh.has_geometry  # nothing built yet: nothing to share
    geo = scene.geometry
    moved = scene.replace(camera=rs.Camera(eye=(0.0, 0.5, 3.0), width=8, height=6))
    assert moved.has_geometry and moved.geometry is geo
    other = scene.replace(models=[rs.shapes.icosphere(1)])
    assert not other.has_geometry and len(other.geometry.faces) == 80


def test_replace_with_a_geometry_gives_the_variant_that_geometry():
    scene = small_scene()
    twin = scene_module.SceneGeometry(scene.models)
    variant = scene.replace(geometry=twin, ambient=0.5)
    assert variant.geometry is twin and scene.geometry is not twin
    np.testing.assert_array_equal(variant.ambient, [0.5, 0.5, 0.5])


def test_replace_refuses_a_geometry_that_does_not_fit():
    scene = small_scene()
    with pytest.raises(TypeError, match="geometry: expected a SceneGeometry, got dict"):
        scene.replace(geometry={})
    two = rs.Scene([rs.shapes.icosphere(0), rs.shapes.icosphere(0)])
    with pytest.raises(ValueError, match="geometry: packs 2 models, the scene has 1"):
        scene.replace(geometry=two.geometry)
    with pytest.raises(ValueError, match="geometry: packs 1 models, the scene has 2"):
        scene.replace(geometry=scene.geometry, models=[rs.shapes.icosphere(0), rs.shapes.icosphere(0)])


def test_pickling_drops_the_geometry_and_the_lock():
    scene = small_scene()
    geo = scene.geometry
    back = pickle.loads(pickle.dumps(scene))
    assert not back.has_geometry
    assert back.geometry is not geo and back.geometry is back.geometry
    np.testing.assert_array_equal(back.geometry.faces, geo.faces)


def test_eight_threads_build_one_geometry(monkeypatch):
    """Eight threads read a fresh scene's geometry at once; the build is slowed so that they all
    arrive while it runs: one build, one object for all."""
    built = []
    original = scene_module.SceneGeometry
    barrier = threading.Barrier(8)

    class Slow(original):
        def __init__(self, models):
            built.append(1)
            threading.Event().wait(0.2)
            super().__init__(models)

    monkeypatch.setattr(scene_module, "SceneGeometry", Slow)
    scene = small_scene()
    seen = [None] * 8

    def read(i):
        barrier.wait()
        seen[i] = scene.geometry

    threads = [threading.Thread(target=read, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(built) == 1 and all(g is seen[0] for g in seen) and isinstance(seen[0], Slow)
