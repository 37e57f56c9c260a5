"""Tests of the drive signals, the resampler and the PSD helper."""

from __future__ import annotations

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.signals import (
    DEFAULT_RMS_M,
    SIGNALS,
    acceleration_rms_of_flat_band,
    drive_signal,
    psd,
    rational_ratio,
    resample,
    test_signal,
    test_signal_50,
    test_signal_shape,
    white_noise,
)

FS = 1000.0
DUR = 40.0


@pytest.mark.parametrize("name", sorted(SIGNALS))
def test_band_edges_welch(name):
    x = drive_signal(name, DUR, FS, seed=3)
    f, p = psd(x, FS, resolution_hz=0.1)
    inside = np.median(p[(f > 3.5) & (f < 59.5)])
    outside = np.concatenate([p[f < 2.5], p[f > 61.0]])
    assert outside.max() < 1e-3 * inside


@pytest.mark.parametrize("name", sorted(SIGNALS))
def test_band_exact_in_the_dft(name):
    x = drive_signal(name, DUR, FS, seed=4)
    spec = np.abs(np.fft.rfft(x))
    f = np.fft.rfftfreq(x.size, 1 / FS)
    out = (f < 3.0) | (f > 60.0)
    assert spec[out].max() < 1e-12 * spec[~out].max()


def test_rms_and_reproducible():
    for fn in (white_noise, test_signal):
        x = fn(DUR, FS, rms_m=3e-4, seed=11)
        assert np.sqrt(np.mean(x**2)) == pytest.approx(3e-4, rel=1e-12)
        np.testing.assert_array_equal(x, fn(DUR, FS, rms_m=3e-4, seed=11))
        assert not np.allclose(x, fn(DUR, FS, rms_m=3e-4, seed=12))
    x = white_noise(DUR, FS)
    assert np.sqrt(np.mean(x**2)) == pytest.approx(DEFAULT_RMS_M, rel=1e-12)
    assert x.shape == (40000,)
    np.testing.assert_array_equal(
        test_signal_50(DUR, FS, seed=2), 0.5 * test_signal(DUR, FS, seed=2)
    )


def test_white_noise_is_flat_and_test_signal_boosted():
    f, p_w = psd(white_noise(80.0, FS, seed=5), FS, resolution_hz=1.0)
    band = (f >= 5) & (f <= 58)
    # flat within the scatter of a 160-segment Welch estimate
    assert p_w[band].std() / p_w[band].mean() < 0.2
    f, p_t = psd(test_signal(80.0, FS, seed=5), FS, resolution_hz=1.0)
    low = p_t[(f >= 7) & (f <= 24)].mean()
    flat = p_t[(f >= 45) & (f <= 58)].mean()
    bump = p_t[(f >= 37) & (f <= 39)].mean()
    assert low / flat == pytest.approx(10.0, rel=0.25)
    assert bump / flat > 8.0
    np.testing.assert_allclose(
        test_signal_shape(np.array([4.0, 10.0, 38.0, 50.0, 70.0])),
        [1.0, 10.0, 10.0, 1.0, 0.0],
        rtol=1e-3,
    )


def test_default_rms_is_realistic():
    # 0.25 mm rms over 3-60 Hz -> ~16 m/s^2 at the drive point (1 mm -> ~65)
    a = acceleration_rms_of_flat_band(DEFAULT_RMS_M, (3.0, 60.0))
    assert 10.0 < a < 25.0
    x = white_noise(80.0, FS, seed=1)
    acc = np.fft.irfft(
        -((2 * np.pi * np.fft.rfftfreq(x.size, 1 / FS)) ** 2) * np.fft.rfft(x), x.size
    )
    assert np.sqrt(np.mean(acc**2)) == pytest.approx(a, rel=0.02)


def test_resample_1000_to_204_8():
    assert rational_ratio(1000.0, 204.8) == (128, 625)
    assert rational_ratio(204.8, 1000) == (625, 128)
    t = np.arange(int(20 * FS)) / FS
    x = np.vstack([np.sin(2 * np.pi * 20.0 * t + 0.3), np.sin(2 * np.pi * 150.0 * t)])
    y = resample(x, FS, 204.8)
    assert y.shape == (2, 4096)
    t2 = np.arange(y.shape[1]) / 204.8
    mid = slice(200, -200)  # away from the filter's edge transients
    # in-band sine: amplitude and phase kept (no delay), error < 1e-4
    np.testing.assert_allclose(y[0, mid], np.sin(2 * np.pi * 20.0 * t2[mid] + 0.3), atol=1e-4)
    # 150 Hz is above the new Nyquist (102.4 Hz): removed, not aliased to 54.8 Hz
    assert np.abs(y[1, mid]).max() < 1e-3
    # a plain decimation would alias it at full amplitude
    assert np.abs(x[1, ::5]).max() > 0.5
    # round trip up again is consistent
    z = resample(y, 204.8, FS)
    assert z.shape[1] == x.shape[1]
    np.testing.assert_allclose(z[0, 1000:-1000], x[0, 1000:-1000], atol=2e-4)


def test_resample_axis_and_errors():
    x = np.random.default_rng(0).normal(size=(3000, 2))
    np.testing.assert_allclose(resample(x, 1000, 500, axis=0), resample(x.T, 1000, 500).T)
    with pytest.raises(InputError, match="from_hz 0"):
        resample(x, 0, 10)
    with pytest.raises(InputError, match="non-finite"):
        resample(np.array([0.0, np.nan, 1.0]), 10, 5)
    with pytest.raises(InputError, match="simpler rational ratio"):
        resample(np.zeros(10), 1000.0, 1000.0 / 3.0)


def test_psd_parseval():
    x = white_noise(DUR, FS, rms_m=1e-3, seed=9)
    f, p = psd(x, FS, resolution_hz=0.5)
    assert f[1] - f[0] == pytest.approx(0.5)
    assert np.sum(p) * 0.5 == pytest.approx(1e-6, rel=0.05)
    with pytest.raises(InputError, match="shorter than one segment"):
        psd(x[:100], FS, resolution_hz=0.2)


def test_signal_errors():
    with pytest.raises(
        InputError,
        match=r"drive signal 'pink' is unknown; expected one of white-noise, test, test-50",
    ):
        drive_signal("pink", 10.0, FS)
    with pytest.raises(InputError, match="sample_rate_hz 100.0.*> 120 Hz"):
        white_noise(10.0, 100.0)
    with pytest.raises(InputError, match="rms_m -1"):
        white_noise(10.0, FS, rms_m=-1)
    with pytest.raises(InputError, match="seed 1.5"):
        white_noise(10.0, FS, seed=1.5)
    with pytest.raises(InputError, match="duration_s 0.1"):
        white_noise(0.1, FS)
