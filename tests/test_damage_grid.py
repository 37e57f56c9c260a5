"""The study grid (drive iteration + relative pseudo damage) on the mini frame.

The 'measured' recordings here are NOT measurements: they are simulated from a different
model (the mini frame with 1 % damping and a 28 Hz drive-linkage compliance,
``drive_linkage_compliance``), so the grid's models lack the rig resonance, as the thesis's
models did (Section 7.1).
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.recording import write_recording

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402

DURATION_S = 12.0  # >= 2 Welch segments (10 s) of the 0.2 Hz FRF grid; short to keep the tests fast
LINKAGE_HZ = 28.0  # the rig resonance of thesis Fig. 20
TOL = 0.05  # issue 6: control error below 5 % rms
Z_FRAME = tuple(n for n in FRAME_SENSORS if n.endswith("Z"))


@pytest.fixture(scope="module")
def bodies():
    pytest.importorskip("exudyn")
    return mini_bodies()


def mini_builder(bodies, exudyn_mesh="used"):
    """``builder(variant, damping)`` of :func:`run_grid` on the mini frame (any variant)."""
    from exudyn_study.model import build_model_from_bodies

    def build(variant, damping):
        return build_model_from_bodies(bodies, 1, damping=damping, sensors=FRAME_SENSORS,
                                       exudyn_mesh=exudyn_mesh)

    return build


def linkage_values(bodies, damping="constant-1") -> dict:
    """The truth's drive linkage: its mass on a spring resonating at LINKAGE_HZ with the drive's mass."""
    from exudyn_study.model import linearise

    lin0 = linearise(mini_builder(bodies)(1, damping))
    mass = 20.0
    m_eff = float(lin0.drive_shape @ lin0.full_mass @ lin0.drive_shape) + mass
    return {"stiffness_n_per_m": (2 * math.pi * LINKAGE_HZ) ** 2 * m_eff, "damping_n_s_per_m": 2e3,
            "mass_kg": mass}


def truth_plant(bodies, damping="constant-1"):
    """The 'measured' system: mini frame + a drive linkage resonating at LINKAGE_HZ."""
    from exudyn_study.physics import entry
    from exudyn_study.sweep.plant import ModelPlant

    model = mini_builder(bodies)(1, damping)
    entry("drive_linkage_compliance").apply(model, **linkage_values(bodies, damping))
    return ModelPlant(model, label="truth")


def recording_of(plant, signal, seed=5, duration_s=DURATION_S):
    from exudyn_study.signals import drive_signal
    from exudyn_study.simulate import OUTPUT_RATE_HZ

    drive = drive_signal(signal, duration_s, OUTPUT_RATE_HZ, 0.25e-3, seed)
    return plant.recording(drive, {"source": "test truth (simulated, not measured)", "signal": signal})


@pytest.fixture(scope="module")
def truth(bodies):
    return truth_plant(bodies)


@pytest.fixture(scope="module")
def measured(truth):
    return {s: recording_of(truth, s) for s in ("white-noise", "test")}


@pytest.fixture(scope="module")
def grid(bodies, measured, tmp_path_factory):
    from exudyn_study.sweep.damage_grid import run_grid

    out = tmp_path_factory.mktemp("grid")
    result = run_grid(measured, models=(1,), dampings=("constant-1", "step"), builder=mini_builder(bodies),
                      out_dir=out, max_iter=5)
    return result, out


def test_grid_iterates_the_control_sensors_and_compares_every_z_sensor(grid):
    result, _ = grid
    assert [(c.damping, c.signal) for c in result.cells] == [
        ("constant-1", "white-noise"), ("constant-1", "test"), ("step", "white-noise"), ("step", "test")]
    for c in result.cells:
        assert c.damage.names == Z_FRAME
        assert c.converged and c.final_error < TOL
        # the drive was iterated to reproduce the control sensors: damage there within
        # (1 +- 5 %)^5 of the measured, the band an rms error of 5 % allows
        for name in ("ARFVZ", "ARFHZ"):
            assert 0.95**5 < c.damage[name].ratio < 1.05**5
    for s in ("white-noise", "test"):
        # the truth's own damping: every sensor near 100 %, although the model lacks the
        # linkage resonance (the iterated drive absorbs it, thesis Section 7.1)
        np.testing.assert_allclose(result.cell(1, "constant-1", s).damage.ratios, 1.0, atol=0.15)
        # STEP's 16.6 %: far less response at the rear sensors, away from the drive point
        hi = result.cell(1, "step", s).damage
        assert hi["ARVBZ"].ratio < 0.5 and hi["ARHBZ"].ratio < 0.5
    assert result.rate_hz == 204.8 and result.beta == 5.0


def test_grid_writes_csv_and_plots(grid):
    import csv

    result, out = grid
    rows = list(csv.DictReader(open(out / "damage_grid.csv")))
    assert len(rows) == 4 * len(Z_FRAME)
    assert set(rows[0]) >= {"model", "damping", "signal", "channel", "relative_pseudo_damage",
                            "iteration_error"}
    row = next(r for r in rows
               if r["damping"] == "step" and r["signal"] == "test" and r["channel"] == "ARVBZ")
    assert float(row["relative_pseudo_damage"]) == pytest.approx(
        result.cell(1, "step", "test").damage["ARVBZ"].ratio, rel=1e-5)
    its = list(csv.DictReader(open(out / "drive_iterations.csv")))
    assert {"run", "ARFVZ", "ARFHZ"} <= set(its[0])
    assert len(its) == sum(c.iteration_errors.shape[0] for c in result.cells)
    names = {p.name for p in result.files}
    assert {"model1_white-noise_dampings.png", "model1_test_dampings.png", "model1_step_signals.png"} <= names
    assert all(p.stat().st_size > 1000 for p in result.files if p.suffix == ".png")
    assert "constant-1" in result.summary() and result.wall_time_s > 0


def test_model_against_its_own_recording_gives_100_percent(bodies):
    """A recording of the grid's own model driven by its recorded drive (iterate=False):
    every sensor's relative pseudo damage is 100 %."""
    from exudyn_study.sweep.damage_grid import run_grid
    from exudyn_study.sweep.plant import ModelPlant

    own = ModelPlant(mini_builder(bodies)(1, "step"))
    rec = {"white-noise": recording_of(own, "white-noise", seed=11)}
    plain = run_grid(rec, models=(1,), dampings=("step",), builder=lambda v, d: own.model, iterate=False)
    assert plain.cells[0].iteration_errors is None
    # the recorded drive is the controller's 204.8 Hz copy, resampled back to 1000 Hz
    np.testing.assert_allclose(plain.cells[0].damage.ratios, 1.0, atol=0.05)


def test_linkage_resonance_the_iteration_model_lacks(bodies, truth, measured):
    """TWR on the truth (with the 28 Hz linkage) with H of the nominal model (without it):
    far off at D_0, below 5 % within 10 iterations; a fixed H diverges."""
    from exudyn_study.sweep.plant import ModelPlant, iterate_model_drive

    nominal = ModelPlant(mini_builder(bodies)(1, "constant-1"))
    # 20 s: the H update needs a few Welch segments per run (12 s: 6.8 % after 10 updates)
    target = recording_of(truth, "white-noise", seed=9, duration_s=20.0)
    res = iterate_model_drive(truth, target, frf_plant=nominal, max_iter=10, tol=TOL)
    assert res.errors[0].max() > 1.0  # 1790 % measured: the missing resonance at D_0
    assert res.converged and res.n_iterations <= 10 and res.best_error < TOL  # 4 updates measured
    fixed = iterate_model_drive(truth, target, frf_plant=nominal, max_iter=2, update_frf=False)
    assert not fixed.converged and fixed.errors[-1].max() > fixed.errors[0].max()


def test_plant_recording_is_simulate_linear(truth):
    """ModelPlant.recording (no re-linearisation) gives what simulate(method='linear') gives."""
    from exudyn_study.signals import drive_signal
    from exudyn_study.simulate import simulate

    plant = truth
    drive = drive_signal("test", 3.0, 1000.0, 0.25e-3, 3)
    mine = plant.recording(drive)
    ref = simulate(plant.model, drive, method="linear", drive_rate_hz=1000.0)
    assert mine.names == ref.names
    for a, b in zip(mine.channels, ref.channels, strict=True):
        assert (a.direction, a.position_m, a.sample_rate_hz, a.role, a.sensitivity) == (
            b.direction, b.position_m, b.sample_rate_hz, b.role, b.sensitivity)
        # same algebra; the eigen-decomposition's rounding differs with one or two BLAS threads
        # (measured up to 4e-8 of the peak on this truth model)
        np.testing.assert_allclose(a.data, b.data, rtol=0, atol=1e-6 * np.abs(b.data).max())
    assert mine.metadata["damping"] == "truth"  # the plant's label
    assert {k: v for k, v in mine.metadata.items() if k not in ("wall_s", "damping")} == {
        k: v for k, v in ref.metadata.items() if k not in ("wall_s", "damping")}


# ----------------------------------------------------------------------------- bad input


def _no_build(variant, damping):  # bad input must be rejected before any model is built
    raise AssertionError("a model was built")


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(models=(4,)), r"model 4 is unknown; expected one of \[1, 2, 3\]"),
        (dict(dampings=("rayleigh",)), r"damping 'rayleigh' is unknown"),
        (dict(beta=0.0), r"beta 0.0; expected a finite value > 0"),
        (dict(beta=-5), r"beta -5; expected a finite value > 0"),
        (dict(signals=("test-50",)), r"signal\(s\) test-50 have no measured recording"),
        (dict(control=("ARFVZ", "ARFXZ")), r"control channel\(s\) ARFXZ missing"),
        (dict(out_dir="/nonexistent/dir"), r"out_dir '/nonexistent/dir' does not exist"),
        (dict(calibrations={2: {}}), r"calibrations for model\(s\) \[2\] not in the grid"),
        (dict(dampings=("diagnosed",)), r"damping 'diagnosed' needs a diagnosis"),
        (dict(diagnosis={"mismatch_found": True, "findings": [], "unexplained": [],
                         "metadata": {"model": 3}}), r"lacks 'model_entries'"),
    ],
)
def test_bad_input_is_rejected_before_building(measured, kwargs, match):
    from exudyn_study.sweep.damage_grid import run_grid

    args = dict(models=(1,), dampings=("step",), builder=_no_build)
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        run_grid(measured, **args)


def test_nan_and_missing_recordings(measured, tmp_path):
    import h5py

    from exudyn_study.sweep.damage_grid import measured_recordings, run_grid

    path = tmp_path / "rig_white-noise.h5"
    write_recording(measured["white-noise"], path)
    with h5py.File(path, "r+") as f:
        ds = f["channels"]["0001"]
        data = ds[...]
        data[100] = np.nan
        ds[...] = data
    with pytest.raises(InputError,
                       match=r"channel 'ARFVZ': data has 1 non-finite sample\(s\), the first at index 100"):
        run_grid({"white-noise": path}, models=(1,), builder=_no_build)
    with pytest.raises(InputError, match="does not exist"):
        run_grid({"white-noise": tmp_path / "absent.h5"}, models=(1,), builder=_no_build)
    assert measured_recordings(tmp_path) == {"white-noise": path}
    with pytest.raises(InputError, match=r"no recording for signal 'test'"):
        measured_recordings(tmp_path, ["white-noise", "test"])
    write_recording(measured["white-noise"], tmp_path / "other_white-noise.h5")
    with pytest.raises(InputError, match=r"2 recordings for signal 'white-noise'"):
        measured_recordings(tmp_path)


def test_different_channel_sets(bodies, measured):
    from exudyn_study.sweep.damage_grid import run_grid

    fewer = measured["white-noise"].select(["ARFVZ", "ARFHZ", "ARFMZ", "drive"])
    with pytest.raises(InputError, match=r"lacks compared channel\(s\) AVBFZ, ARVBZ, ARHBZ"):
        run_grid({"white-noise": fewer}, models=(1,), dampings=("step",), builder=mini_builder(bodies))


def test_calibration_file(bodies, tmp_path):
    from exudyn_study.sweep.grid_damping import damping_from_calibration, resolve_damping

    f = np.asarray(bodies["chassis"].body.frequencies_hz)
    cal = {"format": "exudyn_study.calibration", "metadata": {"other_damping": "step"},
           "body_damping": {"chassis": {"frequency_hz": f.tolist(), "damping_ratio": [0.03] * f.size}}}
    path = tmp_path / "cal.json"
    path.write_text(json.dumps(cal))
    damping = resolve_damping(1, "suggested", path)
    assert damping["rear_foundation"] == "step"
    np.testing.assert_allclose(damping["chassis"](f), 0.03)
    model = mini_builder(bodies)(1, damping)
    np.testing.assert_allclose(model.damping_ratios["chassis"], 0.03)
    with pytest.raises(InputError, match=r"calibration of body 'chassis': .* calibrate on the same mesh"):
        damping["chassis"](f[:-1])
    with pytest.raises(InputError, match=r"expected a 'exudyn_study.calibration' JSON"):
        damping_from_calibration({"format": "exudyn_study.modes"})
    with pytest.raises(InputError, match=r"body 'chassis' damping ratio \[0\] = .*1\.5"):
        damping_from_calibration({**cal, "body_damping": {"chassis": {"frequency_hz": [1.0],
                                                                     "damping_ratio": [1.5]}}})
    assert resolve_damping(3, "table6").ratios["frame"] == 0.015  # thesis Table 6
    for name in ("suggested", "diagnosed"):
        with pytest.raises(InputError, match="needs a calibration"):
            resolve_damping(1, name)


def test_study_script_smoke(bodies, measured, tmp_path, monkeypatch, capsys):
    """studies/damage_grid.py end to end on the mini frame (build_model replaced)."""
    import importlib.util
    from pathlib import Path

    import exudyn_study.model as model_pkg

    build = mini_builder(bodies)

    def build_model(variant, damping="adams-default", **kwargs):
        return build(variant, damping)

    monkeypatch.setattr(model_pkg, "build_model", build_model)
    meas = tmp_path / "meas"
    meas.mkdir()
    write_recording(measured["test"], meas / "mini_test.h5")
    script = Path(__file__).resolve().parents[1] / "studies" / "damage_grid.py"
    spec = importlib.util.spec_from_file_location("study_damage_grid", script)
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    out = tmp_path / "out"
    assert study.main(["--measured-dir", str(meas), "--out", str(out), "--models", "1", "--dampings", "step",
                       "--no-plots"]) == 0
    text = capsys.readouterr().out
    assert "grid of 1 cells: wall time" in text and (out / "damage_grid.csv").is_file()
    assert study.main(["--measured-dir", str(tmp_path / "absent"), "--out", str(out)]) == 2
    assert "does not exist" in capsys.readouterr().err


def held_modes_target(plant, reference="ARFVZ", max_frequency_hz=60.0):
    """The truth's modes as an EMA on transmissibilities sees them: the reference held, shapes at the
    other sensors (an exact target: what a perfect identification of the recording would give)."""
    from exudyn_study.identify.model import ModalModel, Mode
    from exudyn_study.model.linearisation import system_modes
    from exudyn_study.virtual_rig.thesis import references_held

    md = system_modes(plant.model, lin=references_held(plant.lin, (reference,)),
                      max_frequency_hz=max_frequency_hz)
    names = [n for n in md.sensor_names if n != reference]
    rows = [list(md.sensor_names).index(n) for n in names]
    return ModalModel(tuple(
        Mode(float(f), float(z), shape=dict(zip(names, md.shapes[rows, k], strict=True)))
        for k, (f, z) in enumerate(zip(md.frequency_hz, md.damping_ratio, strict=True))),
        {"source": "truth, reference held", "references": [reference]})


@pytest.fixture(scope="module")
def calibrated_grid(bodies, tmp_path_factory):
    """Truth: the mini frame with 2 % on every body mode; the grid's models start from Adams default."""
    from exudyn_study.sweep.damage_grid import run_grid
    from exudyn_study.sweep.plant import ModelPlant

    truth = ModelPlant(mini_builder(bodies)(1, "constant-2"), label="truth")
    measured = {"white-noise": recording_of(truth, "white-noise"), "test": recording_of(truth, "test")}
    out = tmp_path_factory.mktemp("calibrated")
    result = run_grid(measured, models=(1,), dampings=("adams-default", "suggested"),
                      builder=mini_builder(bodies), probe_builder=mini_builder(bodies, "all"), out_dir=out,
                      max_iter=5, target=held_modes_target(truth))
    return result, out


def test_suggested_damping_is_calibrated_on_the_modes_with_shapes(calibrated_grid):
    """Model and target modes pair by MAC (same structure: MAC 1, same frequencies), the calibrated model
    carries the target damping, and that brings the damage to the measured one; Adams default misses."""
    result, out = calibrated_grid
    cal = result.calibrations[(1, "suggested")]
    assert cal["metadata"]["target"] == "truth, reference held"
    assert cal["settings"]["held_sensors"] == ["ARFVZ"]
    paired = [r for r in cal["modes"] if r["target_frequency_hz"] is not None]
    assert len(paired) == 5 and not cal["unpaired_targets"]  # the mini frame's 5 held modes below 60 Hz
    for r in paired:
        assert r["mac"] > 0.99
        # |lambda| moves with non-proportional damping: the body modes above the band differ from the truth's
        assert r["frequency_hz"] == pytest.approx(r["target_frequency_hz"], rel=1e-3)
        # 0.35 pp: the floor that the body modes above the cut-off (fixed at 100 %, as the thesis's) and the
        # calibrated ones' lower bound (0.5 %) leave: the 29 Hz mode, 0.13 % in the truth, stays at 0.44 %
        assert r["damping_ratio"] == pytest.approx(r["target_damping_ratio"], abs=3.5e-3)
    assert sum(abs(r["error"]) < 1e-5 for r in paired) >= 4
    for s in ("white-noise", "test"):
        calibrated = np.abs(np.log(result.cell(1, "suggested", s).damage.ratios))
        adams = np.abs(np.log(result.cell(1, "adams-default", s).damage.ratios))
        assert np.median(calibrated) < 0.5 * np.median(adams)
        assert np.all(calibrated < np.log(2.0))  # within 50-200 % at every sensor
    names = {p.name for p in result.files}
    assert {"calibration_model1_suggested.json", "pairing.txt", "reading.txt", "model1_summary.png",
            "calibration_target_modes.json"} <= names
    assert "target modes without a partner: none" in (out / "pairing.txt").read_text()


def test_ema_target_needs_its_references(measured):
    from exudyn_study.sweep.grid_damping import ema_target

    with pytest.raises(InputError, match=r"EMA references \['ARXXZ'\]: not channels"):
        ema_target(measured["white-noise"], references=("ARFVZ", "ARXXZ"))


def test_reading_names_the_best_damping_per_sensor_group(calibrated_grid):
    result, _ = calibrated_grid
    from exudyn_study.sweep.damage_grid import sensor_group

    assert [sensor_group(n) for n in ("ARFVZ", "ARVBZ", "ATHFZ", "ASVZ", "ARSVZ")] == [
        "frame and cross members", "rear attachments", "tanks", "brackets", "frame and cross members"]
    text = result.reading()
    groups = result.group_ratios(1)
    assert list(groups) == ["frame and cross members", "rear attachments"]  # the mini frame's sensors
    for g, per in groups.items():
        best = min(per, key=lambda d: np.median(np.abs(np.log(per[d]))))
        assert f"  {g}: best {best} " in text


def _diagnosis(entries, gains=None, model=1):
    fit = {"train_before": 1.0, "train_after": 0.1, "holdout_before": 1.0, "holdout_after": 0.1,
           "metric": "m"}
    return {"format": "exudyn_study.diagnosis", "format_version": 1, "mismatch_found": True,
            "findings": [{"physics": e["physics"],
                          "location": {"sensors": [], "component": None, "interface": None},
                          "band_hz": None, "level_dependent": False, "explanation": "", "parameters": {},
                          "fit": fit} for e in entries],
            "unexplained": [], "metadata": {"model": model, "model_entries": entries,
                                            "output_gains": gains or {}}}


def test_apply_diagnosis_rebuilds_the_fitted_model(bodies, truth):
    """The fitted model rebuilt from a diagnosis JSON is the model with the entries applied: same
    linearisation as applying the catalogue entry by hand (the truth), sensor gains multiplied in."""
    from exudyn_study.diagnose.fitted import apply_diagnosis
    from exudyn_study.sweep.plant import ModelPlant

    lin_truth = truth.lin
    linkage = linkage_values(bodies)
    d = _diagnosis([{"physics": "drive_linkage_compliance", "location": None, "values": linkage}],
                   gains={"ARFMZ": 1.1, "ARFVZ": 1.0})
    plant = ModelPlant(apply_diagnosis(mini_builder(bodies)(1, "constant-1"), d))
    np.testing.assert_allclose(plant.lin.stiffness, lin_truth.stiffness, rtol=1e-12, atol=1e-6)
    assert plant.model.output_gains == {"ARFMZ": 1.1}
    with pytest.raises(InputError, match="diagnosis of model 3 cannot be applied to model 1"):
        apply_diagnosis(mini_builder(bodies)(1, "constant-1"), _diagnosis([], model=3))
    with pytest.raises(InputError, match="lacks 'model_entries'"):
        apply_diagnosis(mini_builder(bodies)(1, "constant-1"),
                        {**d, "metadata": {"model": 1}})


def test_diagnosed_column_runs_the_fitted_model_on_its_variant_only(bodies, measured, truth):
    from exudyn_study.sweep.damage_grid import run_grid

    d = _diagnosis([{"physics": "drive_linkage_compliance", "location": None,
                     "values": linkage_values(bodies)}])
    res = run_grid({"test": measured["test"]}, models=(1, 2), builder=mini_builder(bodies),
                   probe_builder=mini_builder(bodies, "all"), diagnosis=d, target=held_modes_target(truth))
    assert [(c.model, c.damping) for c in res.cells] == [
        (1, "adams-default"), (1, "step"), (1, "suggested"), (1, "diagnosed"),
        (2, "adams-default"), (2, "step"), (2, "suggested")]
    assert set(res.calibrations) == {(1, "suggested"), (1, "diagnosed"), (2, "suggested")}
    # the fitted model has the truth's linkage mode, so its pairing with the truth's modes is complete
    assert not res.calibrations[(1, "diagnosed")]["unpaired_targets"]
    assert "model 2: no diagnosed column (the diagnosis was made on model 1)" in res.reading()
