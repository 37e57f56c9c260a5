"""The rig diagnosis on the ``thesis`` scenario (issue #8 acceptance): Model 3 against the virtual thesis rig.

The virtual rig plays the ``thesis`` scenario (compliant tank and bracket joints, the
compliant drive linkage, the left pad's cubic hardening, banded damping) into white
noise, the test signal at 50 % and at 100 %. The diagnosis gets only the recording files
and the nominal model (Model 3 with the scenario's damping): it trains on white noise +
test at 50 % and holds out the test signal at 100 %. Only this script reads the truth
file, to print fitted against true parameters.

Printed: the findings (physics, location, level dependence, fitted vs truth parameters),
the held-out error before and after, the relative pseudo damage at the z sensors before
and after (median and range over the sensors; 100 % is the measurement), what is left
unexplained, the wall time and the machine load. Acceptance: the linkage compliance and
the bushing nonlinearity found; the pseudo damage moves toward 100 %; one diagnosis under
10 minutes.

Run: ``python3 benchmarks/bench_diagnose_thesis.py [--out DIR] [--recordings DIR] [--duration S]``
(``--recordings`` reuses recordings written by an earlier run). Results: ``DIR/thesis_diagnosis.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SIGNALS = ("white-noise", "test-50", "test")


def _match(truth_augs, finding) -> dict | None:
    """The truth augmentation a finding corresponds to (same physics and place), or None."""
    loc = finding.location
    for a in truth_augs:
        if a["physics"] != finding.physics:
            continue
        if a["physics"] == "drive_linkage_compliance" and loc.get("interface") == "piston_linkage":
            return a
        if a["physics"] == "bushing_stiffening" and loc.get("component") == "bracket_left":
            return a
        if a["physics"] in ("joint_stiffness", "joint_friction") and a["location"].endswith(
            str(loc.get("interface"))
        ):
            return a
        if a["physics"] == "modal_damping" and a["location"] == loc.get("component"):
            return a
        if a["physics"] == "bushing_stiffness" and loc.get("component") == "bracket_left":
            return a
    return None


def _load() -> str:
    try:
        return " ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "?"


def main(argv=None) -> int:
    from exudyn_study.atomic import write_text_atomic
    from exudyn_study.diagnose.rig import diagnose_rig
    from exudyn_study.virtual_rig import run_virtual_test, scenario, truth_name
    from exudyn_study.virtual_rig.run import recording_name

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="directory for the results (default: a temporary one)")
    ap.add_argument("--recordings", default=None, help="reuse the thesis recordings in this directory")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per recording")
    args = ap.parse_args(argv)
    out_dir = Path(args.out or tempfile.mkdtemp(prefix="bench_diagnose_thesis_"))
    out_dir.mkdir(parents=True, exist_ok=True)
    rec_dir = Path(args.recordings) if args.recordings else out_dir
    sc = scenario("thesis")
    paths = [rec_dir / recording_name(sc.name, s) for s in SIGNALS]
    t0 = time.perf_counter()
    if not all(p.exists() for p in paths) or not (rec_dir / truth_name(sc.name)).exists():
        paths = run_virtual_test(sc, list(SIGNALS), rec_dir, duration_s=args.duration)
    t_rec = time.perf_counter() - t0
    print(f"recordings: {[p.name for p in paths]} ({t_rec:.0f} s); load {_load()}", flush=True)

    t0 = time.perf_counter()
    d = diagnose_rig(sc.variant, paths[:2], paths[2:], damping=sc.damping, progress=lambda t: print("  " + t))
    wall = time.perf_counter() - t0
    truth = json.loads((rec_dir / truth_name(sc.name)).read_text())
    augs = truth["augmentations"]

    print(f"\nnominal held-out error {d.metadata['nominal_holdout_error']}")
    rows = []
    for k, f in enumerate(d.findings, 1):
        a = _match(augs, f)
        print(
            f"finding {k}: {f.physics} at {f.location.get('interface') or f.location.get('component')} "
            f"(level dependent: {f.level_dependent}); held-out error {f.fit['holdout_before']:.4f} -> "
            f"{f.fit['holdout_after']:.4f}; {'matches the truth' if a else 'NOT in the truth'}"
        )
        params = {}
        for name, v in f.parameters.items():
            true = None if a is None else a["parameters"].get(name)
            params[name] = {"fitted": v["value"], "std": v["std"], "truth": true}
            rel = "" if not true else f" ({100 * (v['value'] / true - 1):+.1f} %)"
            print(
                f"    {name:36s} {v['value']:.4g} +- {v['std']:.2g}   truth "
                f"{true if true is not None else '-'}{rel}"
            )
        rows.append(
            {
                "physics": f.physics,
                "location": f.location,
                "in_truth": a is not None,
                "parameters": params,
                "fit": {k_: v_ for k_, v_ in f.fit.items() if k_ != "per_channel"},
                "level_dependent": f.level_dependent,
            }
        )
    for u in d.unexplained:
        print(f"unexplained: {u['explanation']}")
    dmg = d.metadata.get("relative_pseudo_damage", {})
    summary = {}
    if dmg:
        before = np.array([v["before"] for v in dmg.values()])
        after = np.array([v["after"] for v in dmg.values()])
        # distance from 100 % on a log scale, median over the z sensors
        dist_b, dist_a = np.median(np.abs(np.log10(before))), np.median(np.abs(np.log10(after)))
        summary = {
            "z_sensors": len(dmg),
            "before_median_pct": float(100 * np.median(before)),
            "after_median_pct": float(100 * np.median(after)),
            "before_range_pct": [float(100 * before.min()), float(100 * before.max())],
            "after_range_pct": [float(100 * after.min()), float(100 * after.max())],
            "median_log10_distance_from_100pct": {"before": float(dist_b), "after": float(dist_a)},
            "sensors_closer_to_100pct": int(np.sum(np.abs(np.log10(after)) < np.abs(np.log10(before)))),
        }
        print(
            f"relative pseudo damage at {len(dmg)} z sensors (held out): median "
            f"{summary['before_median_pct']:.0f} % "
            f"-> {summary['after_median_pct']:.0f} % (range {summary['before_range_pct'][0]:.0f}-"
            f"{summary['before_range_pct'][1]:.0f} % -> {summary['after_range_pct'][0]:.0f}-"
            f"{summary['after_range_pct'][1]:.0f} %); closer to 100 % at "
            f"{summary['sensors_closer_to_100pct']}/"
            f"{len(dmg)}"
        )
    found = {f.physics for f in d.findings}
    accept = {
        "linkage_found": "drive_linkage_compliance" in found,
        "bushing_found": "bushing_stiffening" in found,
        "pseudo_damage_toward_100pct": bool(
            summary
            and summary["median_log10_distance_from_100pct"]["after"]
            < summary["median_log10_distance_from_100pct"]["before"]
        ),
        "under_10_min": wall < 600.0,
    }
    print(f"final held-out error {d.metadata.get('final_holdout_error')}")
    print(f"diagnosis wall time {wall:.0f} s (load {_load()}); acceptance {accept}")
    result = {
        "findings": rows,
        "unexplained": list(d.unexplained),
        "nominal_holdout_error": d.metadata["nominal_holdout_error"],
        "final_holdout_error": d.metadata.get("final_holdout_error"),
        "pseudo_damage": dmg,
        "pseudo_damage_summary": summary,
        "candidates": d.metadata.get("candidates"),
        "rounds": d.metadata.get("rounds"),
        "wall_diagnosis_s": wall,
        "load": _load(),
        "acceptance": accept,
        "truth": augs,
    }
    path = write_text_atomic(out_dir / "thesis_diagnosis.json", json.dumps(result, indent=1, default=float))
    print(f"results {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
