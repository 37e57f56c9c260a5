r"""``exudyn-study identify``: modes from a recording (HDF5 or UFF58) to a modes JSON.

Example::

    exudyn-study identify run.h5 --reference ARFVZ --band 3 50 --resolution 0.2 \
        --estimator Hv --json modes.json --plots figs/

Bad input (unknown reference, mixed rates, NaN samples, a band beyond Nyquist, a
record too short for the resolution, a UFF without type-58 sets, an output that is the
input or cannot be written) is reported on one line with exit code 2, and nothing is
written: the JSON and the figures are staged and moved into place together at the end.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from exudyn_study.cli.options import Bounded
from exudyn_study.errors import InputError

__all__ = ["configure", "run"]

logger = logging.getLogger(__name__)

FREQUENCY = Bounded(float, 0.0, 1e5, "Hz", "a frequency of the recording's band", low_open=True)
RESOLUTION = Bounded(float, 0.005, 10.0, "Hz", "finer than 0.005 Hz needs records of hours per average; "
                     "coarser than 10 Hz resolves no structural mode")
MAX_ORDER = Bounded(int, 4, 200, "", "PolyMAX needs order 4 for one mode pair; each order adds a solve "
                    "and 200 is far beyond the modes of any band")


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``identify`` arguments to ``parser``."""
    parser.add_argument("file", metavar="FILE", help="recording: .h5/.hdf5 or UFF58 .uff/.unv")
    parser.add_argument("--reference", "-r", required=True, nargs="+", metavar="NAME",
                        help="reference channel(s), e.g. ARFVZ (several: one estimate each)")
    parser.add_argument("--responses", nargs="+", metavar="NAME",
                        help="response channels (default: all response channels)")
    parser.add_argument("--band", nargs=2, type=FREQUENCY, metavar=("FMIN", "FMAX"),
                        help="frequency band in Hz (default: where coherence >= 0.5)")
    parser.add_argument("--resolution", type=RESOLUTION, default=0.2, metavar="HZ",
                        help="FRF resolution in Hz")
    parser.add_argument("--estimator", choices=("H1", "H2", "Hv"), default="Hv",
                        help="FRF estimator: H1, H2 or Hv")
    parser.add_argument("--max-order", type=MAX_ORDER, default=60, metavar="N",
                        help="highest model order of the stabilisation diagram")
    parser.add_argument("--pin", type=FREQUENCY, nargs="+", default=(), metavar="HZ",
                        help="force modes near these frequencies into the selection")
    parser.add_argument("--drop", type=FREQUENCY, nargs="+", default=(), metavar="HZ",
                        help="drop selected modes near these frequencies")
    parser.add_argument("--no-leakage-correction", action="store_true",
                        help="fit plain pole terms (no model of the Welch window smoothing)")
    parser.add_argument("--json", required=True, metavar="OUT", help="modes JSON to write")
    parser.add_argument("--plots", metavar="DIR", help="write figures (PNG) into DIR (created when missing)")


def run(args: argparse.Namespace) -> int:
    """Run the identification; returns 0 on success (InputError propagates)."""
    from exudyn_study.identify.model import write_modes_json
    from exudyn_study.identify.pipeline import identify_recording
    from exudyn_study.infra.files import OutputSet
    from exudyn_study.recording.io import read_recording

    if args.band is not None and not args.band[0] < args.band[1]:
        raise InputError(f"--band {args.band[0]:g} {args.band[1]:g}: expected FMIN < FMAX in Hz")
    with OutputSet(inputs={"FILE": args.file}) as outputs:
        out = outputs.file(args.json, "--json")
        plots = outputs.directory(args.plots, "--plots")
        rec = read_recording(args.file)
        result = identify_recording(
            rec, args.reference, responses=args.responses, band_hz=args.band,
            resolution_hz=args.resolution, estimator=args.estimator,
            orders=range(2, args.max_order + 1), pin_hz=args.pin, drop_hz=args.drop,
            leakage_correction=not args.no_leakage_correction,
            metadata={"source_file": str(args.file)},
        )
        write_modes_json(result.model, out)
        figures = []
        if plots is not None:
            from exudyn_study.identify.plots import plot_all

            chans = {c.name: c for c in rec.channels}
            pos = {n: c.position_m for n, c in chans.items() if c.position_m is not None}
            dirs = {n: c.direction for n, c in chans.items()}
            figures = [Path(args.plots) / p.relative_to(plots)
                       for p in plot_all(result, plots, positions_m=pos, directions=dirs)]
    model = result.model
    lo, hi = result.band_hz
    print(f"{len(model)} modes in {lo:.2f}-{hi:.2f} Hz ({result.frf.estimator}, "
          f"{result.frf.resolution_hz:g} Hz, {result.frf.n_averages} averages, reference "
          f"{', '.join(result.frf.inputs)}):")
    print("  no.  frequency [Hz]       damping [%]        MPC")
    for k, m in enumerate(model.modes, 1):
        print(f"  {k:3d}  {m.frequency_hz:8.3f} +- {m.frequency_std_hz or 0:5.3f}   "
              f"{100 * m.damping_ratio:6.3f} +- {100 * (m.damping_std or 0):5.3f}   "
              f"{m.mpc if m.mpc is not None else float('nan'):6.3f}")
    if result.fit is not None:
        worst = result.fit.fit_error.argmax()
        print(f"fit error per channel: median {100 * float(_median(result.fit.fit_error)):.1f} %,"
              f" worst {100 * result.fit.fit_error[worst]:.1f} % ({result.frf.outputs[worst]})")
    print(f"wrote {args.json}")
    for p in figures:
        print(f"wrote {p}")
    return 0


def _median(x):
    import numpy as np

    return np.median(x)
