"""``exudyn-study virtual-test``: play a scenario on the virtual rig and write its recordings.

The output directory is created when missing; the recordings and the truth file are staged
and moved into it together when every one is complete, so a failure leaves nothing behind.
"""

from __future__ import annotations

import argparse

from exudyn_study.cli.options import DURATION_MAX_S, Bounded, add_cache_dir, add_seed

__all__ = ["configure", "run"]

SIGNALS = ("white-noise", "test", "test-50")
LEVEL = Bounded(float, 0.01, 4.0, "", "the scenarios' physics is tuned for drive levels up to a few times "
                "the thesis level; below 1 % the response is at the sensor noise")
DURATION = Bounded(float, 0.0, DURATION_MAX_S, "s", "43 channels at 1000 Hz hold 1.2 GB per hour in memory; "
                   "a rig test record is 60-120 s", low_open=True)


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``virtual-test`` arguments."""
    parser.add_argument("--scenario", required=True, metavar="NAME",
                        help="scenario name: none, thesis, or a catalogue entry name (single effect); "
                             "'list' prints them")
    parser.add_argument("--signal", nargs="+", default=["white-noise"], choices=SIGNALS, metavar="SIGNAL",
                        help=f"one or more of {', '.join(SIGNALS)}")
    parser.add_argument("--level", type=LEVEL, nargs="+", default=[1.0], metavar="FACTOR",
                        help="drive amplitude factor(s) relative to the scenario's")
    parser.add_argument("--duration", type=DURATION, default=None, metavar="S",
                        help="duration in s (default 120 s white noise, 60 s test signals)")
    add_seed(parser, None, "override the scenario's seed (default: the scenario's own)")
    add_cache_dir(parser)
    parser.add_argument("--out", default=None, metavar="DIR",
                        help="output directory (created when missing; default: none, required unless "
                             "--scenario list)")


def run(args: argparse.Namespace) -> int:
    """Write ``<scenario>_<signal>.h5`` per signal/level and ``<scenario>_truth.json``."""
    from pathlib import Path

    from exudyn_study.errors import InputError
    from exudyn_study.infra.cache import cache_dir
    from exudyn_study.infra.files import OutputSet
    from exudyn_study.virtual_rig import scenario
    from exudyn_study.virtual_rig.run import run_virtual_test
    from exudyn_study.virtual_rig.scenarios import SCENARIOS

    if args.scenario == "list":
        for name, sc in sorted(SCENARIOS.items()):
            print(f"{name:26s} {sc.description}")
        return 0
    if args.out is None:
        raise InputError("--out is required: the directory for the recordings and the truth file")
    sc = scenario(args.scenario)
    if args.seed is not None:
        sc = sc.with_seed(args.seed)
    with OutputSet() as outputs:
        staged = outputs.directory(args.out, "--out")
        cache_dir(args.cache_dir)
        paths = run_virtual_test(sc, args.signal, staged, args.duration, args.level, cache_dir=args.cache_dir)
    for p in paths:
        print(f"wrote {Path(args.out) / p.name}")
    return 0
