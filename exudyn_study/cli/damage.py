r"""``exudyn-study damage``: relative pseudo damage between two recordings.

Example::

    exudyn-study damage --simulated sim.h5 --measured rig.uff --beta 5 \
        --z-sensors --json damage.json --plot damage.png

Both recordings may be native HDF5 or UFF58 files. The JSON holds ``channels``: name ->
{``pseudo_damage_simulated``, ``pseudo_damage_measured``, ``relative_pseudo_damage``}
plus ``beta``, ``C``, ``rate_hz`` and ``info`` (sources). Files are written atomically.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``damage`` arguments to ``parser``."""
    parser.add_argument(
        "--simulated",
        required=True,
        metavar="FILE",
        help="simulated recording (.h5/.hdf5 or .uff/.unv)",
    )
    parser.add_argument(
        "--measured",
        required=True,
        metavar="FILE",
        help="measured (desired) recording (.h5/.hdf5 or .uff/.unv)",
    )
    parser.add_argument(
        "--beta",
        type=float,
        default=5.0,
        help="Basquin exponent beta > 0 (default: 5, as the thesis)",
    )
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--channels",
        nargs="+",
        metavar="NAME",
        help="channels to compare (default: all response channels, which "
        "must then be the same in both recordings)",
    )
    group.add_argument(
        "--z-sensors",
        action="store_true",
        help="compare the 21 z-direction sensors of thesis Appendix A",
    )
    parser.add_argument(
        "--rate-hz",
        type=float,
        default=None,
        help="common rate in Hz (default: the lowest channel rate; the "
        "higher-rate recording is resampled, anti-aliased)",
    )
    parser.add_argument("--json", required=True, metavar="OUT", help="JSON result file")
    parser.add_argument(
        "--plot", metavar="IMAGE", default=None, help="also write a bar plot (.png/.pdf/.svg)"
    )


def _write_text_atomic(text: str, path: Path) -> None:
    from exudyn_study.infra.atomic import write_text_atomic

    write_text_atomic(path, text, "--json")


def run(args: argparse.Namespace) -> int:
    """Compute relative pseudo damage and write the JSON (and plot); return 0."""
    from exudyn_study.recording.io import read_recording
    from exudyn_study.signals.fatigue import relative_pseudo_damage

    simulated = read_recording(args.simulated)
    measured = read_recording(args.measured)
    channels = args.channels
    if args.z_sensors:
        from exudyn_study.model.sensors import z_sensors

        channels = [s.name for s in z_sensors()]
    result = relative_pseudo_damage(
        simulated, measured, beta=args.beta, channels=channels, rate_hz=args.rate_hz
    )
    result = type(result)(
        result.channels,
        result.beta,
        result.rate_hz,
        result.C,
        {**result.info, "simulated_file": str(args.simulated), "measured_file": str(args.measured)},
    )
    _write_text_atomic(result.to_json() + "\n", Path(args.json))
    if args.plot:
        from exudyn_study.signals.fatigue_plots import plot_relative_pseudo_damage

        plot_relative_pseudo_damage(
            {Path(args.simulated).stem: result},
            args.plot,
            title=f"{Path(args.simulated).name} vs {Path(args.measured).name}",
        )
    width = max(len(n) for n in result.names)
    print(f"{'channel':<{width}}  {'D_sim':>11}  {'D_meas':>11}  {'relative':>9}")
    for c in result.channels:
        print(
            f"{c.name:<{width}}  {c.damage_simulated:11.4e}  {c.damage_measured:11.4e}  "
            f"{c.percent:8.1f}%"
        )
    print(f"beta = {result.beta:g}, rate = {result.rate_hz:g} Hz -> {args.json}")
    return 0
