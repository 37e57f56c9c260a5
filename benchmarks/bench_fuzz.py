"""Fuzz benchmark: every generated bad input, in process and in a fresh process, counted by class.

The cases are those of ``tests/fuzz_cases.py`` (ten defect classes, every subcommand). A case
is handled cleanly when the command exits with code 2, prints one line on stderr and no
traceback, leaves nothing behind and keeps every input byte-identical. The figures (cases
tried and handled cleanly, per class and in all, for each way of running, and the failures)
go to ``benchmarks/results/bench_fuzz.json``.

Run::

    PYTHONPATH=$PWD python3 benchmarks/bench_fuzz.py [--mode in-process|subprocess|both]

``--mode subprocess`` starts one Python process per case (what a user sees on a terminal),
``in-process`` calls ``exudyn_study.cli.main`` (what the default test run does). The package
that runs is the one first on ``PYTHONPATH``, so the same cases can be tried on another
checkout (``--case NAME`` names its result file).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def run(mode: str) -> dict:
    import fuzz_cases

    with tempfile.TemporaryDirectory(prefix="exudyn-study-fuzz-") as tmp:
        work = Path(tmp) / "work"
        work.mkdir()
        os.environ["EXUDYN_STUDY_CACHE"] = str(work / "cache")  # nothing may be built
        fuzz_cases.prepare(work)
        cases = fuzz_cases.cases(work)
        t0 = time.perf_counter()
        if mode == "in-process":
            outcomes = [fuzz_cases.run_in_process(c, work) for c in cases]
        else:
            env = dict(os.environ)
            outcomes = [fuzz_cases.run_in_subprocess(c, work, env) for c in cases]
        figures = fuzz_cases.tally(outcomes)
        figures["wall_s"] = time.perf_counter() - t0
        figures["slowest_case_s"] = max(o.wall_s for o in outcomes)
    return figures


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mode", choices=("in-process", "subprocess", "both"), default="both")
    ap.add_argument("--case", default=None, help="name of this run's result file (bench_fuzz--CASE.json)")
    ap.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    args = ap.parse_args()
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    start = start_run()
    modes = ("in-process", "subprocess") if args.mode == "both" else (args.mode,)
    figures = {}
    for mode in modes:
        figures[mode] = run(mode)
        f = figures[mode]
        print(f"{mode}: {f['clean']} of {f['tried']} bad inputs handled cleanly in {f['wall_s']:.1f} s")
        for klass, c in f["by_class"].items():
            print(f"  {klass:<18s} {c['clean']:>4d} / {c['tried']:<4d} ({', '.join(c['commands'])})")
            for failure in c["failures"][:10]:
                print(f"      {failure}")
    if not args.no_results:
        path = write_results("bench_fuzz", figures, args=args, case=args.case, start=start)
        print(f"key figures {path}")


if __name__ == "__main__":
    main()
