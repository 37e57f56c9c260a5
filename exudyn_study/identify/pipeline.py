"""End-to-end identification: time data -> FRFs -> PolyMAX -> selection -> LSFD -> modes.

:func:`identify_frf` works on FRFs, :func:`identify` on time arrays and
:func:`identify_recording` on a :class:`~exudyn_study.recording.Recording`.
All return an :class:`IdentificationResult` whose ``model`` is a
:class:`~exudyn_study.identify.model.ModalModel` (the modes JSON schema).
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify.frf import FRF, estimate_frf, frf_weights
from exudyn_study.identify.local import refine_locally, trouble_bands
from exudyn_study.identify.lsfd import Leakage, LSFDResult, fit_modal_model
from exudyn_study.identify.mac import mpc
from exudyn_study.identify.model import ModalModel, Mode
from exudyn_study.identify.polymax import Poles, modal_to_pole, polymax
from exudyn_study.identify.resolution import (
    choose_resolution,
    fft_friendly_resolution,
    first_pass_resolution,
    resolution_warnings,
    window_corrected_damping,
)
from exudyn_study.identify.selection import Selection, select_modes
from exudyn_study.identify.selfcheck import self_check
from exudyn_study.infra.blas import one_blas_thread
from exudyn_study.infra.progress import StageProgress

__all__ = ["IdentificationResult", "identify_frf", "identify", "identify_recording",
           "DEFAULT_ORDERS", "excited_band"]

logger = logging.getLogger(__name__)

#: model orders of the stabilisation diagram by default
DEFAULT_ORDERS = tuple(range(2, 61))


@dataclass(frozen=True, eq=False)
class IdentificationResult:
    """Everything an identification produced.

    Attributes
    ----------
    model : ModalModel
        The identified modes (JSON schema of :mod:`~exudyn_study.identify.model`).
    frf : FRF
        The FRFs the modes were fitted to.
    poles : Poles
        All poles of the stabilisation diagram.
    selection : Selection
        Clusters and which were accepted.
    fit : LSFDResult or None
        Residues, shapes, synthesised FRFs and fit error per channel (None when
        no mode was found).
    band_hz : (float, float)
        Fitted band in Hz.
    warnings : tuple of str
        Resolution warnings (also issued with :func:`warnings.warn`).
    """

    model: ModalModel
    frf: FRF
    poles: Poles
    selection: Selection
    fit: LSFDResult | None
    band_hz: tuple[float, float]
    warnings: tuple[str, ...] = ()


def _default_band(frf: FRF) -> tuple[float, float]:
    """Lines where the median coherence over channels is at least 0.5."""
    coh = np.median(frf.coherence.reshape(-1, frf.coherence.shape[-1]), axis=0)
    good = np.flatnonzero((coh >= 0.5) & (frf.freq_hz > 0))
    if good.size < 4:
        raise InputError(
            "band: the coherence is below 0.5 almost everywhere, so no excited band can be "
            "chosen automatically; give band_hz (fmin, fmax)"
        )
    return float(frf.freq_hz[good[0]]), float(frf.freq_hz[good[-1]])


@one_blas_thread
def identify_frf(
    frf: FRF,
    *,
    band_hz: tuple[float, float] | None = None,
    orders: Iterable[int] = DEFAULT_ORDERS,
    frf_form: str = "accelerance",
    leakage_correction: bool = True,
    refine: bool = True,
    weighting: str = "coherence",
    pin_hz: Sequence[float] = (),
    drop_hz: Sequence[float] = (),
    stability: dict | None = None,
    selection: dict | None = None,
    duration_s: float | None = None,
    metadata: dict | None = None,
    check: bool = True,
) -> IdentificationResult:
    """Identify modes from FRFs: PolyMAX, automatic selection, LSFD, self-check.

    Parameters
    ----------
    frf : FRF
        FRFs ``H[n_out, n_in, n_freq]`` with names (see :func:`estimate_frf`).
    band_hz : (float, float), optional
        Band in Hz; default the lines whose median coherence is at least 0.5.
    orders : iterable of int, optional
        Model orders of the stabilisation diagram (default 2..60).
    frf_form : str, optional
        'accelerance' (also acceleration transmissibility, default), 'mobility'
        or 'receptance': sets the residual terms.
    leakage_correction : bool, optional
        Fit the leakage-aware model of the Welch estimate (default True; needs
        ``frf.sample_rate_hz``), see :class:`~exudyn_study.identify.lsfd.Leakage`.
    refine : bool, optional
        Refine the selected poles by nonlinear least squares (default True).
    weighting : {'coherence', 'none'}, optional
        Weight every line of the LSFD/refinement fit by the inverse standard
        error of the FRF estimate from its coherence (default 'coherence',
        :func:`~exudyn_study.identify.frf.frf_weights`; needs ``frf.n_averages`` above 1,
        or a local-model estimate, 'LRM' or 'LPM', whose coherence is its local residual's),
        or fit with per-channel 1/rms weights ('none').
    pin_hz, drop_hz : sequence of float, optional
        Modes to force into / remove from the automatic selection (Hz).
    stability : dict, optional
        Tolerances for :func:`polymax` (``tol_frequency``, ``tol_damping``, ``tol_vector``).
    selection : dict, optional
        Options for :func:`select_modes`.
    duration_s : float, optional
        Record length in s, for the resolution suggestion.
    metadata : dict, optional
        Extra metadata for the model.
    check : bool, optional
        Run the self-check after LSFD (default True): where the synthesised FRFs misfit the
        data beyond their noise, look for the missing pole and add it
        (:func:`~exudyn_study.identify.selfcheck.self_check`); what was added and where the
        fit stays poor goes to the metadata under ``'self_check'``.

    Returns
    -------
    IdentificationResult
    """
    if not isinstance(frf, FRF):
        raise InputError(f"frf of type {type(frf).__name__}: expected an FRF (estimate_frf)")
    band = _default_band(frf) if band_hz is None else tuple(float(b) for b in band_hz)
    poles = polymax(frf.H, frf.freq_hz, orders, band_hz=band, **(stability or {}))
    sel = select_modes(poles, pin_hz=pin_hz, drop_hz=drop_hz, **(selection or {}))
    meta = {
        "estimator": frf.estimator,
        "resolution_hz": frf.resolution_hz,
        "n_averages": frf.n_averages,
        "band_hz": list(band),
        "references": list(frf.inputs),
        "orders": [min(poles.orders), max(poles.orders)],
        "leakage_correction": bool(leakage_correction and frf.sample_rate_hz is not None),
        "weighting": weighting,
        "method": "PolyMAX + automatic clustering + LSFD",
    }
    meta.update(metadata or {})
    if not sel.modes:
        logger.warning("no stable physical poles found in %.4g-%.4g Hz", *band)
        return IdentificationResult(ModalModel((), meta), frf, poles, sel, None, band, ())
    leak = None
    if leakage_correction and frf.sample_rate_hz is not None:
        leak = Leakage(frf.sample_rate_hz, frf.n_segment, frf.window)
    if weighting not in ("coherence", "none"):
        raise InputError(f"weighting {weighting!r}: expected 'coherence' or 'none'")
    # a Welch estimate's coherence from one segment is 1 everywhere; a local-model estimate
    # (LRM/LPM) has one DFT but its coherence comes from the local fit's residual
    noise_known = frf.n_averages > 1 or frf.estimator in ("LRM", "LPM")
    weights = frf_weights(frf) if weighting == "coherence" and noise_known else None

    def refit(start_poles):
        return fit_modal_model(frf.H, frf.freq_hz, start_poles, band_hz=band, frf_form=frf_form,
                               leakage=leak, estimator=frf.estimator, refine=refine,
                               weights=weights)

    fit = refit(sel.poles)
    clusters = list(sel.modes)
    if check:
        report, fit, clusters = self_check(frf, fit, poles, sel, band, refit, clusters=clusters,
                                           exclude_hz=[float(x) for x in drop_hz])
        meta["self_check"] = report.as_dict()
        for a in report.added:
            logger.info("self-check added %.3f Hz / %.2f %% (%s): misfit in %.2f-%.2f Hz %.1f -> %.1f",
                        a["frequency_hz"], 100 * a["damping_ratio"], a["source"], *a["band_hz"],
                        a["misfit_before"], a["misfit_after"])
        for r in report.removed:
            logger.info("self-check removed %.3f Hz / %.2f %%: %s", r["frequency_hz"],
                        100 * r["damping_ratio"], r["reason"])
        if report.poor_fit_bands_hz:
            logger.info("self-check: poor fit in %s Hz", report.poor_fit_bands_hz)
    names = frf.outputs or tuple(f"ch{i}" for i in range(frf.H.shape[0]))
    phase_coll = mpc(fit.shapes)
    modes = []
    for k, c in enumerate(clusters):
        shape = {n: complex(v) for n, v in zip(names, fit.shapes[:, k], strict=True)}
        modes.append(Mode(
            frequency_hz=float(fit.frequency_hz[k]),
            damping_ratio=float(max(fit.damping_ratio[k], 0.0)),
            frequency_std_hz=c.frequency_std_hz,
            damping_std=c.damping_std,
            mpc=float(phase_coll[k]),
            shape=shape,
        ))
    order = np.argsort([m.frequency_hz for m in modes])
    modes = [modes[i] for i in order]
    fit = _sorted_fit(fit, order)
    model = ModalModel(tuple(modes), meta)
    msgs = tuple(resolution_warnings(model.frequency_hz, model.damping_ratio,
                                     frf.resolution_hz, duration_s=duration_s))
    if msgs and leak is not None:
        msgs = msgs + ("leakage correction is on: the damping values above are corrected for "
                       "the spectral window; a finer resolution still reduces their variance",)
    for m in msgs:
        warnings.warn(m, stacklevel=3)  # past the one_blas_thread wrapper
    return IdentificationResult(model, frf, poles, sel, fit, band, msgs)


def _sorted_fit(fit: LSFDResult, order: np.ndarray) -> LSFDResult:
    """Return the fit with its modes in the order ``order`` (poles, residues, shapes, ...)."""
    return replace(fit, poles=fit.poles[order], residues=fit.residues[:, :, order],
                   shapes=fit.shapes[:, order], participation=fit.participation[:, order])


def identify(
    reference: np.ndarray,
    response: np.ndarray,
    sample_rate_hz: float,
    *,
    outputs: Sequence[str] = (),
    inputs: Sequence[str] = (),
    resolution_hz: float | None = None,
    estimator: str = "Hv",
    band_hz: tuple[float, float] | None = None,
    overlap: float = 0.5,
    window: str = "hann",
    mimo: bool = False,
    local_refinement: bool | None = None,
    **kwargs,
) -> IdentificationResult:
    """Identify modes from time data ``reference[n_in, n]`` and ``response[n_out, n]``.

    Parameters
    ----------
    reference : ndarray, shape (n_in, n_samples)
        Reference channels (e.g. base acceleration in m/s^2).
    response : ndarray, shape (n_out, n_samples)
        Response channels.
    sample_rate_hz : float
        Sampling rate in Hz.
    outputs, inputs : sequence of str, optional
        Channel names of responses and references.
    resolution_hz : float, optional
        FRF resolution in Hz. Default: chosen from the data, a survey pass at the finest
        resolution that keeps 30 averages finds the modes, then
        :func:`~exudyn_study.identify.resolution.choose_resolution` sets the resolution
        from their narrowest bandwidth, their closest spacing and the record length; when
        the modes identified at that resolution ask for a finer one (a close pair the
        survey saw as one peak), the identification is repeated once at it.
    estimator : {'H1', 'H2', 'Hv'}, optional
        FRF estimator (default 'Hv').
    band_hz : (float, float), optional
        Band in Hz; must lie below the Nyquist frequency. Default: the band the first
        reference excites (:func:`excited_band`).
    overlap, window, mimo
        Welch settings, see :func:`estimate_frf`.
    local_refinement : bool, optional
        Re-identify close pairs (modes fewer than
        :data:`~exudyn_study.identify.local.PAIR_LINES` lines apart) and bands the self-check
        left poorly fitted on the local-rational FRF of the whole record, whose lines are
        ``1 / T`` apart (:func:`~exudyn_study.identify.local.refine_locally`); what was
        re-identified and why goes to the metadata under ``'local_refinement'``. Default: when
        the resolution is chosen from the data (an explicit ``resolution_hz`` is kept as given).
        Not with ``mimo=True``.
    **kwargs
        Passed to :func:`identify_frf`.

    Returns
    -------
    IdentificationResult

    Raises
    ------
    InputError
        On bad time data, a band outside 0..Nyquist, or a record too short.
    """
    nyq = sample_rate_hz / 2
    if band_hz is not None:
        try:
            lo, hi = (float(b) for b in band_hz)
        except (TypeError, ValueError):
            raise InputError(
                f"band {band_hz!r}: expected two frequencies FMIN FMAX in Hz"
            ) from None
        if not (0 <= lo < hi <= nyq):
            raise InputError(
                f"band {lo:g}-{hi:g} Hz: expected 0 <= FMIN < FMAX <= Nyquist ({nyq:g} Hz "
                f"at {sample_rate_hz:g} Hz sampling)"
            )
    n = np.shape(response)[-1]
    duration = n / sample_rate_hz
    stages = ("band and resolution", "FRF estimate", "PolyMAX, selection, LSFD", "refined resolution",
              "close modes at the record's resolution")
    with StageProgress("identification", stages, leave=False) as progress:
        chosen = {}
        progress.stage("band and resolution")
        if band_hz is None:
            band_hz = excited_band(reference, sample_rate_hz, first_pass_resolution(duration))
            chosen["band_hz"] = f"{band_hz[0]:.3g}-{band_hz[1]:.3g} Hz, where the reference is excited"
        if resolution_hz is None:
            resolution_hz, chosen["resolution_hz"] = _choose_resolution(
                reference, response, sample_rate_hz, band_hz, estimator=estimator, overlap=overlap,
                window=window, mimo=mimo, orders=kwargs.get("orders", DEFAULT_ORDERS))
            resolution_hz = fft_friendly_resolution(resolution_hz, sample_rate_hz)
        for what, why in chosen.items():
            logger.info("%s chosen: %s", what, why)
        progress.stage("FRF estimate")
        frf = estimate_frf(reference, response, sample_rate_hz, resolution_hz=resolution_hz,
                           estimator=estimator, overlap=overlap, window=window, mimo=mimo,
                           fmax_hz=min(nyq, band_hz[1] * 1.2),
                           outputs=tuple(outputs), inputs=tuple(inputs))
        if chosen:
            meta = dict(kwargs.pop("metadata", None) or {})
            meta["chosen"] = chosen
            kwargs["metadata"] = meta
        kwargs.setdefault("duration_s", n / sample_rate_hz)
        progress.stage("PolyMAX, selection, LSFD")
        with warnings.catch_warnings(record=True) as first_warnings:
            warnings.simplefilter("always")
            result = identify_frf(frf, band_hz=band_hz, **kwargs)
        refined = False
        if "resolution_hz" in chosen and len(result.model):
            # the survey may see a close pair as one peak: when the modes found at the chosen
            # resolution ask for a finer one the record supports, estimate and identify again
            adv = choose_resolution(result.model.frequency_hz, result.model.damping_ratio, duration,
                                    overlap=overlap)
            finer = fft_friendly_resolution(adv.resolution_hz, sample_rate_hz)
            if finer < 0.99 * frf.resolution_hz:
                progress.stage("refined resolution")
                chosen["resolution_hz"] = adv.message + " (refined after the first identification)"
                logger.info("resolution_hz refined: %s", adv.message)
                frf = estimate_frf(reference, response, sample_rate_hz, resolution_hz=finer,
                                   estimator=estimator, overlap=overlap, window=window, mimo=mimo,
                                   fmax_hz=min(nyq, band_hz[1] * 1.2),
                                   outputs=tuple(outputs), inputs=tuple(inputs))
                kwargs["metadata"]["chosen"] = chosen
                result = identify_frf(frf, band_hz=band_hz, **kwargs)
                refined = True
        if not refined:  # the first pass's warnings stand (a refined pass issued its own)
            for w in first_warnings:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        if local_refinement is None:
            local_refinement = "resolution_hz" in chosen
        if local_refinement and not mimo and len(result.model):
            progress.stage("close modes at the record's resolution")
            result = _refine_close_modes(reference, response, sample_rate_hz, result, kwargs,
                                         outputs=tuple(outputs), inputs=tuple(inputs))
    msg = None if mimo else collinear_references_warning(reference, sample_rate_hz, frf, result.band_hz,
                                                         names=tuple(inputs))
    if msg:
        warnings.warn(msg, stacklevel=3)  # past the one_blas_thread wrapper
        result = replace(result, warnings=result.warnings + (msg,))
    return result


def _refine_close_modes(reference, response, fs, result: IdentificationResult, kwargs, *,
                        outputs, inputs) -> IdentificationResult:
    """Re-identify close pairs and poorly fitted bands on the fine FRF (see :mod:`.local`)."""
    model = result.model
    poor = model.metadata.get("self_check", {}).get("poor_fit_bands_hz", [])
    bands = trouble_bands(model.frequency_hz, model.damping_ratio, result.frf.resolution_hz,
                          result.band_hz, poor_fit_bands_hz=[tuple(b) for b in poor])
    if not bands:
        return result
    frf_form = kwargs.get("frf_form", "accelerance")
    new, report = refine_locally(np.atleast_2d(reference), np.atleast_2d(response), fs, model, bands,
                                 identify_frf, frf_form=frf_form, outputs=outputs, inputs=inputs)
    for r in report:
        logger.info("close modes: %.2f-%.2f Hz re-identified at %.4g Hz (%s, %s): %s -> %s Hz",
                    *r["band_hz"], r["resolution_hz"], r["reason"], r["chosen"], r["before_hz"],
                    r["after_hz"])
    meta = dict(new.metadata)
    meta["local_refinement"] = report
    model = ModalModel(new.modes, meta)
    fit = result.fit
    if len(model) and fit is not None:
        # the synthesised FRFs and fit errors of the result stay those of the fitted FRF, for
        # the final poles (fixed); the modes' shapes come from the fine FRF
        leak = None
        if kwargs.get("leakage_correction", True) and result.frf.sample_rate_hz is not None:
            leak = Leakage(result.frf.sample_rate_hz, result.frf.n_segment, result.frf.window)
        weights = (frf_weights(result.frf) if kwargs.get("weighting", "coherence") == "coherence"
                   and result.frf.n_averages > 1 else None)
        poles = modal_to_pole(model.frequency_hz, model.damping_ratio)
        try:
            fit = fit_modal_model(result.frf.H, result.frf.freq_hz, poles, band_hz=result.band_hz,
                                  frf_form=frf_form, leakage=leak, estimator=result.frf.estimator,
                                  refine=False, weights=weights)
        except InputError:
            fit = None
    return replace(result, model=model, fit=fit)


def excited_band(reference, sample_rate_hz: float, resolution_hz: float) -> tuple[float, float]:
    """Return the band the first reference excites, in Hz.

    The band runs from the first to the last line of the reference's auto spectrum (Welch,
    ``resolution_hz``) that lies within 20 dB of the plateau (the median of the lines within
    10 dB of the maximum): a random or swept drive has a flat plateau, a measurement's noise
    floor lies far below it.

    Parameters
    ----------
    reference : ndarray, shape (n_in, n_samples) or (n_samples,)
        Reference time data.
    sample_rate_hz : float
        Sampling rate in Hz.
    resolution_hz : float
        Resolution of the spectrum in Hz.

    Returns
    -------
    (float, float)
        Lower and upper edge in Hz.

    Raises
    ------
    InputError
        When the reference excites fewer than 8 lines.
    """
    import scipy.signal

    ref = np.atleast_2d(np.asarray(reference, dtype=float))[0]
    nseg = min(ref.size, max(8, int(round(sample_rate_hz / resolution_hz))))
    f, g = scipy.signal.welch(ref, sample_rate_hz, nperseg=nseg)
    peak = g[1:].max()
    top = np.median(g[1:][g[1:] >= 0.1 * peak])  # the plateau's level
    good = np.flatnonzero((g >= 0.01 * top) & (f > 0))
    if good.size < 8:
        raise InputError(
            "band: the reference excites fewer than 8 spectral lines, so no band can be chosen "
            "from it; give band_hz (fmin, fmax) (the CLI's --band)"
        )
    return float(f[good[0]]), float(f[good[-1]])


def _choose_resolution(reference, response, fs, band_hz, *, estimator, overlap, window, mimo,
                       orders) -> tuple[float, str]:
    """Survey pass (resolution for 30 averages, PolyMAX, selection), then choose_resolution."""
    duration = np.shape(response)[-1] / fs
    survey = fft_friendly_resolution(first_pass_resolution(duration, overlap=overlap), fs)
    frf = estimate_frf(reference, response, fs, resolution_hz=survey, estimator=estimator,
                       overlap=overlap, window=window, mimo=mimo,
                       fmax_hz=min(fs / 2, band_hz[1] * 1.2))
    orders = sorted(int(o) for o in orders)
    try:
        poles = polymax(frf.H, frf.freq_hz, orders, band_hz=band_hz)
        sel = select_modes(poles)
    except InputError:
        return survey, f"{survey:g} Hz: the survey pass found no modes"
    # the survey's coarse lines broaden every peak: its damping ratios overstate the bandwidths
    # the resolution has to resolve (a 0.37 % mode at 15 Hz shows about 0.6 % at 0.1 Hz)
    fr = np.array([c.frequency_hz for c in sel.modes])
    ze = window_corrected_damping(fr, [c.damping_ratio for c in sel.modes], frf.resolution_hz)
    adv = choose_resolution(fr, ze, duration, overlap=overlap)
    return adv.resolution_hz, adv.message


#: median reference-to-reference coherence in the band above which the references count as collinear
COLLINEAR_COHERENCE = 0.99


def collinear_references_warning(reference, sample_rate_hz: float, frf: FRF, band_hz,
                                 names=()) -> str | None:
    """Return a warning when two references are (nearly) fully coherent in the band, else None.

    Responses to one common drive (the thesis's ``ARFVZ``/``ARFHZ`` on a rig driven at one point)
    are single-reference estimates each (``mimo=False``); when two references also move almost
    identically, their FRFs are near copies and PolyMAX on both at once is ill-conditioned: it
    shows poles the structure does not have (measured on the virtual rig: three spurious poles at
    37-44 Hz with MPC < 0.75 that one-reference identifications do not show).
    """
    ref = np.atleast_2d(np.asarray(reference, dtype=float))
    if ref.shape[0] < 2 or frf.n_segment is None:
        return None
    import scipy.signal

    lo, hi = band_hz
    worst = None
    for i in range(ref.shape[0]):
        for j in range(i + 1, ref.shape[0]):
            f, coh = scipy.signal.coherence(ref[i], ref[j], sample_rate_hz, window=frf.window,
                                            nperseg=frf.n_segment)
            inband = (f >= lo) & (f <= hi)
            if not inband.any():
                continue
            med = float(np.median(coh[inband]))
            if med >= COLLINEAR_COHERENCE and (worst is None or med > worst[0]):
                worst = (med, i, j)
    if worst is None:
        return None
    med, i, j = worst
    a, b = (names[i], names[j]) if len(names) == ref.shape[0] else (f"reference {i}", f"reference {j}")
    return (f"references {a} and {b} are nearly fully coherent in {lo:g}-{hi:g} Hz (median coherence "
            f"{med:.4f}): identifying with both at once can show spurious poles; identify with each "
            "reference separately and keep the modes both find")


def _frf_form(ref_q: str, resp_q: str) -> str:
    if resp_q == "displacement" and ref_q == "force":
        return "receptance"
    return "accelerance"


def identify_recording(
    recording,
    reference: str | Sequence[str],
    *,
    responses: Sequence[str] | None = None,
    **kwargs,
) -> IdentificationResult:
    """Identify modes from a :class:`~exudyn_study.recording.Recording`.

    Parameters
    ----------
    recording : Recording
        Measured or simulated recording.
    reference : str or sequence of str
        Reference channel name(s), e.g. ``'ARFVZ'``.
    responses : sequence of str, optional
        Response channels; default every channel with role 'response' that is not
        a reference.
    **kwargs
        Passed to :func:`identify` (``resolution_hz``, ``estimator``, ``band_hz``, ...).

    Returns
    -------
    IdentificationResult

    Raises
    ------
    InputError
        For an unknown channel, mixed sample rates, NaN samples, a band outside
        the Nyquist range or a record too short for the resolution.
    """
    refs = (reference,) if isinstance(reference, str) else tuple(reference)
    if not refs:
        raise InputError("reference: expected at least one channel name")
    for r in refs:
        recording.channel(r)  # InputError naming close matches for unknown names
    if responses is None:
        responses = tuple(c.name for c in recording.channels
                          if c.role == "response" and c.name not in refs)
    responses = tuple(responses)
    if not responses:
        raise InputError(f"recording has no response channels besides {list(refs)}")
    both = set(refs) & set(responses)
    if both:
        raise InputError(f"channels {sorted(both)} are both reference and response")
    x_ref, fs = recording.time_data(refs)
    x_resp, fs2 = recording.time_data(responses)
    if fs != fs2:
        raise InputError(
            f"references sampled at {fs:g} Hz, responses at {fs2:g} Hz: expected one rate"
        )
    kwargs.setdefault("frf_form", _frf_form(recording.channel(refs[0]).quantity,
                                            recording.channel(responses[0]).quantity))
    meta = dict(kwargs.pop("metadata", None) or {})
    meta.setdefault("recording", {k: v for k, v in dict(recording.metadata).items()
                                  if isinstance(v, (str, int, float, bool))})
    return identify(x_ref, x_resp, fs, outputs=responses, inputs=refs, metadata=meta,
                    **kwargs)
