r"""``exudyn-study import``: CSV/TSV time data to a recording (``.h5`` or ``.uff``) through a column map.

Example (a shaker test: force gauge, drive-point and two joint accelerometers in g)::

    exudyn-study import run.csv --rate 400 --out run.h5 \
        --column force=Fz:force:N:Z:drive --column DP=a1:acceleration:g \
        --column A=a2:acceleration:g --column B=a3:acceleration:g \
        --position force=0.1,0,0 --position DP=0.1,0,0

A missing or non-numeric column, rows of unequal length or a missing rate is reported on
one line with exit code 2, and nothing is written.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

from exudyn_study.errors import InputError

__all__ = ["configure", "run"]

#: largest CSV/TSV file read (bytes): a day of 64 channels at 1 kHz in text is about 20 GB, refused
MAX_CSV_BYTES = 2 * 1024**3


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``import`` arguments to ``parser``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The ``import`` subcommand's parser; gets ``FILE``, ``--column`` (repeated, required),
        ``--rate``, ``--time-column``, ``--position`` (repeated), ``--delimiter`` and ``--out``
        (required).
    """
    parser.add_argument("file", metavar="FILE", help="delimited time data (.csv, .tsv, .txt)")
    parser.add_argument(
        "--column",
        action="append",
        required=True,
        metavar="MAP",
        help="NAME=COLUMN:QUANTITY:UNIT[:DIRECTION[:ROLE]] (COLUMN: header or 0-based "
        "index; ROLE 'drive' for the excitation), once per channel",
    )
    parser.add_argument("--rate", type=float, metavar="HZ",
                        help="sampling rate in Hz (default: none; give it or --time-column)")
    parser.add_argument("--time-column", metavar="COLUMN",
                        help="column of the sample times in s (default: none; give it or --rate)")
    parser.add_argument(
        "--position",
        action="append",
        default=[],
        metavar="NAME=X,Y,Z",
        help="a channel's position in m (the drive-point accelerometer at the force's; default: none)",
    )
    parser.add_argument("--delimiter", metavar="SEP", help="column separator (default from the suffix)")
    parser.add_argument("--out", required=True, metavar="OUT", help="recording to write (.h5 or .uff)")


def _positions(items) -> dict[str, tuple[float, float, float]]:
    out = {}
    for text in items:
        name, eq, xyz = text.partition("=")
        try:
            pos = tuple(float(v) for v in xyz.split(","))
        except ValueError:
            pos = ()
        if not eq or len(pos) != 3:
            raise InputError(f"--position {text!r}: expected NAME=X,Y,Z in m, e.g. DP=0.1,0,0")
        out[name.strip()] = pos
    return out


def run(args: argparse.Namespace) -> int:
    """Read the file through the column map and write the recording; returns 0.

    The output is declared and checked before the file is read and written staged, so a
    refused input leaves nothing behind.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of :func:`configure`: ``file``, ``column`` (list of
        ``NAME=COLUMN:QUANTITY:UNIT[:DIRECTION[:ROLE]]``), ``rate`` (Hz or None),
        ``time_column`` (header name, 0-based index or None), ``position`` (list of
        ``NAME=X,Y,Z`` in m), ``delimiter`` (or None) and ``out`` (``.h5``/``.hdf5`` or
        ``.uff``/``.unv``).

    Returns
    -------
    int
        0, the exit code.

    Raises
    ------
    InputError
        An output suffix that is not a recording's, a rate outside (0, 1e7] Hz, a missing,
        empty or too large input file, a malformed ``--column`` or ``--position``, a position
        for a channel not in the map, an output that cannot be written, or any refusal of
        :func:`~exudyn_study.recording.csv.read_csv`.
    """
    from exudyn_study.infra.files import OutputSet, check_input_file
    from exudyn_study.recording.csv import parse_column, read_csv
    from exudyn_study.recording.io import write_recording

    if Path(args.out).suffix.lower() not in (".h5", ".hdf5", ".uff", ".unv"):
        raise InputError(f"--out {args.out!r}: expected a .h5/.hdf5 or .uff/.unv file name")
    if args.rate is not None and not (math.isfinite(args.rate) and 0.0 < args.rate <= 1e7):
        raise InputError(f"--rate {args.rate!r}: expected a sampling rate in (0, 1e7] Hz")
    source = check_input_file(args.file, "FILE", max_bytes=MAX_CSV_BYTES)
    cols = [parse_column(t) for t in args.column]
    pos = _positions(args.position)
    unknown = sorted(set(pos) - {c.name for c in cols})
    if unknown:
        raise InputError(f"--position for {', '.join(unknown)}: no such channel in the --column map")
    cols = [replace(c, position_m=pos.get(c.name)) for c in cols]
    tcol = args.time_column
    if tcol is not None and tcol.isdigit():
        tcol = int(tcol)
    with OutputSet(inputs={"FILE": str(source)}) as outputs:
        out = outputs.file(args.out, "--out")
        rec = read_csv(source, cols, sample_rate_hz=args.rate, time_column=tcol, delimiter=args.delimiter)
        write_recording(rec, out)
    n = rec.channels[0].n_samples
    rate = rec.channels[0].sample_rate_hz
    print(f"wrote {args.out}: {len(rec.channels)} channels, {n} samples at {rate:g} Hz")
    return 0
