"""Identification benchmark (issue 4 acceptance figures).

Synthetic base-excited test with the ten modes of thesis Table 1 on the 36 response
channels of the thesis (1 and 8-42), reference = base acceleration 'ARFVZ', 1000 Hz,
band-limited random base excitation 3-60 Hz, 2 % noise on every channel, FRFs at
0.2 Hz, band 3-50 Hz. For 80 s and 300 s records and the H1, H2 and Hv estimators:

- ours, fully automatic (PolyMAX orders 2-60, automatic selection, leakage-aware
  LSFD refinement), and the same with the leakage correction switched off;
- sdypy-EMA (LSCF, pol_order_high=60) on the same Hv FRFs, given the TRUE
  frequencies as its hand-picked starting values (its best case), with its default
  pole-search window (f_window=50 Hz) and a hand-tuned one (1 Hz).

Columns: found = true modes matched within 1 %; spur = reported modes matching no
true mode; NaN = NaN poles; dup = modes reported more than once (merged);
|df|, |dz| = largest relative error over the matched modes; MACmin = lowest MAC
with the true shape; wall = identification wall time (FRF estimation excluded,
given in the case name).

Seed sweep (``--sweep``): the same test for seeds 1..N (excitation and noise
realisations), per seed and estimator: number of modes, spurious modes, largest
|df|, |dz| and lowest MAC, for our default fit (coherence weights) and the
unweighted fit; then the *oracle*: the TRUE poles as starting values of the same
leakage-aware fit, whose spread over the seeds is the scatter the FRF data of that
record length support (mean and standard deviation of dz per mode).

Run:  python benchmarks/bench_identify.py   (needs the 'bench' extra: sdypy-EMA)
      python benchmarks/bench_identify.py --sweep --seeds 10 --durations 80
      (``--no-results``: do not write the result file)

The table's rows and the damping error per mode (comparison), or the worst case over the seeds
and the oracle scatter (sweep), go with date, commit and load to
``benchmarks/results/bench_identify.json`` (``bench_identify--sweep.json``).
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # small LAPACK calls: threads only hurt

import numpy as np  # noqa: E402

from exudyn_study.identify import (  # noqa: E402
    Leakage,
    estimate_frf,
    fit_modal_model,
    frf_weights,
    identify_frf,
    mac,
)
from exudyn_study.identify.synthetic import simulate, table1_system  # noqa: E402

BAND = (3.0, 50.0)


def _score(f_hat, z_hat, shapes, sysm):
    """Match identified modes to true ones (nearest frequency); return a row dict."""
    f_true, z_true = sysm.frequency_hz, sysm.damping_ratio
    f_hat = np.asarray(f_hat, float)
    ok = np.isfinite(f_hat)
    n_nan = int((~ok).sum())
    idx = [int(np.argmin(np.abs(f_true - f))) if np.isfinite(f) else -1 for f in f_hat]
    matched = sorted({i for i, f in zip(idx, f_hat, strict=True)
                      if i >= 0 and abs(f / f_true[i] - 1) < 0.01})
    spurious = sum(1 for i, f in zip(idx, f_hat, strict=True)
                   if i < 0 or abs(f / f_true[i] - 1) >= 0.01) - n_nan
    dup = len([i for i in idx if i >= 0]) - len({i for i in idx if i >= 0})
    df, dz, mm = [], [], []
    for k, (i, f, z) in enumerate(zip(idx, f_hat, z_hat, strict=True)):
        if i in matched and np.isfinite(f):
            df.append(abs(f / f_true[i] - 1))
            dz.append(abs(z / z_true[i] - 1))
            if shapes is not None:
                mm.append(mac(shapes[:, k], sysm.shapes[:, i])[0, 0])
    return {
        "found": len(matched), "spurious": max(spurious, 0), "nan": n_nan, "dup": dup,
        "df": 100 * max(df) if df else np.nan, "dz": 100 * max(dz) if dz else np.nan,
        "mac": min(mm) if mm else np.nan,
        "dz_modes": {f"{f_true[i]:.2f}": 100 * (z / z_true[i] - 1)
                     for i, f, z in zip(idx, f_hat, z_hat, strict=True) if i in matched},
    }


def _ours(frf, sysm, leakage, duration, weighting="coherence"):
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        res = identify_frf(frf, band_hz=BAND, leakage_correction=leakage, duration_s=duration,
                           weighting=weighting)
    wall = time.perf_counter() - t0
    row = _score(res.model.frequency_hz, res.model.damping_ratio,
                 res.model.shapes(sysm.names), sysm)
    row["wall"] = wall
    row["warn"] = [str(w.message) for w in caught]
    return row


def _sdypy(frf, sysm, f_window=50.0):
    from sdypy import EMA

    sel = frf.freq_hz <= BAND[1] + 1e-9
    t0 = time.perf_counter()
    m = EMA.Model(frf=frf.H[:, 0, sel], freq=frf.freq_hz[sel], lower=BAND[0], upper=BAND[1],
                  pol_order_high=60, frf_form="accelerance")
    m.get_poles(show_progress=False)
    # hand-picked starting frequencies: the true values (its best case)
    m.select_closest_poles(list(sysm.frequency_hz), f_window=f_window)
    note = ""
    try:
        _, a = m.get_constants(whose_poles="own")
        shapes = np.asarray(a)
        shapes = shapes if shapes.shape == (frf.H.shape[0], len(m.nat_freq)) else None
    except np.linalg.LinAlgError as exc:  # NaN poles make its LSFD fail
        shapes, note = None, f"LSFD failed: {exc}"
    wall = time.perf_counter() - t0
    row = _score(m.nat_freq, m.nat_xi, shapes, sysm)
    row["wall"] = wall
    row["note"] = note
    row["freqs"] = np.round(np.asarray(m.nat_freq, float), 3).tolist()
    return row


def _fmt(name, row):
    return (f"{name:<34s} {row['found']:>3d}/10 {row['spurious']:>4d} {row['nan']:>4d} "
            f"{row['dup']:>4d} {row['df']:>8.3f} {row['dz']:>8.2f} {row['mac']:>8.4f} "
            f"{row['wall']:>8.1f}")


def _figures(row: dict, **extra) -> dict:
    """The scored figures of one identification (see ``_score``), for the result file."""
    keys = {"found": "found", "spurious": "spurious", "nan": "nan_poles", "dup": "duplicates",
            "df": "max_df_pct", "dz": "max_dz_pct", "mac": "min_mac", "wall": "wall_s"}
    return {name: row[k] for k, name in keys.items()} | extra


def _oracle(frf, sysm, weighted):
    """Damping/frequency errors (%) of the leakage-aware fit started at the TRUE poles."""
    leak = Leakage(frf.sample_rate_hz, frf.n_segment, frf.window)
    fit = fit_modal_model(frf.H, frf.freq_hz, sysm.poles, band_hz=BAND, leakage=leak,
                          estimator=frf.estimator,
                          weights=frf_weights(frf) if weighted else None)
    return (100 * (fit.damping_ratio / sysm.damping_ratio - 1),
            100 * (fit.frequency_hz / sysm.frequency_hz - 1))


def sweep(durations, n_seeds, estimators=("H1", "H2", "Hv"), oracle=True) -> dict:
    """Seed sweep: per-seed figures, worst case, oracle scatter (see module notes); return the summary."""
    sysm = table1_system(n_channels=36)
    names = [f"{f:.2f}" for f in sysm.frequency_hz]
    summary = {}
    for duration in durations:
        per_duration = {"worst_case": {}, "oracle_damping_error_pct": {}}
        summary[f"{duration:g}s"] = per_duration
        rows = {}
        orc = {}
        print(f"\n=== seed sweep, {duration:g} s, 36 channels, Hv/H1/H2 at 0.2 Hz, seeds "
              f"1..{n_seeds} ===")
        print(f"{'case':<26s} {'seed':>4s} {'modes':>5s} {'spur':>4s} {'|df|max%':>8s} "
              f"{'|dz|max%':>8s} {'MACmin':>7s} {'wall s':>6s}  worst mode")
        for seed in range(1, n_seeds + 1):
            ref, resp = simulate(sysm, duration, noise=0.02, seed=seed)
            for est in estimators:
                frf = estimate_frf(ref, resp, 1000.0, resolution_hz=0.2, estimator=est,
                                   fmax_hz=60.0, outputs=sysm.names, inputs=("ARFVZ",))
                for wt in ("coherence", "none"):
                    r = _ours(frf, sysm, True, duration, weighting=wt)
                    n_modes = r["found"] + r["spurious"] + r["nan"]
                    worst = max(r["dz_modes"], key=lambda k: abs(r["dz_modes"][k]))
                    case = f"ours {est} {'weighted' if wt == 'coherence' else 'unweighted'}"
                    rows.setdefault(case, []).append(r)
                    print(f"{case:<26s} {seed:>4d} {n_modes:>5d} {r['spurious']:>4d} "
                          f"{r['df']:>8.3f} {r['dz']:>8.2f} {r['mac']:>7.4f} {r['wall']:>6.1f}"
                          f"  {worst} Hz {r['dz_modes'][worst]:+.1f} %", flush=True)
                if oracle:
                    for wt in (True, False):
                        orc.setdefault((est, wt), []).append(_oracle(frf, sysm, wt)[0])
        print(f"\nworst case over seeds 1..{n_seeds}, {duration:g} s:")
        for case, rs in rows.items():
            bad = [i + 1 for i, r in enumerate(rs) if r["found"] < 10 or r["spurious"] or r["dup"]]
            per_duration["worst_case"][case] = {
                "seeds_all_ten_no_spurious": len(rs) - len(bad), "seeds": len(rs), "failed_seeds": bad,
                "max_df_pct": float(np.nanmax([r["df"] for r in rs])),
                "max_dz_pct": float(np.nanmax([r["dz"] for r in rs])),
                "min_mac": float(np.nanmin([r["mac"] for r in rs])),
            }
            print(f"  {case:<26s} all ten, no spurious in {len(rs) - len(bad)}/{len(rs)} seeds"
                  f"{' (not: ' + str(bad) + ')' if bad else ''}; max |df| "
                  f"{np.nanmax([r['df'] for r in rs]):.3f} %, max |dz| "
                  f"{np.nanmax([r['dz'] for r in rs]):.2f} %, min MAC "
                  f"{np.nanmin([r['mac'] for r in rs]):.4f}")
        if oracle:
            print(f"\noracle (true poles as start) damping error per mode over seeds 1..{n_seeds}, "
                  f"{duration:g} s, % relative: mean / std / max|.|")
            print(f"{'fit':<22s}{'':>6s}" + "".join(f"{n:>7s}" for n in names))
            for (est, wt), vals in orc.items():
                a = np.array(vals)
                label = f"{est} {'weighted' if wt else 'unweighted'}"
                for stat, v in (("mean", a.mean(0)), ("std", a.std(0, ddof=1)),
                                ("max", np.abs(a).max(0))):
                    print(f"{label:<22s}{stat:>6s}" + "".join(f"{x:>7.1f}" for x in v))
                    per_duration["oracle_damping_error_pct"].setdefault(label, {})[stat] = dict(
                        zip(names, v.tolist(), strict=True))
    return summary


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--durations", type=float, nargs="+", default=[80.0, 300.0])
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--no-sdypy", action="store_true")
    ap.add_argument("--sweep", action="store_true", help="seed sweep instead of the comparison")
    ap.add_argument("--seeds", type=int, default=10, help="seeds 1..N of the sweep (default 10)")
    ap.add_argument("--estimators", nargs="+", default=["H1", "H2", "Hv"])
    ap.add_argument("--no-oracle", action="store_true")
    ap.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = ap.parse_args()
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    if args.sweep:
        figures = sweep(args.durations, args.seeds, tuple(args.estimators), oracle=not args.no_oracle)
        if not args.no_results:
            path = write_results("bench_identify", figures, args=args, case="sweep", start=run)
            print(f"key figures {path}")
        return
    table = {}
    sysm = table1_system(n_channels=36)
    print(__doc__.split("Run:")[0])
    hdr = (f"{'case':<34s} {'found':>6s} {'spur':>4s} {'NaN':>4s} {'dup':>4s} "
           f"{'|df|max%':>8s} {'|dz|max%':>8s} {'MACmin':>8s} {'wall s':>8s}")
    per_mode = []
    for duration in args.durations:
        ref, resp = simulate(sysm, duration, noise=0.02, seed=args.seed)
        print(f"\n=== {duration:g} s record, {resp.shape[0]} response channels ===")
        print(hdr)
        for est in ("H1", "H2", "Hv"):
            t0 = time.perf_counter()
            frf = estimate_frf(ref, resp, 1000.0, resolution_hz=0.2, estimator=est,
                               fmax_hz=60.0, outputs=sysm.names, inputs=("ARFVZ",))
            t_frf = time.perf_counter() - t0
            row = _ours(frf, sysm, True, duration)
            table[f"{duration:g}s ours {est}"] = _figures(row, wall_frf_s=t_frf)
            print(_fmt(f"ours {est} (FRF {t_frf:.1f} s)", row))
            per_mode.append((f"ours {est} {duration:g}s", row["dz_modes"]))
            row0 = _ours(frf, sysm, False, duration)
            table[f"{duration:g}s ours {est} no-leak"] = _figures(row0)
            print(_fmt(f"ours {est}, no leakage correction", row0))
            per_mode.append((f"ours {est} {duration:g}s no-leak", row0["dz_modes"]))
            if est == "Hv" and not args.no_sdypy:
                try:
                    for fw in (50.0, 1.0):  # its default search window, and a tuned one
                        rs = _sdypy(frf, sysm, fw)
                        table[f"{duration:g}s sdypy Hv fw={fw:g}"] = _figures(rs)
                        print(_fmt(f"sdypy-EMA Hv, f_window={fw:g} Hz", rs))
                        print(f"  sdypy-EMA frequencies: {rs['freqs']} {rs['note']}")
                        per_mode.append((f"sdypy Hv {duration:g}s fw={fw:g}", rs["dz_modes"]))
                except ImportError:
                    print("sdypy-EMA not installed: pip install 'exudyn_study[bench]'")
        print("warnings (ours Hv):", *row["warn"], sep="\n  ")
    print("\nDamping error per mode, % (relative):")
    names = [f"{f:.2f}" for f in sysm.frequency_hz]
    print(f"{'case':<30s}" + "".join(f"{n:>8s}" for n in names))
    for case, d in per_mode:
        print(f"{case:<30s}" + "".join(f"{d.get(n, np.nan):>8.1f}" for n in names))
    if not args.no_results:
        figures = {"seed": args.seed, "cases": table,
                   "damping_error_pct_per_mode": {case: {n: d.get(n) for n in names} for case, d in per_mode}}
        print(f"key figures {write_results('bench_identify', figures, args=args, start=run)}")


if __name__ == "__main__":
    main()
