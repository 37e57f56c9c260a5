"""``exudyn-study iterate-drive`` on the mini frame (build_model is replaced by the mini builder).

The 'measured' recording is NOT a measurement: it is simulated from the mini frame with a
28 Hz drive-linkage compliance (``drive_linkage_compliance``) the iterated model lacks, as the
thesis's models lacked the rig's resonance (Section 7.1), so the drive has to be iterated.
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest

from exudyn_study.cli import main
from exudyn_study.recording import read_recording, write_recording

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402

DURATION_S = 12.0  # >= 2 Welch segments (10 s) of the 0.2 Hz FRF grid


@pytest.fixture(scope="module")
def bodies():
    pytest.importorskip("exudyn")
    return mini_bodies()


@pytest.fixture(scope="module")
def measured_file(bodies, tmp_path_factory):
    from exudyn_study.model import build_model_from_bodies, linearise
    from exudyn_study.physics import entry
    from exudyn_study.signals import drive_signal
    from exudyn_study.sweep.plant import ModelPlant

    def build():
        return build_model_from_bodies(bodies, 1, damping="constant-1", sensors=FRAME_SENSORS,
                                       exudyn_mesh="used")

    lin = linearise(build())
    m_eff = float(lin.drive_shape @ lin.full_mass @ lin.drive_shape) + 20.0  # mass the drive moves
    model = build()
    entry("drive_linkage_compliance").apply(model, stiffness_n_per_m=(2 * math.pi * 28.0) ** 2 * m_eff,
                                            damping_n_s_per_m=2e3, mass_kg=20.0)
    rec = ModelPlant(model).recording(drive_signal("white-noise", DURATION_S, 1000.0, 0.25e-3, 4),
                                      {"source": "test (simulated, not measured)"})
    path = tmp_path_factory.mktemp("measured") / "rig_white-noise.h5"
    write_recording(rec, path)
    return path


@pytest.fixture
def mini_build_model(bodies, monkeypatch):
    """Make ``exudyn_study.model.build_model`` build on the mini frame; record its calls."""
    import exudyn_study.model as model_pkg
    from exudyn_study.model import build_model_from_bodies

    calls = []

    def build(variant, damping="adams-default", **kwargs):
        calls.append((variant, damping))
        return build_model_from_bodies(bodies, variant, damping=damping, sensors=FRAME_SENSORS,
                                       exudyn_mesh="used")

    monkeypatch.setattr(model_pkg, "build_model", build)
    return calls


def test_iterate_drive_writes_the_recording_and_the_error_per_iteration(measured_file, mini_build_model,
                                                                        tmp_path, capsys):
    out, report = tmp_path / "iterated.h5", tmp_path / "iteration.json"
    rc = main(["iterate-drive", "--model", "1", "--damping", "constant-1", "--measured", str(measured_file),
               "--iterations", "3", "--tolerance", "0.05", "--out", str(out), "--json", str(report)])
    assert rc == 0
    assert mini_build_model == [(1, "constant-1")]
    data = json.loads(report.read_text())
    assert data["converged"] and data["control_channels"] == ["ARFVZ", "ARFHZ"]
    assert len(data["rms_error"]) == data["iterations"] + 1
    final = data["final_rms_error"]
    assert max(final.values()) < 0.05
    # the written recording is the best iterate (same error as in the iteration table)
    best = min(max(row.values()) for row in data["rms_error"])
    assert max(final.values()) == pytest.approx(best, rel=1e-6)
    # with the recording's own drive the model, lacking the linkage resonance, is far off
    assert max(data["measured_drive_rms_error"].values()) > 1.0
    rec = read_recording(out)
    assert rec.names == (*FRAME_SENSORS, "drive")
    assert rec.metadata["drive"] == "iterated" and rec.metadata["damping"] == "constant-1"
    assert rec.channel("ARFVZ").n_samples == read_recording(measured_file).channel("ARFVZ").n_samples
    text = capsys.readouterr().out
    assert "converged" in text and "ARFVZ" in text
    # not reaching the tolerance: the best drive's recording is still written, exit code 1
    rc = main(["iterate-drive", "--model", "1", "--damping", "constant-1", "--measured", str(measured_file),
               "--iterations", "0", "--tolerance", "0.001", "--out", str(tmp_path / "best.h5")])
    assert rc == 1 and (tmp_path / "best.h5").is_file()
    assert "NOT converged" in capsys.readouterr().out


def _run_error(argv, capsys):
    rc = main(["iterate-drive", *argv])
    err = capsys.readouterr().err.strip()
    return rc, err


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--model", "4"], "--model: invalid choice: 4 (choose from 1, 2, 3)"),
        (["--model", "1", "--damping", "rayleigh"], "--damping: invalid choice: 'rayleigh'"),
        (["--model", "1", "--control", "ARFVZ", "ARFXZ"],
         "control channel(s) ARFXZ missing from the recording; it has ARFMZ, ARFVZ"),
        (["--model", "1", "--tolerance", "0"], "--tolerance 0: out of range; expected > 0 and <= 1"),
        (["--model", "1", "--reg", "-1"], "--reg -1: out of range; expected > 0 and <= 10"),
        (["--model", "1", "--calibration", "c.json"], "--calibration is used with --damping suggested only"),
    ],
)
def test_bad_input_one_line_exit_2_nothing_written(measured_file, mini_build_model, tmp_path, capsys,
                                                   extra, match):
    out = tmp_path / "x.h5"
    rc, err = _run_error(["--measured", str(measured_file), "--out", str(out), *extra], capsys)
    assert rc == 2 and len(err.splitlines()) == 1
    assert err.startswith("exudyn-study iterate-drive: error: ") and match in err
    assert not out.exists() and mini_build_model == []


def test_nan_missing_recording_and_output_directory(measured_file, mini_build_model, tmp_path, capsys):
    import h5py

    bad = tmp_path / "nan_white-noise.h5"
    bad.write_bytes(measured_file.read_bytes())
    with h5py.File(bad, "r+") as f:
        ds = f["channels"]["0002"]
        data = ds[...]
        data[7] = np.nan
        ds[...] = data
    out = tmp_path / "x.h5"
    rc, err = _run_error(["--model", "1", "--measured", str(bad), "--out", str(out)], capsys)
    assert rc == 2 and "channel 'ARFHZ': data has 1 non-finite sample(s), the first at index 7" in err
    rc, err = _run_error(["--model", "1", "--measured", str(tmp_path / "absent.h5"), "--out", str(out)],
                         capsys)
    assert rc == 2 and "does not exist" in err
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    rc, err = _run_error(["--model", "1", "--measured", str(measured_file), "--out", str(blocker / "x.h5")],
                         capsys)
    assert rc == 2 and f"{str(blocker)!r} is a file, not a directory" in err
    assert not out.exists() and mini_build_model == []
