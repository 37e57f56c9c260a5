"""Refine the place of a point finding: the mesh nodes around it screened with the fitted element.

Part of the fit stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`. The structure screen
(:mod:`~exudyn_study.diagnose.rig_places`) tries one mesh node per ``place_spacing_m`` cube, so a mass,
a resonator or a dashpot between two of them is fitted at the nearest screened place, and the fit
makes up for the wrong motion there with a wrong value (a dashpot at a place moving 20 % more needs
about 30 % less damping). :func:`refine_places` scores the fitted element at every mesh node within
:data:`REFINE_RADIUS_M` (one per :data:`REFINE_SPACING_M` cube) by the same low-rank update, and refits
at the best node when it explains clearly more; the refit is kept if it fits the round's evaluator
better.
"""

from __future__ import annotations

import numpy as np

from exudyn_study.diagnose.rig_candidates import POINT_KINDS
from exudyn_study.diagnose.rig_evaluate import aic, effective_samples
from exudyn_study.diagnose.rig_fit import candidates_meta, fit_one, judge

__all__ = ["refine_places", "nodes_near", "REFINE_RADIUS_M", "REFINE_SPACING_M", "REFINE_MIN_GAIN"]

#: mesh nodes within this distance (m) of a point fit's place are tried (the screen's cube diagonal)
REFINE_RADIUS_M = 0.26
#: one node per cube of this edge (m) among them
REFINE_SPACING_M = 0.04
#: a node is refitted if the fitted element there leaves this share less of the residual
REFINE_MIN_GAIN = 0.02


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

    point = [f for f in fits.ok if f["h"].physics in POINT_KINDS]
    if fits.together or not point:
        return fits
    from exudyn_study.diagnose.rig_candidates import place_where, point_of
    from exudyn_study.diagnose.rig_places import LocalSensitivity, PlaceScorer

    ev = problem.ev_spectral
    sens = LocalSensitivity.of_evaluator(state.lin, ev)
    ok, fitted = list(fits.ok), list(fits.fitted)
    for f in point:
        h = f["h"]
        here = point_of(h, screening.ctx.markers).get("position_m")
        if here is None:
            continue
        values = {n: float(v) for n, v in zip(h.names, f["p"], strict=True)}
        scorer = PlaceScorer.of_evaluator(sens, ev, state.gains, {h.physics: [values]})
        _, p_here = place_where(screening.ctx, h.location)
        nodes = nodes_near(state.model, here)
        maps = [p_here] + [place_where(screening.ctx, name)[1] for name, _ in nodes]
        shares = [
            (best[0][2] if best else -np.inf)
            for best in scorer.score([sens.reduced(m) for m in maps])
        ]
        k = int(np.argmax(shares[1:])) + 1 if nodes else 0
        left_here, left_best = 1.0 - shares[0], 1.0 - shares[k]
        if k == 0 or not left_best < (1.0 - REFINE_MIN_GAIN) * left_here:
            continue
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
        scr = replace(screening, hyps=screening.hyps + (h2,), scores=screening.scores + (shares[k],))
        f2 = fit_one(problem, scr, len(scr.hyps) - 1)
        f2["rejected"] = judge(f2, problem.settings)
        f2["refined_from"] = h.location
        fitted.append(f2)
        if f2["rejected"] is None and f2["rss"] < f["rss"]:
            ok[next(i for i, g in enumerate(ok) if g is f)] = f2
        else:
            problem.say(f"  the refit at {name} does not fit better: {h.label} kept")
    refits = fitted[len(fits.fitted) :]
    if refits:
        aic0 = aic(screening.rss0, 0, effective_samples(screening.ev_fit))
        meta["candidates"] += candidates_meta(refits, round_no, aic0)
    return replace(fits, fitted=tuple(fitted), ok=tuple(ok))


def _moved(h, ctx, place: str, values: dict, lin):
    """Return a hypothesis like ``h`` at mesh node ``place``, started at ``values``."""
    from exudyn_study.diagnose.rig_candidates import place_where, point_hypothesis

    where, p_map = place_where(ctx, place)
    moved = point_hypothesis(h.physics, place, lin, p_map, values, **where)
    moved.start = np.clip(moved.start, moved.lower, moved.upper)
    if hasattr(h, "closest"):
        moved.closest = h.closest
    return moved
