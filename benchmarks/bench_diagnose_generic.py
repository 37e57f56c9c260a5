"""Benchmark: generic diagnosis of the two-beam lap-joint structure at four drive levels.

For each joint law of :mod:`exudyn_study.diagnose.testbench` ('none', 'friction',
'stiffening', 'clearance') the truth is simulated at 0.1, 0.3, 1 and 3 m/s^2 rms table
acceleration (512 Hz, 16 s, sensor noise 0.01 m/s^2); the diagnosis identifies its linear
model from the lowest level, trains on 0.1 and 1 m/s^2, holds out 0.3 and 3 m/s^2, and
searches every sensor pair for the joint (no interface declared). Prints per level the FRF
error of the nominal and the fitted model, the named physics and its parameters against
the truth, and wall times.

    python benchmarks/bench_diagnose_generic.py [--joints friction stiffening] [--force] [--out DIR]
        [--no-results]

With ``--force`` the structure is driven by a shaker force on B3 (0.15, 0.45, 1.5, 4.5 N rms,
table fixed, drive-point accelerometer B3) instead of the table.

With ``--out`` the diagnosis JSON and the HTML report of each case are written there.

Per joint law the named physics, its parameters, the train and held-out errors and the wall times
go with date, commit and load to ``benchmarks/results/bench_diagnose_generic--<table|force>.json``
(``--no-results``: not written).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from exudyn_study.diagnose import diagnose_generic
from exudyn_study.diagnose import testbench as tb
from exudyn_study.diagnose.report import write_report

LEVELS = (0.1, 0.3, 1.0, 3.0)
FORCE_LEVELS = (0.15, 0.45, 1.5, 4.5)
TRAIN, HOLDOUT = (0, 2), (1, 3)
#: a finding's errors kept in the result file (relative FRF errors, before and after the fit)
FIT_FIGURES = ("train_before", "train_after", "holdout_before", "holdout_after")


def truth(joint: str, s: tb.TestStructure) -> str:
    k = s.springs_n_per_m[2]
    if joint == "friction":
        return f"slip_share {s.friction_share:g}, slip_displacement {1e6 * s.slip_displacement_m:g} um"
    if joint == "stiffening":
        return f"k3/k_joint {s.cubic_n_per_m3 / k:.3g} 1/m^2"
    if joint == "clearance":
        return f"gap {1e6 * s.gap_m:g} um, contact_ratio {s.contact_ratio:g}"
    return "linear joint"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--joints", nargs="+", default=list(tb.JOINTS), choices=tb.JOINTS)
    parser.add_argument("--force", action="store_true", help="shaker force on B3 instead of the table drive")
    parser.add_argument("--out", type=Path, default=None, help="write JSON + HTML report per case here")
    parser.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = parser.parse_args()
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    s = tb.TestStructure()
    levels = FORCE_LEVELS if args.force else LEVELS
    key_figures = {"levels": levels, "train": TRAIN, "holdout": HOLDOUT, "joints": {}}
    print(
        f"levels ({'N' if args.force else 'm/s^2'} rms): {levels}; train {[levels[i] for i in TRAIN]}, "
        f"held out {[levels[i] for i in HOLDOUT]}"
    )
    for joint in args.joints:
        t0 = time.perf_counter()
        if args.force:
            recs = tb.simulate_levels(joint, levels=FORCE_LEVELS, force_at="B3")
        else:
            recs = tb.simulate_levels(joint, levels=LEVELS)
        t_sim = time.perf_counter() - t0
        figures: dict = {}
        t0 = time.perf_counter()
        d = diagnose_generic(
            recs[0],
            [recs[i] for i in TRAIN],
            [recs[i] for i in HOLDOUT],
            figures=figures,
            labels={
                "reference": f"L{levels[0]:g}",
                "train": [f"L{levels[i]:g}" for i in TRAIN],
                "holdout": [f"L{levels[i]:g}" for i in HOLDOUT],
            },
        )
        t_diag = time.perf_counter() - t0
        print(f"\n=== joint '{joint}' (truth: {truth(joint, s)}) ===")
        print(f"truth simulation {t_sim:.1f} s, diagnosis {t_diag:.1f} s -> {d.summary}")
        key_figures["joints"][joint] = {
            "truth": truth(joint, s), "wall_simulation_s": t_sim, "wall_diagnosis_s": t_diag,
            "findings": [
                {"physics": f.physics, "interface": f.location.get("interface"),
                 "level_dependent": f.level_dependent,
                 "parameters": {name: p["value"] for name, p in f.parameters.items()},
                 **{k: f.fit.get(k) for k in FIT_FIGURES}}
                for f in d.findings
            ],
        }
        for f in d.findings:
            print(
                f"named: {f.physics} at interface {f.location['interface']}, band "
                f"{f.band_hz[0]:.3g}-{f.band_hz[1]:.3g} Hz, level dependent {f.level_dependent}"
            )
            for name, p in f.parameters.items():
                std = "-" if p["std"] is None else f"{p['std']:.3g}"
                print(f"  {name} = {p['value']:.4g} +- {std} {p['unit']}")
            print(f"{'level':>8} {'role':>9} {'before':>8} {'after':>8} {'reduction':>9}")
            for lab, per in f.fit["per_channel"].items():
                b = np.mean([v["before"] for v in per.values()])
                a = np.mean([v["after"] for v in per.values()])
                role = "held-out" if lab in d.metadata["holdout"] else "train"
                print(f"{lab:>8} {role:>9} {b:8.3f} {a:8.3f} {100 * (1 - a / b):8.0f}%")
            print(
                f"train {f.fit['train_before']:.3f} -> {f.fit['train_after']:.3f}; held-out "
                f"{f.fit['holdout_before']:.3f} -> {f.fit['holdout_after']:.3f}"
            )
        for u in d.unexplained:
            print("unexplained:", u["explanation"])
        for c in d.metadata.get("candidates", []):
            print(f"  candidate {c['physics']}: {c['rejected'] or 'chosen'}")
        if args.out is not None:
            d.write_json(args.out / f"{joint}.json")
            write_report(d, args.out / f"{joint}_report", figures)
    if not args.no_results:
        case = "force" if args.force else "table"
        path = write_results("bench_diagnose_generic", key_figures, args=args, case=case, start=run)
        print(f"key figures {path}")


if __name__ == "__main__":
    main()
