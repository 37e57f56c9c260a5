"""Local rational / polynomial FRF estimates against an exactly known discrete-time resonator."""

import numpy as np
import pytest
import scipy.signal as sps

from exudyn_study.errors import InputError
from exudyn_study.identify.frf import estimate_frf
from exudyn_study.identify.lpm import estimate_frf_lpm

RATE_HZ = 1000.0


def _resonator(f_n_hz=12.0, zeta=0.003):
    """Discrete-time image (matched poles) of a lightly damped SDOF: exact DTFT known."""
    wn = 2 * np.pi * f_n_hz
    pole = np.exp((-zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)) / RATE_HZ)
    a = np.real(np.poly([pole, np.conj(pole)]))
    b = np.array([0.0, 1.0, 0.5])
    return b, a


def _record(seconds=80.0, seed=0, noise=0.0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(int(seconds * RATE_HZ))
    b, a = _resonator()
    y = sps.lfilter(b, a, u)
    y = y + noise * np.std(y) * rng.standard_normal(y.size)
    return u, y, b, a


def _db(h, ref):
    return np.abs(20 * np.log10(np.abs(h) / np.abs(ref)))


def test_lpm_has_no_window_bias_at_a_lightly_damped_peak():
    u, y, b, a = _record()
    lpm = estimate_frf_lpm(u, y[None], RATE_HZ, fmin_hz=2.0, fmax_hz=60.0)
    _, exact = sps.freqz(b, a, worN=lpm.freq_hz, fs=RATE_HZ)
    err_lpm = _db(lpm.H[0, 0], exact)
    assert lpm.resolution_hz == pytest.approx(RATE_HZ / u.size)
    assert np.max(err_lpm) < 0.1, np.max(err_lpm)
    assert np.min(lpm.coherence) > 0.999
    # the Welch H1 of the same record (16 s Hann segments) is biased low at the 0.07 Hz wide peak
    welch = estimate_frf(u, y[None], RATE_HZ, resolution_hz=RATE_HZ / 16384, estimator="H1", fmax_hz=60.0)
    _, exact_w = sps.freqz(b, a, worN=welch.freq_hz, fs=RATE_HZ)
    near_peak = np.abs(welch.freq_hz - 12.0) < 0.2
    assert np.max(_db(welch.H[0, 0, near_peak], exact_w[near_peak])) > 1.0


def test_lpm_with_output_noise_stays_close_and_reports_lower_coherence():
    u, y, b, a = _record(noise=0.05, seed=3)
    lpm = estimate_frf_lpm(u, y[None], RATE_HZ, fmin_hz=5.0, fmax_hz=20.0, half_width=8)
    _, exact = sps.freqz(b, a, worN=lpm.freq_hz, fs=RATE_HZ)
    err = _db(lpm.H[0, 0], exact)
    near_peak = np.abs(lpm.freq_hz - 12.0) < 0.5
    assert np.median(err[near_peak]) < 0.2
    assert np.median(lpm.coherence[0, 0]) < 0.999


def test_lpm_bad_input():
    u, y, _, _ = _record(seconds=2.0)
    with pytest.raises(InputError, match="same length"):
        estimate_frf_lpm(u[:-1], y[None], RATE_HZ)
    with pytest.raises(InputError, match="half_width"):
        estimate_frf_lpm(u, y[None], RATE_HZ, half_width=3, degree=2)
    with pytest.raises(InputError, match="method"):
        estimate_frf_lpm(u, y[None], RATE_HZ, method="welch")
    bad = y.copy()
    bad[7] = np.nan
    with pytest.raises(InputError, match="non-finite"):
        estimate_frf_lpm(u, bad[None], RATE_HZ)


def test_polynomial_model_is_biased_at_a_narrow_peak_the_rational_one_is_not():
    u, y, b, a = _record()
    band = dict(fmin_hz=11.5, fmax_hz=12.5)
    lpm = estimate_frf_lpm(u, y[None], RATE_HZ, method="lpm", **band)
    lrm = estimate_frf_lpm(u, y[None], RATE_HZ, method="lrm", **band)
    _, exact = sps.freqz(b, a, worN=lpm.freq_hz, fs=RATE_HZ)
    assert lpm.estimator == "LPM" and lrm.estimator == "LRM"
    assert np.max(_db(lpm.H[0, 0], exact)) > 0.3
    assert np.max(_db(lrm.H[0, 0], exact)) < 1e-3
