"""Screen: every candidate of the registry at every place, scored by the share of the residual it explains.

A stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`: :func:`screen` asks each registered
candidate (:mod:`~exudyn_study.diagnose.rig_candidates`) for its hypotheses in this round and scores
each on a short record (:func:`screen_score`); the result is a
:class:`~exudyn_study.diagnose.rig_state.Screening` whose best candidates the fit stage fits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from exudyn_study.diagnose.rig_candidates import RIG_CANDIDATES, CandidateContext
from exudyn_study.diagnose.rig_compare import summary_error
from exudyn_study.diagnose.rig_evaluate import Evaluator, fit_hypothesis, safe_residual
from exudyn_study.diagnose.rig_hypotheses import Hypothesis
from exudyn_study.diagnose.rig_state import Comparison, Location, ModelState, RigProblem, Screening
from exudyn_study.errors import InputError


def hypotheses_of(cand, ctx) -> list:
    """Return the hypotheses of registered candidate ``cand`` in the round ``ctx`` (checked).

    Parameters
    ----------
    cand : RigCandidate
        The registered candidate (its ``factory``).
    ctx : CandidateContext
        What the factory may use in this round.

    Returns
    -------
    list of Hypothesis
        The candidate's hypotheses (empty if it does not apply).

    Raises
    ------
    InputError
        If the factory returns something other than :class:`Hypothesis` objects.
    """
    made = list(cand.factory(ctx) or [])
    for h in made:
        if not isinstance(h, Hypothesis):
            raise InputError(
                f"rig candidate {cand.physics!r}: its factory returned {h!r}; expected Hypothesis "
                "objects (exudyn_study.diagnose.rig_hypotheses)"
            )
    return made


def screen_score(h: Hypothesis, ev: Evaluator, channels, r0: np.ndarray, nfev: int = 6) -> float:
    """Share of the training residual the candidate explains at its best screening value (0-1).

    A candidate with a :attr:`~exudyn_study.diagnose.rig_hypotheses.Hypothesis.screen_grid`
    is evaluated on it (scalars: values of its one parameter, refined by a parabola in the
    log parameter through the best point and its neighbours; tuples: whole parameter
    vectors, a linear candidate then refined by a short fit from the best of them: a
    resonator's residual has a local minimum per mode it can tune to). Otherwise a short
    least-squares fit (``nfev`` evaluations) on the screening recording scores it. The best
    value becomes the start of the full fit.

    Parameters
    ----------
    h : Hypothesis
        The candidate; its ``start`` is set to the best screening value.
    ev : Evaluator or SpectralEvaluator or DistortionEvaluator
        Evaluator of the screening record.
    channels : sequence of str
        The simulated channels, in row order.
    r0 : numpy.ndarray
        The current model's residual vector on ``ev``, shape (n_rows,).
    nfev : int, optional
        Residual evaluations of a short screening fit (default 6).

    Returns
    -------
    float
        ``1 - rss / rss0`` at the best value, at least 0 (0 when the residual is already zero).
    """
    rss0 = float(r0 @ r0)
    if rss0 <= 0:
        return 0.0

    def rss(p):
        r = safe_residual(h, ev, channels, p)
        return math.inf if r is None else float(r @ r)

    grid = h.screen_grid
    if grid is None:
        p, _, value, _, _ = fit_hypothesis(h, ev, channels, nfev)
        h.start = np.clip(p, h.lower, h.upper)
        return max(0.0, 1.0 - value / rss0)
    points = [np.atleast_1d(np.asarray(g, dtype=float)) for g in grid]
    vals = [rss(p) for p in points]
    k = int(np.argmin(vals))
    best, h.start = vals[k], points[k]
    if len(h.names) > 1 and h.kind_linear:
        # several parameters: a short fit from the best grid point
        p, _, value, _, _ = fit_hypothesis(h, ev, channels, nfev)
        if value < best:
            best, h.start = value, np.clip(p, h.lower, h.upper)
        return max(0.0, 1.0 - best / rss0)
    if len(h.names) == 1 and 0 < k < len(grid) - 1 and all(float(p[0]) > 0 for p in points):
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


@dataclass(frozen=True)
class CandidateScorer:
    """What :func:`screen_score` needs for every candidate of a screen, sent to the workers once.

    The candidates share the current model's linearisation (one copy in the pickle); a point
    candidate travels without its derived dense matrices
    (:class:`~exudyn_study.diagnose.rig_hypotheses.AddedMassHypothesis` and its kin rebuild them).

    Attributes
    ----------
    hyps : tuple of Hypothesis
        The screen's candidates.
    ev : Evaluator or SpectralEvaluator
        The screening evaluator.
    ev_gains : Evaluator
        The evaluator of the candidates carried as output gains (the time histories also when the
        others are screened on log transmissibilities).
    channels : tuple of str
        The simulated channels, in row order.
    r0, r0_gains : numpy.ndarray
        The current model's residual on ``ev`` and on ``ev_gains``.
    nfev : int
        Residual evaluations of a short screening fit.
    """

    hyps: tuple
    ev: object
    ev_gains: object
    channels: tuple
    r0: np.ndarray
    r0_gains: np.ndarray
    nfev: int

    def score(self, i: int) -> tuple:
        """Return ``(score, start)`` of candidate ``i``.

        Parameters
        ----------
        i : int
            Index of the candidate in :attr:`hyps`.

        Returns
        -------
        tuple
            ``(score, start)``: :func:`screen_score`'s share and the candidate's best screening value
            (the start of its fit).
        """
        h = self.hyps[i]
        gains = h.carry == "gains"
        score = screen_score(
            h,
            self.ev_gains if gains else self.ev,
            self.channels,
            self.r0_gains if gains else self.r0,
            self.nfev,
        )
        return score, np.array(h.start, dtype=float)


def score_candidates(problem: RigProblem, hyps, ev, r0, ev_gains=None, r0_gains=None) -> list:
    """Score each candidate by :func:`screen_score` (on the pool's workers when it has them).

    Each candidate's ``start`` is set to its best screening value (the start of its fit), as the
    serial screen leaves it.

    Parameters
    ----------
    problem : RigProblem
        The settings, channels and pool.
    hyps : sequence of Hypothesis
        The candidates.
    ev : Evaluator or SpectralEvaluator
        The screening evaluator.
    r0 : numpy.ndarray
        The current model's residual on ``ev``.
    ev_gains, r0_gains : optional
        Evaluator and residual of the candidates carried as output gains (default ``ev``, ``r0``).

    Returns
    -------
    list of float
        The screening shares, in the order of ``hyps``.
    """
    scorer = CandidateScorer(
        hyps=tuple(hyps),
        ev=ev,
        ev_gains=ev if ev_gains is None else ev_gains,
        channels=tuple(problem.channels),
        r0=r0,
        r0_gains=r0 if r0_gains is None else r0_gains,
        nfev=problem.settings.screen_nfev,
    )
    items = list(range(len(scorer.hyps)))
    pool = problem.pool
    if pool is not None and pool.parallel and len(items) > 1:
        results = pool.map_shared(score_candidate_task, scorer, items)
    else:
        results = [scorer.score(i) for i in items]
    for h, (_, start) in zip(scorer.hyps, results, strict=True):
        h.start = start
    return [score for score, _ in results]


def score_candidate_task(scorer: CandidateScorer, i: int) -> tuple:
    """:meth:`CandidateScorer.score` in a worker (BLAS on one thread).

    Parameters
    ----------
    scorer : CandidateScorer
        The screen's candidates and evaluators.
    i : int
        Index of the candidate.

    Returns
    -------
    tuple
        As :meth:`CandidateScorer.score` (the worker's copy of the candidate is not the caller's: the
        caller sets the start).
    """
    from exudyn_study.infra.blas import single_threaded_blas

    with single_threaded_blas():
        return scorer.score(i)


def candidate_context(
    problem: RigProblem, state: ModelState, location: Location, done, comparison: Comparison | None = None
) -> CandidateContext:
    """Return what the candidate factories may use in this round (:class:`CandidateContext`).

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    location : Location
        Where the mismatch is.
    done : iterable of tuple
        ``(physics, location)`` of the findings made (not offered again).
    comparison : Comparison or None, optional
        The current model against the recordings (None: no residual share per channel).

    Returns
    -------
    CandidateContext
        The context of this round.
    """
    best_places = []
    if problem.settings.place_screen:
        import time

        from exudyn_study.diagnose.rig_places import screen_places, structure_places

        t0 = time.perf_counter()
        places = structure_places(state.model, problem.settings.place_spacing_m, markers=state.markers)
        best_places = screen_places(state.lin, places, problem.ev_spectral, state.gains, pool=problem.pool)
        problem.say(
            "screened a point mass, a tuned mass-damper and a spring-damper to ground at "
            f"{len(places.names)} places of the structure in {time.perf_counter() - t0:.1f} s"
        )
    return CandidateContext(
        model=state.model,
        lin=state.lin,
        build=state.builder(problem),
        locations=list(state.locations),
        markers=state.markers,
        sensor_names=problem.sensor_names,
        located=list(location.located),
        level_dependent=location.level_dependent,
        done=set(done),
        say=problem.say,
        nonlinear_sensors=list(location.nonlinear_sensors),
        channels=tuple(problem.channels),
        measured_peak=measured_peaks(problem),
        best_places=best_places,
        residual_share=residual_shares(problem, comparison) if comparison is not None else {},
        coherence=measured_coherence(problem),
        swap_partner=swap_partners(problem, comparison) if comparison is not None else {},
    )


def measured_coherence(problem: RigProblem) -> dict:
    """Return channel -> median coherence of its measured response with the drive, 3-60 Hz.

    Of the first training recording (Welch, as the spectral evaluator). A channel that records the
    structure is coherent with the drive; a dead one records noise (coherence near the estimate's bias,
    about one over the number of segments).

    Parameters
    ----------
    problem : RigProblem
        The training recordings and their channels.

    Returns
    -------
    dict
        Channel -> median coherence (0-1).
    """
    from exudyn_study.diagnose.rig_compare import drive_spectra

    r = problem.train_recs[0]
    k0 = 1000  # the start-up transient left out, as the spectral evaluator does
    sp = drive_spectra(r.drive.samples[k0:], r.measured[:, k0:])
    band = (sp.f >= 3.0) & (sp.f <= 60.0)
    med = np.median(sp.coherence[:, band], axis=1)
    return {c: float(v) for c, v in zip(r.channels, med, strict=True)}


def swap_partners(problem: RigProblem, comparison: Comparison) -> dict:
    """Return channel -> (the channel whose swap with it fits best, the share of the pair's residual removed).

    The current model's band-limited simulations of two channels exchanged against their measured
    responses (the relative errors of :func:`~exudyn_study.diagnose.rig_compare.relative_errors`, first
    training recording): ``1 - (e(a<-b)^2 + e(b<-a)^2) / (e(a)^2 + e(b)^2)``, for all pairs at once
    from one product of the filtered channels.

    Parameters
    ----------
    problem : RigProblem
        The training recordings.
    comparison : Comparison
        The current model against them (its training simulations).

    Returns
    -------
    dict
        Channel -> ``(partner, share)`` (share may be negative: no swap helps).
    """
    from exudyn_study.diagnose.rig_compare import band_filter

    r, sim = problem.train_recs[0], comparison.sims_tr[0]
    m, s_ = band_filter(r.measured), band_filter(sim)
    n = m.shape[1]
    scale2 = np.asarray(r.scale, dtype=float) ** 2
    # e2[a, b]: channel a's squared relative error if it read the simulation of channel b
    e2 = ((m**2).sum(axis=1)[:, None] + (s_**2).sum(axis=1)[None, :] - 2.0 * m @ s_.T) / n
    e2 = e2 * scale2[:, None]
    own = np.diag(e2)
    before = own[:, None] + own[None, :]
    share = 1.0 - (e2 + e2.T) / np.maximum(before, 1e-300)
    np.fill_diagonal(share, -np.inf)
    best = np.argmax(share, axis=1)
    return {c: (r.channels[int(best[a])], float(share[a, best[a]])) for a, c in enumerate(r.channels)}


def residual_shares(problem: RigProblem, comparison: Comparison) -> dict:
    """Return channel -> its share of the training residual (squared relative errors, over recordings).

    Parameters
    ----------
    problem : RigProblem
        The recordings and evaluators.
    comparison : Comparison
        The current model against the recordings (its training simulations).

    Returns
    -------
    dict
        Channel -> share of the residual, summing to 1 (all 0 if there is no residual).
    """
    errs = np.mean([e**2 for e in problem.ev_train.errors(comparison.sims_tr)], axis=0)
    total = float(np.sum(errs))
    return {c: float(v) / total if total > 0 else 0.0 for c, v in zip(problem.channels, errs, strict=True)}


def measured_peaks(problem: RigProblem) -> dict:
    """Return channel -> largest magnitude over the training recordings (m/s^2).

    Parameters
    ----------
    problem : RigProblem
        The training recordings and their channels.

    Returns
    -------
    dict
        Channel -> peak acceleration (m/s^2).
    """
    peaks = np.max([np.max(np.abs(r.measured), axis=1) for r in problem.train_recs], axis=0)
    return {c: float(v) for c, v in zip(problem.channels, peaks, strict=True)}


def screen(
    problem: RigProblem, state: ModelState, comparison: Comparison, location: Location, done, round_no: int
):
    """Collect this round's candidates and score each; None when no candidate applies.

    Simulated (nonlinear) candidates are deferred to the level-dependent share when the training
    data hold one drive at two levels (``problem.ev_distortion``); a candidate that needs level
    dependence is asked only when the mismatch has it. Far off (training error above
    ``spectral_above_error``) only linear candidates are screened, on log transmissibilities.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    comparison : Comparison
        The current model against the recordings.
    location : Location
        Where the mismatch is.
    done : iterable of tuple
        ``(physics, location)`` of the findings made (not offered again).
    round_no : int
        Index of the round (0 for the first).

    Returns
    -------
    Screening or None
    """
    st, say = problem.settings, problem.say
    ctx = candidate_context(problem, state, location, done, comparison)
    hyps: list[Hypothesis] = []
    deferred = []  # simulated candidates judged on the level-dependent share if no linear one fits
    for cand in list(RIG_CANDIDATES.values()):
        if not problem.wants(cand.physics):
            continue
        if problem.ev_distortion is not None and cand.kind == "simulated":
            if location.level_dependent or ctx.nonlinear_sensors:
                deferred.append(cand)
            continue
        if cand.needs_level_dependence and not location.level_dependent:
            continue
        hyps += hypotheses_of(cand, ctx)
    if not hyps and not deferred:
        return None
    for h in hyps:
        h.base_gains = state.gains
    # far off (error > 100 %: resonances misplaced): judge and fit on log transmissibilities
    error_now = float(np.mean([summary_error(e) for e in problem.ev_train.errors(comparison.sims_tr)]))
    spectral = error_now > st.spectral_above_error
    if spectral:
        hyps = [h for h in hyps if h.kind_linear]
    ev_fit = problem.ev_spectral if spectral else problem.ev_train
    ev_scr = problem.ev_spectral if spectral else problem.ev_screen
    say(
        f"round {round_no + 1}: screening {len(hyps)} candidates"
        + (f" on log transmissibilities (training error {error_now:.2f})" if spectral else "")
    )
    r0 = ev_fit.residual_vector(state.lin, state.gains)
    r0_screen = ev_scr.residual_vector(state.lin, state.gains)
    # acquisition faults on the time histories in any round (Screening.judged_on)
    r0_time_screen = problem.ev_screen.residual_vector(state.lin, state.gains) if spectral else r0_screen
    scores = score_candidates(
        problem, hyps, ev_scr, r0_screen, problem.ev_screen if spectral else ev_scr, r0_time_screen
    )
    order = [
        i
        for i in np.argsort(scores)[::-1]
        if scores[i] > 0 and scores[i] >= st.min_screen_share * max(scores, default=0.0)
    ]
    return Screening(
        ctx=ctx,
        hyps=tuple(hyps),
        scores=tuple(float(s) for s in scores),
        order=tuple(int(i) for i in order),
        deferred=tuple(deferred),
        spectral=spectral,
        ev_fit=ev_fit,
        rss0=float(r0 @ r0),
        rss0_time=float(np.sum(problem.ev_train.residual_vector(state.lin, state.gains) ** 2)),
        ev_time=problem.ev_train,
    )
