"""render_views renders each view into the arrays of the view before it in its slot (no fresh
pages per view), and every file is still that view's own render."""

from __future__ import annotations

import numpy as np
import pytest

import raycast_shade as rs
import raycast_shade.apps.views as views_mod
from raycast_shade.apps.animate import orbit_cameras
from raycast_shade.apps.views import render_views
from raycast_shade.apps.viewslots import ViewSlots
from raycast_shade.output.bufferfile import load_npz


@pytest.fixture(scope="module")
def scene():
    return rs.Scene([rs.Model(rs.shapes.icosphere(2))], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                    camera=rs.Camera(eye=(0.3, 0.5, 4.0), width=40, height=30))


@pytest.mark.parametrize("overlap", [True, False])
def test_views_reuse_their_slot_and_files_are_each_views_own(scene, tmp_path, monkeypatch, overlap):
    calls = []
    real = views_mod.render

    def spy(*args, **kwargs):
        frame = real(*args, **kwargs)
        calls.append((kwargs.get("out"), kwargs.get("buffers_out"), frame))
        return frame

    monkeypatch.setattr(views_mod, "render", spy)
    monkeypatch.setattr(views_mod, "_two_frames_fit", lambda jobs, memory: overlap)  # else decided by memory
    cams = orbit_cameras(scene.camera, 5)
    names = ["zdepth", "normal", "id", "mask"]
    render_views(scene, cams, tmp_path, files=rs.ViewFiles(buffers=names, image=None, compression="none"))
    assert len(calls) == 5
    slots = 2 if overlap else 1
    for i, (out, reused, frame) in enumerate(calls):
        assert frame.image is out
        if i < slots:
            assert not reused  # the slot's first view: nothing to reuse yet
        else:  # the arrays of the view `slots` before it, every asked buffer
            before = calls[i - slots][2]
            assert out is calls[i - slots][0]
            assert set(reused) == set(frame.buffers)
            for name, array in reused.items():
                assert frame.buffers[name] is array and array is before.buffers[name]
    for i, cam in enumerate(cams):  # the files are each view's fresh render, bit for bit
        fresh = rs.render(scene, camera=cam, buffers=names)
        stored = load_npz(tmp_path / f"view_{i:05d}.npz")
        for name, array in fresh.buffers.items():
            assert np.array_equal(stored[name], array), (i, name)


def test_slots_start_over_when_the_camera_size_changes():
    slots = ViewSlots(2)
    small, large = rs.Camera(eye=(0, 0, 3), width=8, height=6), rs.Camera(eye=(0, 0, 3), width=10, height=6)
    image, reused = slots.next(small).arrays(small, ("zdepth",))
    assert image.shape == (6, 8, 3) and reused == {}
    slots.keep({"zdepth": np.zeros((6, 8), np.float32)})
    slots.next(small)
    slots.next(small)  # back to the first slot: its kept buffer is offered again
    assert set(slots.arrays(small, ("zdepth",))[1]) == {"zdepth"}
    assert slots.arrays(small, ("mask",))[1] == {}  # only buffers asked for again
    image, reused = slots.next(large).arrays(large, ("zdepth",))
    assert image.shape == (6, 10, 3) and reused == {}
