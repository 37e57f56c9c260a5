"""``exudyn-study sweep CONFIG.toml``: run a parameter sweep (process pool or Dask).

Everything is validated before any task runs (configuration, scheduler address, output
directory). Results go to ``--out`` (default ``sweep-results/<config name>``):
``results.csv`` (+ ``results.parquet`` when pyarrow is installed; the command says so when
it is not), ``points/`` (one JSON per finished point), ``summary.txt`` and ``sweep.png``
(both written atomically). ``[study] imports`` are imported only with ``--allow-imports``.
Exit codes: 0 all points ok, 1 some points failed, 2 bad input, 130 interrupted (rerun with
``--resume``).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

from exudyn_study.cli.options import Bounded, add_hidden_alias
from exudyn_study.errors import InputError

__all__ = ["configure", "run"]

log = logging.getLogger(__name__)

WORKERS = Bounded(int, 1, 1024, "", "a count of local worker processes")


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``exudyn-study sweep``."""
    parser.add_argument("config", help="sweep configuration (TOML, see exudyn_study.sweep.config)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler (tcp://host:port); default: local process pool")
    parser.add_argument("--workers", type=WORKERS, metavar="N",
                        help="local worker processes (default: number of CPUs)")
    parser.add_argument("--out", metavar="DIR",
                        help="result directory, created when missing (default sweep-results/<name>)")
    parser.add_argument("--cache-dir", default=None, metavar="DIR",
                        help="flexible-body and virtual-recording cache of the local workers (default: "
                             "$EXUDYN_STUDY_CACHE or ~/.cache/exudyn_study; Dask workers use their own "
                             "environment)")
    parser.add_argument("--allow-imports", action="store_true",
                        help="import the modules listed in the configuration's [study] imports (they run "
                             "code: only for configurations you trust)")
    parser.add_argument("--resume", action="store_true", help="run only the points missing from --out")
    parser.add_argument("--retry-failed", action="store_true", help="with --resume, rerun failed points too")
    parser.add_argument("--dry-run", action="store_true", help="validate and list the points, run nothing")
    parser.add_argument("--plot-x", metavar="PARAM",
                        help="swept parameter on the plot's x axis (default: the first swept numeric one)")
    parser.add_argument("--no-plot", action="store_true", help="skip sweep.png")
    add_hidden_alias(parser, "--no-progress", "quiet", action="store_true")  # the one name is --quiet


def run(args: argparse.Namespace) -> int:
    """Run the sweep; return the exit code."""
    from exudyn_study.infra.files import OutputSet, nearest_existing_dir
    from exudyn_study.sweep.config import check_scheduler, expand_points, load_config
    from exudyn_study.sweep.engine import run_sweep, summary_table
    from exudyn_study.sweep.tasks import get_task

    config = load_config(args.config, allow_imports=args.allow_imports)
    if args.scheduler:
        check_scheduler(args.scheduler)
        if args.workers is not None:
            log.warning("--workers is ignored with --scheduler (the cluster decides)")
    task = get_task(config.task)
    points = expand_points(config)
    if args.plot_x is not None and args.plot_x not in config.swept:
        raise InputError(
            f"--plot-x {args.plot_x!r}: expected one of the swept parameters {list(config.swept)}"
        )
    out = Path(args.out) if args.out else Path("sweep-results") / config.name
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {str(out)!r} is a file; expected a result directory (created when missing)")
    nearest_existing_dir(out, "--out")
    if args.cache_dir is not None:
        from exudyn_study.infra.cache import cache_dir

        cache_dir(args.cache_dir)  # a file in the way or not writable: refused now
    if args.dry_run:
        print(f"{config.name}: task {task.name}, {len(points)} point(s), mode {config.mode}")
        for p in points:
            swept = {k: p.params[k] for k in config.swept if k != "seed"}
            print(f"  {p.index:4d} {p.key} seed={p.seed} {swept}")
        return 0
    with OutputSet(inputs={"CONFIG": args.config}) as outputs:
        summary_path = outputs.file(out / "summary.txt", "--out")  # checks --out is writable, up front
        plot_path = None if args.no_plot else outputs.file(out / "sweep.png", "--out")
        saved_cache = os.environ.get("EXUDYN_STUDY_CACHE")
        if args.cache_dir is not None:  # the spawned local workers inherit the environment
            os.environ["EXUDYN_STUDY_CACHE"] = str(Path(args.cache_dir).resolve())
        try:
            result = run_sweep(config, out, scheduler=args.scheduler,
                               workers=None if args.scheduler else args.workers, resume=args.resume,
                               retry_failed=args.retry_failed, progress=not args.quiet)
        except KeyboardInterrupt:
            print(f"exudyn-study sweep: interrupted; finished points are kept in {out}; "
                  "rerun with --resume to complete", file=sys.stderr)
            return 130
        finally:
            if saved_cache is None:
                os.environ.pop("EXUDYN_STUDY_CACHE", None)
            else:
                os.environ["EXUDYN_STUDY_CACHE"] = saved_cache
        table = summary_table(result.rows, config, task)
        summary_path.write_text(table + "\n", encoding="utf-8")
        if plot_path is not None:
            from exudyn_study.sweep.plots import save_sweep_plot

            try:
                save_sweep_plot(result.rows, config, task, plot_path, args.plot_x)
            except InputError as exc:
                log.warning("no plot: %s", exc)
                plot_path = None
    print(table)
    print(f"{result.n_points} point(s): {result.n_points - result.n_failed} ok, {result.n_failed} failed; "
          f"ran {result.n_run} in {result.wall_s:.1f} s; results in {result.csv_path}"
          + (f" and {result.parquet_path.name}" if result.parquet_path else ""))
    if result.parquet_path is None:
        print("results.parquet not written: pyarrow is not installed (pip install pyarrow); "
              "results.csv holds the same table")
    if plot_path is not None:
        print(f"plot: {out / 'sweep.png'}")
    return 1 if result.n_failed else 0
