"""Tests of rainflow counting, Basquin pseudo damage and relative pseudo damage."""

from __future__ import annotations

import json

import numpy as np
import pytest
import rainflow

from exudyn_study.errors import InputError
from exudyn_study.recording import Recording
from exudyn_study.signals import white_noise
from exudyn_study.signals.fatigue import (
    RelativeDamage,
    cycles_to_failure,
    plausibility_notes,
    pseudo_damage,
    rainflow_cycles,
    relative_pseudo_damage,
)
from exudyn_study.signals.fatigue_plots import plot_relative_pseudo_damage

# ASTM E1049-85 Section 5.4.4, Fig. 6 / Table 4: the load history and its rainflow count
ASTM_SERIES = np.array([-2.0, 1.0, -3.0, 5.0, -1.0, 3.0, -4.0, 4.0, -2.0])
ASTM_TABLE_4 = {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}  # range -> cycles


def test_astm_e1049_example():
    ranges, counts, means = rainflow_cycles(ASTM_SERIES)
    got: dict[float, float] = {}
    for r, c in zip(ranges, counts, strict=True):
        got[r] = got.get(r, 0.0) + c
    assert got == ASTM_TABLE_4
    # damage from the table by hand: sum n_i (range_i / 2)^beta
    beta = 5.0
    expected = sum(n * (r / 2) ** beta for r, n in ASTM_TABLE_4.items())
    assert pseudo_damage(ASTM_SERIES, beta) == pytest.approx(expected, rel=1e-14)
    assert expected == pytest.approx(0.5 * 1.5**5 + 1.5 * 2**5 + 0.5 * 3**5 + 4**5 + 0.5 * 4.5**5)


def test_closed_form_sine():
    a, n, beta, C = 0.37, 25, 5.0, 3.0
    t = np.arange(n * 40 + 1) / 40  # 40 samples per cycle, peaks on samples
    x = a * np.cos(2 * np.pi * t)
    assert pseudo_damage(x, beta, C) == pytest.approx(n * a**beta / C, rel=1e-12)
    # a sine starting at zero: n - 1/2 full cycles of range 2a + 2 half cycles of range a
    x = a * np.sin(2 * np.pi * t)
    exact = ((n - 0.5) * a**beta + (a / 2) ** beta) / C
    assert pseudo_damage(x, beta, C) == pytest.approx(exact, rel=1e-9)
    assert pseudo_damage(x, beta, C) == pytest.approx(n * a**beta / C, rel=1 / (2 * n))
    # damage = sum over cycles of 1/N with Basquin's N
    ranges, counts, _ = rainflow_cycles(x)
    assert np.sum(counts / cycles_to_failure(ranges / 2, beta, C)) == pytest.approx(exact)


def test_turning_points_match_rainflow_package():
    rng = np.random.default_rng(2)
    for _ in range(20):
        x = np.round(rng.normal(size=int(rng.integers(2, 400))) * 3) / 3  # plateaus
        ref = [(c[0], c[2]) for c in rainflow.extract_cycles(x)]
        r, c, _ = rainflow_cycles(x)
        assert list(zip(r.tolist(), c.tolist(), strict=True)) == [
            (float(a), float(b)) for a, b in ref
        ]


def test_pseudo_damage_shapes_and_errors():
    x = np.vstack([ASTM_SERIES, 2 * ASTM_SERIES, np.zeros(9)])
    d = pseudo_damage(x, 5.0)
    assert d.shape == (3,)
    assert d[1] == pytest.approx(2**5 * d[0]) and d[2] == 0.0
    with pytest.raises(InputError, match="beta 0.*> 0"):
        pseudo_damage(x, 0.0)
    with pytest.raises(InputError, match="beta -5"):
        pseudo_damage(x, -5)
    x[1, 4] = np.nan
    with pytest.raises(InputError, match="channel 1 has a non-finite sample at index 4"):
        pseudo_damage(x)


def rec(x, fs, names=("ARFVZ", "ARFHZ", "ASVZ"), source="x"):
    return Recording.from_arrays(np.atleast_2d(x), fs, list(names), metadata={"source": source})


def test_plus_minus_ten_percent():
    """Thesis Section 7: +-10 % amplitude gives 0.9^5 = 59.0 % and 1.1^5 = 161 %."""
    x = np.vstack([white_noise(20.0, 204.8, rms_m=1.0, seed=s) for s in range(3)])
    meas = rec(x, 204.8)
    low = relative_pseudo_damage(rec(0.9 * x, 204.8), meas, beta=5)
    high = relative_pseudo_damage(rec(1.1 * x, 204.8), meas, beta=5)
    np.testing.assert_allclose(low.ratios, 0.9**5, rtol=1e-12)
    np.testing.assert_allclose(high.ratios, 1.1**5, rtol=1e-12)
    assert round(low["ASVZ"].percent, 1) == 59.0
    assert round(high["ASVZ"].percent) == 161


def test_resampled_measurement_matches_direct_sampling():
    """A band-limited 'continuous' signal measured at 1000 Hz with extra 150 Hz content
    (above the 102.4 Hz Nyquist of 204.8 Hz) and simulated at 204.8 Hz: after
    anti-aliased resampling both are counted at the same instants and rate."""
    rng = np.random.default_rng(5)
    f = np.linspace(3.0, 60.0, 120)
    amp = rng.uniform(0.5, 1.0, f.size) / np.sqrt(f.size)
    ph = rng.uniform(0, 2 * np.pi, f.size)

    def signal(t):
        return (amp[:, None] * np.sin(2 * np.pi * f[:, None] * t + ph[:, None])).sum(0)

    t_meas = np.arange(20_000) / 1000.0
    t_sim = np.arange(4096) / 204.8
    noise = 0.5 * np.sin(2 * np.pi * 150.0 * t_meas)
    meas = rec(np.vstack([signal(t_meas) + noise]), 1000.0, names=("ARFVZ",))
    sim = rec(np.vstack([signal(t_sim)]), 204.8, names=("ARFVZ",))
    res = relative_pseudo_damage(sim, meas, beta=5)
    assert res.rate_hz == 204.8
    # edges excluded by the filter transient are a small share of 20 s
    assert res["ARFVZ"].ratio == pytest.approx(1.0, abs=0.02)
    # without the 150 Hz removal the measured damage would be far higher
    d_raw = pseudo_damage(meas.channel("ARFVZ").data)
    assert d_raw > 3 * res["ARFVZ"].damage_measured


def test_channel_set_errors_and_json():
    x = np.vstack([white_noise(5.0, 204.8, rms_m=1.0, seed=s) for s in range(3)])
    sim = rec(x, 204.8)
    meas = rec(x[:2], 204.8, names=("ARFVZ", "ATBGZ"))
    with pytest.raises(
        InputError,
        match="recordings have different channel sets: only in simulated: ARFHZ, ASVZ, "
        "only in measured: ATBGZ",
    ):
        relative_pseudo_damage(sim, meas)
    with pytest.raises(InputError, match="channel.s. ASVZ missing from the measured recording"):
        relative_pseudo_damage(sim, meas, channels=["ARFVZ", "ASVZ"])
    with pytest.raises(InputError, match="beta 0"):
        relative_pseudo_damage(sim, sim, beta=0)
    with pytest.raises(InputError, match=r"rate_hz 500.*<= 204.8 Hz"):
        relative_pseudo_damage(sim, sim, rate_hz=500)
    res = relative_pseudo_damage(sim, meas, channels=["ARFVZ"])
    assert res["ARFVZ"].ratio == pytest.approx(1.0, rel=1e-12)
    data = json.loads(res.to_json())
    assert set(data["channels"]["ARFVZ"]) == {
        "pseudo_damage_simulated",
        "pseudo_damage_measured",
        "relative_pseudo_damage",
    }
    assert data["beta"] == 5.0 and data["rate_hz"] == 204.8
    assert data["notes"] == []
    with pytest.warns(UserWarning, match="pseudo damage grows with the duration"):
        short = relative_pseudo_damage(rec(x[:, :500], 204.8), sim)
    assert "scaled by about" in short.notes[0]


def test_plausibility_notes_name_the_channels_far_off_and_their_amplitude_ratio():
    # relative damage 1e4 at beta 5 is an rms amplitude ratio of 1e4 ** 0.2 = 6.3
    notes = plausibility_notes(["A", "B", "C"], [1.0, 1e4, 0.5], 5.0, 60.0, 60.0)
    assert len(notes) == 1
    assert "1 of 3 channel(s) off by more than x100 (B)" in notes[0]
    assert "amplitude ratio of about 6.3" in notes[0]
    assert plausibility_notes(["A"], [99.0], 5.0, 60.0, 60.0) == ()
    assert plausibility_notes(["A"], [1 / 101], 5.0, 60.0, 60.0)[0].startswith("1 of 1")
    (length,) = plausibility_notes(["A"], [1.0], 5.0, 10.0, 120.0)
    assert "scaled by about 0.0833" in length


def test_plot(tmp_path):
    x = np.vstack([white_noise(5.0, 204.8, rms_m=1.0, seed=s) for s in range(3)])
    meas = rec(x, 204.8)
    cases = {
        "Adams default": relative_pseudo_damage(
            rec(np.array([[4.0], [1.2], [9.0]]) * x, 204.8), meas
        ),
        "STEP 16.6-100 %": relative_pseudo_damage(
            rec(np.array([[1.05], [0.9], [0.5]]) * x, 204.8), meas
        ),
        "suggested": relative_pseudo_damage(rec(np.array([[1.0], [1.0], [1.2]]) * x, 204.8), meas),
    }
    out = plot_relative_pseudo_damage(cases, tmp_path / "damage.png", title="Model 1, white noise")
    assert out.stat().st_size > 10_000
    assert isinstance(cases["suggested"], RelativeDamage)
    with pytest.raises(InputError, match="not in the result"):
        plot_relative_pseudo_damage(cases, tmp_path / "d.png", channels=["ATBGZ"])
