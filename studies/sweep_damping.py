"""Thesis damping-function comparison as parameter sweeps (linear modal surrogate).

1. ``sweep_damping.toml``: damping function (Adams default, STEP, constant 2 %,
   calibrated = identified per-mode) x drive signal -> relative pseudo damage per z
   sensor; grouped bars per signal (``comparison/sweep.png``).
2. Sensitivity: the calibrated damping scaled by 0.25..4 (log grid) on the test signal
   -> relative pseudo damage per z sensor against the scale (``sensitivity/sweep.png``).

Model path: ``damping_sensitivity`` on the linear modal surrogate (thesis Table 1
modes), see :func:`exudyn_study.sweep.tasks.damping_sensitivity`.

    python studies/sweep_damping.py --out results/sweep_damping --workers 2 [--quick]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

HERE = Path(__file__).resolve().parent


def sensitivity_config(duration_s: float):
    from exudyn_study.sweep import parse_config

    return parse_config(
        {
            "study": {
                "name": "damping_scale_sensitivity",
                "task": "damping_sensitivity",
                "seed": 7,
                "settings": {"damping": "calibrated", "signal": "test", "duration_s": duration_s},
            },
            "parameters": {"damping_scale": {"logspace": [-0.60206, 0.60206, 9]}},  # 0.25 .. 4
        }
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/sweep_damping")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--quick", action="store_true", help="20 s drives (smoke test)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    print(f"sweep_damping: damping x signal, then the calibrated damping x 0.25-4, into {out}", flush=True)
    from exudyn_study.sweep import get_task, load_config, run_sweep
    from exudyn_study.sweep.engine import summary_table
    from exudyn_study.sweep.plots import save_sweep_plot

    comparison = load_config(HERE / "sweep_damping.toml")
    duration = 20.0 if args.quick else comparison.settings["duration_s"]
    if args.quick:
        comparison = dataclasses.replace(comparison, settings={**comparison.settings, "duration_s": duration})
    task = get_task("damping_sensitivity")
    for sub, config, x in ((("comparison"), comparison, "damping"),
                           ("sensitivity", sensitivity_config(duration), "damping_scale")):
        result = run_sweep(config, out / sub, workers=args.workers, resume=True, progress=True)
        table = summary_table(result.rows, config, task)
        (out / sub / "summary.txt").write_text(table + "\n")
        save_sweep_plot(result.rows, config, task, out / sub / "sweep.png", x=x)
        print(f"== {config.name} ({result.n_run} run, {result.wall_s:.1f} s)\n{table}\n")


if __name__ == "__main__":
    main()
