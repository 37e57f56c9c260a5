"""Joint fits: candidates fitted together in a round, and the final joint refit of all linear findings.

Part of the fit stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`. :func:`fit_together`
fits the best-screened linear candidates at different places together (a model far off, no
candidate explaining enough alone) and judges each member by what it pays for itself;
:func:`final_refit` refits the linear findings carried into the model together, and
:func:`refit_findings` adopts that refit when it lowers the training residual without raising the
held-out error.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from exudyn_study.diagnose.rig_compare import compare, summary_error
from exudyn_study.diagnose.rig_evaluate import (
    aic,
    catalogue_default,
    effective_samples,
    fit_hypothesis,
    fit_per_recording,
    holdout_error,
    holdout_errors,
    response_ratio,
    safe_residual,
    set_offsets,
    system_residual,
)
from exudyn_study.diagnose.rig_explain import explain, make_finding
from exudyn_study.diagnose.rig_hypotheses import log_bounds, to_x
from exudyn_study.diagnose.rig_state import Comparison, ModelState, Progress, RigProblem, model_state


def member_neutral(comp, k: int, p) -> dict | None:
    """Composite parameter index -> value with member ``k`` taken out (its ``neutral`` values), or None.

    Parameters
    ----------
    comp : CompositeHypothesis
        The joint fit's composite.
    k : int
        Index of the member in ``comp.members``.
    p : array_like
        The composite's fitted values, shape (n_params,); member ``k``'s parameters without a
        neutral value keep theirs.

    Returns
    -------
    dict or None
        Composite parameter index -> held value, or None if the member has no ``neutral`` values.
    """
    h = comp.members[k]
    if not h.neutral:
        return None
    held = {}
    for j, (i, n) in enumerate(comp.specs):
        if i == k:
            held[j] = float(h.neutral.get(n, p[j]))  # the others (a linkage's mass) as fitted
    return held


def prior_starts(comp, members, start_a, all_prior: bool) -> list:
    """Return the joint fit's further starts ``(ordinal, what, start)`` after ``start_a``.

    The second start puts the best-screened physics (``members[0]``'s) at its prior start
    (:attr:`Hypothesis.prior`), the third (``all_prior``) every member; the others keep their
    values in ``start_a``. A start equal to an earlier one is left out.

    Parameters
    ----------
    comp : CompositeHypothesis
        The joint fit's composite (its ``specs`` and bounds).
    members : list of Hypothesis
        The composite's members, best-screened first.
    start_a : numpy.ndarray
        The first start, shape (n_params,).
    all_prior : bool
        Whether a third start puts every member at its prior start.
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


def fit_together(
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
    pool=None,
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

    Parameters
    ----------
    hyps : list of Hypothesis
        The round's screened hypotheses.
    scores : list of float
        Their screening scores, in the order of ``hyps``.
    build : callable
        Returns a fresh, unassembled model of the current round.
    ev_fit : Evaluator or SpectralEvaluator
        Evaluator the joint fit runs on.
    ev_time : Evaluator
        Evaluator of the training recordings (time histories).
    ev_hold : Evaluator
        Evaluator of the held-out recordings (convolution).
    system_now : LinearSystem or NonlinearSystem
        The current model (the held-out error before).
    channels : sequence of str
        The simulated channels, in row order.
    recs : list of RigRecording
        The training recordings (for the response ratio).
    gains : numpy.ndarray or OutputChain or None
        Output gains already found (None: all one).
    rss0 : float
        Residual sum of squares of the current model on ``ev_fit``.
    st : RigDiagnosisSettings
        Settings (``composite_max``, ``composite_damping``, ``member_nfev``, ``min_member_gain``,
        ``max_relative_std``, ...).
    say : callable
        Progress messages, ``say(text)``.
    meta : dict
        The diagnosis metadata; the members are appended to ``meta['candidates']``.
    round_no : int
        Index of the round (0 for the first).
    pool : EvaluationPool or None, optional
        Workers for the fits' finite differences (None: this process).
    """
    from exudyn_study.diagnose.rig_hypotheses import CompositeHypothesis

    members = _joint_members(hyps, scores, st)
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
            default = catalogue_default(h.physics, "damping_time_s")
            h.start[k] = default if default > 0 or not st.composite_damping else 1e-4
    say(f"fitting {len(members)} candidates together: {', '.join(h.label for h in members)}")
    try:
        comp = CompositeHypothesis(members, build, free)
    except Exception as exc:  # noqa: BLE001 - an entry that cannot be combined: no composite
        say(f"the candidates cannot be combined: {exc}")
        return []
    comp.base_gains = gains
    jf = _fit_from_starts(comp, members, ev_fit, channels, st, say, pool)
    if not math.isfinite(jf.rss):
        return []
    jf, pinned = _hold_pinned_damping(comp, jf, ev_fit, channels, st, say, pool)
    hold_errs = holdout_errors(ev_hold, comp.system(jf.p), gains)
    verdicts, held_out = _member_verdicts(
        comp, members, jf, pinned, hold_errs, ev_fit, ev_hold, channels, gains, st, say
    )
    hold_err = float(np.mean(hold_errs))
    if len(held_out) > len(pinned):
        if len(held_out) == jf.p.size:
            say("no member of the joint fit pays for itself")
        else:
            jf = _refit_held(comp, jf, held_out, ev_fit, channels, st)
            hold_err = holdout_error(ev_hold, comp.system(jf.p), gains)
    out = _member_records(
        comp, members, jf, verdicts, hold_err, hyps, scores, ev_fit, ev_time, channels, recs, gains, rss0, st
    )
    hold_err0 = holdout_error(ev_hold, system_now, gains)
    for rec in out:
        rec["rejected"] = _member_rejected(rec, hold_err, hold_err0, st)
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


@dataclass(frozen=True)
class JointFit:
    """A joint fit: values ``p``, ``std``, training ``rss``, ``at_bound``, Jacobian ``jac``, ``nfev``.

    Parameters
    ----------
    p : numpy.ndarray
        Fitted composite parameters, shape (n_params,).
    std : numpy.ndarray
        Their standard deviations, shape (n_params,).
    rss : float
        Training residual sum of squares.
    at_bound : numpy.ndarray of bool
        Per parameter, whether it ended at a bound.
    jac : numpy.ndarray or None
        Final Jacobian in the fitting variable, shape (n_rows, n_params) (None: not kept).
    nfev : int
        Number of residual evaluations.
    """

    p: np.ndarray
    std: np.ndarray
    rss: float
    at_bound: np.ndarray
    jac: np.ndarray | None
    nfev: int


#: point candidates a joint fit leaves out: placed by the screen at the located points, a mass, a resonator
#: or the generic local element there takes up a share of any structural member's mismatch (on the
#: ``thesis`` truth a 0.15 kg resonator took the tenth place, and the left pad, the eleventh best, was not
#: fitted; a spring-damper to ground at a tank's node took the place of its sloshing); they are fitted
#: alone, where a catalogue entry at the same place competes with them on what each explains
POINT_PHYSICS = ("added_mass", "tuned_mass_damper", "local_element")


def _joint_members(hyps, scores, st) -> list:
    """Return the best-screened linear candidates at different places (at most ``composite_max``).

    Point candidates (:data:`POINT_PHYSICS`) are not joint members.
    """
    members, places = [], set()
    for i in np.argsort(scores)[::-1]:
        h = hyps[i]
        if len(members) >= st.composite_max or scores[i] <= 0.0:
            break
        if not h.kind_linear or h.carry != "model" or h.physics in POINT_PHYSICS:
            continue
        place = (h.physics, h.location)
        same = {m.component for m in members if m.physics == h.physics and h.one_per_component}
        if place in places or h.component in same:
            continue
        places.add(place)
        members.append(h)
    return members


def _fit_from_starts(comp, members, ev_fit, channels, st, say, pool=None) -> JointFit:
    """Fit the composite from its start and (``composite_prior_start``) from prior starts; the lowest wins.

    More starts: the best-screened physics at its prior start, the others at their screening optima
    (screened alone, the best candidate takes up the whole mismatch: soft rear supports for vertically
    soft tank mounts; started there, the joint fit stays in that basin), and with
    ``composite_all_prior_start`` every member at its prior start (screened alone, each member takes up
    a share of the others' mismatch too). The composite is exact wherever it is evaluated, so one serves
    every start. ``comp.start`` is left at the winning start.
    """
    info = {}
    p, std, rss, at_bound, nfev = fit_hypothesis(
        comp, ev_fit, channels, st.fit_nfev_composite, info=info, pool=pool
    )
    if st.composite_prior_start:
        start_a = comp.start.copy()
        best_start = start_a
        for ordinal, what, start in prior_starts(comp, members, start_a, st.composite_all_prior_start):
            comp.start = start
            info_b = {}
            fit_b = fit_hypothesis(comp, ev_fit, channels, st.fit_nfev_composite, info=info_b, pool=pool)
            say(f"  {ordinal} start ({what}): training residual {fit_b[2]:.4g} against {rss:.4g}")
            nfev += fit_b[4]
            if fit_b[2] < rss:
                p, std, rss, at_bound, _ = fit_b
                info, best_start = info_b, start
        comp.start = best_start
    return JointFit(p, std, rss, at_bound, info.get("jac"), nfev)


def _hold_pinned_damping(comp, jf: JointFit, ev_fit, channels, st, say, pool=None) -> tuple:
    """Hold damping times that ran to their upper bound at their start and refit the others.

    A damping time at its upper bound: the data want more damping than that spring plausibly gives
    (it stands in for damping elsewhere, the water's or another joint's, or flattens a misplaced
    resonance); it is held at its start and the others refitted, and stays held after.

    Returns
    -------
    tuple
        ``(joint fit, pinned)``: ``pinned`` maps composite index -> held value.
    """
    from exudyn_study.diagnose.rig_hypotheses import HeldHypothesis

    p = jf.p
    pinned = {
        j: float(comp.start[j])
        for j, (_, n) in enumerate(comp.specs)
        if n == "damping_time_s" and p[j] >= comp.upper[j] * (1.0 - 1e-3)
    }
    if not pinned or len(pinned) == p.size:  # every parameter a damping at its bound: nothing to refit
        return jf, {}
    say(
        "  damping held at its start (it ran to its upper bound): "
        + ", ".join(comp.members[comp.specs[j][0]].label for j in pinned)
    )
    sub = HeldHypothesis(comp, pinned)
    sub.start = np.clip(np.delete(p, list(pinned)), sub.lower, sub.upper)
    info_sub = {}
    p_sub, std_sub, rss_sub, at_sub, nfev_sub = fit_hypothesis(
        sub, ev_fit, channels, st.fit_nfev_composite, info=info_sub, pool=pool
    )
    if not math.isfinite(rss_sub):
        return jf, {}
    std, at_bound = np.zeros(p.size), np.zeros(p.size, bool)
    std[sub.keep], at_bound[sub.keep] = std_sub, at_sub
    jac = jf.jac.copy()
    jac[:, sub.keep] = info_sub["jac"]
    return JointFit(sub.full(p_sub), std, rss_sub, at_bound, jac, jf.nfev + nfev_sub), pinned


def _member_verdicts(
    comp, members, jf: JointFit, pinned, hold_errs, ev_fit, ev_hold, channels, gains, st, say
):
    """Judge each member of the joint fit by taking it out (the others refitted).

    A member pays for itself if the joint fit beats that refit on the training AIC and cuts the
    held-out error of every held-out recording by at least ``min_member_gain``.

    Returns
    -------
    tuple
        ``(verdicts, held_out)``: per member index its verdict (None: it cannot be taken out), and
        composite index -> value of the members that do not pay (with the pinned dampings).
    """
    from exudyn_study.diagnose.rig_hypotheses import HeldHypothesis

    p, rss, jac = jf.p, jf.rss, jf.jac
    n_eff = effective_samples(ev_fit)
    hold_err = float(np.mean(hold_errs))
    held_out = dict(pinned)
    verdicts = {}
    for k, h in enumerate(members):
        held = member_neutral(comp, k, p)
        if held is None:
            verdicts[k] = None
            continue
        n_k = len(set(held) - set(pinned))  # parameters taken out beyond the pinned dampings
        held = {**pinned, **held}
        sub = HeldHypothesis(comp, held)
        sub.start = np.clip(np.delete(p, list(held)), sub.lower, sub.upper)
        p_k, _, rss_k, _, _ = fit_hypothesis(
            sub, ev_fit, channels, st.member_nfev, jac=lambda x, c=sub.keep: jac[:, c]
        )
        errs_k = holdout_errors(ev_hold, sub.system(p_k), gains) if math.isfinite(rss_k) else None
        err_k = float(np.mean(errs_k)) if errs_k is not None else math.nan
        d_aic = aic(rss, p.size, n_eff) - aic(rss_k, p.size - n_k, n_eff)
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
    return verdicts, held_out


def _refit_held(comp, jf: JointFit, held_out: dict, ev_fit, channels, st) -> JointFit:
    """Refit the joint fit with the members that do not pay taken out together (held at ``held_out``)."""
    from exudyn_study.diagnose.rig_hypotheses import HeldHypothesis

    p = jf.p
    sub = HeldHypothesis(comp, held_out)
    sub.start = np.clip(np.delete(p, list(held_out)), sub.lower, sub.upper)
    p_sub, std_sub, rss, at_sub, nfev_sub = fit_hypothesis(
        sub, ev_fit, channels, st.member_nfev, jac=lambda x, c=sub.keep: jf.jac[:, c]
    )
    std, at_bound = np.zeros(p.size), np.ones(p.size, bool)
    std[sub.keep], at_bound[sub.keep] = std_sub, at_sub
    return JointFit(sub.full(p_sub), std, rss, at_bound, jf.jac, jf.nfev + nfev_sub)


def _member_records(
    comp,
    members,
    jf: JointFit,
    verdicts,
    hold_err,
    hyps,
    scores,
    ev_fit,
    ev_time,
    channels,
    recs,
    gains,
    rss0,
    st,
) -> list:
    """Return one fit record per member of the joint fit (like the single fits' records)."""
    p, std, rss, at_bound = jf.p, jf.std, jf.rss, jf.at_bound
    n_eff = effective_samples(ev_fit)
    improvement = 1.0 - math.sqrt(rss / rss0) if math.isfinite(rss) else -1.0
    sys_p = comp.system(p)
    r_time = system_residual(ev_time, sys_p, gains)
    ratio = 0.0 if r_time is None else response_ratio(recs, ev_time.simulate(sys_p, gains))
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
        out.append(
            {
                "h": h,
                "p": values[k],
                "std": std_k,
                "at_bound": bound_k,
                "rss": rss,
                "aic": aic(rss, p.size, n_eff),
                "identifiable": bool(np.all(good[firm]) and np.any(good[mine])),
                "improvement": improvement,
                "error_after": math.sqrt(float(r_time @ r_time) / len(recs)) if r_time is not None else 1e9,
                "response_ratio": ratio,
                "score": float(scores[hyps.index(h)]),
                "nfev": jf.nfev,
                "member": verdicts[k],
                "holdout_error": hold_err,
            }
        )
    return out


def _member_rejected(rec: dict, hold_err: float, hold_err0: float, st) -> str | None:
    """Why a member of the joint fit is rejected (None: kept)."""
    verdict = rec["member"]
    if verdict is not None and not verdict["pays"]:
        return "does not pay for itself in the joint fit"
    if not rec["identifiable"]:
        return "not identifiable in the joint fit"
    if hold_err > (1.0 - st.min_member_gain) * hold_err0:
        return f"the joint fit cuts the held-out error by less than {100 * st.min_member_gain:.0f} %"
    if rec["response_ratio"] < st.min_response_ratio:
        return "the fitted model switches the response off"
    return None


def final_refit(
    records, accepted, build, ev, channels, gains, st, say, hold_at_bound: bool = True, pool=None
) -> dict | None:
    """Refit the linear findings carried into the model together; judge them again.

    Each finding was fitted in its round against the model of that round; later findings can take
    over part of its effect (a drive linkage's mass standing in for tank mounts that round 1 lacked, or
    for a sensor fault found in a later round: a single linear finding is refitted too when anything
    was found after it).
    All parameters of the linear findings carried into the model (``records`` whose ``accepted`` entry
    is a linear hypothesis) are fitted together from their values (:class:`CompositeHypothesis` on the
    nominal model plus the other findings), on ``ev``; with ``hold_at_bound`` a parameter that ended at a
    bound in its round (the data did not determine it) is held there. Each member is judged again: a
    parameter at a bound (within 1 % of its log range), a firm parameter not identifiable (relative std
    above ``max_relative_std``) and (with two or more recordings) parameters that drift between the
    recordings (:func:`fit_per_recording`) are flagged.

    Parameters
    ----------
    records : list of dict
        Records of the findings (``h``: the hypothesis, ``accepted``: its index in ``accepted`` or None).
    accepted : list of tuple
        The carried findings ``(physics, location, values)``, in the order applied to the model.
    build : callable
        Returns a fresh, unassembled nominal model.
    ev : Evaluator or SpectralEvaluator
        Evaluator the refit runs on.
    channels : sequence of str
        The simulated channels, in row order.
    gains : numpy.ndarray or OutputChain or None
        Output gains already found (None: all one).
    st : RigDiagnosisSettings
        Settings (``max_relative_std``, drift settings, ...).
    say : callable
        Progress messages, ``say(text)``.
    hold_at_bound : bool, optional
        Whether parameters that ended at a bound in their round are held there (default True).
    pool : EvaluationPool or None, optional
        Workers for the refit's finite differences (None: this process).

    Returns
    -------
    dict or None
        ``members`` (the records), ``values``, ``std``, ``at_bound`` (per member, its parameter
        order), ``flags`` (per member, sentences), ``rss_before``/``rss_after`` (training residual at
        the rounds' values and after the refit) and ``meta`` (with ``held_at_bound``: the parameters
        held, and ``holdable``: those ``hold_at_bound`` holds); None without a linear finding, with one
        that is the last finding (nothing found after it), or when they cannot be combined.
    """
    from exudyn_study.diagnose.rig_hypotheses import CompositeHypothesis
    from exudyn_study.physics.catalogue import entry

    members = [r for r in records if r["accepted"] is not None and r["h"].kind_linear]
    if not members or (len(members) == 1 and members[0] is records[-1]):
        return None  # nothing found after a single linear finding changes what it was fitted against
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
    r0 = safe_residual(comp, ev, channels, comp.start)
    if r0 is None:
        return None
    info = {}
    p, std, rss, at_bound, nfev = fit_hypothesis(comp, ev, channels, st.final_nfev, info=info, pool=pool)
    # at a bound: within 1 % of the parameter's (log) range of it (the solver stops short of the bound
    # when the residual flattens there, e.g. a mass the data do not want running to its lower bound)
    _, lo, hi = log_bounds(comp)
    x, margin = to_x(comp, p), 0.01 * (hi - lo)
    at_bound = at_bound | (x <= lo + margin) | (x >= hi - margin)
    rel_std = np.abs(std) / np.maximum(np.abs(p), 1e-300)
    good = (rel_std < st.max_relative_std) & ~at_bound
    drift = None
    if st.drift_check and math.isfinite(rss) and len(getattr(ev, "recs", ())) > 1:
        drift = fit_per_recording(comp, p, good, ev, channels, st, info.get("jac"))
    values = comp.member_values(p)
    out_std, out_bound, out_flags = [], [], []
    for k, r in enumerate(members):
        h = r["h"]
        spec = {n: j for j, (i, n) in enumerate(comp.specs) if i == k}
        # a parameter held at the bound it ended at in its round: still at it, no std
        std_k = np.array([std[spec[n]] if n in spec else 0.0 for n in h.names])
        bound_k = np.array([bool(at_bound[spec[n]]) if n in spec else True for n in h.names])
        flags = _refit_flags(comp, h, spec, good, at_bound, rel_std, drift)
        flags += _neutral_flags(h, spec, p, std)
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


def _refit_flags(comp, h, spec: dict, good, at_bound, rel_std, drift) -> list:
    """Return a member's flags in the final joint refit: firm parameters not identifiable, drifting ones."""
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
    return flags


#: a finding whose every parameter with a value meaning "no effect" (its ``neutral``) lies within this
#: many standard deviations of it is not established by the data
NEUTRAL_Z = 2.0


def _neutral_flags(h, spec: dict, p, std) -> list:
    """Return a member's flag when the final joint refit cannot tell it from the model without it.

    A finding is carried by the parameters that move the model away from its state without the finding
    (:attr:`Hypothesis.neutral`: a scale factor of 1, a mass of 0, a rigid joint). When each of them lies
    within :data:`NEUTRAL_Z` standard deviations of that value once all findings are refitted together,
    the data do not establish the finding (other findings took over what it explained in its round).
    """
    names = [n for n in (h.neutral or {}) if n in spec]
    if not names or not all(abs(p[spec[n]] - h.neutral[n]) <= NEUTRAL_Z * std[spec[n]] for n in names):
        return []
    values = ", ".join(
        f"{n} {p[spec[n]]:.3g} +- {std[spec[n]]:.2g} (without it {h.neutral[n]:.3g})" for n in names
    )
    return [f"not distinguishable from the model without it in the joint refit of all findings: {values}"]


def _refit_findings_text(refit: dict, progress: Progress) -> Progress:
    """Rewrite the findings of an adopted final refit with its values, flags and texts."""
    from dataclasses import replace

    findings = list(progress.findings)
    per_member = (refit["members"], refit["values"], refit["std"], refit["at_bound"], refit["flags"])
    for r, p_new, std_new, bound_new, flags in zip(*per_member, strict=True):
        old = findings[r["finding"]]
        text = explain(r["h"], p_new, std_new, r["lin_before"], r["lin_after"], r["located"])
        findings[r["finding"]] = make_finding(
            r["h"],
            p_new,
            std_new,
            bound_new,
            list(r.get("flags", ())) + list(flags),
            old.band_hz,
            old.level_dependent,
            text + " (Values from the final joint refit of all findings; the modes named are "
            "those the finding moved in its round.)",
            old.fit,
            {k: old.location[k] for k in ("position_m", "nearest_sensor") if k in old.location},
        )
    return replace(progress, findings=tuple(findings))


def refit_findings(
    problem: RigProblem, state: ModelState, comparison: Comparison, progress: Progress, meta: dict
) -> tuple:
    """Refit the linear findings together and judge them again (once per set of them).

    Tried free first (every parameter may move); if that is not adopted, again with the parameters
    that ended at a bound in their rounds held there (freed, the undetermined ones can wander on the
    noise). Fitted on log transmissibilities when the model is far off (training error above
    ``spectral_above_error``), else on time histories: with ``final_refit_short`` those of the shorter
    training records of the nonlinear fits (the refit's cost is one evaluation per parameter and step).
    A refit is adopted if it lowers the residual it was fitted on and does not raise the held-out error
    (nor, fitted on the shorter records, the error on the full training records);
    ``meta['final_refit']`` records the attempts.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    comparison : Comparison
        The current model against the recordings.
    progress : Progress
        The findings and their records so far.
    meta : dict
        The diagnosis metadata; ``meta['final_refit']`` is set.

    Returns
    -------
    tuple
        ``(state, comparison, progress)`` after the refit (the inputs when nothing changed).
    """
    from dataclasses import replace

    st, say = problem.settings, problem.say
    records = progress.records
    linear = tuple(r["h"].label for r in records if r["accepted"] is not None and r["h"].kind_linear)
    if not st.final_refit or len(records) < 2 or linear == progress.refitted:
        return state, comparison, progress
    progress = replace(progress, refitted=linear)
    t_refit = time.perf_counter()
    error_now = float(np.mean([summary_error(e) for e in problem.ev_train.errors(comparison.sims_tr)]))
    short = st.final_refit_short and st.train_duration_nonlinear_s < st.train_duration_s
    ev_time = problem.ev_train_nonlinear if short else problem.ev_train
    duration = st.train_duration_nonlinear_s if short else st.train_duration_s
    ev_final = problem.ev_spectral if error_now > st.spectral_above_error else ev_time
    hold_before = float(np.mean([summary_error(e) for e in problem.ev_hold.errors(comparison.sims_ho)]))
    tried, refit, adopted = [], None, False
    for hold in (False, True):
        accepted = list(state.accepted)
        refit = final_refit(
            records,
            accepted,
            problem.build,
            ev_final,
            problem.channels,
            state.gains,
            st,
            say,
            hold,
            problem.pool,
        )
        if refit is None:
            break
        refit["meta"]["holdout_before"] = hold_before
        refit["meta"]["evaluator"] = (
            "log transmissibilities"
            if ev_final is problem.ev_spectral
            else f"time histories ({duration:g} s per recording)"
        )
        adopted = False
        if refit["rss_after"] < refit["rss_before"]:
            for r, p_new in zip(refit["members"], refit["values"], strict=True):
                accepted[r["accepted"]] = r["h"].carried(p_new)
            new_state = model_state(problem, tuple(accepted), state.gains)
            new = compare(problem, new_state.system, new_state.gains)
            hold_after = float(np.mean([summary_error(e) for e in problem.ev_hold.errors(new.sims_ho)]))
            train_after = float(np.mean([summary_error(e) for e in problem.ev_train.errors(new.sims_tr)]))
            refit["meta"].update(
                holdout_after=hold_after, train_error_before=error_now, train_error_after=train_after
            )
            # fitted on a share of the training records: the full ones must not get worse either
            on_share = short and ev_final is ev_time
            adopted = hold_after <= hold_before and (train_after <= error_now or not on_share)
            if adopted:
                state, comparison = new_state, new
            else:  # the rounds' model back: its evaluators' nonlinear correction (state, comparison kept)
                set_offsets(problem.evaluators, state.system)
        tried.append(
            {
                "held_at_bound": refit["meta"]["held_at_bound"],
                "holdout_after": refit["meta"].get("holdout_after"),
                "adopted": adopted,
            }
        )
        if adopted or hold or not refit["meta"]["holdable"]:
            break  # adopted, or held already, or holding would repeat this refit
    if refit is None:
        return state, comparison, progress
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
        progress = _refit_findings_text(refit, progress)
    refit["meta"]["wall_s"] = round(time.perf_counter() - t_refit, 1)
    meta["final_refit"] = refit["meta"]
    return state, comparison, progress
