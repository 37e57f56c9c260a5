"""Sweeps that are killed: workers die with their parent, saved points are never computed again.

Each execution of a ``sleep_cpu`` point leaves a file ``<seed>.<pid>.<start ns>`` in a run
log; a point whose shard was saved at time t must have no execution that started after t,
whatever is killed (the sweep's main process, a Dask worker) and however often the sweep is
resumed. The kill tests take 10-40 s each (pool and cluster start-ups) and are marked slow.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from exudyn_study.errors import InputError
from exudyn_study.sweep import load_config, parse_config, run_sweep
from exudyn_study.sweep.engine import read_rows


def _executions(run_log: Path) -> dict[int, list[int]]:
    """Seed -> start times (ns) of its executions."""
    out: dict[int, list[int]] = {}
    for p in run_log.iterdir():
        seed, _, start = p.name.split(".")
        out.setdefault(int(seed), []).append(int(start))
    return out


def _saved_ns(out: Path) -> dict[int, int]:
    """Seed -> time (ns) its shard was written."""
    saved = {}
    for p in (out / "points").glob("*.json"):
        saved[json.loads(p.read_text())["seed"]] = p.stat().st_mtime_ns
    return saved


def _computed_after_saved(run_log: Path, out: Path) -> list[int]:
    saved = _saved_ns(out)
    return sorted(s for s, starts in _executions(run_log).items() if s in saved and max(starts) > saved[s])


def _config_file(tmp_path: Path, n: int, seconds: float, run_log: Path, pid_dir: Path | None = None) -> Path:
    cfg = tmp_path / "kill.toml"
    pid_line = f'pid_dir = "{pid_dir}"\n' if pid_dir else ""
    cfg.write_text(textwrap.dedent(f"""
        [study]
        task = "sleep_cpu"
        [study.settings]
        seconds = {seconds}
        run_log = "{run_log}"
        """) + pid_line + f"[parameters]\nseed = {{ range = [0, {n - 1}] }}\n")
    return cfg


def _wait_for(predicate, timeout_s: float, what: str, proc=None) -> None:
    t_end = time.monotonic() + timeout_s
    while not predicate():
        if proc is not None and proc.poll() is not None:
            raise AssertionError(f"{what}: the sweep ended early: {proc.stderr.read().decode()[-500:]}")
        assert time.monotonic() < t_end, f"{what}: not within {timeout_s} s"
        time.sleep(0.05)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie (dead, not yet reaped) counts as gone
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(") ", 1)[1][0] != "Z"
    except OSError:
        return False


def _children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (Linux /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().split(") ", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


# --------------------------------------------------------------------------- fast checks


def test_damaged_point_files_are_ignored_and_their_points_run_again(tmp_path):
    config = parse_config({"study": {"task": "sleep_cpu", "settings": {"seconds": 0.0}},
                           "parameters": {"seed": {"range": [0, 2]}}})
    first = run_sweep(config, tmp_path, workers=1, progress=False)
    shards = sorted((tmp_path / "points").glob("*.json"))
    shards[0].write_text("{}")
    shards[1].write_text("[1, 2]")
    result = run_sweep(config, tmp_path, workers=1, resume=True, progress=False)
    assert result.n_run == 2 and len(result.rows) == 3 and result.n_failed == 0
    assert [r["checksum"] for r in result.rows] == [r["checksum"] for r in first.rows]


def test_study_name_is_a_folder_name_and_imports_need_the_opt_in(tmp_path):
    cfg = tmp_path / "my sweep (copy).toml"
    cfg.write_text('[study]\ntask = "sleep_cpu"\nimports = ["json"]\n')
    with pytest.raises(InputError, match=r"pass --allow-imports"):
        load_config(cfg)
    config = load_config(cfg, allow_imports=True)
    assert config.name == "my_sweep__copy_"  # the file's stem, made a plain folder name
    for bad in ("../x", "/tmp/x", "a/b", ".hidden", ""):
        with pytest.raises(InputError, match="expected a folder name"):
            parse_config({"study": {"task": "sleep_cpu", "name": bad}})


def test_no_pyarrow_is_said_plainly(tmp_path, capsys, monkeypatch):
    import builtins

    from exudyn_study.cli import main

    real_import = builtins.__import__

    def no_pyarrow(name, *args, **kwargs):
        if name.startswith("pyarrow"):
            raise ImportError("no pyarrow here")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pyarrow)
    cfg = tmp_path / "s.toml"
    cfg.write_text('[study]\ntask = "sleep_cpu"\n[study.settings]\nseconds = 0.0\n')
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "out"), "--workers", "1", "--no-plot",
                 "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "results.parquet not written: pyarrow is not installed" in text
    assert not (tmp_path / "out" / "results.parquet").exists()
    assert (tmp_path / "out" / "summary.txt").is_file()
    assert not list((tmp_path / "out").glob(".exudyn-study-*"))


# --------------------------------------------------------------------------- kills


@pytest.mark.slow
def test_pool_workers_die_with_the_killed_sweep_and_resume_computes_each_point_once(tmp_path):
    run_log, pid_dir = tmp_path / "log", tmp_path / "pids"
    run_log.mkdir()
    pid_dir.mkdir()
    cfg = _config_file(tmp_path, 10, 0.4, run_log, pid_dir)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "exudyn_study.cli", "sweep", str(cfg), "--out", str(out),
                             "--workers", "2", "--quiet", "--no-plot"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _wait_for(lambda: len(list((out / "points").glob("*.json"))) >= 2 if (out / "points").is_dir() else False,
              120, "two points saved", proc)
    workers = [int(p.name) for p in pid_dir.iterdir()] + _children(proc.pid)  # + the resource tracker
    os.kill(proc.pid, signal.SIGKILL)  # the main process only: its workers must follow it
    proc.wait()
    _wait_for(lambda: not any(_alive(w) for w in workers), 15, f"workers {workers} ended")
    before = read_rows(out)
    assert 2 <= len(before) < 10
    result = run_sweep(load_config(cfg), out, workers=2, resume=True, progress=False)
    assert result.n_run == 10 - len(before) and len(result.rows) == 10 and result.n_failed == 0
    assert _computed_after_saved(run_log, out) == []
    assert all(read_rows(out)[k] == row for k, row in before.items())


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as c:
        yield c


@pytest.mark.slow
def test_a_killed_dask_worker_does_not_make_saved_points_run_again(tmp_path, cluster):
    import threading

    run_log = tmp_path / "log"
    run_log.mkdir()
    out = tmp_path / "out"
    config = parse_config({"study": {"task": "sleep_cpu", "settings": {"seconds": 0.3,
                                                                      "run_log": str(run_log)}},
                           "parameters": {"seed": {"range": [0, 15]}}})
    killed = []

    def kill_a_worker_after_saves():
        t_end = time.monotonic() + 120
        while time.monotonic() < t_end:
            if (out / "points").is_dir() and len(list((out / "points").glob("*.json"))) >= 6:
                # the worker that computed most of the saved points holds their results
                pids = [int(p.name.split(".")[1]) for p in run_log.iterdir()]
                pid = max(set(pids), key=pids.count)
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
            time.sleep(0.02)

    killer = threading.Thread(target=kill_a_worker_after_saves)
    killer.start()
    result = run_sweep(config, out, scheduler=cluster.scheduler_address, progress=False)
    killer.join()
    assert killed, "no worker was killed"
    assert result.n_failed == 0 and len(result.rows) == 16
    assert _computed_after_saved(run_log, out) == []
    executions = sum(len(v) for v in _executions(run_log).values())
    assert executions <= 16 + 2  # at most the points running on the killed worker ran twice


@pytest.mark.slow
def test_a_killed_dask_sweep_resumes_and_computes_each_point_once(tmp_path, cluster):
    run_log = tmp_path / "log"
    run_log.mkdir()
    cfg = _config_file(tmp_path, 10, 0.3, run_log)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "exudyn_study.cli", "sweep", str(cfg), "--out", str(out),
                             "--scheduler", cluster.scheduler_address, "--quiet", "--no-plot"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _wait_for(lambda: len(list((out / "points").glob("*.json"))) >= 2 if (out / "points").is_dir() else False,
              120, "two points saved", proc)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    before = read_rows(out)
    assert 2 <= len(before) < 10
    result = run_sweep(load_config(cfg), out, scheduler=cluster.scheduler_address, resume=True,
                       progress=False)
    assert result.n_run == 10 - len(before) and len(result.rows) == 10 and result.n_failed == 0
    assert _computed_after_saved(run_log, out) == []
    assert all(read_rows(out)[k] == row for k, row in before.items())
