"""The self-check after LSFD: a mode missing from the selection is found where the fit misses the data."""

import numpy as np

from exudyn_study.identify import fit_modal_model, polymax, select_modes
from exudyn_study.identify.frf import FRF
from exudyn_study.identify.polymax import modal_to_pole
from exudyn_study.identify.selfcheck import misfit_bands, self_check
from exudyn_study.identify.synthetic import pole_residue_frf

FREQ = np.array([10.0, 16.0, 23.0, 31.0])
ZETA = np.array([0.01, 0.02, 0.055, 0.008])
FREQ_RTOL = 1e-3  # noise of 0.5 % on 12 channels: the refitted pole lies well within this
DAMP_RTOL = 0.05


def _noisy_frf(seed=0) -> FRF:
    rng = np.random.default_rng(seed)
    f = np.arange(60, 800) * 0.05
    res = (rng.standard_normal((12, 1, 4)) * 20).astype(complex)
    h = pole_residue_frf(modal_to_pole(FREQ, ZETA), res, f)
    scale = 0.005 * np.sqrt(np.mean(np.abs(h) ** 2, axis=-1, keepdims=True))
    h = h + scale * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
    coh = 1 / (1 + (scale / np.maximum(np.abs(h), 1e-12)) ** 2 * 2 * 40)
    return FRF(freq_hz=f, H=h, coherence=coh, estimator="H1", resolution_hz=0.05, n_averages=40,
               outputs=tuple(f"c{i}" for i in range(12)), inputs=("F",))


def test_missing_heavily_damped_mode_is_found_and_reported():
    frf = _noisy_frf()
    band = (4.0, 39.0)
    poles = polymax(frf.H, frf.freq_hz, range(2, 41), band_hz=band)
    sel = select_modes(poles)

    def refit(p):
        return fit_modal_model(frf.H, frf.freq_hz, p, band_hz=band, estimator="H1")

    without = modal_to_pole(np.delete(FREQ, 2), np.delete(ZETA, 2))  # the 5.5 % mode left out
    report, fit, clusters = self_check(frf, refit(without), poles, sel, band, refit)
    # one mode added; the clusters stand for the four poles of the final fit, in their order
    assert len(report.added) == 1 and len(clusters) == fit.poles.size == 4 and report.removed == ()
    a = report.added[0]
    assert abs(a["frequency_hz"] / FREQ[2] - 1) < FREQ_RTOL
    assert abs(a["damping_ratio"] / ZETA[2] - 1) < DAMP_RTOL
    assert a["band_hz"][0] <= FREQ[2] <= a["band_hz"][1] and a["misfit_after"] < 0.5 * a["misfit_before"]
    assert report.poor_fit_bands_hz == ()
    # the complete model leaves nothing to add
    full = refit(modal_to_pole(FREQ, ZETA))
    report2, fit2, _ = self_check(frf, full, poles, sel, band, refit)
    assert report2.added == () and fit2 is full


def test_dropped_mode_is_not_added_back_but_reported_as_poor_fit():
    frf = _noisy_frf()
    band = (4.0, 39.0)
    poles = polymax(frf.H, frf.freq_hz, range(2, 41), band_hz=band)
    sel = select_modes(poles)

    def refit(p):
        return fit_modal_model(frf.H, frf.freq_hz, p, band_hz=band, estimator="H1")

    without = modal_to_pole(np.delete(FREQ, 2), np.delete(ZETA, 2))
    report, _, _ = self_check(frf, refit(without), poles, sel, band, refit, exclude_hz=[23.0])
    assert report.added == ()
    assert any(lo <= 23.0 <= hi for lo, hi in report.poor_fit_bands_hz)


def test_misfit_bands_finds_runs_above_threshold_worst_first():
    ratio = np.ones(50)
    ratio[10:14] = 20.0
    ratio[30:33] = 50.0
    ratio[40] = 100.0  # one line: smoothed over 3 lines it still marks a short run
    runs = misfit_bands(ratio, np.arange(50.0), threshold=8.0)
    # 3-line running mean: the 50-run widens to 29..33 (17.3 > 8 at its neighbours), the
    # 20-run does not (7.3), the single line spans 39..41; mean of the raw ratio over each
    assert [(r[0], r[1]) for r in runs] == [(39, 41), (29, 33), (10, 13)]
    np.testing.assert_allclose([r[2] for r in runs], [34.0, 30.4, 20.0])


def test_pole_without_support_in_the_data_is_removed():
    # a pole between the modes fits only noise: its residues are noise, its shape complex
    frf = _noisy_frf()
    band = (4.0, 39.0)
    poles = polymax(frf.H, frf.freq_hz, range(2, 41), band_hz=band)
    sel = select_modes(poles)

    def refit(p):
        return fit_modal_model(frf.H, frf.freq_hz, p, band_hz=band, estimator="H1", refine=False)

    extra = modal_to_pole(np.r_[FREQ, 27.0], np.r_[ZETA, 0.01])
    report, fit, clusters = self_check(frf, refit(extra), poles, sel, band, refit)
    assert [round(r["frequency_hz"]) for r in report.removed] == [27]
    assert len(clusters) == fit.poles.size == 4
    np.testing.assert_allclose(np.sort(fit.frequency_hz), FREQ, rtol=FREQ_RTOL)
