"""Refine a point finding: its place (the mesh nodes around it) and its entry (the simpler one it nests).

Part of the fit stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`. The structure screen
(:mod:`~exudyn_study.diagnose.rig_places`) tries one mesh node per ``place_spacing_m`` cube, so a mass,
a resonator or a dashpot between two of them is fitted at the nearest screened place, and the fit
makes up for the wrong motion there with a wrong value (a dashpot at a place moving 20 % more needs
about 30 % less damping). :func:`refine_places` scores the fitted element at every mesh node within
:data:`REFINE_RADIUS_M` (one per :data:`REFINE_SPACING_M` cube) by the same low-rank update, and refits
at the best node when it explains clearly more; the refit is kept if it fits the round's evaluator
better.

A tuned mass-damper can stand in for simpler physics it contains as a limit: tuned above the
diagnosed band its mass follows its point there (a point mass, apparent value
``m / (1 - (f / f_t)^2)``), and damped so much that it makes no resonance of its own it dissipates
like a dashpot to ground above its tuning. Its three parameters then buy nothing the data show, and
naming a resonator would claim physics the data do not hold. :func:`simpler_entries` fits the nested
entry (a point mass; the generic spring-damper to ground) at the resonator's place, refines that place
as above, and names it instead when it leaves at most :data:`SIMPLER_MARGIN` more of the residual.
"""

from __future__ import annotations

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
    "REFINE_MIN_GAIN",
    "REFINE_STEPS",
    "SIMPLER_MARGIN",
]

#: mesh nodes within this distance (m) of a point fit's place are tried (the screen's cube diagonal)
REFINE_RADIUS_M = 0.26
#: one node per cube of this edge (m) among them
REFINE_SPACING_M = 0.04
#: a node is refitted if the fitted element there leaves this share less of the residual
REFINE_MIN_GAIN = 0.02
#: refinement steps per point fit at most (each from the last refit's node)
REFINE_STEPS = 3
#: the nested simpler entry is named if the residual it leaves (sum of squares) is at most this share
#: larger than the resonator's
SIMPLER_MARGIN = 0.1
#: resonator fits of a round tried for the simpler entry they nest (best first)
SIMPLER_TRIES = 2


def nodes_near(
    model,
    position_m,
    radius_m: float = REFINE_RADIUS_M,
    spacing_m: float = REFINE_SPACING_M,
    skip=("rear_foundation",),
) -> list:
    """Return ``(place name 'body#node', position)`` of mesh nodes within ``radius_m`` of a point.

    One node per ``spacing_m`` cube (the nearest the centroid of the cube's nodes), on every flexible
    body but those in ``skip``.

    Parameters
    ----------
    model : Model
        The assembled model.
    position_m : array_like
        The point (m), shape (3,).
    radius_m : float, optional
        Search radius (m).
    spacing_m : float, optional
        Cube edge (m).
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
        current = f
        for _ in range(REFINE_STEPS):  # from node to node while a neighbour explains clearly more
            f2 = _refine_step(problem, state, screening, current, sens, ev)
            if f2 is None:
                break
            fitted.append(f2)
            if f2["rejected"] is not None or not f2["rss"] < current["rss"]:
                problem.say(
                    f"  the refit at {f2['h'].location} does not fit better: {current['h'].label} kept"
                )
                break
            current = f2
        if current is not f:
            ok[next(i for i, g in enumerate(ok) if g is f)] = current
    refits = fitted[len(fits.fitted) :]
    if refits:
        aic0 = aic(screening.rss0, 0, effective_samples(screening.ev_fit))
        meta["candidates"] += candidates_meta(refits, round_no, aic0)
    return replace(fits, fitted=tuple(fitted), ok=tuple(ok))


def _refine_step(problem, state, screening, f: dict, sens, ev):
    """Refit point fit ``f`` at the mesh node nearby where its fitted element explains clearly more.

    Returns the refit's record (``rejected`` and ``refined_from`` set), or None when no node within
    :data:`REFINE_RADIUS_M` leaves :data:`REFINE_MIN_GAIN` less of the residual than ``f``'s place.
    """
    from exudyn_study.diagnose.rig_candidates import place_where, point_of
    from exudyn_study.diagnose.rig_places import PlaceScorer

    h = f["h"]
    here = point_of(h, screening.ctx.markers).get("position_m")
    if here is None:
        return None
    values = {n: float(v) for n, v in zip(h.names, f["p"], strict=True)}
    scorer = PlaceScorer.of_evaluator(sens, ev, state.gains, {h.physics: _value_grid(values)})
    _, p_here = place_where(screening.ctx, h.location)
    nodes = [(name, pos) for name, pos in nodes_near(state.model, here) if name != h.location]
    maps = [p_here] + [place_where(screening.ctx, name)[1] for name, _ in nodes]
    shares = [(best[0][2] if best else -np.inf) for best in scorer.score([sens.reduced(m) for m in maps])]
    k = int(np.argmax(shares[1:])) + 1 if nodes else 0
    left_here, left_best = 1.0 - shares[0], 1.0 - shares[k]
    if k == 0 or not left_best < (1.0 - REFINE_MIN_GAIN) * left_here:
        return None
    name, pos = nodes[k - 1]
    h2 = _moved(h, screening.ctx, name, values, state.lin)
    h2.position_m = [float(v) for v in pos]
    if hasattr(h, "place"):
        h2.place = point_of(h2, screening.ctx.markers)
    problem.say(
        f"refining {h.label}: the fitted element leaves {100 * left_best:.1f} % of the residual at "
        f"{name}, {np.linalg.norm(np.asarray(pos) - np.asarray(here)):.2f} m away, against "
        f"{100 * left_here:.1f} % at {h.location}: refitting there"
    )
    f2 = fit_extra(problem, screening, h2, shares[k])
    f2["refined_from"] = h.location
    return f2


#: factors on a point fit's amounts (mass, stiffness, damping) at which its element is scored at the
#: nodes nearby: the value fitted at one node makes up for the motion there, another node needs another
REFINE_VALUE_FACTORS = (0.5, 0.7, 1.0, 1.4, 2.0)
#: parameters scaled by :data:`REFINE_VALUE_FACTORS` (a resonator keeps its tuning and damping ratio)
_AMOUNTS = ("mass_kg", "stiffness_n_per_m", "damping_n_s_per_m")


def _value_grid(values: dict) -> list:
    """Return the point element's parameter sets scored at the nodes nearby (its amounts scaled)."""
    return [{n: v * a if n in _AMOUNTS else v for n, v in values.items()} for a in REFINE_VALUE_FACTORS]


def _moved(h, ctx, place: str, values: dict, lin, kind: str | None = None):
    """Return a hypothesis like ``h`` (or of point ``kind``) at ``place``, started at ``values``."""
    from exudyn_study.diagnose.rig_candidates import place_where, point_hypothesis

    where, p_map = place_where(ctx, place)
    moved = point_hypothesis(kind or h.physics, place, lin, p_map, values, **where)
    moved.start = np.clip(moved.start, moved.lower, moved.upper)
    if hasattr(h, "closest"):
        moved.closest = h.closest
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
    import math

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
    :data:`SIMPLER_MARGIN` larger; it joins the acceptable fits in place of an unidentifiable one when it
    is acceptable itself.

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
            continue
        if tried == SIMPLER_TRIES:
            break
        tried += 1
        kind, values = nested
        h2 = _moved(h, screening.ctx, h.location, values, state.lin, kind=kind)
        h2.base_gains = h.base_gains
        if getattr(h, "position_m", None) is not None:
            h2.position_m = list(h.position_m)
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
        elif best["rss"] <= (1.0 + SIMPLER_MARGIN) * f["rss"]:
            problem.say(
                f"  {best['h'].label} leaves {best['rss'] / f['rss']:.2f} times the resonator's residual: "
                "named instead"
            )
            ok[next(i for i, g in enumerate(ok) if g is f)] = best
        else:
            problem.say(f"  it leaves {best['rss'] / f['rss']:.2f} times the resonator's residual: kept")
    return replace(fits, fitted=tuple(fitted), ok=tuple(ok))
