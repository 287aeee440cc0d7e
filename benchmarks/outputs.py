"""Where the benchmarks write, by mode.

A full run's CSVs (``benchmarks/results/``), charts (``docs/images/``) and
tables (``docs/benchmarks.md``) are committed: the docs quote them. A quick
run (``--quick``) is a smoke test of the same machinery on small sizes; its
files keep the full run's names but go to ``benchmarks/results/quick/``,
``docs/images/quick/`` and ``docs/benchmarks_quick.md``, which ``.gitignore``
lists, so that ``python -m benchmarks --quick`` changes no tracked file and
never overwrites a full run's numbers (``tests/project/test_benchmark_outputs.py``
checks the folders with ``git check-ignore``).
"""

from __future__ import annotations

import os

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def results_dir(quick: bool) -> str:
    """Folder of the CSVs: ``benchmarks/results/`` (full) or ``benchmarks/results/quick/``."""
    base = os.path.join(HERE, "results")
    return os.path.join(base, "quick") if quick else base


def images_dir(quick: bool) -> str:
    """Folder of the charts: ``docs/images/`` (full) or ``docs/images/quick/``."""
    base = os.path.join(ROOT, "docs", "images")
    return os.path.join(base, "quick") if quick else base


def doc_path(quick: bool) -> str:
    """The generated tables: ``docs/benchmarks.md`` (full) or ``docs/benchmarks_quick.md``."""
    return os.path.join(ROOT, "docs", "benchmarks_quick.md" if quick else "benchmarks.md")


def results_file(name: str, quick: bool) -> str:
    """``results_dir(quick)/name``."""
    return os.path.join(results_dir(quick), name)


def image_file(name: str, quick: bool) -> str:
    """``images_dir(quick)/name``."""
    return os.path.join(images_dir(quick), name)
