"""The rig path of the diagnosis on the mini frame: finds a hidden effect, says nothing when nothing is
missing, rejects bad input. Truth recordings come from the virtual rig (the diagnosis never sees the
truth)."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.virtual_rig import Augment, Scenario, virtual_recording

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402

DURATION_S = 16.0


@pytest.fixture(scope="module")
def bodies():
    pytest.importorskip("exudyn")
    return mini_bodies()


def _recordings(bodies, augmentations, seed=5):
    sc = Scenario("mini", "test", variant=1, damping="constant-2", augmentations=augmentations)
    sc = sc.with_seed(seed)
    train = virtual_recording(sc, "white-noise", DURATION_S, bodies=bodies, sensors=FRAME_SENSORS)
    hold = virtual_recording(sc, "test", DURATION_S, bodies=bodies, sensors=FRAME_SENSORS)
    return train, hold


def _diagnose(bodies, train, hold, **kw):
    from exudyn_study.diagnose.rig import RigDiagnosisSettings, diagnose_rig

    st = RigDiagnosisSettings(train_duration_s=12.0, screen_duration_s=8.0)
    return diagnose_rig(1, [train], [hold], damping="constant-2", bodies=bodies, sensors=FRAME_SENSORS,
                        settings=st, **kw)


def test_nothing_missing_gives_no_finding(bodies):
    train, hold = _recordings(bodies, ())
    d = _diagnose(bodies, train, hold)
    assert d.mismatch_found is False and not d.findings and not d.unexplained


def test_hidden_mass_is_named_located_fitted_and_improves_held_out(bodies):
    train, hold = _recordings(bodies, (Augment("added_mass", "ARFHZ", {"mass_kg": 12.0}),))
    figures = {}
    d = _diagnose(bodies, train, hold, figures=figures)
    assert d.mismatch_found
    f = d.findings[0]
    assert f.physics == "added_mass"
    assert "ARFHZ" in f.location["sensors"]
    assert f.parameters["mass_kg"]["value"] == pytest.approx(12.0, rel=0.05)
    assert f.fit["holdout_after"] < 0.5 * f.fit["holdout_before"]
    assert set(figures) >= {"residual_map", "measured", "nominal_T", "after_T", "channels"}


def test_wrong_sensor_gain_is_not_mistaken_for_structure(bodies):
    train, hold = _recordings(bodies, (Augment("sensor_gain", "ARHBZ", {"gain": 1.2}),))
    d = _diagnose(bodies, train, hold)
    f = d.findings[0]
    assert f.physics == "sensor_gain" and f.location["sensors"] == ["ARHBZ"]
    assert f.parameters["gain"]["value"] == pytest.approx(1.2, rel=0.02)


def test_bad_input(bodies):
    from exudyn_study.diagnose.rig import diagnose_rig
    from exudyn_study.recording import Recording

    train, hold = _recordings(bodies, ())
    with pytest.raises(InputError, match="no held-out recording"):
        diagnose_rig(1, [train], [], bodies=bodies, sensors=FRAME_SENSORS)
    fewer = Recording(tuple(ch for ch in hold if ch.name != "ARFVY"), dict(hold.metadata))
    with pytest.raises(InputError, match="different sensor layouts"):
        diagnose_rig(1, [train], [fewer], bodies=bodies, sensors=FRAME_SENSORS)
    no_drive = Recording(tuple(ch for ch in hold if ch.role != "drive"), dict(hold.metadata))
    with pytest.raises(InputError, match="has no drive channel"):
        _diagnose(bodies, train, no_drive.__class__(tuple(no_drive) + (), dict(no_drive.metadata)))

    def rename(rec):
        chans = tuple(dataclasses.replace(ch, name="XXXZ") if ch.name == "ARFVY" else ch for ch in rec)
        return Recording(chans, dict(rec.metadata))

    renamed, renamed_hold = rename(train), rename(hold)
    with pytest.raises(InputError, match=r"channels \['XXXZ'\] are not sensors of the model"):
        _diagnose(bodies, renamed, renamed_hold)
    assert np.isfinite(train.channel("ARFVZ").data).all()


@pytest.mark.slow
def test_bushing_stiffening_on_model_3_is_found_as_level_dependent(tmp_path):
    """Real Model 3: the cubic pad hardening, trained on white noise and the test signal at 50 %, held out
    the test signal at 100 %."""
    from exudyn_study.diagnose.rig import diagnose_rig
    from exudyn_study.virtual_rig import run_virtual_test

    paths = run_virtual_test("bushing_stiffening", ["white-noise", "test-50", "test"], tmp_path,
                             duration_s=60.0)
    d = diagnose_rig(3, paths[:2], paths[2:])
    f = d.findings[0]
    assert f.physics == "bushing_stiffening" and f.level_dependent
    assert f.parameters["cubic_stiffness_n_per_m3"]["value"] == pytest.approx(5e13, rel=0.15)
    assert f.fit["holdout_after"] < 0.5 * f.fit["holdout_before"]


def test_a_soft_rear_support_is_named_at_its_side_and_fitted(bodies):
    """The frame's left rear attachment on a vertical spring: found as ``rear_support_compliance`` at
    that side (not as a mass or the drive linkage), its stiffness within 10 %, the held-out error at
    least halved."""
    truth = {"vertical_stiffness_n_per_m": 5e6, "damping_time_s": 2e-4}
    train, hold = _recordings(bodies, (Augment("rear_support_compliance", "rear_left", truth),))
    d = _diagnose(bodies, train, hold)
    assert d.mismatch_found and d.findings
    f = d.findings[0]
    assert (f.physics, f.location["interface"]) == ("rear_support_compliance", "foundation_rear_left")
    assert f.parameters["vertical_stiffness_n_per_m"]["value"] == pytest.approx(5e6, rel=0.1)
    assert f.fit["holdout_after"] < 0.5 * f.fit["holdout_before"]
    assert "rear attachment" in f.explanation and "N/m" in f.explanation


def test_a_finding_fitted_before_a_sensor_fault_is_refitted_once_the_fault_is_found(bodies):
    """The left rear attachment on a 5e6 N/m spring and channel ARHBZ (at that attachment) reading 1.25
    times its acceleration: the support is fitted first, against the faulty channel, then the gain. The
    single structural finding is refitted with the gain in place (the final refit runs and is adopted),
    and the stiffness stays within 3 % of the truth, the gain within 2 %."""
    truth = {"vertical_stiffness_n_per_m": 5e6, "damping_time_s": 2e-4}
    train, hold = _recordings(
        bodies,
        (
            Augment("rear_support_compliance", "rear_left", truth),
            Augment("sensor_gain", "ARHBZ", {"gain": 1.25}),
        ),
    )
    d = _diagnose(bodies, train, hold)
    found = {f.physics: f for f in d.findings}
    assert set(found) == {"rear_support_compliance", "sensor_gain"}
    k = found["rear_support_compliance"].parameters["vertical_stiffness_n_per_m"]["value"]
    assert k == pytest.approx(5e6, rel=0.03)
    assert d.metadata["final_refit"]["adopted"]
    assert found["sensor_gain"].parameters["gain"]["value"] == pytest.approx(1.25, rel=0.02)
