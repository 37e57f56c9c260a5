"""Progress bars of long steps: shown on request, silent when switched off, alive while a stage blocks."""

from __future__ import annotations

import io
import time

import pytest

from exudyn_study.infra import progress
from exudyn_study.infra.progress import StageProgress


def test_stage_bar_names_each_stage_and_keeps_its_clock_running(monkeypatch, capsys):
    monkeypatch.setenv("EXUDYN_STUDY_PROGRESS", "1")
    monkeypatch.setattr(progress, "REFRESH_S", 0.05)
    with StageProgress("building body", ["mesh", "assembly", "reduction"]) as p:
        p.stage("mesh")
        p.stage("reduction")
        time.sleep(0.3)  # a blocking stage: the heartbeat refreshes the bar meanwhile
    err = capsys.readouterr().err
    assert "building body" in err and "mesh" in err and "reduction" in err
    assert err.count("reduction") >= 3  # refreshed while blocked, not only when the stage began
    assert "stage 3/3, done" in err


def test_stage_bar_is_silent_when_switched_off(monkeypatch, capsys):
    monkeypatch.setenv("EXUDYN_STUDY_PROGRESS", "0")
    with StageProgress("building body", ["mesh"]) as p:
        p.stage("mesh")
    assert capsys.readouterr().err == ""


def test_an_unknown_stage_is_a_programming_error(monkeypatch):
    monkeypatch.setenv("EXUDYN_STUDY_PROGRESS", "0")
    with pytest.raises(ValueError), StageProgress("x", ["mesh"]) as p:
        p.stage("meshing")


def test_status_bar_shows_the_latest_text_and_keeps_its_clock_running(monkeypatch, capsys):
    monkeypatch.setenv("EXUDYN_STUDY_PROGRESS", "1")
    monkeypatch.setattr(progress, "REFRESH_S", 0.05)
    with progress.StatusProgress("diagnosis") as status:
        status("comparing the nominal model")
        status("fitting joint_stiffness at A2-B1\nsecond line not shown")
        time.sleep(0.3)
    err = capsys.readouterr().err
    assert "comparing the nominal model" in err and "second line" not in err
    assert err.count("fitting joint_stiffness at A2-B1") >= 3  # refreshed while the fit blocks
    assert err.rstrip().endswith("done")


def test_status_bar_is_silent_when_switched_off(monkeypatch, capsys):
    monkeypatch.setenv("EXUDYN_STUDY_PROGRESS", "0")
    with progress.StatusProgress("diagnosis") as status:
        status("comparing")
    assert capsys.readouterr().err == ""


def test_keep_alive_refreshes_a_bar_that_waits_for_a_slow_item(monkeypatch):
    from tqdm import tqdm

    monkeypatch.setattr(progress, "REFRESH_S", 0.05)
    refreshed = []
    bar = tqdm(total=2, disable=False, file=io.StringIO())
    monkeypatch.setattr(bar, "refresh", lambda *a, **k: refreshed.append(time.perf_counter()))
    with progress.keep_alive(bar):
        time.sleep(0.3)  # one slow item: no update, yet the bar is redrawn
    n = len(refreshed)
    time.sleep(0.15)
    assert n >= 3 and len(refreshed) == n  # refreshed while the item ran, not after
    bar.close()
