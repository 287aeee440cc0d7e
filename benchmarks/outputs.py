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
