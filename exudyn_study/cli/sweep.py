"""``exudyn-study sweep CONFIG.toml``: run a parameter sweep (process pool or Dask).

Everything is validated before any task runs (configuration, scheduler address, output
directory). Results go to ``--out`` (default ``sweep-results/<config name>``):
``results.csv`` (+ ``results.parquet`` with pyarrow), ``points/`` (one JSON per finished
point), ``summary.txt`` and ``sweep.png``. Exit codes: 0 all points ok, 1 some points
failed, 2 bad input, 130 interrupted (rerun with ``--resume``).
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from exudyn_study.errors import InputError

__all__ = ["configure", "run"]

log = logging.getLogger(__name__)


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``exudyn-study sweep``."""
    parser.add_argument("config", help="sweep configuration (TOML, see exudyn_study.sweep.config)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler (tcp://host:port); default: local process pool")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="local worker processes (default: number of CPUs)")
    parser.add_argument("--out", metavar="DIR", help="result directory (default sweep-results/<name>)")
    parser.add_argument("--resume", action="store_true", help="run only the points missing from --out")
    parser.add_argument("--retry-failed", action="store_true", help="with --resume, rerun failed points too")
    parser.add_argument("--dry-run", action="store_true", help="validate and list the points, run nothing")
    parser.add_argument("--plot-x", metavar="PARAM", help="swept parameter on the plot's x axis")
    parser.add_argument("--no-plot", action="store_true", help="skip sweep.png")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    """Run the sweep; return the exit code."""
    from exudyn_study.sweep.config import check_scheduler, expand_points, load_config
    from exudyn_study.sweep.engine import run_sweep, summary_table
    from exudyn_study.sweep.tasks import get_task

    config = load_config(args.config)
    if args.scheduler:
        check_scheduler(args.scheduler)
        if args.workers is not None:
            log.warning("--workers is ignored with --scheduler (the cluster decides)")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers {args.workers}: expected an integer >= 1")
    task = get_task(config.task)
    points = expand_points(config)
    if args.plot_x is not None and args.plot_x not in config.swept:
        raise InputError(
            f"--plot-x {args.plot_x!r}: expected one of the swept parameters {list(config.swept)}"
        )
    out = Path(args.out) if args.out else Path("sweep-results") / config.name
    if args.dry_run:
        print(f"{config.name}: task {task.name}, {len(points)} point(s), mode {config.mode}")
        for p in points:
            swept = {k: p.params[k] for k in config.swept if k != "seed"}
            print(f"  {p.index:4d} {p.key} seed={p.seed} {swept}")
        return 0
    try:
        result = run_sweep(config, out, scheduler=args.scheduler,
                           workers=None if args.scheduler else args.workers, resume=args.resume,
                           retry_failed=args.retry_failed, progress=not args.no_progress)
    except KeyboardInterrupt:
        print(f"exudyn-study sweep: interrupted; finished points are kept in {out}; "
              "rerun with --resume to complete", file=sys.stderr)
        return 130
    table = summary_table(result.rows, config, task)
    (out / "summary.txt").write_text(table + "\n")
    print(table)
    print(f"{result.n_points} point(s): {result.n_points - result.n_failed} ok, {result.n_failed} failed; "
          f"ran {result.n_run} in {result.wall_s:.1f} s; results in {result.csv_path}"
          + (f" and {result.parquet_path.name}" if result.parquet_path else ""))
    if not args.no_plot:
        from exudyn_study.sweep.plots import save_sweep_plot

        try:
            save_sweep_plot(result.rows, config, task, out / "sweep.png", args.plot_x)
            print(f"plot: {out / 'sweep.png'}")
        except InputError as exc:
            log.warning("no plot: %s", exc)
    return 1 if result.n_failed else 0
