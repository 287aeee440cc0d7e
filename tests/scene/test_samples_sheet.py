"""docs/figures/samples.py: the Khronos samples' contact sheet, on a samples folder the test writes."""

from __future__ import annotations

import json
import os

import numpy as np
from PIL import Image

from benchmarks.outputs import images_dir
from docs.figures import samples as sheet


def test_without_the_samples_the_sheet_is_skipped_saying_why(capsys, monkeypatch):
    monkeypatch.delenv("KHRONOS_SAMPLES", raising=False)
    assert sheet.main(["--quick"]) == 2
    assert "needs the Khronos samples" in capsys.readouterr().err


def test_a_present_sample_is_drawn_beside_its_screenshot_and_absent_ones_listed(tmp_path, capsys):
    """One sample (TriangleWithoutIndices' layout, written here) and its screenshot: our tile shows the
    triangle (lit pixels below the diagonal only), the screenshot tile the screenshot's colour; every
    other sample is named as left out."""
    import base64

    folder = tmp_path / "2.0" / "TriangleWithoutIndices"
    (folder / "glTF").mkdir(parents=True)
    (folder / "screenshot").mkdir()
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    js = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
          "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
          "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(pos).decode(),
                       "byteLength": 36}],
          "bufferViews": [{"buffer": 0, "byteLength": 36}],
          "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                         "min": [0, 0, 0], "max": [1, 1, 0]}]}
    (folder / "glTF" / "TriangleWithoutIndices.gltf").write_text(json.dumps(js))
    Image.new("RGB", (40, 40), (10, 200, 30)).save(folder / "screenshot" / "screenshot.png")
    assert sheet.main([str(tmp_path / "2.0"), "--quick"]) == 0
    err = capsys.readouterr().err
    assert "Duck/glTF-pbrSpecularGlossiness/Duck.gltf (spec-gloss) is not in" in err
    assert "TriangleWithoutIndices" not in err
    out = np.asarray(Image.open(os.path.join(images_dir(True), "files_classes.png")).convert("RGB")).astype(int)
    t, head = sheet.TILE, 14
    ours = out[2 * head - 2:2 * head - 2 + t, :t]
    lit = ours.sum(axis=2) > 0
    assert lit[-10, 10] and not lit[10, -10]  # the right angle at the bottom left, seen from +z
    shot = out[2 * head - 2 + t // 2, t + t // 2]
    np.testing.assert_array_equal(shot, [10, 200, 30])
