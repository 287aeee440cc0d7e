"""Measured numbers quoted in the prose are those of their one generated place.

The benchmarks and the figure scripts write CSVs (``benchmarks/results/``); the README
and the pages quote some of their numbers. Each quote below is checked against its CSV
row, formatted as the page formats it, so that a rerun that changes a number fails here
until the page says the new one (the drift issue 21 found: one speed-up with two figures,
failure-case numbers from before a fix).
"""

from __future__ import annotations

import csv
import os
from decimal import ROUND_HALF_UP, Decimal

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RESULTS = os.path.join(ROOT, "benchmarks", "results")


def _rows(name):
    with open(os.path.join(RESULTS, name), newline="") as fh:
        return list(csv.DictReader(fh))


def _failure(quantity):
    """A value of ``failure_cases.csv`` (docs/figures/failure_cases.py) by its quantity."""
    values = [float(r["value"]) for r in _rows("failure_cases.csv") if r["quantity"] == quantity]
    assert len(values) == 1, quantity
    return values[0]


def _page(path):
    with open(os.path.join(ROOT, path), encoding="utf-8") as fh:
        return " ".join(fh.read().split())  # quotes may wrap across lines


def _packet_range():
    """The 16-ray over 8-ray packet speed-up of ``limits.csv`` (bench_limits), as ``a–b×``."""
    ratios = [Decimal(r["value"]) for r in _rows("limits.csv") if r["metric"] == "packets8_over_packets"]
    assert len(ratios) >= 2
    # The CSV's decimal value rounded half up, as a reader would (1.295 -> 1.30).
    lo, hi = (x.quantize(Decimal("0.01"), ROUND_HALF_UP) for x in (min(ratios), max(ratios)))
    return f"{lo}–{hi}×"


def _failure_quotes():
    f = _failure
    misses = "{} / {} / {}"
    return [
        ("docs/failure-cases.md", misses.format(*(int(f(f"grid at pixel rays, near, step {s}, default flags: misses"))
                                                  for s in (1, 2, 3)))),
        ("docs/failure-cases.md", misses.format(*(int(f(f"grid at pixel rays, near, step {s}, robust: misses"))
                                                  for s in (1, 2, 3)))),
        ("docs/failure-cases.md", misses.format(*(int(f(f"grid at pixel rays, far, step {s}, robust: misses"))
                                                  for s in (1, 2, 3)))),
        ("docs/failure-cases.md", f"Phong RMSE **{f('winding 30% flipped, computed: phong RMSE'):.3f}**"),
        ("docs/failure-cases.md", f"Gouraud {f('winding 30% flipped, computed: gouraud RMSE'):.3f}"),
        ("docs/failure-cases.md", f"RMSE {f('winding 30% flipped, given: gouraud RMSE'):.3f}"),
        ("docs/failure-cases.md", f"RMSE {f('winding 30% flipped, given: phong RMSE'):.3f} "
                                  f"({f('winding consistent, computed: phong RMSE'):.4f} consistent)"),
        ("docs/failure-cases.md", f"**{f('cube crease None: phong RMSE vs flat'):.3f}** (Phong)"),
    ]


def test_the_packet_speed_up_has_one_figure():
    quote = _packet_range()
    for page in ("README.md", "docs/performance.md"):
        assert quote in _page(page), f"{page} should quote {quote} (benchmarks/results/limits.csv)"


@pytest.mark.parametrize("page, quote", _failure_quotes())
def test_failure_case_figures_are_the_csvs(page, quote):
    assert quote in _page(page), f"{page} should say {quote!r} (benchmarks/results/failure_cases.csv)"
