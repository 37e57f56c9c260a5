"""Refine a point finding: its place (the mesh nodes around it) and its entry (the simpler one it nests).

Part of the fit stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`. The structure screen
(:mod:`~exudyn_study.diagnose.rig_places`) tries one mesh node per ``place_spacing_m`` cube, so a mass,
a resonator or a dashpot between two of them is fitted at the nearest screened place, and the fit
makes up for the wrong motion there with a wrong value (a dashpot at a place moving 20 % more needs
about 30 % less damping). :func:`refine_places` scores the fitted element at every mesh node within
:data:`REFINE_RADIUS_M` (one per :data:`REFINE_SPACING_M` cube) by the same low-rank update, and refits
at the best node when it explains clearly more; the refit is kept if it fits the round's evaluator
better. When no sampled node explains more, every node nearby is tried, and the walk ends on the
training time histories (:class:`~exudyn_study.diagnose.rig_places.TimeScorer`, each node at its best
amount): log transmissibilities no longer resolve a few centimetres once a point finding explains
nearly everything, and a heavy mass a few centimetres off its node still leaves tens of times the
noise floor there.

A tuned mass-damper can stand in for simpler physics it contains as a limit: tuned above the
diagnosed band its mass follows its point there (a point mass, apparent value
``m / (1 - (f / f_t)^2)``), and damped so much that it makes no resonance of its own it dissipates
like a dashpot to ground above its tuning. Its three parameters then buy nothing the data show, and
naming a resonator would claim physics the data do not hold. :func:`simpler_entries` fits the nested
entry (a point mass; the generic spring-damper to ground) at the resonator's place, refines that place
as above, and names it instead when it leaves at most :data:`SIMPLER_MARGIN` more of the residual.
"""

from __future__ import annotations

import math

import numpy as np

from exudyn_study.diagnose.rig_candidates import POINT_KINDS
from exudyn_study.diagnose.rig_evaluate import aic, effective_samples
from exudyn_study.diagnose.rig_fit import candidates_meta, closest_candidates, fit_extra

__all__ = [
    "refine_places",
    "simpler_entries",
    "nested_point_entry",
    "nodes_near",
    "REFINE_RADIUS_M",
    "REFINE_SPACING_M",
    "REFINE_FINE_RADIUS_M",
    "REFINE_TIME_RADIUS_M",
    "REFINE_TIME_SPACING_M",
    "REFINE_TIME_FINE_RADIUS_M",
    "REFINE_MIN_GAIN",
    "REFINE_STEPS",
    "SIMPLER_MARGIN",
    "SIMPLER_SHARE",
    "place_again",
    "PLACE_AGAIN_MARGIN",
    "STAND_IN_SHARE",
]

#: mesh nodes within this distance (m) of a point fit's place are tried (the screen's cube diagonal)
REFINE_RADIUS_M = 0.26
#: one node per cube of this edge (m) among them
REFINE_SPACING_M = 0.04
#: when no such node explains clearly more, every mesh node within this distance (m) is tried: a place
#: between two sampled nodes (a few centimetres on a thin shell carrying a heavy mass) leaves tens of times
#: the noise floor
REFINE_FINE_RADIUS_M = 0.06
#: a node is refitted if the fitted element there leaves this share less of the residual
REFINE_MIN_GAIN = 0.02
#: when neither explains clearly more on log transmissibilities (whose estimation noise hides what a few
#: centimetres change once a point finding explains nearly everything), nodes within this distance (m), one
#: per :data:`REFINE_TIME_SPACING_M` cube, are scored on the time histories (:class:`TimeScorer`)
REFINE_TIME_RADIUS_M = 0.1
REFINE_TIME_SPACING_M = 0.025
#: and when none of them explains clearly more, every node within this distance (m)
REFINE_TIME_FINE_RADIUS_M = 0.03
#: the best nodes of a step on the time histories whose amount is refined on the exact residual
REFINE_TIME_POLISHED = 3
#: refinement steps per point fit at most (each from the last refit's node; a walk ends earlier when no
#: node nearby explains clearly more)
REFINE_STEPS = 8
#: the nested simpler entry is named if the residual it leaves (sum of squares) is at most this share
#: larger than the resonator's ...
SIMPLER_MARGIN = 0.1
#: ... or if it explains at most this share of the round's error less than the resonator (the margin by
#: which the generic element gives way to a catalogue entry): the resonator's third parameter makes up
#: for a place a few centimetres off, which is a large share of a small residual left
SIMPLER_SHARE = 0.05
#: resonator fits of a round tried for the simpler entry they nest (best first)
SIMPLER_TRIES = 2


def nodes_near(
    model,
    position_m,
    radius_m: float = REFINE_RADIUS_M,
    spacing_m: float | None = REFINE_SPACING_M,
    skip=("rear_foundation",),
) -> list:
    """Return ``(place name 'body#node', position)`` of mesh nodes within ``radius_m`` of a point.

    One node per ``spacing_m`` cube (the nearest the centroid of the cube's nodes), or every node when
    ``spacing_m`` is None, on every flexible body but those in ``skip``.

    Parameters
    ----------
    model : Model
        The assembled model.
    position_m : array_like
        The point (m), shape (3,).
    radius_m : float, optional
        Search radius (m).
    spacing_m : float or None, optional
        Cube edge (m); None: every node.
    skip : tuple of str, optional
        Bodies left out (the rig's foundation).

    Returns
    -------
    list of tuple
        ``(name, position)`` pairs.
    """
    pos = np.asarray(position_m, dtype=float)
    out = []
    for b, handle in model.bodies.items():
        if b in skip:
            continue
        x = np.asarray(handle.body.node_positions_m, dtype=float) + np.asarray(handle.position_m, dtype=float)
        near = np.flatnonzero(np.linalg.norm(x - pos, axis=1) <= radius_m)
        if near.size == 0:
            continue
        if spacing_m is None:
            out += [(f"{b}#{int(n)}", x[n]) for n in near]
            continue
        cells = np.floor(x[near] / spacing_m).astype(int)
        _, inverse = np.unique(cells, axis=0, return_inverse=True)
        for c in range(int(inverse.max()) + 1):
            members = near[inverse.ravel() == c]
            centre = x[members].mean(axis=0)
            node = int(members[np.argmin(np.linalg.norm(x[members] - centre, axis=1))])
            out.append((f"{b}#{node}", x[node]))
    return out


def refine_places(problem, state, screening, fits, meta: dict, round_no: int):
    """Refit each acceptable point fit of the round at a better mesh node nearby, when there is one.

    Step by step (at most :data:`REFINE_STEPS`): each refit's node is searched around again, so a fit
    placed beyond :data:`REFINE_RADIUS_M` from its node walks to it while every step fits better.

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    screening : Screening
        The round's screening (its context, the evaluator each fit is judged on).
    fits : RoundFits
        The round's fits.
    meta : dict
        The diagnosis metadata; the refits are appended to ``meta['candidates']`` (``refined_from``).
    round_no : int
        Index of the round (0 for the first).

    Returns
    -------
    RoundFits
        ``fits`` with each refined fit in place of its original (the refits appended to ``fitted``).
    """
    from dataclasses import replace

    point = [f for f in fits.ok if f["h"].physics in POINT_KINDS and not f.get("place_refined")]
    if fits.together or not point:
        return fits
    from exudyn_study.diagnose.rig_places import LocalSensitivity

    ev = problem.ev_spectral
    sens = LocalSensitivity.of_evaluator(state.lin, ev)
    ok, fitted = list(fits.ok), list(fits.fitted)
    for f in point:
        current, refits = _walk(problem, state, screening, f, sens, ev, screening.walks)
        fitted += refits
        if current is not f:
            ok[next(i for i, g in enumerate(ok) if g is f)] = current
    refits = fitted[len(fits.fitted) :]
    if refits:
        aic0 = aic(screening.rss0, 0, effective_samples(screening.ev_fit))
        meta["candidates"] += candidates_meta(refits, round_no, aic0)
    return replace(fits, fitted=tuple(fitted), ok=tuple(ok))


def _walk(problem, state, screening, f: dict, sens, ev, walked: dict | None = None) -> tuple:
    """Refine point fit ``f``'s place from node to node while a neighbour explains clearly more.

    Each refit fits better than the last. A step tries one node per :data:`REFINE_SPACING_M` cube within
    :data:`REFINE_RADIUS_M` and, when none of them explains clearly more, every node within
    :data:`REFINE_FINE_RADIUS_M` (both on log transmissibilities); when neither finds one, or after
    :data:`REFINE_STEPS` such steps, the walk goes on on the time histories only (the nodes within
    :data:`REFINE_TIME_RADIUS_M`, then every node within :data:`REFINE_TIME_FINE_RADIUS_M`, each at its
    best amounts; a refit there judged on them), for at most :data:`REFINE_STEPS` steps.
    ``walked`` maps ``(kind, place)`` of the nodes the round's earlier walks refitted at to where those
    walks ended: a walk reaching one of them ends there too instead of fitting the same element at the
    same node again (it is updated).

    Returns ``(best fit, every refit made)``; the best fit is ``f`` when no step fits better.
    """
    from exudyn_study.diagnose.rig_places import TimeScorer

    walked = {} if walked is None else walked
    current, refits, visited, timed = f, [], [], None
    in_time, steps = False, {False: 0, True: 0}
    while True:
        step = None
        if not in_time and steps[False] < REFINE_STEPS:
            step = _better_node(state, screening, current, sens, ev, REFINE_RADIUS_M, REFINE_SPACING_M)
            if step is None:
                step = _better_node(state, screening, current, sens, ev, REFINE_FINE_RADIUS_M, None)
        if step is None and steps[True] < REFINE_STEPS:
            # from here on the time histories only: log transmissibilities no longer resolve the place
            in_time = True
            if timed is None:
                timed = TimeScorer(state.lin, problem.ev_screen, state.gains)
            step = _better_node_in_time(
                state, screening, current, timed, REFINE_TIME_RADIUS_M, REFINE_TIME_SPACING_M
            )
            if step is None:
                step = _better_node_in_time(state, screening, current, timed, REFINE_TIME_FINE_RADIUS_M, None)
        if step is None:
            break
        steps[in_time] += 1
        key = (current["h"].physics, step[0])
        if key in visited or step[0] == f["h"].location:  # back to a node of this walk: it ends here
            break
        if key in walked:  # an earlier walk of the round went on from this node
            end = walked[key]
            if end["rejected"] is None and _fits_better(problem, end, current, in_time):
                current = end
            break
        f2 = _refit_at(problem, state, screening, current, step)
        refits.append(f2)
        visited.append(key)
        if f2["rejected"] is not None or not _fits_better(problem, f2, current, in_time):
            problem.say(f"  the refit at {f2['h'].location} does not fit better: {current['h'].label} kept")
            break
        current = f2
    walked.update((key, current) for key in visited)
    return current, refits


def _better_node(state, screening, f: dict, sens, ev, radius_m: float, spacing_m: float | None):
    """Return the mesh node near point fit ``f``'s place where its element explains clearly more, or None.

    Nodes within ``radius_m`` (one per ``spacing_m`` cube; None: every node) are scored by the low-rank
    update at the fitted values scaled (:data:`REFINE_VALUE_FACTORS`). Returns ``(name, position, share,
    left there, left here, values)`` (``f``'s values) when the best node leaves :data:`REFINE_MIN_GAIN`
    less of the residual than ``f``'s place.
    """
    from exudyn_study.diagnose.rig_candidates import place_where
    from exudyn_study.diagnose.rig_places import PlaceScorer

    around = _around(state, screening, f, radius_m, spacing_m)
    if around is None:
        return None
    h, values, nodes = f["h"], *around
    scorer = PlaceScorer.of_evaluator(sens, ev, state.gains, {h.physics: _value_grid(values)})
    _, p_here = place_where(screening.ctx, h.location)
    maps = [p_here] + [place_where(screening.ctx, name)[1] for name, _ in nodes]
    shares = [(best[0][2] if best else -np.inf) for best in scorer.score([sens.reduced(m) for m in maps])]
    k = int(np.argmax(shares[1:])) + 1
    left_here, left_best = 1.0 - shares[0], 1.0 - shares[k]
    if not left_best < (1.0 - REFINE_MIN_GAIN) * left_here:
        return None
    return (*nodes[k - 1], shares[k], left_best, left_here, values)


def _around(state, screening, f: dict, radius_m: float, spacing_m: float | None):
    """Return ``(values, nodes)`` of point fit ``f``: its values and the other nodes within ``radius_m``.

    ``nodes``: ``(name, position)`` from :func:`nodes_near` (one per ``spacing_m`` cube; None: every node).
    None when ``f`` has no position or no other node is near.
    """
    from exudyn_study.diagnose.rig_candidates import point_of

    h = f["h"]
    here = point_of(h, screening.ctx.markers).get("position_m")
    if here is None:
        return None
    values = {n: float(v) for n, v in zip(h.names, f["p"], strict=True)}
    near = nodes_near(state.model, here, radius_m, spacing_m)
    nodes = [(name, pos) for name, pos in near if name != h.location]
    return (values, nodes) if nodes else None


def _fits_better(problem, a: dict, b: dict, in_time: bool) -> bool:
    """Return whether fit ``a`` leaves less than fit ``b``.

    On the time histories for a step found on them, else on the round's evaluator (it may be log
    transmissibilities).
    """
    if in_time:
        return _rss_time(problem, a) < _rss_time(problem, b)
    return a["rss"] < b["rss"]


def _rss_time(problem, f: dict) -> float:
    """Return fit ``f``'s residual sum of squares on the training time histories (computed once)."""
    if "rss_time" not in f:
        from exudyn_study.diagnose.rig_evaluate import combined_gains, system_residual

        h, p = f["h"], f["p"]
        r = system_residual(problem.ev_train, h.system(p), combined_gains(h, p, problem.channels))
        f["rss_time"] = float(r @ r) if r is not None else math.inf
    return f["rss_time"]


def _better_node_in_time(state, screening, f: dict, timed, radius_m: float, spacing_m: float | None):
    """Return the node near point fit ``f``'s place where its element leaves clearly less (time histories).

    Nodes within ``radius_m`` (one per ``spacing_m`` cube; None: every node) are scored by ``timed`` (a
    :class:`~exudyn_study.diagnose.rig_places.TimeScorer`), each at its best amounts
    (:meth:`~exudyn_study.diagnose.rig_places.TimeScorer.best`). Returns what :func:`_better_node`
    returns, the element's values those found there, or None.
    """
    from exudyn_study.diagnose.rig_candidates import place_where

    around = _around(state, screening, f, radius_m, spacing_m) if timed.rss0 > 0.0 else None
    if around is None:
        return None
    h, values, nodes = f["h"], *around
    maps = [place_where(screening.ctx, name)[1] for name, _ in nodes]
    scored = [timed.best(m, values) for m in maps]
    # the best few and the place itself refined on the exact residual
    p_here = place_where(screening.ctx, h.location)[1]
    rss_here = timed.polish(p_here, timed.best(p_here, values)[1])[0]
    for i in np.argsort([rss for rss, _ in scored])[:REFINE_TIME_POLISHED]:
        scored[i] = timed.polish(maps[i], scored[i][1])
    k = int(np.argmin([rss for rss, _ in scored]))
    left_here, left_best = rss_here / timed.rss0, scored[k][0] / timed.rss0
    if not left_best < (1.0 - REFINE_MIN_GAIN) * left_here:
        return None
    return (*nodes[k], max(0.0, 1.0 - left_best), left_best, left_here, scored[k][1])


def _refit_at(problem, state, screening, f: dict, step: tuple) -> dict:
    """Refit point fit ``f``'s element at the node of ``step`` (:func:`_better_node`); its record.

    The refit starts from the values the step carries. The record has ``rejected`` and ``refined_from``
    set.
    """
    from exudyn_study.diagnose.rig_candidates import point_of

    h = f["h"]
    name, pos, share, left_best, left_here, found = step
    here = point_of(h, screening.ctx.markers).get("position_m")
    values = {n: float(found[n]) for n in h.names}
    h2 = _moved(h, screening.ctx, name, values, state.lin)
    h2.position_m = [float(v) for v in pos]
    if hasattr(h, "place"):
        h2.place = point_of(h2, screening.ctx.markers)
    problem.say(
        f"refining {h.label}: the fitted element leaves {100 * left_best:.3g} % of the residual at "
        f"{name}, {np.linalg.norm(np.asarray(pos) - np.asarray(here)):.2f} m away, against "
        f"{100 * left_here:.3g} % at {h.location}: refitting there"
    )
    f2 = fit_extra(problem, screening, h2, share)
    f2["refined_from"] = h.location
    return f2


#: factors on a point fit's amounts (mass, stiffness, damping) at which its element is scored at the
#: nodes nearby: the value fitted at one node makes up for the motion there, another node needs another
REFINE_VALUE_FACTORS = (0.5, 0.7, 1.0, 1.4, 2.0)
def _value_grid(values: dict) -> list:
    """Return the point element's parameter sets scored at the nodes nearby (its amounts scaled)."""
    from exudyn_study.diagnose.rig_places import scale_amounts

    return [scale_amounts(values, a) for a in REFINE_VALUE_FACTORS]


def _moved(h, ctx, place: str, values: dict, lin, kind: str | None = None):
    """Return a hypothesis like ``h`` (or of point ``kind``) at ``place``, started at ``values``.

    At ``h``'s own place it keeps ``h``'s coordinates (a mesh node's, which the place name alone does not
    carry to the markers). It keeps ``h``'s output gains of the faults found before (``base_gains``):
    refitted without them, a place is judged against the faults' own mismatch.
    """
    from exudyn_study.diagnose.rig_candidates import place_where, point_hypothesis

    where, p_map = place_where(ctx, place)
    moved = point_hypothesis(kind or h.physics, place, lin, p_map, values, **where)
    moved.start = np.clip(moved.start, moved.lower, moved.upper)
    if hasattr(h, "closest"):
        moved.closest = h.closest
    if hasattr(h, "base_gains"):
        moved.base_gains = h.base_gains
    if place == h.location and getattr(h, "position_m", None) is not None:
        moved.position_m = list(h.position_m)
    return moved


def nested_point_entry(values: dict, band_hz: tuple | None = None):
    """Return the simpler point entry a fitted tuned mass-damper reduces to in the band, or None.

    - Tuned above the band (``frequency_hz > band_hz[1]``): a point mass of the resonator's apparent
      mass ``m / (1 - (f / f_t)^2)`` at the band's geometric middle ``f``.
    - Damped by :data:`~exudyn_study.diagnose.rig_explain.TMD_NO_RESONANCE_DAMPING` or more: the
      generic spring-damper to ground whose stiffness and damping are the resonator's dynamic
      stiffness ``-mu`` averaged over the band above its tuning (real part; imaginary part over
      ``omega``).

    Parameters
    ----------
    values : dict
        The resonator's ``mass_kg``, ``frequency_hz`` and ``damping_ratio``.
    band_hz : tuple of float, optional
        The diagnosed band (default :data:`~exudyn_study.diagnose.rig_compare.BAND_HZ`).

    Returns
    -------
    tuple or None
        ``(kind, start values)``: ``('added_mass', {'mass_kg': ...})`` or
        ``('local_element', {'stiffness_n_per_m': ..., 'damping_n_s_per_m': ...})``; None when the
        resonator resonates in the band.
    """
    from exudyn_study.diagnose.rig_compare import BAND_HZ
    from exudyn_study.diagnose.rig_explain import TMD_NO_RESONANCE_DAMPING
    from exudyn_study.diagnose.rig_places import element_mu

    lo, hi = band_hz or BAND_HZ
    m, f_t, zeta = (float(values[k]) for k in ("mass_kg", "frequency_hz", "damping_ratio"))
    if f_t > hi:
        f_mid = math.sqrt(lo * hi)
        return "added_mass", {"mass_kg": m / (1.0 - (f_mid / f_t) ** 2)}
    if zeta >= TMD_NO_RESONANCE_DAMPING:
        omega = 2.0 * math.pi * np.geomspace(max(lo, f_t), hi, 32)
        mu = element_mu(omega, mass_kg=m, frequency_hz=f_t, damping_ratio=zeta)
        return "local_element", {
            "stiffness_n_per_m": max(float(np.mean(-mu.real)), 0.0),
            "damping_n_s_per_m": max(float(np.mean(-mu.imag / omega)), 0.0),
        }
    return None


def simpler_entries(problem, state, screening, fits, meta: dict, round_no: int):
    """Fit the simpler point entry a resonator fit stands in for; name it when it fits nearly as well.

    Tried for the round's tuned mass-damper fits (at most :data:`SIMPLER_TRIES`, best first) whose
    fitted values reduce to a simpler entry in the band (:func:`nested_point_entry`; a point mass only
    if wanted) and that are acceptable or rejected only as not identifiable (a resonator tuned above
    the band has a tuning and damping the data do not determine). The nested entry is fitted at the
    resonator's place from the resonator's equivalent values and its place refined
    (:func:`refine_places`). It replaces an acceptable resonator when the residual it leaves is at most
    :data:`SIMPLER_MARGIN` larger, or when it explains at most :data:`SIMPLER_SHARE` of the round's error
    less; it joins the acceptable fits in place of an unidentifiable one when it
    is acceptable itself. Each resonator fit is asked once: the round asks again after the place
    refinement, of the resonators refitted at a better place (their values there may not resonate in
    the band where the screened place's did).

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
        The diagnosis metadata; the nested fits are appended to ``meta['candidates']``
        (``simpler_than``: the resonator's label).
    round_no : int
        Index of the round (0 for the first).

    Returns
    -------
    RoundFits
        ``fits`` with the nested entries named (the nested fits appended to ``fitted``).
    """
    from dataclasses import replace

    from exudyn_study.diagnose.rig_candidates import point_of
    from exudyn_study.diagnose.rig_state import RoundFits

    st = problem.settings
    ok_ids = {id(f) for f in fits.ok}
    resonators = sorted(
        (
            f
            for f in fits.fitted
            if f["h"].physics == "tuned_mass_damper"
            and not f.get("nested_tried")
            and (
                id(f) in ok_ids
                or (f["rejected"] == "not identifiable" and f["improvement"] >= st.min_improvement)
            )
        ),
        key=lambda f: f["rss"],
    )
    if fits.together or not resonators:
        return fits
    ok, fitted = list(fits.ok), list(fits.fitted)
    closest = closest_candidates(screening)
    aic0 = aic(screening.rss0, 0, effective_samples(screening.ev_fit))
    tried = 0
    for f in resonators:
        h = f["h"]
        nested = nested_point_entry({n: float(v) for n, v in zip(h.names, f["p"], strict=True)})
        if nested is None or (nested[0] == "added_mass" and not problem.wants("added_mass")):
            f["nested_tried"] = True  # asked once: asked again only of a refit at a refined place
            continue
        if tried == SIMPLER_TRIES:
            break
        tried += 1
        f["nested_tried"] = True
        kind, values = nested
        h2 = _moved(h, screening.ctx, h.location, values, state.lin, kind=kind)
        h2.place = point_of(h2, state.markers)
        h2.closest = closest
        problem.say(f"{h.label} does not resonate in the band: fitting the {kind.replace('_', ' ')} it nests")
        f2 = fit_extra(problem, screening, h2, f["score"])
        f2["simpler_than"] = h.label
        meta["candidates"] += candidates_meta([f2], round_no, aic0)
        fitted.append(f2)
        if f2["rejected"] is not None:
            problem.say(f"  {h2.label}: {f2['rejected']}")
            continue
        refined = refine_places(problem, state, screening, RoundFits((f2,), (f2,)), meta, round_no)
        fitted += list(refined.fitted[1:])
        best = refined.ok[0]
        best["simpler_than"], best["place_refined"] = h.label, True
        if id(f) not in ok_ids:
            problem.say(f"  {best['h'].label} explains {100 * best['improvement']:.0f} %: acceptable")
            ok.append(best)
        elif (
            best["rss"] <= (1.0 + SIMPLER_MARGIN) * f["rss"]
            or best["improvement"] >= f["improvement"] - SIMPLER_SHARE
        ):
            problem.say(
                f"  {best['h'].label} leaves {best['rss'] / f['rss']:.2f} times the resonator's residual "
                f"(explains {100 * best['improvement']:.0f} % against {100 * f['improvement']:.0f} %): "
                "named instead"
            )
            ok[next(i for i, g in enumerate(ok) if g is f)] = best
        else:
            problem.say(
                f"  it leaves {best['rss'] / f['rss']:.2f} times the resonator's residual (explains "
                f"{100 * best['improvement']:.0f} % against {100 * f['improvement']:.0f} %): kept"
            )
    return replace(fits, fitted=tuple(fitted), ok=tuple(ok))


#: a later finding whose residual share an earlier point finding placed again comes within this share of
#: (residual sum of squares) is not named: the earlier finding is moved instead
PLACE_AGAIN_MARGIN = 0.1
#: a later finding is flagged when an earlier point finding placed again explains this share of what
#: it explains (or more)
STAND_IN_SHARE = 0.5


def place_again(problem, state, comparison, screening, fits, progress, meta: dict, round_no: int):
    """Place the point findings made so far again, before a later round names new physics for what they leave.

    A point finding (a mass, a resonator, a spring-damper to ground) is placed in its round against the
    residual of that round; a place a few centimetres off, or judged on a residual that a later finding
    has since explained, leaves a mismatch of its own that a small element elsewhere can take up. Each
    earlier point finding is taken out of the current model, its values refitted at its place (a value a
    few per cent off leaves a mismatch as a place does) and its place refined there (the walk of
    :func:`refine_places`, from its place and those values, each step fitting better). Then:

    - the round has an acceptable fit: when the moved finding leaves at most
      :data:`PLACE_AGAIN_MARGIN` more of the residual than the round's best fit, the finding is moved
      instead of naming the new one; when it explains at least :data:`STAND_IN_SHARE` of what the new
      fit explains, the new fit is flagged (it may stand in for the earlier finding's place);
    - the round has none: the moved finding is taken when it explains ``min_improvement`` of the
      residual.

    A move is proven on the held-out recordings as a finding is
    (:func:`~exudyn_study.diagnose.rig_prove.prove`).

    Parameters
    ----------
    problem : RigProblem
        The recordings, evaluators and settings.
    state : ModelState
        The current model.
    comparison : Comparison
        The current model against the recordings.
    screening : Screening
        The round's screening (the evaluator the round is judged on).
    fits : RoundFits
        The round's fits; the acceptable ones may get a ``flags`` entry.
    progress : Progress
        The findings so far.
    meta : dict
        The diagnosis metadata; the refits are appended to ``meta['candidates']`` (``placed_again``:
        the finding's number), a move to ``meta['placed_again']``.
    round_no : int
        Index of the round (0 for the first).

    Returns
    -------
    tuple or None
        ``(state, comparison, progress)`` with the finding moved, or None (nothing moved).
    """
    from exudyn_study.diagnose.rig_evaluate import set_offsets

    earlier = [
        r for r in progress.records if r["accepted"] is not None and r["h"].physics in POINT_KINDS
    ]
    if not earlier or (fits is not None and fits.together):
        return None
    best_new = max(fits.ok, key=lambda f: f["improvement"]) if fits is not None and fits.ok else None
    left_new = (1.0 - best_new["improvement"]) ** 2 if best_new is not None else None
    aic0 = aic(screening.rss0, 0, effective_samples(screening.ev_fit))
    moves = []
    for r in earlier:
        move = _walk_again(problem, state, screening, r, meta, round_no, aic0)
        if move is not None:
            moves.append(move)
    set_offsets(problem.evaluators, state.system)  # the evaluators back at the round's model
    if not moves:
        return None
    best = min(moves, key=lambda m: m["f"]["rss"])
    left_move = best["f"]["rss"] / screening.rss0
    explained = 1.0 - math.sqrt(min(left_move, 1.0))
    number, label = best["record"]["finding"] + 1, best["f"]["h"].label
    if best_new is None:
        take = explained >= problem.settings.min_improvement
        problem.say(
            f"finding {number} placed again ({label}) explains {100 * explained:.0f} % "
            + ("of what is left: moved" if take else "of what is left: not enough to move it")
        )
    else:
        take = left_move <= (1.0 + PLACE_AGAIN_MARGIN) * left_new
        problem.say(
            f"finding {number} placed again ({label}) explains {100 * explained:.0f} % "
            f"against {100 * best_new['improvement']:.0f} % for {best_new['h'].label}"
            + (": moved instead of a new finding" if take else "")
        )
        if not take and explained >= STAND_IN_SHARE * best_new["improvement"]:
            flag = (
                f"finding {number} ({best['record']['h'].label}) placed again at {best['f']['h'].location}, "
                f"{best['distance_m']:.2f} m from its place, explains {100 * explained:.0f} % of the "
                f"residual, this finding {100 * best_new['improvement']:.0f} %: it may stand in for that "
                "finding's place"
            )
            for f in fits.ok:
                f.setdefault("flags", []).append(flag)
    if not take:
        return None
    return _move(problem, state, comparison, progress, best, meta, round_no)


def _walk_again(problem, state, screening, record: dict, meta: dict, round_no: int, aic0: float):
    """Refine an earlier point finding's place in the current model without it; its best move or None."""
    from dataclasses import replace

    from exudyn_study.diagnose.rig_candidates import point_of
    from exudyn_study.diagnose.rig_evaluate import combined_gains, system_residual
    from exudyn_study.diagnose.rig_places import LocalSensitivity
    from exudyn_study.diagnose.rig_state import model_state

    h = record["h"]
    k = record["accepted"]
    accepted = list(state.accepted)
    without = model_state(problem, tuple(accepted[:k] + accepted[k + 1 :]), state.gains)
    ctx = replace(
        screening.ctx,
        model=without.model,
        lin=without.lin,
        markers=without.markers,
        build=without.builder(problem),
        locations=list(without.locations),
    )
    ev = screening.judged_on(h)[0]
    r0 = system_residual(ev, without.lin, without.gains)
    if r0 is None:
        return None
    scr = replace(screening, ctx=ctx, hyps=(), scores=(), order=(), rss0=float(r0 @ r0), walks={})
    p = h.fit_values(accepted[k][2])
    values = {n: float(v) for n, v in zip(h.names, p, strict=True)}
    h0 = _moved(h, ctx, h.location, values, without.lin)
    h0.base_gains = state.gains
    r_here = system_residual(ev, h0.system(p), combined_gains(h0, p, problem.channels))
    if r_here is None:
        return None
    here = {"h": h0, "p": p, "rss": float(r_here @ r_here)}
    sens = LocalSensitivity.of_evaluator(without.lin, problem.ev_spectral)
    problem.say(f"placing finding {record['finding'] + 1} ({h.label}) again on what the later findings leave")
    # its values refitted at its own place first: a value a few per cent off leaves a mismatch as a place does
    own = fit_extra(problem, scr, h0, 0.0)
    start = own if own["rejected"] is None and own["rss"] < here["rss"] else here
    current, refits = _walk(problem, without, scr, start, sens, problem.ev_spectral)
    refits = [own] + refits
    for f2 in refits:
        f2["placed_again"] = record["finding"] + 1
    meta["candidates"] += candidates_meta(refits, round_no, aic0)
    if current is here:
        return None
    start = np.asarray(point_of(h, state.markers).get("position_m", np.nan), dtype=float)
    end = np.asarray(point_of(current["h"], without.markers).get("position_m", np.nan), dtype=float)
    return {
        "record": record,
        "f": current,
        "without": without,
        "distance_m": float(np.linalg.norm(end - start)),
    }


def _move(problem, state, comparison, progress, move: dict, meta: dict, round_no: int):
    """Carry a moved point finding into the model, prove it on held-out data; the new state or None."""
    from dataclasses import replace

    from exudyn_study.diagnose.rig_candidates import point_of
    from exudyn_study.diagnose.rig_compare import compare
    from exudyn_study.diagnose.rig_evaluate import set_offsets
    from exudyn_study.diagnose.rig_explain import explain, make_finding
    from exudyn_study.diagnose.rig_prove import prove
    from exudyn_study.diagnose.rig_state import model_state

    r, f = move["record"], move["f"]
    accepted = list(state.accepted)
    accepted[r["accepted"]] = f["h"].carried(f["p"])
    after = model_state(problem, tuple(accepted), state.gains)
    comparison_after = compare(problem, after.system, after.gains)
    proof = prove(problem, state, comparison, after, comparison_after, [f])
    if not proof.accepted:
        set_offsets(problem.evaluators, state.system)
        return None
    k = r["finding"]
    old = progress.findings[k]
    at_bound = np.asarray(f.get("at_bound", np.zeros(len(f["h"].names), bool)), dtype=bool)
    text = explain(f["h"], f["p"], f["std"], move["without"].lin, after.lin, r["located"])
    if f["h"].location == r["h"].location:
        text += (
            f" (Refitted at its place in round {round_no + 1}: the later findings left a mismatch these "
            "values explain.)"
        )
    else:
        text += (
            f" (Placed again in round {round_no + 1}, {move['distance_m']:.2f} m from where its own round "
            "put it: the later findings left a mismatch this place explains.)"
        )
    findings, records = list(progress.findings), list(progress.records)
    findings[k] = make_finding(
        f["h"],
        f["p"],
        f["std"],
        at_bound,
        tuple(r.get("flags", ())),
        old.band_hz,
        old.level_dependent,
        text,
        old.fit,
        point_of(f["h"], after.markers),
    )
    records[k] = {
        **r,
        "h": f["h"],
        "lin_before": move["without"].lin,
        "lin_after": after.lin,
        "at_bound": at_bound,
    }
    problem.say(
        f"finding {k + 1} moved to {f['h'].location}, held-out error "
        f"{proof.fit['holdout_before']:.4f} -> {proof.fit['holdout_after']:.4f}"
    )
    meta.setdefault("placed_again", []).append(
        {
            "round": round_no + 1,
            "finding": k + 1,
            "from": r["h"].location,
            "to": f["h"].location,
            "distance_m": round(move["distance_m"], 3),
            "holdout_before": proof.fit["holdout_before"],
            "holdout_after": proof.fit["holdout_after"],
        }
    )
    return after, comparison_after, replace(progress, findings=tuple(findings), records=tuple(records))
