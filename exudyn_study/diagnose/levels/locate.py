"""Locate stage: the sensor pair whose relative motion carries the level-dependent change.

A joint that slips (or closes) with amplitude changes the stiffness *across* it, so in the
modes that change with level the relative motion of the two sensors that straddle the joint
grows (slip) or shrinks (contact) relative to the rest of the shape. For every mode with a
level dependence the shape at each level (its residues) is scaled onto the lowest level's
shape (complex least squares), and for every sensor pair the relative motion
``d_ij = |psi_i - psi_j|`` is compared between the lowest and the highest level: the score is
its relative change ``(d_ij,high - d_ij,low) / d_ij,low``, and its z value that change over
its standard deviation (from the residues' uncertainties). The pair with the largest score
whose change is significant (z above ``trend_sigma``) is the located interface; the evidence
per pair, mode and level goes into the JSON.
"""

from __future__ import annotations

import itertools

import numpy as np

from exudyn_study.diagnose.levels.amplitude import ModalTable
from exudyn_study.diagnose.levels.screen import NONLINEAR, ModeTrend
from exudyn_study.diagnose.levels.settings import LevelSettings

__all__ = ["locate_pair"]


def locate_pair(table: ModalTable, trends: list[ModeTrend], channels, settings: LevelSettings,
                interfaces=None) -> tuple[tuple[str, str] | None, list[dict]]:
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
    weight = {r: abs(trends[r].frequency_z) + abs(trends[r].damping_z) for r in modes}
    evidence = []
    for a, b in pairs:
        i, j = names.index(a), names.index(b)
        num = den = 0.0
        zs = []
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
            change = (d[hi] - d[lo]) / max(d[lo], 1e-300)
            sd = np.hypot(s[hi], s[lo]) / max(d[lo], 1e-300)
            z = change / max(sd, 1e-300)
            num += weight[r] * change
            den += weight[r]
            zs.append(z)
            per_mode.append({"mode": r + 1, "relative_motion": d.tolist(), "std": s.tolist(),
                             "relative_change": float(change), "z": float(z)})
        evidence.append({"pair": [a, b], "score": float(num / den), "z": float(np.max(np.abs(zs))),
                         "modes": per_mode})
    evidence.sort(key=lambda e: -abs(e["score"]))
    best = evidence[0]
    located = abs(best["score"]) > 0 and best["z"] > settings.trend_sigma
    return (tuple(best["pair"]) if located else None), evidence
