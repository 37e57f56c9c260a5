"""`exudyn-study identify` end to end, and bad input that must write nothing."""

import subprocess
import sys

import h5py
import numpy as np
import pytest

from exudyn_study.cli import main
from exudyn_study.identify import read_modes_json
from exudyn_study.identify.synthetic import simulate, table1_system, to_recording
from exudyn_study.recording import Channel, Recording, write_recording


@pytest.fixture(scope="module")
def rec_path(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    sysm = table1_system(n_channels=12)
    ref, resp = simulate(sysm, 40.0, noise=0.02, seed=5)
    path = d / "run.h5"
    write_recording(to_recording(sysm, ref, resp), path)
    return path


def test_identify_cli_writes_modes_and_plots(rec_path, tmp_path, capsys):
    out = tmp_path / "modes.json"
    # the 30-50 Hz part of the Table 1 system: five modes (the full band is the
    # acceptance test's job; this checks the command, its files and its output)
    code = main(["identify", str(rec_path), "--reference", "ARFVZ", "--band", "30", "50",
                 "--resolution", "0.25", "--max-order", "30", "--json", str(out),
                 "--plots", str(tmp_path / "figs")])
    assert code == 0
    model = read_modes_json(out)
    true_f = table1_system().frequency_hz[5:]
    np.testing.assert_allclose(model.frequency_hz, true_f, rtol=0.005)
    assert set(model.modes[0].shape) == set(table1_system(n_channels=12).names)
    assert model.metadata["estimator"] == "Hv" and model.metadata["references"] == ["ARFVZ"]
    figs = sorted(p.name for p in (tmp_path / "figs").iterdir())
    assert figs == ["automac.png", "frf_fit.png", "mode_shapes.png", "stabilisation.png"]
    assert "5 modes in 30.00-50.00 Hz" in capsys.readouterr().out


def _run_bad(args, tmp_path, capsys, match):
    out = tmp_path / "modes.json"
    code = main(["identify", *args, "--json", str(out), "--plots", str(tmp_path / "figs")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "exudyn-study identify: error:" in err
    assert match in err, err
    assert not out.exists() and not (tmp_path / "figs").exists()


def test_unknown_reference(rec_path, tmp_path, capsys):
    _run_bad([str(rec_path), "--reference", "ARFVQ"], tmp_path, capsys, "ARFVQ")


def test_band_beyond_nyquist(rec_path, tmp_path, capsys):
    _run_bad([str(rec_path), "--reference", "ARFVZ", "--band", "3", "600"], tmp_path, capsys,
             "band 3-600 Hz: expected 0 <= FMIN < FMAX <= Nyquist (500 Hz")


def test_record_too_short_for_resolution(rec_path, tmp_path, capsys):
    _run_bad([str(rec_path), "--reference", "ARFVZ", "--resolution", "0.05"], tmp_path, capsys,
             "record of 40 s is too short for resolution 0.05 Hz")


def test_mixed_sample_rates(tmp_path, capsys):
    a = Channel("REF", "acceleration", "m/s^2", "Z", None, 1000.0, np.zeros(20000))
    b = Channel("R1", "acceleration", "m/s^2", "Z", None, 1000.0, np.zeros(20000))
    c = Channel("R2", "acceleration", "m/s^2", "Z", None, 512.0, np.zeros(10240))
    path = tmp_path / "mixed.h5"
    write_recording(Recording((a, b, c), {}), path)
    _run_bad([str(path), "--reference", "REF"], tmp_path, capsys, "mixed sample rates")


def test_nan_samples(rec_path, tmp_path, capsys):
    path = tmp_path / "nan.h5"
    path.write_bytes(rec_path.read_bytes())
    with h5py.File(path, "r+") as fh:
        def first_dataset(group):
            for key in group:
                if isinstance(group[key], h5py.Dataset):
                    return group[key]
                found = first_dataset(group[key])
                if found is not None:
                    return found
            return None
        ds = first_dataset(fh["channels"])
        ds[100] = np.nan
    _run_bad([str(path), "--reference", "ARFVZ"], tmp_path, capsys, "non-finite")


def test_uff_without_type58(tmp_path, capsys):
    import pyuff

    path = tmp_path / "units_only.uff"
    uff = pyuff.UFF(str(path))
    uff.write_sets(pyuff.prepare_164(units_code=1, units_description="SI",
                                     temp_mode=2, length=1.0, force=1.0, temp=1.0,
                                     temp_offset=273.15), mode="overwrite")
    _run_bad([str(path), "--reference", "ARFVZ"], tmp_path, capsys, "58")


def test_identify_imports_neither_exudyn_nor_ngsolve():
    code = ("import sys, exudyn_study.identify, exudyn_study.cli.identify, "
            "exudyn_study.identify.plots, exudyn_study.identify.synthetic; "
            "bad = [m for m in ('exudyn', 'ngsolve', 'netgen') if m in sys.modules]; "
            "print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_identify_cli_prints_the_close_modes_it_identified_again(tmp_path, capsys):
    from exudyn_study.identify.synthetic import BaseExcitedSystem

    rng = np.random.default_rng(3)
    phi = rng.standard_normal((6, 3))
    names = tuple(f"R{i}Z" for i in range(6))
    # 10 and 10.08 Hz: less than a line apart at the resolution 12 averages of 60 s allow
    sysm = BaseExcitedSystem(np.array([10.0, 10.08, 20.0]), np.array([0.004, 0.009, 0.01]), phi,
                             np.array([1.0, 0.8, 1.2]), np.ones(6), names, ("Z",) * 6, np.zeros((6, 3)),
                             reference="BASEZ")
    ref, resp = simulate(sysm, 60.0, noise=0.02, excitation_band_hz=(3.0, 45.0), seed=5)
    path, out = tmp_path / "pair.h5", tmp_path / "modes.json"
    write_recording(to_recording(sysm, ref, resp), path)
    assert main(["identify", str(path), "--reference", "BASEZ", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    (entry,) = read_modes_json(out).metadata["local_refinement"]
    assert "close modes: " in printed and "lines apart" in entry["reason"]
    assert f"{entry['band_hz'][0]:.2f}-{entry['band_hz'][1]:.2f} Hz identified again" in printed
