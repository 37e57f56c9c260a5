r"""``exudyn-study identify``: modes from a recording or measured FRFs to a modes JSON.

Examples::

    exudyn-study identify run.h5 --reference ARFVZ --json modes.json
    exudyn-study identify run.h5 --reference ARFVZ --band 3 50 --resolution 0.2 \
        --estimator Hv --json modes.json --plots figs/
    exudyn-study identify frfs.uff --reference 1:+Z --json modes.json

Without ``--band``/``--resolution`` both are chosen from the data and printed. Bad input
(unknown reference, mixed rates, NaN samples, a band beyond Nyquist, a record too short for
the resolution, a UFF without type-58 sets, an FRF file without reference records, mixing FRFs
and time data, or FRFs on different grids, an output that is the input or cannot be written)
is reported on one line with exit code 2, and nothing is written: the JSON and the figures are
staged and moved into place together at the end.
"""

from __future__ import annotations

import argparse
import logging
import warnings
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
    parser.add_argument("file", metavar="FILE",
                        help="recording (.h5/.hdf5 or UFF58 time data .uff/.unv), or measured FRFs "
                             "(UFF58 function type 4, or an HDF5 file with an 'frf' group)")
    parser.add_argument("--reference", "-r", required=True, nargs="+", metavar="NAME",
                        help="reference channel(s), e.g. ARFVZ (several: one estimate each); for an "
                             "FRF file the reference DOF as NODE:+DIR, e.g. 1:+Z")
    parser.add_argument("--responses", nargs="+", metavar="NAME",
                        help="response channels (default: all response channels)")
    parser.add_argument("--band", nargs=2, type=FREQUENCY, metavar=("FMIN", "FMAX"),
                        help="frequency band in Hz (default: where the reference is excited; for "
                             "FRF files where the coherence is >= 0.5)")
    parser.add_argument("--resolution", type=RESOLUTION, default=None, metavar="HZ",
                        help="FRF resolution in Hz (default: chosen from the record length and "
                             "the modes of a survey pass; not for FRF files)")
    parser.add_argument("--estimator", choices=("H1", "H2", "Hv"), default="Hv",
                        help="FRF estimator: H1, H2 or Hv")
    parser.add_argument("--max-order", type=MAX_ORDER, default=60, metavar="N",
                        help="highest model order of the stabilisation diagram")
    parser.add_argument("--pin", type=FREQUENCY, nargs="+", default=(), metavar="HZ",
                        help="force modes near these frequencies into the selection (default: none)")
    parser.add_argument("--drop", type=FREQUENCY, nargs="+", default=(), metavar="HZ",
                        help="drop selected modes near these frequencies (default: none)")
    parser.add_argument("--no-leakage-correction", action="store_true",
                        help="fit plain pole terms (no model of the Welch window smoothing)")
    parser.add_argument("--json", required=True, metavar="OUT", help="modes JSON to write")
    parser.add_argument("--plots", metavar="DIR",
                        help="write figures (PNG) into DIR (created when missing; default: no figures)")


def run(args: argparse.Namespace) -> int:
    """Run the identification; returns 0 on success (InputError propagates)."""
    from exudyn_study.identify.model import write_modes_json
    from exudyn_study.identify.pipeline import identify_recording
    from exudyn_study.infra.files import OutputSet
    from exudyn_study.recording.io import read_recording

    if args.band is not None and not args.band[0] < args.band[1]:
        raise InputError(f"--band {args.band[0]:g} {args.band[1]:g}: expected FMIN < FMAX in Hz")
    from exudyn_study.identify.frf_io import is_frf_file

    with OutputSet(inputs={"FILE": args.file}) as outputs:
        out = outputs.file(args.json, "--json")
        plots = outputs.directory(args.plots, "--plots")
        rec = None
        if is_frf_file(args.file):
            result, caught = _identify_frf_file(args)
        else:
            rec = read_recording(args.file)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", UserWarning)
                result = identify_recording(
                    rec, args.reference, responses=args.responses, band_hz=args.band,
                    resolution_hz=args.resolution, estimator=args.estimator,
                    orders=range(2, args.max_order + 1), pin_hz=args.pin, drop_hz=args.drop,
                    leakage_correction=not args.no_leakage_correction,
                    metadata={"source_file": str(args.file)},
                )
        for what, why in result.model.metadata.get("chosen", {}).items():
            print(f"{what} chosen: {why}")
        check = result.model.metadata.get("self_check", {})
        for a in check.get("added", []):
            print(f"self-check added {a['frequency_hz']:.3f} Hz / {100 * a['damping_ratio']:.2f} % "
                  f"({a['source']}): misfit in {a['band_hz'][0]:.2f}-{a['band_hz'][1]:.2f} Hz "
                  f"{a['misfit_before']:.1f} -> {a['misfit_after']:.1f} times the noise level")
        if check.get("poor_fit_bands_hz"):
            print("self-check: the fit stays poor in " + ", ".join(
                f"{lo:.2f}-{hi:.2f} Hz" for lo, hi in check["poor_fit_bands_hz"]))
        for r in result.model.metadata.get("local_refinement", []):
            print(f"close modes: {r['band_hz'][0]:.2f}-{r['band_hz'][1]:.2f} Hz identified again at "
                  f"{r['resolution_hz']:.3g} Hz ({r['estimator']} of the whole record), as {r['reason']}: "
                  f"{r['chosen']}, {r['before_hz']} -> {r['after_hz']} Hz")
        for message in dict.fromkeys(str(w.message) for w in caught):
            print(f"warning: {message}")
        write_modes_json(result.model, out)
        figures = []
        if plots is not None:
            from exudyn_study.identify.plots import plot_all

            chans = {c.name: c for c in rec.channels} if rec is not None else {}
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


def _identify_frf_file(args):
    """Identify measured FRFs read from ``args.file`` (UFF58 type 4 or HDF5)."""
    import dataclasses

    from exudyn_study.identify.frf_io import read_frf_file
    from exudyn_study.identify.pipeline import identify_frf

    if args.resolution is not None:
        raise InputError(f"--resolution {args.resolution:g}: {args.file!r} holds FRFs at a fixed "
                         "resolution; drop --resolution (or identify the time data)")
    frf = read_frf_file(args.file)
    unknown = [r for r in args.reference if r not in frf.inputs]
    if unknown:
        raise InputError(f"--reference {' '.join(unknown)}: not a reference of the FRF file; its "
                         f"references are {', '.join(frf.inputs)}")
    cols = [frf.inputs.index(r) for r in args.reference]
    rows = list(range(len(frf.outputs)))
    if args.responses:
        missing = [r for r in args.responses if r not in frf.outputs]
        if missing:
            raise InputError(f"--responses {' '.join(missing)}: not in the FRF file; its responses "
                             f"are {', '.join(frf.outputs[:10])}{' ...' if len(frf.outputs) > 10 else ''}")
        rows = [frf.outputs.index(r) for r in args.responses]
    frf = dataclasses.replace(frf, H=frf.H[rows][:, cols], coherence=frf.coherence[rows][:, cols],
                              outputs=tuple(frf.outputs[i] for i in rows),
                              inputs=tuple(frf.inputs[j] for j in cols))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        result = identify_frf(frf, band_hz=args.band, orders=range(2, args.max_order + 1),
                              pin_hz=args.pin, drop_hz=args.drop,
                              metadata={"source_file": str(args.file), "input": "measured FRFs"})
    return result, caught


def _median(x):
    import numpy as np

    return np.median(x)
