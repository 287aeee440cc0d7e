"""The notebooks in notebooks/ run from top to bottom without error (their cells assert what the
lecture says) and without noise (no stderr output, no warning box, except a warning a cell tagged
``shows-warning`` shows on purpose and the markdown above it announces: notebook_noise.py), and are
committed without outputs (docs/teaching.md shows the pictures)."""

from __future__ import annotations

import os
import pathlib

import pytest

from .notebook_noise import TAG, noise

ROOT = pathlib.Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def test_there_are_notebooks():
    assert {p.stem for p in NOTEBOOKS} >= {"lecture", "exercise", "explorer"}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_is_committed_without_outputs(path):
    import nbformat

    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    stale = [i for i, c in enumerate(nb.cells) if c.cell_type == "code" and (c.outputs or c.execution_count)]
    assert not stale, f"{path.name}: cells {stale} have outputs; clear them before committing (docs/teaching.md)"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs(path, tmp_path, monkeypatch):
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    # The kernel is this interpreter: ipykernel's "python3" spec, whose "python" jupyter_client
    # replaces by sys.executable (nothing to register in a fresh venv). It imports the package this
    # test imports: the checkout's, first on its path.
    paths = [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(paths))
    client = NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    client.execute()  # raises CellExecutionError, with the cell and its traceback, on the first failing cell
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
    assert not noise(nb, require_shown=True), noise(nb, require_shown=True)
    assert any(o.get("data", {}).get("image/png") for c in nb.cells if c.cell_type == "code" for o in c.outputs)


def _cell(kind, source="", tags=(), stderr=None):
    cell = {"cell_type": kind, "source": source, "metadata": {"tags": list(tags)} if tags else {}}
    if kind == "code":
        cell["outputs"] = [] if stderr is None else [{"output_type": "stream", "name": "stderr", "text": stderr}]
    return cell


_CREASE = ("/tmp/ipykernel_7/123.py:9: CreaseWarning: mesh: 12 edge(s) join faces at more than 60 degrees\n"
           "  cubes = {k: rs.render(...)}\n")


@pytest.mark.parametrize("cells, flagged", [
    ([_cell("code", stderr="")], []),                                                      # quiet
    ([_cell("code", stderr=_CREASE)], [0]),                                                # untagged warning
    ([_cell("code", stderr="100%|#####| 3/3\n")], [0]),                                    # a progress bar
    ([_cell("markdown", "a `CreaseWarning` follows"), _cell("code", tags=[TAG], stderr=_CREASE)], []),
    ([_cell("markdown", "no warning named"), _cell("code", tags=[TAG], stderr=_CREASE)], [1]),
    ([_cell("markdown", "CreaseWarning"), _cell("code", tags=[TAG], stderr=_CREASE.replace(
        "/tmp/ipykernel_7/123.py:9", "/usr/lib/python3.11/functools.py:1001"))], [1]),     # not the user's line
    ([_cell("markdown", "CreaseWarning"), _cell("code", tags=[TAG], stderr="")], [1]),    # stale tag
    ([_cell("markdown", "CreaseWarning"), _cell("code", tags=[TAG], stderr="chatter\n")], [1]),
])
def test_noise_flags_what_the_notebook_did_not_ask_for(cells, flagged):
    found = noise({"cells": cells}, require_shown=True)
    assert sorted({i for i, _ in found}) == flagged, found


def test_every_tagged_cell_is_announced_in_the_markdown_above_it():
    """The lecture's one warning on purpose is tagged and announced (and no notebook tags a cell idly)."""
    import nbformat

    tagged = {}
    for path in NOTEBOOKS:
        nb = nbformat.read(path, as_version=4)
        for i, c in enumerate(nb.cells):
            if TAG in c.metadata.get("tags", []):
                above = next(m.source for m in reversed(nb.cells[:i]) if m.cell_type == "markdown")
                assert "Warning" in above and TAG in above, (path.name, i)
                tagged.setdefault(path.stem, []).append(i)
    assert tagged == {"lecture": [22]}, tagged
