"""``exudyn-study virtual-test``: play a scenario on the virtual rig and write its recordings."""

from __future__ import annotations

import argparse

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``virtual-test`` arguments."""
    parser.add_argument(
        "--scenario",
        required=True,
        help="scenario name: none, thesis, or a catalogue entry name (single effect); 'list' prints them",
    )
    parser.add_argument(
        "--signal", nargs="+", default=["white-noise"], help="one or more of white-noise, test, test-50"
    )
    parser.add_argument(
        "--level",
        type=float,
        nargs="+",
        default=[1.0],
        help="drive amplitude factor(s) relative to the scenario's (default 1)",
    )
    parser.add_argument(
        "--duration",
        type=float,
        default=None,
        help="duration in s (default 120 s white noise, 60 s test signals)",
    )
    parser.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    parser.add_argument("--cache-dir", default=None, help="flexible-body cache directory")
    parser.add_argument("--out", default=None, help="output directory (must exist)")


def run(args: argparse.Namespace) -> int:
    """Write ``<scenario>_<signal>.h5`` per signal/level and ``<scenario>_truth.json``."""
    from exudyn_study.errors import InputError
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
    paths = run_virtual_test(sc, args.signal, args.out, args.duration, args.level, cache_dir=args.cache_dir)
    for p in paths:
        print(f"wrote {p}")
    return 0
