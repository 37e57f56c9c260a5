"""Close modes re-identified locally at the record's own resolution (local rational method).

The automatic resolution keeps :data:`~exudyn_study.identify.resolution.MIN_AVERAGES` Welch
averages, so on a short record it cannot separate every close pair: two modes 0.07 Hz apart
on a 61 s record are 0.7 lines apart at the 0.107 Hz that 12 averages allow, and the fit
returns one broad mode, a wrong damping and mixed shapes, or a pole between the two. Fewer
averages give finer lines but more variance and more window bias; the local rational method
(:func:`~exudyn_study.identify.lpm.estimate_frf_lpm`) takes one DFT of the whole record
instead, its lines are ``1 / T`` apart (0.016 Hz for 61 s: the same pair 4.4 lines apart),
and its local model removes the leakage without a window.

Where the identification shows a close pair (two modes fewer than :data:`PAIR_LINES` lines
apart) or a band the self-check could not fit, that band, widened by a margin, is
identified again on the local-rational FRF, two ways:

- the modes the identification found there, their poles refined and residues refitted on
  the fine FRF (``'refit'``);
- an identification from scratch on the fine FRF (PolyMAX, selection, LSFD, self-check,
  :func:`~exudyn_study.identify.pipeline.identify_frf`) (``'re-identification'``).

The one with the lower Akaike criterion on the fine FRF (the misfit weighted by the noise of
the estimate, :func:`~exudyn_study.identify.frf.frf_weights`, plus twice the number of real
parameters: a pole has two, a mode's residues two per channel and reference) replaces the
modes in the inner part of the band; the margin only holds the neighbours the fit needs.
What was refined, why, at which resolution and with which result goes to the metadata.

References
----------
McKelvey, T., Guérin, G. (2012). Non-parametric frequency response estimation using a local
rational model. IFAC Proceedings 45(16), 49-54.

Akaike, H. (1974). A new look at the statistical model identification. IEEE Trans. Automatic
Control 19(6), 716-723.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify.frf import FRF, frf_weights
from exudyn_study.identify.lpm import estimate_frf_lpm
from exudyn_study.identify.lsfd import fit_modal_model
from exudyn_study.identify.mac import mpc
from exudyn_study.identify.model import ModalModel, Mode
from exudyn_study.identify.polymax import modal_to_pole
from exudyn_study.identify.resolution import fft_friendly_resolution

__all__ = ["PAIR_LINES", "LocalBand", "trouble_bands", "fine_frf", "refine_locally"]

#: modes closer than this many lines of the fitted FRF are re-identified on the fine FRF
PAIR_LINES = 3.0
#: half-width (lines each side) and degree of the local rational model of the fine FRF: 15
#: lines for 8 parameters leave 7 for the noise estimate the fit weights come from
LRM_HALF_WIDTH = 6
LRM_DEGREE = 2
#: highest PolyMAX order of the local re-identification (a local band holds a few modes)
LOCAL_MAX_ORDER = 40


@dataclass(frozen=True)
class LocalBand:
    """A band to re-identify on the fine FRF.

    Attributes
    ----------
    trouble_hz : (float, float)
        The modes or the misfit that asked for it (Hz).
    band_hz : (float, float)
        The fitted band: ``trouble_hz`` widened by the margin (Hz).
    inner_hz : (float, float)
        The part whose modes are replaced: ``trouble_hz`` widened by half the margin (Hz).
    reason : str
        Why: the close pair or the misfit band.
    """

    trouble_hz: tuple[float, float]
    band_hz: tuple[float, float]
    inner_hz: tuple[float, float]
    reason: str


def trouble_bands(frequency_hz, damping_ratio, resolution_hz: float, band_hz: tuple[float, float],
                  *, poor_fit_bands_hz: Sequence[tuple[float, float]] = (),
                  pair_lines: float = PAIR_LINES) -> list[LocalBand]:
    """Return the bands whose modes a finer resolution should re-identify.

    A band is made of every run of modes whose neighbours lie fewer than ``pair_lines``
    lines apart, and of every band the self-check left poorly fitted. It is widened by a
    margin of the larger of its width, three half-power bandwidths of its widest mode and
    ten lines; overlapping bands are merged. A mode outside whose peak reaches into the band
    (within two of its half-power bandwidths) is then taken in with one bandwidth beyond it.

    Parameters
    ----------
    frequency_hz, damping_ratio : array_like
        The identified modes (Hz, -).
    resolution_hz : float
        Line spacing of the FRF they were fitted to (Hz).
    band_hz : (float, float)
        The fitted band (Hz); the bands are clipped to it.
    poor_fit_bands_hz : sequence of (float, float), optional
        Bands the self-check could not fit (Hz).
    pair_lines : float, optional
        Spacing in lines below which two modes count as a close pair (default
        :data:`PAIR_LINES`).

    Returns
    -------
    list of LocalBand
        By ascending frequency.
    """
    fr = np.asarray(frequency_hz, float)
    ze = np.asarray(damping_ratio, float)
    if fr.shape != ze.shape:
        raise InputError(f"frequency_hz of shape {fr.shape}, damping_ratio {ze.shape}: expected equal")
    if not (np.isfinite(resolution_hz) and resolution_hz > 0):
        raise InputError(f"resolution_hz={resolution_hz!r}: expected a positive number in Hz")
    order = np.argsort(fr)
    fr, ze = fr[order], ze[order]
    raw = []  # (lo, hi, reason)
    close = np.flatnonzero(np.diff(fr) < pair_lines * resolution_hz)
    for k in close:
        raw.append((fr[k], fr[k + 1], f"modes at {fr[k]:.3f} and {fr[k + 1]:.3f} Hz are "
                                      f"{(fr[k + 1] - fr[k]) / resolution_hz:.1f} lines apart"))
    for lo, hi in poor_fit_bands_hz:
        raw.append((float(lo), float(hi), f"the fit stays poor in {lo:.2f}-{hi:.2f} Hz"))
    out: list[list] = []
    for lo, hi, why in sorted(raw):
        inside = (fr >= lo) & (fr <= hi)
        widest = float(np.max(2 * ze[inside] * fr[inside])) if inside.any() else 0.0
        margin = max(hi - lo, 3 * widest, 10 * resolution_hz)
        a, b = max(band_hz[0], lo - margin), min(band_hz[1], hi + margin)
        if out and a <= out[-1][1][1]:
            prev = out[-1]
            prev[0] = (prev[0][0], max(prev[0][1], hi))
            prev[1] = (prev[1][0], max(prev[1][1], b))
            prev[2] = (prev[2][0], max(prev[2][1], min(band_hz[1], hi + margin / 2)))
            prev[3] += "; " + why
        else:
            out.append([(lo, hi), (a, b), (max(band_hz[0], lo - margin / 2),
                                           min(band_hz[1], hi + margin / 2)), why])
    bw = 2 * ze * fr
    bands = []
    for t, (a, b), i, w in out:
        # a neighbour whose peak reaches into the band belongs in its fit (the residual terms
        # stand for modes far outside, not for a 5 %-damped mode 0.2 Hz below the edge)
        while True:
            below = (fr < a) & (fr + 2 * bw > a)
            above = (fr > b) & (fr - 2 * bw < b)
            a2 = max(band_hz[0], min([a, *(fr[below] - bw[below])]))
            b2 = min(band_hz[1], max([b, *(fr[above] + bw[above])]))
            if (a2, b2) == (a, b):
                break
            a, b = a2, b2
        bands.append(LocalBand(tuple(map(float, t)), (float(a), float(b)), tuple(map(float, i)), w))
    return bands


def fine_frf(reference, response, sample_rate_hz: float, band_hz: tuple[float, float], *,
             outputs: tuple[str, ...] = (), inputs: tuple[str, ...] = ()) -> FRF:
    """Return the local-rational FRF of the whole record in ``band_hz``, lines ``1 / T`` apart.

    The record is shortened at its start to the longest length of the form 2^a 3^b 5^c (at
    most a few per cent: the DFT of a length with a large prime factor costs up to ten times
    more), then :func:`~exudyn_study.identify.lpm.estimate_frf_lpm` fits its local rational
    model (:data:`LRM_HALF_WIDTH`, :data:`LRM_DEGREE`).

    Parameters
    ----------
    reference : ndarray, shape (n_in, n_samples)
        Reference time data.
    response : ndarray, shape (n_out, n_samples)
        Response time data.
    sample_rate_hz : float
        Sampling rate in Hz.
    band_hz : (float, float)
        Band of the result in Hz (it holds one line beyond each edge).
    outputs, inputs : tuple of str, optional
        Channel names carried into the result.

    Returns
    -------
    FRF
        ``estimator='LRM'``, ``n_averages=1``.
    """
    n = np.shape(response)[-1]
    fast = int(round(sample_rate_hz / fft_friendly_resolution(sample_rate_hz / n, sample_rate_hz)))
    line = sample_rate_hz / fast  # one line beyond each edge, so that the band lies inside
    return estimate_frf_lpm(reference, response, sample_rate_hz, half_width=LRM_HALF_WIDTH,
                            degree=LRM_DEGREE, fmin_hz=max(0.0, band_hz[0] - line),
                            fmax_hz=band_hz[1] + line,
                            skip_s=(n - fast) / sample_rate_hz, method="lrm", outputs=outputs,
                            inputs=inputs)


def _chi2(frf: FRF, w: np.ndarray, synthesised: np.ndarray, sel: np.ndarray) -> float:
    return float(np.sum(np.abs((frf.H[:, :, sel] - synthesised) * w[:, :, sel]) ** 2))


def refine_locally(
    reference,
    response,
    sample_rate_hz: float,
    model: ModalModel,
    bands: Sequence[LocalBand],
    identify_frf: Callable[..., object],
    *,
    frf_form: str = "accelerance",
    outputs: tuple[str, ...] = (),
    inputs: tuple[str, ...] = (),
) -> tuple[ModalModel, list[dict]]:
    """Re-identify the modes of every band on the fine FRF; return the new model and a report.

    Parameters
    ----------
    reference : ndarray, shape (n_in, n_samples)
        Reference time data.
    response : ndarray, shape (n_out, n_samples)
        Response time data.
    sample_rate_hz : float
        Sampling rate in Hz.
    model : ModalModel
        The identified modes; shapes keyed by ``outputs``.
    bands : sequence of LocalBand
        Where to re-identify (:func:`trouble_bands`).
    identify_frf : callable
        :func:`~exudyn_study.identify.pipeline.identify_frf` (passed in: the pipeline imports
        this module).
    frf_form : str, optional
        FRF form for the residual terms (see :func:`~exudyn_study.identify.lsfd.lsfd`).
    outputs, inputs : tuple of str, optional
        Channel names of the responses and references.

    Returns
    -------
    ModalModel
        ``model`` with the modes of each band's inner part replaced by the better local fit.
    list of dict
        Per band: ``band_hz``, ``inner_hz``, ``reason``, ``resolution_hz`` of the fine FRF,
        ``chosen`` ('refit', 're-identification' or 'kept' when neither fitted),
        ``aic`` of both, the modes ``before_hz`` and ``after_hz``.
    """
    modes = list(model.modes)
    names = outputs or tuple(f"ch{i}" for i in range(np.shape(response)[0]))
    report = []
    for lb in bands:
        frf = fine_frf(reference, response, sample_rate_hz, lb.band_hz, outputs=names, inputs=inputs)
        sel = (frf.freq_hz >= lb.band_hz[0]) & (frf.freq_hz <= lb.band_hz[1])
        w = frf_weights(frf)
        per_mode = 2 + 2 * frf.H.shape[0] * frf.H.shape[1]
        in_band = [m for m in modes if lb.band_hz[0] <= m.frequency_hz <= lb.band_hz[1]]
        cands = {}
        if in_band:
            start = modal_to_pole([m.frequency_hz for m in in_band], [m.damping_ratio for m in in_band])
            try:
                fit = fit_modal_model(frf.H, frf.freq_hz, start, band_hz=lb.band_hz, frf_form=frf_form,
                                      leakage=None, estimator=frf.estimator, weights=w)
            except InputError:
                fit = None
            if fit is not None:
                new = [Mode(frequency_hz=float(fit.frequency_hz[k]),
                            damping_ratio=float(max(fit.damping_ratio[k], 0.0)),
                            frequency_std_hz=m.frequency_std_hz, damping_std=m.damping_std,
                            mpc=float(mpc(fit.shapes[:, k:k + 1])[0]),
                            shape={n: complex(v) for n, v in zip(names, fit.shapes[:, k], strict=True)})
                       for k, m in enumerate(in_band)]
                cands["refit"] = (_chi2(frf, w, fit.synthesised, sel) + 2 * per_mode * len(new), new)
        n_lines = int(sel.sum())
        pmax = min(LOCAL_MAX_ORDER, (n_lines * frf.H.shape[0]) // 2 - 1)
        if pmax >= 6:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", UserWarning)
                    res = identify_frf(frf, band_hz=lb.band_hz, orders=range(2, pmax + 1),
                                       frf_form=frf_form, leakage_correction=False)
            except InputError:
                res = None
            if res is not None and res.fit is not None:
                cands["re-identification"] = (
                    _chi2(frf, w, res.fit.synthesised, sel) + 2 * per_mode * len(res.model),
                    list(res.model.modes))
        entry = {"band_hz": list(lb.band_hz), "inner_hz": list(lb.inner_hz), "reason": lb.reason,
                 "resolution_hz": frf.resolution_hz, "estimator": frf.estimator,
                 "aic": {k: v[0] for k, v in cands.items()},
                 "before_hz": [round(m.frequency_hz, 4) for m in in_band
                               if lb.inner_hz[0] <= m.frequency_hz <= lb.inner_hz[1]]}
        if not cands:
            report.append(entry | {"chosen": "kept", "after_hz": entry["before_hz"]})
            continue
        chosen = min(cands, key=lambda k: cands[k][0])
        local = [m for m in cands[chosen][1] if lb.inner_hz[0] <= m.frequency_hz <= lb.inner_hz[1]]
        kept = [m for m in modes if not lb.inner_hz[0] <= m.frequency_hz <= lb.inner_hz[1]]
        # a local mode that repeats a kept neighbour just outside the inner band is that neighbour
        local = [m for m in local if not any(abs(m.frequency_hz - k.frequency_hz)
                                             <= max(k.damping_ratio, m.damping_ratio) * k.frequency_hz
                                             for k in kept)]
        modes = sorted(kept + local, key=lambda m: m.frequency_hz)
        report.append(entry | {"chosen": chosen,
                               "after_hz": [round(m.frequency_hz, 4) for m in local]})
    return ModalModel(tuple(modes), model.metadata), report
