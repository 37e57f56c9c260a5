"""Locate stage: the sensor pair whose relative motion carries the level-dependent change.

A joint that slips (or closes) with amplitude changes the stiffness *across* it, so in the
modes that change with level the relative motion of the two sensors that straddle the joint
grows (slip, softening) or shrinks (contact, hardening) relative to the rest of the shape. For
every mode with a level dependence the shape at each level (its residues) is scaled onto the
lowest level's shape (complex least squares), and for every sensor pair the relative motion
``d_ij = |psi_i - psi_j|`` is followed over the levels: its relative change from the lowest to
the highest level, estimated from every level by regressing the level's change on the mode's
own trend (0 at the lowest, 1 at the highest level: the relative motion changes with the amount
of slip or contact, which the mode's frequency shift measures), inverse-variance weighted, signed so that
growth counts for a softening mode
and shrinking for a hardening one, averaged over the modes with inverse-variance weights (the
variances from the residues' uncertainties), is the pair's score; its z value is the score over
its standard deviation. The pair with the highest score is the located interface
if its z exceeds ``trend_sigma``; the evidence per pair, mode and level goes into the JSON.
"""

from __future__ import annotations

import itertools

import numpy as np

from exudyn_study.diagnose.levels.amplitude import ModalTable
from exudyn_study.diagnose.levels.screen import NONLINEAR, ModeTrend
from exudyn_study.diagnose.levels.settings import LevelSettings

__all__ = ["locate_pair"]


def locate_pair(
    table: ModalTable, trends: list[ModeTrend], channels, settings: LevelSettings, interfaces=None
) -> tuple[tuple[str, str] | None, list[dict]]:
    """Rank sensor pairs by the level-dependent relative motion they carry.

    Parameters
    ----------
    table : ModalTable
    trends : list of ModeTrend
    channels : sequence of str
        Response channels, in the order of ``table.residues``' second axis.
    settings : LevelSettings
    interfaces : sequence of (str, str), optional
        Candidate pairs (default: every pair of response channels).

    Returns
    -------
    pair : (str, str) or None
        The located pair, or None when no pair's relative motion changes significantly.
    evidence : list of dict
        Per pair (best first): ``pair``, ``score``, ``z``, and per mode the relative motion per level.
    """
    modes = [t.mode - 1 for t in trends if t.outcome in NONLINEAR]
    if not modes:
        return None, []
    names = list(channels)
    pairs = [tuple(p) for p in interfaces] if interfaces else list(itertools.combinations(names, 2))
    order = np.argsort(table.levels)
    lo, hi = order[0], order[-1]
    sign = {r: -1.0 if trends[r].outcome in ("joint_stiffening", "joint_clearance") else 1.0 for r in modes}
    evidence = []
    for a, b in pairs:
        i, j = names.index(a), names.index(b)
        num = den = 0.0
        per_mode = []
        for r in modes:
            ref = table.residues[lo, :, r]
            d, s = [], []
            for L in range(table.residues.shape[0]):
                psi = table.residues[L, :, r]
                alpha = np.vdot(psi, ref) / np.vdot(psi, psi)  # scale the level's shape onto the lowest one
                v = alpha * psi
                d.append(abs(v[i] - v[j]))
                s.append(abs(alpha) * np.hypot(table.residue_std[L, i, r], table.residue_std[L, j, r]))
            d, s = np.array(d), np.array(s)
            # every level's change from the lowest, regressed on the mode's own trend e (0 at the lowest, 1
            # at the
            # highest level; its frequency, or its damping when only that moves): the relative motion changes
            # with the amount of slip (or contact), which the modal trend measures
            tr = (
                table.frequency_hz[:, r]
                if trends[r].outcome != "joint_damping"
                else table.damping_ratio[:, r]
            )
            e = (tr - tr[lo]) / (tr[hi] - tr[lo]) if tr[hi] != tr[lo] else np.zeros_like(tr)
            if d[lo] <= 1e-9 * np.max(
                np.abs(ref)
            ):  # two sensors moving together: no relative motion to follow
                per_mode.append(
                    {
                        "mode": r + 1,
                        "relative_motion": d.tolist(),
                        "std": s.tolist(),
                        "relative_change": 0.0,
                        "z": 0.0,
                    }
                )
                continue
            c = (d - d[lo]) / max(d[lo], 1e-300)
            sc = np.hypot(s, s[lo]) / max(d[lo], 1e-300)
            others = np.arange(d.size) != lo
            wl = e[others] ** 2 / np.maximum(sc[others], 1e-12) ** 2
            change = float(
                np.sum(wl * c[others] / np.where(e[others] == 0, 1.0, e[others])) / max(np.sum(wl), 1e-300)
            )
            sd = float(1.0 / np.sqrt(max(np.sum(wl), 1e-300)))
            z = change / max(sd, 1e-300)
            w_r = 1.0 / max(sd, 1e-12) ** 2
            num += w_r * sign[r] * change
            den += w_r
            per_mode.append(
                {
                    "mode": r + 1,
                    "relative_motion": d.tolist(),
                    "std": s.tolist(),
                    "relative_change": float(change),
                    "z": float(z),
                }
            )
        score = num / den if den > 0 else 0.0
        evidence.append(
            {"pair": [a, b], "score": float(score), "z": float(score * np.sqrt(den)), "modes": per_mode}
        )
    evidence.sort(key=lambda e: -e["score"])
    if not evidence:  # one channel: no pair
        return None, []
    best = evidence[0]
    located = best["score"] > 0 and best["z"] > settings.trend_sigma
    return (tuple(best["pair"]) if located else None), evidence
