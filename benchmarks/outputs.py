"""Where the benchmarks write, by mode.

A full run's CSVs (``benchmarks/results/``), charts (``docs/images/``) and
tables (``docs/benchmarks.md``) are committed: the docs quote them. A quick
run (``--quick``) is a smoke test of the same machinery on small sizes; its
files keep the full run's names but go to ``out/quick/results/``,
``out/quick/images/`` and ``out/quick/benchmarks.md``, outside every tracked
folder and git-ignored (``/out/``), so that ``python -m benchmarks --quick`` changes no tracked file and
never overwrites a full run's numbers (``tests/project/test_benchmark_outputs.py``
checks the folders with ``git check-ignore``).
"""

from __future__ import annotations

import csv
import os

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
QUICK = os.path.join(ROOT, "out", "quick")  # every quick-mode file, away from the tracked folders


def results_dir(quick: bool) -> str:
    """Folder of the CSVs: ``benchmarks/results/`` (full) or ``out/quick/results/``."""
    return os.path.join(QUICK, "results") if quick else os.path.join(HERE, "results")


def images_dir(quick: bool) -> str:
    """Folder of the charts: ``docs/images/`` (full) or ``out/quick/images/``."""
    return os.path.join(QUICK, "images") if quick else os.path.join(ROOT, "docs", "images")


def doc_path(quick: bool) -> str:
    """The generated tables: ``docs/benchmarks.md`` (full) or ``out/quick/benchmarks.md``."""
    return os.path.join(QUICK, "benchmarks.md") if quick else os.path.join(ROOT, "docs", "benchmarks.md")


def results_file(name: str, quick: bool) -> str:
    """``results_dir(quick)/name``."""
    return os.path.join(results_dir(quick), name)


def image_file(name: str, quick: bool) -> str:
    """``images_dir(quick)/name``."""
    return os.path.join(images_dir(quick), name)


def page_file(name: str, quick: bool) -> str:
    """A generated page of the docs: ``docs/name`` (full) or ``out/quick/name``."""
    return os.path.join(QUICK, name) if quick else os.path.join(ROOT, "docs", name)


def write_table(text: str, quick_name: str, begin: str, end: str, quick: bool) -> str:
    """Put a generated table between the ``begin`` and ``end`` markers of ``docs/performance.md``
    (quick: alone into ``out/quick/results/quick_name``, no tracked file touched); returns the path."""
    if quick:
        path = results_file(quick_name, True)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        return path
    path = os.path.join(ROOT, "docs", "performance.md")
    with open(path, encoding="utf-8") as fh:
        page = fh.read()
    start, stop = page.index(begin) + len(begin), page.index(end)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(page[:start] + "\n" + text + page[stop:])
    return path


def write_csv(path: str, rows, fields=None) -> str:
    """Write ``rows`` (dicts) to the CSV ``path``, its folder made if missing; returns ``path``.

    ``fields`` orders the columns; by default every key of the rows, in first-seen order.
    """
    if fields is None:
        fields = []
        for r in rows:
            fields += [k for k in r if k not in fields]
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(fields))
        writer.writeheader()
        writer.writerows(rows)
    return path
