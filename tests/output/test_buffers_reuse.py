"""render(buffers_out=...): buffers written into the caller's arrays (an earlier frame's), bit for bit the
fresh ones, checked before any kernel, and counted as no new memory."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import raycast_shade as rs
from raycast_shade.common import validate
from raycast_shade.common.bufferspec import BUFFERS
from raycast_shade.scene.framememory import frame_bytes, frame_bytes_per_pixel
from raycast_shade.visibility import bands

ALL = tuple(n for n in BUFFERS if n != "coverage")
render_module = importlib.import_module("raycast_shade.render")  # the module (rs.render is the function)


def _scene(w, h):
    a = rs.shapes.icosphere(2)
    b = rs.Mesh(a.vertices * 0.5 + np.array([1.1, 0.3, 0.3]), a.faces)
    models = [rs.Model(a, rs.Material(ks=0.4, shininess=30), name="a"), rs.Model(b, name="b")]
    return rs.Scene(models, lights=[rs.PointLight((0, 2, 5), intensity=20)],
                    camera=rs.Camera(eye=(0.2, 0.1, 3.5), width=w, height=h))


def _garbage(buffers):
    """Arrays of the buffers' shapes and dtypes holding values no buffer has."""
    out = {}
    for name, a in buffers.items():
        g = np.empty_like(a)
        g[...] = True if a.dtype == np.bool_ else (-7 if a.dtype.kind == "i" else np.nan)
        if a.dtype == np.bool_:
            g[::2] = False
        out[name] = g
    return out


# 96 x 72: the whole-frame path; 1024 x 512 (2**19 pixels): the banded one.
@pytest.mark.parametrize("w, h", [(96, 72), (1024, 512)], ids=["whole", "banded"])
@pytest.mark.parametrize("kw", [dict(buffers=ALL), dict(buffers=ALL, shading=("flat", "gouraud")),
                                dict(buffers=("coverage", "zdepth", "normal_camera"), samples=4)],
                         ids=["phong", "mixed", "samples"])
def test_reused_arrays_get_the_fresh_frames_buffers_bit_for_bit(w, h, kw):
    assert (w * h >= bands.MIN_PIXELS) == (w == 1024)
    scene = _scene(w, h)
    other = scene.camera.replace(eye=(-0.3, 0.4, 3.2))
    first = rs.render(scene, **kw)  # an earlier view: its arrays are reused for the next one
    fresh = rs.render(scene, camera=other, **kw)
    given = _garbage(first.buffers)
    reused = rs.render(scene, camera=other, buffers_out=given, **kw)
    assert list(reused.buffers) == list(fresh.buffers)
    assert fresh.mask.mean() > 0.2
    for name, a in fresh.buffers.items():
        assert reused.buffers[name] is given[name], name  # the caller's very array
        np.testing.assert_array_equal(reused.buffers[name], a, err_msg=name)
    np.testing.assert_array_equal(reused.image, fresh.image)


def test_some_buffers_given_the_others_made():
    scene = _scene(96, 72)
    fresh = rs.render(scene, buffers=("zdepth", "normal", "id", "mask"))
    given = {"normal": np.zeros((72, 96, 3), np.float32), "model_id": np.zeros((72, 96), np.int32)}
    frame = rs.render(scene, buffers=("zdepth", "normal", "id", "mask"), buffers_out=given)
    assert frame.buffers["normal"] is given["normal"] and frame.buffers["model_id"] is given["model_id"]
    assert frame.buffers["zdepth"] is not fresh.buffers["zdepth"]
    for name in fresh.buffers:
        np.testing.assert_array_equal(frame.buffers[name], fresh.buffers[name], err_msg=name)


def test_the_phong_kernels_normals_are_the_shading_normals_with_a_bump_map():
    """The normal buffer, written by the Phong kernel as it shades, is rs.shading_normals (the normals
    kernel) bit for bit, bump-mapped included."""
    hm = rs.HeightMap(np.sin(np.linspace(0, 12, 64))[:, None] * np.cos(np.linspace(0, 9, 48))[None, :], scale=0.05)
    mesh = rs.shapes.uv_sphere(24, 48)
    scene = rs.Scene([rs.Model(mesh, rs.Material(ks=0.3, bump=hm))], lights=[rs.PointLight((1, 2, 4))],
                     camera=rs.Camera(eye=(0, 0, 3), width=80, height=60))
    frame = rs.render(scene, buffers=("normal",))
    plain = rs.render(scene.replace(models=[rs.Model(mesh, rs.Material(ks=0.3))]), buffers=("normal",))
    expect = rs.shading_normals(scene, scene.camera, frame.hits)
    assert frame.mask.mean() > 0.3
    assert np.abs(frame.buffers["normal"] - plain.buffers["normal"]).max() > 1e-3  # the bump shows
    np.testing.assert_array_equal(frame.buffers["normal"], expect)
    np.testing.assert_array_equal(frame.image, rs.render(scene).image)  # shading unchanged by the write


def _bad_cases():
    h, w = 72, 96
    ok = lambda n: np.zeros(BUFFERS[n].shape(h, w), BUFFERS[n].dtype)  # noqa: E731
    shared = np.zeros((h, w, 3), np.float32)
    return [
        ([("zdepth",), ok("zdepth")], TypeError, "buffers_out: expected a mapping"),
        ([("zdepth",), {"zdepth": ok("zdepth").tolist()}], TypeError, r"buffers_out\['zdepth'\]: expected a numpy"),
        ([("zdepth",), {"position": ok("position")}], ValueError, r"buffers_out\['position'\]: not among"),
        ([("id",), {"id": ok("model_id")}], ValueError, r"buffers_out\['id'\]: not among"),
        ([("zdepth",), {"zdepth": np.zeros((h, w + 1), np.float32)}], ValueError,
         r"buffers_out\['zdepth'\]: expected a \(72, 96\) float32"),
        ([("zdepth",), {"zdepth": np.zeros((h, w), np.float64)}], ValueError, r"buffers_out\['zdepth'\]: expected"),
        ([("mask",), {"mask": np.zeros((h, w), np.uint8)}], ValueError, r"buffers_out\['mask'\]: expected a \(72, 96\) bool"),
        ([("normal",), {"normal": np.zeros((h, w, 4), np.float32)[..., :3]}], ValueError,
         r"buffers_out\['normal'\]: expected a writeable C-contiguous"),
        ([("zdepth",), {"zdepth": np.broadcast_to(np.float32(0), (h, w))}], ValueError,
         r"buffers_out\['zdepth'\]: expected a writeable C-contiguous"),
        ([("normal", "position"), {"normal": shared, "position": shared}], ValueError,
         r"buffers_out\['position'\]: shares memory with buffers_out\['normal'\]"),
        ([("normal",), {"normal": "out"}], ValueError, r"buffers_out\['normal'\]: shares memory with out"),
    ]


@pytest.mark.parametrize("names, given, exc, match", [(*c[0], *c[1:]) for c in _bad_cases()],
                         ids=[c[2] for c in _bad_cases()])
def test_bad_outputs_are_refused_naming_the_field_before_any_kernel(monkeypatch, names, given, exc, match):
    scene = _scene(96, 72)
    image = np.zeros((72, 96, 3), np.float32)
    if isinstance(given, dict) and any(isinstance(v, str) for v in given.values()):
        given = {k: image for k in given}  # the image array itself
    before = {k: np.array(v, copy=True) for k, v in given.items()} if isinstance(given, dict) else None

    def no_kernel(*args, **kwargs):
        raise AssertionError("a kernel's inputs were packed before the refusal")

    monkeypatch.setattr(render_module, "prepare", no_kernel)
    with pytest.raises(exc, match=match):
        rs.render(scene, buffers=names, buffers_out=given, out=image)
    for k, v in (before or {}).items():
        np.testing.assert_array_equal(np.asarray(given[k]), v)  # untouched


def test_reused_buffers_are_no_new_memory_in_the_count(monkeypatch):
    # frame.normal is the given normal buffer: the plain frame's 12 bytes of normals are not made.
    assert frame_bytes_per_pixel(["zdepth", "normal"], reused=["normal"]) == 47 - 12 + 4
    assert frame_bytes_per_pixel(ALL, reused=ALL) == 47 - 12  # normal_camera's normals go into the given normal
    assert frame_bytes_per_pixel(["normal_camera"], reused=["normal_camera"]) == 47 + 12  # its scratch normals
    assert frame_bytes(100, 1000, ["id", "mask"], band_rows=128, reused=["model_id"]) == 100 * 1000 * (48 + 4 + 1)
    # Banded with the normal buffer: nothing reads the hits, so neither they nor the normals are made.
    assert frame_bytes(100, 1000, ["normal"], band_rows=128, reused=["normal"]) == 100 * 1000 * (48 - 20 - 12)
    scene = _scene(100, 100)
    monkeypatch.setattr(validate, "memory_limit", lambda: 100 * 100 * 60)
    with pytest.raises(ValueError, match="camera.width x camera.height: 100 x 100"):
        rs.render(scene, buffers=("position", "zdepth"))  # 63 bytes a pixel do not fit
    given = {"position": np.zeros((100, 100, 3), np.float32), "zdepth": np.zeros((100, 100), np.float32)}
    frame = rs.render(scene, buffers=("position", "zdepth"), buffers_out=given)  # 47 do
    assert frame.buffers["position"] is given["position"]


_PEAK = """
import json, sys
import numpy as np
import raycast_shade as rs

def status(key):
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith(key))

W, H = 1280, 720
names = tuple(json.loads(sys.argv[1]))
scene = rs.Scene([rs.Model(rs.shapes.icosphere(4))], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                 camera=rs.Camera(eye=(0, 0.5, 3.2), width=W, height=H))
warm = rs.render(scene, camera=scene.camera.replace(width=40, height=30), buffers=names)  # compiled, BVH built
warm.normal, warm.to_uint8()  # their kernels too: a compile in the measured frame would count (cold cache)
given = {k: a.copy() for k, a in rs.render(scene, buffers=names).buffers.items()}
for a in given.values():
    a.fill(0)  # resident
before = status("VmRSS")
with open("/proc/self/clear_refs", "w") as fh:
    fh.write("5")
frame = rs.render(scene, buffers=names, buffers_out=given)
frame.normal, frame.to_uint8()
print(json.dumps((status("VmHWM") - before) / (W * H)))
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/clear_refs"), reason="needs Linux's /proc/self/clear_refs")
def test_a_frame_into_reused_buffers_peaks_as_counted():
    """All 12 buffers into the caller's arrays (banded, 1280 x 720): the peak above the resident set
    before is the plain frame's, within a quarter of the count (which leaves the 93 bytes out)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.getcwd()] + sys.path), MALLOC_MMAP_THRESHOLD_="131072")
    res = subprocess.run([sys.executable, "-c", _PEAK, json.dumps(ALL)], capture_output=True, text=True, env=env,
                         timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    got = json.loads(res.stdout.strip().splitlines()[-1])
    want = frame_bytes(1280, 720, ALL, band_rows=bands.BAND_ROWS, reused=ALL) / (1280 * 720)
    fresh = frame_bytes(1280, 720, ALL, band_rows=bands.BAND_ROWS) / (1280 * 720)
    print(f"measured {got:.0f}, counted {want:.0f} bytes a pixel (fresh buffers: {fresh:.0f})")
    assert abs(got - want) <= 0.25 * got and got < 0.75 * fresh
