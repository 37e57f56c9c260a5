"""Blind benchmark of the rig diagnosis (issue #8): random virtual-rig scenarios, the diagnosis sees only files.

For each scenario (:func:`exudyn_study.virtual_rig.random_scenario`: effect, location,
parameter values and seed drawn; plus scenarios with no effect) the virtual rig writes
recordings of white noise, the test signal at 50 % and at 100 % and the truth file into a
scratch directory; :func:`exudyn_study.diagnose.rig.diagnose_rig` gets the recording
paths (white noise and the test signal at 50 % to train, the test signal held out) and the
nominal model (the variant the truth started from, Adams default damping), never the truth.
Only the scorer reads the truth. Scores:

- physics named correctly (no-effect scenarios: no finding at all);
- location correct: same sensor (sensor gain), same body (modal damping), the drive linkage,
  or (added mass) the fitted point within 0.25 m of the true one;
- fitted parameters within 15 % of the truth;
- held-out error (the diagnosis's metric) reduced by at least 50 %;
- wall time per diagnosis.

Run: ``python3 benchmarks/bench_diagnose_rig.py [--n 20] [--n-none 3] [--start 0] [--out DIR]
[--no-results]`` (minutes per scenario on 2 cores; ``--start I --n N`` runs scenarios I..I+N-1).
Results: ``DIR/results.json`` and a table on stdout; the scores (per scenario and in total) and the
wall times with date, commit and load in ``benchmarks/results/bench_diagnose_rig.json``
(``bench_diagnose_rig--s<start>-n<n>-none<n_none>.json`` for another selection; ``--no-results``: not
written).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: truth parameters that are fixed by the generator, not drawn (not scored)
FIXED = {"modal_damping": ("max_frequency_hz", "min_frequency_hz")}


def _point(model, location):
    from exudyn_study.physics.entries import location_point

    return np.asarray(location_point(model, location)[1])


def score(truth: dict, diagnosis, model) -> dict:
    """Compare a diagnosis with the scenario's truth (the only place the truth is read)."""
    augs = truth["augmentations"]
    out = {
        "effect": augs[0]["physics"] if augs else "none",
        "found": [f.physics for f in diagnosis.findings],
        "mismatch_found": diagnosis.mismatch_found,
    }
    if not augs:
        ok = not diagnosis.mismatch_found and not diagnosis.findings
        out.update(physics_ok=ok, location_ok=ok, parameters_ok=ok, holdout_ok=ok)
        return out
    aug = augs[0]
    f = diagnosis.findings[0] if diagnosis.findings else None
    out["physics_ok"] = bool(f is not None and f.physics == aug["physics"])
    if not out["physics_ok"]:
        out.update(
            location_ok=False,
            parameters_ok=False,
            holdout_ok=bool(f is not None and f.fit["holdout_after"] <= 0.5 * f.fit["holdout_before"]),
        )
        return out
    loc = f.location
    if aug["physics"] == "added_mass":
        found = f"chassis.{loc['interface']}" if loc.get("interface") else (loc["sensors"] or [None])[0]
        dist = (
            float(np.linalg.norm(_point(model, found) - _point(model, aug["location"]))) if found else np.inf
        )
        out["location_error_m"] = dist
        out["location_ok"] = dist <= 0.25
    elif aug["physics"] == "sensor_gain":
        out["location_ok"] = loc["sensors"] == [aug["location"]]
    elif aug["physics"] == "modal_damping":
        out["location_ok"] = loc["component"] == aug["location"]
    elif aug["physics"] == "bushing_stiffening":
        out["location_ok"] = loc["component"] == "bracket_left"
    else:
        out["location_ok"] = loc.get("interface") == "piston_linkage"
    errs = {}
    for name, true in aug["parameters"].items():
        if name in FIXED.get(aug["physics"], ()):
            continue  # set by the scenario generator, not drawn (e.g. the band of modal damping)
        fitted = f.parameters.get(name, {}).get("value")
        errs[name] = None if fitted is None else abs(fitted - true) / abs(true)
    out["parameter_errors"] = errs
    out["parameters_ok"] = bool(errs) and all(e is not None and e <= 0.15 for e in errs.values())
    out["holdout_before"], out["holdout_after"] = f.fit["holdout_before"], f.fit["holdout_after"]
    out["holdout_ok"] = f.fit["holdout_after"] <= 0.5 * f.fit["holdout_before"]
    return out


def main(argv=None) -> int:
    from exudyn_study.diagnose.rig import diagnose_rig
    from exudyn_study.model import build_model
    from exudyn_study.virtual_rig import random_scenario, run_virtual_test, truth_name

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="scenarios with a random effect")
    ap.add_argument("--n-none", type=int, default=3, help="scenarios with no effect")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per recording")
    ap.add_argument("--out", default=None, help="directory for results.json (default: a temporary one)")
    ap.add_argument("--start", type=int, default=0, help="first scenario index")
    ap.add_argument("--verbose", action="store_true", help="print the diagnosis's progress lines")
    ap.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = ap.parse_args(argv)
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    out_dir = Path(args.out or tempfile.mkdtemp(prefix="bench_diagnose_rig_"))
    out_dir.mkdir(parents=True, exist_ok=True)
    scenarios = [random_scenario(i) for i in range(args.start, args.start + args.n)]
    scenarios += [random_scenario(100 + i, effect="none") for i in range(args.n_none)]
    ref_models = {}
    rows = []
    results_path = out_dir / "results.json"
    for sc in scenarios:
        with tempfile.TemporaryDirectory(prefix=f"{sc.name}_") as tmp:
            t0 = time.perf_counter()
            paths = run_virtual_test(sc, ["white-noise", "test-50", "test"], tmp, duration_s=args.duration)
            t_rec = time.perf_counter() - t0
            t0 = time.perf_counter()
            # the diagnosis sees the files only: white noise and the test signal at 50 % to train,
            # the test signal at 100 % held out; the nominal model is the variant the truth started from
            progress = None
            if args.verbose:
                progress = lambda t, name=sc.name: print(f"  {name}: {t}", flush=True)  # noqa: E731
            d = diagnose_rig(sc.variant, paths[:2], paths[2:], progress=progress)
            t_diag = time.perf_counter() - t0
            truth = json.loads((Path(tmp) / truth_name(sc.name)).read_text())
        if sc.variant not in ref_models:
            ref_models[sc.variant] = build_model(sc.variant, exudyn_mesh="used")
        row = score(truth, d, ref_models[sc.variant])
        row.update(
            scenario=sc.name,
            truth=truth["augmentations"],
            wall_recordings_s=round(t_rec, 1),
            wall_diagnosis_s=round(t_diag, 1),
            findings=[f.to_dict() for f in d.findings],
            unexplained=list(d.unexplained),
            final_refit=d.metadata.get("final_refit"),
            rejected_for_drift=[
                f"{c['physics']}@{c['location']}"
                for c in d.metadata.get("candidates", [])
                if "drift" in str(c.get("rejected"))
            ],
        )
        for f in row["findings"]:
            f["fit"].pop("per_channel", None)
        rows.append(row)
        print(
            f"{sc.name}: truth {row['effect']:26s} found {row['found']!s:32s} physics {row['physics_ok']!s:5s} "
            f"location {row['location_ok']!s:5s} params {row['parameters_ok']!s:5s} "
            f"holdout {row.get('holdout_before', float('nan')):.3f}->{row.get('holdout_after', float('nan')):.3f} "
            f"({t_diag:.0f} s)",
            flush=True,
        )
        tmp_path = results_path.with_suffix(".tmp")
        tmp_path.write_text(json.dumps(rows, indent=1, default=float))
        tmp_path.replace(results_path)
    effect = [r for r in rows if r["effect"] != "none"]
    none = [r for r in rows if r["effect"] == "none"]

    def share(key, group):
        return f"{sum(bool(r[key]) for r in group)}/{len(group)}"

    print(
        f"\n{len(effect)} scenarios with an effect: physics {share('physics_ok', effect)}, location "
        f"{share('location_ok', effect)}, parameters within 15 % {share('parameters_ok', effect)}, held-out error "
        f"halved {share('holdout_ok', effect)}"
    )
    print(f"{len(none)} scenarios without an effect: no finding {share('physics_ok', none)}")
    walls = [r["wall_diagnosis_s"] for r in rows]
    print(
        f"diagnosis wall time: median {np.median(walls):.0f} s, max {np.max(walls):.0f} s; results {results_path}"
    )
    if not args.no_results:
        keys = ("physics_ok", "location_ok", "parameters_ok", "holdout_ok")
        figures = {
            "n_effect": len(effect),
            **{f"effect_{k}": sum(bool(r[k]) for r in effect) for k in keys},
            "n_none": len(none),
            "none_without_finding": sum(bool(r["physics_ok"]) for r in none),
            "wall_diagnosis_median_s": float(np.median(walls)),
            "wall_diagnosis_max_s": float(np.max(walls)),
            "scenarios": [
                {"scenario": r["scenario"], "effect": r["effect"], "found": r["found"],
                 **{k: r[k] for k in keys}, "wall_diagnosis_s": r["wall_diagnosis_s"]}
                for r in rows
            ],
        }
        default = (args.start, args.n, args.n_none) == (0, 20, 3)
        case = None if default else f"s{args.start}-n{args.n}-none{args.n_none}"
        print(f"key figures {write_results('bench_diagnose_rig', figures, args=args, case=case, start=run)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
