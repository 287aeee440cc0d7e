"""The command line's subcommands come from one registry (``apps/cli.py``'s ``COMMANDS``), and
the docs name exactly those: every registered subcommand is documented, every documented one
registered."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from raycast_shade.apps import cli

ROOT = Path(__file__).resolve().parents[2]
COMMANDS = cli.COMMANDS
NAMES = [c.name for c in COMMANDS]
MENTION = re.compile(r"raycast-shade ([a-z][a-z-]*)")


def _subparsers(parser):
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def test_the_parser_has_one_subcommand_per_entry_in_order():
    sub = _subparsers(cli.build_parser())
    assert list(sub.choices) == NAMES
    assert len(set(NAMES)) == len(NAMES) >= 8
    shown = {a.dest: a.help for a in sub._choices_actions}  # the lines of `raycast-shade --help`
    assert shown == {c.name: c.help for c in COMMANDS}


@pytest.mark.parametrize("command", COMMANDS, ids=NAMES)
def test_each_entry_builds_and_runs(command):
    """Builder and runner resolve; a builder's own ``help=`` (if any) is the registry's line."""
    sub = argparse.ArgumentParser().add_subparsers()
    one = cli._add_subcommand(sub, command)
    assert one.given_help in (None, command.help)
    assert isinstance(one.parser, argparse.ArgumentParser) and list(sub.choices) == [command.name]
    assert callable(command.runner())
    assert command.help and "\n" not in command.help


def test_main_dispatches_through_the_registry(monkeypatch, capsys):
    entry = cli._BY_NAME["info"]
    seen = []
    monkeypatch.setitem(cli._BY_NAME, "info", cli.Subcommand("info", entry.help, entry.build,
                                                            lambda args: seen.append(args.command) or 7))
    assert cli.main(["info"]) == 7 and seen == ["info"]
    assert capsys.readouterr().out == ""


def test_a_builder_adds_only_its_own_subcommand():
    wrong = cli.Subcommand("demo", "a demo", lambda sub: sub.add_parser("render"), lambda args: 0)
    with pytest.raises(ValueError, match="'demo' adds 'render'"):
        cli._add_subcommand(argparse.ArgumentParser().add_subparsers(), wrong)
    none = cli.Subcommand("demo", "a demo", lambda sub: None, lambda args: 0)
    with pytest.raises(ValueError, match="added no subparser"):
        cli._add_subcommand(argparse.ArgumentParser().add_subparsers(), none)


def _readme_block() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("\n## Command line\n", 1)[1].split("\n## ", 1)[0]
    return section.split("```bash\n", 1)[1].split("```", 1)[0]


def test_the_readme_shows_every_registered_subcommand_and_no_other():
    shown = MENTION.findall(_readme_block())
    assert sorted(set(shown)) == sorted(NAMES)


def _documents():
    yield ROOT / "README.md"
    yield from sorted((ROOT / "docs").glob("*.md"))
    yield from sorted((ROOT / "raycast_shade").rglob("*.py"))
    yield from sorted((ROOT / "examples").glob("*"))


def test_every_documented_subcommand_is_registered():
    unknown = {}
    for path in _documents():
        if path.is_file():
            for name in MENTION.findall(path.read_text(encoding="utf-8", errors="replace")):
                if name not in NAMES:
                    unknown.setdefault(name, str(path.relative_to(ROOT)))
    assert not unknown, f"documented but not registered in apps/cli.py's COMMANDS: {unknown}"
    assert "views" in MENTION.findall((ROOT / "docs" / "vision.md").read_text(encoding="utf-8"))  # not vacuous


def test_the_module_docstring_lists_the_registry():
    first = cli.__doc__.split("\n\n")[0]
    assert re.findall(r"``([a-z]+)``", first) == NAMES
