"""What pyproject.toml promises an installation: the console script resolves."""

from __future__ import annotations

import importlib
import os

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _project():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as fh:
        return tomllib.load(fh)["project"]


def test_console_script_names_a_callable_of_the_package():
    scripts = _project()["scripts"]
    assert set(scripts) == {"raycast-shade"}
    module, _, attr = scripts["raycast-shade"].partition(":")
    main = getattr(importlib.import_module(module), attr)
    assert callable(main) and module.startswith("raycast_shade.")
