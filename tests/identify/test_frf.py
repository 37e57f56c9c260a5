"""FRF estimators against closed-form expectations."""

import numpy as np
import pytest
import scipy.signal

from exudyn_study.errors import InputError
from exudyn_study.identify import estimate_frf

FS = 200.0


def _white(n, seed, rows=1):
    return np.random.default_rng(seed).standard_normal((rows, n))


def test_fir_system_all_estimators_match_exact_response():
    # a short FIR filter: its response is known in closed form and the segment
    # (1000 samples) is far longer than its memory, so leakage is negligible
    b = np.array([0.5, 1.0, -0.3, 0.2])
    f = _white(200_000, 1)
    x = scipy.signal.lfilter(b, [1.0], f, axis=1)
    for est in ("H1", "H2", "Hv"):
        r = estimate_frf(f, x, FS, resolution_hz=0.2, estimator=est)
        _, h_true = scipy.signal.freqz(b, worN=r.freq_hz, fs=FS)
        np.testing.assert_allclose(r.H[0, 0, 1:], h_true[1:], rtol=0,
                                   atol=2e-3 * np.abs(h_true).max())
        assert r.coherence[..., 1:].min() > 0.999  # DC is removed by detrending
        assert r.H.shape == (1, 1, r.freq_hz.size) and r.resolution_hz == pytest.approx(0.2)


def test_noise_bias_h1_output_h2_input():
    # classic: output noise leaves H1 unbiased and inflates |H2| by 1 + N/S;
    # input noise deflates |H1| by 1 / (1 + N/S) and leaves H2 unbiased
    gain = 2.0
    n = 400_000
    f = _white(n, 2)
    x = gain * f
    nr = 0.5  # noise rms ratio, N/S = 0.25
    noise = _white(n, 3)
    out = estimate_frf(f, x + nr * gain * noise, FS, resolution_hz=1.0, estimator="H1")
    out2 = estimate_frf(f, x + nr * gain * noise, FS, resolution_hz=1.0, estimator="H2")
    inp = estimate_frf(f + nr * noise, x, FS, resolution_hz=1.0, estimator="H1")
    inp2 = estimate_frf(f + nr * noise, x, FS, resolution_hz=1.0, estimator="H2")
    hv = estimate_frf(f + nr * noise, x + nr * gain * _white(n, 4), FS, resolution_hz=1.0,
                      estimator="Hv")
    med = lambda r: np.median(np.abs(r.H[0, 0, 1:]))  # noqa: E731
    assert med(out) == pytest.approx(gain, rel=0.01)
    assert med(out2) == pytest.approx(gain * 1.25, rel=0.01)
    assert med(inp) == pytest.approx(gain / 1.25, rel=0.01)
    assert med(inp2) == pytest.approx(gain, rel=0.01)
    # equal relative noise on both sides: Hv (total least squares) is unbiased... for
    # gain 1 only; here the noise variances are 0.25 and 0.25*4: Hv lies between
    assert med(inp) < med(hv) < med(out2)
    assert np.median(out.coherence) == pytest.approx(1 / 1.25, rel=0.02)


def test_hv_single_reference_is_geometric_mean_and_mimo_hv_is_tls():
    f = _white(40_000, 5)
    x = scipy.signal.lfilter([1.0, 0.4], [1.0, -0.5], f, axis=1) + 0.1 * _white(40_000, 6, 1)
    h1 = estimate_frf(f, x, FS, resolution_hz=1.0, estimator="H1").H[0, 0, 1:]
    h2 = estimate_frf(f, x, FS, resolution_hz=1.0, estimator="H2").H[0, 0, 1:]
    hv = estimate_frf(f, x, FS, resolution_hz=1.0, estimator="Hv").H[0, 0, 1:]
    # thesis eq. (36): phase of H1, magnitude sqrt(Gxx/Gff) = sqrt(|H1| |H2|)
    np.testing.assert_allclose(np.abs(hv), np.sqrt(np.abs(h1) * np.abs(h2)), rtol=1e-10)
    np.testing.assert_allclose(np.angle(hv), np.angle(h1), atol=1e-10)
    # the multiple-input Hv (eigenvector of the spectral matrix) with one input is the
    # total-least-squares solution (Gxx - Gff + sqrt((Gxx - Gff)^2 + 4|Gxf|^2)) / (2 Gfx)
    mimo = estimate_frf(f, x, FS, resolution_hz=1.0, estimator="Hv", mimo=True).H[0, 0, 1:]
    gff = np.mean(np.abs(_seg_fft(f)) ** 2, axis=0)[1:]
    gxx = np.mean(np.abs(_seg_fft(x)) ** 2, axis=0)[1:]
    gxf = np.mean(_seg_fft(x) * np.conj(_seg_fft(f)), axis=0)[1:]
    tls = (gxx - gff + np.sqrt((gxx - gff) ** 2 + 4 * np.abs(gxf) ** 2)) / (2 * np.conj(gxf))
    np.testing.assert_allclose(mimo, tls, rtol=1e-8)
    # two independent inputs through two gains: MIMO H1 separates them
    u = _white(100_000, 7, rows=2)
    y = np.vstack([1.5 * u[0] - 0.7 * u[1], 0.2 * u[0] + 3.0 * u[1]])
    r = estimate_frf(u, y, FS, resolution_hz=1.0, estimator="H1", mimo=True)
    np.testing.assert_allclose(np.median(r.H.real, axis=2), [[1.5, -0.7], [0.2, 3.0]],
                               atol=0.02)


def _seg_fft(x, nseg=200):
    """Hann-windowed, mean-removed segment spectra with 50 % overlap, [n_seg, n_freq]."""
    x = x[0]
    w = scipy.signal.get_window("hann", nseg)
    starts = range(0, x.size - nseg + 1, nseg // 2)
    return np.array([np.fft.rfft((x[s:s + nseg] - x[s:s + nseg].mean()) * w) for s in starts])


def test_frf_bad_input():
    f = _white(10_000, 8)
    x = f.copy()
    bad = x.copy()
    bad[0, 1234] = np.nan
    with pytest.raises(InputError, match=r"response: 1 non-finite samples .*sample 1234"):
        estimate_frf(f, bad, FS)
    with pytest.raises(InputError, match=r"record of 50 s is too short for resolution 0.04 Hz: 4 "
                       r"averages of 25 s segments"):
        estimate_frf(f, x, FS, resolution_hz=0.04)
    with pytest.raises(InputError, match=r"estimator 'H3': expected one of H1, H2, Hv"):
        estimate_frf(f, x, FS, estimator="H3")
    with pytest.raises(InputError, match=r"references .* are coherent"):
        estimate_frf(np.vstack([f, 2 * f]), x, FS, resolution_hz=1.0, mimo=True)
    with pytest.raises(InputError, match=r"reference has 10000 samples, response 9999"):
        estimate_frf(f, x[:, :-1], FS)
