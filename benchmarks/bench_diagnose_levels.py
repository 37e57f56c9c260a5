"""Benchmark: the level-trend diagnosis on a synthetic twin and on a real bolted beam.

**Twin** (:mod:`exudyn_study.diagnose.twin`): a 12-mode chain (9-148 Hz, 1 % modal damping) with a
bolted joint between sensors A and B whose stuck stiffness is half slider (Jenkins, slip at
20 um), a force odd-random multisine (5-160 Hz, period 20 s) at 7 levels (0.15-1.6 N rms), 4
realisations of 3 periods each (the first of each its transient; 4 min at 400 Hz per level;
``--realisations``/``--periods`` change it, and 3 realisations are measured too), 0.5 % noise on
every channel and 0.5 % shaker-gain drift from period to period; sensors DP (drive point), A and
B. No interface is declared. Trained on levels 1, 3, 5, 7, held out 2, 4, 6. Measured: the wall
time of the diagnosis; the located pair and the named physics; every mode's frequency and damping
per level against the truth (the poles of the level's best linear approximation: the joint's
equivalent complex stiffness at each mode, the slider force replayed on the simulated joint motion
as the simulation ran it, taken against the shaker force as the instrument, smooth over
frequency, put into the linear structure's eigenproblem:
:func:`~exudyn_study.diagnose.twin.truth_modes`); the held-out FRF errors before and after. The
same twin with a linear joint must give no finding. Seeds: 0-3 were used while developing;
``--seeds`` gives others (reported separately).

Why 4 realisations: a multisine FRF of a nonlinear structure carries the stochastic nonlinear
distortion of its realisations, which only more realisations reduce (as ``1 / sqrt(M)``) and
which no prediction from the drive can remove. The FRF estimate measures it (the noise +
distortion floor below). With 3 realisations the floor of the 0.6 N level, where the joint
starts to slip, is 0.45-0.50 of that level's error before the fit (``holdout_floor_over_before``),
so even an exact linear model of the level could not show its error halved; a lab sizes the
number of realisations from the distortion a first run shows, so that it sits well below the
effect to be shown: 4 bring it to 0.41-0.44 and leave room for the model's own error.

Held-out criterion: the error of every held-out level is at least halved, **or** the error after is
at the noise floor (within 10 % of the noise floor from the period-to-period scatter,
``||sigma|| / ||H||``: a level whose error was already there has nothing to halve).
``holdout_met`` gives the verdict per held-out level. ``holdout_met_distortion_floor`` gives it
against the noise + distortion floor instead (halved, or within 10 % of that floor): at a level where
the joint barely slips the error before the fit is already at that floor, and the stochastic
nonlinear distortion of the realisations is what no linear model of the level can predict from the
drive, so there is nothing to halve. The raw errors before and
after, the noise floor, the noise + distortion floor and the error of the level's own modal fit
(poles and residues fitted on that level: what a linear model fitted to the level itself leaves)
are reported beside it.

**UNESP bolted beam** (``--unesp DIR``, e.g. ``../shared/data/unesp-bert-bolted-beam``; public dataset
``shm-unesp/DATASET_BOLTEDBEAM``, SHM Lab UNESP Ilha Solteira, CC-BY-NC-SA, Teloli et al. 2020;
read by path, never copied): a cantilever of two aluminium beams with a bolted lap joint between
accelerometers 2 and 3, shaker amplifier voltage as the drive (not a force), 0-40 Hz chirps and
random bursts at 0.05-0.30 V. Trained on 0.05, 0.15, 0.30 V, held out 0.10, 0.20, 0.25 V.

**Brake-Reuss beam** (``--brb FILE``: ``ForcedFrequencyResponses.mat`` of the public repository
``mattiacenedese/BRBtesting``, GPL-3.0, Chen et al. / Jin et al. 2022, MSSP 166; read by path): four
force levels (0.195-1.46 N) of stepped-sine first-harmonic FRFs at 79.2-81.2 Hz, one accelerometer,
and eight response-controlled levels (5-80 m/s^2 at 79-81.2 Hz). Measured FRFs, so the stages after
the FRF estimate run (``diagnose_level_frfs``) with an assumed 1 % standard deviation per line (the
file holds none); one channel: nothing can be located or fitted, the modal trend is the result.
Force control: trained on levels 1, 2, 4, held out 3; response control: held out 2, 4, 6.

    python benchmarks/bench_diagnose_levels.py [--seeds 0] [--realisations 4] [--periods 3] [--no-twin]
        [--no-linear] [--unesp DIR] [--brb FILE] [--out DIR] [--no-results]

Figures go with date, commit and load to ``benchmarks/results/bench_diagnose_levels--<case>.json``.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

from exudyn_study.diagnose.levels import LevelSettings, diagnose_levels, write_level_report
from exudyn_study.diagnose.twin import Twin, simulate_twin

TWIN_LEVELS_N = (0.15, 0.25, 0.4, 0.6, 0.85, 1.2, 1.6)
TRAIN, HOLDOUT = [0, 2, 4, 6], [1, 3, 5]
UNESP_LEVELS = ("05", "10", "15", "20", "25", "30")
UNESP_TRAIN, UNESP_HOLDOUT = [0, 2, 5], [1, 3, 4]


def run_twin(seed: int, friction: bool, out: Path | None, realisations: int = 4, periods: int = 3) -> dict:
    tw = Twin(period_s=20.0, friction_share=0.5 if friction else 0.0)
    t0 = time.perf_counter()
    recs, truth = simulate_twin(
        TWIN_LEVELS_N, twin=tw, periods=periods, realisations=realisations, seed=seed, return_truth=True
    )
    t_sim = time.perf_counter() - t0
    state: dict = {}
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = diagnose_levels(
            recs,
            TRAIN,
            HOLDOUT,
            settings=LevelSettings(realisations=realisations),
            state=state,
            progress=False,
        )
    t_diag = time.perf_counter() - t0
    case = f"twin-{'friction' if friction else 'linear'}-seed{seed}"
    if out is not None:
        d.write_json(out / f"{case}.json")
        write_level_report(d, state, out / case)
    fig = {
        "seed": seed,
        "realisations": realisations,
        "periods_per_realisation": periods,
        "record_s_per_level": realisations * periods * tw.period_s,
        "simulation_s": t_sim,
        "diagnosis_s": t_diag,
        "summary": d.summary,
        "warnings": [str(w.message) for w in caught],
        "findings": len(d.findings),
    }
    tab = state["table"]
    f_true = np.array([t[0] for t in truth])
    z_true = np.array([t[1] for t in truth])
    f_err = tab.frequency_hz / f_true - 1.0
    z_err = tab.damping_ratio / z_true - 1.0
    fig["frequency_error_max_per_level"] = np.max(np.abs(f_err), axis=1).tolist()
    fig["damping_error_max_per_level"] = np.max(np.abs(z_err), axis=1).tolist()
    fig["frequency_error_median_per_level"] = np.median(np.abs(f_err), axis=1).tolist()
    fig["damping_error_median_per_level"] = np.median(np.abs(z_err), axis=1).tolist()
    fig["modes_within_0p5pct_frequency"] = int(np.sum(np.abs(f_err) <= 0.005))
    fig["modes_within_10pct_damping"] = int(np.sum(np.abs(z_err) <= 0.10))
    fig["mode_level_cells"] = int(f_err.size)
    fig["true_frequency_change_max"] = float(np.max(np.abs(f_true[-1] / f_true[0] - 1)))
    fig["true_damping_ratio_range"] = [float(z_true.min()), float(z_true.max())]
    if d.findings:
        f = d.findings[0]
        fig.update(
            physics=f.physics,
            interface=f.location.get("interface"),
            parameters=f.parameters,
            per_level_columns=[
                "before",
                "after",
                "noise+distortion floor",
                "noise floor",
                "own fit",
                "held out",
            ],
            per_level={
                k: [
                    v["mean_before"],
                    v["mean_after"],
                    v["mean_floor"],
                    v["mean_noise_floor"],
                    v["mean_own_fit"],
                    v["held_out"],
                ]
                for k, v in f.fit["per_level"].items()
            },
        )
        ho = [v for v in f.fit["per_level"].values() if v["held_out"]]
        fig["holdout_ratio_after_before"] = [v["mean_after"] / v["mean_before"] for v in ho]
        fig["holdout_noise_floor"] = [v["mean_noise_floor"] for v in ho]
        fig["holdout_own_fit"] = [v["mean_own_fit"] for v in ho]
        # what no prediction of the level from its drive can remove, against what there is to halve
        fig["holdout_floor_over_before"] = [v["mean_floor"] / v["mean_before"] for v in ho]
        fig["holdout_met"] = [
            bool(v["mean_after"] <= 0.5 * v["mean_before"] or v["mean_after"] <= 1.1 * v["mean_noise_floor"])
            for v in ho
        ]

        fig["holdout_met_distortion_floor"] = [
            bool(v["mean_after"] <= 0.5 * v["mean_before"] or v["mean_after"] <= 1.1 * v["mean_floor"])
            for v in ho
        ]

        def excess(e, fl):  # the error beyond the noise and distortion floor
            return float(np.sqrt(max(e * e - fl * fl, 0.0)))

        fig["holdout_excess_ratio_after_before"] = [
            excess(v["mean_after"], v["mean_floor"]) / max(excess(v["mean_before"], v["mean_floor"]), 1e-300)
            for v in ho
        ]
    fig["location_evidence"] = [
        (e["pair"], e["score"], e["z"]) for e in d.metadata.get("location_evidence", [])
    ]
    fig["location_sensitivity"] = [
        (e["pair"], e["reduced_chi2"], e["z"]) for e in d.metadata.get("location_sensitivity", [])
    ]
    fig["located_by"] = d.metadata.get("located_by")
    return fig


def _unesp_recordings(root: Path, kind: str):
    import scipy.io as sio

    from exudyn_study.recording import Channel, Recording

    recs = []
    for lv in UNESP_LEVELS:
        d = (
            root
            / "Data"
            / "T5Nm"
            / ("Rand/Rand0p" + lv if kind == "random" else "Chirp/Chirp0to40Hz/Chirp0p" + lv)
        )
        t = sio.loadmat(d / "Time.mat", squeeze_me=True, struct_as_record=False)
        s = sio.loadmat(d / "TimeShaker.mat", squeeze_me=True, struct_as_record=False)
        acc = np.asarray(t["Signal"].y_values.values, float) * 9.80665  # g -> m/s^2
        v = np.asarray(s["Time_Shaker__X"].y_values.values, float)
        fs = 1.0 / float(t["Signal"].x_values.increment)
        ch = [Channel(f"acc{i + 1}", "acceleration", "m/s^2", "Z", None, fs, acc[:, i]) for i in range(4)]
        ch.append(Channel("shaker", "voltage", "V", "Z", None, fs, v, role="drive"))
        recs.append(Recording(tuple(ch), {"source": f"{kind} 0.{lv} V"}))
    return recs


def run_unesp(root: Path, kind: str, band, out: Path | None) -> dict:
    recs = _unesp_recordings(root, kind)
    state: dict = {}
    t0 = time.perf_counter()
    fig: dict = {"kind": kind, "band_hz": band}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            d = diagnose_levels(
                recs,
                UNESP_TRAIN,
                UNESP_HOLDOUT,
                settings=LevelSettings(band_hz=band),
                state=state,
                progress=False,
            )
        except Exception as exc:  # a refusal is a result too: what the tool says on this data
            fig.update(refused=str(exc), diagnosis_s=time.perf_counter() - t0)
            return fig
    fig.update(
        diagnosis_s=time.perf_counter() - t0, summary=d.summary, warnings=[str(w.message) for w in caught]
    )
    if out is not None:
        d.write_json(out / f"unesp-{kind}.json")
        write_level_report(d, state, out / f"unesp-{kind}")
    tab = state["table"]
    fig["modes_hz"] = tab.frequency_hz[0].tolist()
    fig["frequency_hz_per_level"] = tab.frequency_hz.tolist()
    fig["damping_ratio_per_level"] = tab.damping_ratio.tolist()
    fig["frequency_std_hz_per_level"] = tab.frequency_std_hz.tolist()
    fig["damping_std_per_level"] = tab.damping_std.tolist()
    fig["trends"] = [
        (t.mode, t.frequency_hz, t.outcome, t.frequency_change, t.damping_change) for t in state["trends"]
    ]
    fig["location_evidence"] = [
        (e["pair"], e["score"], e["z"]) for e in d.metadata.get("location_evidence", [])
    ]
    fig["reference_check"] = d.metadata["reference_model"]["check"]
    for f in d.findings:
        fig.update(
            physics=f.physics,
            interface=f.location.get("interface"),
            flags=list(f.flags),
            per_level={
                k: [v["mean_before"], v["mean_after"], v["mean_floor"], v["held_out"]]
                for k, v in f.fit["per_level"].items()
            },
        )
    for u in d.unexplained:
        fig["unexplained"] = u["explanation"]
    return fig


def run_brb(path: Path, control: str = "ForceControl") -> dict:
    import scipy.io as sio

    from exudyn_study.diagnose.levels import LevelFRF, diagnose_level_frfs

    data = getattr(sio.loadmat(path, squeeze_me=True, struct_as_record=False)["FRdata"], control)
    frfs = []
    for x in data:
        force = np.asarray(x.force, float)
        h = (np.asarray(x.amplitude) * np.exp(1j * np.asarray(x.phase)) / force)[None, :]  # (m/s^2)/N
        frfs.append(
            LevelFRF(
                f"BRB {np.mean(force):.3g} N",
                float(np.sqrt(np.mean(force**2 / 2))),
                np.asarray(x.frequency, float),
                h,
                0.01 * np.abs(h),
                None,
                force.astype(complex),
                "periodic",
                0.05,
                1,
                ("acc",),
                "N",
                "m/s^2",
            )
        )
    state: dict = {}
    t0 = time.perf_counter()
    n = len(frfs)
    holdout = list(range(1, n - 1, 2)) if n > 4 else [2]
    train = [i for i in range(n) if i not in holdout]
    d = diagnose_level_frfs(frfs, train, holdout, state=state, progress=False)
    tab = state["table"]
    return {
        "control": control,
        "levels_force_rms_n": [f.level for f in frfs],
        "train": train,
        "holdout": holdout,
        "diagnosis_s": time.perf_counter() - t0,
        "summary": d.summary,
        "frequency_hz_per_level": tab.frequency_hz.tolist(),
        "damping_ratio_per_level": tab.damping_ratio.tolist(),
        "frequency_std_hz_per_level": tab.frequency_std_hz.tolist(),
        "damping_std_per_level": tab.damping_std.tolist(),
        "trends": [
            (t.mode, t.frequency_hz, t.outcome, t.frequency_change, t.damping_change) for t in state["trends"]
        ],
        "reference_check": d.metadata["reference_model"]["check"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--seeds", type=int, nargs="+", default=[0], help="twin seeds (0: the development seed)"
    )
    parser.add_argument("--no-twin", action="store_true", help="skip the synthetic twin")
    parser.add_argument("--realisations", type=int, default=4, help="twin: multisine realisations per level")
    parser.add_argument(
        "--periods", type=int, default=3, help="twin: periods per realisation (first dropped)"
    )
    parser.add_argument("--no-linear", action="store_true", help="skip the twin with a linear joint")
    parser.add_argument(
        "--unesp", type=Path, default=None, metavar="DIR", help="the UNESP bolted-beam dataset"
    )
    parser.add_argument(
        "--brb", type=Path, default=None, metavar="FILE", help="BRB ForcedFrequencyResponses.mat"
    )
    parser.add_argument("--out", type=Path, default=None, help="write JSON + HTML report per case here")
    parser.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = parser.parse_args()
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
    cases = []
    if not args.no_twin:
        rp = (args.realisations, args.periods)
        tail = "" if rp == (4, 3) else f"-r{rp[0]}p{rp[1]}"
        cases += [(f"twin-seed{s}{tail}", lambda s=s: run_twin(s, True, args.out, *rp)) for s in args.seeds]
        if not args.no_linear:
            cases.append(
                (
                    f"twin-linear-seed{args.seeds[0]}{tail}",
                    lambda: run_twin(args.seeds[0], False, args.out, *rp),
                )
            )
    if args.unesp is not None:
        cases.append(("unesp-chirp", lambda: run_unesp(args.unesp, "chirp", None, args.out)))
        cases.append(("unesp-chirp-band5-40", lambda: run_unesp(args.unesp, "chirp", (5.0, 40.0), args.out)))
        cases.append(
            ("unesp-random-band10-30", lambda: run_unesp(args.unesp, "random", (10.0, 30.0), args.out))
        )
    if args.brb is not None:
        cases.append(("brb-force-control", lambda: run_brb(args.brb)))
        cases.append(("brb-response-control", lambda: run_brb(args.brb, "ResponseControl")))
    for name, fn in cases:
        fig = fn()
        print(f"== {name}")
        for k, v in fig.items():
            if k not in (
                "location_evidence",
                "frequency_hz_per_level",
                "damping_ratio_per_level",
                "warnings",
            ):
                print(f"  {k}: {v}")
        print(f"  location_evidence: {fig.get('location_evidence', [])[:3]}")
        if not args.no_results:
            print(f"  -> {write_results('bench_diagnose_levels', fig, args=args, case=name, start=run)}")


if __name__ == "__main__":
    main()
