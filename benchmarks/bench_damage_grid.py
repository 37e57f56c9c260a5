"""Benchmark of issue 6: drive iteration with a rig resonance the model lacks, and the full study grid.

Part 1 (acceptance: error at the control sensors below 5 % rms within 10 iterations). The
'truth' is a real model (default Model 1, STEP damping) with the ``drive_linkage_compliance``
physics entry tuned to a linkage resonance at 28 Hz (thesis Section 7.1, Fig. 20); its 80 s
white-noise response passes the acquisition chain (noise, anti-alias filter, ADC) and is the
'measured' recording. Three iterations are reported, error per run:

(a) the thesis's setting: the drive of the *nominal* model (no linkage compliance) is iterated
    until its control responses match the measured ones (H: the nominal model's FRF);
(b) time waveform replication on the truth itself with the nominal model's H, the FRF
    updated from the runs (what a rig controller does when its model lacks a resonance);
(c) as (b) with H kept fixed (the plain scheme of Fig. 21): diverges above the resonance.

Part 2: the full grid, Models 1-3 x {adams-default, step, suggested[, diagnosed]} x
{white-noise, test, test-50}, against the measured recordings in ``--measured-dir``
(``<name>_<signal>.h5``); without it, they are made first by the virtual test rig's
``--scenario`` (default ``thesis``; timed apart). ``suggested`` is each model calibrated on the
EMA of the white-noise recording (shapes, MAC pairing); ``--diagnosis FILE`` (a rig diagnosis
JSON of the same recordings) adds the ``diagnosed`` column. Prints the wall time, the summary
table, the pairing of model and EMA modes, the grid's reading per sensor group and the
acceptance of issue 33:

- scenario ``thesis``: on every model the calibrated damping's median relative damage (over
  the sensors and signals) closer to 100 % than Adams default (as the factor ``exp |log r|``);
  on the bracket and tank sensors at least as close as STEP; the diagnosed column within
  50-200 % on at least 18 of the 21 z sensors (each signal);
- scenario ``none`` (truth: Model 1 with Adams default): Model 1 with Adams default within
  100 +- 5 % on every sensor (each signal): the pipeline check.

CSV, calibrations, pairing, reading and plots go to ``--out``.

    python benchmarks/bench_damage_grid.py [--measured-dir DIR] [--scenario thesis|none]
        [--diagnosis FILE] [--target MODES.json] [--models 1 2 3] [--tolerance 0.05] [--out DIR]
        [--skip-grid] [--skip-linkage] [--no-results]

The iteration errors of part 1, the summary per grid cell, the acceptance figures and the wall
time of part 2 go with date, commit and load to
``benchmarks/results/bench_damage_grid--<scenario>.json`` (``--no-results``: not written).
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

LINKAGE_HZ = 28.0
LINKAGE_MASS_KG = 20.0
LINKAGE_DAMPING_N_S_PER_M = 2e3
ACCEPT = 0.05


def _errors_table(label: str, res) -> None:
    print(f"  {label}")
    for k, row in enumerate(res.errors):
        print(f"    run {k:2d}: " + "  ".join(f"{n} {100 * e:8.2f} %" for n, e in zip(res.control_names, row,
                                                                                      strict=True)))
    print(f"    -> {'converged' if res.converged else 'NOT converged'}, best {100 * res.best_error:.2f} % "
          f"after {res.n_iterations} update(s)")


def _iteration_figures(res) -> dict:
    return {"converged": res.converged, "updates": res.n_iterations, "best_error_pct": 100 * res.best_error,
            "error_per_run_pct": [100 * float(max(row)) for row in res.errors]}


def linkage_acceptance(variant: int, damping: str, duration_s: float, cache_dir=None) -> dict:
    """Drive iteration against a truth with a linkage resonance (part 1); return its figures."""
    from exudyn_study.linear.response import frf_linear
    from exudyn_study.model import build_model
    from exudyn_study.model.linearisation import system_modes
    from exudyn_study.physics import entry
    from exudyn_study.signals import drive_signal
    from exudyn_study.sweep.plant import ModelPlant, iterate_model_drive
    from exudyn_study.virtual_rig.measurement import measure

    print(f"== drive iteration, Model {variant} ({damping}) with a {LINKAGE_HZ:g} Hz drive-linkage resonance "
          f"in the truth, {duration_s:g} s white noise")
    t0 = time.perf_counter()

    def build():
        return build_model(variant, damping=damping, cache_dir=cache_dir, exudyn_mesh="used")

    nominal = ModelPlant(build())
    lin = nominal.lin
    m_eff = float(lin.drive_shape @ lin.full_mass @ lin.drive_shape) + LINKAGE_MASS_KG
    k = (2 * math.pi * LINKAGE_HZ) ** 2 * m_eff  # first guess: the drive's mass on the spring
    nominal_hz = system_modes(nominal.model, lin, max_frequency_hz=80.0).frequency_hz
    for _ in range(4):  # the linkage mode couples with the frame: retune k on the new system mode
        truth_model = build()
        entry("drive_linkage_compliance").apply(truth_model, None, stiffness_n_per_m=k,
                                                mass_kg=LINKAGE_MASS_KG,
                                                damping_n_s_per_m=LINKAGE_DAMPING_N_S_PER_M)
        truth, k_used = ModelPlant(truth_model, label=f"{damping} + linkage"), k
        modes_hz = system_modes(truth_model, truth.lin, max_frequency_hz=80.0).frequency_hz
        new = [f for f in modes_hz if np.min(np.abs(nominal_hz - f)) > 0.3]
        f_new = min(new, key=lambda f: abs(f - LINKAGE_HZ)) if new else math.nan
        if not new or abs(f_new - LINKAGE_HZ) < 0.5:
            break
        k *= (LINKAGE_HZ / f_new) ** 2
    f = np.arange(3.0, 60.0, 0.05)
    i = list(lin.sensor_names).index("ARFVZ")
    ratio = np.abs(frf_linear(truth.lin, f)[i, 0]) / np.abs(frf_linear(lin, f)[i, 0])
    print(f"  truth: k = {k_used:.3g} N/m, new system mode at {f_new:.2f} Hz; |H_truth / H_nominal| at "
          f"ARFVZ peaks {ratio.max():.1f}x at {f[np.argmax(ratio)]:.2f} Hz; models built in "
          f"{time.perf_counter() - t0:.1f} s")
    drive = drive_signal("white-noise", duration_s, 1000.0, 0.25e-3, 21)
    measured = measure(truth.recording(drive, {"source": "benchmark truth (simulated)"}))
    t1 = time.perf_counter()
    a = iterate_model_drive(nominal, measured, max_iter=10, tol=ACCEPT)
    t2 = time.perf_counter()
    _errors_table(f"(a) nominal model iterated (thesis setting), {t2 - t1:.1f} s", a)
    b = iterate_model_drive(truth, measured, frf_plant=nominal, max_iter=10, tol=ACCEPT)
    t3 = time.perf_counter()
    _errors_table(f"(b) TWR on the truth, H of the nominal model, updated from the runs, {t3 - t2:.1f} s", b)
    c = iterate_model_drive(truth, measured, frf_plant=nominal, max_iter=3, tol=ACCEPT, update_frf=False)
    _errors_table("(c) as (b) with H fixed (plain Fig. 21 scheme)", c)
    ok = a.converged and b.converged and b.n_iterations <= 10
    print(f"  [{'PASS' if ok else 'FAIL'}: (a) and (b) below {100 * ACCEPT:g} % rms within 10 iterations]")
    return {
        "model": variant, "damping": damping, "duration_s": duration_s,
        "linkage_stiffness_n_per_m": k_used, "linkage_mode_hz": f_new,
        "nominal_iterated": _iteration_figures(a), "truth_frf_updated": _iteration_figures(b),
        "truth_frf_fixed": _iteration_figures(c), "pass": ok,
    }


def _miss(r) -> float:
    """Median factor by which ratios miss 1 (``exp |log r|``)."""
    r = np.asarray(r, float)
    r = r[np.isfinite(r) & (r > 0)]
    return float(np.exp(np.median(np.abs(np.log(r))))) if r.size else math.nan


def acceptance(res, scenario: str) -> dict:
    """Issue 33's acceptance figures of a grid (see the module docstring)."""
    from exudyn_study.sweep.damage_grid import sensor_group

    models = list(dict.fromkeys(c.model for c in res.cells))
    dampings = set(c.damping for c in res.cells)
    out: dict = {"scenario": scenario}
    if scenario == "none":
        if 1 in models and "adams-default" in dampings:
            cells = [c for c in res.cells if c.model == 1 and c.damping == "adams-default"]
            dev = [float(np.max(np.abs(c.damage.ratios - 1.0))) for c in cells]
            out["model1_adams_default_max_deviation_pct"] = {
                c.signal: 100 * d for c, d in zip(cells, dev, strict=True)}
            out["pipeline_check_pass"] = bool(max(dev) <= 0.05)
        return out
    per_model = {}
    for m in models:
        entry = {}
        for d in ("adams-default", "step", "suggested", "diagnosed"):
            cells = [c for c in res.cells if c.model == m and c.damping == d]
            if not cells:
                continue
            all_r = np.concatenate([c.damage.ratios for c in cells])
            frame = np.concatenate([[ch.ratio for ch in c.damage.channels
                                     if sensor_group(ch.name) in ("tanks", "brackets")] for c in cells])
            entry[d] = {"median_pct": 100 * float(np.nanmedian(all_r)), "miss_factor": _miss(all_r),
                        "brackets_tanks_median_pct": (
                            100 * float(np.nanmedian(frame)) if frame.size else None),
                        "brackets_tanks_miss_factor": _miss(frame),
                        "within_50_200": {
                            c.signal: int(np.sum((c.damage.ratios >= 0.5) & (c.damage.ratios <= 2.0)))
                            for c in cells},
                        "sensors": int(cells[0].damage.ratios.size)}
        if "suggested" in entry and "adams-default" in entry:
            entry["suggested_closer_than_adams"] = (
                entry["suggested"]["miss_factor"] < entry["adams-default"]["miss_factor"])
        if "suggested" in entry and "step" in entry:
            entry["suggested_brackets_tanks_as_close_as_step"] = (
                entry["suggested"]["brackets_tanks_miss_factor"]
                <= entry["step"]["brackets_tanks_miss_factor"])
        if "diagnosed" in entry:
            entry["diagnosed_18_of_21"] = all(v >= 18 for v in entry["diagnosed"]["within_50_200"].values())
        per_model[str(m)] = entry
    out["models"] = per_model
    return out


def full_grid(measured_dir: str | None, out: Path, cache_dir=None, iterations: int = 5,
              scenario: str = "thesis", diagnosis: str | None = None, models=(1, 2, 3),
              tolerance: float = 0.05, target: str | None = None) -> dict:
    """Run the study grid (part 2); return its wall time, the summary per cell and the acceptance figures."""
    from exudyn_study.identify.model import read_modes_json
    from exudyn_study.sweep.damage_grid import measured_recordings, run_grid

    if measured_dir is None:
        from exudyn_study.virtual_rig import run_virtual_test

        measured_dir = str(out / "measured")
        Path(measured_dir).mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        run_virtual_test(scenario, ("white-noise", "test", "test-50"), measured_dir, cache_dir=cache_dir)
        print(f"\n== measured recordings: virtual rig {scenario!r} scenario, "
              f"{time.perf_counter() - t0:.1f} s "
              f"-> {measured_dir}")
    measured = measured_recordings(measured_dir)
    print(f"\n== full grid: Models {list(models)} x adams-default/step/suggested"
          f"{'/diagnosed' if diagnosis else ''} x {'/'.join(measured)}")
    t0 = time.perf_counter()
    res = run_grid(measured, models=models, out_dir=out, cache_dir=cache_dir, max_iter=iterations,
                   tol=tolerance, diagnosis=diagnosis,
                   target=None if target is None else read_modes_json(target),
                   progress=lambda s: print(f"  [{time.perf_counter() - t0:6.1f} s] {s}", flush=True))
    print()
    print(res.summary())
    print()
    print(res.pairing_report())
    print()
    print(res.reading())
    print(f"\n  grid wall time {res.wall_time_s:.1f} s for {len(res.cells)} cells; "
          f"{len(res.files)} files in {out}")
    # per model and damping: relative damage per z sensor for white noise (the thesis's Figs 22-24)
    signal = "white-noise" if "white-noise" in measured else next(iter(measured))
    names = res.cells[0].damage.names
    print(f"\n  relative pseudo damage (%), {signal}:")
    print("  " + f"{'sensor':<8}" + "".join(f"{f'M{c.model} {c.damping}':>22}" for c in res.cells
                                            if c.signal == signal))
    for n in names:
        print("  " + f"{n:<8}" + "".join(f"{100 * c.damage[n].ratio:22.1f}" for c in res.cells
                                         if c.signal == signal))
    cells = []
    for c in res.cells:
        r = 100 * c.damage.ratios
        r = r[np.isfinite(r)]
        cells.append({"model": c.model, "damping": c.damping, "signal": c.signal,
                      "control_error_pct": 100 * c.final_error, "converged": c.converged,
                      "relative_damage_median_pct": float(np.median(r)) if r.size else None,
                      "relative_damage_min_pct": float(r.min()) if r.size else None,
                      "relative_damage_max_pct": float(r.max()) if r.size else None,
                      "sensors_within_50_200_pct": int(np.sum((r >= 50) & (r <= 200))),
                      "sensors": int(r.size), "wall_s": c.wall_s})
    acc = acceptance(res, scenario)
    print("\n  acceptance (issue 33):")
    print("  " + json.dumps(acc, indent=1).replace("\n", "\n  "))
    pairing = {f"model{m}_{d}": {
        "paired": [{k: r[k] for k in ("frequency_hz", "damping_ratio", "target_frequency_hz",
                                      "target_damping_ratio", "mac")}
                   for r in cal["modes"] if r["target_frequency_hz"] is not None],
        "unpaired_targets": cal["unpaired_targets"]} for (m, d), cal in res.calibrations.items()}
    return {"wall_s": res.wall_time_s, "cells": cells, "acceptance": acc, "pairing": pairing,
            "reading": res.reading().splitlines()}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--measured-dir", default=None, help="measured recordings <name>_<signal>.h5")
    p.add_argument("--out", default=None, help="output directory (default: a temporary one)")
    p.add_argument("--model", type=int, default=1, help="model of the linkage acceptance (default 1)")
    p.add_argument("--damping", default="step", help="its damping (default step)")
    p.add_argument("--duration", type=float, default=80.0, help="its white-noise duration, s (default 80)")
    p.add_argument("--iterations", type=int, default=5, help="grid: max drive updates per cell (default 5)")
    p.add_argument("--scenario", default="thesis",
                   help="virtual-rig scenario of the measured recordings (thesis or none; default thesis)")
    p.add_argument("--diagnosis", default=None, help="rig diagnosis JSON: adds the 'diagnosed' column")
    p.add_argument("--models", type=int, nargs="+", default=[1, 2, 3], help="grid models (default 1 2 3)")
    p.add_argument("--tolerance", type=float, default=0.05,
                   help="grid: control rms error to stop the drive iteration at (default 0.05; damage goes "
                        "with the 5th power, so a 100 +- 5 %% check needs 0.01)")
    p.add_argument("--target", default=None,
                   help="target modes of the calibration (a modes JSON; default: the EMA of the white-noise "
                        "recording, identified in the run and written as calibration_target_modes.json)")
    p.add_argument("--skip-grid", action="store_true")
    p.add_argument("--skip-linkage", action="store_true")
    p.add_argument("--cache-dir", default=None)
    p.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = p.parse_args()
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    figures = {}
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="damage_grid_"))
    out.mkdir(parents=True, exist_ok=True)
    from exudyn_study.infra.blas import single_threaded_blas

    t0 = time.perf_counter()
    with single_threaded_blas():  # small dense algebra: one BLAS thread is faster on a loaded machine
        if not args.skip_linkage:
            figures["linkage"] = linkage_acceptance(args.model, args.damping, args.duration, args.cache_dir)
        if not args.skip_grid:
            figures["grid"] = full_grid(args.measured_dir, out, args.cache_dir, args.iterations,
                                        args.scenario, args.diagnosis, tuple(args.models), args.tolerance,
                                        args.target)
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")
    if not args.no_results:
        path = write_results('bench_damage_grid', figures, args=args, start=run, case=args.scenario)
        print(f"key figures {path}")


if __name__ == "__main__":
    main()
