"""The README's set-up: two commands on a fresh machine, the first refreshing the package lists before it
installs Chromium (a stale list installs an older Chromium in which JupyterLab cannot run the browser test:
issue 46, item 0), as .ci/run does."""

from __future__ import annotations

import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _setup_commands():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("\n## Set-up", 1)[1].split("\n## ", 1)[0]
    block = section.split("```bash\n", 1)[1].split("```", 1)[0]
    return [line for line in block.splitlines() if line.strip()]


def test_the_setup_is_two_commands_install_and_demo_then_tests():
    first, second = _setup_commands()
    assert "pip install -e \".[test]\"" in first and "raycast-shade demo" in first
    assert second.strip() == ".venv/bin/python -m pytest -q"


def test_the_package_lists_are_refreshed_before_chromium_is_installed():
    first = _setup_commands()[0]
    steps = [s.strip() for s in first.split("&&")]
    update = next(i for i, s in enumerate(steps) if re.fullmatch(r"(sudo )?apt-get update( -qq)?", s))
    install = next(i for i, s in enumerate(steps) if s.startswith(("apt-get install", "sudo apt-get install")))
    assert update < install and {"chromium", "chromium-driver"} <= set(steps[install].split())


def test_ci_installs_the_same_way():
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert ci.index("apt-get update") < ci.index("apt-get install") and "chromium-driver" in ci
