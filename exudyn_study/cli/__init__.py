"""The ``exudyn-study`` console script: one entry point, a table of subcommands.

Each subcommand lives in its own module, which defines two functions:

- ``configure(parser: argparse.ArgumentParser) -> None`` adds its arguments;
- ``run(args: argparse.Namespace) -> int`` does the work and returns the exit code.

Every subcommand module is imported to configure its parser, so these modules import
their heavy dependencies (ngsolve, exudyn) inside ``run`` only: ``exudyn-study identify``
never imports ngsolve or exudyn (a test checks it). Bad input (:class:`~exudyn_study.errors.InputError`)
is reported as one line on stderr with exit code 2, as is every usage error of the parser;
warnings (``warnings.warn`` and ``logging``) are printed through one path as one
``warning: ...`` line each, a repeated one once. ``-v/--verbose`` and ``-q/--quiet`` are
accepted before or after the subcommand.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import re
import sys
import warnings

from tqdm import tqdm

from exudyn_study.cli.options import HelpFormatter, add_verbosity
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
    "iterate-drive": ("exudyn_study.cli.iterate_drive",
                      "iterate a model's drive to match measured responses"),
    "calibrate": ("exudyn_study.cli.calibrate",
                      "choose flexible-body modal damping to match identified modes"),
    "sweep": ("exudyn_study.cli.sweep", "run a parameter sweep from a TOML file (process pool or Dask)"),
    "diagnose": ("exudyn_study.cli.diagnose",
                 "locate model/recording mismatch, name the missing physics, fit it"),
    "import": ("exudyn_study.cli.import_", "CSV/TSV time data to a recording through a column map"),
    "virtual-test": ("exudyn_study.cli.virtual_test",
                     "play a scenario on the virtual test rig into recordings"),
}


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line on stderr (exit 2), like every bad input."""

    def error(self, message: str):
        """Print ``PROG: error: MESSAGE (see PROG --help)`` on one line and exit with code 2."""
        text = " ".join(message.split())
        # 'argument --beta: 0: out of range ...' -> '--beta 0: out of range ...' (option and value first)
        text = re.sub(r"^argument ([^:]+): ('?[^:' ]*'?): ", r"\1 \2: ", text)
        text = re.sub(r"^argument ([^:]+): ", r"\1: ", text)
        self.exit(2, f"{self.prog}: error: {text} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser with every available subcommand configured."""
    parser = _Parser(
        prog="exudyn-study",
        description="Structural damping of flexible bodies: FE, rig models, EMA, fatigue, diagnosis.",
        formatter_class=HelpFormatter,
    )
    add_verbosity(parser, top_level=True)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, (module, help_text) in SUBCOMMANDS.items():
        sub_parser = sub.add_parser(name, help=help_text, description=help_text,
                                    formatter_class=HelpFormatter)
        importlib.import_module(module).configure(sub_parser)
        add_verbosity(sub_parser, top_level=False)
        sub_parser.set_defaults(_module=module)
    return parser


class _WarningPrinter(logging.Handler):
    """The one path of warnings: ``warnings.warn`` and ``logging`` warnings, one ``warning: ...`` line each.

    A message is printed the first time it occurs; repeats are counted and reported once at
    the end (:meth:`close_run`).
    """

    def __init__(self, stream) -> None:
        super().__init__(level=logging.WARNING)
        self.stream = stream
        self.counts: dict[str, int] = {}

    def show(self, message: str) -> None:
        text = " ".join(str(message).split())
        self.counts[text] = self.counts.get(text, 0) + 1
        if self.counts[text] == 1:  # above any active progress bar, which is redrawn below it
            tqdm.write(f"warning: {text}", file=self.stream)

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= logging.ERROR:
            tqdm.write(f"error: {' '.join(record.getMessage().split())}", file=self.stream)
        else:
            self.show(record.getMessage())

    def showwarning(self, message, category, filename, lineno, file=None, line=None) -> None:
        self.show(str(message))

    def close_run(self) -> None:
        repeats = sum(n - 1 for n in self.counts.values())
        if repeats:
            kinds = sum(n > 1 for n in self.counts.values())
            print(f"warning: {repeats} repeat(s) of {kinds} warning(s) above not shown again",
                  file=self.stream)


def main(argv: list[str] | None = None) -> int:
    """Run the console script; returns the process exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # a usage error (printed on one line) returns its code; --help exits
        if exc.code in (0, None):
            raise
        return int(exc.code)
    if not getattr(args, "_module", None):
        parser.print_help()
        return 1
    printer = _WarningPrinter(sys.stderr)
    root = logging.getLogger()
    saved = (root.level, list(root.handlers))
    info = logging.StreamHandler(sys.stderr)
    info.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    info.addFilter(lambda record: record.levelno < logging.WARNING)
    root.handlers = [printer] + ([info] if args.verbose else [])
    root.setLevel(logging.INFO if args.verbose else logging.WARNING)
    saved_env = {k: os.environ.get(k) for k in ("TQDM_DISABLE", "EXUDYN_STUDY_PROGRESS")}
    if args.quiet:  # every bar off: tqdm's own and the stage and status bars of exudyn_study.infra.progress
        os.environ.update(TQDM_DISABLE="1", EXUDYN_STUDY_PROGRESS="0")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", UserWarning)
            warnings.simplefilter("always", RuntimeWarning)
            warnings.showwarning = printer.showwarning
            return int(importlib.import_module(args._module).run(args) or 0)
    except InputError as exc:
        print(f"exudyn-study {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except StudyError as exc:
        print(f"exudyn-study {args.command}: failed: {_one_line(exc)}", file=sys.stderr)
        return 3
    except OSError as exc:  # a full disk, a file removed under us: the run's outputs were discarded
        print(f"exudyn-study {args.command}: failed: {_one_line(exc)}", file=sys.stderr)
        return 3
    finally:
        printer.close_run()
        root.handlers, root.level = saved[1], saved[0]
        for key, value in saved_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
