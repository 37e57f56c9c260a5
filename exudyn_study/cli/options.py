"""The options shared by the subcommands: one name, one meaning, one bound each.

Every numeric option is parsed by a :class:`Bounded` type, so a value outside its range is
refused by the parser (one line, exit 2) before anything is computed, and the message says
why the bound is there. The option vocabulary (``docs/cli.md`` lists it per subcommand):

========================  ================================================================
``--model``               rig model variant (1, 2, 3; ``diagnose`` also ``modal:REC``)
``--damping``             flexible-body damping function by name
``--mesh``                mesh of the flexible bodies: coarse, production or a size in m
``--cache-dir``           flexible-body cache directory (default ``$EXUDYN_STUDY_CACHE`` or
                          ``~/.cache/exudyn_study``)
``--seed``                random seed (an integer >= 0)
``--duration``            signal duration in s
``--max-frequency``       highest frequency kept, in Hz
``--resolution``          FRF frequency resolution in Hz
``--rate``                sample rate in Hz
``--regularization``      regularisation weight
``--json``                a JSON result file
``--out``                 a recording file or an output directory (created when missing)
``--plot`` / ``--plots``  one figure file / a directory of figures
``-v/--verbose``          log progress details (before or after the subcommand)
``-q/--quiet``            only errors and warnings; no progress bars
========================  ================================================================
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

__all__ = [
    "Bounded",
    "MESH_MIN_M",
    "MESH_MAX_M",
    "SEED_MAX",
    "DURATION_MAX_S",
    "parse_mesh_option",
    "add_mesh",
    "add_hidden_alias",
    "add_cache_dir",
    "add_seed",
    "add_damping",
    "add_verbosity",
    "HelpFormatter",
]

#: largest seed: it is stored as a 64-bit integer in the recordings' metadata
SEED_MAX = 2**63 - 1
#: longest simulated or virtual recording (s): 43 channels at 1000 Hz are 1.2 GB per hour in
#: memory, and a thesis test record is 60-120 s
DURATION_MAX_S = 3600.0
#: element size bounds of --mesh (m): below 0.04 m the chassis mesh has several times the
#: production mesh's 160 000 DOF (hours to reduce, tens of GB); above 0.5 m (larger than the
#: chassis's members) Netgen cannot mesh the geometry
MESH_MIN_M = 0.04
MESH_MAX_M = 0.5


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Show every option's default in ``--help`` (options without a default say nothing)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "%(default)" in text or not action.option_strings:
            return text
        if action.default is None or action.default is False or action.default == argparse.SUPPRESS:
            return text
        if isinstance(action.default, (list, tuple)) and not action.default:
            return text
        return text + " (default: %(default)s)"


def _number_text(value: float) -> str:
    if float(value).is_integer() and abs(value) < 1e19:
        return str(int(value))
    return f"{value:g}"


@dataclass(frozen=True)
class Bounded:
    """An argparse type: an int or float within ``[low, high]``, with the reason for the bounds.

    Parameters
    ----------
    kind : type
        ``int`` or ``float``.
    low, high : float or None
        Inclusive bounds (None: unbounded on that side).
    unit : str
        Unit for the message (``'s'``, ``'Hz'``), or ''.
    reason : str
        Why the bounds are there, appended to the message.
    low_open : bool
        Exclude ``low`` itself (a duration > 0).
    """

    kind: type
    low: float | None
    high: float | None
    unit: str = ""
    reason: str = ""
    low_open: bool = False

    @property
    def __name__(self) -> str:  # argparse names the type in its "invalid ... value" message
        return self.kind.__name__

    def describe(self) -> str:
        """Return the accepted range as text, e.g. ``'> 0 and <= 3600 s'``."""
        parts = []
        if self.low is not None:
            parts.append(f"{'>' if self.low_open else '>='} {_number_text(self.low)}")
        if self.high is not None:
            parts.append(f"<= {_number_text(self.high)}")
        text = " and ".join(parts) or "any value"
        return f"{text} {self.unit}".rstrip()

    def __call__(self, text: str):
        """Parse ``text``; raise ``argparse.ArgumentTypeError`` with the range and reason."""
        what = "an integer" if self.kind is int else "a number"
        try:
            if self.kind is int:
                digits = text.strip().lstrip("+-")
                if digits.isdigit() and len(digits) > 30:  # far out of any range; int() of 5000 digits fails
                    raise argparse.ArgumentTypeError(
                        f"{text[:12]}...: out of range ({len(digits)} digits); expected {self.describe()}")
                value = int(text)
            else:
                value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: not {what}; expected {what} "
                                             f"{self.describe()}") from None
        if self.kind is float and not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text}: not finite; expected {self.describe()}")
        too_low = self.low is not None and (value <= self.low if self.low_open else value < self.low)
        too_high = self.high is not None and value > self.high
        if too_low or too_high:
            reason = f" ({self.reason})" if self.reason else ""
            raise argparse.ArgumentTypeError(f"{text}: out of range; expected {self.describe()}{reason}")
        return value


def parse_mesh_option(text: str):
    """Parse ``--mesh``: ``'coarse'``, ``'production'`` or an element size in m within bounds.

    Used as the argparse ``type`` of ``--mesh``, so a bad value is refused by the parser.

    Parameters
    ----------
    text : str
        The option's value as given on the command line: ``'coarse'``, ``'production'`` or a
        number, the element size of the flexible bodies' mesh in m.

    Returns
    -------
    str or float
        The preset name unchanged, or the element size in m (within
        [:data:`MESH_MIN_M`, :data:`MESH_MAX_M`]).

    Raises
    ------
    argparse.ArgumentTypeError
        If ``text`` is neither a preset name nor a number, or the size is out of bounds (the
        message gives the range and why it is there).
    """
    if text in ("coarse", "production"):
        return text
    size = Bounded(float, MESH_MIN_M, MESH_MAX_M, "m",
                   "below, the chassis mesh grows to several times the production DOF; above, "
                   "Netgen cannot mesh the members")(text) if _is_number(text) else None
    if size is None:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected coarse, production or an element size in m "
            f"({_number_text(MESH_MIN_M)} to {_number_text(MESH_MAX_M)})")
    return size


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def add_mesh(parser: argparse.ArgumentParser, help_text: str = "mesh of the flexible bodies") -> None:
    """Add ``--mesh {coarse,production,SIZE_M}`` (default ``'production'``).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The (sub)command parser the option is added to.
    help_text : str, optional
        What the mesh is of, the start of the option's help; the accepted values and the size
        range in m are appended.
    """
    parser.add_argument("--mesh", type=parse_mesh_option, default="production",
                        metavar="{coarse,production,SIZE_M}",
                        help=f"{help_text}: coarse, production or an element size in m "
                             f"({_number_text(MESH_MIN_M)}-{_number_text(MESH_MAX_M)})")


def add_hidden_alias(parser: argparse.ArgumentParser, old: str, dest: str, **kwargs) -> None:
    """Accept the old spelling ``old`` of an option (stored in ``dest``) without listing it in --help.

    The alias has no default (``argparse.SUPPRESS``), so when it is not given it leaves the
    value of the current option that shares ``dest`` untouched.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The (sub)command parser that has the current option.
    old : str
        The old option string, e.g. ``'--reg'``.
    dest : str
        Attribute of the parsed namespace that the current option fills, e.g.
        ``'regularization'``; the alias stores its value there too.
    **kwargs
        Further ``add_argument`` arguments, as for the current option (typically its
        ``type``, so the alias is parsed and bounded the same way).
    """
    parser.add_argument(old, dest=dest, default=argparse.SUPPRESS, help=argparse.SUPPRESS, **kwargs)


def add_cache_dir(parser: argparse.ArgumentParser) -> None:
    """Add ``--cache-dir DIR`` (flexible-body cache).

    The default None means ``$EXUDYN_STUDY_CACHE``, else ``~/.cache/exudyn_study`` (resolved by
    :func:`exudyn_study.infra.cache.cache_dir`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The (sub)command parser the option is added to.
    """
    parser.add_argument("--cache-dir", default=None, metavar="DIR",
                        help="flexible-body cache directory (default: $EXUDYN_STUDY_CACHE or "
                             "~/.cache/exudyn_study)")


def add_seed(parser: argparse.ArgumentParser, default: int | None, help_text: str) -> None:
    """Add ``--seed N`` (an integer in [0, 2**63 - 1]).

    The upper bound is :data:`SEED_MAX`: the seed is stored as a 64-bit integer in the
    recording's metadata.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The (sub)command parser the option is added to.
    default : int or None
        Seed used when the option is not given; None leaves the choice to the command (e.g.
        the scenario's own seed).
    help_text : str
        The option's help: what the seed drives in this command.
    """
    parser.add_argument("--seed", type=Bounded(int, 0, SEED_MAX, "",
                                               "stored as a 64-bit integer in the recording's metadata"),
                        default=default, metavar="N", help=help_text)


def add_damping(parser: argparse.ArgumentParser, choices: tuple[str, ...], default: str = "adams-default",
                help_text: str = "damping function of the flexible bodies") -> None:
    """Add ``--damping NAME`` with its choices listed.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The (sub)command parser the option is added to.
    choices : tuple of str
        Names of the damping functions the command accepts; any other name is refused by the
        parser, and the names are listed in the help.
    default : str, optional
        Damping function used when the option is not given; should be one of ``choices``.
    help_text : str, optional
        The start of the option's help; the choices are appended.
    """
    parser.add_argument("--damping", choices=choices, default=default, metavar="NAME",
                        help=f"{help_text}: {', '.join(choices)}")


def add_verbosity(parser: argparse.ArgumentParser, *, top_level: bool) -> None:
    """Add ``-v/--verbose`` and ``-q/--quiet``; after the subcommand they override nothing unless given.

    The two flags are mutually exclusive within one parser.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The top-level parser or a subcommand's parser.
    top_level : bool
        True for the top-level parser: the flags default to False. False for a subcommand's
        parser: they have no default (``argparse.SUPPRESS``), so a flag given before the
        subcommand is not reset by the subcommand's parser when it is not repeated after it.
    """
    default = False if top_level else argparse.SUPPRESS
    group = parser.add_mutually_exclusive_group()
    group.add_argument("-v", "--verbose", action="store_true", default=default, help="log progress details")
    group.add_argument("-q", "--quiet", action="store_true", default=default,
                       help="print only results, warnings and errors; no progress bars")
