"""Rig model and system modal analysis on the mini frame (tests/rig_fixtures.py)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from exudyn_study.errors import InputError

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402

pytest.importorskip("exudyn")


@pytest.fixture(scope="session")
def bodies():
    return mini_bodies()


@pytest.fixture(scope="session")
def model_and_modes(bodies):
    from exudyn_study.model import build_model_from_bodies, linearise
    from exudyn_study.model.linearisation import system_modes

    model = build_model_from_bodies(bodies, 1, damping="constant-2", sensors=FRAME_SENSORS)
    lin = linearise(model)
    return model, lin, system_modes(model, lin, max_frequency_hz=120.0)


def test_damped_modes_agree_with_exudyn_eigenvalues(model_and_modes):
    """Our projected state-space eigenproblem equals Exudyn's ComputeODE2Eigenvalues."""
    model, _, modes = model_and_modes
    ev, _ = model.mbs.ComputeODE2Eigenvalues(computeComplexEigenvalues=True, useAbsoluteValues=False)
    ev = ev[ev.imag > 1e-3]
    f = np.sort(np.abs(ev) / (2 * np.pi))
    f = f[f <= 120.0]
    np.testing.assert_allclose(modes.frequency_hz, f[: modes.frequency_hz.size], rtol=1e-6)
    zeta_exu = -ev.real / np.abs(ev)
    order = np.argsort(np.abs(ev))
    np.testing.assert_allclose(modes.damping_ratio, zeta_exu[order][: modes.frequency_hz.size], atol=1e-6)


def test_formulations_have_the_same_linearised_system(bodies, model_and_modes):
    """The linear CMS body is the linearisation of the FFRF body: same system modes."""
    from exudyn_study.model import build_model_from_bodies
    from exudyn_study.model.linearisation import system_modes

    ffrf = build_model_from_bodies(bodies, 1, damping="constant-2", sensors=FRAME_SENSORS, formulation="ffrf")
    modes_ffrf = system_modes(ffrf, max_frequency_hz=120.0)
    modes = model_and_modes[2]
    np.testing.assert_allclose(modes_ffrf.frequency_hz, modes.frequency_hz, rtol=1e-6)
    np.testing.assert_allclose(modes_ffrf.damping_ratio, modes.damping_ratio, atol=1e-6)


def test_drive_shape_lifts_the_frame_front(model_and_modes):
    """A unit piston displacement lifts the drive pads by ~1 (lever ratio 1) and not the rear."""
    _, lin, _ = model_and_modes
    s = dict(zip(lin.sensor_names, lin.sensor_drive, strict=False))
    assert s["ARFVZ"] == pytest.approx(1.0, abs=0.05)
    assert s["ARFHZ"] == pytest.approx(1.0, abs=0.05)
    assert abs(s["ARVBZ"]) < 0.05
    assert np.abs(lin.b0).max() < 1e-6 * np.abs(lin.stiffness).max()


def test_modes_json_schema_and_self_pairing(model_and_modes, tmp_path):
    from exudyn_study import linear
    from exudyn_study.identify.model import read_modes_json, write_modes_json

    model, _, modes = model_and_modes
    mm = linear.to_modal_model(modes, model.metadata)
    path = write_modes_json(mm, tmp_path / "m.json")
    back = read_modes_json(path)
    np.testing.assert_allclose(back.frequency_hz, modes.frequency_hz)
    assert all(m.description for m in back.modes)
    assert set(back.channels) == set(FRAME_SENSORS)
    pairs = linear.pair_modal_models(back, back)
    assert len(pairs) == len(back)
    # distinct modes can share a shape at 8 sensors; each mode pairs with itself or an equivalent one
    assert all(p.mac > 0.99 for p in pairs)


def test_sensor_attached_near_its_position(model_and_modes):
    model = model_and_modes[0]
    assert model.sensors["ARFVZ"].distance_m < 0.03
    assert model.sensors["ARFVZ"].direction.tolist() == [0.0, 0.0, 1.0]


def test_bad_input(bodies):
    from exudyn_study.model import BushingParameters, build_model, build_model_from_bodies

    with pytest.raises(InputError, match="unknown sensor 'NOPE'"):
        build_model_from_bodies(bodies, 1, sensors=["NOPE"])
    with pytest.raises(InputError, match="model 4 is unknown"):
        build_model(4)
    with pytest.raises(InputError, match="damping 'wet' is unknown"):
        build_model_from_bodies(bodies, 1, damping="wet", sensors=FRAME_SENSORS)
    with pytest.raises(InputError, match="bushing given for model 1"):
        build_model(1, bushing=BushingParameters())
    with pytest.raises(InputError, match="sits on 'tank_left'"):
        from exudyn_study.model import build_model_from_bodies as b

        b({"frame": bodies["chassis"], "rear_foundation": bodies["rear_foundation"]}, 3, sensors=["ATVBZ"])
    with pytest.raises(InputError, match="bushing stiffness"):
        BushingParameters(stiffness=[1, 2, 3]).matrices()


def test_cli_modes_bad_model(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "exudyn_study.cli", "modes", "--model", "7", "--json",
                           str(tmp_path / "x.json")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "--model: invalid choice: 7 (choose from 1, 2, 3)" in proc.stderr and proc.stderr.count("\n") == 1
    assert not (tmp_path / "x.json").exists()
