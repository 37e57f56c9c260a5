"""A body-wide entry must show that it acts body-wide: the modal damping factor against local damping.

A modal damping finding (``modal_damping``: the damping of every mode of one flexible body scaled
by one factor) claims the change is spread over the body. A local damper (a dashpot to ground, a
damped mount) adds damping to each mode in proportion to the mode's motion squared at its place:
across the body's modes that is far from one factor, yet the single factor fitted to it can still
explain much of the residual, and its text ("frequencies agree") would raise no doubt. When a
round's acceptable fits include a modal damping factor, :func:`body_wide` asks two things:

1. **Per band.** The body's modes in the recorded band are split into up to
   :data:`MODAL_BAND_GROUPS` groups of neighbouring frequencies (the modes below the band join the
   first, those above the last) and one factor is fitted per group
   (:class:`~exudyn_study.diagnose.rig_hypotheses.ModalDampingBandsHypothesis`). The factors
   disagree when two of them that the data determine (relative standard deviation below
   ``max_relative_std``, not at a bound) differ by more than :data:`BAND_RATIO` and by more
   than :data:`BAND_SIGMAS` standard deviations of their logarithms.
2. **Against the local element.** The generic local element (a spring-damper to ground at the
   places the round's screen points at) is fitted. It replaces the factor when it explains
   ``GENERIC_MARGIN`` more of the training error than the factor, or, the bands disagreeing, nearly
   as much (at most ``GENERIC_MARGIN`` less): local physics that the data say is local. Both are
   compared on the time histories, where a round far off fits on log transmissibilities: there a
   damping change moves little of the residual (the peaks' heights, not their places), and a
   factor can come in through a joint fit, proven on the held-out error, while every single fit
   "explains too little". The local element must itself be identifiable, keep the response on and
   explain ``min_improvement`` of the training error.

A factor kept although its bands disagree is flagged; the factors per band are in the JSON
(``meta['candidates']``, ``per_band``) either way.
"""

from __future__ import annotations

import math

import numpy as np

from exudyn_study.diagnose.rig_compare import BANDS_HZ

__all__ = ["body_wide", "band_groups", "bands_disagree", "MODAL_BAND_GROUPS", "BAND_RATIO", "BAND_SIGMAS"]

#: at most this many groups of a body's modes get a factor of their own
MODAL_BAND_GROUPS = 3
#: two determined band factors further apart than this ratio (and BAND_SIGMAS) disagree
BAND_RATIO = 1.5
#: ... and further apart than this many standard deviations of their logarithms' difference
BAND_SIGMAS = 3.0
#: the modes of the recorded band reach this far above its top (their peaks' flanks are in the band)
BAND_TOP_REACH = 1.2


def band_groups(frequencies_hz, n_groups: int = MODAL_BAND_GROUPS, band_hz=None) -> list:
    """Split a body's modes into groups of neighbouring frequencies, about as many in the band in each.

    Parameters
    ----------
    frequencies_hz : array_like
        The body's free-free mode frequencies (Hz), shape (n_modes,).
    n_groups : int, optional
        Most groups (default :data:`MODAL_BAND_GROUPS`).
    band_hz : tuple of float, optional
        ``(lowest, highest)`` recorded frequency (default the comparison's bands, the top widened by
        :data:`BAND_TOP_REACH`).

    Returns
    -------
    list of numpy.ndarray
        Positions in ``frequencies_hz`` of each group's modes, lowest group first; empty when fewer
        than two modes lie in the band (one factor is all the data can tell).
    """
    f = np.asarray(frequencies_hz, dtype=float)
    lo, hi = band_hz if band_hz is not None else (BANDS_HZ[0][0], BANDS_HZ[-1][1] * BAND_TOP_REACH)
    order = np.argsort(f, kind="stable")
    inside = [i for i in order if lo <= f[i] <= hi]
    if len(inside) < 2:
        return []
    groups = [list(g) for g in np.array_split(np.asarray(inside, dtype=int), min(n_groups, len(inside)))]
    groups[0] = [i for i in order if f[i] < lo] + groups[0]
    groups[-1] = groups[-1] + [i for i in order if f[i] > hi]
    return [np.asarray(g, dtype=int) for g in groups]


def bands_disagree(p, std, at_bound, max_relative_std: float) -> tuple | None:
    """Return the two band factors that disagree most, or None when the determined ones agree.

    Parameters
    ----------
    p, std : array_like
        Fitted factor per group and its standard deviation, shape (n_groups,).
    at_bound : array_like of bool
        Whether each factor ended at a bound.
    max_relative_std : float
        A factor is determined when its relative standard deviation is below this.

    Returns
    -------
    tuple or None
        ``(i, j)``: positions of the two factors (lower first) whose disagreement is largest in
        standard deviations, among pairs further apart than :data:`BAND_RATIO` and
        :data:`BAND_SIGMAS` standard deviations; None if no pair is.
    """
    p, std = np.asarray(p, dtype=float), np.asarray(std, dtype=float)
    rel = np.abs(std) / np.maximum(np.abs(p), 1e-300)
    determined = np.flatnonzero((rel < max_relative_std) & ~np.asarray(at_bound, dtype=bool))
    best, best_sigmas = None, 0.0
    for a in determined:
        for b in determined:
            if p[a] >= p[b]:
                continue
            gap = math.log(p[b] / p[a])
            sigmas = gap / max(math.hypot(rel[a], rel[b]), 1e-300)
            if gap > math.log(BAND_RATIO) and sigmas > BAND_SIGMAS and sigmas > best_sigmas:
                best, best_sigmas = (int(a), int(b)), sigmas
    return best


def _bands_fit(problem, screening, f: dict) -> dict | None:
    """Fit the modal damping fit ``f``'s body one factor per group of modes; None if it has too few modes."""
    from exudyn_study.diagnose.rig_evaluate import fit_hypothesis
    from exudyn_study.diagnose.rig_hypotheses import ModalDampingBandsHypothesis

    h = f["h"]
    freq = getattr(h, "frequencies_hz", None)
    if freq is None:
        return None
    groups = band_groups(freq)
    if len(groups) < 2:
        return None
    bands = [(float(freq[g].min()), float(freq[g].max())) for g in groups]
    hb = ModalDampingBandsHypothesis(h, groups, bands)
    hb.start = np.full(len(groups), float(np.clip(f["p"][0], hb.lower[0] * 1.01, hb.upper[0] / 1.01)))
    ev_fit, rss0, _ = screening.judged_on(h)
    problem.say(f"fitting {h.label} per band of its modes ({len(groups)} bands)")
    p, std, rss, at_bound, _ = fit_hypothesis(
        hb, ev_fit, problem.channels, problem.settings.fit_nfev, pool=problem.pool
    )
    return {
        "h": hb,
        "p": p,
        "std": std,
        "at_bound": at_bound,
        "improvement": 1.0 - math.sqrt(rss / rss0) if math.isfinite(rss) else -1.0,
        "disagree": bands_disagree(p, std, at_bound, problem.settings.max_relative_std),
    }


def _band_text(bands: dict, k: int) -> str:
    (lo, hi), p, s = bands["h"].bands_hz[k], bands["p"][k], bands["std"][k]
    return f"{lo:.0f}-{hi:.0f} Hz x{p:.2f} +- {s:.2f}"


def body_wide(problem, state, screening, fits, meta: dict, round_no: int):
    """Check the round's acceptable modal damping fits for a body-wide change (module docstring).

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    screening : Screening
        The round's screening.
    fits : RoundFits
        The round's fits.
    meta : dict
        The diagnosis metadata; the fits per band and the generic element's fits are appended to
        ``meta['candidates']``.
    round_no : int
        Index of the round (0 for the first).

    Returns
    -------
    RoundFits
        ``fits``; the generic element's acceptable fits in place of a modal damping fit it replaces,
        or the modal damping fit flagged when its bands disagree.
    """
    from dataclasses import replace

    from exudyn_study.diagnose.rig_fit import GENERIC_MARGIN, fit_generic
    from exudyn_study.diagnose.rig_state import RoundFits

    modal = [f for f in fits.ok if f["h"].physics == "modal_damping"]
    if not modal:
        return fits
    st = problem.settings
    fitted = list(fits.fitted)
    if not any(f["h"].physics == "local_element" for f in fits.fitted):
        fitted += list(fit_generic(problem, state, screening, RoundFits((), ()), meta, round_no).fitted)
    error0 = math.sqrt(screening.rss0_time / len(problem.train_recs))

    def explains(f):  # share of the training error (time histories) the fit removes
        return 1.0 - f["error_after"] / error0

    generic_ok = [
        f
        for f in fitted
        if f["h"].physics == "local_element"
        and f["identifiable"]
        and f["response_ratio"] >= st.min_response_ratio
        and explains(f) >= st.min_improvement
    ]
    best_generic = max(generic_ok, key=explains, default=None)
    # a joint fit's other members were fitted with the factor: it is replaced only when it stands alone
    replaceable = not fits.together or len(fits.ok) == 1
    ok = list(fits.ok)
    for f in modal:
        bands = _bands_fit(problem, screening, f)
        disagree = bands is not None and bands["disagree"] is not None
        if bands is not None:
            meta["candidates"].append(
                {
                    "round": round_no + 1,
                    "physics": "modal_damping",
                    "location": f["h"].location,
                    "per_band": [
                        {
                            "band_hz": [round(lo, 2), round(hi, 2)],
                            "factor": round(float(p), 4),
                            "std": round(float(s), 4),
                            "at_bound": bool(b),
                        }
                        for (lo, hi), p, s, b in zip(
                            bands["h"].bands_hz, bands["p"], bands["std"], bands["at_bound"], strict=True
                        )
                    ],
                    "bands_disagree": disagree,
                    "improvement": round(bands["improvement"], 4),
                }
            )
        local_explains = explains(best_generic) if best_generic is not None else -math.inf
        need = explains(f) + (-GENERIC_MARGIN if disagree else GENERIC_MARGIN)
        if replaceable and local_explains >= need:
            problem.say(
                f"{f['h'].label}: the generic local element at {best_generic['h'].location} explains "
                f"{100 * local_explains:.0f} % of the training error against {100 * explains(f):.0f} %"
                + (", and the factors per band of modes disagree" if disagree else "")
                + ": the local element is taken instead"
            )
            ok = [g for g in ok if g is not f] + [best_generic]
            continue
        if disagree:
            i, j = bands["disagree"]
            flag = (
                f"the damping factors per band of {f['h'].location}'s modes disagree "
                f"({_band_text(bands, i)} against {_band_text(bands, j)}): the change is not body-wide, "
                "a local damper may explain it"
                + (
                    f" (the generic local element at {best_generic['h'].location} explains "
                    f"{100 * local_explains:.0f} % of the training error against {100 * explains(f):.0f} %)"
                    if best_generic is not None
                    else ""
                )
            )
            problem.say(f"{f['h'].label}: {flag}")
            f.setdefault("flags", []).append(flag)
    together = fits.together and all(g["h"].physics != "local_element" for g in ok)
    return replace(fits, fitted=tuple(fitted), ok=tuple(ok), together=together)
