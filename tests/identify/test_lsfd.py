"""LSFD residues/shapes, the leakage model of the Welch estimate, MAC/MPC."""

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.identify import (
    Leakage,
    automac,
    estimate_frf,
    lsfd,
    mac,
    mcf,
    modal_to_pole,
    mpc,
    refine_poles,
    synthesise,
)
from exudyn_study.identify.synthetic import pole_residue_frf, table1_system


def test_lsfd_recovers_residues_and_residuals_exactly():
    sysm = table1_system(n_channels=10)
    f = np.arange(0, 60.0001, 0.2)
    r = lsfd(sysm.transmissibility(f), f, sysm.poles, band_hz=(3, 55))
    np.testing.assert_allclose(r.residues, sysm.residues(), rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(r.lower, sysm.constant(), atol=1e-8)  # constant term
    np.testing.assert_allclose(r.upper, 0, atol=1e-12)
    assert np.diag(mac(r.shapes, sysm.shapes)).min() > 1 - 1e-12
    assert r.fit_error.max() < 1e-9
    np.testing.assert_allclose(synthesise(r, f[20:40]), sysm.transmissibility(f[20:40]),
                               rtol=1e-8)
    # shapes are scaled to a unit largest component
    np.testing.assert_allclose(np.abs(r.shapes).max(axis=0), 1.0)


def test_leakage_model_predicts_welch_h1_of_a_lightly_damped_mode():
    # SDOF-like transmissibility, 0.5 % damping at 20 Hz: 2 lines per half-power
    # bandwidth at 0.5 Hz resolution. The plain pole model misses the smoothed
    # peak; the leakage-aware basis predicts the Welch H1 to within its variance.
    fs, fn, zeta = 200.0, 20.0, 0.005
    lam = modal_to_pole(fn, zeta)
    rng = np.random.default_rng(0)
    n = 2_000_000
    a = rng.standard_normal(n)
    fr = np.fft.rfftfreq(n, 1 / fs)
    resid = np.array([[[1.0j * 2 * np.pi * fn]]])
    h_full = pole_residue_frf(np.array([lam]), resid, fr)[0, 0]
    x = np.fft.irfft(np.fft.rfft(a) * h_full, n)
    est = estimate_frf(a, x, fs, resolution_hz=0.5, estimator="H1")
    band = (est.freq_hz > 15) & (est.freq_hz < 25)
    f = est.freq_hz[band]
    meas = est.H[0, 0, band]
    plain = lsfd(est.H, est.freq_hz, np.array([lam]), band_hz=(15, 25))
    leak = lsfd(est.H, est.freq_hz, np.array([lam]), band_hz=(15, 25),
                leakage=Leakage(fs, int(fs / 0.5)))
    assert leak.fit_error[0] < 0.01
    assert plain.fit_error[0] > 5 * leak.fit_error[0]
    # and refining the pole on the leaky basis returns the true damping
    p = refine_poles(est.H, est.freq_hz, np.array([modal_to_pole(fn, 2 * zeta)]),
                     band_hz=(15, 25), leakage=Leakage(fs, int(fs / 0.5)))
    z_hat = -p.real[0] / abs(p[0])
    assert z_hat == pytest.approx(zeta, rel=0.03)
    # the plain model's peak overshoots the smoothed measured peak
    assert np.abs(synthesise(plain, f)).max() > 1.1 * np.abs(meas).max()


def test_mac_and_complexity():
    rng = np.random.default_rng(1)
    q, _ = np.linalg.qr(rng.standard_normal((8, 4)))
    np.testing.assert_allclose(automac(q), np.eye(4), atol=1e-12)
    # scale invariance, including complex scaling
    np.testing.assert_allclose(mac(q, q * (2 - 3j))[1, 1], 1.0)
    real = rng.standard_normal((6, 1))
    circ = np.exp(1j * np.linspace(0, 2 * np.pi, 6, endpoint=False))[:, None]
    assert mpc(real * (1 + 1j))[0] == pytest.approx(1.0)
    assert mpc(circ)[0] == pytest.approx(0.0, abs=1e-12)
    assert mcf(real)[0] == pytest.approx(0.0)
    with pytest.raises(InputError, match=r"phi_a has 8 DOFs, phi_b 6"):
        mac(q, real)
    with pytest.raises(InputError, match=r"poles: expected finite poles in the upper half"):
        lsfd(np.ones((1, 1, 10)), np.arange(10.0), np.array([-1 - 1j]))
    with pytest.raises(InputError, match=r"frf_form 'velocity': expected one of"):
        lsfd(np.ones((1, 1, 10)), np.arange(10.0), np.array([-1 + 10j]), frf_form="velocity")


@pytest.mark.parametrize("window", ["hann", "hamming", "blackman", "boxcar"])
def test_leakage_basis_closed_form_equals_its_definition(window):
    """The closed-form leakage-aware pole term equals the DFT sum that defines it (Leakage)."""
    leak = Leakage(1000.0, 4000, window)
    poles = modal_to_pole(np.array([3.0, 15.2, 47.1, 60.0]), np.array([0.003, 0.06, 0.004, 0.2]))
    freq = np.arange(8, 300) * 0.25
    m = np.arange(leak.n_segment)
    g = 1e-3 * np.exp(poles[:, None] * (m[None, :] * 1e-3)) * leak.lag_window()[None, :]
    direct = np.fft.fft(g, axis=1)[:, np.rint(freq * 4).astype(int)].T
    closed = leak.pole_term(poles, freq)
    assert np.max(np.abs(closed - direct) / np.abs(direct)) < 1e-9
