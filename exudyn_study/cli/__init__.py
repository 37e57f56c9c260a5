"""The ``exudyn-study`` console script: one entry point, a table of subcommands.

Each subcommand lives in its own module, which defines two functions:

- ``configure(parser: argparse.ArgumentParser) -> None`` adds its arguments;
- ``run(args: argparse.Namespace) -> int`` does the work and returns the exit code.

Every subcommand module is imported to configure its parser, so these modules import
their heavy dependencies (ngsolve, exudyn) inside ``run`` only: ``exudyn-study identify``
never imports ngsolve or exudyn (a test checks it). Bad input (:class:`~exudyn_study.errors.InputError`)
is reported as one line on stderr with exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

from exudyn_study.errors import InputError, StudyError

__all__ = ["SUBCOMMANDS", "main"]

#: subcommand name -> (module implementing configure/run, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("exudyn_study.cli.demo", "run the demo study on shipped settings"),
    "reduce": ("exudyn_study.cli.reduce", "mesh, assemble and reduce a flexible body"),
    "modes": ("exudyn_study.cli.modes", "system modes of a model variant (frequencies, damping, shapes)"),
    "simulate": ("exudyn_study.cli.simulate", "simulate a model variant on the rig into a recording"),
    "identify": ("exudyn_study.cli.identify", "identify modes (PolyMAX) from a recording"),
    "damage": ("exudyn_study.cli.damage", "relative pseudo damage between two recordings"),
    "iterate-drive": ("exudyn_study.cli.iterate_drive", "iterate a model's drive to match measured responses"),
    "calibrate": ("exudyn_study.cli.calibrate", "choose flexible-body modal damping to match identified modes"),
    "sweep": ("exudyn_study.cli.sweep", "run a parameter sweep from a TOML file (process pool or Dask)"),
    "diagnose": ("exudyn_study.cli.diagnose", "locate model/recording mismatch, name the missing physics, fit it"),
    "import": ("exudyn_study.cli.import_", "CSV/TSV time data to a recording through a column map"),
    "virtual-test": ("exudyn_study.cli.virtual_test", "play a scenario on the virtual test rig into recordings"),
}


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser with every available subcommand configured."""
    parser = argparse.ArgumentParser(
        prog="exudyn-study",
        description="Structural damping of flexible bodies: FE, rig models, EMA, fatigue, diagnosis.",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_text) in SUBCOMMANDS.items():
        sub_parser = sub.add_parser(name, help=help_text, description=help_text)
        importlib.import_module(module).configure(sub_parser)
        sub_parser.set_defaults(_module=module)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the console script; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    if not getattr(args, "_module", None):
        parser.print_help()
        return 1
    try:
        return int(importlib.import_module(args._module).run(args) or 0)
    except InputError as exc:
        print(f"exudyn-study {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except StudyError as exc:
        print(f"exudyn-study {args.command}: failed: {exc}", file=sys.stderr)
        return 3


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
