"""Run the points of a sweep on a local process pool or a Dask cluster; store the rows.

Execution
---------
- Local (default): :class:`concurrent.futures.ProcessPoolExecutor` with the ``spawn``
  start method and ``workers`` processes. BLAS/OpenMP thread pools of the workers are
  limited to one thread each (``OMP_NUM_THREADS=1`` etc., unless already set), so
  ``workers`` processes use ``workers`` cores. If a worker process dies (killed, out of
  memory, segfault) the pool is rebuilt and the unfinished points are resubmitted, each
  at most ``retries`` times.
- Dask: with a scheduler address, the same function runs through
  ``dask.distributed.Client(address).submit(..., retries=retries)``. Tasks of a worker
  that dies are rescheduled by the scheduler (``distributed.scheduler.allowed-failures``).
  Results are identical to the local pool: a point's outputs depend only on its
  parameters and seed.

Shared artefacts (e.g. reduced bodies) declared by the task (:attr:`Task.artefact`) are
built first, once per distinct artefact and in parallel; the points then hit the
on-disk cache. On a multi-machine cluster the cache directory must be shared
(``EXUDYN_STUDY_CACHE`` on a common file system).

Results
-------
``OUT/points/<point_id>.json``: one file per finished point, written to a temporary file
and renamed, so a kill at any moment loses at most the points still running. The table
files ``OUT/results.csv`` (and ``OUT/results.parquet`` when ``pyarrow`` is installed) are
rebuilt from the shards, also atomically, every few seconds and at the end. Each row:
``point_id, index``, every task parameter, ``seed, version, status`` (``ok`` or
``failed``), ``error, wall_s, worker`` and the task's outputs. ``OUT/manifest.json``
records the configuration. ``resume=True`` runs only the points without a shard.
"""

from __future__ import annotations

import contextlib
import csv
import json
import logging
import math
import os
import socket
import sys
import tempfile
import time
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from exudyn_study.errors import InputError
from exudyn_study.infra.workers import die_with_parent, single_threaded_workers
from exudyn_study.sweep.config import Point, SweepConfig, check_scheduler, expand_points
from exudyn_study.sweep.tasks import Task, TaskRegistry, get_task

__all__ = ["SweepResult", "run_sweep", "run_point", "read_rows", "summary_table", "BASE_COLUMNS"]

log = logging.getLogger(__name__)

#: Columns every row starts with (then the task parameters, then these, then the outputs)
BASE_COLUMNS = ("point_id", "index")
STATUS_COLUMNS = ("seed", "version", "status", "error", "wall_s", "worker")


@dataclass(frozen=True)
class SweepResult:
    """What :func:`run_sweep` did.

    Attributes
    ----------
    out_dir : Path
    rows : tuple of dict
        One row per point of the configuration that has a result, in point order.
    n_points : int
        Points in the configuration.
    n_run : int
        Points run by this call (the others were already done).
    n_failed : int
        Rows with status 'failed'.
    wall_s : float
        Wall time of this call (s).
    csv_path, parquet_path : Path or None
    """

    out_dir: Path
    rows: tuple[dict, ...]
    n_points: int
    n_run: int
    n_failed: int
    wall_s: float
    csv_path: Path
    parquet_path: Path | None


def _flatten(outputs: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for k, v in outputs.items():
        name = f"{prefix}{k}"
        if isinstance(v, Mapping):
            flat.update(_flatten(v, name + "."))
        else:
            if hasattr(v, "item") and getattr(v, "ndim", 1) == 0:
                v = v.item()  # NumPy scalar
            if not isinstance(v, (int, float, str, bool)) and v is not None:
                raise TypeError(f"output {name!r} is a {type(v).__name__}; expected a number, string or bool")
            flat[name] = v
    return flat


def run_point(function: Callable[..., Mapping[str, Any]], params: Mapping[str, Any], seed: int,
              point_id: str, index: int) -> dict[str, Any]:
    """Run one point; return its row (exceptions of the task become a 'failed' row).

    Parameters
    ----------
    function : callable
        The task function.
    params : mapping
        Task parameters.
    seed : int
    point_id : str
    index : int

    Returns
    -------
    dict
        The row (see the module notes).
    """
    from exudyn_study import __version__

    row: dict[str, Any] = {"point_id": point_id, "index": index, **params, "seed": seed,
                           "version": __version__, "status": "ok", "error": "", "wall_s": math.nan,
                           "worker": f"{socket.gethostname()}:{os.getpid()}"}
    t0 = time.perf_counter()
    try:
        outputs = _flatten(function(seed=seed, **params))
        clash = sorted(set(outputs) & set(row))
        if clash:
            raise ValueError(f"outputs {clash} clash with parameter/status columns")
        row.update(outputs)
    except Exception as exc:  # a failed point is a result, the sweep goes on
        row["status"] = "failed"
        row["error"] = f"{type(exc).__name__}: {exc}"
        log.debug("point %s failed:\n%s", point_id, traceback.format_exc())
    row["wall_s"] = time.perf_counter() - t0
    return row


def _build_artefact(builder: Callable, args: Sequence) -> None:
    builder(*args)


# ---------------------------------------------------------------------------------------
# result store
# ---------------------------------------------------------------------------------------


def _atomic_write_text(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def read_rows(out_dir: str | os.PathLike) -> dict[str, dict]:
    """All finished rows under ``out_dir/points``, by point id (temporary files ignored).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Output folder of the sweep; its rows are the JSON files in ``points/``.

    Returns
    -------
    dict of str to dict
        Result row of each finished point, keyed by point id; unreadable files and files that
        are not the row of their point are skipped with a warning.
    """
    rows = {}
    shard_dir = Path(out_dir) / "points"
    if not shard_dir.is_dir():
        return rows
    for path in shard_dir.glob("*.json"):
        try:
            row = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError) as exc:  # damaged or edited by hand
            log.warning("ignoring unreadable result %s (%s); the point will run again", path.name, exc)
            continue
        if not isinstance(row, dict) or row.get("point_id") != path.stem:
            log.warning("ignoring result %s: not a row of point %s; the point will run again", path.name,
                        path.stem)
            continue
        rows[row["point_id"]] = row
    return rows


class _Store:
    """Per-point JSON shards plus the consolidated table files."""

    def __init__(self, out_dir: Path, points: Sequence[Point], consolidate_every_s: float = 2.0) -> None:
        self.out_dir = out_dir
        self.shards = out_dir / "points"
        self.shards.mkdir(parents=True, exist_ok=True)
        for tmp in self.shards.glob("*.tmp"):  # left by a kill during a write
            tmp.unlink(missing_ok=True)
        self.points = points
        self.rows = read_rows(out_dir)
        self.every = consolidate_every_s
        self._last = 0.0
        self.csv_path = out_dir / "results.csv"
        self.parquet_path: Path | None = None

    def add(self, row: dict) -> None:
        _atomic_write_text(self.shards / f"{row['point_id']}.json", json.dumps(row))
        self.rows[row["point_id"]] = row
        if time.monotonic() - self._last >= self.every:
            self.consolidate()

    def ordered(self) -> list[dict]:
        return [self.rows[p.key] for p in self.points if p.key in self.rows]

    def consolidate(self) -> None:
        self._last = time.monotonic()
        rows = self.ordered()
        fields: list[str] = []
        for row in rows:
            fields.extend(k for k in row if k not in fields)
        buf = _StringWriter()
        writer = csv.DictWriter(buf, fieldnames=fields, extrasaction="raise")
        writer.writeheader()
        writer.writerows(rows)
        _atomic_write_text(self.csv_path, buf.text())
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:  # the CLI says so: results.csv only
            return
        columns = {f: _column([r.get(f) for r in rows]) for f in fields}
        path = self.out_dir / "results.parquet"
        fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=self.out_dir)
        os.close(fd)
        try:
            pq.write_table(pa.table(columns), tmp)
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            raise
        self.parquet_path = path


class _StringWriter:
    def __init__(self) -> None:
        self.parts: list[str] = []

    def write(self, s: str) -> None:
        self.parts.append(s)

    def text(self) -> str:
        return "".join(self.parts)


def _column(values: list) -> list:
    kinds = {type(v) for v in values if v is not None}
    if kinds <= {int, float} and float in kinds:
        return [None if v is None else float(v) for v in values]
    if len(kinds) > 1:  # e.g. mesh_size 'coarse' and 0.02 in one column
        return [None if v is None else str(v) for v in values]
    return values


# ---------------------------------------------------------------------------------------
# executors
# ---------------------------------------------------------------------------------------


def _failed_row(p: Point, message: str) -> dict:
    from exudyn_study import __version__

    return {"point_id": p.key, "index": p.index, **p.params, "seed": p.seed, "version": __version__,
            "status": "failed", "error": message, "wall_s": math.nan, "worker": ""}


def _run_local(task: Task, points: list[Point], artefacts: list[tuple], workers: int, retries: int,
               on_row: Callable[[dict], None]) -> None:
    pending = list(points)
    attempts: dict[str, int] = {}
    ctx = get_context("spawn")
    phase_artefacts = list(artefacts)
    with single_threaded_workers():
        while pending or phase_artefacts:
            executor = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=die_with_parent,
                                           initargs=(os.getpid(),))
            try:
                if phase_artefacts:
                    futs = [executor.submit(_build_artefact, b, a) for _, b, a in phase_artefacts]
                    phase_artefacts = []
                    for (key, _, _), fut in zip(artefacts, futs, strict=True):
                        try:
                            fut.result()
                        except Exception as exc:  # the points will report it
                            log.warning("shared artefact %s failed: %s", key, exc)
                    if any(f.exception() is not None and isinstance(f.exception(), BrokenProcessPool)
                           for f in futs):
                        continue
                futures = {executor.submit(run_point, task.function, dict(p.params), p.seed, p.key,
                                           p.index): p for p in pending}
                pending = []
                not_done = set(futures)
                while not_done:
                    done, not_done = wait(not_done, return_when=FIRST_COMPLETED)
                    for fut in done:
                        p = futures[fut]
                        try:
                            on_row(fut.result())
                        except BrokenProcessPool:
                            attempts[p.key] = attempts.get(p.key, 0) + 1
                            if attempts[p.key] > retries:
                                on_row(_failed_row(p, f"worker process died {attempts[p.key]} times"))
                            else:
                                pending.append(p)
                if pending:
                    log.warning("a worker process died; restarting the pool for %d point(s)", len(pending))
            except BaseException:
                executor.shutdown(wait=False, cancel_futures=True)
                raise
            executor.shutdown(wait=True)


def _run_dask(task: Task, points: list[Point], artefacts: list[tuple], address: str, retries: int,
              on_row: Callable[[dict], None]) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise InputError(
            "--scheduler needs dask.distributed; install it with pip install 'dask[distributed]'"
        ) from None
    import uuid

    run = uuid.uuid4().hex[:8]
    with Client(address, timeout="10s") as client:
        if artefacts:
            futs = [client.submit(_build_artefact, b, a, key=f"artefact-{run}-{i}", pure=False,
                                  retries=retries) for i, (_, b, a) in enumerate(artefacts)]
            for (key, _, _), fut in zip(artefacts, futs, strict=True):
                try:
                    fut.result()
                except Exception as exc:
                    log.warning("shared artefact %s failed: %s", key, exc)
                fut.release()
            del futs
        futures = {
            client.submit(run_point, task.function, dict(p.params), p.seed, p.key, p.index,
                          key=f"{task.name}-{p.key}-{run}", pure=False, retries=retries): p
            for p in points
        }
        pending = as_completed(list(futures))
        for fut in pending:
            p = futures.pop(fut)
            try:
                row = fut.result()
            except Exception as exc:  # KilledWorker after repeated worker deaths, lost scheduler
                row = _failed_row(p, f"{type(exc).__name__}: {exc}")
            on_row(row)
            # saved: release the result, so that a worker dying later does not make the
            # scheduler recompute a point whose row is already on disk
            fut.release()
            del fut


# ---------------------------------------------------------------------------------------
# the sweep
# ---------------------------------------------------------------------------------------


def _check_manifest(out_dir: Path, config: SweepConfig, resume: bool, n_done: int) -> None:
    manifest = out_dir / "manifest.json"
    if not resume and n_done:
        raise InputError(
            f"--out {str(out_dir)!r} already holds {n_done} result(s); pass --resume to complete "
            "that sweep or choose another --out"
        )
    if resume and manifest.exists():
        try:
            old = json.loads(manifest.read_text())
        except (OSError, ValueError):
            old = {}
        if old.get("task") not in (None, config.task):
            raise InputError(
                f"--resume: {str(out_dir)!r} holds a sweep of task {old.get('task')!r}, "
                f"the configuration runs {config.task!r}; choose another --out"
            )


def run_sweep(
    config: SweepConfig,
    out_dir: str | os.PathLike,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    resume: bool = False,
    retry_failed: bool = False,
    retries: int = 2,
    progress: bool = True,
    registry: TaskRegistry | None = None,
    consolidate_every_s: float = 2.0,
) -> SweepResult:
    """Run the points of ``config`` and store one row per point under ``out_dir``.

    Parameters
    ----------
    config : SweepConfig
        From :func:`~exudyn_study.sweep.config.load_config`.
    out_dir : path
        Result directory (created).
    scheduler : str, optional
        Dask scheduler address; default: local process pool.
    workers : int, optional
        Local worker processes (default ``os.cpu_count()``); ignored with ``scheduler``.
    resume : bool
        Run only the points without a result in ``out_dir``. Without it, a non-empty
        ``out_dir`` is an error.
    retry_failed : bool
        With ``resume``, also rerun points whose row says 'failed'.
    retries : int
        Resubmissions of a point whose worker died.
    progress : bool
        Show a progress bar with ETA (tqdm, on stderr).
    registry : TaskRegistry, optional
    consolidate_every_s : float
        Minimum interval between rewrites of the table files (s).

    Returns
    -------
    SweepResult

    Raises
    ------
    InputError
        Unreachable scheduler, ``workers < 1``, an ``out_dir`` that holds results without
        ``resume`` (checked before any task runs).
    """
    t_start = time.perf_counter()
    if scheduler is not None:
        scheduler = check_scheduler(scheduler)
    elif workers is None:
        workers = os.cpu_count() or 1
    if scheduler is None and (not isinstance(workers, int) or workers < 1):
        raise InputError(f"--workers {workers!r}: expected an integer >= 1")
    task = get_task(config.task, registry)
    points = list(expand_points(config, registry))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    done_before = read_rows(out)
    _check_manifest(out, config, resume, len(done_before))
    store = _Store(out, points, consolidate_every_s)
    _atomic_write_text(out / "manifest.json", json.dumps(
        {"config": config.as_dict(), "source": config.source, "task": config.task,
         "n_points": len(points), "point_ids": [p.key for p in points]}, indent=1, default=str))

    def needs_run(p: Point) -> bool:
        row = store.rows.get(p.key)
        return row is None or (retry_failed and row.get("status") != "ok")

    todo = [p for p in points if needs_run(p)]
    artefacts: dict[str, tuple] = {}
    if task.artefact is not None:
        for p in todo:
            spec = task.artefact(dict(p.params))
            if spec is not None:
                artefacts.setdefault(spec[0], spec)
    log.info("sweep %s: %d points, %d to run, %d shared artefact(s), %s", config.name, len(points),
             len(todo), len(artefacts), f"Dask at {scheduler}" if scheduler else f"{workers} local worker(s)")

    from tqdm.auto import tqdm

    from exudyn_study.infra.progress import keep_alive, progress_disabled

    bar = tqdm(total=len(points), initial=len(points) - len(todo), unit="pt", desc=config.name,
               disable=True if not progress else progress_disabled(), dynamic_ncols=True, file=sys.stderr)

    recorded: set[str] = set()

    def on_row(row: dict) -> None:
        if row["point_id"] in recorded:  # a second result of one point (a resubmission): keep the first
            log.warning("point %s returned twice; its first row is kept", row["point_id"])
            return
        recorded.add(row["point_id"])
        store.add(row)
        bar.update(1)
        if row["status"] != "ok":
            bar.write(f"point {row['index']} ({row['point_id']}) failed: {row['error']}")

    try:
        with keep_alive(bar):  # the clock runs while a point of minutes is computed
            if todo and scheduler is None:
                _run_local(task, todo, list(artefacts.values()), workers, retries, on_row)
            elif todo:
                _run_dask(task, todo, list(artefacts.values()), scheduler, retries, on_row)
    finally:
        bar.close()
        store.consolidate()
    rows = tuple(store.ordered())
    return SweepResult(
        out_dir=out, rows=rows, n_points=len(points), n_run=len(todo),
        n_failed=sum(r.get("status") != "ok" for r in rows), wall_s=time.perf_counter() - t_start,
        csv_path=store.csv_path, parquet_path=store.parquet_path,
    )


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.4g}"
    return str(v)


def summary_table(rows: Iterable[Mapping[str, Any]], config: SweepConfig, task: Task,
                  max_rows: int = 40) -> str:
    """Return a fixed-width text table: index, swept parameters, status, wall time, summary outputs.

    Parameters
    ----------
    rows : iterable of mapping
        Result rows, in the order to print.
    config : SweepConfig
        The sweep's configuration (its swept parameters give the columns).
    task : Task
        The sweep's task (its ``summary`` outputs give the columns).
    max_rows : int, default 40
        Number of rows printed; a last line counts the rows left out.

    Returns
    -------
    str
        The table, lines separated by newlines.
    """
    rows = list(rows)
    cols = ["index", *config.swept, "status", "wall_s", *task.summary]
    body = [[_fmt(r.get(c, "")) for c in cols] for r in rows[:max_rows]]
    widths = [max(len(c), *(len(b[i]) for b in body)) if body else len(c) for i, c in enumerate(cols)]
    lines = ["  ".join(c.rjust(w) for c, w in zip(cols, widths, strict=True))]
    lines += ["  ".join(v.rjust(w) for v, w in zip(b, widths, strict=True)) for b in body]
    if len(rows) > max_rows:
        lines.append(f"... {len(rows) - max_rows} more rows in results.csv")
    return "\n".join(lines)
