r"""``exudyn-study damage``: relative pseudo damage between two recordings.

Example::

    exudyn-study damage --simulated sim.h5 --measured rig.uff --beta 5 \
        --z-sensors --json damage.json --plot damage.png

Both recordings may be native HDF5 or UFF58 files. The JSON holds ``channels``: name ->
{``pseudo_damage_simulated``, ``pseudo_damage_measured``, ``relative_pseudo_damage``}
plus ``beta``, ``C``, ``rate_hz`` and ``info`` (sources). The JSON and the plot are staged
and moved into place together when both are complete; on an error neither is written.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from exudyn_study.cli.options import Bounded
from exudyn_study.errors import InputError

__all__ = ["configure", "run"]


BETA = Bounded(float, 0.0, 50.0, "", "Basquin exponents of metals are 3-15; above 50 the damage sums "
               "overflow a double", low_open=True)
RATE = Bounded(float, 1.0, 1e6, "Hz", "a sample rate of a recording")
PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``damage`` arguments to ``parser``."""
    parser.add_argument("--simulated", required=True, metavar="FILE",
                        help="simulated recording (.h5/.hdf5 or .uff/.unv)")
    parser.add_argument("--measured", required=True, metavar="FILE",
                        help="measured (desired) recording (.h5/.hdf5 or .uff/.unv)")
    parser.add_argument("--beta", type=BETA, default=5.0, help="Basquin exponent beta (the thesis uses 5)")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--channels", nargs="+", metavar="NAME",
                       help="channels to compare (default: all response channels, which "
                       "must then be the same in both recordings)")
    group.add_argument("--z-sensors", action="store_true",
                       help="compare the 21 z-direction sensors of thesis Appendix A")
    parser.add_argument("--rate", type=RATE, default=None, metavar="HZ",
                        help="common rate in Hz (default: the lowest channel rate; the "
                        "higher-rate recording is resampled, anti-aliased)")
    parser.add_argument("--json", required=True, metavar="OUT", help="JSON result file")
    parser.add_argument("--plot", metavar="IMAGE", default=None,
                        help="also write a bar plot (.png/.pdf/.svg; default: no plot)")


def run(args: argparse.Namespace) -> int:
    """Compute relative pseudo damage and write the JSON (and plot); return 0."""
    from exudyn_study.infra.files import OutputSet
    from exudyn_study.recording.io import read_recording
    from exudyn_study.signals.fatigue import relative_pseudo_damage

    if args.plot is not None and Path(args.plot).suffix.lower() not in PLOT_SUFFIXES:
        raise InputError(f"--plot {args.plot!r}: suffix {Path(args.plot).suffix!r}; expected one of "
                         f"{', '.join(PLOT_SUFFIXES)}")
    with OutputSet(inputs={"--simulated": args.simulated, "--measured": args.measured}) as outputs:
        json_path = outputs.file(args.json, "--json")
        plot_path = outputs.file(args.plot, "--plot")
        simulated = read_recording(args.simulated)
        measured = read_recording(args.measured)
        channels = args.channels
        if args.z_sensors:
            from exudyn_study.model.sensors import z_sensors

            channels = [s.name for s in z_sensors()]
        result = relative_pseudo_damage(simulated, measured, beta=args.beta, channels=channels,
                                        rate_hz=args.rate)
        result = type(result)(
            result.channels, result.beta, result.rate_hz, result.C,
            {**result.info, "simulated_file": str(args.simulated), "measured_file": str(args.measured)},
            result.notes,
        )
        json_path.write_text(result.to_json() + "\n", encoding="utf-8")
        if plot_path is not None:
            from exudyn_study.signals.fatigue_plots import plot_relative_pseudo_damage

            plot_relative_pseudo_damage({Path(args.simulated).stem: result}, plot_path,
                                        title=f"{Path(args.simulated).name} vs {Path(args.measured).name}")
    width = max(len(n) for n in result.names)
    print(f"{'channel':<{width}}  {'D_sim':>11}  {'D_meas':>11}  {'relative':>9}")
    for c in result.channels:
        print(f"{c.name:<{width}}  {c.damage_simulated:11.4e}  {c.damage_measured:11.4e}  {c.percent:8.1f}%")
    print(f"beta = {result.beta:g}, rate = {result.rate_hz:g} Hz -> {args.json}")

    return 0
