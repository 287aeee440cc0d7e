"""What a notebook shows that it did not ask for: stderr text and warning boxes.

A code cell may show a warning on purpose (the lecture showing the library's own ``CreaseWarning``)
only if it carries the cell tag :data:`TAG` and the markdown cell above it names each warning class
it shows. Everything else on stderr is noise: a warning box nobody explained, a progress bar, a
library's chatter. Used by ``test_notebooks.py`` (nbclient) and ``test_browser.py`` (the notebook
JupyterLab saved after Run All).
"""

from __future__ import annotations

import re

TAG = "shows-warning"
# "path:line: SomeWarning: message" as warnings.formatwarning writes it.
WARNING_LINE = re.compile(r"^(?P<file>\S.*?):(?P<line>\d+): (?P<cls>\w+Warning): ", re.M)


def stderr_text(cell) -> str:
    """All stderr a code cell showed: stream outputs, and the stderr mime type of display outputs."""
    parts = []
    for o in cell.get("outputs", []):
        if o.get("output_type") == "stream" and o.get("name") == "stderr":
            parts.append("".join(o.get("text", "")))
        elif o.get("output_type") in ("display_data", "execute_result"):
            text = o.get("data", {}).get("application/vnd.jupyter.stderr")
            if text:
                parts.append("".join(text))
    return "".join(parts)


def _source(cell) -> str:
    src = cell.get("source", "")
    return "".join(src) if isinstance(src, list) else src


def noise(nb, *, require_shown: bool = False) -> list:
    """``(cell index, why)`` for every unasked stderr output of an executed notebook (a dict, or nbformat's).

    ``require_shown``: a tagged cell must also show a warning (a fresh kernel shows each once; a
    re-run in the same kernel may not, Python's registry having seen it)."""
    found = []
    cells = nb["cells"]
    for i, cell in enumerate(cells):
        if cell.get("cell_type") != "code":
            continue
        text = stderr_text(cell)
        tagged = TAG in cell.get("metadata", {}).get("tags", [])
        if not tagged:
            if text.strip():
                found.append((i, f"stderr the notebook did not ask for: {text.strip()[:300]!r}"))
            continue
        above = next((_source(c) for c in reversed(cells[:i]) if c.get("cell_type") == "markdown"), "")
        shown = list(WARNING_LINE.finditer(text))
        if require_shown and not shown:
            found.append((i, f"tagged {TAG!r} but shows no warning (remove the tag, or the markdown's claim)"))
        for m in shown:
            if m["cls"] not in above:
                found.append((i, f"shows a {m['cls']} that the markdown above does not announce"))
            if "raycast_shade" in m["file"] or m["file"].endswith("functools.py"):
                found.append((i, f"{m['cls']} attributed to {m['file']}:{m['line']}, not to the cell's line"))
        rest = WARNING_LINE.sub("", text)
        # what remains of a warning is its message and the source line Python quotes under it
        junk = [ln for ln in rest.splitlines() if ln.strip() and not ln.startswith(" ") and not shown]
        if junk:
            found.append((i, f"stderr besides the announced warning: {junk[:2]!r}"))
    return found
