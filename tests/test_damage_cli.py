"""Tests of the ``exudyn-study damage`` subcommand."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from exudyn_study.cli import main
from exudyn_study.recording import Recording, write_recording
from exudyn_study.signals import resample, white_noise

NAMES = ["ARFVZ", "ARFHZ", "ASVZ"]


@pytest.fixture
def files(tmp_path):
    # measured at 1000 Hz (UFF58, as test software exports), simulated at 204.8 Hz (HDF5)
    x = np.vstack([white_noise(10.0, 1000.0, rms_m=1.0, seed=s) for s in range(3)])
    meas = Recording.from_arrays(x, 1000.0, NAMES, metadata={"source": "rig"})
    scale = np.array([[0.9], [1.0], [1.1]])
    sim_x = scale * resample(x, 1000.0, 204.8)
    sim = Recording.from_arrays(
        sim_x, 204.8, NAMES, drive=np.zeros(sim_x.shape[1]), metadata={"source": "sim"}
    )
    paths = tmp_path / "meas.uff", tmp_path / "sim.h5"
    write_recording(meas, paths[0])
    write_recording(sim, paths[1])
    return paths


def test_damage_in_process(files, tmp_path, capsys):
    meas, sim = files
    out = tmp_path / "damage.json"
    code = main(
        [
            "damage",
            "--simulated",
            str(sim),
            "--measured",
            str(meas),
            "--json",
            str(out),
            "--plot",
            str(tmp_path / "d.png"),
        ]
    )
    assert code == 0
    data = json.loads(out.read_text())
    assert list(data["channels"]) == NAMES
    ratios = [data["channels"][n]["relative_pseudo_damage"] for n in NAMES]
    np.testing.assert_allclose(ratios, [0.9**5, 1.0, 1.1**5], rtol=1e-9)
    ch = data["channels"]["ASVZ"]
    assert ch["relative_pseudo_damage"] == pytest.approx(
        ch["pseudo_damage_simulated"] / ch["pseudo_damage_measured"]
    )
    assert data["beta"] == 5.0 and data["rate_hz"] == 204.8
    assert "161.1%" in capsys.readouterr().out
    assert (tmp_path / "d.png").stat().st_size > 5000
    assert sorted(os.listdir(tmp_path)) == ["d.png", "damage.json", "meas.uff", "sim.h5"]


def test_damage_channels_and_beta(files, tmp_path):
    meas, sim = files
    out = tmp_path / "d.json"
    assert (
        main(
            [
                "damage",
                "--simulated",
                str(sim),
                "--measured",
                str(meas),
                "--beta",
                "3",
                "--channels",
                "ASVZ",
                "--json",
                str(out),
            ]
        )
        == 0
    )
    data = json.loads(out.read_text())
    assert list(data["channels"]) == ["ASVZ"]
    assert data["channels"]["ASVZ"]["relative_pseudo_damage"] == pytest.approx(1.1**3, rel=1e-9)


def test_damage_bad_input(files, tmp_path, capsys):
    meas, sim = files
    out = tmp_path / "d.json"
    code = main(
        [
            "damage",
            "--simulated",
            str(sim),
            "--measured",
            str(meas),
            "--beta",
            "0",
            "--json",
            str(out),
        ]
    )
    assert code == 2
    assert "beta 0" in capsys.readouterr().err
    code = main(
        [
            "damage",
            "--simulated",
            str(sim),
            "--measured",
            str(meas),
            "--z-sensors",
            "--json",
            str(out),
        ]
    )
    assert code == 2
    assert "missing from the simulated recording" in capsys.readouterr().err
    code = main(
        [
            "damage",
            "--simulated",
            str(tmp_path / "nope.h5"),
            "--measured",
            str(meas),
            "--json",
            str(out),
        ]
    )
    assert code == 2
    assert "does not exist" in capsys.readouterr().err
    assert not out.exists()


def test_damage_subprocess(files, tmp_path):
    """One fresh process: the console-script entry point (cli.main) runs the damage
    subcommand, and none of these modules pulls in exudyn, ngsolve or netgen."""
    meas, sim = files
    out = tmp_path / "sub.json"
    argv = [
        "damage",
        "--simulated",
        str(sim),
        "--measured",
        str(meas),
        "--channels",
        "ARFVZ",
        "--json",
        str(out),
    ]
    code = (
        "import sys\n"
        "import exudyn_study.recording, exudyn_study.model.sensors, exudyn_study.signals\n"
        "import exudyn_study.signals.fatigue, exudyn_study.signals.fatigue_plots\n"
        "import exudyn_study.signals.drive_iteration\n"
        "roots = {m.split('.')[0] for m in sys.modules}\n"
        "bad = sorted(roots & {'exudyn', 'ngsolve', 'netgen'})\n"
        "assert not bad, bad\n"
        "from exudyn_study.cli import main\n"
        f"sys.exit(main({argv!r}))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "ARFVZ" in proc.stdout
    data = json.loads(out.read_text())
    assert data["channels"]["ARFVZ"]["relative_pseudo_damage"] == pytest.approx(0.9**5, rel=1e-9)
