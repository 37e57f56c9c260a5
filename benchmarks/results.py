"""Result files of the benchmarks: a benchmark's key figures with the context they were measured in.

A benchmark calls :func:`start_run` when it starts and :func:`write_results` at its end::

    run = start_run()
    ...
    write_results("bench_sweep", {"speedup": 1.93}, args=args, start=run)

which writes ``benchmarks/results/<bench>.json`` (``<bench>--<case>.json`` when the run is one
case of several, e.g. one scenario and seed) atomically, holding the bench name, the UTC date and
time, the git commit (short hash, and whether tracked files had uncommitted changes), the machine
(cores, memory, Python and NumPy versions), the load average at the start and at the end, the
wall and CPU time, the command-line arguments and the figures. ``make_results_md.py`` turns all
result files into ``benchmarks/RESULTS.md``.

Measured figures live in these files, not in docstrings: a figure means something only with its
date, commit and load. The directory is ``benchmarks/results`` unless ``out_dir`` or the
environment variable ``EXUDYN_STUDY_RESULTS_DIR`` says otherwise.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

__all__ = ["RunStart", "start_run", "write_results", "result_path", "RESULTS_DIR"]

#: where result files go by default (next to this module)
RESULTS_DIR = Path(__file__).resolve().parent / "results"
#: environment variable that overrides :data:`RESULTS_DIR`
RESULTS_DIR_ENV = "EXUDYN_STUDY_RESULTS_DIR"
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


@dataclass(frozen=True)
class RunStart:
    """The state of the machine and the clocks when a benchmark started.

    Parameters
    ----------
    load : tuple of float or None
        1, 5 and 15 min load averages (None where the platform has none).
    wall : float
        ``time.perf_counter()`` in s.
    cpu : float
        CPU time in s of this process and its waited-for children (``os.times``).
    """

    load: tuple[float, float, float] | None
    wall: float
    cpu: float


def _load() -> tuple[float, float, float] | None:
    try:
        return tuple(round(v, 2) for v in os.getloadavg())
    except (OSError, AttributeError):
        return None


def _cpu_s() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def start_run() -> RunStart:
    """Return the load average and the clocks now, for :func:`write_results` at the end."""
    return RunStart(load=_load(), wall=time.perf_counter(), cpu=_cpu_s())


def _git(*cmd: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", *cmd], cwd=Path(__file__).resolve().parent, capture_output=True, text=True, timeout=20
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def _commit() -> dict:
    short = _git("rev-parse", "--short", "HEAD")
    status = _git("status", "--porcelain", "--untracked-files=no")
    return {"short": short, "dirty": None if status is None else bool(status)}


def _memory_bytes() -> int | None:
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return None


def _machine() -> dict:
    try:
        import numpy

        numpy_version = numpy.__version__
    except ImportError:
        numpy_version = None
    return {
        "cores": os.cpu_count(),
        "memory_gb": None if _memory_bytes() is None else round(_memory_bytes() / 2**30, 1),
        "python": platform.python_version(),
        "numpy": numpy_version,
        "platform": platform.platform(),
    }


def _jsonable(value):
    """Return ``value`` as plain JSON types (NumPy scalars and arrays, paths, tuples; NaN and inf as None)."""
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, set, frozenset)):
        return [_jsonable(v) for v in value]
    if isinstance(value, argparse.Namespace):
        return _jsonable(vars(value))
    if hasattr(value, "tolist") and callable(value.tolist):  # NumPy scalar or array
        return _jsonable(value.tolist())
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return str(value)


def _check_name(what: str, name: str) -> None:
    if not isinstance(name, str) or not _NAME.match(name):
        raise ValueError(
            f"{what} = {name!r}: expected letters, digits, '_', '.' or '-', starting with a letter or digit"
        )


def result_path(bench: str, case: str | None = None, out_dir: str | os.PathLike | None = None) -> Path:
    """Return the path of the result file of ``bench`` (and ``case``) in the results directory.

    Parameters
    ----------
    bench : str
        Benchmark name, e.g. ``"bench_sweep"``.
    case : str, optional
        One case of several the benchmark runs (``"thesis-seed0"``): ``<bench>--<case>.json``.
    out_dir : path, optional
        Results directory (default: ``$EXUDYN_STUDY_RESULTS_DIR`` or :data:`RESULTS_DIR`).

    Raises
    ------
    ValueError
        ``bench`` or ``case`` not a plain file-name token.
    """
    _check_name("bench", bench)
    if case is not None:
        _check_name("case", case)
    directory = Path(out_dir or os.environ.get(RESULTS_DIR_ENV) or RESULTS_DIR)
    return directory / (f"{bench}--{case}.json" if case is not None else f"{bench}.json")


def write_results(
    bench: str,
    figures: Mapping,
    *,
    args=None,
    out_dir: str | os.PathLike | None = None,
    case: str | None = None,
    start: RunStart | None = None,
    wall_s: float | None = None,
    cpu_s: float | None = None,
) -> Path:
    """Write a benchmark's figures and their context to ``<out_dir>/<bench>.json`` atomically.

    Parameters
    ----------
    bench : str
        Benchmark name (the script's name without ``.py``).
    figures : mapping
        The key figures, JSON-able after conversion (NumPy values become plain numbers, NaN and
        inf become null). Units in the keys (``wall_s``, ``error_db``).
    args : argparse.Namespace or mapping, optional
        The parsed command-line arguments; ``sys.argv[1:]`` is recorded too.
    out_dir : path, optional
        Results directory (default: ``$EXUDYN_STUDY_RESULTS_DIR`` or ``benchmarks/results``).
    case : str, optional
        One case of several (see :func:`result_path`).
    start : RunStart, optional
        From :func:`start_run` at the benchmark's start: the load average then, and the wall and
        CPU time since (unless ``wall_s``/``cpu_s`` are given).
    wall_s, cpu_s : float, optional
        Wall and CPU time of the benchmark in s.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ValueError
        ``bench`` or ``case`` not a plain file-name token, or ``figures`` not a mapping.
    """
    if not isinstance(figures, Mapping):
        raise ValueError(f"figures: {type(figures).__name__}; expected a mapping of figure names to values")
    path = result_path(bench, case, out_dir)
    if start is not None:
        wall_s = time.perf_counter() - start.wall if wall_s is None else wall_s
        cpu_s = _cpu_s() - start.cpu if cpu_s is None else cpu_s
    record = {
        "bench": bench,
        "case": case,
        "date_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "commit": _commit(),
        "machine": _machine(),
        "load_start": None if start is None else start.load,
        "load_end": _load(),
        "wall_s": wall_s,
        "cpu_s": cpu_s,
        "argv": sys.argv[1:],
        "args": args,
        "figures": figures,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(_jsonable(record), indent=1, allow_nan=False) + "\n"
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
