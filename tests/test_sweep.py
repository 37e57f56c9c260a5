"""Sweeps: configuration checks, point expansion, process pool vs Dask, kill and resume."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from exudyn_study.errors import InputError
from exudyn_study.sweep import expand_points, load_config, parse_config, run_sweep
from exudyn_study.sweep.config import check_scheduler, point_key
from exudyn_study.sweep.engine import read_rows, run_point
from exudyn_study.sweep.tasks import sleep_cpu

#: columns that legitimately differ between two runs of the same point
RUN_COLUMNS = {"wall_s", "worker", "cpu_s"}


def _config(task="sleep_cpu", settings=None, parameters=None, **study):
    return parse_config({"study": {"task": task, "settings": settings or {}, **study},
                         "parameters": parameters or {}})


def _comparable(rows):
    return [{k: v for k, v in r.items() if k not in RUN_COLUMNS} for r in rows]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "data, match",
    [
        ({"study": {"task": "sleep_cpu"}, "parameters": {"secnds": {"values": [1.0]}}},
         r"parameters\.secnds: unknown parameter of task 'sleep_cpu'; did you mean seconds"),
        ({"study": {"task": "sleep_cpu", "settings": {"sizes": 3}}},
         r"study\.settings\.sizes: unknown parameter"),
        ({"study": {"task": "sleep_cpu"}, "parameters": {"seconds": {"linspace": [0.1, 1.0, 0]}}},
         r"parameters\.seconds\.linspace = \[0\.1, 1\.0, 0\]: empty range"),
        ({"study": {"task": "sleep_cpu"}, "parameters": {"size": {"range": [10, 2]}}},
         r"parameters\.size\.range = \[10, 2\]: empty range"),
        ({"study": {"task": "sleep_cpu"}, "parameters": {"size": {"values": []}}},
         r"parameters\.size\.values = \[\]: empty list"),
        ({"study": {"task": "damping_sensitivity", "settings": {"model": "model-7"}}},
         r"study\.settings\.model = 'model-7' is unknown; expected one of \['modal-table1', 'rig-1'"),
        ({"study": {"task": "damping_sensitivity"}, "parameters": {"damping": {"values": ["adams", "step"]}}},
         r"parameters\.damping\.values = 'adams' is unknown"),
        ({"study": {"task": "no_such_task"}}, r"study\.task = 'no_such_task' is unknown; registered tasks"),
        ({"study": {"task": "sleep_cpu"}, "parameters": {"seconds": {"values": [-1.0]}}},
         r"parameters\.seconds\.values = -1\.0 is out of bounds"),
        ({"study": {"task": "sleep_cpu"}, "parameters": {"size": {"linspace": [1, 5, 3]}}},
         r"size is int; use values"),
        ({"study": {"task": "sleep_cpu", "settings": {"seconds": 0.1}},
          "parameters": {"seconds": {"values": [0.2]}}}, r"parameters\.seconds: also set in study\.settings"),
        ({"study": {"task": "sleep_cpu", "mode": "random"}}, r"study\.samples: random mode needs"),
        ({"study": {"task": "sleep_cpu", "mode": "latin"}}, r"study\.mode = 'latin'"),
        ({"parameters": {}}, r"missing \[study\]"),
        ({"study": {"task": "sleep_cpu"}, "parameters": {"size": {"values": [3, 3]}}}, r"value 3 repeats"),
    ],
)
def test_bad_configuration_is_one_clear_line(data, match):
    with pytest.raises(InputError, match=match) as info:
        parse_config(data)
    assert "\n" not in str(info.value)


def test_unreachable_scheduler_is_reported_before_anything_runs(tmp_path):
    port = _free_port()  # bound then released: nothing listens there
    with pytest.raises(InputError, match=rf"--scheduler 'tcp://127.0.0.1:{port}': no scheduler reachable"):
        check_scheduler(f"tcp://127.0.0.1:{port}", timeout_s=1.0)
    with pytest.raises(InputError, match="no scheduler reachable"):
        run_sweep(_config(), tmp_path / "out", scheduler=f"127.0.0.1:{port}")
    assert not (tmp_path / "out").exists()
    with pytest.raises(InputError, match="expected tcp://HOST:PORT"):
        check_scheduler("http://somewhere")


def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys):
    from exudyn_study.cli import main

    cfg = tmp_path / "bad.toml"
    cfg.write_text('[study]\ntask = "damping_sensitivity"\n[parameters]\nzeta = { values = [0.1] }\n')
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"exudyn-study sweep: error: sweep configuration {str(cfg)!r}: parameters.zeta: "
                          "unknown parameter")
    assert len(err.splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_toml_file_and_syntax_error(tmp_path):
    good = tmp_path / "s.toml"
    good.write_text("[study]\ntask = 'sleep_cpu'\nseed = 4\n[parameters]\nsize = { range = [1, 5, 2] }\n")
    config = load_config(good)
    assert config.name == "s" and config.seed == 4
    assert [p.params["size"] for p in expand_points(config)] == [1, 3, 5]
    bad = tmp_path / "b.toml"
    bad.write_text("[study\n")
    with pytest.raises(InputError, match="TOML syntax error"):
        load_config(bad)


# --------------------------------------------------------------------------- expansion


def test_grid_is_the_cartesian_product_last_parameter_fastest():
    config = _config(parameters={"size": {"values": [10, 20]}, "seconds": {"linspace": [0.0, 1.0, 3]},
                                 "seed": {"range": [0, 1]}})
    points = expand_points(config)
    assert len(points) == 2 * 3 * 2
    assert [(p.params["size"], p.params["seconds"], p.seed) for p in points[:4]] == [
        (10, 0.0, 0), (10, 0.0, 1), (10, 0.5, 0), (10, 0.5, 1)]
    assert len({p.key for p in points}) == len(points)
    assert points[0].params["pid_dir"] == ""  # defaults are part of every point
    assert points[0].key == point_key("sleep_cpu", points[0].params, 0)


def test_logspace_values():
    config = _config("damping_sensitivity", parameters={"damping_scale": {"logspace": [-1, 1, 3]}})
    assert [p.params["damping_scale"] for p in expand_points(config)] == pytest.approx([0.1, 1.0, 10.0])


def test_random_sampling_is_seeded_and_within_the_ranges():
    params = {"seconds": {"linspace": [0.1, 0.2, 2]}, "size": {"values": [5, 6, 7]},
              "damping": None}
    del params["damping"]
    a = expand_points(_config(parameters=params, mode="random", samples=25, seed=11))
    b = expand_points(_config(parameters=params, mode="random", samples=25, seed=11))
    c = expand_points(_config(parameters=params, mode="random", samples=25, seed=12))
    assert [p.key for p in a] == [p.key for p in b] != [p.key for p in c]
    assert len(a) == 25  # continuous values: no duplicates
    assert all(0.1 <= p.params["seconds"] <= 0.2 and p.params["size"] in (5, 6, 7) for p in a)
    logs = expand_points(_config("damping_sensitivity",
                                 parameters={"damping_scale": {"logspace": [-1, 1, 2]}},
                                 mode="random", samples=200, seed=1))
    values = [p.params["damping_scale"] for p in logs]
    assert min(values) >= 0.1 and max(values) <= 10 and sum(v < 1 for v in values) > 60  # log-uniform


def test_run_point_records_failures_as_rows():
    row = run_point(sleep_cpu, {"seconds": 0.0, "size": 10, "pid_dir": "", "fail": True}, 3, "abc", 0)
    assert row["status"] == "failed" and row["error"] == "RuntimeError: sleep_cpu asked to fail"
    assert row["seed"] == 3 and row["version"]
    ok = run_point(sleep_cpu, {"seconds": 0.0, "size": 10, "pid_dir": "", "fail": False}, 3, "abc", 0)
    assert ok["status"] == "ok" and ok["checksum"] == sleep_cpu(seed=3, seconds=0.0, size=10)["checksum"]


# --------------------------------------------------------------------------- execution

DAMPING_POINTS = {"damping": {"values": ["adams-default", "step", "calibrated"]}}
DAMPING_SETTINGS = {"duration_s": 4.0, "sample_rate_hz": 256.0}


@pytest.fixture(scope="module")
def pool_rows(tmp_path_factory):
    config = _config("damping_sensitivity", DAMPING_SETTINGS, DAMPING_POINTS, seed=5)
    out = tmp_path_factory.mktemp("pool")
    result = run_sweep(config, out, workers=2, progress=False)
    return config, out, result


def test_process_pool_sweep_writes_one_row_per_point(pool_rows):
    config, out, result = pool_rows
    assert result.n_points == result.n_run == 3 and result.n_failed == 0
    rows = result.rows
    assert [r["damping"] for r in rows] == ["adams-default", "step", "calibrated"]
    calibrated = rows[2]
    assert calibrated["rpd_mean"] == pytest.approx(1.0, rel=1e-9)  # identified damping = reference
    assert rows[0]["rpd_mean"] > 1.0 > rows[1]["rpd_mean"]  # Adams default: less damping; STEP: more
    lines = (out / "results.csv").read_text().splitlines()
    assert len(lines) == 4 and lines[0].startswith("point_id,index,model,signal,damping")
    for column in ("seed", "version", "status", "wall_s", "rpd.ARFMZ"):
        assert column in lines[0].split(",")
    if result.parquet_path is not None:
        import pyarrow.parquet as pq

        assert pq.read_table(result.parquet_path).num_rows == 3
    assert json.loads((out / "manifest.json").read_text())["n_points"] == 3


def test_rerun_without_resume_refuses_and_resume_runs_nothing(pool_rows):
    config, out, _ = pool_rows
    with pytest.raises(InputError, match="already holds 3 result"):
        run_sweep(config, out, workers=1, progress=False)
    again = run_sweep(config, out, workers=1, resume=True, progress=False)
    assert again.n_run == 0 and len(again.rows) == 3


@pytest.fixture(scope="module")
def dask_cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        yield cluster


def test_dask_cluster_gives_results_identical_to_the_process_pool(pool_rows, dask_cluster, tmp_path):
    config, _, pool = pool_rows
    result = run_sweep(config, tmp_path, scheduler=dask_cluster.scheduler_address, progress=False)
    assert result.n_failed == 0
    assert _comparable(result.rows) == _comparable(pool.rows)  # exact equality, every output


def _kill_first_worker(pid_dir: Path, killed: list, timeout_s: float = 60.0) -> None:
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        pids = sorted(pid_dir.iterdir())
        if pids:
            pid = int(pids[0].name)
            time.sleep(0.1)
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
            return
        time.sleep(0.02)


def _killed_worker_sweep(tmp_path, **run_kwargs):
    pid_dir = tmp_path / "pids"
    pid_dir.mkdir()
    config = _config(settings={"seconds": 0.3, "pid_dir": str(pid_dir)},
                     parameters={"seed": {"range": [0, 3]}})
    killed: list[int] = []
    killer = threading.Thread(target=_kill_first_worker, args=(pid_dir, killed))
    killer.start()
    result = run_sweep(config, tmp_path / "out", progress=False, **run_kwargs)
    killer.join()
    return killed, result


@pytest.mark.slow  # ~20 s on the shared 2-core machine: two pool start-ups
def test_a_killed_pool_worker_does_not_stop_the_sweep(tmp_path):
    killed, result = _killed_worker_sweep(tmp_path, workers=2)
    assert killed, "no worker was killed"
    assert result.n_failed == 0 and len(result.rows) == 4
    assert all(not r["worker"].endswith(f":{killed[0]}") for r in result.rows)


def test_a_killed_dask_worker_does_not_stop_the_sweep(tmp_path, dask_cluster):
    killed, result = _killed_worker_sweep(tmp_path, scheduler=dask_cluster.scheduler_address)
    assert killed, "no worker was killed"
    assert result.n_failed == 0 and len(result.rows) == 4
    assert all(not r["worker"].endswith(f":{killed[0]}") for r in result.rows)


def test_resume_runs_only_the_missing_points(tmp_path, dask_cluster):
    """Cheap version of the kill test below: an interrupted sweep is a subset of shards."""
    first = _config(settings={"seconds": 0.0}, parameters={"seed": {"range": [0, 2]}})
    full = _config(settings={"seconds": 0.0}, parameters={"seed": {"range": [0, 5]}})
    address = dask_cluster.scheduler_address
    run_sweep(first, tmp_path, scheduler=address, progress=False)
    before = read_rows(tmp_path)
    result = run_sweep(full, tmp_path, scheduler=address, resume=True, progress=False)
    assert (result.n_run, len(result.rows)) == (3, 6)
    after = read_rows(tmp_path)
    assert all(after[k] == row for k, row in before.items())


@pytest.mark.slow  # ~30 s on the shared 2-core machine: CLI subprocess, kill, resume
def test_kill_the_sweep_midway_then_resume_runs_only_the_missing_points(tmp_path):
    cfg = tmp_path / "kill.toml"
    cfg.write_text(textwrap.dedent("""
        [study]
        task = "sleep_cpu"
        [study.settings]
        seconds = 0.25
        [parameters]
        seed = { range = [0, 9] }
    """))
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "exudyn_study.cli", "sweep", str(cfg), "--out", str(out),
           "--workers", "2", "--no-progress", "--no-plot"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        t_end = time.monotonic() + 120
        while len(list((out / "points").glob("*.json"))) < 2 if (out / "points").exists() else True:
            assert proc.poll() is None, proc.stderr.read().decode()
            assert time.monotonic() < t_end, "sweep did not start"
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the CLI and its workers, mid-sweep
        proc.wait()
    before = read_rows(out)
    assert 2 <= len(before) < 10
    result = run_sweep(load_config(cfg), out, workers=2, resume=True, progress=False)
    assert result.n_run == 10 - len(before)
    assert result.n_failed == 0 and len(result.rows) == 10
    after = read_rows(out)
    assert all(after[k] == row for k, row in before.items())  # finished points were not rerun
    assert len((out / "results.csv").read_text().splitlines()) == 11
    assert not list((out / "points").glob("*.tmp"))


def test_damping_sensitivity_rig_path_rejects_table6_on_models_1_and_2():
    from exudyn_study.errors import InputError
    from exudyn_study.sweep.tasks import damping_sensitivity

    with pytest.raises(InputError, match="Table 6 exists for model 3 only"):
        damping_sensitivity(seed=1, model="rig-1", damping="calibrated")


@pytest.mark.slow
def test_damping_sensitivity_rig_path_is_one_when_the_model_is_the_truth():
    """Model 1 with Adams default damping against the 'none' scenario (its truth is that model)."""
    from exudyn_study.sweep.tasks import damping_sensitivity

    same = damping_sensitivity(seed=1, model="rig-1", signal="test", damping="adams-default", duration_s=20.0,
                               measured_scenario="none")
    assert 0.9 < same["rpd_min"] and same["rpd_max"] < 1.1
    more = damping_sensitivity(seed=1, model="rig-1", signal="test", damping="step", duration_s=20.0,
                               measured_scenario="none")
    assert more["rpd_mean"] < 0.5 * same["rpd_mean"]  # more damping, less damage
