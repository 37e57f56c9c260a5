"""FRF accuracy of simulated recordings (issue #3): estimated FRFs vs the linearised model's.

An 80 s white-noise run (3-60 Hz) of a rig model is simulated, the drive -> acceleration FRFs
are estimated from the time data, and each channel's largest dB error against the
frequency-domain FRF of the linearised model (complex modal superposition) is taken in
3.5-59 Hz outside antiresonances and within 60 dB of the channel's peak
(:func:`exudyn_study.simulate.frf_db_error`). Estimators, in one run:

- Welch H1 (16 s Hann segments, 50 % overlap), raw;
- Welch H1 against the modal FRF seen through the same window (its expected value: the
  estimator's bias at peaks narrower than the resolution removed);
- the local rational method on one DFT of the whole record
  (:func:`exudyn_study.identify.lpm.estimate_frf_lpm`; no window, no leakage).

Methods: ``linear`` (exact discretisation; the drive given by its 1 kHz samples, as in every
simulation, reconstructed band-limited by :class:`exudyn_study.model.rig.Drive`: upsampled 8x,
cubic spline on the fine grid), ``linear-spline`` (the same 1 kHz samples through the plain cubic
spline, ``Drive(upsampling=1)``, for comparison: its acceleration is ~(w h)^2 / 12 off, 1.1 % at
58 Hz), ``linear-oversampled`` (the 4 kHz samples of the same band-limited signal,
output every 4th sample: what is left of the error is the estimator's), ``exudyn-reduced``
(Exudyn's integration of the linearisation, 1/8 ms).

Run:  python benchmarks/bench_frf.py [--model 1] [--method linear exudyn-reduced] [--duration 80] [--plot PNG]
      [--no-results]

Per method and estimator the channels within 1 dB, the median and largest error and the worst
channels go with date, commit and load to ``benchmarks/results/bench_frf--model<N>.json``
(``--no-results``: not written).
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", type=int, default=1, choices=(1, 2, 3))
    parser.add_argument(
        "--method",
        nargs="+",
        default=["linear", "linear-spline", "linear-oversampled"],
        choices=("linear", "linear-spline", "linear-oversampled", "exudyn-reduced"),
    )
    parser.add_argument("--duration", type=float, default=80.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--plot", help="PNG: FRF overlays (model, Welch H1, LRM) at ARFVZ, ARFVY and ARFHY")
    parser.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = parser.parse_args(argv)
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    figures = {"model": args.model, "duration_s": args.duration, "seed": args.seed, "methods": {}}

    from exudyn_study.identify.lpm import estimate_frf_lpm
    from exudyn_study.infra.blas import single_threaded_blas
    from exudyn_study.linear.response import frf_linear, frf_linear_at_resolution, simulate_linear
    from exudyn_study.model import build_model, linearise
    from exudyn_study.model.rig import Drive
    from exudyn_study.signals import DEFAULT_RMS_M, drive_signal
    from exudyn_study.simulate import IntegratorSettings, simulate_exudyn_reduced
    from exudyn_study.simulate.checks import estimate_frf, frf_db_error
    from exudyn_study.simulate.drive import _ramp as fade_in

    with single_threaded_blas():
        t0 = time.perf_counter()
        model = build_model(args.model, damping="adams-default", mesh_size="production")
        model.assemble()
        lin = linearise(model)
        print(
            f"Model {args.model}: build + linearise {time.perf_counter() - t0:.1f} s, "
            f"{lin.size} coordinates, "
            f"{len(lin.sensor_names)} sensors"
        )
        # the band-limited white noise generated at 4 kHz (periodic, FFT-shaped, faded in); the 1 kHz drive
        # is its every 4th sample, so both drive rates carry exactly the same signal
        fine = drive_signal("white-noise", args.duration, 4000.0, DEFAULT_RMS_M, args.seed)
        fine = fine * fade_in(fine.size, 4000.0, 0.25)
        x = fine[::4]
        model.drive.set_signal(x, 1000.0)
        overlays = {}
        for method in args.method:
            t0 = time.perf_counter()
            if method == "linear":
                y = simulate_linear(lin, model.drive)
            elif method == "linear-spline":
                # the plain cubic spline through the 1 kHz samples: a relative acceleration error of
                # ~(w h)^2 / 12 (1.1 % at 58 Hz)
                plain = Drive(upsampling=1)
                plain.set_signal(x, 1000.0)
                y = simulate_linear(lin, plain)
            elif method == "linear-oversampled":
                model.drive.set_signal(fine, 4000.0)
                y = simulate_linear(lin, model.drive)[:, ::4]
                model.drive.set_signal(x, 1000.0)
            else:
                y, _ = simulate_exudyn_reduced(lin, model.drive, IntegratorSettings(step_s=0.125e-3))
            n = min(y.shape[1], x.size)
            y, u = y[:, :n], x[:n]
            print(
                f"\n[{method}] {args.duration:.0f} s white noise simulated "
                f"in {time.perf_counter() - t0:.1f} s"
            )
            t_sim = time.perf_counter() - t0
            rows = []
            f, h1 = estimate_frf(u, y)
            rows.append(("Welch H1, raw", frf_db_error(h1, frf_linear(lin, f)[:, 0, :], f)))
            rows.append(("Welch H1 vs windowed model", frf_db_error(h1, frf_linear_at_resolution(lin, f), f)))
            t1 = time.perf_counter()
            lrm = estimate_frf_lpm(u, y, 1000.0, fmin_hz=3.4, fmax_hz=59.1, skip_s=1.0)
            rows.append(
                (
                    f"LRM ({time.perf_counter() - t1:.1f} s)",
                    frf_db_error(lrm.H[:, 0], frf_linear(lin, lrm.freq_hz)[:, 0, :], lrm.freq_hz),
                )
            )
            overlays[method] = (f, h1, lrm)
            figures["methods"][method] = {"wall_simulation_s": t_sim}
            for label, err in rows:
                worst = np.argsort(err)[::-1][:3]
                figures["methods"][method][label.split(" (")[0]] = {
                    "channels_within_1db": int(np.sum(err <= 1.0)), "channels": int(err.size),
                    "median_db": float(np.nanmedian(err)), "max_db": float(np.nanmax(err)),
                    "worst": {lin.sensor_names[i]: float(err[i]) for i in worst},
                }
                print(
                    f"  {label:30s} {int(np.sum(err <= 1.0)):2d}/{err.size} channels within 1 dB; "
                    f"median {np.nanmedian(err):.3f} dB, max {np.nanmax(err):.2f} dB; worst "
                    + ", ".join(f"{lin.sensor_names[i]} {err[i]:.2f}" for i in worst)
                )
        if args.plot:
            _plot(args.plot, lin, overlays, frf_linear)
            print(f"\nwrote {args.plot}")
    if not args.no_results:
        path = write_results("bench_frf", figures, args=args, case=f"model{args.model}", start=run)
        print(f"key figures {path}")
    return 0


def _plot(path, lin, overlays, frf_linear, channels=("ARFVZ", "ARFVY", "ARFHY")) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from exudyn_study.infra.atomic import atomic_write

    names = list(lin.sensor_names)
    fig, axes = plt.subplots(len(channels), 1, figsize=(10, 3.2 * len(channels)), sharex=True)
    for ax, ch in zip(axes, channels, strict=True):
        i = names.index(ch)
        first = next(iter(overlays.values()))
        fm = first[2].freq_hz
        ax.semilogy(fm, np.abs(frf_linear(lin, fm)[i, 0]), "k-", lw=2.2, label="linearised model")
        for method, (f, h1, lrm) in overlays.items():
            band = (f >= 3.4) & (f <= 59.1)
            ax.semilogy(f[band], np.abs(h1[i, band]), lw=0.8, alpha=0.8, label=f"{method}: Welch H1")
            ax.semilogy(lrm.freq_hz, np.abs(lrm.H[i, 0]), "--", lw=1.0, label=f"{method}: LRM")
        ax.set_ylabel(f"|{ch} / drive| (m/s^2)/m")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8, ncol=2)
    axes[-1].set_xlabel("frequency (Hz)")
    axes[0].set_title("Simulated FRFs vs the linearised model (80 s white noise)")
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"), "--plot")
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
