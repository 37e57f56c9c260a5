"""docs/cli.md is what docs/make_cli_reference.py writes from the parser, and --help shows defaults."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))

import make_cli_reference  # noqa: E402


def test_cli_reference_is_current():
    assert (ROOT / "docs" / "cli.md").read_text(encoding="utf-8") == make_cli_reference.reference(), (
        "docs/cli.md is stale: run PYTHONPATH=$PWD python3 docs/make_cli_reference.py")


def test_every_option_of_every_subcommand_is_in_the_reference():
    import argparse

    from exudyn_study.cli import SUBCOMMANDS, build_parser

    text = make_cli_reference.reference()
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for name in SUBCOMMANDS:
        assert f"## {name}" in text
        for action in sub.choices[name]._actions:
            if (action.help != argparse.SUPPRESS and action.option_strings
                    and not isinstance(action, argparse._HelpAction)):
                assert f"`{action.option_strings[-1]}`" in text, (name, action.option_strings)


@pytest.mark.parametrize("command", ["simulate", "modes", "demo", "identify", "calibrate"])
def test_help_shows_the_defaults(command, capsys):
    from exudyn_study.cli import main

    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    expected = {"simulate": ["(default: exudyn)", "(default: 80.0)", "(default: 0)"],
                "modes": ["(default: 100.0)", "(default: production)"],
                "demo": ["(default: demo_out)", "(default: 1)"],
                "identify": ["chosen from the record length", "(default: Hv)", "(default: 60)"],
                "calibrate": ["(default: 500.0)", "(default: adams-default)"]}[command]
    for item in expected:
        assert item in text, (command, item)


def test_one_name_per_concept():
    """The same concept has the same option name in every subcommand (former spellings are hidden)."""
    import argparse

    from exudyn_study.cli import SUBCOMMANDS, build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    shown = {s for name in SUBCOMMANDS for a in sub.choices[name]._actions
             if a.help != argparse.SUPPRESS for s in a.option_strings}
    for former in ("--mesh-size", "--cutoff-hz", "--rate-hz", "--reg"):
        assert former not in shown
    cached = [name for name in SUBCOMMANDS
              if any("--mesh" in a.option_strings or "--scenario" in a.option_strings
                     for a in sub.choices[name]._actions)] + ["sweep"]
    for name in cached:  # every subcommand that builds flexible bodies takes --cache-dir
        assert any("--cache-dir" in a.option_strings for a in sub.choices[name]._actions), name


def _shown_options(name):
    """(action, its help as --help renders it) of every listed option of subcommand ``name``."""
    import argparse

    from exudyn_study.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    parser = sub.choices[name]
    formatter = parser._get_formatter()
    return [(a, " ".join(formatter._expand_help(a).split())) for a in parser._actions
            if a.option_strings and a.help != argparse.SUPPRESS and not isinstance(a, argparse._HelpAction)]


@pytest.mark.parametrize("command", sorted(__import__("exudyn_study.cli").cli.SUBCOMMANDS))
def test_help_of_every_subcommand_states_each_default_once(command, capsys):
    """Every option that takes a value and is not required says in --help what holds when it is not
    given, and not twice in brackets; the rendered --help contains those texts."""
    import re

    from exudyn_study.cli import main

    with pytest.raises(SystemExit):
        main([command, "--help"])
    page = "".join(capsys.readouterr().out.split())  # argparse wraps lines, also at hyphens
    for action, text in _shown_options(command):
        if action.nargs == 0 or action.required:
            continue
        words = re.findall(r"(?<![-\w])default(?![-\w])", text.lower())  # not 'adams-default'
        assert words and text.lower().count("(default") <= 1, (command, action.option_strings, text)
        assert "".join(text.split()) in page, (command, action.option_strings)
