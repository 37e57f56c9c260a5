"""Tests of the drive-signal iteration (time waveform replication) on a linear plant."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from exudyn_study.errors import InputError
from exudyn_study.recording import Recording
from exudyn_study.signals import white_noise
from exudyn_study.signals.drive_iteration import (
    DriveFRF,
    apply_inverse,
    estimate_frf,
    identify_frf,
    iterate_drive,
    regularised_inverse,
    target_from_recording,
)

FS = 204.8  # simulation rate of the thesis (Section 7.2)
DURATION_S = 40.0
CONTROL = ("ARFVZ", "ARFHZ")
# frame modes seen by the two control sensors: (frequency Hz, damping ratio, participation)
MODES = [(12.5, 0.03, (0.6, 0.4)), (17.0, 0.03, (0.3, -0.2)), (36.0, 0.035, (0.2, 0.3))]
RIG_RESONANCE = (28.0, 0.08)  # the cylinder/linkage resonance of thesis Fig. 20
TOL = 0.05  # acceptance of issue 6: below 5 % rms within 10 iterations


def _biquad(num, den):
    return sps.bilinear(num, den, FS)


def plant(with_rig: bool):
    """Drive displacement (m) -> control accelerations (m/s^2), simulated with lfilter.

    a_j = s^2 L(s) R(s) [1 + sum_m c_jm s^2 / (s^2 + 2 zeta_m w_m s + w_m^2)] d,
    L a 150 Hz low-pass (sensor), R the rig's base-excitation resonance at 28 Hz
    (absent when ``with_rig`` is False: a rigid linkage, as the MBS model).
    """
    wp = 2 * np.pi * 150.0
    base = [_biquad([wp * wp, 0, 0], [1, 2 * 0.7 * wp, wp * wp])]
    if with_rig:
        w, z = 2 * np.pi * RIG_RESONANCE[0], RIG_RESONANCE[1]
        base.append(_biquad([2 * z * w, w * w], [1, 2 * z * w, w * w]))
    modes = [
        (_biquad([1, 0, 0], [1, 2 * z * 2 * np.pi * f, (2 * np.pi * f) ** 2]), c)
        for f, z, c in MODES
    ]

    def simulate(drive):
        b = np.asarray(drive, dtype=float)
        for nb, na in base:
            b = sps.lfilter(nb, na, b)
        out = np.tile(b, (2, 1))
        for (nb, na), c in modes:
            out += np.outer(c, sps.lfilter(nb, na, b))
        return out

    def frf(f_hz):
        z = np.exp(2j * np.pi * f_hz / FS)
        h = np.ones_like(z)
        for nb, na in base:
            h *= np.polyval(nb, z) / np.polyval(na, z)
        out = np.tile(h, (2, 1))
        for (nb, na), c in modes:
            out += np.outer(c, h * np.polyval(nb, z) / np.polyval(na, z))
        return out

    return simulate, frf


@pytest.fixture(scope="module")
def measured():
    """Target: the plant with the rig resonance driven by a 3-60 Hz white noise, plus
    1 % rms measurement noise per channel."""
    simulate, _ = plant(with_rig=True)
    a = simulate(white_noise(DURATION_S, FS, seed=7))
    noise = np.random.default_rng(1).normal(size=a.shape)
    return a + 0.01 * a.std(axis=1, keepdims=True) * noise


def test_h1_recovers_the_plant_frf():
    simulate, exact = plant(with_rig=True)
    d = white_noise(DURATION_S, FS, seed=3)
    frf, coh = estimate_frf(d, simulate(d), FS, resolution_hz=0.2)
    assert frf.H.shape == (2, 1, 513) and frf.freq_hz[1] == pytest.approx(0.2)
    band = (frf.freq_hz > 4) & (frf.freq_hz < 58)
    h_true = exact(frf.freq_hz[band])
    rel = np.abs(frf.H[:, 0, band] - h_true) / np.abs(h_true)
    assert np.median(rel) < 0.01  # noise-free linear plant: H1 exact up to leakage
    assert np.quantile(rel, 0.95) < 0.08  # worst near the 3 % damped modes (0.2 Hz bins)
    # noise-free: coherence ~1 except at sharp dips (antiresonances), lost to leakage
    assert np.median(coh[:, band]) > 0.99 and np.quantile(coh[:, band], 0.05) > 0.9


def test_regularised_inverse():
    _, exact = plant(with_rig=True)
    f = np.linspace(0, FS / 2, 513)
    frf = DriveFRF(f, exact(f)[:, None, :], FS)
    inv = regularised_inverse(frf, reg=1e-3)
    assert inv.shape == (1, 2, 513)
    band = (f > 4) & (f < 58)
    # H^+ H = |H|^2 / (|H|^2 + lambda) ~ 1 in band with small reg
    prod = np.einsum("ijf,jif->f", inv, frf.H)
    assert np.all(np.abs(prod[band] - 1) < 0.02)
    assert np.all(inv[..., (f < 2.0) | (f > 61.0)] == 0)  # drive stays in band
    # stronger regularisation limits the inverse where |H| dips
    assert np.abs(regularised_inverse(frf, reg=0.5)).max() < np.abs(inv).max()
    with pytest.raises(InputError, match="reg 0"):
        regularised_inverse(frf, reg=0)
    with pytest.raises(InputError, match="band_hz"):
        regularised_inverse(frf, band_hz=(3.0, 150.0))


def test_apply_inverse_reproduces_a_band_limited_drive():
    simulate, exact = plant(with_rig=True)
    f = np.linspace(0, FS / 2, 1025)
    frf = DriveFRF(f, exact(f)[:, None, :], FS)
    d = white_noise(DURATION_S, FS, seed=5)
    d_hat = apply_inverse(regularised_inverse(frf, reg=1e-3), simulate(d))
    mid = slice(1000, -1000)
    # acceleration hides drive errors at the lowest frequencies (a ~ f^2 d); compare
    # the responses the recovered drive produces
    a, a_hat = simulate(d), simulate(d_hat)
    err = np.sqrt(np.mean((a - a_hat)[:, mid] ** 2, axis=1)) / a.std(axis=1)
    assert err.max() < 0.03


def test_iteration_converges_despite_missing_rig_resonance(measured):
    true_plant, _ = plant(with_rig=True)
    model, _ = plant(with_rig=False)  # the MBS model: rigid linkage, no 28 Hz resonance
    frf_model, _ = identify_frf(model, FS, DURATION_S, seed=3)
    res = iterate_drive(
        true_plant, measured, FS, frf=frf_model, tol=TOL, max_iter=10, control_names=CONTROL
    )
    # D_0 from the model without the resonance is far off (the thesis saw much lower
    # simulated amplitudes; here the mismatch is the other way round)
    assert res.errors[0].max() > 1.0
    assert res.converged and res.n_iterations <= 10
    assert res.errors[-1].max() < TOL
    assert res.best_error == pytest.approx(res.errors[-1].max())
    # run to the noise floor: 1 % measurement noise limits the error from below
    deep = iterate_drive(true_plant, measured, FS, frf=frf_model, tol=1e-6, max_iter=6)
    assert deep.errors[-1].max() < 0.02
    assert np.all(deep.errors[-1] > 0.008)
    assert res.as_dict()["control_channels"] == list(CONTROL)


def test_fixed_frf_diverges_above_the_missing_resonance(measured):
    """With H fixed (plain Fig. 21 scheme) the update factor 1 - H_plant/H_model leaves
    the unit disc above 28 Hz, so the error grows: why update_frf defaults to True."""
    true_plant, _ = plant(with_rig=True)
    model, _ = plant(with_rig=False)
    frf_model, _ = identify_frf(model, FS, DURATION_S, seed=3)
    res = iterate_drive(
        true_plant, measured, FS, frf=frf_model, update_frf=False, tol=TOL, max_iter=4
    )
    assert not res.converged
    assert np.all(np.diff(res.errors.max(axis=1)) > 0)
    # the best iterate is returned, not the last
    np.testing.assert_array_equal(res.drive, res.drives[0])


def test_identified_frf_converges_at_once(measured):
    true_plant, _ = plant(with_rig=True)
    res = iterate_drive(true_plant, measured, FS, tol=TOL, max_iter=10)
    assert res.n_iterations == 0 and res.converged
    assert res.errors[0].max() < 0.03


def test_bad_input(measured):
    true_plant, _ = plant(with_rig=True)
    bad = measured.copy()
    bad[1, 17] = np.nan
    with pytest.raises(InputError, match=r"non-finite value at \(channel, sample\) \(1, 17\)"):
        iterate_drive(true_plant, bad, FS)
    with pytest.raises(InputError, match="gain 2.5"):
        iterate_drive(true_plant, measured, FS, gain=2.5)
    with pytest.raises(InputError, match="simulate returned shape"):
        iterate_drive(lambda d: np.zeros((3, d.size)), measured, FS, max_iter=0)
    rec = Recording.from_arrays(measured, FS, ["ARFVZ", "ATBGZ"])
    with pytest.raises(InputError, match="control channel.s. ARFHZ missing from the recording"):
        target_from_recording(rec)
    rec = Recording.from_arrays(measured, FS, list(CONTROL))
    x, fs = target_from_recording(rec)
    assert fs == FS and np.array_equal(x, measured)
    x, fs = target_from_recording(rec, rate_hz=102.4)
    assert x.shape == (2, measured.shape[1] // 2) and fs == 102.4
