"""Silence of a command as a user sees it: time to the first output and the longest silent gap.

The command runs under a pseudo-terminal (so tqdm bars are drawn as on a user's terminal) with
``PYTHONUNBUFFERED=1``; its stdout and stderr are read as bytes as they arrive, and every chunk's
arrival time is kept. A bar's ``\\r`` refresh counts as output: it is what tells the user the step
is alive. The figures are the time from the start to the first output, the longest gap between
two outputs (or between the last output and the end), and the line shown before that gap.
Acceptance (issue 32): first output within 5 s, never silent for more than 30 s.

    python benchmarks/bench_silence.py --case demo-empty-cache
    python benchmarks/bench_silence.py --case demo-virtual-rig
    python benchmarks/bench_silence.py --case study-model2 [--study-args --mesh coarse]
    python benchmarks/bench_silence.py --case custom --label generic -- python3 benchmarks/bench_x.py

Named cases: ``demo-empty-cache`` (the README's first command, ``exudyn-study demo --out DIR``,
with ``EXUDYN_STUDY_CACHE`` set to an empty temporary directory), ``demo-virtual-rig``
(``demo --virtual-rig``, with the user's cache unless ``--empty-cache``), and ``study-<name>``
for each ``studies/<name>.py`` (``study-damage_grid`` needs ``--measured-dir``, e.g. the
``virtual_rig`` folder a ``demo --virtual-rig`` wrote). ``--study-args`` passes options on to
the study (``--quick`` for ``sweep_damping``: the same stages with 20 s drives).

Writes ``benchmarks/results/bench_silence--<case>.json`` (``<case>-empty-cache`` with
``--empty-cache``; the figures, the five longest gaps
with the line before each, the exit code) and keeps the raw output in ``--log``.
"""

from __future__ import annotations

import argparse
import fcntl
import os
import pty
import re
import select
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import termios
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: acceptance of issue 32
FIRST_OUTPUT_LIMIT_S = 5.0
GAP_LIMIT_S = 30.0
#: terminal size given to the command (columns, rows)
TERMINAL = (120, 40)
_ANSI = re.compile(rb"\x1b\[[0-9;?]*[A-Za-z]")
STUDIES = sorted(p.stem for p in (ROOT / "studies").glob("*.py"))


@dataclass(frozen=True)
class Gap:
    """One silent stretch: its start (s after the command started), its length (s), the line before it."""

    start_s: float
    length_s: float
    line_before: str


def last_line(data: bytes) -> str:
    """Return the last non-empty line of terminal output without colour codes (``\\r`` ends a line too).

    Parameters
    ----------
    data : bytes
        Output so far.
    """
    text = _ANSI.sub(b"", data[-4000:]).decode("utf-8", errors="replace")
    for line in reversed(re.split(r"[\r\n]", text)):
        if line.strip():
            return line.strip()
    return ""


def silences(chunks: list[tuple[float, bytes]], end_s: float) -> tuple[float | None, list[Gap]]:
    """Return the time to the first output and the silent gaps of a run, longest first.

    Parameters
    ----------
    chunks : list of (float, bytes)
        Output chunks with their arrival time in s after the start, in order.
    end_s : float
        When the command ended (s after the start).

    Returns
    -------
    first_s : float or None
        Arrival of the first chunk with visible characters (None: no output).
    gaps : list of Gap
        Every stretch between two chunks, and from the last chunk to the end, longest first; the
        stretch before the first output is not a gap (it is ``first_s``).
    """
    seen = b""
    previous: float | None = None
    first: float | None = None
    gaps: list[Gap] = []
    for t, data in chunks:
        if first is None and not _ANSI.sub(b"", data).strip():
            seen += data
            continue
        if previous is not None:
            gaps.append(Gap(previous, t - previous, last_line(seen)))
        else:
            first = t
        seen += data
        previous = t
    if previous is not None:
        gaps.append(Gap(previous, end_s - previous, last_line(seen)))
    gaps.sort(key=lambda g: -g.length_s)
    return first, gaps


def run_captured(cmd: list[str], env: dict, log: Path, timeout_s: float) -> tuple[list, float, int | None]:
    """Run ``cmd`` under a pseudo-terminal, return ``(chunks, end_s, exit code)``; output also to ``log``.

    The exit code is None when the command was stopped at ``timeout_s``.
    """
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", TERMINAL[1], TERMINAL[0], 0, 0))
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=slave, stderr=slave, env=env, cwd=ROOT,
                            start_new_session=True)
    os.close(slave)
    chunks: list[tuple[float, bytes]] = []
    code: int | None = None
    with open(log, "wb") as fh:
        while True:
            if time.perf_counter() - t0 > timeout_s:
                os.killpg(proc.pid, signal.SIGTERM)
                proc.wait()
                break
            ready, _, _ = select.select([master], [], [], 0.5)
            if ready:
                try:
                    data = os.read(master, 65536)
                except OSError:  # the terminal closed: the command ended
                    data = b""
                if data:
                    chunks.append((time.perf_counter() - t0, data))
                    fh.write(data)
                    fh.flush()
                    continue
                code = proc.wait()
                break
            if proc.poll() is not None:
                code = proc.returncode
                break
    end = time.perf_counter() - t0
    os.close(master)
    return chunks, end, code


def command(case: str, args: argparse.Namespace, work: Path) -> tuple[list[str], dict]:
    """The command line and the environment additions of a case."""
    py = [sys.executable]
    extra: dict = {}
    if args.empty_cache or case == "demo-empty-cache":
        extra["EXUDYN_STUDY_CACHE"] = str(work / "cache")
    if case == "demo-empty-cache":
        return py + ["-m", "exudyn_study.cli", "demo", "--out", str(work / "demo")], extra
    if case == "demo-virtual-rig":
        return py + ["-m", "exudyn_study.cli", "demo", "--virtual-rig", "--out", str(work / "demo")], extra
    if case.startswith("study-") and case[6:] in STUDIES:
        name = case[6:]
        cmd = py + [str(ROOT / "studies" / f"{name}.py"), "--out", str(work / name)]
        if name == "damage_grid":
            if args.measured_dir is None:
                raise SystemExit("--case study-damage_grid: give --measured-dir (virtual test recordings)")
            cmd += ["--measured-dir", args.measured_dir]
        return cmd + list(args.study_args), extra
    if case == "custom":
        if not args.cmd:
            raise SystemExit("--case custom: give the command after '--'")
        return list(args.cmd), extra
    raise SystemExit(f"--case {case!r}: expected demo-empty-cache, demo-virtual-rig, custom or one of "
                     + ", ".join(f"study-{s}" for s in STUDIES))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--case", required=True, help="named command (see the module docstring)")
    parser.add_argument("--empty-cache", action="store_true",
                        help="run with an empty body cache (always for demo-empty-cache)")
    parser.add_argument("--measured-dir", default=None, help="recordings for study-damage_grid")
    parser.add_argument("--study-args", nargs=argparse.REMAINDER, default=[],
                        help="options passed on to the study script (last on the line)")
    parser.add_argument("--label", default=None,
                        help="result name of --case custom (bench_silence--custom-<label>.json)")
    parser.add_argument("--timeout", type=float, default=7200.0, help="stop the command after this many s")
    parser.add_argument("--log", default=None, help="raw output file (default: <work dir>/output.log)")
    parser.add_argument("--work-dir", default=None, help="output and cache folder (default: a temporary one)")
    parser.add_argument("--keep", action="store_true", help="keep the temporary work folder")
    parser.add_argument("--no-results", action="store_true", help="do not write benchmarks/results/*.json")
    parser.add_argument("cmd", nargs="*", help="the command of --case custom (after '--')")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from results import start_run, write_results  # benchmarks/results.py, beside this script

    work = Path(args.work_dir or tempfile.mkdtemp(prefix="bench_silence_"))
    work.mkdir(parents=True, exist_ok=True)
    cmd, extra = command(args.case, args, work)
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "PYTHONPATH": str(ROOT), **extra}
    env.pop("EXUDYN_STUDY_PROGRESS", None)  # as a user runs it: bars on because stderr is a terminal
    log = Path(args.log) if args.log else work / "output.log"
    run = start_run()
    print(f"{args.case}: {' '.join(cmd)}  (load {os.getloadavg()[0]:.2f}, log {log})", flush=True)
    chunks, end_s, code = run_captured(cmd, env, log, args.timeout)
    first_s, gaps = silences(chunks, end_s)
    longest = gaps[0] if gaps else Gap(0.0, 0.0, "")
    figures = {
        "command": [Path(c).name if c == sys.executable else c for c in cmd],
        "env": sorted(extra),
        "exit_code": code,
        "timed_out": code is None,
        "total_s": round(end_s, 1),
        "first_output_s": None if first_s is None else round(first_s, 2),
        "longest_gap_s": round(longest.length_s, 1),
        "longest_gap_at_s": round(longest.start_s, 1),
        "line_before_longest_gap": longest.line_before,
        "gaps_over_limit": sum(g.length_s > GAP_LIMIT_S for g in gaps),
        "longest_gaps": [{"at_s": round(g.start_s, 1), "length_s": round(g.length_s, 1),
                          "line_before": g.line_before} for g in gaps[:5]],
        "output_bytes": sum(len(c) for _, c in chunks),
        "first_output_ok": first_s is not None and first_s <= FIRST_OUTPUT_LIMIT_S,
        "gap_ok": longest.length_s <= GAP_LIMIT_S,
    }
    print(f"exit {code}, {end_s:.0f} s; first output after {figures['first_output_s']} s; longest silence "
          f"{longest.length_s:.1f} s at {longest.start_s:.0f} s after {longest.line_before!r}")
    for g in gaps[:5]:
        print(f"  {g.length_s:7.1f} s at {g.start_s:7.1f} s after {g.line_before[:100]!r}")
    if not args.no_results:
        case = args.case + ("-empty-cache" if args.empty_cache and args.case != "demo-empty-cache" else "")
        case += f"-{args.label}" if args.case == "custom" and args.label else ""
        print("wrote", write_results("bench_silence", figures, args=args, case=case, start=run))
    if args.work_dir is None and not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if figures["first_output_ok"] and figures["gap_ok"] and code == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
