"""The benchmark suite and the figure scripts: where they write, checked without running them,
and that each is reachable from its runner (``python -m benchmarks``, ``python -m docs.figures``).

``python -m benchmarks --quick`` must change no tracked file: every path a
quick run writes is git-ignored, and every path a full run writes is not
(the docs quote those). The paths come from each registered benchmark's
``outputs(quick)``, which its ``main`` writes to (benchmarks/outputs.py).
"""

from __future__ import annotations

import ast
import importlib
import os
import shutil
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from benchmarks import outputs  # noqa: E402
from benchmarks.__main__ import REGISTRY  # noqa: E402


def _git_checkout():
    if shutil.which("git") is None:
        return False
    out = subprocess.run(["git", "-C", ROOT, "rev-parse", "--show-toplevel"], capture_output=True, text=True)
    return out.returncode == 0 and os.path.samefile(out.stdout.strip(), ROOT)


needs_git = pytest.mark.skipif(not _git_checkout(), reason="not a git checkout of the project")


def _ignored(paths):
    """The subset of ``paths`` that git ignores (tracked files never count as ignored)."""
    rel = [os.path.relpath(os.path.join(ROOT, p), ROOT) for p in paths]
    out = subprocess.run(["git", "-C", ROOT, "check-ignore", "--stdin"], input="\n".join(rel) + "\n",
                         capture_output=True, text=True)
    assert out.returncode in (0, 1), out.stderr  # 1: none ignored
    return set(out.stdout.split())


def _written(quick):
    """Every file the registered benchmarks write in this mode, and the generated tables."""
    paths = []
    for entry in REGISTRY:
        mod = importlib.import_module(entry["module"])
        assert hasattr(mod, "outputs"), f"{entry['module']} must declare its files with outputs(quick)"
        paths += mod.outputs(quick)
        # The files write_doc collects, with a sample name for the glob patterns.
        paths += [os.path.join(outputs.results_dir(quick), p.replace("*", "_x")) for p in entry["csv"]]
        paths += [os.path.join(outputs.images_dir(quick), p.replace("*", "_x")) for p in entry["images"]]
    return paths + [outputs.doc_path(quick)]


def test_quick_and_full_runs_write_different_files():
    quick, full = set(_written(True)), set(_written(False))
    assert quick and full and not quick & full
    for p in quick - {outputs.doc_path(True)}:
        assert os.path.dirname(p) in (outputs.results_dir(True), outputs.images_dir(True)), p


@needs_git
def test_every_quick_output_is_ignored_by_git():
    paths = {os.path.relpath(p, ROOT) for p in _written(True)}
    not_ignored = sorted(paths - _ignored(paths))
    assert not not_ignored, f"quick-mode outputs git would track: {not_ignored}"


@needs_git
def test_no_full_output_is_ignored_by_git():
    ignored = _ignored(_written(False))
    assert not ignored, f"full-run outputs that git would not track: {sorted(ignored)}"


def _path_literals(tree):
    """String constants used as path parts (os.path.join arguments, pathlib ``/`` operands), and ``"_quick"``."""
    for node in ast.walk(tree):
        parts = []
        if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "join":
            parts = node.args
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
            parts = [node.left, node.right]
        elif isinstance(node, ast.Constant) and node.value == "_quick":
            yield node.lineno, node.value
        for part in parts:
            if isinstance(part, ast.Constant) and part.value in ("results", "images"):
                yield node.lineno, part.value


@pytest.mark.parametrize("module", sorted({e["module"] for e in REGISTRY} | {"benchmarks.__main__"}))
def test_benchmarks_build_no_output_folder_of_their_own(module):
    """Output folders are named only in benchmarks/outputs.py, so outputs(quick) is the whole story."""
    path = os.path.join(ROOT, *module.split(".")) + ".py"
    bad = sorted(_path_literals(ast.parse(open(path, encoding="utf-8").read())))
    assert not bad, f"{module}: " + "; ".join(f"line {n}: {v!r}" for n, v in bad)


def test_the_path_literal_check_is_not_vacuous():
    old = 'RESULTS = os.path.join(HERE, "results")\nsuffix = "_quick" if quick else ""\np = ROOT / "docs" / "images"\n'
    assert sorted(v for _, v in _path_literals(ast.parse(old))) == ["_quick", "images", "results"]


def _package_imports(path):
    """(line, module, name or None) of every ``raycast_shade`` import in a file, at any depth
    (the benchmarks import most of theirs inside functions, where no import-time error shows)."""
    tree = ast.parse(open(path, encoding="utf-8").read())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("raycast_shade"):
            for alias in node.names:
                yield node.lineno, node.module, alias.name
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("raycast_shade"):
                    yield node.lineno, alias.name, None


def test_every_package_name_a_benchmark_imports_exists():
    """A module moved or a name renamed breaks a benchmark only when it runs (the peers
    benchmark needs Open3D and EGL, which CI lacks): every import is resolved here."""
    missing = []
    files = [os.path.join(d, f) for d in (os.path.join(ROOT, "benchmarks"), FIGURES_DIR)
             for f in sorted(os.listdir(d)) if f.endswith(".py")]
    for path in files:
        fname = os.path.relpath(path, ROOT)
        for line, module, name in _package_imports(path):
            try:
                mod = importlib.import_module(module)
            except ImportError as exc:
                missing.append(f"{fname}:{line}: {module} ({exc})")
                continue
            if name is not None and not hasattr(mod, name):
                try:
                    importlib.import_module(f"{module}.{name}")
                except ImportError:
                    missing.append(f"{fname}:{line}: {module}.{name}")
    assert not missing, missing


# -- one suite: every benchmark registered, every figure script reachable ---------------------------

FIGURES_DIR = os.path.join(ROOT, "docs", "figures")
# The runner and the helpers (corpus_geometry: corpus_check.py's "geometry" subcommand, on a samples folder;
# gradient_panels: what the per-pixel gradient figures share).
NOT_BENCHMARKS = {"__init__", "__main__", "outputs", "corpus_geometry", "gradient_panels"}


def _modules_in(folder, package):
    return sorted(f"{package}.{f[:-3]}" for f in os.listdir(folder)
                  if f.endswith(".py") and f[:-3] not in NOT_BENCHMARKS)


def test_every_benchmark_module_is_registered():
    """A benchmark that runs only on its own drifts: each module of benchmarks/ is in the registry."""
    registered = [e["module"] for e in REGISTRY]
    assert len(registered) == len(set(registered))
    assert sorted(registered) == _modules_in(os.path.join(ROOT, "benchmarks"), "benchmarks")
    assert len({e["name"] for e in REGISTRY}) == len(REGISTRY)


def test_every_figure_script_is_reachable_from_the_runner():
    from docs.figures.__main__ import FIGURES

    listed = [f["module"] for f in FIGURES]
    assert len(listed) == len(set(listed))
    assert sorted(listed) == _modules_in(FIGURES_DIR, "docs.figures")
    for f in FIGURES:
        assert os.path.exists(os.path.join(ROOT, "docs", f["page"])), f
        mod = importlib.import_module(f["module"])
        assert callable(getattr(mod, "main", None)), f"{f['module']} needs main(argv)"


@pytest.mark.parametrize("name", _modules_in(FIGURES_DIR, "docs.figures"))
def test_figure_scripts_write_through_the_outputs_module(name):
    """A figure script names no output folder itself and takes ``--quick``, which sends its
    files to the quick folders of benchmarks/outputs.py (git-ignored, checked above)."""
    path = os.path.join(ROOT, *name.split(".")) + ".py"
    src = open(path, encoding="utf-8").read()
    tree = ast.parse(src)
    bad = sorted(_path_literals(tree))
    assert not bad, f"{name}: " + "; ".join(f"line {n}: {v!r}" for n, v in bad)
    assert "--quick" in src
    assert any(isinstance(n, ast.ImportFrom) and n.module == "benchmarks.outputs" for n in ast.walk(tree)), name


def test_quick_outputs_are_outside_the_tracked_folders():
    """Not under docs/ or benchmarks/ at all: a quick run cannot touch a tracked file even where
    .gitignore would be wrong."""
    tracked = [os.path.join(ROOT, "docs"), os.path.join(ROOT, "benchmarks")]
    for path in (outputs.results_dir(True), outputs.images_dir(True), outputs.doc_path(True)):
        assert not any(os.path.commonpath([path, t]) == t for t in tracked), path
        assert os.path.commonpath([path, ROOT]) == ROOT
    assert outputs.results_dir(False) == os.path.join(ROOT, "benchmarks", "results")
    assert outputs.images_dir(False) == os.path.join(ROOT, "docs", "images")


def test_the_figure_check_finds_every_changed_picture(tmp_path):
    """``python -m docs.figures --check`` compares pixels, not bytes: a re-encoded identical
    picture passes; a changed pixel, a new size or a missing tracked file is reported."""
    import imageio.v3 as iio
    import numpy as np

    from docs.figures.__main__ import differing

    new, old = tmp_path / "new", tmp_path / "old"
    new.mkdir()
    old.mkdir()
    img = np.zeros((4, 5, 3), np.uint8)
    iio.imwrite(old / "same.png", img)
    iio.imwrite(new / "same.png", img, compress_level=0)  # other bytes, same pixels
    iio.imwrite(old / "changed.png", img)
    changed = img.copy()
    changed[1, 2] = (0, 7, 0)
    iio.imwrite(new / "changed.png", changed)
    iio.imwrite(old / "resized.png", img)
    iio.imwrite(new / "resized.png", img[:3])
    iio.imwrite(new / "new.png", img)
    (new / "notes.csv").write_text("a,b\n")
    found = dict(differing(str(new), str(old)))
    assert sorted(found) == ["changed.png", "new.png", "resized.png"]
    assert found["changed.png"] == "max difference 7, in 1 pixel(s)"


def test_bench_paths_only_without_a_csv_says_so(tmp_path, monkeypatch, capsys):
    """``--only`` re-times rows of an existing CSV; with none yet it ends with one line, exit 2."""
    import benchmarks.bench_paths as bp

    monkeypatch.setattr(bp, "results_file", lambda name, quick: str(tmp_path / name))
    with pytest.raises(SystemExit) as e:
        bp.main(["--quick", "--only", "explain"])
    assert e.value.code == 2 and "does not exist yet" in capsys.readouterr().err
