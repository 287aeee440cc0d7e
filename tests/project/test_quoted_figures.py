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


def _cold_start():
    """The demo's first run from an empty kernel cache (``limits.csv``'s ``cold`` rows), as ``N s of CPU``."""
    values = [float(r["value"]) for r in _rows("limits.csv")
              if (r["section"], r["variant"], r["metric"]) == ("cold", "cold_cache", "demo_cpu_s")]
    assert len(values) == 1
    return f"{values[0]:.0f} s of CPU"


def test_the_cold_start_has_one_figure():
    quote = _cold_start()
    for page in ("README.md", "docs/performance.md"):
        assert quote in _page(page), f"{page} should quote {quote} (benchmarks/results/limits.csv, cold rows)"


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


def _core(mesh, w, h, pipeline, stage):
    values = [Decimal(r["median_ms"]) for r in _rows("core.csv")
              if (r["benchmark"], r["mesh"], r["width"], r["height"], r["pipeline"], r["stage"])
              == ("frame", mesh, str(w), str(h), pipeline, stage)]
    assert len(values) == 1, (mesh, w, h, pipeline, stage)
    return values[0]


def _ms(x, places="0.1"):
    return f"{x.quantize(Decimal(places), ROUND_HALF_UP)} ms"


@pytest.mark.parametrize("label, mesh, w, h", [
    ("icosphere, 81,920 tris | 640×480", "icosphere6", 640, 480),
    ("icosphere, 81,920 tris | 1920×1080", "icosphere6", 1920, 1080),
    ("icosphere, 1.31 M tris | 640×480", "icosphere8", 640, 480),
    ("icosphere, 1.31 M tris | 1920×1080", "icosphere8", 1920, 1080),
])
def test_the_readmes_core_table_is_core_csv(label, mesh, w, h):
    """The README's one-frame table, row by row, from ``core.csv`` (bench_core)."""
    c = lambda *k: _core(mesh, w, h, *k)  # noqa: E731
    naive = c("naive", "total")
    row = (f"| {label} | {_ms(c('raycast_shade', 'cast'))} | {_ms(c('raycast_shade', 'shade'))} | "
           f"**{_ms(c('raycast_shade', 'total'))}** | {_ms(c('embreex', 'cast_2threads'))} | "
           f"{_ms(naive, '1')} ({c('ratio', 'naive_over_total').quantize(Decimal('0.1'), ROUND_HALF_UP)}×) |")
    assert row in _page("README.md"), row
