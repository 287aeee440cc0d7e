"""The confusion study on images from an independent shader (benchmarks/diagnose_outside.py): its shader is
our renderer's equation written apart, its quick mode gives no confident wrong verdict, and the table in
docs/diagnose.md is in the format the script writes."""

from __future__ import annotations

import pathlib
import warnings

import numpy as np
import pytest

import raycast_shade as rs
from benchmarks import diagnose_outside as study

DOC = pathlib.Path(__file__).resolve().parents[2] / "docs" / "diagnose.md"


@pytest.mark.parametrize("name", ["prism", "cube8"])
def test_independent_shader_is_our_equation(name):
    scene, method = study.scenes()[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the 8-vertex cube's rounded edges are the point
        frame = rs.render(scene, method)
    got = study.student_linear(scene, frame.hits, method)
    np.testing.assert_allclose(got[frame.mask], frame.image[frame.mask], atol=1e-6)
    assert np.abs(study.student_linear(scene, frame.hits, method, reverse=True, no_ambient=True) - got).max() > 0.05


def test_quick_study_has_no_confident_wrong_verdict():
    rows = study.run(quick=True)
    assert {r["slip"] for r in rows} == set(study.QUICK)
    wrong = [r for r in rows if r["outcome"] == "wrong"]
    assert not wrong, wrong
    by = {r["slip"]: r for r in rows}
    assert by["correct"]["status"] == "matches"
    assert by["photo"]["status"] == "not-a-render"
    for slip in ("highlight-times-kd", "directional-reversed", "light-object-space", "no-ambient"):
        assert by[slip]["outcome"] == "right", by[slip]
    text = study.table(rows)
    lines = text.splitlines()
    assert tuple(lines[:2]) == study.HEADER
    assert all(study.ROW.match(line) for line in lines[2:]), lines
    assert lines[-1].startswith("| all | all | - | ") and lines[-1].endswith(" 0 |")


def test_docs_table_has_the_scripts_format():
    doc = DOC.read_text(encoding="utf-8")
    table = doc[doc.index(study.BEGIN) + len(study.BEGIN):doc.index(study.END)].strip().splitlines()
    assert tuple(table[:2]) == study.HEADER
    assert len(table) > 10 and all(study.ROW.match(line) for line in table[2:]), table
    assert table[-1].startswith("| all | all | - | ")
    assert study.put_table(doc, "\n".join(table)) == doc  # the script would write back the same text
