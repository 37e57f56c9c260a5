"""The explain stage of the rig diagnosis: what is left unexplained, precisely."""

from __future__ import annotations

import numpy as np

from exudyn_study.diagnose.rig_compare import BANDS_HZ, SignificanceMap
from exudyn_study.diagnose.rig_explain import residual_carriers, unexplained_entry

CHANNELS = tuple(f"S{i}" for i in range(6))


def _map(effect):
    effect = np.asarray(effect, dtype=float)
    sig = effect > 0.01
    return SignificanceMap(CHANNELS, BANDS_HZ, np.where(sig, 10.0, 0.0), effect, sig, 40, 4.0)


def test_the_smallest_set_of_sensors_and_the_band_that_carry_the_residual():
    """Two channels carry almost all of the coherent residual in two adjacent bands; four others are
    barely significant across the band. The carriers are those two channels and those two bands, though
    all six are significant over the whole band."""
    n_b = len(BANDS_HZ)
    effect = np.full((6, n_b), 0.02)
    effect[2, 3] = effect[4, 3] = 0.5
    effect[2, 4] = effect[4, 4] = 0.3
    m = _map(effect)
    rows, (j0, j1) = residual_carriers(m.significant, [m])
    assert sorted(rows) == [2, 4] and (j0, j1) == (3, 4)
    u = unexplained_entry(m.significant, CHANNELS, False, "nothing fits", [m], [("added_mass@S2", 0.42)])
    assert sorted(u["location"]["sensors"]) == ["S2", "S4"]
    assert u["band_hz"] == [BANDS_HZ[3][0], BANDS_HZ[4][1]]
    assert u["all_sensors"] == list(CHANNELS)
    assert u["best_places"] == [{"candidate": "added_mass@S2", "share": 0.42}]
    assert "added_mass@S2 (42 % of the residual)" in u["explanation"]
    # a second recording whose residual sits elsewhere takes its share: the larger of the two per cell
    effect2 = np.zeros((6, n_b))
    effect2[0, 0] = 2.0
    rows2, (j0, j1) = residual_carriers(m.significant | _map(effect2).significant, [m, _map(effect2)])
    assert rows2 == [0] and (j0, j1) == (0, 0)


def test_a_tuned_mass_damper_without_a_resonance_is_flagged():
    """A 15 kg resonator tuned to 12.4 Hz: at 40 % damping its dynamic stiffness never exceeds 1.7 times
    the mass's own (no resonance; at 8 % it peaks at over 6 times), and from three times its tuning up it
    dissipates within 20 % of a dashpot to ground with its damper, so a dashpot near it explains the data
    as well. Its finding says so at 40 % and not at 8 %."""
    from types import SimpleNamespace

    from exudyn_study.diagnose.rig_explain import make_finding
    from exudyn_study.diagnose.rig_places import element_mu

    m, f_t, zeta = 15.0, 12.4, 0.4
    omega, w_t = 2 * np.pi * np.linspace(3.0, 60.0, 2000), 2 * np.pi * f_t

    def peak(z):
        return np.max(np.abs(element_mu(omega, m, frequency_hz=f_t, damping_ratio=z)) / (omega**2 * m))

    assert peak(zeta) < 1.7 and peak(0.08) > 6.0
    high = omega[omega >= 3 * w_t]
    tmd = element_mu(high, m, frequency_hz=f_t, damping_ratio=zeta)
    dashpot = element_mu(high, stiffness_n_per_m=m * w_t**2, damping_n_s_per_m=2 * zeta * m * w_t)
    assert np.max(np.abs(tmd.imag / dashpot.imag - 1)) < 0.2
    names, units = ("mass_kg", "frequency_hz", "damping_ratio"), ("kg", "Hz", "1")
    h = SimpleNamespace(
        physics="tuned_mass_damper", names=names, units=units, sensors=(), component="chassis", interface=None
    )
    fit = dict(train_before=1.0, train_after=0.1, holdout_before=1.0, holdout_after=0.1, metric="-")

    def flags(z):
        p, std = np.array([m, f_t, z]), np.array([0.1, 0.01, 0.001])
        return make_finding(h, p, std, np.zeros(3, bool), (), (3.0, 60.0), False, "", fit).flags

    assert any("no resonance of its own" in t for t in flags(zeta))
    assert not any("no resonance" in t for t in flags(0.08))


def test_a_tuned_mass_damper_tuned_above_the_band_is_flagged():
    """A 4.5 kg resonator tuned to 67 Hz, above the 60 Hz band: in the band its dynamic stiffness is that
    of a point mass of ``m / (1 - (f / f_t)^2)`` within 2 % (damping 1 %), growing from 4.5 to 23 kg at
    60 Hz, and its finding says so; tuned to 40 Hz it is not flagged for it."""
    from types import SimpleNamespace

    from exudyn_study.diagnose.rig_explain import make_finding
    from exudyn_study.diagnose.rig_places import element_mu

    m, f_t = 4.5, 67.0
    f = np.linspace(3.0, 60.0, 200)
    omega = 2 * np.pi * f
    apparent = m / (1 - (f / f_t) ** 2)
    mu = element_mu(omega, m, frequency_hz=f_t, damping_ratio=0.01)
    np.testing.assert_allclose(np.abs(mu), omega**2 * apparent, rtol=0.02)
    names, units = ("mass_kg", "frequency_hz", "damping_ratio"), ("kg", "Hz", "1")
    h = SimpleNamespace(
        physics="tuned_mass_damper", names=names, units=units, sensors=(), component="chassis", interface=None
    )
    fit = dict(train_before=1.0, train_after=0.1, holdout_before=1.0, holdout_after=0.1, metric="-")

    def flags(tuning):
        p, std = np.array([m, tuning, 0.01]), np.array([0.1, 0.01, 0.001])
        return make_finding(h, p, std, np.zeros(3, bool), (), (3.0, 60.0), False, "", fit).flags

    assert any("above the diagnosed band" in t for t in flags(f_t))
    assert not any("above the diagnosed band" in t for t in flags(40.0))
