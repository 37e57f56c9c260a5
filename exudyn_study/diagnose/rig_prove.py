"""Prove: a round's findings judged on the held-out recordings.

A stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`: :func:`prove` compares the held-out
error before and after the round's findings (per channel and in summary), the relative pseudo
damage at the z sensors, and, for a nonlinear finding fitted on the level-dependent share, that
share at a held-out level of the same drive. Acceptance is per channel, not on a mean: the mean
over channels can halve while most channels get worse when a few large ones dominate it, so the
findings may make at most ``max_channels_worse`` of the held-out channels materially worse
(:func:`channel_verdict`); the median per-channel improvement is reported beside the mean.
"""

from __future__ import annotations

import math

import numpy as np

from exudyn_study.diagnose.rig_compare import METRIC, summary_error
from exudyn_study.diagnose.rig_explain import recording_label
from exudyn_study.diagnose.rig_state import Comparison, ModelState, Proof, RigProblem


def relative_damage(recs, before, after, cache: dict | None = None):
    """Relative pseudo damage (Basquin beta 5) at the z sensors, before and after, per held-out recording.

    Parameters
    ----------
    recs : sequence of RigRecording
        The held-out recordings.
    before : sequence of numpy.ndarray
        Simulation per recording before the findings, shape (n_channels, n_samples).
    after : sequence of numpy.ndarray
        Simulation per recording after the findings, shape (n_channels, n_samples).
    cache : dict or None, optional
        Pseudo damages already counted, by array and row (:func:`channel_damage`); the measured ones and
        the model before a round (the one after the round before) are then counted once.

    Returns
    -------
    dict
        z channel -> ``{'before': d, 'after': d}``: the simulated pseudo damage over the measured one,
        mean over the recordings (1: as measured).
    """
    out = {}
    for r, b, a in zip(recs, before, after, strict=True):
        for i, c in enumerate(r.channels):
            if not c.endswith("Z") and "Z" not in c[-2:]:
                continue
            d_meas = channel_damage(r.measured, i, cache)
            if d_meas <= 0:
                continue
            out.setdefault(c, {"before": [], "after": []})
            out[c]["before"].append(channel_damage(b, i, cache) / d_meas)
            out[c]["after"].append(channel_damage(a, i, cache) / d_meas)
    return {
        c: {"before": float(np.mean(v["before"])), "after": float(np.mean(v["after"]))}
        for c, v in out.items()
    }


#: samples left out at the start of a record before counting its pseudo damage (the start-up)
DAMAGE_SKIP_SAMPLES = 1000


def channel_damage(x: np.ndarray, i: int, cache: dict | None = None) -> float:
    """Pseudo damage (Basquin beta 5) of row ``i`` of ``x`` after the first :data:`DAMAGE_SKIP_SAMPLES`.

    Parameters
    ----------
    x : numpy.ndarray
        Signals, shape (n_channels, n_samples); not changed afterwards when ``cache`` is given.
    i : int
        Row.
    cache : dict or None, optional
        Memo by the array's identity (a weak reference: a freed array's entry is never reused) and row.

    Returns
    -------
    float
        The summed pseudo damage of the rainflow cycles.
    """
    import weakref

    from exudyn_study.signals.fatigue import pseudo_damage

    if cache is None:
        return float(np.sum(pseudo_damage(x[i, DAMAGE_SKIP_SAMPLES:])))
    key = (id(x), i)
    hit = cache.get(key)
    if hit is not None and hit[0]() is x:
        return hit[1]
    d = float(np.sum(pseudo_damage(x[i, DAMAGE_SKIP_SAMPLES:])))
    cache[key] = (weakref.ref(x), d)
    return d


def prove(
    problem: RigProblem,
    before: ModelState,
    comparison: Comparison,
    after: ModelState,
    comparison_after: Comparison,
    batch: list,
) -> Proof:
    """Judge the round's findings ``batch`` (carried from ``before`` into ``after``) on held-out data.

    The findings must not raise the held-out error, except a nonlinear one fitted on the
    level-dependent share: it is proven on that share at a held-out level of the same drive (it
    must explain ``min_improvement`` of it there) and may raise the held-out error by
    ``nonlinear_holdout_tolerance`` at most.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    before : ModelState
        The model before the round's findings.
    comparison : Comparison
        ``before`` against the recordings.
    after : ModelState
        The model with the round's findings.
    comparison_after : Comparison
        ``after`` against the recordings.
    batch : list of dict
        Fit records of the round's findings (``h``, ``on_distortion``, ...).

    Returns
    -------
    Proof
        The finding's ``fit`` block and the verdict.
    """
    st, ev_hold, ev_train = problem.settings, problem.ev_hold, problem.ev_train
    per_ho0, per_ho1 = ev_hold.errors(comparison.sims_ho), ev_hold.errors(comparison_after.sims_ho)
    fit = {
        "train_before": float(np.mean([summary_error(e) for e in ev_train.errors(comparison.sims_tr)])),
        "train_after": float(np.mean([summary_error(e) for e in ev_train.errors(comparison_after.sims_tr)])),
        "holdout_before": float(np.mean([summary_error(e) for e in per_ho0])),
        "holdout_after": float(np.mean([summary_error(e) for e in per_ho1])),
        "metric": METRIC,
        "per_channel": {
            recording_label(name): {
                c: {"before": float(e0[k]), "after": float(e1[k])} for k, c in enumerate(problem.channels)
            }
            for (name, _), e0, e1 in zip(problem.holdout, per_ho0, per_ho1, strict=True)
        },
        "relative_pseudo_damage": relative_damage(
            problem.hold_recs, comparison.sims_ho, comparison_after.sims_ho, problem.damage_cache
        ),
    }
    held_share = None
    if problem.ev_distortion_hold is not None and any(f.get("on_distortion") for f in batch):
        # a nonlinear finding fitted on the level-dependent share: proven on it at a held-out level
        r_before = problem.ev_distortion_hold.residual_vector(before.system, before.gains)
        r_after = problem.ev_distortion_hold.residual_vector(after.system, after.gains)
        held_share = 1.0 - math.sqrt(float(r_after @ r_after) / max(float(r_before @ r_before), 1e-300))
        fit["holdout_level_dependent_improvement"] = held_share
        problem.say(
            f"it explains {100 * held_share:.0f} % of the level-dependent share at the held-out level"
        )
    verdict = channel_verdict(problem.holdout, problem.channels, per_ho0, per_ho1, st)
    fit.update(verdict)
    nonlinear_proven = (
        held_share is not None
        and held_share >= st.min_improvement
        and fit["holdout_after"] <= (1.0 + st.nonlinear_holdout_tolerance) * fit["holdout_before"]
    )
    if len(batch) > 1:
        fit["together_with"] = [f["h"].label for f in batch]  # the fit is that of the whole round
    if fit["holdout_after"] > fit["holdout_before"] and not nonlinear_proven:
        # it fits the training recordings but not the held-out ones: not a finding
        labels = " + ".join(f["h"].label for f in batch)
        problem.say(
            f"{labels} worsens the held-out error ({fit['holdout_before']:.4f} -> "
            f"{fit['holdout_after']:.4f}): not accepted"
        )
        return Proof(
            fit,
            False,
            f"the best fit ({labels}) improves the training recordings but worsens the held-out error "
            f"({fit['holdout_before']:.3g} -> {fit['holdout_after']:.3g})",
        )
    # a model far off (resonances misplaced: the round fitted log transmissibilities) is proven on the mean
    # held-out error: its first findings (one of several interacting effects) move channels that only the
    # later ones put right; the per-channel verdict of the final model is in the metadata
    far_off = fit["train_before"] > st.spectral_above_error
    fit["channel_rule_applied"] = not far_off
    if verdict["share_channels_worse"] > st.max_channels_worse and not far_off:
        labels = " + ".join(f["h"].label for f in batch)
        worse = [f"{c} {a:.2g} -> {b:.2g}" for c, (a, b) in verdict["channels_worse"].items()]
        reason = (
            f"the best fit ({labels}) makes {len(worse)} of {verdict['n_channels']} held-out channels "
            f"materially worse ({', '.join(worse[:6])}{', ...' if len(worse) > 6 else ''}), more than "
            f"{100 * st.max_channels_worse:.0f} %"
        )
        problem.say(reason + ": not accepted")
        return Proof(fit, False, reason)
    return Proof(fit, True)


def channel_verdict(holdout, channels, before, after, st) -> dict:
    """Per held-out channel, whether it got materially worse; the median improvement over channels.

    Parameters
    ----------
    holdout : sequence of (str, Recording)
        The named held-out recordings.
    channels : sequence of str
        The channels (rows of ``before`` and ``after``).
    before, after : sequence of numpy.ndarray
        Per held-out recording, the relative error per channel before and after, shape (n_channels,).
    st : RigDiagnosisSettings
        ``channel_worse_tolerance`` and ``channel_worse_floor``.

    Returns
    -------
    dict
        ``channels_worse`` (``'recording:channel'`` or, with one held-out recording, the channel ->
        (before, after)), ``n_channels`` (channels times recordings), ``share_channels_worse`` and
        ``holdout_median_improvement`` (median over all of ``1 - after / before``).
    """
    worse, gains = {}, []
    for (name, _), e0, e1 in zip(holdout, before, after, strict=True):
        e0, e1 = np.asarray(e0, dtype=float), np.asarray(e1, dtype=float)
        gains.append(1.0 - e1 / np.maximum(e0, 1e-300))
        grew = e1 - e0
        bad = (grew > st.channel_worse_tolerance * e0) & (grew > st.channel_worse_floor)
        for k in np.flatnonzero(bad):
            key = channels[k] if len(holdout) == 1 else f"{recording_label(name)}:{channels[k]}"
            worse[key] = (float(e0[k]), float(e1[k]))
    n = len(channels) * len(holdout)
    return {
        "channels_worse": worse,
        "n_channels": n,
        "share_channels_worse": len(worse) / max(n, 1),
        "holdout_median_improvement": float(np.median(np.concatenate(gains))),
    }
