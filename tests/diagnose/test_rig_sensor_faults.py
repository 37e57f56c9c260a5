"""Sensor faults on the rig path: each is named as such, with its channel, on the mini frame.

The faults themselves (:class:`~exudyn_study.physics.sensor_faults.SensorFault`) are checked against
their definitions first: a delay is the linear phase of its FRF, a swap exchanges two rows, and the
time and frequency forms agree.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.physics.sensor_faults import SensorFault
from exudyn_study.virtual_rig import Augment, Scenario, virtual_recording

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from rig_fixtures import FRAME_SENSORS, mini_bodies  # noqa: E402

DURATION_S = 16.0
RATE_HZ = 1000.0
NAMES = ("A", "B", "C")


def _signals(n=4096, seed=1):
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, 1.0 / RATE_HZ)
    spec = rng.normal(size=(3, f.size)) + 1j * rng.normal(size=(3, f.size))
    spec[:, f > 100.0] = 0.0  # band-limited: a delay is exact on it
    spec[:, 0] = 0.0
    return np.fft.irfft(spec, n), spec, f


def test_each_fault_in_time_is_its_frequency_form():
    """For a band-limited periodic record, applying a linear fault in time equals applying it to the
    spectrum (a delay: the phase ``exp(-2 pi i f tau)``); a swap exchanges rows, a wrong axis copies one."""
    y, spec, f = _signals()
    n = y.shape[1]
    # a whole number of samples: a delay equals the circular shift of the periodic record
    delayed = SensorFault("delay", "B", value=0.005).apply(np.tile(y, 3), NAMES, RATE_HZ)[:, n : 2 * n]
    np.testing.assert_allclose(delayed[1], np.roll(y[1], 5), atol=1e-9 * np.abs(y).max())
    np.testing.assert_array_equal(delayed[[0, 2]], y[[0, 2]])
    for fault in (
        SensorFault("polarity", "A", value=1.2),
        SensorFault("swap", "A", "C"),
        SensorFault("axis", "B", "C"),
        SensorFault("dead", "C"),
    ):
        in_time = fault.apply(y, NAMES, RATE_HZ)
        in_freq = np.fft.irfft(fault.apply_frf(spec, NAMES, f), n)
        np.testing.assert_allclose(in_time, in_freq, atol=1e-12 * np.abs(y).max())
    swapped = SensorFault("swap", "A", "C").apply(y, NAMES, RATE_HZ)
    np.testing.assert_array_equal(swapped, y[[2, 1, 0]])
    np.testing.assert_array_equal(SensorFault("axis", "B", "C").apply(y, NAMES, RATE_HZ)[1], y[2])
    clipped = SensorFault("clipped", "A", value=0.5 * np.abs(y[0]).max()).apply(y, NAMES, RATE_HZ)
    assert np.abs(clipped[0]).max() == pytest.approx(0.5 * np.abs(y[0]).max())
    with pytest.raises(InputError, match="not among the channels"):
        SensorFault("dead", "X").apply(y, NAMES, RATE_HZ)
    with pytest.raises(InputError, match="other channel"):
        SensorFault("swap", "A")


def test_faults_are_offered_only_where_their_channels_carry_the_residual():
    """A model far off leaves large errors at many channels; a fault is offered at a located channel only
    if it (a swap: the pair) carries a quarter of the residual, so zeroing or delaying one channel of many
    cannot pass for an explanation of structural mismatch."""
    from exudyn_study.diagnose.rig_candidates import FAULT_MIN_SHARE, RIG_CANDIDATES, CandidateContext

    chans = ("ARFVZ", "ARHBZ", "ARFMZ")
    ctx = CandidateContext(
        model=None, lin=None, build=None, locations=[], markers={}, sensor_names=chans,
        located=list(chans), level_dependent=False, channels=chans,
        residual_share={"ARFVZ": 0.6, "ARHBZ": 0.15, "ARFMZ": 0.15},
    )
    dead = RIG_CANDIDATES["sensor_dead"].factory(ctx)
    assert [h.location for h in dead] == ["ARFVZ"] and FAULT_MIN_SHARE > 0.15
    swaps = [h.location for h in RIG_CANDIDATES["sensor_swap"].factory(ctx)]
    assert swaps == ["ARFVZ/ARHBZ", "ARFVZ/ARFMZ", "ARHBZ/ARFMZ"]  # 0.75, 0.75 and 0.3 of the residual
    ctx.residual_share = {"ARFVZ": 0.1, "ARHBZ": 0.1, "ARFMZ": 0.1}
    assert RIG_CANDIDATES["sensor_polarity"].factory(ctx) == []


def _rig_like(measured, drive, sims):
    """A problem and comparison with one training recording (the attributes the context helpers read)."""
    from types import SimpleNamespace

    from exudyn_study.diagnose.rig_compare import band_filter

    chans = tuple(f"C{k}" for k in range(measured.shape[0]))
    rec = SimpleNamespace(
        channels=chans, measured=measured, drive=SimpleNamespace(samples=drive),
        scale=1.0 / np.sqrt(np.mean(band_filter(measured) ** 2, axis=1)),
    )
    return SimpleNamespace(train_recs=[rec]), SimpleNamespace(sims_tr=[sims]), chans


def _broadband(n_ch, seconds=40.0, seed=3):
    """Drive and responses: each channel the drive through its own 2nd-order resonance (8-50 Hz)."""
    from scipy import signal

    rng = np.random.default_rng(seed)
    n = int(seconds * RATE_HZ)
    u = rng.normal(size=n)
    ys = []
    for k, f0 in enumerate(np.geomspace(8.0, 50.0, n_ch)):
        w0 = 2 * np.pi * f0
        b, a = signal.bilinear([w0**2], [1.0, 2 * 0.05 * w0, w0**2], RATE_HZ)
        ys.append((1.0 + 0.3 * k) * signal.lfilter(b, a, u))
    return u, np.array(ys)


def test_a_swap_is_found_from_the_simulations_exchanged():
    """Measured = the model's simulations with channels C1 and C4 exchanged (a swap's identity): each
    one's best partner is the other and their swap removes the whole residual of the pair; a channel the
    model gets right gains nothing from any swap. The swap factory then offers C1/C4 although C4 is not
    among the located channels (it carries its share of the residual, not a located rank)."""
    from exudyn_study.diagnose.rig_candidates import RIG_CANDIDATES, SWAP_MIN_SHARE, CandidateContext
    from exudyn_study.diagnose.rig_screen import swap_partners

    u, sims = _broadband(6)
    measured = sims.copy()
    measured[[1, 4]] = sims[[4, 1]]
    problem, comparison, chans = _rig_like(measured, u, sims)
    partner = swap_partners(problem, comparison)
    assert partner["C1"][0] == "C4" and partner["C4"][0] == "C1"
    assert partner["C1"][1] == pytest.approx(1.0, abs=1e-9) and SWAP_MIN_SHARE < 1.0
    assert partner["C0"][1] < 0.1  # the model is right there: no exchange helps
    ctx = CandidateContext(
        model=None, lin=None, build=None, locations=[], markers={}, sensor_names=chans,
        located=["C1", "C0"], level_dependent=False, channels=chans,
        residual_share={"C1": 0.6, "C4": 0.4}, swap_partner=partner,
    )
    swaps = [h.location for h in RIG_CANDIDATES["sensor_swap"].factory(ctx)]
    assert swaps == ["C1/C0", "C1/C4"]


def test_a_channel_coherent_with_the_drive_is_not_offered_as_dead():
    """A dead channel records noise: its median coherence with the drive is near the estimate's bias
    (about one over the number of Welch segments); a channel that records the structure has coherence
    near one. Only the first is offered as dead, however large the other's error."""
    from exudyn_study.diagnose.rig_candidates import DEAD_MAX_COHERENCE, RIG_CANDIDATES, CandidateContext
    from exudyn_study.diagnose.rig_screen import measured_coherence

    u, ys = _broadband(3)
    measured = ys.copy()
    measured[2] = np.random.default_rng(9).normal(scale=0.01, size=u.size)  # dead: noise only
    problem, _, chans = _rig_like(measured, u, ys)
    coh = measured_coherence(problem)
    assert coh["C0"] > 0.9 and coh["C1"] > 0.9 and coh["C2"] < 0.2 < DEAD_MAX_COHERENCE
    ctx = CandidateContext(
        model=None, lin=None, build=None, locations=[], markers={}, sensor_names=chans,
        located=list(chans), level_dependent=False, channels=chans,
        residual_share={"C0": 0.5, "C1": 0.1, "C2": 0.4}, coherence=coh,
    )
    assert [h.location for h in RIG_CANDIDATES["sensor_dead"].factory(ctx)] == ["C2"]


@pytest.fixture(scope="module")
def bodies():
    pytest.importorskip("exudyn")
    return mini_bodies()


def _diagnose(bodies, augmentations, seed=7):
    from exudyn_study.diagnose.rig import RigDiagnosisSettings, diagnose_rig

    sc = Scenario("mini", "test", variant=1, damping="constant-2", augmentations=augmentations)
    sc = sc.with_seed(seed)
    train = virtual_recording(sc, "white-noise", DURATION_S, bodies=bodies, sensors=FRAME_SENSORS)
    hold = virtual_recording(sc, "test", DURATION_S, bodies=bodies, sensors=FRAME_SENSORS)
    st = RigDiagnosisSettings(train_duration_s=12.0, screen_duration_s=8.0, max_findings=2)
    return diagnose_rig(
        1, [train], [hold], damping="constant-2", bodies=bodies, sensors=FRAME_SENSORS, settings=st
    )


@pytest.mark.parametrize(
    ("physics", "location", "params", "sensors"),
    [
        ("sensor_polarity", "ARHBZ", {"gain": 1.0}, ["ARHBZ"]),
        ("sensor_swap", "ARFVZ/ARHBZ", {}, ["ARFVZ", "ARHBZ"]),
        ("sensor_axis", "ARFVZ>ARFVY", {}, ["ARFVZ", "ARFVY"]),
        ("sensor_dead", "ARVBZ", {}, ["ARVBZ"]),
        ("sensor_delay", "ARHBZ", {"delay_s": 0.004}, ["ARHBZ"]),
    ],
)
def test_a_sensor_fault_is_named_with_its_channel(bodies, physics, location, params, sensors):
    d = _diagnose(bodies, (Augment(physics, location, params),))
    assert d.mismatch_found and d.findings, d.unexplained
    f = d.findings[0]
    assert f.physics == physics, [(g.physics, g.location) for g in d.findings]
    assert sorted(f.location["sensors"]) == sorted(sensors)
    for name, true in params.items():
        assert f.parameters[name]["value"] == pytest.approx(true, rel=0.05)
    assert f.fit["holdout_after"] < 0.5 * f.fit["holdout_before"]
    assert "sensor fault" in f.explanation
