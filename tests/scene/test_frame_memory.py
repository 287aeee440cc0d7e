"""Camera.check_frame_memory's table (raycast_shade.scene.framememory) against measured peaks."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

import raycast_shade as rs
from raycast_shade.common import validate
from raycast_shade.scene.framememory import BUFFER_BYTES, FRAME_BYTES_PER_PIXEL, frame_bytes, frame_bytes_per_pixel
from raycast_shade.visibility import bands

ALL = tuple(n for n in BUFFER_BYTES if n != "coverage")
CASES = [dict(), dict(buffers=ALL), dict(buffers=("zdepth", "normal", "id", "mask")), dict(buffers=("position",)),
         dict(samples=4), dict(samples=8, buffers=("coverage",)), dict(terms=True), dict(terms="per_light")]
# 1280 x 720 takes the banded path (at least bands.MIN_PIXELS pixels): no full-frame hit buffer while rendering.
BANDED = [dict(), dict(buffers=ALL), dict(buffers=("zdepth", "normal_camera", "id")), dict(samples=4),
          dict(samples=9, buffers=("coverage", "mask")), dict(terms=True), dict(terms="per_light")]

# One process, every case: the peak resident set (VmHWM, reset through /proc/self/clear_refs) of
# render() and the frame's normals and 8-bit image, above the resident set before, per pixel.
_MEASURE = """
import json, sys
import raycast_shade as rs

def status(key):
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith(key))

W, H = int(sys.argv[2]), int(sys.argv[3])
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


def _measure(cases, w, h):
    # A fixed mmap threshold: every large array is mapped and unmapped, none kept in the heap by an
    # earlier case (glibc raises the threshold to the largest freed block), so cases do not share pages.
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.getcwd()] + sys.path), MALLOC_MMAP_THRESHOLD_="131072")
    res = subprocess.run([sys.executable, "-c", _MEASURE, json.dumps(cases), str(w), str(h)], capture_output=True,
                         text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    return json.loads(res.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not os.path.exists("/proc/self/clear_refs"), reason="needs Linux's /proc/self/clear_refs")
@pytest.mark.parametrize("w, h, cases", [(700, 700, CASES), (1280, 720, BANDED)], ids=["whole", "banded"])
def test_the_table_is_within_a_quarter_of_measured_peaks(w, h, cases):
    """700 x 700 (490,000 pixels, under the banded path's threshold) takes the whole-frame path,
    1280 x 720 the banded one: each against the count render() checks."""
    banded = w * h >= bands.MIN_PIXELS and h > bands.BAND_ROWS
    assert banded == (w == 1280)
    measured = _measure(cases, w, h)
    for kw, got in zip(cases, measured):
        terms = rs.shading.terms.check_terms(kw["terms"]) if "terms" in kw else None
        want = frame_bytes(w, h, kw.get("buffers", ()), kw.get("samples", 1), terms, lights=1,
                           band_rows=bands.BAND_ROWS if banded else 0) / (w * h)
        print(kw, f"measured {got:.0f}, counted {want:.0f} bytes a pixel")
        assert abs(got - want) <= 0.25 * got, (kw, got, want)


def test_the_table_counts_what_is_asked():
    assert frame_bytes_per_pixel() == FRAME_BYTES_PER_PIXEL == 47
    assert frame_bytes_per_pixel(["id", "model_id"]) == 47 + 8  # aliases expanded, counted once
    assert frame_bytes_per_pixel(["normal"]) == 47  # the buffer is frame.normal: the 12 bytes move into it
    assert frame_bytes_per_pixel(["normal_camera"]) == 47 + 12 + 12  # the buffer and the normals
    # Banded: the mask, and the band scratch beyond the 35 bytes a pixel made on access after it.
    assert frame_bytes(100, 1000, ["mask"], samples=2, band_rows=128) == 100 * 1000 * 49
    band = 130 * 100 * (16 * 20 + 4 * 12 + 24)  # per band of 130 rows x 100 pixels: a window per sample, ...
    assert frame_bytes(100, 200, samples=16, band_rows=128) == 100 * 200 * 48 + band - 100 * 200 * 35
    assert frame_bytes(100, 1000, samples=3) == 100 * 1000 * frame_bytes_per_pixel(samples=3)
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


def test_render_refuses_a_frame_whose_buffers_push_it_over_the_limit(monkeypatch):
    """render() counts the buffers, samples and terms asked for, before any kernel runs."""
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1))], lights=[rs.PointLight((2, 3, 4))],
                     camera=rs.Camera(eye=(0, 0, 3), width=100, height=100))
    monkeypatch.setattr(validate, "memory_limit", lambda: 100 * 100 * 60)
    rs.render(scene)
    for kw in (dict(buffers=("position", "zdepth")), dict(samples=2), dict(terms=True)):
        with pytest.raises(ValueError, match="camera.width x camera.height: 100 x 100"):
            rs.render(scene, **kw)
