"""Virtual test rig: scenarios, truth files apart from recordings, the measurement chain, bad input
(mini frame)."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.virtual_rig import (
    SCENARIOS,
    THESIS_TABLE1,
    Augment,
    Scenario,
    random_scenario,
    recording_name,
    run_virtual_test,
    scenario,
    truth_name,
    virtual_recording,
)

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402


@pytest.fixture(scope="module")
def bodies():
    pytest.importorskip("exudyn")
    return mini_bodies()


def test_registry_has_none_thesis_and_one_scenario_per_effect():
    assert {"none", "thesis", "added_mass", "drive_linkage_compliance"} <= set(SCENARIOS)
    assert len(THESIS_TABLE1) == 10
    for name, sc in SCENARIOS.items():
        assert sc.description
        if name not in ("none", "thesis", "thesis-iso", "thesis-dry"):
            assert [a.physics for a in sc.augmentations] == [name]
    from exudyn_study.physics import CATALOGUE

    assert set(CATALOGUE) <= set(SCENARIOS)  # a single-effect scenario for every catalogue entry


def test_recording_and_truth_are_separate_and_the_recording_names_no_physics(bodies, tmp_path):
    sc = Scenario("mini-mass", "test", variant=1, damping="constant-2",
                  augmentations=(Augment("added_mass", "ARFVZ", {"mass_kg": 20.0}),))
    paths = run_virtual_test(sc, ["white-noise"], tmp_path, duration_s=4.0, bodies=bodies,
                             sensors=FRAME_SENSORS)
    assert [p.name for p in paths] == [recording_name("mini-mass", "white-noise")]
    truth = json.loads((tmp_path / truth_name("mini-mass")).read_text())
    assert truth["augmentations"][0]["physics"] == "added_mass"
    from exudyn_study.recording import read_recording

    rec = read_recording(paths[0])
    text = json.dumps(dict(rec.metadata))
    assert "added_mass" not in text and "mass_kg" not in text
    assert rec.drive.sample_rate_hz == pytest.approx(204.8)
    assert {ch.name for ch in rec if ch.role == "response"} == set(FRAME_SENSORS)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary files left


def test_measured_recording_differs_from_the_ideal_by_the_chain_only(bodies):
    """'none' on the mini frame: the noise floor of the measured channels is the sensor noise density."""
    from exudyn_study.virtual_rig.measurement import ServoParameters

    sc = Scenario("mini-none", "test", variant=1, damping="constant-2",
                  servo=ServoParameters(tracking_noise_rms_m=0.0))
    rec = virtual_recording(sc, "white-noise", 8.0, bodies=bodies, sensors=FRAME_SENSORS)
    quiet = virtual_recording(dataclasses.replace(sc, rms_m=1e-9), "white-noise", 8.0, bodies=bodies,
                              sensors=FRAME_SENSORS)
    from scipy import signal as sps

    x = quiet.channel("ARFMZ").data
    f, p = sps.welch(x, 1000.0, nperseg=1024)
    band = (f > 150) & (f < 350)
    density = np.sqrt(np.median(p[band]))
    assert density == pytest.approx(sc.acquisition.noise_density, rel=0.2)
    assert np.std(rec.channel("ARFMZ").data) > 100 * np.std(x)


def test_level_scales_a_linear_truth(bodies):
    from exudyn_study.virtual_rig.measurement import AcquisitionParameters, ServoParameters

    sc = Scenario("mini-none", "test", variant=1, damping="constant-2",
                  servo=ServoParameters(tracking_noise_rms_m=0.0),
                  acquisition=AcquisitionParameters(noise_density=0.0))
    a = virtual_recording(sc, "test", 4.0, level=1.0, bodies=bodies, sensors=FRAME_SENSORS)
    b = virtual_recording(sc, "test", 4.0, level=0.5, bodies=bodies, sensors=FRAME_SENSORS)
    ya, yb = a.channel("ARFVZ").data, b.channel("ARFVZ").data
    assert np.std(ya - 2 * yb) < 3e-5 * np.std(ya)  # quantisation (24 bit) only


def test_bad_input(bodies, tmp_path):
    with pytest.raises(InputError, match=r"scenario 'nope' is unknown; expected one of \["):
        scenario("nope")
    bad = Scenario("x", "x", augmentations=(Augment("sloshy", None, {}),))
    with pytest.raises(InputError, match="physics entry 'sloshy' is unknown"):
        bad.validate()
    out_of_bounds = Scenario("x", "x", augmentations=(Augment("added_mass", "ARFVZ", {"mass_kg": 1e6}),))
    with pytest.raises(InputError, match=r"mass_kg = 1000000.0 kg; expected a value in \[0.01, 500\] kg"):
        run_virtual_test(out_of_bounds, ["white-noise"], tmp_path, duration_s=2.0, bodies=bodies,
                         sensors=FRAME_SENSORS)
    with pytest.raises(InputError, match="signal 'pink' is unknown"):
        virtual_recording(Scenario("x", "x"), "pink", 2.0, bodies=bodies, sensors=FRAME_SENSORS)
    with pytest.raises(InputError, match="directory does not exist"):
        run_virtual_test("none", ["white-noise"], tmp_path / "missing")
    assert list(tmp_path.iterdir()) == []


def test_blind_scenarios_are_reproducible_and_opaque():
    from exudyn_study.physics import CATALOGUE
    from exudyn_study.virtual_rig import BLIND_EFFECTS

    if not set(BLIND_EFFECTS) <= set(CATALOGUE):
        pytest.skip(f"catalogue entries {sorted(set(BLIND_EFFECTS) - set(CATALOGUE))} not implemented yet")
    a, b = random_scenario(3), random_scenario(3)
    assert a == b and a.name == "blind-03" and a.description == "blind scenario"
    for i in range(20):
        sc = random_scenario(i)
        sc.validate()
    assert random_scenario(5, effect="none").augmentations == ()


def test_wide_blind_scenarios_mix_effects_and_keep_a_held_back_range():
    """The wide pool draws every effect kind, two effects in at least 30 % of the scenarios (never two
    sensor faults, never at one place), reproducibly; the held-back seed range draws other scenarios."""
    from exudyn_study.physics import CATALOGUE
    from exudyn_study.virtual_rig import HELD_BACK_SEED, SURFACE_REGIONS, WIDE_EFFECTS, wide_scenario

    assert set(WIDE_EFFECTS) <= set(CATALOGUE)
    dev = [wide_scenario(i) for i in range(60)]
    assert wide_scenario(7) == dev[7] and dev[7].name == "wide-007" and dev[7].description == "blind scenario"
    two = [sc for sc in dev if len(sc.augmentations) == 2]
    assert len(two) >= 0.3 * len(dev)
    for sc in two:
        a, b = sc.augmentations
        assert not (a.physics.startswith("sensor_") and b.physics.startswith("sensor_"))
        assert a.location is None or a.location != b.location
    drawn = {a.physics for sc in dev for a in sc.augmentations}
    assert drawn == set(WIDE_EFFECTS)
    # point effects anywhere on the parts' surfaces, not at the sensors the diagnosis knows
    points = [a for sc in dev for a in sc.augmentations
              if a.physics in ("added_mass", "tuned_mass_damper", "ground_spring_damper")]
    regions = [a.location.split("@")[1].rsplit(":", 1)[0] for a in points]
    assert all(a.location.startswith("chassis@") for a in points) and set(regions) <= set(SURFACE_REGIONS)
    assert len(set(regions)) >= 8
    for sc in dev[:20]:
        sc.validate()
    held = [wide_scenario(i, rng_seed=HELD_BACK_SEED) for i in range(20)]
    assert [h.augmentations for h in held] != [d.augmentations for d in dev[:20]]
    assert wide_scenario(3, effect="none").augmentations == ()
    with pytest.raises(InputError, match="wide effect 'nope' is unknown"):
        wide_scenario(1, effect="nope")


def test_cli_lists_scenarios_and_rejects_unknown(tmp_path):
    out = subprocess.run([sys.executable, "-m", "exudyn_study.cli", "virtual-test", "--scenario", "list"],
                         capture_output=True, text=True)
    assert out.returncode == 0 and "thesis" in out.stdout
    out = subprocess.run([sys.executable, "-m", "exudyn_study.cli", "virtual-test", "--scenario", "nope",
                          "--out", str(tmp_path)], capture_output=True, text=True)
    assert out.returncode == 2 and "scenario 'nope' is unknown" in out.stderr
