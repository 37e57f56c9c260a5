"""Close modes re-identified on the local-rational FRF of the whole record (identify.local).

References: the known poles and shapes of synthetic systems, the exact transmissibility.
"""

import warnings

import numpy as np
import pytest

from exudyn_study.errors import InputError
from exudyn_study.identify import identify, mac
from exudyn_study.identify.local import PAIR_LINES, fine_frf, trouble_bands
from exudyn_study.identify.synthetic import BaseExcitedSystem, simulate

FREQ_RTOL = 2e-3  # the issue's |df| <= 0.2 %
DAMP_RTOL = 0.10  # |dzeta| <= 10 %
MAC_MIN = 0.99


def _system(freq, zeta, n_out=12, seed=3):
    rng = np.random.default_rng(seed)
    phi = rng.standard_normal((n_out, len(freq)))
    phi /= np.max(np.abs(phi), axis=0, keepdims=True)
    names = tuple(f"R{i:02d}Z" for i in range(n_out))
    return BaseExcitedSystem(np.array(freq, float), np.array(zeta, float), phi,
                             rng.uniform(0.5, 1.5, len(freq)), np.ones(n_out), names, ("Z",) * n_out,
                             np.zeros((n_out, 3)), reference="BASEZ")


def test_trouble_bands_group_close_modes_and_poor_fit():
    fr = [10.0, 10.05, 20.0, 30.0]
    ze = [0.01, 0.01, 0.01, 0.01]
    res = 0.02  # 10 and 10.05 Hz are 2.5 lines apart, the rest far
    bands = trouble_bands(fr, ze, res, (2.0, 50.0), poor_fit_bands_hz=[(29.5, 29.7)])
    assert len(bands) == 2
    pair, poor = bands
    assert pair.trouble_hz == (10.0, 10.05) and "2.5 lines" in pair.reason
    # margin: three half-power bandwidths of the widest mode beat its width and ten lines
    margin = 3 * 2 * 0.01 * 10.05
    assert pair.band_hz == pytest.approx((10.0 - margin, 10.05 + margin))
    assert pair.inner_hz == pytest.approx((10.0 - margin / 2, 10.05 + margin / 2))
    assert poor.trouble_hz == (29.5, 29.7) and "poor" in poor.reason
    # modes PAIR_LINES apart or more are left alone; a band is clipped to the fitted band
    assert trouble_bands([10.0, 10.0 + PAIR_LINES * res], ze[:2], res, (2.0, 50.0)) == []
    (edge,) = trouble_bands([2.1, 2.12], [0.01, 0.01], res, (2.0, 50.0))
    assert edge.band_hz[0] == 2.0 and edge.inner_hz[0] == 2.0


def test_trouble_bands_merge_overlapping_bands():
    (band,) = trouble_bands([10.0, 10.03, 10.5, 10.53], [0.005] * 4, 0.02, (2.0, 50.0))
    assert band.trouble_hz == (10.0, 10.53) and band.reason.count("lines apart") == 2


def test_trouble_bands_refuse_mismatched_input():
    with pytest.raises(InputError, match="damping_ratio"):
        trouble_bands([10.0, 11.0], [0.01], 0.1, (2.0, 50.0))
    with pytest.raises(InputError, match="resolution_hz"):
        trouble_bands([10.0], [0.01], 0.0, (2.0, 50.0))


def test_fine_frf_is_the_transmissibility_at_the_record_resolution():
    system = _system([10.0, 10.1, 25.0], [0.004, 0.008, 0.02], n_out=4)
    fs, duration = 1000.0, 61.434  # a length with a large prime factor: shortened to 2^a 3^b 5^c
    ref, resp = simulate(system, duration, noise=0.0, excitation_band_hz=(3.0, 60.0), seed=2)
    frf = fine_frf(ref, resp, fs, (9.0, 11.0), outputs=system.names)
    n_used = int(round(fs / frf.resolution_hz))
    assert n_used <= ref.shape[1] and n_used >= 0.97 * ref.shape[1]
    assert frf.estimator == "LRM" and frf.freq_hz[0] < 9.0 and frf.freq_hz[-1] > 11.0
    exact = system.transmissibility(frf.freq_hz)
    err = np.abs(frf.H - exact) / np.abs(exact)
    # the shortened record is no longer periodic: the local model's transient term takes the
    # leakage; what stays is the local model's bias at the two peaks 0.1 Hz apart
    assert np.median(err) < 1e-3 and np.max(err) < 0.05


def test_close_pair_below_one_line_of_the_chosen_resolution_is_separated():
    # 60 s: the automatic resolution keeps 12 averages, about 0.11 Hz, and the pair 0.08 Hz
    # apart is less than a line apart; the whole record's lines are 0.017 Hz apart
    system = _system([6.0, 10.0, 10.08, 17.0, 31.0], [0.012, 0.004, 0.009, 0.03, 0.01])
    ref, resp = simulate(system, 60.0, noise=0.02, excitation_band_hz=(3.0, 45.0), seed=5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        res = identify(ref, resp, 1000.0, outputs=system.names, inputs=("BASEZ",))
    m = res.model
    assert res.frf.resolution_hz > 0.08  # the Welch FRF cannot separate the pair
    assert len(m) == 5
    shapes = m.shapes(system.names)
    for k, (f, z) in enumerate(zip(system.frequency_hz, system.damping_ratio, strict=True)):
        j = int(np.argmin(np.abs(m.frequency_hz - f)))
        assert m.frequency_hz[j] == pytest.approx(f, rel=FREQ_RTOL)
        assert m.damping_ratio[j] == pytest.approx(z, rel=DAMP_RTOL)
        assert mac(shapes[:, j], system.shapes[:, k])[0, 0] >= MAC_MIN
    (entry,) = m.metadata["local_refinement"]
    assert entry["band_hz"][0] < 10.0 < 10.08 < entry["band_hz"][1]
    assert entry["resolution_hz"] == pytest.approx(1000.0 / int(round(1000.0 / entry["resolution_hz"])))
    assert entry["resolution_hz"] < 1.0 / 58.0 and entry["chosen"] in ("refit", "re-identification")
    assert len(res.fit.poles) == len(m)  # the result's fit carries the final poles


def test_explicit_resolution_is_kept_as_given():
    system = _system([10.0, 10.08, 20.0], [0.004, 0.009, 0.01], n_out=6)
    ref, resp = simulate(system, 60.0, noise=0.02, excitation_band_hz=(3.0, 45.0), seed=5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        res = identify(ref, resp, 1000.0, resolution_hz=0.2, band_hz=(5.0, 30.0))
    assert "local_refinement" not in res.model.metadata
