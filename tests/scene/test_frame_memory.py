"""Camera.check_frame_memory's table (raycast_shade.scene.framememory) against measured peaks."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

import raycast_shade as rs
from raycast_shade.common import validate
from raycast_shade.scene.framememory import BUFFER_BYTES, FRAME_BYTES_PER_PIXEL, frame_bytes_per_pixel

ALL = tuple(n for n in BUFFER_BYTES if n != "coverage")
CASES = [dict(), dict(buffers=ALL), dict(buffers=("zdepth", "normal", "id", "mask")), dict(buffers=("position",)),
         dict(samples=4), dict(samples=8, buffers=("coverage",)), dict(terms=True), dict(terms="per_light")]

# One process, every case: the peak resident set (VmHWM, reset through /proc/self/clear_refs) of
# render() and the frame's normals and 8-bit image, above the resident set before, per pixel.
_MEASURE = """
import json, sys
import raycast_shade as rs

def status(key):
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith(key))

W = H = 700  # 490,000 pixels: below the banded path's threshold, so every case takes the whole-frame path
scene = rs.Scene([rs.Model(rs.shapes.icosphere(4))], lights=[rs.PointLight((2, 3, 4), intensity=20)],
                 camera=rs.Camera(eye=(0, 0.5, 3.2), width=W, height=H))
small = scene.camera.replace(width=40, height=30)
out = []
for kw in json.loads(sys.argv[1]):
    frame = rs.render(scene, camera=small, **kw)  # compiled, BVH built
    frame.normal, frame.to_uint8()
    del frame
    before = status("VmRSS")
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")
    frame = rs.render(scene, **kw)
    frame.normal, frame.to_uint8()
    out.append((status("VmHWM") - before) / (W * H))
    del frame
print(json.dumps(out))
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/clear_refs"), reason="needs Linux's /proc/self/clear_refs")
def test_the_table_is_within_a_quarter_of_measured_peaks():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.getcwd()] + sys.path))
    res = subprocess.run([sys.executable, "-c", _MEASURE, json.dumps(CASES)], capture_output=True, text=True,
                         env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    measured = json.loads(res.stdout.strip().splitlines()[-1])
    for kw, got in zip(CASES, measured):
        terms = rs.shading.terms.check_terms(kw["terms"]) if "terms" in kw else None
        want = frame_bytes_per_pixel(kw.get("buffers", ()), kw.get("samples", 1), terms, lights=1)
        print(kw, f"measured {got:.0f}, counted {want} bytes a pixel")
        assert abs(got - want) <= 0.25 * got, (kw, got, want)


def test_the_table_counts_what_is_asked():
    assert frame_bytes_per_pixel() == FRAME_BYTES_PER_PIXEL == 47
    assert frame_bytes_per_pixel(["id", "model_id"]) == 47 + 8  # aliases expanded, counted once
    assert frame_bytes_per_pixel(["normal"]) == 47 + 12 + 12  # the buffer and the normals it is made from
    assert frame_bytes_per_pixel(samples=2) == 47 + 20 + 12
    assert frame_bytes_per_pixel(samples=16, buffers=["coverage"]) == 47 + 4 + 4 * 20 + 3 * 12 + 24 + 4
    assert frame_bytes_per_pixel(terms=("per_light",), lights=3) == 47 + 60 + 12 + 72
    with pytest.raises(ValueError, match="buffers: unknown buffer 'opacity'"):
        frame_bytes_per_pixel(["opacity"])
    with pytest.raises(ValueError, match="samples: expected an integer >= 1"):
        frame_bytes_per_pixel(samples=0)


def test_check_frame_memory_refuses_what_the_buffers_push_over_the_limit(monkeypatch):
    cam = rs.Camera(eye=(0, 0, 3), width=100, height=100)
    monkeypatch.setattr(validate, "memory_limit", lambda: 100 * 100 * 60)
    cam.check_frame_memory()  # 47 bytes a pixel fit
    with pytest.raises(ValueError, match="camera.width x camera.height: 100 x 100"):
        cam.check_frame_memory(buffers=["position", "zdepth"])  # 63 do not
