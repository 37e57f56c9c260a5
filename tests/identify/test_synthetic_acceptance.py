"""Synthetic base-excited test with the thesis Table 1 modes (issue 4 acceptance)."""

import warnings

import numpy as np
import pytest

from exudyn_study.identify import identify, mac
from exudyn_study.identify.synthetic import simulate, table1_system

# acceptance tolerances of issue 4 (Hv, 0.2 Hz resolution, 2 % noise)
FREQ_RTOL = 0.002  # |df| <= 0.2 %
DAMP_RTOL = 0.08  # |dzeta| <= 8 % relative
MAC_MIN = 0.99


def _check(res, sysm):
    got_f = res.model.frequency_hz
    assert got_f.size == sysm.frequency_hz.size, got_f  # all ten, no spurious
    df = got_f / sysm.frequency_hz - 1
    dz = res.model.damping_ratio / sysm.damping_ratio - 1
    m = np.diag(mac(res.model.shapes(sysm.names), sysm.shapes))
    assert np.abs(df).max() <= FREQ_RTOL, df
    assert np.abs(dz).max() <= DAMP_RTOL, dz
    assert m.min() >= MAC_MIN, m
    # uncertainties are reported and plausible (spread over orders, not zero)
    assert all(0 < mo.frequency_std_hz < 0.01 * mo.frequency_hz for mo in res.model.modes)
    return df, dz, m


def test_table1_base_excited_hv_80s_fast():
    # 20 channels (the issue asks for 20+), 80 s at 1000 Hz, 2 % noise on all channels
    sysm = table1_system(n_channels=20)
    ref, resp = simulate(sysm, 80.0, noise=0.02, seed=11)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the resolution warning is expected
        res = identify(ref, resp, 1000.0, outputs=sysm.names, inputs=("ARFVZ",),
                       band_hz=(3, 50), resolution_hz=0.2, estimator="Hv",
                       orders=range(2, 51))
    _check(res, sysm)
    # the lightest mode spans ~2.5 lines at 0.2 Hz and must be flagged, with a suggestion
    assert "47.5" in res.warnings[0] or "47.6" in res.warnings[0]
    assert "(2.5 lines)" in res.warnings[0] and res.warnings[1].startswith("suggested")


@pytest.mark.slow
@pytest.mark.parametrize("duration", [80.0, 300.0])
@pytest.mark.parametrize("estimator", ["H1", "H2", "Hv"])
def test_table1_base_excited_all_estimators(duration, estimator):
    sysm = table1_system(n_channels=36)
    ref, resp = simulate(sysm, duration, noise=0.02, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        res = identify(ref, resp, 1000.0, outputs=sysm.names, inputs=("ARFVZ",),
                       band_hz=(3, 50), resolution_hz=0.2, estimator=estimator)
    _check(res, sysm)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(1, 11))
def test_table1_hv_80s_seed_sweep(seed):
    # robustness of the acceptance over the excitation/noise realisation: ten seeds of the
    # 80 s test on all 36 channels (the damping scatter of the weighted fit at 80 s is
    # 2-4 % rms for the modes with fewest lines, see benchmarks/bench_identify.py --sweep)
    sysm = table1_system(n_channels=36)
    ref, resp = simulate(sysm, 80.0, noise=0.02, seed=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        res = identify(ref, resp, 1000.0, outputs=sysm.names, inputs=("ARFVZ",),
                       band_hz=(3, 50), resolution_hz=0.2, estimator="Hv")
    _check(res, sysm)
