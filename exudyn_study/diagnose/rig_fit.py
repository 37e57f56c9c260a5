"""Fit: the best-screened candidates of a round, fitted on exact simulations and judged.

A stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`. :func:`fit_round` fits the best
``n_fit`` screened candidates one by one (bounded least squares, log parameters) and rejects a fit
that is not identifiable (relative std above ``max_relative_std`` or at a bound), explains too
little (``min_improvement``), switches the response off (``min_response_ratio``) or whose parameters
drift between the training recordings (:func:`fit_per_recording`); in a spectral round where no
candidate explains enough alone the linear candidates are fitted together
(:func:`~exudyn_study.diagnose.rig_fit_together.fit_together`). :func:`fit_nonlinear` fits the
simulated candidates on the level-dependent share of the response, :func:`choose_batch` picks the
round's findings.
"""

from __future__ import annotations

import math
import time

import numpy as np

from exudyn_study.diagnose.rig_evaluate import (
    Evaluator,
    aic,
    combined_gains,
    effective_samples,
    fit_hypothesis,
    fit_per_recording,
    response_ratio,
    system_residual,
)
from exudyn_study.diagnose.rig_screen import hypotheses_of, score_candidates, screen_score
from exudyn_study.diagnose.rig_state import ModelState, RigProblem, RoundFits, Screening


def fit_on_distortion(cands, ctx, ev_d, ev_time, channels, system, gains, st, say, meta, round_no, pool=None):
    """Screen and fit simulated (nonlinear) candidates on the level-dependent share of the response.

    ``ev_d`` (:class:`DistortionEvaluator`) compares the measured and simulated differences
    between one drive at two levels; the current ``system`` leaves the whole measured one
    (or, with nonlinear findings, what they miss). A candidate is acceptable if it explains
    at least ``min_improvement`` of it (``1 - rms after / rms before``), its parameters are
    identifiable and its model keeps the response on (``ev_time``: the training recordings).
    Returns fit records like the single fits (``rejected`` None if acceptable).

    Parameters
    ----------
    cands : sequence of RigCandidate
        The deferred simulated candidates.
    ctx : CandidateContext
        What the candidates' factories need (model builder, places, sensors).
    ev_d : DistortionEvaluator
        Evaluator of the level-dependent share.
    ev_time : Evaluator
        Evaluator of the training recordings (time histories), for the error after and the response ratio.
    channels : sequence of str
        The simulated channels, in row order.
    system : LinearSystem or NonlinearSystem
        The current model.
    gains : numpy.ndarray or OutputChain or None
        Output gains already found (None: all one).
    st : RigDiagnosisSettings
        Settings (``screen_nfev``, ``min_screen_share``, ``n_fit_simulated``, ``fit_nfev_simulated``,
        ``max_relative_std``, ``min_improvement``, ``min_response_ratio``).
    say : callable
        Progress messages, ``say(text)``.
    meta : dict
        The diagnosis metadata; the fits are appended to ``meta['candidates']``.
    round_no : int
        Index of the round (0 for the first).
    pool : EvaluationPool or None, optional
        Workers for the fits' finite differences (None: this process).
    """
    hyps = [h for cand in cands for h in hypotheses_of(cand, ctx)]
    if not hyps:
        return []
    for h in hyps:
        h.base_gains = gains
    r0 = ev_d.residual_vector(system, gains)
    rss0 = float(r0 @ r0)
    say(f"screening {len(hyps)} nonlinear candidates on the level-dependent share of the response")
    scores = [screen_score(h, ev_d, channels, r0, st.screen_nfev) for h in hyps]
    order = [i for i in np.argsort(scores)[::-1] if scores[i] >= st.min_screen_share * max(scores)]
    n_eff = effective_samples(ev_d)
    out = []
    for i in order[: st.n_fit_simulated]:
        h = hyps[i]
        say(f"fitting {h.label} on the level-dependent share (screening score {scores[i]:.3f})")
        p, std, rss, at_bound, nfev = fit_hypothesis(h, ev_d, channels, st.fit_nfev_simulated, pool=pool)
        rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
        firm = np.array([n not in h.may_vanish for n in h.names], dtype=bool)
        good = (rel_std < st.max_relative_std) & ~at_bound
        sys_p, gains_p = h.system(p), combined_gains(h, p, channels)
        r_time = system_residual(ev_time, sys_p, gains_p)
        sims = None if r_time is None else ev_time.simulate(sys_p, gains_p)  # the residual's simulation
        ratio = 0.0 if sims is None else response_ratio(ev_time.recs, sims)
        rss_time = math.inf if r_time is None else float(r_time @ r_time)
        f = {
            "h": h,
            "p": p,
            "std": std,
            "rss": rss,
            "aic": aic(rss, p.size, n_eff),
            "identifiable": bool(np.all(good[firm]) and (np.any(good) or good.size == 0)),
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


def polish(f: dict, ev: Evaluator, channels, recs, st, say, pool=None) -> None:
    """Refine a fit found on log transmissibilities in the time domain, if that keeps the response on.

    Near the truth the time-domain fit is the sharper one (the blind benchmark's single
    effects); far from it (other effects still missing) it runs towards switching the
    response off, and the log-spectral fit is kept.

    Parameters
    ----------
    f : dict
        Fit record of the spectral fit (``h``, ``p``, ``rss_time``, ...); updated in place (``p``,
        ``std``, ``rss_time``, ``at_bound``, ``polished``) if the time-domain fit is taken.
    ev : Evaluator
        Evaluator of the training recordings (time histories).
    channels : sequence of str
        The simulated channels, in row order.
    recs : list of RigRecording
        The training recordings (for the response ratio).
    st : RigDiagnosisSettings
        Settings (``polish_nfev``, ``min_response_ratio``, ``max_relative_std``).
    say : callable
        Progress messages, ``say(text)``.
    pool : EvaluationPool or None, optional
        Workers for the fit's finite differences (None: this process).
    """
    h = f["h"]
    h.start = np.asarray(f["p"], dtype=float)
    say(f"polishing {h.label} in the time domain")
    p, std, rss, at_bound, _ = fit_hypothesis(h, ev, channels, st.polish_nfev, pool=pool)
    if not (rss < f["rss_time"] and np.isfinite(rss)):
        return
    sims = ev.simulate(h.system(p), combined_gains(h, p, channels))
    if response_ratio(recs, sims) < st.min_response_ratio:
        return
    rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
    firm = np.array([n not in h.may_vanish for n in h.names], dtype=bool)
    good = (rel_std < st.max_relative_std) & ~at_bound
    if np.all(good[firm]) and (np.any(good) or good.size == 0):
        f.update(p=p, std=std, rss_time=rss, polished=True, at_bound=at_bound)


def batch_of(ok, max_batch: int) -> list:
    """Return the best acceptable fit and, if linear, up to ``max_batch - 1`` more at other components.

    Only linear candidates join a batch, each at a component (body, joint's component, the
    linkage) no earlier member touches, and a sensor gain only at another sensor.

    Parameters
    ----------
    ok : list of dict
        Acceptable fit records, best first (not empty).
    max_batch : int
        Largest number of findings a round takes.

    Returns
    -------
    list of dict
        The batch's fit records.
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


def _chosen(screening: Screening, st) -> list:
    """Return the candidates fitted in full: the best ``n_fit``, at most ``n_fit_simulated`` simulated.

    A linear candidate whose screening share implies less than ``min_screen_improvement`` of the
    residual's rms (:func:`screened_improvement`) is not fitted: its full fit starts from the screen's
    optimum and could not reach ``min_improvement``.
    """
    chosen, n_simulated = [], 0
    for i in screening.order:
        if len(chosen) == st.n_fit:
            break
        if not screening.hyps[i].kind_linear:
            if n_simulated == st.n_fit_simulated:
                continue
            n_simulated += 1
        elif screened_improvement(screening.scores[i]) < st.min_screen_improvement:
            continue
        chosen.append(i)
    return chosen


def screened_improvement(share: float) -> float:
    """Return the share of the residual's rms a screening share of its square removes, ``1 - sqrt(1 - s)``.

    The screening score is a share of the residual sum of squares; a fit's ``improvement`` is a share of
    its root (the relative error).

    Parameters
    ----------
    share : float
        Screening share of the residual sum of squares (0-1).

    Returns
    -------
    float
        The implied improvement (0-1).
    """
    return 1.0 - math.sqrt(min(max(1.0 - float(share), 0.0), 1.0))


def fit_one(problem: RigProblem, screening: Screening, i: int) -> dict:
    """Fit screened candidate ``i`` in full; its fit record (judged by :func:`judge`).

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    screening : Screening
        The round's screening (hypotheses, scores, the evaluator each is judged on).
    i : int
        Index of the candidate in ``screening.hyps``.

    Returns
    -------
    dict
        Fit record: ``h``, ``p``, ``std``, ``rss``, ``aic``, ``identifiable``, ``good``, ``at_bound``,
        ``improvement``, ``error_after``, ``rss_time``, ``response_ratio``, ``score``, ``nfev``.
    """
    st, channels = problem.settings, problem.channels
    h = screening.hyps[i]
    ev_fit, rss0, spectral = screening.judged_on(h)
    problem.say(f"fitting {h.label} (screening score {screening.scores[i]:.3f})")
    if h.kind_linear:
        p, std, rss, at_bound, nfev = fit_hypothesis(h, ev_fit, channels, st.fit_nfev, pool=problem.pool)
    else:  # simulated in time: fitted on shorter records, judged on the full training records
        p, std, _, at_bound, nfev = fit_hypothesis(
            h, problem.ev_train_nonlinear, channels, st.fit_nfev_simulated, pool=problem.pool
        )
    rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
    firm = np.array([n not in h.may_vanish for n in h.names], dtype=bool)
    good = (rel_std < st.max_relative_std) & ~at_bound
    sys_p, gains_p = h.system(p), combined_gains(h, p, channels)
    r_fit = system_residual(problem.ev_train, sys_p, gains_p)
    if r_fit is None:
        rss, sims_fit, good[:] = 1e9 * rss0, [r.measured * 0.0 for r in problem.train_recs], False
        rss_time = 1e9 * screening.rss0_time
    else:
        rss_time = float(r_fit @ r_fit)
        if not spectral:
            rss = rss_time
        sims_fit = problem.ev_train.simulate(sys_p, gains_p)
    return {
        "h": h,
        "p": p,
        "std": std,
        "rss": rss,
        "aic": aic(rss, p.size, effective_samples(ev_fit)),
        # every firm parameter identifiable, and at least one parameter (if it has any)
        "identifiable": bool(np.all(good[firm]) and (np.any(good) or good.size == 0)),
        "good": good,
        "at_bound": at_bound,
        "improvement": 1.0 - math.sqrt(rss / rss0),
        "error_after": math.sqrt(rss_time / len(problem.train_recs)),
        "rss_time": rss_time,
        "response_ratio": response_ratio(problem.train_recs, sims_fit),
        "score": float(screening.scores[i]),
        "nfev": nfev,
    }


def judge(f: dict, st) -> str | None:
    """Why a single fit is rejected (None: acceptable).

    Parameters
    ----------
    f : dict
        Fit record (``identifiable``, ``improvement``, ``response_ratio``).
    st : RigDiagnosisSettings
        Settings (``min_improvement``, ``min_response_ratio``).

    Returns
    -------
    str or None
        The reason for rejection, or None.
    """
    if not f["identifiable"]:
        return "not identifiable"
    if f["improvement"] < st.min_improvement:
        return "explains too little"
    if f["response_ratio"] < st.min_response_ratio:
        return "the fitted model switches the response off"
    return None


def check_drift(problem: RigProblem, screening: Screening, fitted: list) -> None:
    """Reject fits the round would take whose parameters drift between the training recordings.

    Only the fits the round would take (the best acceptable one and its batch; a fit rejected here
    lets the next one in): each check costs about one fit per recording.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    screening : Screening
        The round's screening (the evaluator each fit is judged on).
    fitted : list of dict
        The round's fit records; ``drift`` and ``rejected`` are set in place.
    """
    st = problem.settings
    while True:
        ok = sorted((f for f in fitted if f["rejected"] is None), key=lambda f: f["aic"])
        todo = [f for f in (batch_of(ok, st.max_batch) if ok else []) if "drift" not in f]
        todo = [f for f in todo if f["h"].kind_linear]
        if not todo:
            return
        for f in todo:
            ev = screening.judged_on(f["h"])[0]
            f["drift"] = fit_per_recording(
                f["h"], f["p"], f["good"], ev, problem.channels, st, pool=problem.pool
            )
            if f["drift"] is not None and f["drift"]["drifting"]:
                f["rejected"] = f"its parameters drift between the training recordings ({f['drift']['text']})"
                problem.say(f"{f['h'].label}: {f['rejected']}")


def candidates_meta(fitted, round_no: int, aic0: float) -> list:
    """Return the JSON's ``candidates`` entries of a round's single fits.

    Parameters
    ----------
    fitted : list of dict
        Fit records (:func:`fit_one`; ``rejected`` set, ``drift``, ``refined_from``, ``simpler_than`` and
        ``placed_again`` when made).
    round_no : int
        Index of the round (0 for the first).
    aic0 : float
        The current model's own AIC on the round's evaluator (each entry's ``aic`` is relative to it).

    Returns
    -------
    list of dict
        One entry per fit.
    """
    return [
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
            **({"refined_from": f["refined_from"]} if f.get("refined_from") else {}),
            **({"simpler_than": f["simpler_than"]} if f.get("simpler_than") else {}),
            **({"placed_again": f["placed_again"]} if f.get("placed_again") else {}),
        }
        for f in fitted
    ]


def fit_round(
    problem: RigProblem, state: ModelState, screening: Screening, meta: dict, round_no: int
) -> RoundFits:
    """Fit the round's best-screened candidates one by one; jointly if none is acceptable in a spectral round.

    Appends the fits to ``meta['candidates']``.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    screening : Screening
        The round's screening.
    meta : dict
        The diagnosis metadata; the fits are appended to ``meta['candidates']``.
    round_no : int
        Index of the round (0 for the first).

    Returns
    -------
    RoundFits
        All fits and the acceptable ones (``together``: they come from a joint fit).
    """
    from exudyn_study.diagnose.rig_fit_together import fit_together

    st = problem.settings
    fitted = [fit_one(problem, screening, i) for i in _chosen(screening, st)]
    for f in fitted:
        f["rejected"] = judge(f, st)
    if st.drift_check and len(problem.train_recs) > 1:
        check_drift(problem, screening, fitted)
    aic0 = aic(screening.rss0, 0, effective_samples(screening.ev_fit))
    meta["candidates"] += candidates_meta(fitted, round_no, aic0)
    ok = [f for f in fitted if f["rejected"] is None]
    if ok or not screening.spectral or st.composite_max <= 1:
        return RoundFits(tuple(fitted), tuple(ok))
    ok = fit_together(
        list(screening.hyps),
        list(screening.scores),
        state.builder(problem),
        problem.ev_spectral,
        problem.ev_train,
        problem.ev_hold_fast,
        state.lin,
        problem.channels,
        problem.train_recs,
        state.gains,
        screening.rss0,
        st,
        problem.say,
        meta,
        round_no,
        pool=problem.pool,
    )
    return RoundFits(tuple(fitted), tuple(ok), together=bool(ok))


def fit_nonlinear(
    problem: RigProblem, state: ModelState, screening: Screening, fits: RoundFits, meta: dict, round_no: int
) -> RoundFits:
    """Fit the deferred simulated candidates on the level-dependent share (after the linear ``fits``).

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    screening : Screening
        The round's screening (its ``deferred`` simulated candidates and context).
    fits : RoundFits
        The round's linear fits.
    meta : dict
        The diagnosis metadata; the fits are appended to ``meta['candidates']``.
    round_no : int
        Index of the round (0 for the first).

    Returns
    -------
    RoundFits
        ``fits``' fits and the nonlinear ones; the acceptable nonlinear ones; their wall time (s).
    """
    from dataclasses import replace

    t0 = time.perf_counter()
    # the factories build the current model (the linear findings may have been refitted since screening)
    ctx = replace(screening.ctx, build=state.builder(problem))
    fitted_nl = fit_on_distortion(
        screening.deferred,
        ctx,
        problem.ev_distortion,
        problem.ev_train_nonlinear,
        problem.channels,
        state.system,
        state.gains,
        problem.settings,
        problem.say,
        meta,
        round_no,
        pool=problem.pool,
    )
    ok = [f for f in fitted_nl if f["rejected"] is None]
    return RoundFits(fits.fitted + tuple(fitted_nl), tuple(ok), nonlinear_s=time.perf_counter() - t0)


def choose_batch(problem: RigProblem, screening: Screening, fits: RoundFits) -> list:
    """Return the round's findings: the best fit by AIC and its batch; spectral fits polished in time.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    screening : Screening
        The round's screening.
    fits : RoundFits
        The round's fits.

    Returns
    -------
    list of dict
        Fit records of the round's findings.
    """
    ok = sorted(fits.ok, key=lambda f: f["aic"])
    if len({screening.judged_on(f["h"])[2] for f in ok}) > 1:
        # fits judged on log transmissibilities and on time histories: their AICs do not compare,
        # the share of the residual each explains does
        ok = sorted(fits.ok, key=lambda f: -f["improvement"])
    batch = ok if fits.together else batch_of(ok, problem.settings.max_batch)
    if screening.spectral and not fits.together:
        for f in batch:
            if f["h"].kind_linear and screening.judged_on(f["h"])[2]:
                polish(
                    f,
                    problem.ev_train,
                    problem.channels,
                    problem.train_recs,
                    problem.settings,
                    problem.say,
                    problem.pool,
                )
    return batch


def closest_candidates(screening: Screening, n: int = 3) -> tuple:
    """Return ``(label, screening share)`` of the round's ``n`` best-screened candidates.

    What the generic element's explanation names as the closest catalogue entries.

    Parameters
    ----------
    screening : Screening
        The round's screening.
    n : int, optional
        How many (default 3).

    Returns
    -------
    tuple of tuple
        ``(label, share)``, best first.
    """
    ranked = sorted(zip(screening.scores, screening.hyps, strict=True), key=lambda t: -t[0])
    return tuple((h.label, float(score)) for score, h in ranked[:n])


def fit_extra(problem: RigProblem, screening: Screening, h, score: float) -> dict:
    """Fit a hypothesis made after the screen (a refined place, a nested entry) as a screened one; judged.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    screening : Screening
        The round's screening (the evaluator ``h`` is judged on).
    h : Hypothesis
        The hypothesis.
    score : float
        The screening share recorded for it.

    Returns
    -------
    dict
        Its fit record (:func:`fit_one`) with ``rejected`` set (:func:`judge`).
    """
    from dataclasses import replace

    scr = replace(screening, hyps=screening.hyps + (h,), scores=screening.scores + (float(score),))
    f = fit_one(problem, scr, len(scr.hyps) - 1)
    f["rejected"] = judge(f, problem.settings)
    return f


#: the generic element replaces catalogue fits if it removes this much more of the residual (and gives
#: way to one that explains within this much of it)
GENERIC_MARGIN = 0.05


def fit_generic(
    problem: RigProblem,
    state: ModelState,
    screening: Screening,
    fits: RoundFits,
    meta: dict,
    round_no: int,
) -> RoundFits:
    """Screen and fit the generic local element, the last candidate of a round (none of the catalogue's fits).

    Each element is told its place (coordinates, nearest sensor) and the round's closest catalogue
    candidates (by screening score), which its explanation names.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    screening : Screening
        The round's screening (context, catalogue scores).
    fits : RoundFits
        The round's fits so far.
    meta : dict
        The diagnosis metadata; the fits are appended to ``meta['candidates']``.
    round_no : int
        Index of the round (0 for the first).

    Returns
    -------
    RoundFits
        ``fits``' fits and the generic ones; the acceptable generic ones (``fits`` if there are no places).
    """
    from dataclasses import replace

    from exudyn_study.diagnose.rig_candidates import generic_local_elements
    from exudyn_study.diagnose.rig_explain import point_of

    st = problem.settings
    hyps = generic_local_elements(screening.ctx)
    if not hyps:
        return fits
    ev_scr = problem.ev_spectral if screening.spectral else problem.ev_screen
    r0 = ev_scr.residual_vector(state.lin, state.gains)
    problem.say(f"screening the generic local element at {len(hyps)} places (no catalogue candidate fits)")
    scores = score_candidates(problem, hyps, ev_scr, r0)
    closest = closest_candidates(screening)
    for h in hyps:
        h.base_gains = state.gains
        h.place = point_of(h, state.markers)
        h.closest = closest
    order = [
        i
        for i in np.argsort(scores)[::-1]
        if 0 < scores[i] and scores[i] >= st.min_screen_share * max(scores)
    ]
    generic = replace(screening, hyps=tuple(hyps), scores=tuple(scores), order=tuple(order))
    fitted = [fit_one(problem, generic, i) for i in _chosen(generic, st)]
    for f in fitted:
        f["rejected"] = judge(f, st)
    aic0 = aic(screening.rss0, 0, effective_samples(screening.ev_fit))
    meta["candidates"] += candidates_meta(fitted, round_no, aic0)
    ok = [f for f in fitted if f["rejected"] is None]
    return RoundFits(fits.fitted + tuple(fitted), tuple(ok), nonlinear_s=fits.nonlinear_s)
