"""The rig diagnosis on the ``thesis`` scenario (issue #8 acceptance): Model 3 against the virtual thesis rig.

The virtual rig plays the ``thesis`` scenario (compliant tank and bracket joints, the right
tank's mounts soft only vertically, the compliant drive linkage, rear supports compliant
vertically and fore-aft, the water sloshing in both tanks, the right tank's wall mode, the left
pad's cubic hardening, banded damping; ``--scenario thesis-iso``: the truth of sessions 8-15,
mounts equally stiff on all axes and no wall mode; ``--scenario thesis-dry``: the session-6 truth
without the water and the fore-aft compliance) into white
noise, the test signal at 50 % and at 100 %. The diagnosis gets only the recording files
and the nominal model (Model 3 with the scenario's damping), never the truth; only this
script reads the truth file, to print fitted against true parameters.

Protocol (``--protocol``):

- ``levels`` (default): train on the test signal at 50 %, 100 % and 300 %, hold out the
  white noise (another signal: another spectrum and another realisation) and the test
  signal at 200 % (another excitation level). Several levels of one drive are then inside
  the training data, so the level-dependent (nonlinear) share of the response,
  ``y_300 - 6 y_50``, is known model-free there and the nonlinear candidates are fitted on
  it; the linear findings are proven on a signal they were not fitted to, a nonlinear one
  on a level it was not fitted to. (The issue allows "held-out recordings (another signal
  or another excitation level)".) Why 300 %: the pad's cubic hardening is Section 7.4's
  "shows with the stronger test signals"; between 50 % and 100 % the thesis scenario's
  level-dependent share at the left bracket's sensors (0.15-0.3 %) is at the noise floor
  of ``y_100 - 2 y_50`` (median over the sensors 0.24 %), so a model-free fit there has
  nothing to fit. The cubic share grows as the level squared; the noise share does not.
- ``original``: train on white noise + the test signal at 50 %, hold out the test signal
  at 100 % (the blind benchmark's protocol). The level pair straddles training and held-out
  data, so no nonlinear share can be fitted inside the training data.

Printed: the findings (physics, location, level dependence, fitted vs truth parameters),
the held-out error before and after, the relative pseudo damage at the z sensors before
and after (median and range over the sensors; 100 % is the measurement), what is left
unexplained, the wall time and the machine load. Acceptance: the linkage compliance and
the bushing nonlinearity found; the pseudo damage moves toward 100 %; one diagnosis under
10 minutes.

Result (session 6, the session-5 truth and recordings, now ``thesis-dry``, protocol ``levels``, 60 s
recordings, default 540 s budget, load 1.0): 789 s, four rounds. Found, all in the truth: both rear
supports (2.20e7 and 2.76e7 N/m, truth 2.2e7 each), the four tank mounts (values 0.02-25x off; two
flagged at a bound or drifting), the pad's linear stiffness (shear modulus at its bound), the
linkage (1.40e7 N/m, truth 1.2e7; 89 kg, truth 20 kg) and, new, the pad's cubic hardening in
compression (5.8e12 N/m^3 per quadrant, truth 3e12: +93 %, fitted on the level-dependent share
``y_300 - 6 y_50``; it explains 36 % of that share's rms). It is found because the linear findings
are now refitted together *before* the nonlinear candidates are screened: on the round's model the
cubic's screening score was 0.001, on the refitted one 0.16 (the share is compared in time, so it
needs the bracket's modes right; on the truth's own linear model the cubic explains 93 % of it). No
finding the truth lacks. Held-out error (white noise / test at 200 %) 5.07/3.68 -> 0.48/0.42; at the
bracket's sensors (ASVX/Y/Z) the cubic takes the test at 200 % from 0.431 to 0.423 and the white
noise from 0.608 to 0.605 (the linear mismatch left there dominates). Relative pseudo damage at the
21 z sensors median 47 944 % -> 240 % (75-341 %), 19/21 closer to 100 %. Wall time: round 4 took 525
s, of which the joint refit 213 s and the nonlinear screening and fit 166 s, so this scenario does
not diagnose in 10 minutes (the blind benchmark's scenarios do: median 43 s, max 344 s).

Result (session 8, the ``thesis`` truth with the water, its session-7 recordings, protocol ``levels``,
60 s recordings, ``--time-budget 1800``, load 2-4: blind-benchmark runs and the test suite alongside):
2336 s, three rounds. Found, all in the truth: both rear supports (vertical 2.22e7 and 2.37e7 N/m, truth
2.2e7; fore-aft 9.3e7 and 1.13e8 N/m, truth 1e8), the four tank mounts (right rear and front within
10 % in translation and rotation; the left tank's stiff translational springs at or near their bound,
its rotations within 21 %), the linkage (1.22e7 N/m, truth 1.2e7; 27 kg, truth 20), the pad (shear
+2.36 MPa, truth 2.3; rocking about x 4.78 MPa, truth 4.68; compression 2.1e7, truth 1.04e7), the
water in both tanks (70.9 and 72.6 kg at the assumed 1.5 Hz, truth 70 kg at 2.5 Hz: the damping
ratios trade with the frequency), the right bracket's joint, and the pad's cubic hardening in
compression (2.82e12 N/m^3, truth 3e12: -6 %; it explains 73 % of the level-dependent share at the
held-out 200 % level, held-out error 0.0933 -> 0.0936, within the 5 % a nonlinear finding may cost).
Held-out error (white noise / test at 200 %) 4.91/4.03 -> 0.096/0.091. Relative pseudo damage at the
21 z sensors median 44 091 % -> 102 % (76-114 %), 21/21 closer to 100 %. (The run printed the two
water findings as "NOT in the truth": this script's matcher lacked ``sloshing``; fixed after the run.)
Not under 10 minutes: round 1 fits 10 candidates together, and the final joint refit of 11 findings
takes minutes. Without the water and fore-aft candidates (session 7) the cubic was not found here; on
``thesis-dry`` with the session-8 candidates and the pad's rocking about x tied (run before that was
freed), the cubic was not found either (490 s), so ``thesis-dry`` is kept for the Table-1 comparison
only.

Session 9 (the same recordings, the final refit holding the parameters that ended at a bound in their
round, load 1-2.5): 1447 s, the same 12 findings, all in the truth (rear supports 1.87e7 and 2.77e7
N/m, water 59 and 55 kg, the cubic 2.55e12 N/m^3, -15 %, explaining 67 % of the held-out level-dependent
share); held-out error 4.91/4.03 -> 0.228/0.219 (session 8, refit all free: 0.096/0.091); pseudo damage
median 44 091 % -> 128 % (42-552 %), 20/21 closer to 100 %. On a trial truth with the right tank's
mounts soft only vertically (Table 1: 9/10, see ``THESIS_FIT['not_reached']``) the diagnosis failed:
round 1's joint fit went to soft supports and a 500 kg linkage (514 s, nothing found; with a joint
candidate fitting the vertical stiffness apart 390 s, held-out 1.09, no cubic).

Session 10 (recordings written fresh by the current code; sessions 8 and 9 reused session 7's, whose
truth file is the same but whose code was older, so their recordings differ): at 6f6e2ff 7 findings,
the cubic not found (it explained 8.7 % of the share), held-out 4.91/4.03 -> 0.845/0.847, pseudo damage
median 0.49 %: round 1's joint fit had run both tank rear mounts' damping to its 1e-2 s bound (standing in
for the water). With a damping time at its upper bound held at its start in the joint fits and the
final refit tried free first (load 1.6-2): 1874 s, 13 findings, 12 in the truth (not: a joint at the left
bracket, 1.2e7 N/m), the cubic 4.06e12 N/m^3 (+35 %), linkage 1.36e7 N/m (+13 %), held-out 0.172/0.173,
pseudo damage median 44 091 % -> 111 % (44-195 %), 20/21 closer to 100 %.

Session 12 (c7662bf: joint candidates with the vertical stiffness apart, both mounts of a tank in one joint
fit, the joint fit started a second time with the best-screened physics at its prior start; session 11's
recordings, the truth and recording code unchanged; load 2-3): round 1's second start 0.122 against 0.190
from the screening optima, 9 members kept (both rear supports, all four tank mounts, both waters, the
linkage), held-out 4.47 -> 0.60 (session 11: 1.16); then the pad (-> 0.32), the right bracket's joint
(-> 0.16), the final joint refit, the cubic (71 % of the level-dependent share at the held-out level):
12 findings, all in the truth, held-out 0.0946 (from the progress log: that run's table printing failed on
a parameter without a standard deviation, since fixed). On session 9's per-axis trial truth (the right
tank's mounts soft only vertically) round 1 now lands in the truth's basin (0.392 against 1.812;
held-out 4.62 -> 0.68, session 11: 1.51); 9 findings, all in the truth (rear supports 2.55e7/1.95e7 N/m
for 2e7, the right tank's front mount 1.8e7 N/m vertically for 2e7, linkage 1.16e7 N/m for 1.2e7), held-out
0.511/0.472 (session 11: 1.12), pseudo damage median 76 022 % -> 86 %, 1756 s; but the pad explained 20 %
of what was left after round 1 (a finding needs 30 %) and the cubic was not found.

Session 13 (fresh recordings of the shipped truth, written by 14fec26's code; load 2): round 1's second
start 0.1223 against 0.1899, 9 members kept, held-out 4.47 -> 0.596; the pad (-> 0.322), the right
bracket's joint (-> 0.164), the final joint refit of 11 findings (free not adopted; with the parameters
at their rounds' bounds held adopted: held-out 0.164 -> 0.094), the cubic (3.59e12 N/m^3, truth 3e12:
+19.5 %; 71 % of the level-dependent share at the held-out level): 12 findings, all in the truth,
held-out 4.91/4.03 -> 0.096/0.093, pseudo damage median 44 091 % -> 91 % (64-107 %), 20/21 closer to 100
%; 4473 s (rounds 1-3 20 min, the refits most of the rest). Trials on the per-axis truth (branch
``axis``; its recordings' code hash equals that branch's), not adopted: refitting the findings together
and screening again when no candidate explains enough left the pad at 15 % (2624 s, held-out 0.51/0.47 as
before); a third start of the joint fit (every member at its prior) on composites rebuilt at each start
reached 0.181 in round 1 (rear supports 1.76e7/2.15e7 N/m, the right tank's mounts 2.0e7/3.08e7 N/m
vertically, the linkage 1.21e7 N/m and 21.6 kg: near the truth) but dropped both waters (they did not
pay) and ended at held-out 0.98/1.20 (952 s); on the shipped truth the same code gave 12 findings, all in
the truth, held-out 0.242/0.252 (the right bracket's joint not found in its round; 2473 s). The joint
entry's per-axis factors widened to 1e-7..1e7 (branch ``fix-clip``: a composite is exact only where no
carried value is clipped) gave the per-axis truth's rounds 1 and 2 unchanged.

Session 14 (the joint fit's composite exact everywhere: linearised at a 1 ms damping time and with a
rear support's spring where the entry switches (a zero damping time, a support carried as rigid), the
joint entry's per-axis factors bounded 1e-7..1e7, and the spectral residual refusing an indefinite mass
matrix; fresh recordings, load 2): round 1's second start 0.157 against 0.277, 9 members kept, held-out
4.47 -> 0.557; the pad (-> 0.344); round 3 fitted the right bracket's joint but it explained 16 % (it needs
30 %): not found; the final joint refit of 10 findings adopted free (0.344 -> 0.180); the cubic 3.11e12
N/m^3 (+3.6 %): 11 findings, all in the truth, held-out 0.198/0.162, pseudo damage median 44 091 % ->
99 % (67-174 %), 21/21 closer to 100 %; 2379 s. Per round-1 value the two runs are about as close to the
truth (this one nearer in the rear supports' and the water's damping and the cubic, farther in the
linkage mass, 45 kg for 20, and the left tank's front mount); the higher held-out error is mostly the
right bracket's mode (47.4 Hz), whose joint was not found. On the per-axis truth the exact composite gave
round 1 0.934 (second start; 0.392 on the inexact one), held-out 0.74/0.76, the pad not found (672 s);
before the mass check its joint fit ended with 300 + 250 kg of water sloshing, an indefinite mass matrix
whose time response diverged, and every member was rejected. A third start (every member at its prior)
on the exact composite reached 0.782 there and then nothing paid for itself: not adopted.

Until session 15 ``thesis`` was the truth now named ``thesis-iso``: the results of sessions 6-14 above
are on that truth (or on ``thesis-dry`` where said).

Session 15 (``--scenario thesis-table1``, the truth whose EMA gives Table 1, ``thesis`` since session 16;
fresh recordings): with the
default starts round 1 ends at 0.922 (the left tank's front mount at 3.3e5 N/m vertically for 3.97e9, 300
and 193 kg of water for 70), held-out 4.61 -> 0.78/0.80, the pad and its cubic not found (910 s). With
``--all-prior-start`` (a third start, every member at its prior) round 1 reaches 0.465, round 3 finds the
pad, and the final time-domain refit and the cubic (2.83e12 N/m^3, -5.6 %) give 12 findings, held-out
0.180/0.171, pseudo damage median 59 910 % -> 96 % (84-225 %), 21/21 closer to 100 %: every acceptance
item but the 10 minutes (2685 s, load 1-1.6).

Session 16: the third start on by default (``RigDiagnosisSettings.composite_all_prior_start``;
``--no-all-prior-start`` turns it off) and ``thesis-table1`` renamed ``thesis``, the old ``thesis``
``thesis-iso``. On ``thesis`` (fresh recordings, the same truth and seed as session 15's, load 3-4.4):
the same run as session 15's with ``--all-prior-start``: round 1 second start 0.922, third 0.465 (7
members kept, held-out 4.61 -> 2.44), round 2 the linkage (-> 0.84), round 3 the pad with the right
tank's water and the right bracket's joint (-> 0.41), the final time-domain refit (-> 0.175) and the
cubic (2.83e12 N/m^3, truth 3e12: -5.6 %; 71 % of the level-dependent share at the held-out level): 12
findings, all in the truth, held-out 0.180/0.171, pseudo damage median 59 910 % -> 96 % (84-225 %), 21/21
closer to 100 %; 4991 s at that load (session 15: 2685 s at load 1-1.6). On ``thesis-iso`` with the
third start (983e3e2 with ``--all-prior-start``, load 3-4): round 1's third start 0.1351 against the
second's 0.1566, 9 members kept (held-out 4.47 -> 0.585), the pad (-> 0.374), then the 1800 s budget
stopped the rounds (round 2 took 976 s at that load), so the cubic was not tried; final held-out
0.205/0.168, pseudo damage median 44 091 % -> 101 %, 21/21 closer (3515 s). With ``--time-budget 3600``
(2a4e49e, fresh recordings, load 1-4): the same rounds 1 and 2, then round 3 the right bracket's joint
(-> 0.229; session 14 missed it), the final refit (-> 0.078): 11 findings, all in the truth, held-out
0.082/0.074 (session 14: 0.198/0.162), pseudo damage median 44 091 % -> 96 % (69-112 %), 20/21 closer;
but the budget again stopped the rounds before one found nothing (3212 s used, round 3 took 1393 s at load
3-4), and the nonlinear candidates are screened only then, so the cubic was not tried (4477 s).

Run: ``python3 benchmarks/bench_diagnose_thesis.py [--out DIR] [--recordings DIR] [--duration S]
[--protocol levels|original] [--time-budget S] [--scenario thesis|thesis-iso|thesis-dry]
[--no-all-prior-start]``
(``--recordings`` reuses recordings written by an earlier run, only if its truth file is the scenario's
and its ``recording_code.json`` holds the hash of the current recording code, i.e. the package's sources
but the diagnosis and the EMA; else new ones are written). Results: ``DIR/thesis_diagnosis.json`` and
the HTML report ``DIR/report/index.html``.
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
#: the test signal at these further drive levels (protocol ``levels``)
LEVELS = (2.0, 3.0)


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
        if a["physics"] == "sloshing" and a["location"] == loc.get("component"):
            return a
        if (
            a["physics"] == "rear_support_compliance"
            and loc.get("interface") == f"foundation_{a['location']}"
        ):
            return a
    return None


def _same_truth(truth_file: Path, sc) -> bool:
    """Whether the truth file next to reused recordings is that of scenario ``sc`` as it is now."""
    augs = json.loads(truth_file.read_text())["augmentations"]
    now = [
        {"physics": a.physics, "location": a.location, "parameters": dict(a.parameters)}
        for a in sc.augmentations
    ]

    def key(items):
        return sorted(
            (
                a["physics"],
                str(a["location"]),
                sorted((k, round(float(v), 12)) for k, v in a["parameters"].items()),
            )
            for a in items
        )

    return key(augs) == key(now)


#: the recordings' code version is a hash of the package's sources but these (the diagnosis under test
#: and the EMA do not write recordings)
NOT_RECORDING_CODE = ("diagnose", "identify")
CODE_VERSION_FILE = "recording_code.json"


def _recording_code_hash() -> str:
    """SHA-256 of the package sources that write the recordings (all but :data:`NOT_RECORDING_CODE`)."""
    import hashlib

    import exudyn_study

    root = Path(exudyn_study.__file__).parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel.parts[0] in NOT_RECORDING_CODE:
            continue
        digest.update(str(rel).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def _same_code(rec_dir: Path, code_hash: str) -> bool:
    """Whether the recordings in ``rec_dir`` were written by the current recording code."""
    try:
        return json.loads((rec_dir / CODE_VERSION_FILE).read_text())["source_sha256"] == code_hash
    except (OSError, ValueError, KeyError):
        return False


def _load() -> str:
    try:
        return " ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "?"


def main(argv=None) -> int:
    from exudyn_study.diagnose.rig import RigDiagnosisSettings, diagnose_rig
    from exudyn_study.infra.atomic import write_text_atomic
    from exudyn_study.virtual_rig import run_virtual_test, scenario, truth_name
    from exudyn_study.virtual_rig.run import recording_name

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="directory for the results (default: a temporary one)")
    ap.add_argument("--recordings", default=None, help="reuse the thesis recordings in this directory")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per recording")
    ap.add_argument(
        "--time-budget",
        type=float,
        default=None,
        help="the diagnosis's time budget in s (default RigDiagnosisSettings.time_budget_s, 540 s: one "
        "diagnosis under 10 min on an unloaded machine; give more on a loaded one and report the load)",
    )
    ap.add_argument(
        "--protocol",
        choices=("levels", "original"),
        default="levels",
        help="levels: train test at 50/100/300 %%, hold out white noise and test at 200 %%; original: train "
        "white noise + test-50, hold out test (see the module docstring)",
    )
    ap.add_argument(
        "--scenario",
        choices=("thesis", "thesis-iso", "thesis-dry"),
        default="thesis",
        help="the truth: the thesis scenario (tuned to Table 1; the diagnosis has no candidate for its "
        "wall mode), the truth of sessions 8-15 (thesis-iso) or the session-6 truth without the water "
        "(thesis-dry)",
    )
    ap.add_argument(
        "--no-all-prior-start",
        action="store_true",
        help="do not start a joint fit a third time with every member at its prior start "
        "(RigDiagnosisSettings.composite_all_prior_start, on by default)",
    )
    args = ap.parse_args(argv)
    out_dir = Path(args.out or tempfile.mkdtemp(prefix="bench_diagnose_thesis_"))
    out_dir.mkdir(parents=True, exist_ok=True)
    rec_dir = Path(args.recordings) if args.recordings else out_dir
    sc = scenario(args.scenario)
    paths = [rec_dir / recording_name(sc.name, s) for s in SIGNALS]
    more = (
        [rec_dir / recording_name(sc.name, "test", lv) for lv in LEVELS] if args.protocol == "levels" else []
    )
    t0 = time.perf_counter()
    truth_file = rec_dir / truth_name(sc.name)
    code_hash = _recording_code_hash()
    reason = None
    if truth_file.exists() and not _same_truth(truth_file, sc):
        reason = f"are of another version of the {sc.name} scenario (its truth file differs from scenario())"
    elif truth_file.exists() and not _same_code(rec_dir, code_hash):
        # the same truth file, but other code may write other recordings of it (session 9 reused
        # session 7's recordings and measured a diagnosis the current recordings did not give)
        reason = f"were written by other code (no {CODE_VERSION_FILE} there, or another hash of its sources)"
    stale = reason is not None
    if stale:
        print(f"the recordings in {rec_dir} {reason}; writing new recordings into {out_dir}", flush=True)
        rec_dir = out_dir
        paths = [rec_dir / recording_name(sc.name, s) for s in SIGNALS]
        more = [rec_dir / recording_name(sc.name, "test", lv) for lv in LEVELS] if more else []
    written = False
    if stale or not all(p.exists() for p in paths) or not (rec_dir / truth_name(sc.name)).exists():
        paths = run_virtual_test(sc, list(SIGNALS), rec_dir, duration_s=args.duration)
        written = True
    if stale or not all(p.exists() for p in more):
        more = run_virtual_test(sc, ["test"], rec_dir, duration_s=args.duration, levels=LEVELS)
        written = True
    if written:
        write_text_atomic(rec_dir / CODE_VERSION_FILE, json.dumps({"source_sha256": code_hash}) + "\n")
    paths = paths + more
    t_rec = time.perf_counter() - t0
    print(f"recordings: {[p.name for p in paths]} ({t_rec:.0f} s); load {_load()}", flush=True)

    t0 = time.perf_counter()
    by_signal = dict(zip(SIGNALS + tuple(f"test-L{lv:g}" for lv in LEVELS)[: len(paths)], paths, strict=True))
    if args.protocol == "levels":
        train = [by_signal["test-50"], by_signal["test"], by_signal["test-L3"]]
        holdout = [by_signal["white-noise"], by_signal["test-L2"]]
    else:
        train, holdout = [by_signal["white-noise"], by_signal["test-50"]], [by_signal["test"]]
    print(f"protocol {args.protocol}: train {[p.name for p in train]}, hold out {[p.name for p in holdout]}")
    st = RigDiagnosisSettings()
    if args.time_budget is not None:
        st.time_budget_s = float(args.time_budget)
    if args.no_all_prior_start:
        st.composite_all_prior_start = False
    figures: dict = {}
    d = diagnose_rig(
        sc.variant,
        train,
        holdout,
        damping=sc.damping,
        progress=lambda t: print("  " + t, flush=True),
        settings=st,
        figures=figures,
    )
    wall = time.perf_counter() - t0
    from exudyn_study.diagnose.report import write_report

    report = write_report(d, out_dir / "report", figures)  # what a user gets from ``diagnose --report``
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
        truth_values = {} if a is None else dict(a["parameters"])
        if a is not None and a["physics"] == "bushing_stiffness":
            from exudyn_study.diagnose.rig_candidates import pad_fit_values

            truth_values = pad_fit_values(truth_values)  # the candidate fits moduli, not the entry's factors
        if a is not None and a["physics"] == "rear_support_compliance":
            c_x = truth_values.get("longitudinal_compliance_m_per_n", 0.0)  # fitted as a stiffness
            truth_values["longitudinal_stiffness_n_per_m"] = 1.0 / c_x if c_x > 0 else None
        if a is not None and a["physics"] == "joint_stiffness":  # the candidate fits the vertical apart
            truth_values["vertical_stiffness_n_per_m"] = truth_values["stiffness_n_per_m"] * truth_values.get(
                "stiffness_factor_z", 1.0
            )
        for name, v in f.parameters.items():
            true = truth_values.get(name)
            params[name] = {"fitted": v["value"], "std": v["std"], "at_bound": v["at_bound"], "truth": true}
            rel = "" if not true else f" ({100 * (v['value'] / true - 1):+.1f} %)"
            std = "?" if v["std"] is None else format(v["std"], ".2g")
            print(
                f"    {name:36s} {v['value']:.4g} +- {std}   truth "
                f"{true if true is not None else '-'}{rel}{'   AT ITS BOUND' if v['at_bound'] else ''}"
            )
        # the held-out error at the finding's own sensors (the summary over 42 channels dilutes a local one)
        at_sensors = {}
        for rec, per in f.fit.get("per_channel", {}).items():
            chans = [c for c in f.location.get("sensors", []) if c in per]
            if chans:
                at_sensors[rec] = {
                    w: float(np.sqrt(np.mean([per[c][w] ** 2 for c in chans]))) for w in ("before", "after")
                }
        if at_sensors:
            print(
                "    held-out error at its sensors: "
                + "; ".join(f"{r} {v['before']:.4f} -> {v['after']:.4f}" for r, v in at_sensors.items())
            )
        for text in f.flags:
            print(f"    flag: {text}")
        rows.append(
            {
                "physics": f.physics,
                "location": f.location,
                "in_truth": a is not None,
                "parameters": params,
                "fit": {k_: v_ for k_, v_ in f.fit.items() if k_ != "per_channel"},
                "level_dependent": f.level_dependent,
                "holdout_at_its_sensors": at_sensors,
                "flags": list(f.flags),
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
        "rear_supports_found": "rear_support_compliance" in found,
        "bushing_found": "bushing_stiffening" in found,
        "pseudo_damage_toward_100pct": bool(
            summary
            and summary["median_log10_distance_from_100pct"]["after"]
            < summary["median_log10_distance_from_100pct"]["before"]
        ),
        "under_10_min": wall < 600.0,
    }
    if "final_refit" in d.metadata:
        r = d.metadata["final_refit"]
        print(
            f"final joint refit of {len(r['members'])} findings ({r.get('evaluator')}): training residual "
            f"{r['train_residual_before']:.4g} -> {r['train_residual_after']:.4g}, held-out "
            f"{r.get('holdout_before', float('nan')):.4g} -> {r.get('holdout_after', float('nan')):.4g}, "
            f"adopted: {r.get('adopted')}"
        )
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
        "final_refit": d.metadata.get("final_refit"),
        "protocol": args.protocol,
        "time_budget_s": st.time_budget_s,
        "wall_diagnosis_s": wall,
        "load": _load(),
        "acceptance": accept,
        "truth": augs,
    }
    path = write_text_atomic(out_dir / "thesis_diagnosis.json", json.dumps(result, indent=1, default=float))
    print(f"results {path}; report {report}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
