"""Diagnosis on the rig: a model variant against recordings (the chassis path of ``exudyn-study diagnose``).

:func:`diagnose_rig` runs the five steps of the diagnosis:

1. **Compare**: the nominal model (variant + damping) is driven by each recording's drive
   channel; residual per channel (:mod:`~exudyn_study.diagnose.rig_compare`).
2. **Locate**: channel x band cells whose residual is significantly coherent with the
   drive and not negligible (family-wise p < 1e-3, effect >= 0.5 %). None: "no missing
   physics found". Level dependence: the same comparison between the recordings' FRFs.
3. **Name**: every candidate (catalogue entry at a location:
   :mod:`~exudyn_study.diagnose.rig_hypotheses`) is scored by how much of the training
   residual it explains at its best value on a coarse grid (candidates with several
   parameters are always fitted); a nonlinear candidate (``bushing_stiffening``) only
   when the mismatch grows with the drive level;
4. **Model and fit**: the best candidates are fitted (bounded least squares on the
   training residual, log parameters), rejected if not identifiable (relative std > 30 %
   or at a bound), if they explain too little (< 30 % of the error) or if the fitted model
   still misses most of the response (relative error > 0.7: a fit that switches the
   response off is no explanation), and chosen by the Akaike information criterion. Far
   from the recordings (resonances misplaced) candidates that explain little alone are
   fitted together (from two starts: each member at its screening optimum, and the
   best-screened physics at its prior start instead, since screened alone it takes up the
   whole mismatch; the lower training residual wins), and each member of that joint fit is
   judged on its own: taken out (the others refitted) it must lose on the training AIC and
   on the held-out error. If the
   training data hold one drive at two levels, the nonlinear candidates are fitted on the
   level-dependent share of the response (``y_strong - c y_weak``), which the model's
   linear errors do not disturb. Rounds until nothing significant is left, the time budget
   is spent or no candidate explains what is left, each finding carried into the next
   round's model; what is left significant is reported as unexplained.
5. **Prove**: held-out error before and after per channel and relative pseudo damage
   at the z sensors before and after; a plain-language explanation. A finding must not
   raise the held-out error, except a nonlinear one fitted on the level-dependent share:
   it is proven on that share at a held-out level of the same drive (it must explain 30 %
   of it there) and may raise the held-out error by 5 % at most, since the linear findings
   before it took up the hardening's mean at the training levels (a joint refit of the
   linear findings with it in place would take those back, but on the thesis scenario it
   took over 20 minutes: not done).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence

import numpy as np

from exudyn_study.diagnose.rig_candidates import (
    RIG_CANDIDATES,
    CandidateContext,
    ExplainContext,
    register_rig_candidate,
    sensor_component,
    unregister_rig_candidate,
)
from exudyn_study.diagnose.rig_compare import (
    BANDS_HZ,
    METRIC,
    band_filter,
    drive_spectra,
    prepare,
    relative_errors,
    significance_map,
    summary_error,
)
from exudyn_study.diagnose.rig_hypotheses import (
    Hypothesis,
    NonlinearSystem,
    log_bounds,
    model_system,
    to_params,
    to_x,
)
from exudyn_study.diagnose.schema import Diagnosis, Finding
from exudyn_study.errors import InputError
from exudyn_study.infra.blas import one_blas_thread

__all__ = ["diagnose_rig", "RigDiagnosisSettings", "register_rig_candidate", "unregister_rig_candidate"]

log = logging.getLogger(__name__)


class RigDiagnosisSettings:
    """Knobs of :func:`diagnose_rig` (defaults are what the benchmark uses)."""

    train_duration_s: float = 40.0  # training seconds used for fitting (per recording)
    screen_duration_s: float = 12.0  # seconds of the first training recording used for screening
    screen_nfev: int = 6  # function evaluations of the short screening fit (several parameters)
    min_screen_share: float = 0.2  # fit only candidates screened at >= this share of the best score
    n_fit: int = 4  # candidates fitted in full after screening
    max_batch: int = 3  # acceptable linear fits at different components taken in one round
    # rounds whose model misses the training response by more than this (relative error) fit
    # and judge candidates on log transmissibilities, then polish accepted ones in time
    spectral_above_error: float = 0.7
    # a joint fit is started twice: at the members' screening optima, and with the best-screened physics at
    # its prior start (Hypothesis.prior); the lower training residual wins
    composite_prior_start: bool = True
    # and a third time with every member at its prior start (needs composite_prior_start). On the thesis
    # truth the other two starts leave round 1 in a basin where the pad is not found; this one reaches the
    # truth's basin
    composite_all_prior_start: bool = True
    polish_nfev: int = 8  # function evaluations of that time-domain polish
    # in such a round, if no candidate explains enough alone: fit the best-screened linear
    # candidates (at most this many, at different places) together (with both tanks' water and the
    # rear supports' fore-aft stiffness among the candidates, 8 let the water take the pad's place in round 1)
    composite_max: int = 10
    fit_nfev_composite: int = 40
    # the joint fit's connectors (joints, pad) fit their damping times too (exact, bilinear)
    composite_damping: bool = True
    # function evaluations of the refits that take a member out of a joint fit (chord steps with the
    # joint fit's Jacobian: one evaluation each)
    member_nfev: int = 15
    # a member of a joint fit must cut the held-out error of each held-out recording by this share
    # (against the others refitted without it) and lower the training AIC
    min_member_gain: float = 0.02
    fit_nfev: int = 30  # function evaluations of a full fit
    n_fit_simulated: int = 2  # of the n_fit, at most this many simulated in time (nonlinear)
    fit_nfev_simulated: int = 15  # function evaluations of a nonlinear (time-simulated) fit
    train_duration_nonlinear_s: float = 15.0  # training seconds per recording of a nonlinear fit
    min_improvement: float = 0.3  # a finding must cut the training error by this share
    # ... and its model must still respond: a fit that only switches the response off (the
    # simulated rms a small share of the measured one) is no explanation
    min_response_ratio: float = 0.3
    max_findings: int = 8  # rounds of locate-name-fit
    time_budget_s: float = 540.0  # no new round once it would end after this (one diagnosis < 10 min)
    max_relative_std: float = 0.3
    # drift between recordings (with two or more training recordings): a linear candidate's parameters are
    # fitted on each training recording alone (from the pooled fit, chord steps with its Jacobian); it is
    # rejected (in a round) or flagged (in the final joint refit) if two recordings' estimates of an
    # identifiable parameter differ by more than drift_sigma combined standard deviations and by more
    # than drift_rel_tol (relative; both in the log of a positive parameter)
    drift_check: bool = True
    drift_sigma: float = 3.0
    drift_rel_tol: float = 0.25
    drift_nfev: int = 10
    # after the rounds, the linear findings carried into the model are refitted together (all their
    # parameters; spectral or time domain as the rounds' last fit) and judged again; the refit is kept
    # if it lowers the training residual and does not raise the held-out error. If the free refit is not
    # kept, it is tried once more with the parameters that ended at a bound in their rounds held there
    final_refit: bool = True
    final_nfev: int = 20
    # a nonlinear finding fitted on the level-dependent share is proven on that share at a held-out level
    # (one drive: a weaker training and a stronger held-out recording): it must explain min_improvement
    # of it there. The held-out error may then grow by this share at most: the linear findings fitted
    # before it took up the hardening's mean at the training levels
    nonlinear_holdout_tolerance: float = 0.05
    min_effect: float = 0.005
    p_value: float = 1e-3


def _label(name) -> str:
    """Return a recording's label in the JSON and the report: its file name (else the name as given)."""
    return str(name).rsplit("/", 1)[-1]


def _load(recs, what):
    from exudyn_study.recording.io import read_recording
    from exudyn_study.recording.types import Recording

    out = []
    for r in recs or []:
        if isinstance(r, Recording):
            out.append((str(r.metadata.get("name", f"{what}{len(out)}")), r))
        else:
            out.append((str(r), read_recording(r)))
    return out


def _check_layouts(named):
    ref_name, ref = named[0]
    ref_set = sorted(ch.name for ch in ref if ch.role == "response")
    for name, rec in named[1:]:
        names = sorted(ch.name for ch in rec if ch.role == "response")
        if names != ref_set:
            diff = sorted(set(names) ^ set(ref_set))
            raise InputError(
                f"recordings {ref_name!r} and {name!r} have different sensor layouts (differ in "
                f"{diff[:6]}); diagnose recordings of one test set-up"
            )


class _Evaluator:
    """Simulate a system against prepared recordings; residual vector and errors.

    ``exact=True``: :func:`~exudyn_study.simulate.simulate_linear` (fits, errors, significance).
    Otherwise (screening) the response from rest is the linear convolution of the drive
    with the model's impulse response, computed as ``irfft(H(f) U(f))`` with the drive zero-padded by
    ``pad_s`` (longer than the slowest mode's decay) after a 1 s fade from its last value
    to zero (by causality the extension does not change the response within the record;
    it only keeps the padded drive band-limited). The recorded drive is band-limited to
    102.4 Hz (204.8 Hz channel), so
    ``H`` is evaluated only up to :data:`F_MAX_HZ`: about 10x cheaper than the exact
    discretisation (:func:`~exudyn_study.simulate.simulate_linear`), which it matches to
    the drive's band limit, except where slow or undamped rig modes (< 3 Hz) wrap around:
    good enough to rank candidates, not to fit them.
    """

    F_MAX_HZ = 110.0

    def __init__(self, recordings, sensor_names, pad_s: float = 30.0, exact: bool = False):
        from exudyn_study.diagnose.rig_compare import RATE_HZ

        self.exact = exact
        self.pad_s = pad_s
        self.recs = recordings
        self.sensor_names = tuple(sensor_names)
        self.idx = [np.array([self.sensor_names.index(c) for c in r.channels]) for r in recordings]
        self._cache = {}
        self.offset = None  # per recording: added to linear simulations (see _set_offsets)
        self.spectra = []
        for r in recordings:
            n = r.drive.samples.size
            m = int(1.0 * RATE_HZ)
            fade = r.drive.samples[-1] * (0.5 + 0.5 * np.cos(np.pi * np.arange(1, m + 1) / m))
            u = np.concatenate([r.drive.samples, fade])
            n_fft = 1 << int(math.ceil(math.log2(n + pad_s * RATE_HZ)))
            spec = np.fft.rfft(u, n_fft)
            f = np.fft.rfftfreq(n_fft, 1.0 / RATE_HZ)
            keep = f <= self.F_MAX_HZ
            self.spectra.append((n, n_fft, f[keep], spec[keep]))

    def simulate(self, lin, gains=None):
        from exudyn_study.linear.response import frf_linear

        if self.exact or isinstance(lin, NonlinearSystem):
            return self.simulate_exact(lin, gains)
        key = id(lin)
        if key in self._cache and self._cache[key][0] is lin:
            base = self._cache[key][1]
        else:
            base = []
            for (n, n_fft, f, spec), idx in zip(self.spectra, self.idx, strict=True):
                h = frf_linear(lin, f)[idx, 0, :]
                full = np.zeros((idx.size, n_fft // 2 + 1), dtype=complex)
                full[:, : f.size] = h * spec[None, :]
                base.append(np.fft.irfft(full, n_fft, axis=1)[:, :n])
            if self.offset is not None:
                base = [b + o for b, o in zip(base, self.offset, strict=True)]
            self._cache = {key: (lin, base)}
        if gains is None:
            return base
        return [b * gains[:, None] for b in base]

    def simulate_exact(self, lin, gains=None):
        """Simulate by exact discretisation (:func:`~exudyn_study.simulate.simulate_linear`)."""
        from exudyn_study.linear.response import simulate_linear

        key = ("exact", id(lin))
        if key in self._cache and self._cache[key][0] is lin:
            base = self._cache[key][1]
        elif isinstance(lin, NonlinearSystem):
            from exudyn_study.linear.nonlinear import simulate_local_nonlinear

            base = [
                simulate_local_nonlinear(lin.lin, r.drive, lin.gather, lin.laws, lin.substeps)[idx]
                for r, idx in zip(self.recs, self.idx, strict=True)
            ]
            self._cache = {key: (lin, base)}
        else:
            base = [simulate_linear(lin, r.drive)[idx] for r, idx in zip(self.recs, self.idx, strict=True)]
            if self.offset is not None:
                base = [b + o for b, o in zip(base, self.offset, strict=True)]
            self._cache = {key: (lin, base)}
        return base if gains is None else [b * gains[:, None] for b in base]

    def residual_vector(self, lin, gains=None):
        parts = []
        for r, sim in zip(self.recs, self.simulate(lin, gains), strict=True):
            e = band_filter(r.measured - sim) * r.scale[:, None]
            parts.append(e.ravel() / math.sqrt(e.size))
        return np.concatenate(parts)

    def errors(self, sims):
        return [relative_errors(r, s) for r, s in zip(self.recs, sims, strict=True)]


class _SpectralEvaluator:
    """Residual of log-magnitude transmissibilities: model FRF against the recordings' H1 estimates.

    When the model is far off (resonances misplaced: a time-domain error above 100 %), a
    least-squares fit of time histories prefers a model that switches the response off over
    one that puts part of the resonances right. The log-magnitude distance of the
    transmissibilities does not: each channel and frequency bin (3-60 Hz, Welch H1, weighted
    by the coherence ``g2 / (1 - g2)`` capped at 0.99) counts by its ratio. Linear systems
    only (a nonlinear system is judged by its tangent); ``residual_vector`` has the
    :class:`_Evaluator` interface, so screening and fitting work unchanged. A system whose mass
    matrix is not positive definite raises :class:`~exudyn_study.errors.SimulationError` (its FRF
    exists, its time response diverges: a fit must not go there).
    """

    def __init__(self, recordings, sensor_names, nperseg: int = 4096):
        self.recs = recordings
        self.sensor_names = tuple(sensor_names)
        self.idx = [np.array([self.sensor_names.index(c) for c in r.channels]) for r in recordings]
        self.log_h, self.weight = [], []
        k0 = 1000
        for r in recordings:
            sp = drive_spectra(r.drive.samples[k0:], r.measured[:, k0:], nperseg)
            band = (sp.f >= 3.0) & (sp.f <= 60.0)
            self.f = sp.f[band]
            g2 = np.minimum(sp.coherence[:, band], 0.99)
            self.log_h.append(np.log(np.abs(sp.h1[:, band]) + 1e-300))
            self.weight.append(np.sqrt(g2 / (1.0 - g2) / np.mean(g2 / (1.0 - g2))))
        self.n_effective = int(sum(w.size for w in self.weight))

    def residual_vector(self, lin, gains=None):
        from exudyn_study.errors import SimulationError
        from exudyn_study.linear.response import frf_linear

        lin = getattr(lin, "lin", lin)
        try:  # an FRF exists for any mass matrix; a structure's is positive definite
            np.linalg.cholesky(0.5 * (lin.mass + lin.mass.T))
        except np.linalg.LinAlgError:
            raise SimulationError(
                "the model's mass matrix is not positive definite (a negative-mass compensation, e.g. a "
                "slosh mass, takes off more than its body has there): it has no physical response"
            ) from None
        h = frf_linear(lin, self.f)[:, 0, :]
        parts = []
        for idx, log_h, w in zip(self.idx, self.log_h, self.weight, strict=True):
            hm = h[idx] if gains is None else h[idx] * gains[:, None]
            e = w * (np.log(np.abs(hm) + 1e-300) - log_h)
            parts.append(e.ravel() / math.sqrt(e.size))
        return np.concatenate(parts)


def _fit(h: Hypothesis, ev: _Evaluator, channels, max_nfev=30, jac=None, info: dict | None = None):
    """Fit ``h`` on ``ev`` from ``h.start``: (p, std, rss, at_bound, nfev).

    ``jac``: a Jacobian callable in the fitting variable (default finite differences: one
    evaluation per parameter and iteration); ``info`` gets the final Jacobian (``'jac'``).
    """
    from scipy.optimize import least_squares

    pos, lo, hi = log_bounds(h)
    x0 = np.clip(to_x(h, h.start), lo + 1e-9, hi - 1e-9)
    r_start = _safe_residual(h, ev, channels, to_params(h, x0))
    if r_start is None:  # the candidate's system is unstable or singular at its start
        return to_params(h, x0), np.full(x0.size, np.inf), math.inf, np.ones(x0.size, bool), 1
    penalty = np.full(r_start.size, 10.0 / math.sqrt(r_start.size))

    def fun(x):
        r = _safe_residual(h, ev, channels, to_params(h, x))
        return penalty if r is None else r  # an unstable parameter set: far worse than any response

    res = least_squares(
        fun,
        x0,
        jac="2-point" if jac is None else jac,
        bounds=(lo, hi),
        diff_step=1e-3,
        max_nfev=max_nfev,
        x_scale=1.0,
    )
    if info is not None:
        info["jac"] = res.jac
    p = to_params(h, res.x)
    n_eff = _effective_samples(ev)
    rss = float(2 * res.cost)
    dof = max(1, n_eff - p.size)
    try:
        cov_x = np.linalg.inv(res.jac.T @ res.jac) * rss / dof
        std_x = np.sqrt(np.maximum(np.diag(cov_x), 0.0))
    except np.linalg.LinAlgError:
        std_x = np.full(p.size, np.inf)
    std_p = np.where(pos, p * std_x, std_x)
    at_bound = (res.x <= lo + 1e-3) | (res.x >= hi - 1e-3)
    return p, std_p, rss, at_bound, res.nfev


def _safe_residual(h: Hypothesis, ev: _Evaluator, channels, p):
    """Return the candidate's residual vector at ``p`` (None where its system is unstable or singular)."""
    from exudyn_study.errors import SimulationError, StudyError

    try:
        with np.errstate(all="ignore"):
            r = ev.residual_vector(h.system(p), _gains(h, p, channels))
    except (SimulationError, StudyError, np.linalg.LinAlgError, ValueError):
        return None
    return r if np.all(np.isfinite(r)) else None


def _per_recording(ev) -> list:
    """One evaluator per recording of ``ev`` (same residual rows as ``ev``'s part of that recording).

    Returns an empty list for an evaluator that is not per recording (the level-dependent share).
    """
    if isinstance(ev, _SpectralEvaluator):
        return [_SpectralEvaluator([r], ev.sensor_names) for r in ev.recs]
    if not isinstance(ev, _Evaluator):
        return []
    out = []
    for i, r in enumerate(ev.recs):
        sub = _Evaluator([r], ev.sensor_names, ev.pad_s, exact=ev.exact)
        sub.offset = None if ev.offset is None else [ev.offset[i]]
        out.append(sub)
    return out


def _drift(h: Hypothesis, p, firm_good, ev, channels, st, jac=None) -> dict | None:
    """Fit ``h`` on each recording of ``ev`` alone and tell whether its parameters drift between them.

    Each recording's fit starts at the pooled fit ``p``: with ``jac`` (the pooled Jacobian in the
    fitting variable) it takes chord steps with that recording's rows of it; otherwise finite
    differences, and (one-parameter candidates) the best point of the candidate's screening grid on
    that recording is a second start (the lower residual wins); ``st.drift_nfev`` evaluations each.

    Criterion, per parameter that is identifiable in the pooled fit (``firm_good``) and per pair of
    recordings ``a``, ``b``: the estimates differ by more than ``st.drift_sigma`` combined standard
    deviations and by more than ``st.drift_rel_tol`` of their value; in ``log p`` for a positive
    parameter::

        |ln p_a - ln p_b| > max(drift_sigma * sqrt((s_a / p_a)^2 + (s_b / p_b)^2), ln(1 + drift_rel_tol))

    The first condition alone would reject on the small standard deviations of long records, which
    the residual's correlation makes optimistic; the second alone would reject parameters a
    recording barely sees.

    Returns
    -------
    dict or None
        ``per_recording`` (name -> list of values), ``std`` (name -> list), ``drifting`` (names) and
        ``text``; None with fewer than two recordings or a recording the candidate cannot simulate.
    """
    subs = _per_recording(ev)
    if len(subs) < 2:
        return None
    p = np.asarray(p, dtype=float)
    parts = [_safe_residual(h, sub, channels, p) for sub in subs]
    if any(r is None for r in parts):
        return None
    sizes = np.cumsum([0] + [r.size for r in parts])
    use_jac = jac is not None and jac.shape[0] == sizes[-1]
    start = h.start
    estimates, stds = [], []
    try:
        for k, sub in enumerate(subs):
            rows = slice(sizes[k], sizes[k + 1])
            starts = [p]
            if not use_jac and h.screen_grid and len(h.names) == 1:
                # a resonance's residual has a local minimum per mode it can tune to: the recording's own
                # best grid point is a second start (a 4 kg mass fitted from a pooled 13 kg stays there)
                grid = [np.atleast_1d(np.asarray(g, dtype=float)) for g in h.screen_grid]
                grid = [g for g in grid if g.size == p.size]
                rss = [_safe_residual(h, sub, channels, g) for g in grid]
                rss = [math.inf if r is None else float(r @ r) for r in rss]
                if grid and math.isfinite(min(rss)):
                    starts.append(grid[int(np.argmin(rss))])
            best = None
            for p_start in starts:
                h.start = np.clip(p_start, h.lower, h.upper)
                p_k, s_k, rss_k, _, _ = _fit(
                    h, sub, channels, st.drift_nfev, jac=(lambda x, j=jac[rows]: j) if use_jac else None
                )
                if best is None or rss_k < best[2]:
                    best = (p_k, s_k, rss_k)
            estimates.append(best[0])
            stds.append(best[1])
    finally:
        h.start = start
    est, sd = np.array(estimates), np.array(stds)
    drifting = []
    for j, name in enumerate(h.names):
        if not firm_good[j]:
            continue
        for a in range(len(subs)):
            for b in range(a + 1, len(subs)):
                pa, pb, sa, sb = est[a, j], est[b, j], sd[a, j], sd[b, j]
                if not (np.isfinite(sa) and np.isfinite(sb)):
                    continue
                if pa > 0 and pb > 0:
                    d, sigma = abs(math.log(pa / pb)), math.hypot(sa / pa, sb / pb)
                    tol = math.log1p(st.drift_rel_tol)
                else:
                    ref = max(abs(pa), abs(pb), 1e-300)
                    d, sigma, tol = abs(pa - pb) / ref, math.hypot(sa, sb) / ref, st.drift_rel_tol
                if d > max(st.drift_sigma * sigma, tol) and name not in drifting:
                    drifting.append(name)
    text = "; ".join(
        f"{n}: " + ", ".join(f"{v:.3g} +- {e:.2g}" for v, e in zip(est[:, j], sd[:, j], strict=True))
        for j, n in enumerate(h.names)
        if n in drifting
    )
    return {
        "per_recording": {n: est[:, j].tolist() for j, n in enumerate(h.names)},
        "std": {n: sd[:, j].tolist() for j, n in enumerate(h.names)},
        "drifting": drifting,
        "text": text,
    }


def _decay_time(lin, factor: float = 5.0, floor_s: float = 4.0) -> float:
    """Zero padding for the convolution: ``factor`` times the slowest decay time of the modes below 200 Hz."""
    from exudyn_study.linear.system import state_space

    a = state_space(lin)[0]
    lam = np.linalg.eigvals(a)
    lam = lam[(np.abs(lam) > 2 * math.pi * 0.5) & (np.abs(lam) < 2 * math.pi * 200)]
    if lam.size == 0:
        return floor_s
    slowest = float(np.max(-1.0 / np.minimum(lam.real, -1e-9)))
    return float(min(60.0, max(floor_s, factor * slowest)))


def _effective_samples(ev: _Evaluator) -> int:
    """Independent residual samples: 2 x bandwidth x duration per channel."""
    from exudyn_study.diagnose.rig_compare import BAND_HZ, RATE_HZ

    if hasattr(ev, "n_effective"):
        return ev.n_effective
    n = 0
    for r in ev.recs:
        dur = r.filtered.shape[1] * 4 / RATE_HZ
        n += int(2 * (BAND_HZ[1] - BAND_HZ[0]) * dur) * len(r.channels)
    return n


def _aic(rss: float, k: int, n_eff: int) -> float:
    return n_eff * math.log(max(rss, 1e-300) / n_eff) + 2 * k


def _catalogue_default(physics: str, name: str) -> float:
    """Return the catalogue default of parameter ``name`` of entry ``physics``."""
    from exudyn_study.physics.catalogue import entry

    return float(entry(physics).parameter(name).default)


def _holdout_error(ev_hold: _Evaluator, system, gains) -> float:
    """Mean over the held-out recordings of the summary error of ``system`` (``ev_hold``'s simulation).

    The joint fit judges its members with the convolution (``exact=False``): a member taken
    out at its neutral values (a joint as stiff as the catalogue allows) has modes far above
    the band that the exact discretisation cannot always resolve (non-finite), the FRF can.
    """
    return float(np.mean(_holdout_errors(ev_hold, system, gains)))


def _holdout_errors(ev_hold: _Evaluator, system, gains) -> np.ndarray:
    """Per held-out recording, the summary error of ``system`` (see :func:`_holdout_error`)."""
    return np.array([summary_error(e) for e in ev_hold.errors(ev_hold.simulate(system, gains))])


def _member_neutral(comp, k: int, p) -> dict | None:
    """Composite parameter index -> value with member ``k`` taken out (its ``neutral`` values), or None."""
    h = comp.members[k]
    if not h.neutral:
        return None
    held = {}
    for j, (i, n) in enumerate(comp.specs):
        if i == k:
            held[j] = float(h.neutral.get(n, p[j]))  # the others (a linkage's mass) as fitted
    return held


def _prior_starts(comp, members, start_a, all_prior: bool) -> list:
    """Return the joint fit's further starts ``(ordinal, what, start)`` after ``start_a``.

    The second start puts the best-screened physics (``members[0]``'s) at its prior start
    (:attr:`Hypothesis.prior`), the third (``all_prior``) every member; the others keep their
    values in ``start_a``. A start equal to an earlier one is left out.
    """
    top = members[0].physics
    wanted = [(f"{top} at its prior start", {top})]
    if all_prior:
        wanted.append(("every member at its prior start", None))
    tried, out = [start_a], []
    for what, chosen in wanted:
        start = start_a.copy()
        for j, (i, n) in enumerate(comp.specs):
            h = members[i]
            if (chosen is None or h.physics in chosen) and n in h.prior:
                start[j] = float(np.clip(h.prior[n], comp.lower[j], comp.upper[j]))
        if any(np.allclose(start, t) for t in tried):
            continue
        tried.append(start)
        out.append((("second", "third")[len(out)], what, start))
    return out


def _fit_together(
    hyps,
    scores,
    build,
    ev_fit,
    ev_time,
    ev_hold,
    system_now,
    channels,
    recs,
    gains,
    rss0,
    st,
    say,
    meta,
    round_no,
):
    """Fit the best-screened linear candidates at different places together; their acceptable members.

    The members are judged one by one, not by one threshold on the whole fit: a member whose
    ``neutral`` values are known is taken out (held there) and the others refitted (chord
    steps with the joint fit's Jacobian: ``member_nfev`` evaluations, not that many times
    the number of parameters); it pays
    for itself if the joint fit with it beats that refit on the training residual by the
    Akaike criterion and cuts the held-out error of every held-out recording by at least
    ``min_member_gain`` of it.
    Members that do not pay are taken out together and the rest refitted once. A member is
    kept if its firm fitted parameters are identifiable (relative std < ``max_relative_std``,
    not at a bound) and at least one of them is. The kept members together must cut the
    held-out error (by ``min_member_gain``; each of them is proven on every held-out
    recording, so the single fits' ``min_improvement`` on the training error is not asked)
    and keep the response on.

    Returns fit records like the single fits (one per member kept), or an empty list.
    """
    from exudyn_study.diagnose.rig_hypotheses import CompositeHypothesis, HeldHypothesis

    members, places = [], set()
    for i in np.argsort(scores)[::-1]:
        h = hyps[i]
        if len(members) >= st.composite_max or scores[i] <= 0.0:
            break
        if not h.kind_linear or h.carry != "model" or h.physics == "added_mass":
            continue
        place = (h.physics, h.location)
        same = {m.component for m in members if m.physics == h.physics and h.one_per_component}
        if place in places or h.component in same:
            continue
        places.add(place)
        members.append(h)
    if len(members) < 2:
        return []
    # a damping time enters bilinearly (damping = time x stiffness); it starts at the catalogue's default
    # (the single fits push it to its bound to flatten misplaced resonances) and is fitted only with
    # composite_damping (the composite takes the bilinear term exactly)
    free = {
        i: [n for n in h.names if st.composite_damping or n != "damping_time_s"]
        for i, h in enumerate(members)
    }
    for h in members:
        if "damping_time_s" in h.names:
            k = h.names.index("damping_time_s")
            h.start = np.array(h.start, dtype=float)
            default = _catalogue_default(h.physics, "damping_time_s")
            h.start[k] = default if default > 0 or not st.composite_damping else 1e-4
    say(f"fitting {len(members)} candidates together: {', '.join(h.label for h in members)}")
    try:
        comp = CompositeHypothesis(members, build, free)
    except Exception as exc:  # noqa: BLE001 - an entry that cannot be combined: no composite
        say(f"the candidates cannot be combined: {exc}")
        return []
    comp.base_gains = gains
    n_eff = _effective_samples(ev_fit)
    info = {}
    p, std, rss, at_bound, nfev = _fit(comp, ev_fit, channels, st.fit_nfev_composite, info=info)
    if st.composite_prior_start:
        # more starts: the best-screened physics at its prior start, the others at their screening optima
        # (screened alone, the best candidate takes up the whole mismatch: soft rear supports for vertically
        # soft tank mounts; started there, the joint fit stays in that basin), and with
        # composite_all_prior_start every member at its prior start (screened alone, each member takes up a
        # share of the others' mismatch too). The composite is exact wherever it is evaluated, so one serves
        # every start. The lowest training residual wins
        start_a = comp.start.copy()
        best_start = start_a
        for ordinal, what, start in _prior_starts(comp, members, start_a, st.composite_all_prior_start):
            comp.start = start
            info_b = {}
            fit_b = _fit(comp, ev_fit, channels, st.fit_nfev_composite, info=info_b)
            say(f"  {ordinal} start ({what}): training residual {fit_b[2]:.4g} against {rss:.4g}")
            nfev += fit_b[4]
            if fit_b[2] < rss:
                p, std, rss, at_bound, _ = fit_b
                info, best_start = info_b, start
        comp.start = best_start
    if not math.isfinite(rss):
        return []
    jac = info["jac"]  # the refits below keep it (chord steps: one evaluation per step)
    # a damping time at its upper bound: the data want more damping than that spring plausibly gives (it
    # stands in for damping elsewhere, the water's or another joint's, or flattens a misplaced
    # resonance); it is held at its start and the others refitted, and stays held below
    pinned = {
        j: float(comp.start[j])
        for j, (_, n) in enumerate(comp.specs)
        if n == "damping_time_s" and p[j] >= comp.upper[j] * (1.0 - 1e-3)
    }
    if len(pinned) == p.size:  # every parameter a damping at its bound: nothing left to refit
        pinned = {}
    if pinned:
        say("  damping held at its start (it ran to its upper bound): "
            + ", ".join(comp.members[comp.specs[j][0]].label for j in pinned))
        sub = HeldHypothesis(comp, pinned)
        sub.start = np.clip(np.delete(p, list(pinned)), sub.lower, sub.upper)
        info_sub = {}
        p_sub, std_sub, rss_sub, at_sub, nfev_sub = _fit(
            sub, ev_fit, channels, st.fit_nfev_composite, info=info_sub
        )
        if math.isfinite(rss_sub):
            p, rss = sub.full(p_sub), rss_sub
            std, at_bound = np.zeros(p.size), np.zeros(p.size, bool)
            std[sub.keep], at_bound[sub.keep] = std_sub, at_sub
            jac = jac.copy()
            jac[:, sub.keep] = info_sub["jac"]
            nfev += nfev_sub
        else:
            pinned = {}
    held_out = dict(pinned)  # composite index -> value of the members taken out (and the pinned dampings)
    hold_errs = _holdout_errors(ev_hold, comp.system(p), gains)
    hold_err = float(np.mean(hold_errs))
    hold_err0 = _holdout_error(ev_hold, system_now, gains)
    verdicts = {}
    for k, h in enumerate(members):
        held = _member_neutral(comp, k, p)
        if held is None:
            verdicts[k] = None
            continue
        n_k = len(set(held) - set(pinned))  # parameters taken out beyond the pinned dampings
        held = {**pinned, **held}
        sub = HeldHypothesis(comp, held)
        sub.start = np.clip(np.delete(p, list(held)), sub.lower, sub.upper)
        p_k, _, rss_k, _, _ = _fit(sub, ev_fit, channels, st.member_nfev, jac=lambda x, c=sub.keep: jac[:, c])
        errs_k = _holdout_errors(ev_hold, sub.system(p_k), gains) if math.isfinite(rss_k) else None
        err_k = float(np.mean(errs_k)) if errs_k is not None else math.nan
        d_aic = _aic(rss, p.size, n_eff) - _aic(rss_k, p.size - n_k, n_eff)
        # the member must pay on every held-out recording (each another signal or level)
        gain = float(np.min(1.0 - hold_errs / errs_k)) if math.isfinite(err_k) else math.nan
        # (without a held-out error, e.g. an unstable refit, the training AIC alone decides)
        pays = d_aic < 0.0 and (gain >= st.min_member_gain or not math.isfinite(gain))
        verdicts[k] = {"aic": round(d_aic, 1), "holdout_gain": round(gain, 4), "pays": bool(pays)}
        say(
            f"  {h.label}: taken out (others refitted) the held-out error is {err_k:.4g} against "
            f"{hold_err:.4g} with it (on the recording it helps least {100 * gain:+.1f} %), training AIC "
            f"{d_aic:+.0f}: "
            f"{'pays for itself' if pays else 'does not pay for itself'}"
        )
        if not pays:
            held_out.update(held)
    if len(held_out) > len(pinned):
        if len(held_out) == p.size:
            say("no member of the joint fit pays for itself")
            p_all = p
        else:
            sub = HeldHypothesis(comp, held_out)
            sub.start = np.clip(np.delete(p, list(held_out)), sub.lower, sub.upper)
            p_sub, std_sub, rss, at_sub, nfev_sub = _fit(
                sub, ev_fit, channels, st.member_nfev, jac=lambda x, c=sub.keep: jac[:, c]
            )
            p_all, std, at_bound = sub.full(p_sub), np.zeros(p.size), np.ones(p.size, bool)
            std[sub.keep], at_bound[sub.keep] = std_sub, at_sub
            nfev += nfev_sub
            hold_err = _holdout_error(ev_hold, comp.system(p_all), gains)
        p = p_all
    improvement = 1.0 - math.sqrt(rss / rss0) if math.isfinite(rss) else -1.0
    r_time = _safe_residual(comp, ev_time, channels, p)
    ratio = 0.0 if r_time is None else _response_ratio(recs, ev_time.simulate(comp.system(p), gains))
    rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
    good = (rel_std < st.max_relative_std) & ~at_bound
    values = comp.member_values(p)
    out = []
    for k, h in enumerate(members):
        mine = [j for j, (i, _) in enumerate(comp.specs) if i == k]
        std_k = np.zeros(len(h.names))
        bound_k = np.zeros(len(h.names), dtype=bool)
        for j in mine:
            std_k[h.names.index(comp.specs[j][1])] = std[j]
            bound_k[h.names.index(comp.specs[j][1])] = at_bound[j]
        firm = [j for j in mine if comp.specs[j][1] not in h.may_vanish]
        rec = {
            "h": h,
            "p": values[k],
            "std": std_k,
            "at_bound": bound_k,
            "rss": rss,
            "aic": _aic(rss, p.size, n_eff),
            "identifiable": bool(np.all(good[firm]) and np.any(good[mine])),
            "improvement": improvement,
            "error_after": math.sqrt(float(r_time @ r_time) / len(recs)) if r_time is not None else 1e9,
            "response_ratio": ratio,
            "score": float(scores[hyps.index(h)]),
            "nfev": nfev,
            "member": verdicts[k],
            "holdout_error": hold_err,
        }
        rec["rejected"] = (
            "does not pay for itself in the joint fit"
            if verdicts[k] is not None and not verdicts[k]["pays"]
            else "not identifiable in the joint fit"
            if not rec["identifiable"]
            else f"the joint fit cuts the held-out error by less than {100 * st.min_member_gain:.0f} %"
            if hold_err > (1.0 - st.min_member_gain) * hold_err0
            else "the fitted model switches the response off"
            if ratio < st.min_response_ratio
            else None
        )
        out.append(rec)
    meta["candidates"] += [
        {
            "round": round_no + 1,
            "physics": f["h"].physics,
            "location": f["h"].location,
            "fitted_together": True,
            "improvement": round(f["improvement"], 4),
            "identifiable": f["identifiable"],
            "member": f["member"],
            "rejected": f["rejected"],
            "training_error_after": round(f["error_after"], 4),
            "holdout_error_after": round(f["holdout_error"], 4),
            "response_ratio": round(f["response_ratio"], 4),
            "parameters": dict(zip(f["h"].names, np.round(f["p"], 6).tolist(), strict=True)),
            "std": dict(zip(f["h"].names, np.round(f["std"], 6).tolist(), strict=True)),
        }
        for f in out
    ]
    return [f for f in out if f["rejected"] is None]


def _finding(h, p, std, at_bound, flags, band_hz, level_dependent, explanation, fit) -> Finding:
    """Return the :class:`Finding` of hypothesis ``h`` at ``p``; a parameter at its bound is flagged."""
    params = {
        n: {"value": float(v), "unit": u, "std": float(s_), "at_bound": bool(b)}
        for n, v, u, s_, b in zip(h.names, p, h.units, std, at_bound, strict=True)
    }
    bound = [
        f"{n} ended at its bound ({v['value']:.3g} {v['unit']}): the data do not determine it"
        for n, v in params.items()
        if v["at_bound"]
    ]
    return Finding(
        physics=h.physics,
        location={"sensors": list(h.sensors), "component": h.component, "interface": h.interface},
        band_hz=band_hz,
        level_dependent=level_dependent,
        explanation=explanation,
        parameters=params,
        fit=fit,
        flags=tuple(bound) + tuple(flags),
    )


def _final_refit(
    records, accepted, build, ev, channels, gains, st, say, hold_at_bound: bool = True
) -> dict | None:
    """Refit the linear findings carried into the model together; judge them again.

    Each finding was fitted in its round against the model of that round; later findings can take
    over part of its effect (a drive linkage's mass standing in for tank mounts that round 1 lacked).
    All parameters of the linear findings carried into the model (``records`` whose ``accepted`` entry
    is a linear hypothesis) are fitted together from their values (:class:`CompositeHypothesis` on the
    nominal model plus the other findings), on ``ev``; with ``hold_at_bound`` a parameter that ended at a
    bound in its round (the data did not determine it) is held there. Each member is judged again: a
    parameter at a bound (within 1 % of its log range), a firm parameter not identifiable (relative std
    above ``max_relative_std``) and (with two or more recordings) parameters that drift between the
    recordings (:func:`_drift`) are flagged.

    Returns
    -------
    dict or None
        ``members`` (the records), ``values``, ``std``, ``at_bound`` (per member, its parameter
        order), ``flags`` (per member, sentences), ``rss_before``/``rss_after`` (training residual at
        the rounds' values and after the refit) and ``meta`` (with ``held_at_bound``: the parameters
        held, and ``holdable``: those ``hold_at_bound`` holds); None with fewer than two linear
        findings or when they cannot be combined.
    """
    from exudyn_study.diagnose.rig_hypotheses import CompositeHypothesis
    from exudyn_study.physics.catalogue import entry

    members = [r for r in records if r["accepted"] is not None and r["h"].kind_linear]
    if len(members) < 2:
        return None
    mine = {r["accepted"] for r in members}

    def build_rest():
        model = build()
        for k, (name, loc, values) in enumerate(accepted):
            if k not in mine:
                entry(name).apply(model, loc, **values)
        return model

    for r in members:
        h = r["h"]
        values = accepted[r["accepted"]][2]
        lower = np.where((h.lower <= 0) & (h.upper > 0), h.upper * 1e-6, h.lower)
        # strictly inside the bounds (either sign)
        inside = (lower + 1e-3 * np.abs(lower), h.upper - 1e-3 * np.abs(h.upper))
        h.start = np.clip(h.fit_values(values), *inside)
    labels = [r["h"].label for r in members]
    # a parameter that ended at a bound in its round was not determined by the data; held, it stays there
    # (freed, it may wander on the noise: a rigid support's fore-aft stiffness can go to 2e5 N/m, the refit
    # then worsens the held-out error and is not adopted, and the vertical stiffnesses it corrects are
    # lost; the caller tries the free refit first and this one when that is not adopted)
    free, holdable = {}, []
    for k, r in enumerate(members):
        bound = np.asarray(r.get("at_bound", np.zeros(len(r["h"].names), bool)), dtype=bool)
        names = [n for n, b in zip(r["h"].names, bound, strict=True) if not b] or list(r["h"].names)
        holdable += [f"{r['h'].label}:{n}" for n in r["h"].names if n not in names]
        free[k] = names if hold_at_bound else list(r["h"].names)
    held = holdable if hold_at_bound else []
    say(
        f"final joint refit of the {len(members)} linear findings: {', '.join(labels)}"
        + (f" (held at the bounds their rounds ended at: {', '.join(held)})" if held else "")
    )
    try:
        comp = CompositeHypothesis([r["h"] for r in members], build_rest, free)
    except Exception as exc:  # noqa: BLE001 - entries that cannot be combined: no refit
        say(f"the findings cannot be refitted together: {exc}")
        return None
    comp.base_gains = gains
    r0 = _safe_residual(comp, ev, channels, comp.start)
    if r0 is None:
        return None
    info = {}
    p, std, rss, at_bound, nfev = _fit(comp, ev, channels, st.final_nfev, info=info)
    # at a bound: within 1 % of the parameter's (log) range of it (the solver stops short of the bound
    # when the residual flattens there, e.g. a mass the data do not want running to its lower bound)
    _, lo, hi = log_bounds(comp)
    x, margin = to_x(comp, p), 0.01 * (hi - lo)
    at_bound = at_bound | (x <= lo + margin) | (x >= hi - margin)
    rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
    good = (rel_std < st.max_relative_std) & ~at_bound
    drift = None
    if st.drift_check and math.isfinite(rss) and len(getattr(ev, "recs", ())) > 1:
        drift = _drift(comp, p, good, ev, channels, st, info.get("jac"))
    values = comp.member_values(p)
    out_std, out_bound, out_flags = [], [], []
    for k, r in enumerate(members):
        h = r["h"]
        spec = {n: j for j, (i, n) in enumerate(comp.specs) if i == k}
        # a parameter held at the bound it ended at in its round: still at it, no std
        std_k = np.array([std[spec[n]] if n in spec else 0.0 for n in h.names])
        bound_k = np.array([bool(at_bound[spec[n]]) if n in spec else True for n in h.names])
        flags = []
        weak = [n for n in spec if n not in h.may_vanish and not good[spec[n]] and not at_bound[spec[n]]]
        if weak:
            flags.append(
                "not identifiable in the final joint refit of all findings: "
                + ", ".join(f"{n} (relative std {rel_std[spec[n]]:.2g})" for n in weak)
            )
        if drift is not None:
            moved = [n for n in spec if comp.names[spec[n]] in drift["drifting"]]
            if moved:
                flags.append(
                    "drifts between the training recordings in the final joint refit: "
                    + "; ".join(
                        f"{n} " + ", ".join(f"{v:.3g}" for v in drift["per_recording"][comp.names[spec[n]]])
                        for n in moved
                    )
                )
        out_std.append(std_k)
        out_bound.append(bound_k)
        out_flags.append(flags)
    rss0 = float(r0 @ r0)
    meta = {
        "members": labels,
        "train_residual_before": rss0,
        "train_residual_after": rss,
        "nfev": nfev,
        "parameters": {n: float(v) for n, v in zip(comp.names, p, strict=True)},
        "at_bound": [n for n, b in zip(comp.names, at_bound, strict=True) if b],
        "held_at_bound": held,
        "holdable": holdable,
        "flags": {lab: f for lab, f in zip(labels, out_flags, strict=True) if f},
    }
    if drift is not None:
        meta["per_recording"] = drift["per_recording"]
    return {
        "members": members,
        "values": values,
        "std": out_std,
        "at_bound": out_bound,
        "flags": out_flags,
        "rss_before": rss0,
        "rss_after": rss if math.isfinite(rss) else math.inf,
        "meta": meta,
    }


def _hypotheses(cand, ctx) -> list:
    """Return the hypotheses of registered candidate ``cand`` in the round ``ctx`` (checked)."""
    made = list(cand.factory(ctx) or [])
    for h in made:
        if not isinstance(h, Hypothesis):
            raise InputError(
                f"rig candidate {cand.physics!r}: its factory returned {h!r}; expected Hypothesis "
                "objects (exudyn_study.diagnose.rig_hypotheses)"
            )
    return made


def _fit_on_distortion(cands, ctx, ev_d, ev_time, channels, system, gains, st, say, meta, round_no):
    """Screen and fit simulated (nonlinear) candidates on the level-dependent share of the response.

    ``ev_d`` (:class:`_DistortionEvaluator`) compares the measured and simulated differences
    between one drive at two levels; the current ``system`` leaves the whole measured one
    (or, with nonlinear findings, what they miss). A candidate is acceptable if it explains
    at least ``min_improvement`` of it (``1 - rms after / rms before``), its parameters are
    identifiable and its model keeps the response on (``ev_time``: the training recordings).
    Returns fit records like the single fits (``rejected`` None if acceptable).
    """
    hyps = [h for cand in cands for h in _hypotheses(cand, ctx)]
    if not hyps:
        return []
    for h in hyps:
        h.base_gains = gains
    r0 = ev_d.residual_vector(system, gains)
    rss0 = float(r0 @ r0)
    say(f"screening {len(hyps)} nonlinear candidates on the level-dependent share of the response")
    scores = [_screen(h, ev_d, channels, r0, st.screen_nfev) for h in hyps]
    order = [i for i in np.argsort(scores)[::-1] if scores[i] >= st.min_screen_share * max(scores)]
    n_eff = _effective_samples(ev_d)
    out = []
    for i in order[: st.n_fit_simulated]:
        h = hyps[i]
        say(f"fitting {h.label} on the level-dependent share (screening score {scores[i]:.3f})")
        p, std, rss, at_bound, nfev = _fit(h, ev_d, channels, st.fit_nfev_simulated)
        rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
        firm = np.array([n not in h.may_vanish for n in h.names])
        good = (rel_std < st.max_relative_std) & ~at_bound
        r_time = _safe_residual(h, ev_time, channels, p)
        sims = None if r_time is None else ev_time.simulate(h.system(p), _gains(h, p, channels))
        ratio = 0.0 if sims is None else _response_ratio(ev_time.recs, sims)
        rss_time = math.inf if r_time is None else float(r_time @ r_time)
        f = {
            "h": h,
            "p": p,
            "std": std,
            "rss": rss,
            "aic": _aic(rss, p.size, n_eff),
            "identifiable": bool(np.all(good[firm]) and np.any(good)),
            "at_bound": at_bound,
            "improvement": 1.0 - math.sqrt(rss / rss0) if math.isfinite(rss) and rss0 > 0 else -1.0,
            "error_after": math.sqrt(rss_time / len(ev_time.recs)) if r_time is not None else 1e9,
            "rss_time": rss_time,
            "response_ratio": ratio,
            "score": float(scores[i]),
            "nfev": nfev,
            "on_distortion": True,
        }
        f["rejected"] = (
            "not identifiable"
            if not f["identifiable"]
            else "explains too little of the level-dependent share"
            if f["improvement"] < st.min_improvement
            else "the fitted model switches the response off"
            if ratio < st.min_response_ratio
            else None
        )
        out.append(f)
    meta["candidates"] += [
        {
            "round": round_no + 1,
            "physics": f["h"].physics,
            "location": f["h"].location,
            "fitted_on": "level-dependent share",
            "signature_score": round(f["score"], 4),
            "improvement": round(f["improvement"], 4),
            "identifiable": f["identifiable"],
            "rejected": f["rejected"],
            "training_error_after": round(f["error_after"], 4),
            "response_ratio": round(f["response_ratio"], 4),
            "parameters": dict(zip(f["h"].names, np.round(f["p"], 6).tolist(), strict=True)),
            "std": dict(zip(f["h"].names, np.round(f["std"], 6).tolist(), strict=True)),
        }
        for f in out
    ]
    return out


def _polish(f: dict, ev: _Evaluator, channels, recs, st, say) -> None:
    """Refine a fit found on log transmissibilities in the time domain, if that keeps the response on.

    Near the truth the time-domain fit is the sharper one (the blind benchmark's single
    effects); far from it (other effects still missing) it runs towards switching the
    response off, and the log-spectral fit is kept.
    """
    h = f["h"]
    h.start = np.asarray(f["p"], dtype=float)
    say(f"polishing {h.label} in the time domain")
    p, std, rss, at_bound, _ = _fit(h, ev, channels, st.polish_nfev)
    if not (rss < f["rss_time"] and np.isfinite(rss)):
        return
    sims = ev.simulate(h.system(p), _gains(h, p, channels))
    if _response_ratio(recs, sims) < st.min_response_ratio:
        return
    rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
    firm = np.array([n not in h.may_vanish for n in h.names])
    good = (rel_std < st.max_relative_std) & ~at_bound
    if np.all(good[firm]) and np.any(good):
        f.update(p=p, std=std, rss_time=rss, polished=True, at_bound=at_bound)


def _batch(ok, max_batch: int) -> list:
    """Return the best acceptable fit and, if linear, up to ``max_batch - 1`` more at other components.

    Only linear candidates join a batch, each at a component (body, joint's component, the
    linkage) no earlier member touches, and a sensor gain only at another sensor.
    """
    batch = [ok[0]]
    if not ok[0]["h"].kind_linear:
        return batch
    for f in ok[1:]:
        if len(batch) >= max_batch:
            break
        h = f["h"]
        if not h.kind_linear:
            continue
        if any(h.component == g["h"].component or h.location == g["h"].location for g in batch):
            continue
        batch.append(f)
    return batch


def _response_ratio(recs, sims) -> float:
    """Median over channels of the band-limited rms of the simulation over that of the measurement."""
    ratios = [
        np.sqrt(np.mean(band_filter(s_) ** 2, axis=1)) * r.scale for r, s_ in zip(recs, sims, strict=True)
    ]
    return float(np.median(np.concatenate(ratios)))


def _set_offsets(evaluators, system) -> None:
    """Carry the current model's nonlinear elements into linear candidates (first order).

    With local nonlinear elements in the current model, a linear candidate's response is
    taken as its linear response plus the current model's nonlinear correction (exact
    nonlinear minus linear-tangent simulation, per recording): the correction's change with
    a linear candidate is of second order. Exact simulations of the accepted model follow.
    """
    for ev in evaluators:
        ev.offset = None
        ev._cache = {}
        if isinstance(system, NonlinearSystem):
            nonlinear = ev.simulate_exact(system)
            tangent = ev.simulate(system.lin)
            ev.offset = [a - b for a, b in zip(nonlinear, tangent, strict=True)]
            ev._cache = {("exact", id(system)): (system, nonlinear)}  # compare() needs them next


def _modes(lin):
    import scipy.linalg as sla

    lin = getattr(lin, "lin", lin)  # a NonlinearSystem: its linear tangent
    w2 = sla.eigh(lin.stiffness, lin.mass, eigvals_only=True)
    return np.sqrt(np.maximum(w2, 0.0)) / (2 * math.pi)


@one_blas_thread
def diagnose_rig(
    variant: int,
    train: Sequence,
    holdout: Sequence,
    damping="adams-default",
    progress: Callable | None = None,
    bodies=None,
    sensors=None,
    candidates: Sequence[str] | None = None,
    settings: RigDiagnosisSettings | None = None,
    cache_dir=None,
    figures: dict | None = None,
) -> Diagnosis:
    """Diagnose the mismatch between model ``variant`` and the recordings.

    Runs with one BLAS thread (:func:`~exudyn_study.infra.blas.one_blas_thread`): the work is
    thousands of small (~100x100) eigen/solve problems, which multi-threaded BLAS makes
    several times slower on a shared machine.

    Parameters
    ----------
    variant : {1, 2, 3}
    train, holdout : sequence of Recording or paths
        Training recordings (fitted) and held-out recordings (only evaluated).
    damping : str
        The nominal model's damping function.
    progress : callable, optional
        Called with short status texts.
    bodies, sensors
        Reduced bodies and sensor names for :func:`~exudyn_study.model.build_model_from_bodies`
        (tests); default the variant's chassis bodies and all sensors.
    candidates : sequence of str, optional
        Catalogue entries to consider (default all the rig path can fit).
    settings : RigDiagnosisSettings, optional
    cache_dir : path, optional
        Flexible-body cache.
    figures : dict, optional
        Filled with the arrays of the report's figures
        (:func:`exudyn_study.diagnose.report.write_report`).

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        No training or held-out recording, different sensor layouts, no drive channel,
        channels the model lacks.
    """
    from exudyn_study.bodies.damping import parse_damping
    from exudyn_study.model import build_model, build_model_from_bodies
    from exudyn_study.physics.catalogue import CATALOGUE
    from exudyn_study.physics.entries import location_point

    st = settings or RigDiagnosisSettings()
    say = progress or (lambda text: log.info(text))
    t_start = time.perf_counter()
    tr, ho = _load(train, "train"), _load(holdout, "holdout")
    if not tr:
        raise InputError("no training recording given (--train): the diagnosis fits on it")
    if not ho:
        raise InputError(
            "no held-out recording given (--holdout): the diagnosis proves a fit on recordings it "
            "was not fitted to; give another signal or excitation level"
        )
    _check_layouts(tr + ho)
    damping_fn = parse_damping(damping) if isinstance(damping, str) else damping

    def build():
        if bodies is None:
            return build_model(
                variant, damping=damping_fn, sensors=sensors, cache_dir=cache_dir, exudyn_mesh="used"
            )
        return build_model_from_bodies(
            bodies, variant, damping=damping_fn, sensors=sensors, exudyn_mesh="used"
        )

    from exudyn_study.physics.catalogue import entry

    wanted = set(candidates) if candidates is not None else None

    def want(name):
        return (wanted is None or name in wanted) and name in CATALOGUE

    accepted = []  # (entry name, location, parameters) applied to the model, in order

    def build_current():
        model = build()
        for name, loc, values in accepted:
            entry(name).apply(model, loc, **values)
        return model

    def assembled(model):
        sensor_names = tuple(model.sensors)
        locations = list(sensor_names) + sorted(
            k for k in model.interfaces if not k.startswith("rear_foundation")
        )
        markers = {loc: location_point(model, loc) for loc in locations}
        model.assemble()
        return locations, markers, model_system(model)

    say("building the nominal model")
    model = build()
    locations, markers, lin0 = assembled(model)
    sensor_names = tuple(model.sensors)
    train_recs = [prepare(r, sensor_names, n, st.train_duration_s) for n, r in tr]
    screen_recs = [prepare(r, sensor_names, n, st.screen_duration_s) for n, r in tr[:1]]
    hold_recs = [prepare(r, sensor_names, n) for n, r in ho]
    channels = train_recs[0].channels
    pad = _decay_time(lin0)
    ev_train = _Evaluator(train_recs, sensor_names, pad, exact=True)
    ev_train_nonlinear = _Evaluator(
        [prepare(r, sensor_names, n, st.train_duration_nonlinear_s) for n, r in tr],
        sensor_names,
        pad,
        exact=True,
    )
    ev_hold = _Evaluator(hold_recs, sensor_names, pad, exact=True)
    ev_hold_fast = _Evaluator(hold_recs, sensor_names, pad)  # judges the members of joint fits
    ev_screen = _Evaluator(screen_recs, sensor_names, pad)
    evaluators = (ev_train, ev_train_nonlinear, ev_hold, ev_screen, ev_hold_fast)
    ev_spectral = _SpectralEvaluator(train_recs, sensor_names)
    # one drive at two levels inside the training data: nonlinear candidates are judged on the
    # level-dependent share of the response, which no linear error of the model disturbs
    pair = _level_pair(ev_train_nonlinear.recs)
    ev_distortion = _DistortionEvaluator(pair, sensor_names, pad) if pair is not None else None
    # ... and proven on it at a held-out level of that drive (a weaker training, a stronger held-out one)
    pair_hold = _level_pair(ev_train_nonlinear.recs + hold_recs, stronger_in=hold_recs)
    ev_distortion_hold = _DistortionEvaluator(pair_hold, sensor_names, pad) if pair_hold is not None else None
    p_cell = st.p_value / (len(tr) + len(ho))

    def compare(lin, gains):
        sims_tr, sims_ho = ev_train.simulate_exact(lin, gains), ev_hold.simulate_exact(lin, gains)
        maps = [
            significance_map(r, s_, min_effect=st.min_effect, p_value=p_cell)
            for r, s_ in zip(train_recs + hold_recs, sims_tr + sims_ho, strict=True)
        ]
        sig = np.zeros((len(channels), len(BANDS_HZ)), dtype=bool)
        for m in maps:
            sig |= m.significant
        return sims_tr, sims_ho, maps, sig

    # 1-2 compare and locate ----------------------------------------------------------------
    say("comparing the nominal model with the recordings")
    ones = np.ones(len(channels))
    sims_tr, sims_ho, maps, significant = compare(lin0, None)
    sims_ho_nominal = sims_ho
    err_tr0 = [summary_error(e) for e in ev_train.errors(sims_tr)]
    err_ho0 = [summary_error(e) for e in ev_hold.errors(sims_ho)]
    meta = {
        "model": int(variant),
        "damping": str(damping),
        "train": [n for n, _ in tr],
        "holdout": [n for n, _ in ho],
        "metric": METRIC,
        "nominal_train_error": err_tr0,
        "nominal_holdout_error": err_ho0,
        "significant_cells": int(significant.sum()),
        "bands_hz": [list(b) for b in BANDS_HZ],
        "residual_z": [m.z.round(2).tolist() for m in maps],
        "residual_effect": [m.effect.round(4).tolist() for m in maps],
        "channels": list(channels),
        "candidates": [],
        "rounds": [],
    }
    if figures is not None:
        _figures_before(figures, tr + ho, train_recs + hold_recs, sims_tr + sims_ho, lin0, sensor_names, maps)
        figures["train"] = [_label(n) for n, _ in tr]
        figures["holdout"] = [_label(n) for n, _ in ho]
    if not significant.any():
        meta["wall_s"] = time.perf_counter() - t_start
        say("no significant mismatch: no missing physics found")
        return Diagnosis(False, [], [], meta)

    findings, unexplained = [], []
    records = []  # per finding: its hypothesis, place in ``accepted``, systems before/after its round
    distortion = _distortion_shares(train_recs + hold_recs)
    if distortion is not None:
        meta["nonlinear_share"] = dict(zip(channels, np.round(distortion[0], 5).tolist(), strict=True))
    sys_r, gains_r, model_r, located = lin0, ones, model, []
    _set_offsets(evaluators, sys_r)
    refitted = None  # labels of the linear findings last refitted together

    def final_refit_now() -> None:
        """4b the linear findings refitted together and judged again (once per set of them)."""
        nonlocal sims_tr, sims_ho, maps, significant, refitted
        linear = tuple(r["h"].label for r in records if r["accepted"] is not None and r["h"].kind_linear)
        if not st.final_refit or len(records) < 2 or linear == refitted:
            return
        refitted = linear
        t_refit = time.perf_counter()
        error_now = float(np.mean([summary_error(e) for e in ev_train.errors(sims_tr)]))
        ev_final = ev_spectral if error_now > st.spectral_above_error else ev_train
        hold_before = float(np.mean([summary_error(e) for e in ev_hold.errors(sims_ho)]))

        def rebuild():
            nonlocal model_r, locations, markers, sys_r
            model_r = build_current()
            locations, markers, sys_r = assembled(model_r)
            _set_offsets(evaluators, sys_r)
            return compare(sys_r, gains_r)

        # free first (every parameter may move); if that is not adopted, again with the parameters that ended
        # at a bound in their rounds held there (freed, the undetermined ones can wander on the noise)
        tried = []
        for hold in (False, True):
            refit = _final_refit(records, accepted, build, ev_final, channels, gains_r, st, say, hold)
            if refit is None:
                break
            saved = list(accepted)
            refit["meta"]["holdout_before"] = hold_before
            refit["meta"]["evaluator"] = (
                "log transmissibilities" if ev_final is ev_spectral else "time histories"
            )
            adopted = False
            if refit["rss_after"] < refit["rss_before"]:
                for r, p_new in zip(refit["members"], refit["values"], strict=True):
                    accepted[r["accepted"]] = r["h"].carried(p_new)
                new = rebuild()
                hold_after = float(np.mean([summary_error(e) for e in ev_hold.errors(new[1])]))
                refit["meta"]["holdout_after"] = hold_after
                adopted = hold_after <= hold_before
                if adopted:
                    sims_tr, sims_ho, maps, significant = new
                else:
                    accepted[:] = saved
                    sims_tr, sims_ho, maps, significant = rebuild()
            tried.append({
                "held_at_bound": refit["meta"]["held_at_bound"],
                "holdout_after": refit["meta"].get("holdout_after"),
                "adopted": adopted,
            })
            if adopted or hold or not refit["meta"]["holdable"]:
                break  # adopted, or held already, or holding would repeat this refit
        if refit is not None:
            refit["meta"]["attempts"] = tried
            refit["meta"]["adopted"] = adopted
            say(
                "final joint refit of "
                + ", ".join(r["h"].label for r in refit["members"])
                + (
                    ": adopted"
                    if adopted
                    else ": not adopted (it does not lower both the training residual "
                    "and the held-out error), the rounds' values kept"
                )
            )
            if adopted:
                per_member = (
                    refit["members"],
                    refit["values"],
                    refit["std"],
                    refit["at_bound"],
                    refit["flags"],
                )
                for r, p_new, std_new, bound_new, flags in zip(*per_member, strict=True):
                    old = findings[r["finding"]]
                    text = _explain(r["h"], p_new, std_new, r["lin_before"], r["lin_after"], r["located"])
                    findings[r["finding"]] = _finding(
                        r["h"],
                        p_new,
                        std_new,
                        bound_new,
                        flags,
                        old.band_hz,
                        old.level_dependent,
                        text + " (Values from the final joint refit of all findings; the modes named are "
                        "those the finding moved in its round.)",
                        old.fit,
                    )
            refit["meta"]["wall_s"] = round(time.perf_counter() - t_refit, 1)
            meta["final_refit"] = refit["meta"]

    stop_reason = f"mismatch left after {st.max_findings} rounds (the most this diagnosis runs)"
    round_s = 0.0
    for round_no in range(st.max_findings):
        elapsed = time.perf_counter() - t_start
        if round_no > 0 and elapsed + round_s > st.time_budget_s:
            stop_reason = (
                f"mismatch left after {len(findings)} findings: the time budget of {st.time_budget_s:.0f} s "
                f"would be exceeded by another round ({elapsed:.0f} s used, the last round took "
                f"{round_s:.0f} s)"
            )
            break
        t_round = time.perf_counter()
        lin_r = getattr(sys_r, "lin", sys_r)
        strength = np.max([np.where(m.significant, m.effect, 0.0) for m in maps], axis=0).max(axis=1)
        located = [channels[i] for i in np.argsort(-strength) if significant[i].any()]  # strongest first
        bands = [BANDS_HZ[j] for j in np.flatnonzero(significant.any(axis=0))]
        band_hz = (min(b[0] for b in bands), max(b[1] for b in bands))
        # level dependence of what is left (a linear finding can uncover a nonlinear one)
        level_dependent = _level_dependent(
            train_recs + hold_recs, sims_tr + sims_ho, np.flatnonzero(significant.any(axis=1)), distortion
        )
        done = {(name, loc) for name, loc, _ in accepted} | {
            (f.physics, f.location["sensors"][0]) for f in findings if f.physics == "sensor_gain"
        }

        # 3 name: candidates from the registry, then screening --------------------------------
        ctx = CandidateContext(
            model=model_r,
            lin=lin_r,
            build=build_current,
            locations=locations,
            markers=markers,
            sensor_names=sensor_names,
            located=located,
            level_dependent=level_dependent,
            done=done,
            say=say,
            nonlinear_sensors=_nonlinear_sensors(distortion, channels, located),
        )
        hyps: list[Hypothesis] = []
        nonlinear_s = None  # wall time of the nonlinear candidates' screening and fits in this round
        deferred = []  # simulated candidates judged on the level-dependent share if no linear one fits
        for cand in list(RIG_CANDIDATES.values()):
            if not want(cand.physics):
                continue
            if ev_distortion is not None and cand.kind == "simulated":
                if level_dependent or ctx.nonlinear_sensors:
                    deferred.append(cand)
                continue
            if cand.needs_level_dependence and not level_dependent:
                continue
            hyps += _hypotheses(cand, ctx)
        if not hyps and not deferred:
            stop_reason = "no catalogue candidate applies to the located mismatch"
            break
        for h in hyps:
            h.base_gains = gains_r
        # far off (error > 100 %: resonances misplaced): judge and fit on log transmissibilities
        error_now = float(np.mean([summary_error(e) for e in ev_train.errors(sims_tr)]))
        spectral = error_now > st.spectral_above_error
        if spectral:
            hyps = [h for h in hyps if h.kind_linear]
        ev_fit = ev_spectral if spectral else ev_train
        ev_scr = ev_spectral if spectral else ev_screen
        say(
            f"round {round_no + 1}: screening {len(hyps)} candidates"
            + (f" on log transmissibilities (training error {error_now:.2f})" if spectral else "")
        )
        r0 = ev_fit.residual_vector(lin_r, gains_r)
        r0_screen = ev_scr.residual_vector(lin_r, gains_r)
        scores = [_screen(h, ev_scr, channels, r0_screen, st.screen_nfev) for h in hyps]
        order = [
            i for i in np.argsort(scores)[::-1] if scores[i] >= st.min_screen_share * max(scores, default=0.0)
        ]
        # 4 fit the best candidates ----------------------------------------------------------
        n_eff = _effective_samples(ev_fit)
        rss0 = float(r0 @ r0)
        rss0_time = float(np.sum(ev_train.residual_vector(lin_r, gains_r) ** 2))
        aic0 = _aic(rss0, 0, n_eff)
        fitted = []
        chosen, n_simulated = [], 0
        for i in order:
            if len(chosen) == st.n_fit:
                break
            if not hyps[i].kind_linear:
                if n_simulated == st.n_fit_simulated:
                    continue
                n_simulated += 1
            chosen.append(i)
        for i in chosen:
            h = hyps[i]
            say(f"fitting {h.label} (screening score {scores[i]:.3f})")
            if h.kind_linear:
                p, std, rss, at_bound, nfev = _fit(h, ev_fit, channels, st.fit_nfev)
            else:  # simulated in time: fitted on shorter records, judged on the full training records
                p, std, _, at_bound, nfev = _fit(h, ev_train_nonlinear, channels, st.fit_nfev_simulated)
            rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
            firm = np.array([n not in h.may_vanish for n in h.names])
            good = (rel_std < st.max_relative_std) & ~at_bound
            sys_p, gains_p = h.system(p), _gains(h, p, channels)
            r_fit = _safe_residual(h, ev_train, channels, p)
            if r_fit is None:
                rss, sims_fit, good[:] = 1e9 * rss0, [r.measured * 0.0 for r in train_recs], False
                rss_time = 1e9 * rss0_time
            else:
                rss_time = float(r_fit @ r_fit)
                if not spectral:
                    rss = rss_time
                sims_fit = ev_train.simulate(sys_p, gains_p)
            fitted.append(
                {
                    "h": h,
                    "p": p,
                    "std": std,
                    "rss": rss,
                    "aic": _aic(rss, p.size, n_eff),
                    # every firm parameter identifiable, and at least one parameter
                    "identifiable": bool(np.all(good[firm]) and np.any(good)),
                    "good": good,
                    "at_bound": at_bound,
                    "improvement": 1.0 - math.sqrt(rss / rss0),
                    "error_after": math.sqrt(rss_time / len(train_recs)),
                    "rss_time": rss_time,
                    "response_ratio": _response_ratio(train_recs, sims_fit),
                    "score": float(scores[i]),
                    "nfev": nfev,
                }
            )
        for f in fitted:
            if not f["identifiable"]:
                f["rejected"] = "not identifiable"
            elif f["improvement"] < st.min_improvement:
                f["rejected"] = "explains too little"
            elif f["response_ratio"] < st.min_response_ratio:
                f["rejected"] = "the fitted model switches the response off"
            else:
                f["rejected"] = None
        if st.drift_check and len(train_recs) > 1:
            # only the fits the round would take (the best acceptable one and its batch; a fit rejected
            # here lets the next one in): each check costs about one fit per recording
            while True:
                ok = sorted((f for f in fitted if f["rejected"] is None), key=lambda f: f["aic"])
                todo = [f for f in (_batch(ok, st.max_batch) if ok else []) if "drift" not in f]
                todo = [f for f in todo if f["h"].kind_linear]
                if not todo:
                    break
                for f in todo:
                    f["drift"] = _drift(f["h"], f["p"], f["good"], ev_fit, channels, st)
                    if f["drift"] is not None and f["drift"]["drifting"]:
                        f["rejected"] = (
                            f"its parameters drift between the training recordings ({f['drift']['text']})"
                        )
                        say(f"{f['h'].label}: {f['rejected']}")
        meta["candidates"] += [
            {
                "round": round_no + 1,
                "physics": f["h"].physics,
                "location": f["h"].location,
                "signature_score": round(f["score"], 4),
                "aic": round(f["aic"] - aic0, 1),
                "improvement": round(f["improvement"], 4),
                "identifiable": f["identifiable"],
                "rejected": f["rejected"],
                "training_error_after": round(f["error_after"], 4),
                "response_ratio": round(f["response_ratio"], 4),
                "parameters": dict(zip(f["h"].names, np.round(f["p"], 6).tolist(), strict=True)),
                **({"per_recording": f["drift"]["per_recording"]} if f.get("drift") else {}),
            }
            for f in fitted
        ]
        ok = [f for f in fitted if f["rejected"] is None]
        together = False
        if not ok and spectral and st.composite_max > 1:
            ok = _fit_together(
                hyps,
                scores,
                build_current,
                ev_spectral,
                ev_train,
                ev_hold_fast,
                lin_r,
                channels,
                train_recs,
                gains_r,
                rss0,
                st,
                say,
                meta,
                round_no,
            )
            together = bool(ok)
        if not ok and deferred:
            # the linear findings refitted together first: the level-dependent share is compared in
            # time, so the nonlinear candidates need the linear model as right as it gets
            final_refit_now()
            t_nonlinear = time.perf_counter()
            fitted_nl = _fit_on_distortion(
                deferred,
                ctx,
                ev_distortion,
                ev_train_nonlinear,
                channels,
                sys_r,
                gains_r,
                st,
                say,
                meta,
                round_no,
            )
            fitted += fitted_nl
            ok = [f for f in fitted_nl if f["rejected"] is None]
            nonlinear_s = time.perf_counter() - t_nonlinear
        if not ok:
            stop_reason = "no catalogue entry explains it: " + "; ".join(
                f"{f['h'].label} improves {100 * f['improvement']:.0f} % ({f['rejected']})" for f in fitted
            )
            break
        ok.sort(key=lambda f: f["aic"])
        batch = ok if together else _batch(ok, st.max_batch)
        if spectral and not together:
            for f in batch:
                if f["h"].kind_linear:
                    _polish(f, ev_train, channels, train_recs, st, say)
        # carry the findings into the model (exact: a nonlinear model is simulated in time)
        sys_before, gains_before, n_accepted = sys_r, gains_r, len(accepted)

        def carry(members, n_accepted=n_accepted, gains_before=gains_before, sys_before=sys_before):
            nonlocal model_r, locations, markers, sys_r, gains_r
            del accepted[n_accepted:]
            gains_r = gains_before
            for f in members:
                if f["h"].carry == "gains":
                    gains_r = _gains(f["h"], f["p"], channels)
                else:
                    accepted.append(f["h"].carried(f["p"]))
            if len(accepted) > n_accepted:
                model_r = build_current()
                locations, markers, sys_r = assembled(model_r)
            else:
                sys_r = sys_before
            _set_offsets(evaluators, sys_r)
            return compare(sys_r, gains_r)

        sims_tr1, sims_ho1, maps1, significant1 = carry(batch)
        if len(batch) > 1 and not together:
            # findings fitted one by one may overlap: keep the batch only if together they beat the best alone
            r_batch = ev_fit.residual_vector(getattr(sys_r, "lin", sys_r), gains_r)
            if not float(r_batch @ r_batch) < batch[0]["rss"]:
                say(
                    f"the {len(batch)} fits together do not beat {batch[0]['h'].label} alone: keeping it only"
                )
                batch = batch[:1]
                sims_tr1, sims_ho1, maps1, significant1 = carry(batch)
        per_ho0, per_ho1 = ev_hold.errors(sims_ho), ev_hold.errors(sims_ho1)
        fit = {
            "train_before": float(np.mean([summary_error(e) for e in ev_train.errors(sims_tr)])),
            "train_after": float(np.mean([summary_error(e) for e in ev_train.errors(sims_tr1)])),
            "holdout_before": float(np.mean([summary_error(e) for e in per_ho0])),
            "holdout_after": float(np.mean([summary_error(e) for e in per_ho1])),
            "metric": METRIC,
            "per_channel": {
                _label(name): {
                    c: {"before": float(e0[k]), "after": float(e1[k])} for k, c in enumerate(channels)
                }
                for (name, _), e0, e1 in zip(ho, per_ho0, per_ho1, strict=True)
            },
            "relative_pseudo_damage": _damage(hold_recs, sims_ho, sims_ho1),
        }
        held_share = None
        if ev_distortion_hold is not None and any(f.get("on_distortion") for f in batch):
            # a nonlinear finding fitted on the level-dependent share: proven on it at a held-out level
            r_before = ev_distortion_hold.residual_vector(sys_before, gains_before)
            r_after = ev_distortion_hold.residual_vector(sys_r, gains_r)
            held_share = 1.0 - math.sqrt(float(r_after @ r_after) / max(float(r_before @ r_before), 1e-300))
            fit["holdout_level_dependent_improvement"] = held_share
            say(f"it explains {100 * held_share:.0f} % of the level-dependent share at the held-out level")
        nonlinear_proven = (
            held_share is not None
            and held_share >= st.min_improvement
            and fit["holdout_after"] <= (1.0 + st.nonlinear_holdout_tolerance) * fit["holdout_before"]
        )
        if fit["holdout_after"] > fit["holdout_before"] and not nonlinear_proven:
            # it fits the training recordings but not the held-out ones: not a finding
            labels = " + ".join(f["h"].label for f in batch)
            say(
                f"{labels} worsens the held-out error ({fit['holdout_before']:.4f} -> "
                f"{fit['holdout_after']:.4f}): not accepted"
            )
            carry([])
            stop_reason = (
                f"the best fit ({labels}) improves the training recordings but worsens the held-out error "
                f"({fit['holdout_before']:.3g} -> {fit['holdout_after']:.3g})"
            )
            break
        if len(batch) > 1:
            fit["together_with"] = [f["h"].label for f in batch]  # the fit is that of the whole round
        k_accepted = n_accepted
        for f in batch:
            h, p = f["h"], f["p"]
            lin_before, lin_after = getattr(sys_before, "lin", sys_before), getattr(sys_r, "lin", sys_r)
            at_bound = np.asarray(f.get("at_bound", np.zeros(len(h.names), bool)), dtype=bool)
            findings.append(
                _finding(
                    h,
                    p,
                    f["std"],
                    at_bound,
                    (),
                    band_hz,
                    # fitted on the level-dependent share: level dependent by construction
                    level_dependent or bool(f.get("on_distortion")),
                    _explain(h, p, f["std"], lin_before, lin_after, located),
                    fit,
                )
            )
            records.append(
                {
                    "h": h,
                    "finding": len(findings) - 1,
                    # the entry's place in ``accepted`` (None: carried as output gains)
                    "accepted": None if h.carry == "gains" else k_accepted,
                    "lin_before": lin_before,
                    "lin_after": lin_after,
                    "located": located,
                    "at_bound": at_bound,  # the round's: what the data did not determine
                }
            )
            if h.carry != "gains":
                k_accepted += 1
        say(
            f"finding {len(findings)}: {' + '.join(f['h'].label for f in batch)}, held-out error "
            f"{fit['holdout_before']:.4f} -> {fit['holdout_after']:.4f}"
        )
        sims_tr, sims_ho, maps, significant = sims_tr1, sims_ho1, maps1, significant1
        round_s = time.perf_counter() - t_round
        meta["rounds"].append({"round": round_no + 1, "candidates": len(hyps), "wall_s": round(round_s, 1)})
        if nonlinear_s is not None:
            meta["rounds"][-1]["nonlinear_s"] = round(nonlinear_s, 1)
        if not significant.any():
            break
    final_refit_now()
    if significant.any():
        unexplained.append(
            _unexplained(
                significant,
                channels,
                _level_dependent(
                    train_recs + hold_recs,
                    sims_tr + sims_ho,
                    np.flatnonzero(significant.any(axis=1)),
                    distortion,
                ),
                stop_reason,
            )
        )
    lin_r = getattr(sys_r, "lin", sys_r)
    if findings:
        final_errors = ev_hold.errors(sims_ho)
        meta["final_holdout_error"] = [summary_error(e) for e in final_errors]
        meta["final_holdout_per_channel"] = {
            _label(name): {c: float(e[k]) for k, c in enumerate(channels)}
            for (name, _), e in zip(ho, final_errors, strict=True)
        }
        meta["relative_pseudo_damage"] = _damage(hold_recs, sims_ho_nominal, sims_ho)
        if figures is not None:
            figures["after_T"] = {
                lab: _model_t(lin_r, figures["freq_hz"], rec.channels, sensor_names, gains_r)
                for lab, rec in zip(figures["labels"], train_recs + hold_recs, strict=True)
            }
            figures["located_sensors"] = [s_ for f in findings for s_ in f.location["sensors"]][:3] or located
            figures["physics"] = " + ".join(f.physics for f in findings)
            figures["pseudo_damage"] = {
                c: {"measured": 1.0, **v} for c, v in meta["relative_pseudo_damage"].items()
            }
    # what the findings put into the model, so that the fitted model can be rebuilt from the JSON
    # (exudyn_study.diagnose.fitted_model): catalogue entry, its location argument, its values
    meta["model_entries"] = [
        {"physics": name, "location": loc, "values": dict(values)} for name, loc, values in accepted
    ]
    final_gains = np.asarray(ones if gains_r is None else gains_r, float)
    meta["output_gains"] = {c: float(g) for c, g in zip(channels, final_gains, strict=True)}
    meta["wall_s"] = time.perf_counter() - t_start
    return Diagnosis(True, findings, unexplained, meta)


def _gains(h: Hypothesis, p, channels):
    """Return the candidate's output gains times those already found (None: all one)."""
    base = getattr(h, "base_gains", None)
    g = h.gains(p, channels)
    if g is None:
        return base
    return g if base is None else g * base


def _model_t(lin, freq, channels, sensor_names, gains=None):
    """Model transmissibility (sensor acceleration / drive acceleration) at ``freq``, (n_channels, n_f)."""
    from exudyn_study.linear.response import frf_linear

    idx = [list(sensor_names).index(c) for c in channels]
    lin = getattr(lin, "lin", lin)  # a NonlinearSystem: its linear tangent (the figure says so)
    w2 = (2 * np.pi * np.asarray(freq)) ** 2
    h = frf_linear(lin, freq)[idx, 0, :] / (-w2[None, :])
    return h if gains is None else h * gains[:, None]


def _figures_before(figures, named, recs, sims, lin0, sensor_names, maps):
    """Residual map (model error power / noise power per bin), measured and nominal transmissibilities."""
    k0 = 1000
    labels = [_label(n) for n, _ in named]
    rmaps, measured, levels = [], {}, []
    freq = None
    for lab, r, s in zip(labels, recs, sims, strict=True):
        u = r.drive.samples[k0:]
        res = drive_spectra(u, (r.measured - s)[:, k0:])
        meas = drive_spectra(u, r.measured[:, k0:])
        f = res.f
        band = (f >= 3.0) & (f <= 60.0)
        g2 = res.coherence
        rmaps.append((g2 / (1.0 - g2))[:, band])
        w2 = (2 * np.pi * f[band]) ** 2
        measured[lab] = meas.h1[:, band] / (-w2[None, :])
        freq = f[band]
        levels.append(float(np.std(np.gradient(np.gradient(u, 1e-3), 1e-3))))
    figures.update(
        channels=list(recs[0].channels),
        freq_hz=freq,
        labels=labels,
        levels=levels,
        residual_map=np.array(rmaps),
        bands_hz=[list(b) for b in BANDS_HZ],
        measured=measured,
    )
    figures["nominal_T"] = {
        lab: _model_t(lin0, freq, r.channels, sensor_names) for lab, r in zip(labels, recs, strict=True)
    }


def _screen(h: Hypothesis, ev: _Evaluator, channels, r0: np.ndarray, nfev: int = 6) -> float:
    """Share of the training residual the candidate explains at its best screening value (0-1).

    A candidate with a :attr:`~exudyn_study.diagnose.rig_hypotheses.Hypothesis.screen_grid`
    is evaluated on it (scalars: values of its one parameter, refined by a parabola in the
    log parameter through the best point and its neighbours; tuples: whole parameter
    vectors, a linear candidate then refined by a short fit from the best of them: a
    resonator's residual has a local minimum per mode it can tune to). Otherwise a short
    least-squares fit (``nfev`` evaluations) on the screening recording scores it. The best
    value becomes the start of the full fit.
    """
    rss0 = float(r0 @ r0)
    if rss0 <= 0:
        return 0.0

    def rss(p):
        r = _safe_residual(h, ev, channels, p)
        return math.inf if r is None else float(r @ r)

    grid = h.screen_grid
    if grid is None:
        p, _, value, _, _ = _fit(h, ev, channels, nfev)
        h.start = np.clip(p, h.lower, h.upper)
        return max(0.0, 1.0 - value / rss0)
    points = [np.atleast_1d(np.asarray(g, dtype=float)) for g in grid]
    vals = [rss(p) for p in points]
    k = int(np.argmin(vals))
    best, h.start = vals[k], points[k]
    if len(h.names) > 1 and h.kind_linear:
        # several parameters: a short fit from the best grid point
        p, _, value, _, _ = _fit(h, ev, channels, nfev)
        if value < best:
            best, h.start = value, np.clip(p, h.lower, h.upper)
        return max(0.0, 1.0 - best / rss0)
    if len(h.names) == 1 and 0 < k < len(grid) - 1:
        xs = np.log([float(p[0]) for p in points])
        a, b, c = vals[k - 1], vals[k], vals[k + 1]
        x0, x1, x2 = xs[k - 1], xs[k], xs[k + 1]
        denom = (x0 - x1) * (x0 - x2) * (x1 - x2)
        if denom != 0:
            A = (x2 * (b - a) + x1 * (a - c) + x0 * (c - b)) / denom
            B = (x2**2 * (a - b) + x1**2 * (c - a) + x0**2 * (b - c)) / denom
            if A > 0 and x0 < -B / (2 * A) < x2:
                v = np.array([float(np.exp(-B / (2 * A)))])
                value = rss(v)
                if value < best:
                    best, h.start = value, v
    return max(0.0, 1.0 - best / rss0)


def _level_pair(recs, stronger_in=None) -> tuple | None:
    """Return the two recordings of one drive at the most different levels: ``(c, weaker, stronger, n)``.

    Two drives are one drive at two levels if they are scaled copies in time (correlation
    > 0.9999 over their first ``n`` common samples) and their rms differs by more than
    20 %; ``c`` is the least-squares scale from the weaker to the stronger drive. None
    without such a pair. ``stronger_in``: only pairs whose stronger recording is one of these.
    """
    best = None
    for a in recs:
        for b in recs:
            if b.drive_rms_m < 1.2 * a.drive_rms_m:
                continue
            if stronger_in is not None and not any(b is r for r in stronger_in):
                continue
            n = min(a.drive.samples.size, b.drive.samples.size)
            ua, ub = a.drive.samples[:n], b.drive.samples[:n]
            if float(np.corrcoef(ua, ub)[0, 1]) < 0.9999:
                continue
            c = float(ub @ ua / (ua @ ua))
            if best is None or c > best[0]:
                best = (c, a, b, n)
    return best


def _distortion_shares(recs) -> tuple | None:
    """Per channel, the share of the response a linear structure cannot produce, from two levels of one drive.

    If two recordings' drives are scaled copies of each other in time (the thesis's test
    signal at 100 % and 50 %: correlation > 0.9999), any linear structure responds to the
    stronger one with exactly the scaled response of the weaker one, so
    ``y_b - c y_a`` (``c`` the drives' least-squares scale) holds only the level-dependent
    (nonlinear) part and noise: no model is needed. Returns
    ``rms(y_b - c y_a) / rms(y_b)`` per channel (band-limited, 3-60 Hz) of the pair with
    the largest level ratio, or None without such a pair (:func:`_level_pair`).
    """
    pair = _level_pair(recs)
    if pair is None:
        return None
    c, a, b, n = pair
    rows_a = [a.channels.index(ch) for ch in b.channels]
    d = band_filter(b.measured[:, :n] - c * a.measured[rows_a, :n])
    return np.sqrt(np.mean(d**2, axis=1)) * b.scale, b


class _DistortionEvaluator:
    """Residual of the level-dependent share of the response: measured against simulated.

    For one drive at two levels (:func:`_level_pair`: weaker ``a``, stronger ``b``, scale
    ``c``) the difference ``y_b - c y_a`` of the measured responses holds only what a linear
    structure cannot produce (:func:`_distortion_shares`); the same difference of a model's
    simulations holds only its nonlinear part. Their residual (band-limited, scaled per
    channel as the training residual) fits a nonlinear candidate's parameters whatever linear
    error the model still has: the linear parts cancel in both. ``residual_vector`` has the
    :class:`_Evaluator` interface (a linear system leaves the whole measured difference).
    """

    def __init__(self, pair, sensor_names, pad_s: float):
        from exudyn_study.diagnose.rig_compare import BAND_HZ, RATE_HZ

        c, a, b, n = pair
        self.c = c
        self.ev = _Evaluator([a, b], sensor_names, pad_s, exact=True)
        self.recs = [a, b]
        self.rows_a = np.array([a.channels.index(ch) for ch in b.channels])
        self.scale = b.scale
        self.target = band_filter(b.measured[:, :n] - c * a.measured[self.rows_a, :n]) * self.scale[:, None]
        self.n = n
        self.n_effective = int(2 * (BAND_HZ[1] - BAND_HZ[0]) * self.target.shape[1] * 4 / RATE_HZ) * len(
            b.channels
        )

    def residual_vector(self, system, gains=None):
        """Residual of the measured against the simulated level-dependent share, flattened."""
        sim_a, sim_b = self.ev.simulate_exact(system, gains)
        model = band_filter(sim_b[:, : self.n] - self.c * sim_a[self.rows_a, : self.n]) * self.scale[:, None]
        e = self.target - model
        return e.ravel() / math.sqrt(e.size)


def _nonlinear_sensors(distortion, channels, located) -> list:
    """Located sensors with a local nonlinear share (:func:`_distortion_shares`), strongest first."""
    if distortion is None:
        return []
    share, strong = distortion
    local = share > max(2.0 * float(np.median(share)), 0.005)
    by_name = {c: float(v) for c, v, ok in zip(strong.channels, share, local, strict=True) if ok}
    return sorted((c for c in located if c in by_name), key=lambda c: -by_name[c])


def _level_dependent(recs, sims, rows, distortion=None) -> bool:
    """Whether the mismatch at the channels ``rows`` grows with the drive level.

    Pairs of recordings whose drives have the same spectral shape (one a scaled copy of the
    other, e.g. the thesis's test signal at 100 % and 50 %) and whose rms differs by more
    than 20 % are compared by the nominal model's relative error per channel
    (:func:`~exudyn_study.diagnose.rig_compare.relative_errors`): a linear mismatch gives
    the same relative error at every level (or a larger one at the lower level, where noise
    weighs more); a stiffening or softening element gives an error that grows with level
    (cubic: about as the level squared). Level dependent if the median ratio over the
    channels exceeds 1.5. Without such a pair, the H1 estimates of the lowest and highest
    level are compared (a bin counts where the difference exceeds 5 times its standard
    error and 5 % of the FRF; level dependent above 5 % of the bins).

    Besides, with ``distortion`` (:func:`_distortion_shares`: the model-free nonlinear share
    per channel and the stronger recording), a channel among ``rows`` whose nonlinear share
    is local (above twice the median over all channels and above 0.5 %) and at least half of
    the current model's error there makes the mismatch level dependent: once linear findings
    have explained most of the error at a nonlinear element, what is left there grows with
    the level, even if other channels' linear error hides it in the median ratio.
    """
    if len(rows) == 0 or len(recs) < 2:
        return False
    if distortion is not None:
        share, strong = distortion
        k = next(i for i, r in enumerate(recs) if r is strong)
        err = relative_errors(strong, sims[k])
        local = (share > max(2.0 * float(np.median(share)), 0.005)) & (share > 0.5 * err)
        if local[np.asarray(rows, dtype=int)].any():
            return True
    k0 = 1000
    spectra = [drive_spectra(r.drive.samples[k0:], r.measured[rows, k0:]) for r in recs]
    f = spectra[0].f
    band = (f >= 5) & (f <= 55)
    errors = [relative_errors(r, s_)[rows] for r, s_ in zip(recs, sims, strict=True)]
    same_shape_pair = False
    for a in range(len(recs)):
        for b in range(len(recs)):
            if recs[b].drive_rms_m < 1.2 * recs[a].drive_rms_m:
                continue
            shape = np.log(spectra[b].suu[band] / spectra[a].suu[band])
            if float(np.median(np.abs(shape - np.median(shape)))) > 0.2:
                continue
            same_shape_pair = True
            ratio = errors[b] / np.maximum(errors[a], 1e-12)
            if float(np.median(ratio)) > 1.5:
                return True
    if same_shape_pair:
        return False
    lo = min(range(len(recs)), key=lambda i: recs[i].drive_rms_m)
    hi = max(range(len(recs)), key=lambda i: recs[i].drive_rms_m)
    if recs[hi].drive_rms_m < 1.2 * recs[lo].drive_rms_m:
        return False
    (h0, v0), (h1, v1) = ((spectra[i].h1, spectra[i].h1_variance()) for i in (lo, hi))
    z = np.abs(h1 - h0)[:, band] / np.sqrt(v0[:, band] + v1[:, band] + 1e-300)
    rel = np.abs(h1 - h0)[:, band] / np.maximum(np.abs(h0[:, band]), 1e-300)
    return bool(np.mean((z > 5) & (rel > 0.05)) > 0.05)


def _damage(recs, before, after):
    """Relative pseudo damage (Basquin beta 5) at the z sensors, before and after, per held-out recording."""
    from exudyn_study.signals.fatigue import pseudo_damage

    out = {}
    for r, b, a in zip(recs, before, after, strict=True):
        k0 = 1000
        for i, c in enumerate(r.channels):
            if not c.endswith("Z") and "Z" not in c[-2:]:
                continue
            d_meas = float(np.sum(pseudo_damage(r.measured[i, k0:])))
            if d_meas <= 0:
                continue
            out.setdefault(c, {"before": [], "after": []})
            out[c]["before"].append(float(np.sum(pseudo_damage(b[i, k0:]))) / d_meas)
            out[c]["after"].append(float(np.sum(pseudo_damage(a[i, k0:]))) / d_meas)
    return {
        c: {"before": float(np.mean(v["before"])), "after": float(np.mean(v["after"]))}
        for c, v in out.items()
    }


def _unexplained(cells, channels, level_dependent, text):
    rows = np.flatnonzero(cells.any(axis=1))
    cols = np.flatnonzero(cells.any(axis=0))
    sensors = [channels[i] for i in rows]
    comps = sorted({sensor_component(s) or "?" for s in sensors})
    return {
        "location": {
            "sensors": sensors,
            "component": comps[0] if len(comps) == 1 else None,
            "interface": None,
        },
        "band_hz": [BANDS_HZ[cols[0]][0], BANDS_HZ[cols[-1]][1]],
        "level_dependent": bool(level_dependent),
        "explanation": f"significant residual at {len(sensors)} sensor(s) ({', '.join(sensors[:8])}"
        f"{', ...' if len(sensors) > 8 else ''}) in {BANDS_HZ[cols[0]][0]:g}-"
        f"{BANDS_HZ[cols[-1]][1]:g} Hz; {text}",
    }


def _shifted_modes(lin0, lin1, f_max=60.0):
    f0, f1 = _modes(lin0), _modes(lin1)
    f0, f1 = f0[(f0 > 1.0) & (f0 < f_max)], f1[(f1 > 1.0) & (f1 < f_max)]
    pairs = []
    for a in f0:
        b = f1[np.argmin(np.abs(f1 - a))] if f1.size else a
        pairs.append((a, b))
    pairs.sort(key=lambda ab: -abs(ab[1] - ab[0]) / ab[0])
    new = [b for b in f1 if f0.size == 0 or np.min(np.abs(f0 - b)) / b > 0.03]
    return pairs[:3], new


def _explain(h: Hypothesis, p, std, lin0, lin1, located) -> str:
    """Plain-language explanation of a finding: its registered ``explain`` callable, else a generic text."""
    v = {n: (float(a), float(s)) for n, a, s in zip(h.names, p, std, strict=True)}
    pairs, new = _shifted_modes(lin0, lin1)
    shifts = ", ".join(f"{a:.2f} -> {b:.2f} Hz" for a, b in pairs if abs(b - a) > 0.005)
    where = ", ".join(located[:6]) + (", ..." if len(located) > 6 else "")
    cand = RIG_CANDIDATES.get(h.physics)
    if cand is not None and cand.explain is not None:
        return str(cand.explain(h, v, ExplainContext(shifts=shifts, new_modes_hz=tuple(new), where=where)))
    values = ", ".join(f"{n} = {a:.3g} +- {s:.2g}" for n, (a, s) in v.items())
    return f"{h.physics} at {h.location}: {values} ({shifts})."
