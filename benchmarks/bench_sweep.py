"""Speed-up of a local sweep: 2 worker processes against 1, CPU-bound tasks.

Each point is ``sleep_cpu``: a fixed amount of CPU time (``--cpu-s``) of NumPy work,
so the work does not shrink when the machine is busy. The wall time includes starting
the pool (spawn) and writing the results. The machine's load average is printed before
and after: other processes competing for the cores lower the speed-up.

    python benchmarks/bench_sweep.py [--points 16] [--cpu-s 1.0] [--repeat 1] [--no-results]

The wall times, cores obtained and speed-up per repetition go with date, commit and load to
``benchmarks/results/bench_sweep.json`` (``--no-results``: not written).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

from exudyn_study.sweep import parse_config, run_sweep


def config(points: int, cpu_s: float):
    return parse_config({"study": {"task": "sleep_cpu", "name": "bench", "settings": {"seconds": cpu_s}},
                         "parameters": {"seed": {"range": [0, points - 1]}}})


def timed(cfg, workers: int) -> tuple[float, list, float]:
    """Wall time, checksums, and the cores the sweep obtained (CPU s of the points / wall s)."""
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        result = run_sweep(cfg, out, workers=workers, progress=False)
        wall = time.perf_counter() - t0
    assert result.n_failed == 0
    return wall, [r["checksum"] for r in result.rows], sum(r["cpu_s"] for r in result.rows) / wall


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=16)
    parser.add_argument("--cpu-s", type=float, default=1.0, help="CPU seconds per point")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = parser.parse_args(argv)
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    run = start_run()
    reps = []
    cfg = config(args.points, args.cpu_s)
    print(f"cpus: {os.cpu_count()}, load average before: {os.getloadavg()}")
    print(f"{args.points} points x {args.cpu_s} CPU s of sleep_cpu")
    for rep in range(args.repeat):
        t1, c1, n1 = timed(cfg, 1)
        la1 = os.getloadavg()[0]
        t2, c2, n2 = timed(cfg, 2)
        la2 = os.getloadavg()[0]
        assert c1 == c2, "results differ between 1 and 2 workers"
        print(f"[{rep}] 1 worker: {t1:7.2f} s ({n1:.2f} cores obtained, load {la1:.1f})   "
              f"2 workers: {t2:7.2f} s ({n2:.2f} cores, load {la2:.1f})   speed-up {t1 / t2:.2f}x   "
              f"(ideal on an idle machine: {args.points * args.cpu_s:.1f} s / "
              f"{args.points * args.cpu_s / 2:.1f} s)")
        reps.append({"wall_1_worker_s": t1, "wall_2_workers_s": t2, "cores_obtained_1_worker": n1,
                     "cores_obtained_2_workers": n2, "speedup": t1 / t2, "load_1_worker": la1,
                     "load_2_workers": la2})
    print(f"load average after: {os.getloadavg()}")
    if not args.no_results:
        figures = {"points": args.points, "cpu_s_per_point": args.cpu_s,
                   "best_speedup": max(r["speedup"] for r in reps), "repetitions": reps}
        print(f"key figures {write_results('bench_sweep', figures, args=args, start=run)}")


if __name__ == "__main__":
    main()
