"""Settings chosen from the data: the excited band of the reference and the FRF resolution."""

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.identify.pipeline import excited_band
from exudyn_study.identify.resolution import (
    FIT_LINES,
    MIN_AVERAGES,
    PAIR_LINES,
    choose_resolution,
    first_pass_resolution,
)


@pytest.mark.parametrize("lo, hi", [(3.0, 60.0), (7.5, 120.0)])
def test_excited_band_of_band_limited_noise(lo, hi):
    fs, n = 1000.0, 100_000
    rng = np.random.default_rng(1)
    f = np.fft.rfftfreq(n, 1 / fs)
    spec = np.where((f >= lo) & (f <= hi), rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size), 0)
    x = np.fft.irfft(spec, n)
    x += 0.03 * x.std() * rng.standard_normal(n)  # 3 % measurement noise
    a, b = excited_band(x, fs, 0.5)
    # within a line or two of the edges (the Hann window smears each edge by two lines)
    assert abs(a - lo) <= 1.0 and abs(b - hi) <= 1.0


def test_excited_band_refuses_a_pure_tone():
    t = np.arange(20_000) / 1000.0
    with pytest.raises(InputError, match="fewer than 8 spectral lines"):
        excited_band(np.sin(2 * np.pi * 10 * t), 1000.0, 0.5)


def test_resolution_from_narrowest_bandwidth_and_closest_pair():
    duration = 600.0  # long enough that the averages do not limit
    # narrowest bandwidth 2 * 0.005 * 20 = 0.2 Hz -> 0.2 / 2.5 = 0.08 -> 0.05 Hz (1-2-5 below)
    adv = choose_resolution([20.0, 40.0], [0.005, 0.02], duration)
    assert adv.feasible and adv.resolution_hz == pytest.approx(0.05)
    assert adv.lines == pytest.approx(0.2 / 0.05) and adv.lines >= FIT_LINES
    # a pair 0.09 Hz apart asks for 0.09 / 3 = 0.03 -> 0.02 Hz
    adv = choose_resolution([20.0, 20.09], [0.02, 0.02], duration)
    assert adv.resolution_hz == pytest.approx(0.02) and 0.09 / adv.resolution_hz >= PAIR_LINES


def test_resolution_limited_by_the_averages_of_a_short_record():
    duration = 60.0
    adv = choose_resolution([20.0], [0.001], duration)  # would need 0.016 Hz
    assert not adv.feasible and adv.n_averages >= MIN_AVERAGES
    # the finest that keeps MIN_AVERAGES with 50 % overlap: (1 + 11 * 0.5) / 60 s
    assert adv.resolution_hz == pytest.approx((1 + (MIN_AVERAGES - 1) * 0.5) / duration)
    # and the survey pass keeps 30 averages at a 1-2-5 resolution
    survey = first_pass_resolution(duration)
    assert survey >= (1 + 29 * 0.5) / duration and 1 + int((duration * survey - 1) / 0.5) >= 30
