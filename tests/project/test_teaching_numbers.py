"""The numbers docs/teaching.md and the notebooks' text state are those of what they show.

Issue 46 found the explorer notebook saying 480 px for a 440 px picture, the terms table without the
``emissive`` term the montage draws, and the exercise calling each light's ``Ii`` an array of 3 (it is
``intensity x color``: the exercise now asserts the shapes it states). Each quote here is read from
the page and compared with the code's constant or the benchmark's CSV row.
"""

from __future__ import annotations

import csv
import pathlib
import re

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _page(path):
    return " ".join((ROOT / path).read_text(encoding="utf-8").split())  # quotes may wrap across lines


def _markdown(name):
    import nbformat

    nb = nbformat.read(ROOT / "notebooks" / name, as_version=4)
    return " ".join(" ".join(c.source for c in nb.cells if c.cell_type == "markdown").split())


def _explore_rows():
    with open(ROOT / "benchmarks" / "results" / "explore.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def test_the_explorer_width_quoted_is_the_default():
    from raycast_shade.apps.explore import DEFAULT_WIDTH

    nb = re.findall(r"The picture is (\d+) pixels wide", _markdown("explorer.ipynb"))
    doc = re.findall(r"\((\d+) by default, `rs.explore\(scene, width=", _page("docs/teaching.md"))
    assert nb == [str(DEFAULT_WIDTH)] and doc == [str(DEFAULT_WIDTH)], (nb, doc, DEFAULT_WIDTH)


def test_the_explorer_frame_rate_quoted_is_the_benchmarks():
    rows = {(r["case"], r["width"], r["height"]): r for r in _explore_rows()}
    phong = rows[("light phong", "480", "360")]
    quoted = re.findall(r"\((\d+) frames a second at 480x360", _markdown("explorer.ipynb"))
    assert quoted == [f"{float(phong['fps']):.0f}"], (quoted, phong["fps"])
    table = _page("docs/teaching.md")
    for w, h in (("480", "360"), ("960", "720")):
        cells = [rows[(case, w, h)]["fps"] for case in ("light phong", "light gouraud", "light flat",
                                                          "light flat | gouraud | phong")]
        assert f"| {w}x{h} | {' | '.join(cells)} |" in table, (w, h, cells)


def test_the_display_sizes_quoted_are_the_constants():
    from raycast_shade.output.display import MAX_WIDTH, MIN_WIDTH, display_scale

    assert f"(at least {MIN_WIDTH} display pixels, at most {MAX_WIDTH}; a 160x120 frame at " \
           f"{display_scale((120, 160))}x)" in _page("docs/teaching.md")


def _table_keys(text):
    section = text.split("## The terms", 1)[1].split("\n## ", 1)[0]
    keys = set()
    for line in section.splitlines():
        if line.startswith("| `"):
            keys |= set(re.findall(r"`(\w+)`", line.split("|")[1]))
    return keys


def test_the_terms_table_lists_every_term_the_montage_draws():
    import raycast_shade as rs

    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1), rs.Material(kd=0.6, ks=0.3, ke=(0.1, 0.0, 0.0))),
                      rs.Model(rs.shapes.plane(4.0, center=(0.0, -1.0, 0.0), normal="+y"),
                               rs.Material(kd=0.5, reflectivity=0.3))],
                     lights=[rs.PointLight((1.0, 2.0, 2.0), 5.0, shadows=True)],
                     camera=rs.Camera(eye=(0.0, 0.5, 3.0), width=16, height=12))
    frame = rs.render(scene, "phong", terms="per_light")
    text = (ROOT / "docs" / "teaching.md").read_text(encoding="utf-8")
    assert _table_keys(text) == set(frame.terms), (sorted(_table_keys(text)), sorted(frame.terms))
    assert np.any(frame.terms["emissive"] > 0)  # the scene has emission: the row is not vacuous
    # the sum the page states is the one compose_terms forms
    assert "image = keep * (ambient + diffuse + specular + emissive) + reflected + background" in text


def test_the_exercise_states_the_shapes_its_cell_asserts():
    text = _markdown("exercise.ipynb")
    assert "`Ii` are arrays of 3" not in text
    assert "`light.intensity` (a number) times `light.color` (an array of 3)" in text


def _timings():
    """docs/images/browser_timings.txt (test_browser.py with RS_SCREENSHOTS=1): name -> list of str."""
    out = {}
    for line in (ROOT / "docs" / "images" / "browser_timings.txt").read_text(encoding="utf-8").splitlines():
        name, _, values = line.rpartition(": ")
        out[name] = values.split(", ")
    return out


def test_the_browser_table_is_the_timings_file():
    t, page = _timings(), _page("docs/teaching.md")
    rows = [("lecture, Run All in a new kernel (kernel cache empty)", "lecture: Run All, new kernel"),
            ("lecture, from Run All to its first picture on screen (kernel cache empty)",
             "lecture, empty kernel cache: wall from Run All to the first picture (s)"),
            ("lecture, Run All again in the same kernel", "lecture: Run All again, same kernel"),
            ("exercise, Run All in a new kernel", "exercise: Run All, new kernel"),
            ("explorer, Run All in a new kernel", "explorer: Run All, new kernel"),
            ("explorer, one slider step to the new picture on screen", "explorer: slider step to screen (s), 3 steps"),
            ("explorer, click to explanation shown", "explorer: click to explanation (s)")]
    for label, key in rows:
        assert f"| {label} | {', '.join(t[key])} |" in page, (label, t[key])


def test_the_cold_start_quoted_is_the_browser_tests():
    """The lecture's cold start in its kernel's CPU, and the run's wall and load, as browser_timings.txt has them."""
    t, page = _timings(), _page("docs/teaching.md")
    cpu = {when: t[f"lecture, empty kernel cache: kernel CPU {when} (s)"][0]
           for when in ("before Run All", "at the first picture", "after Run All")}
    for label, when in (("before Run All (the kernel's start)", "before Run All"),
                        ("at the first picture", "at the first picture"), ("after Run All", "after Run All")):
        assert f"| {label} | {cpu[when]} |" in page, (label, cpu[when])
    assert (f"first picture shows after {cpu['at the first picture']} s of the kernel's CPU and its "
            f"whole Run All after {cpu['after Run All']} s") in page
    (wall,), (start, end) = (t["browser test: wall from the module's import (s)"],
                             t["load average, 1 minute, at the start and at the end"])
    assert f"the whole test {wall} s" in page and f"load average {start} at its start and {end} at its end" in page


def test_the_explorer_layout_quoted_is_the_measured_one():
    import raycast_shade as rs
    from raycast_shade.apps.explore import Explorer
    from raycast_shade.apps.explore_view import EXPLANATION_PX, FONT_PX, SIDE_PANEL_PX

    key = next(k for k in _timings() if k.startswith("explorer, one method"))
    right, left, top, _, height, sliders, _, view_h = (float(v) for v in _timings()[key])
    page = _page("docs/teaching.md")
    assert left >= right and abs(top) <= 40  # beside the picture, level with it (its titles' row)
    assert f"the sliders end {sliders:.0f} px below the picture's top" in page
    assert f"the printout is {height:.0f} px tall" in page and f"{view_h:.0f}-px-high view" in page
    fit = next(v for k, v in _timings().items() if k.startswith("explorer printout fit, one method"))
    p_top, p_bottom, _, _, v_top, v_bottom = (float(v) for v in fit[:6])
    assert v_top <= p_top and p_bottom <= v_bottom  # the whole printout in the view, as the page says
    scene = rs.Scene([rs.Model(rs.shapes.icosphere(1), rs.Material())], lights=[rs.DirectionalLight((0, -1, -1))],
                     camera=rs.Camera(eye=(0.0, 0.0, 3.0), width=16, height=12))
    ex = Explorer(scene)
    assert f"two columns of {ex.controls['azimuth'].layout.width[:-2]} px" in page
    assert f"printout (at least {EXPLANATION_PX} px wide, filling the row)" in page and f"`min(width, {SIDE_PANEL_PX})` pixels" in page
    assert FONT_PX == 14 and "at 14 px" in page
