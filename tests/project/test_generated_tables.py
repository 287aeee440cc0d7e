"""Every table that a benchmark writes into docs/performance.md is its committed CSV, as the
benchmark renders it: a figure in the docs has one source and cannot drift from it."""

from __future__ import annotations

import csv
import os
import statistics

import pytest

from benchmarks import bench_limits, bench_paths, bench_peers, bench_shadows

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# (module, its table function, the CSV it renders, the docs markers)
TABLES = {
    "peers": (bench_peers.table, "peers.csv", bench_peers.BEGIN, bench_peers.END),
    "limits": (bench_limits.limit_table, "limits.csv", bench_limits.LIMIT_BEGIN, bench_limits.LIMIT_END),
    "cold": (bench_limits.cold_table, "limits.csv", bench_limits.COLD_BEGIN, bench_limits.COLD_END),
    "shadows": (bench_shadows.table, "shadows.csv", bench_shadows.BEGIN, bench_shadows.END),
    "paths": (bench_paths.table, "paths.csv", bench_paths.BEGIN, bench_paths.END),
}


def _rows(name):
    with open(os.path.join(ROOT, "benchmarks", "results", name), newline="") as fh:
        return list(csv.DictReader(fh))


def _block(begin, end):
    with open(os.path.join(ROOT, "docs", "performance.md"), encoding="utf-8") as fh:
        page = fh.read()
    assert page.count(begin) == 1 and page.count(end) == 1, (begin, end)
    return page[page.index(begin) + len(begin):page.index(end)]


@pytest.mark.parametrize("name", list(TABLES))
def test_the_docs_table_is_the_csv(name):
    table, csv_name, begin, end = TABLES[name]
    assert _block(begin, end) == "\n" + table(_rows(csv_name)), (
        f"docs/performance.md's {name} table is not benchmarks/results/{csv_name}: "
        f"rewrite it with `python -m benchmarks.bench_{'limits' if name == 'cold' else name} --table`")


@pytest.mark.parametrize("ratio, verdict", [("0.4", "0.400 (aim ≤ 0.45: met)"), ("0.5", "0.500 (aim ≤ 0.45: not met)")])
def test_the_peers_verdicts_read_the_ratios(ratio, verdict):
    """Not vacuous: the rendering reads the figures, and a ratio over its aim is not met."""
    rows = _rows("peers.csv")
    for r in rows:
        if r["pipeline"] == "llvmpipe" and int(r["triangles"]) == 81920 and int(r["width"]) == 640:
            r["ours_over_peer"] = ratio
    assert f"81,920 tris at 640×480: {verdict}" in bench_peers.table(rows)


def test_the_limits_verdicts_follow_the_aims():
    rows = _rows("limits.csv")
    table = bench_limits.limit_table(rows)
    ratios = [float(r["value"]) for r in rows
              if r["section"] == "limit" and r["metric"] == "frame_over_packets_plus_store"]
    assert len(ratios) == 4
    assert table.count("met)") == 5  # a verdict for each of the four frames and the 82k 1080p shade stage
    assert table.count("(met)") == sum(x <= bench_limits.FRAME_AIM for x in ratios)


@pytest.mark.parametrize("before, verdict", [(100.0, "met"), (20.0, "not met")])
def test_the_cold_verdicts_read_the_rounds(before, verdict):
    """Each figure of the cold table is the median of its rounds' ratios, and the verdict follows
    it: the CSV's rounds with the reference's CPU replaced (ours / 100 s is under the aim's 0.34,
    ours / 20 s over it)."""
    rows = [dict(r) for r in _rows("limits.csv") if r["section"] == "cold"]
    ours = [float(r["value"]) for r in rows if r["metric"] == "ours_cpu_s" and r["variant"].startswith("demo/")]
    assert len(ours) >= 3  # rounds: a median, not one run
    for r in rows:
        if r["metric"] == "reference_cpu_s":
            r["value"] = str(before)
    table = bench_limits.cold_table(rows)
    median = statistics.median(x / before for x in ours)
    assert f"| **{median:.2f}** |" in table
    assert f"{median:.2f} for the whole `raycast-shade demo` ({verdict})" in table


def test_the_readme_quotes_the_cold_ratio():
    ratio = f"{statistics.median(bench_limits.cold_ratios(_rows('limits.csv'))):.2f}"
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        readme = " ".join(fh.read().split())
    for quote in (f"{ratio} of what the code before issue 40 took beside it", f"{ratio} of the code before issue 40"):
        assert quote in readme, f"README.md should say {quote!r} (benchmarks/results/limits.csv, cold rows)"


def test_the_readme_quotes_the_peers_csv():
    quote = bench_peers.readme_quote(_rows("peers.csv"))
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        readme = " ".join(fh.read().split())  # a quote may wrap across lines
    assert quote in readme, f"README.md should say {quote!r} (benchmarks/results/peers.csv)"
