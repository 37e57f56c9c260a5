"""Write ``docs/cli.md``, the command-line reference, from the argparse table of ``exudyn-study``.

Every subcommand with its description, and every option with its metavar, choices, default
and help, in the order the parser defines them. Hidden aliases (former spellings) are not
listed. ``tests/test_cli_reference.py`` fails when ``docs/cli.md`` is not what this script
writes, so the page cannot fall behind the parser.

Run::

    PYTHONPATH=$PWD python3 docs/make_cli_reference.py          # writes docs/cli.md
    PYTHONPATH=$PWD python3 docs/make_cli_reference.py --check  # exit 1 if docs/cli.md is stale
"""

from __future__ import annotations

import argparse
import os
import re
import sys
from pathlib import Path

OUT = Path(__file__).resolve().parent / "cli.md"


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _option_name(action: argparse.Action) -> str:
    names = ", ".join(f"`{s}`" for s in action.option_strings) or f"`{action.metavar or action.dest}`"
    if action.nargs == 0:
        return names
    metavar = action.metavar
    if metavar is None and action.choices is not None:
        metavar = "{" + ",".join(str(c) for c in action.choices) + "}"
    if metavar is None:
        metavar = action.dest.upper()
    if isinstance(metavar, tuple):
        metavar = " ".join(metavar)
    if action.nargs in ("+", "*"):
        metavar = f"{metavar} ..."
    return f"{names} `{metavar}`" if action.option_strings else names


def _default(action: argparse.Action) -> str:
    if action.nargs == 0 or action.default is None or action.default == argparse.SUPPRESS or action.required:
        return ""
    if isinstance(action.default, (list, tuple)):
        return " ".join(str(v) for v in action.default) if action.default else ""
    return f"`{action.default}`"


def _help(action: argparse.Action) -> str:
    text = (action.help or "").replace("%%", "%")
    if "%(default)" in text:
        text = text % {"default": action.default}
    if action.choices is not None and action.metavar is not None:
        listed = ", ".join(str(c) for c in action.choices)
        if listed not in text:
            text += f" (one of {listed})"
    if action.required:
        text += " (required)"
    return _cell(text)


def option_table(parser: argparse.ArgumentParser) -> list[str]:
    """Return the Markdown table of the option names: each name, the subcommands that take it, its meaning.

    One row per listed option name (hidden aliases left out), in alphabetical order; the
    meaning is the shortest of the option's help texts in the subcommands, without the default
    (the subcommands' own tables give each help in full).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The ``exudyn-study`` parser.
    """
    from exudyn_study.cli import SUBCOMMANDS

    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    rows: dict[str, tuple[list, str]] = {}
    for name in SUBCOMMANDS:
        for action in sub.choices[name]._actions:
            if (action.help == argparse.SUPPRESS or isinstance(action, argparse._HelpAction)
                    or not action.option_strings):
                continue
            key = ", ".join(sorted(action.option_strings, key=len, reverse=True))
            meaning = re.sub(r"(\s*\(default:[^)]*\)|;\s*default:[^)]*| \(required\))", "", _help(action))
            rows.setdefault(key, ([], []))[0].append(name)
            rows[key][1].append(meaning)
    lines = ["| option | subcommands | meaning (the shortest of its help texts) |", "|---|---|---|"]
    for key in sorted(rows, key=lambda k: k.lstrip("-").lower()):
        names, meanings = rows[key]
        meaning = min(meanings, key=len)
        shown = "every subcommand" if len(names) == len(SUBCOMMANDS) else ", ".join(names)
        lines.append(f"| `{key}` | {shown} | {meaning} |")
    return lines


def reference() -> str:
    """Return the Markdown reference of every subcommand."""
    from exudyn_study.cli import SUBCOMMANDS, build_parser

    os.environ["COLUMNS"] = "100"  # argparse wraps the usage at the terminal width: fix it
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    lines = [
        "# `exudyn-study` command-line reference",
        "",
        "Written by `docs/make_cli_reference.py` from the parser; do not edit by hand.",
        "",
        "Every subcommand accepts `-v/--verbose` and `-q/--quiet` before or after its name. Bad input",
        "(an unknown option or choice, a value out of range, an unreadable or malformed file, an output",
        "that is an input or cannot be written) is reported on one line on stderr with exit code 2,",
        "and nothing is written. Output directories are created when missing. Long steps show progress",
        "bars on stderr when it is a terminal, with a clock that keeps running while a step blocks",
        "(`-q` turns them off; `EXUDYN_STUDY_PROGRESS=1` shows them in a log too).",
        "",
        "| subcommand | what it does |",
        "|---|---|",
    ]
    for name, (_, help_text) in SUBCOMMANDS.items():
        lines.append(f"| [`{name}`](#{name}) | {_cell(help_text)} |")
    lines += ["", "## Options by name", "",
              "One name per concept: the same name means the same thing in every subcommand that takes it.",
              ""] + option_table(parser)
    for name in SUBCOMMANDS:
        p = sub.choices[name]
        lines += ["", f"## {name}", "", _cell(p.description or ""), "", "```", p.format_usage().strip(),
                  "```", "", "| option | default | description |", "|---|---|---|"]
        for action in p._actions:
            if action.help == argparse.SUPPRESS or isinstance(action, argparse._HelpAction):
                continue
            lines.append(f"| {_option_name(action)} | {_default(action)} | {_help(action)} |")
    return "\n".join(lines) + "\n"


def main() -> int:
    """Write docs/cli.md (or, with --check, compare it); return the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if docs/cli.md differs, write nothing")
    args = ap.parse_args()
    text = reference()
    if args.check:
        current = OUT.read_text(encoding="utf-8") if OUT.exists() else ""
        if current != text:
            print(f"{OUT} is stale; run python3 docs/make_cli_reference.py", file=sys.stderr)
            return 1
        return 0
    tmp = OUT.with_suffix(".md.tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(OUT)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
