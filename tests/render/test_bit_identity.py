"""Images are bit-identical to those of the code before the refactor (see tests/render/golden_renders.py)."""

from __future__ import annotations

import json

from tests.render.golden_renders import HASHES, isa, render_hashes


def test_every_golden_render_is_bit_identical():
    assert HASHES.exists(), f"no golden hashes for this machine's instruction set ({isa()}): write {HASHES.name} " \
                            "with the code before a change (python -m tests.render.golden_renders --write)"
    expected = json.loads(HASHES.read_text())
    assert len(expected) == 84
    got = render_hashes()
    assert set(got) == set(expected)
    changed = {k: [part for part in ("image", "hits", "normal", "depth") if got[k][part] != v[part]]
               for k, v in expected.items() if got[k] != v}
    assert not changed, f"{len(changed)} of {len(expected)} renders changed: {changed}"
