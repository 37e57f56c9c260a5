"""Blind benchmark of the rig diagnosis: random virtual-rig scenarios, the diagnosis sees only files.

For each scenario the virtual rig writes recordings of white noise, the test signal at 50 % and at
100 % and the truth file into a scratch directory; :func:`exudyn_study.diagnose.rig.diagnose_rig`
gets the recording paths (white noise and the test signal at 50 % to train, the test signal held
out) and the nominal model (the variant the truth started from, Adams default damping), never the
truth. Only the scorer reads the truth.

Pools (``--pool``):

- ``wide`` (default): :func:`exudyn_study.virtual_rig.wide_scenario`, one or two effects (two in
  40 %) from :data:`~exudyn_study.virtual_rig.WIDE_EFFECTS`: a mass or a tuned mass-damper anywhere on
  the surface of the chassis's parts (:data:`~exudyn_study.virtual_rig.SURFACE_REGIONS`), the drive
  linkage, a rear support, sensor faults (gain, polarity, swapped channels, a dead channel, a delay)
  and a dashpot to ground anywhere on those surfaces, for which the diagnosis has no candidate
  (outside the catalogue); ``--held-back`` draws from the seed range kept for the final score
  (:data:`~exudyn_study.virtual_rig.HELD_BACK_SEED`), reported under its own case name;
- ``classic``: :func:`exudyn_study.virtual_rig.random_scenario` (one effect of the original five).

Scores, per truth effect (a finding matched to it):

- physics named (an effect outside the catalogue: a ``local_element`` finding); no-effect
  scenarios: no finding at all;
- located: a point effect within 0.25 m of the truth (the finding's position, else its first
  sensor), a sensor fault on the right channel(s), a rear support on its side, the linkage;
- parameters within 15 % of the truth (parameters the truth holds at zero are not scored);
- plausible proxy: a finding at the right place with other physics;
- wrong physics claimed without a flag: a finding matching no truth effect by physics or place
  and carrying no flag;
- held-out error at least halved with at most 10 % of the channels materially worse (the
  diagnosis's own per-channel verdict, from nominal to final);
- wall time per diagnosis.

Run: ``python3 benchmarks/bench_diagnose_rig.py [--pool wide|classic] [--held-back] [--n 20]
[--n-none 3] [--start 0] [--out DIR] [--no-results]`` (minutes per scenario on 2 cores; ``--start I
--n N`` runs scenarios I..I+N-1). Results: ``DIR/results.json``, each scenario's diagnosis
(``DIR/<scenario>.diagnosis.json``) and a table on stdout; the scores and wall times with date,
commit and load in ``benchmarks/results/bench_diagnose_rig--<case>.json`` (``--no-results``: not
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
#: truth entry -> the physics a finding names for it (no candidate: the generic local element)
NAMED_AS = {"ground_spring_damper": "local_element"}
#: point effects: located within this distance (m)
POINT_TOLERANCE_M = 0.25
POINT_EFFECTS = ("added_mass", "tuned_mass_damper", "ground_spring_damper")


def _point(model, location):
    from exudyn_study.physics.entries import location_point

    return np.asarray(location_point(model, location)[1])


def _finding_point(model, f):
    loc = f.location
    if loc.get("position_m") is not None:
        return np.asarray(loc["position_m"], dtype=float)
    name = f"chassis.{loc['interface']}" if loc.get("interface") else (loc["sensors"] or [None])[0]
    try:
        return _point(model, name) if name else None
    except Exception:  # noqa: BLE001 - a location that is no point of the model
        return None


def _at_place(aug, f, model) -> bool:
    """Whether finding ``f`` sits where truth effect ``aug`` is."""
    physics, where = aug["physics"], aug["location"]
    if physics in POINT_EFFECTS:
        p = _finding_point(model, f)
        return p is not None and float(np.linalg.norm(p - _point(model, where))) <= POINT_TOLERANCE_M
    if physics.startswith("sensor_"):
        return sorted(f.location["sensors"]) == sorted(str(where).replace(">", "/").split("/"))
    if physics == "rear_support_compliance":
        return f.location.get("interface") == f"foundation_{where}" or where in str(f.location)
    if physics == "drive_linkage_compliance":
        return f.location.get("interface") == "piston_linkage"
    return f.location.get("component") == where


def _parameters_ok(aug, f) -> tuple:
    errs = {}
    for name, true in aug["parameters"].items():
        if name in FIXED.get(aug["physics"], ()) or true == 0.0:
            continue
        fitted = f.parameters.get(name, {}).get("value")
        if aug["physics"] == "sensor_polarity" and fitted is None and "gain" in f.parameters:
            fitted = f.parameters["gain"]["value"]
        errs[name] = None if fitted is None else abs(fitted - true) / abs(true)
    return errs, all(e is not None and e <= 0.15 for e in errs.values())


def score(truth: dict, diagnosis, model) -> dict:
    """Compare a diagnosis with the scenario's truth (the only place the truth is read)."""
    augs = truth["augmentations"]
    found = [f.physics for f in diagnosis.findings]
    out = {
        "effect": " + ".join(a["physics"] for a in augs) or "none",
        "found": found,
        "mismatch_found": diagnosis.mismatch_found,
        "n_effects": len(augs),
    }
    if not augs:
        ok = not diagnosis.mismatch_found and not diagnosis.findings
        out.update(
            physics_ok=ok,
            location_ok=ok,
            parameters_ok=ok,
            holdout_ok=ok,
            effects=[],
            wrong_unflagged=len(diagnosis.findings),
        )
        return out
    effects, used = [], set()
    for aug in augs:
        named = NAMED_AS.get(aug["physics"], aug["physics"])
        match = next(
            (
                k
                for k, f in enumerate(diagnosis.findings)
                if k not in used and f.physics == named and _at_place(aug, f, model)
            ),
            None,
        )
        if match is None:
            match = next(
                (k for k, f in enumerate(diagnosis.findings) if k not in used and f.physics == named), None
            )
        row = {
            "physics": aug["physics"],
            "location": aug["location"],
            "outside": aug["physics"] in NAMED_AS,
            "physics_ok": match is not None,
        }
        if match is None:
            proxy = [f for f in diagnosis.findings if _at_place(aug, f, model)]
            row.update(
                location_ok=False,
                parameters_ok=False,
                proxy=bool(proxy),
                proxy_physics=[f.physics for f in proxy],
            )
        else:
            used.add(match)
            f = diagnosis.findings[match]
            errs, ok = _parameters_ok(aug, f)
            row.update(
                location_ok=_at_place(aug, f, model),
                parameter_errors=errs,
                parameters_ok=ok,
                proxy=False,
                flags=list(f.flags),
            )
        effects.append(row)
    wrong = [
        f
        for k, f in enumerate(diagnosis.findings)
        if k not in used and not any(_at_place(a, f, model) for a in augs) and not f.flags
    ]
    meta = diagnosis.metadata
    nominal = meta.get("nominal_holdout_error") or [np.nan]
    final = meta.get("final_holdout_error") or nominal
    share_worse = len(meta.get("holdout_channels_worse") or {}) / max(1, len(meta.get("channels", [1])))
    out.update(
        effects=effects,
        physics_ok=all(e["physics_ok"] for e in effects),
        location_ok=all(e["location_ok"] for e in effects),
        parameters_ok=all(e["parameters_ok"] for e in effects),
        proxy=any(e.get("proxy") for e in effects),
        wrong_unflagged=len(wrong),
        wrong_unflagged_physics=[f.physics for f in wrong],
        holdout_before=float(np.mean(nominal)),
        holdout_after=float(np.mean(final)),
        share_channels_worse=share_worse,
        holdout_ok=bool(np.mean(final) <= 0.5 * np.mean(nominal) and share_worse <= 0.1),
        # point findings the diagnosis placed again in a later round
        placed_again=meta.get("placed_again", []),
    )
    return out


def main(argv=None) -> int:
    from exudyn_study.diagnose.rig import diagnose_rig
    from exudyn_study.model import build_model
    from exudyn_study.virtual_rig import (
        HELD_BACK_SEED,
        random_scenario,
        run_virtual_test,
        truth_name,
        wide_scenario,
    )
    from exudyn_study.virtual_rig.scenarios import DEVELOPMENT_SEED

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="scenarios with a random effect")
    ap.add_argument("--n-none", type=int, default=3, help="scenarios with no effect")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per recording")
    ap.add_argument(
        "--out",
        default=None,
        help="directory for results.json and each scenario's diagnosis JSON (default: a temporary one)",
    )
    ap.add_argument("--start", type=int, default=0, help="first scenario index")
    ap.add_argument("--none-start", type=int, default=0, help="first index of the scenarios with no effect")
    ap.add_argument("--verbose", action="store_true", help="print the diagnosis's progress lines")
    ap.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    ap.add_argument("--pool", choices=("wide", "classic"), default="wide", help="scenario generator")
    ap.add_argument("--held-back", action="store_true", help="the held-back seed range (pool wide)")
    args = ap.parse_args(argv)
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    out_dir = Path(args.out or tempfile.mkdtemp(prefix="bench_diagnose_rig_"))
    out_dir.mkdir(parents=True, exist_ok=True)
    if args.pool == "wide":
        seed = HELD_BACK_SEED if args.held_back else DEVELOPMENT_SEED
        scenarios = [wide_scenario(i, rng_seed=seed) for i in range(args.start, args.start + args.n)]
        nulls = range(args.none_start, args.none_start + args.n_none)
        scenarios += [wide_scenario(500 + i, effect="none", rng_seed=seed) for i in nulls]
    else:
        scenarios = [random_scenario(i) for i in range(args.start, args.start + args.n)]
        nulls = range(args.none_start, args.none_start + args.n_none)
        scenarios += [random_scenario(100 + i, effect="none") for i in nulls]
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
            d.write_json(out_dir / f"{sc.name}.diagnosis.json")  # every candidate fit, for reading later
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
        rows.append(row)
        print(
            f"{sc.name}: truth {row['effect']:26s} found {row['found']!s:32s} "
            f"physics {row['physics_ok']!s:5s} location {row['location_ok']!s:5s} "
            f"params {row['parameters_ok']!s:5s} holdout {row.get('holdout_before', float('nan')):.3f}->"
            f"{row.get('holdout_after', float('nan')):.3f} "
            f"({t_diag:.0f} s)",
            flush=True,
        )
        tmp_path = results_path.with_suffix(".tmp")
        tmp_path.write_text(json.dumps(rows, indent=1, default=float))
        tmp_path.replace(results_path)
    effect = [r for r in rows if r["effect"] != "none"]
    none = [r for r in rows if r["effect"] == "none"]
    per_effect = [e for r in effect for e in r["effects"]]
    outside = [e for e in per_effect if e["outside"]]

    def share(key, group):
        return f"{sum(bool(r[key]) for r in group)}/{len(group)}"

    print(
        f"\n{len(effect)} scenarios with an effect ({sum(r['n_effects'] == 2 for r in effect)} with two), "
        f"{len(per_effect)} effects: physics {share('physics_ok', per_effect)}, location "
        f"{share('location_ok', per_effect)}, parameters within 15 % {share('parameters_ok', per_effect)}, "
        f"plausible proxy {sum(bool(e.get('proxy')) for e in per_effect)}; per scenario: held-out error "
        "halved "
        f"with <= 10 % channels worse {share('holdout_ok', effect)}, wrong physics claimed without a flag "
        f"{sum(r['wrong_unflagged'] for r in effect)}"
    )
    if outside:
        print(f"outside the catalogue: located and reported as such {share('location_ok', outside)}")
    print(f"{len(none)} scenarios without an effect: no finding {share('physics_ok', none)}")
    walls = [r["wall_diagnosis_s"] for r in rows]
    print(
        f"diagnosis wall time: median {np.median(walls):.0f} s, max {np.max(walls):.0f} s; "
        f"results {results_path}"
    )
    if not args.no_results:
        keys = ("physics_ok", "location_ok", "parameters_ok")
        figures = {
            "pool": args.pool,
            "held_back": bool(args.held_back),
            "n_scenarios_effect": len(effect),
            "n_scenarios_two_effects": sum(r["n_effects"] == 2 for r in effect),
            "n_effects": len(per_effect),
            **{f"effects_{k}": sum(bool(e[k]) for e in per_effect) for k in keys},
            "effects_plausible_proxy": sum(bool(e.get("proxy")) for e in per_effect),
            "n_outside": len(outside),
            "outside_located_as_such": sum(bool(e["location_ok"]) for e in outside),
            "scenarios_holdout_ok": sum(bool(r["holdout_ok"]) for r in effect),
            "wrong_physics_unflagged": sum(r["wrong_unflagged"] for r in effect),
            "n_none": len(none),
            "none_without_finding": sum(bool(r["physics_ok"]) for r in none),
            "wall_diagnosis_median_s": float(np.median(walls)),
            "wall_diagnosis_max_s": float(np.max(walls)),
            "scenarios": [
                {
                    "scenario": r["scenario"],
                    "effect": r["effect"],
                    "found": r["found"],
                    **{k: r[k] for k in (*keys, "holdout_ok", "wrong_unflagged")},
                    "wall_diagnosis_s": r["wall_diagnosis_s"],
                    "placed_again": len(r.get("placed_again", [])),
                }
                for r in rows
            ],
        }
        nulls = f"-none{args.n_none}" + (f"from{args.none_start}" if args.none_start else "")
        case = f"{args.pool}{'-heldback' if args.held_back else ''}-s{args.start}-n{args.n}{nulls}"
        print(f"key figures {write_results('bench_diagnose_rig', figures, args=args, case=case, start=run)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
