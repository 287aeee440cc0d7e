"""Platforms without an Embree 4 binding: ``import raycast_shade`` names the platform and the remedy.

The missing or old library is simulated: ``sys.modules['embreex'] = None`` (what an
interpreter without the package sees) or a stand-in module carrying an Embree 2 version,
in a fresh interpreter so that the real import runs.
"""

from __future__ import annotations

import subprocess
import sys
import types

import pytest

from raycast_shade.visibility import platforms
from raycast_shade.visibility.platforms import platform_name, require_embreex


def _import_with(setup: str) -> subprocess.CompletedProcess:
    code = f"import sys, types\n{setup}\nimport raycast_shade\n"
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)


def test_missing_embreex_is_one_import_error_naming_the_platform_and_remedy():
    run = _import_with("sys.modules['embreex'] = None")
    assert run.returncode == 1
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: raycast_shade needs embreex 4")
    assert "embreex cannot be imported" in last and platform_name() in last and "Remedy:" in last
    assert "OSError" not in run.stderr and "undefined symbol" not in run.stderr  # not a loader error


def test_an_embree2_binding_is_refused_at_import():
    run = _import_with("m = types.ModuleType('embreex'); m.__version__ = '2.17.7.post7'; sys.modules['embreex'] = m")
    assert run.returncode == 1
    last = run.stderr.strip().splitlines()[-1]
    assert "embreex 2.17.7.post7 binds Embree 2" in last and platform_name() in last


def test_the_installed_embreex_passes():
    assert require_embreex().split(".")[0] == "4"


@pytest.mark.parametrize("system, machine, mac, says", [
    ("Linux", "aarch64", "", "PyPI has no embreex 4 wheel for Linux aarch64"),
    ("Linux", "x86_64", "", "pip install --upgrade 'embreex>=4.4' (PyPI has its wheel for Linux x86_64)"),
    ("Windows", "AMD64", "", "PyPI has its wheel for Windows AMD64"),
    ("Darwin", "arm64", "14.2", "PyPI has its wheel for macOS 14.2 arm64"),
    ("Darwin", "arm64", "12.7", "PyPI has no embreex 4 wheel for macOS 12.7 arm64"),
    ("Darwin", "x86_64", "12.6", "before 13 pip picks embreex 2.17"),
    ("Darwin", "x86_64", "", "on macOS 13+"),  # no version: cannot tell, both remedies named
])
def test_the_remedy_follows_the_platform(monkeypatch, system, machine, mac, says):
    monkeypatch.setitem(sys.modules, "embreex", None)
    with pytest.raises(ImportError) as info:
        require_embreex(system, machine, mac)
    assert says in str(info.value)
    assert platform_name(system, machine, mac) in str(info.value)


def test_an_old_binding_without_a_version_attribute_is_read_from_metadata(monkeypatch):
    monkeypatch.setitem(sys.modules, "embreex", types.ModuleType("embreex"))
    from importlib import metadata

    monkeypatch.setattr(metadata, "version", lambda name: "2.17.7.post7" if name == "embreex" else "0")
    with pytest.raises(ImportError, match="binds Embree 2"):
        require_embreex("Darwin", "x86_64", "12.6")


def test_a_version_that_says_nothing_is_not_guessed(monkeypatch):
    monkeypatch.setitem(sys.modules, "embreex", types.ModuleType("embreex"))
    from importlib import metadata

    def none(name):
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(metadata, "version", none)
    assert require_embreex("Linux", "x86_64", "") is None  # cannot tell: the first render will say
