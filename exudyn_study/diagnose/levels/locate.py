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

With a force drive and a drive-point accelerometer the shapes are mass-normalised and a second,
sharper piece of evidence is available (:func:`locate_by_sensitivity`): a change ``dk`` of the
stiffness between sensors ``a`` and ``b`` moves every mode's complex eigenvalue by
``d(Omega_r^2) = dk (phi_b,r - phi_a,r)^2`` (first-order sensitivity, Fox & Kapoor 1968), so
across *all* modes, those that change and those that do not, the pattern of the measured
changes must follow ``g_r = |phi_b,r - phi_a,r|^2`` of the right pair. It uses the frequencies
and damping ratios (known to 1e-4 and a few percent) instead of the shape changes (known to a few
percent).

References
----------
Fox, R. L., Kapoor, M. P. (1968). Rates of change of eigenvalues and eigenvectors. AIAA J. 6, 2426-2429.
"""

from __future__ import annotations

import itertools

import numpy as np

from exudyn_study.diagnose.levels.amplitude import ModalTable
from exudyn_study.diagnose.levels.screen import NONLINEAR, ModeTrend
from exudyn_study.diagnose.levels.settings import LevelSettings

__all__ = ["locate_pair", "locate_by_sensitivity"]


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


def locate_by_sensitivity(
    table: ModalTable,
    couplings: dict[tuple[str, str], np.ndarray],
    settings: LevelSettings,
) -> tuple[tuple[str, str] | None, list[dict]]:
    """Rank sensor pairs by how well ``g_r`` of each explains every mode's eigenvalue change over the levels.

    For every level ``L`` above the lowest, the change of each mode's complex eigenvalue
    ``Omega_r^2 = w_r^2 (1 + 2 j zeta_r)`` from the lowest level is fitted by weighted least
    squares as ``g_r D_L(f_r)``, where ``g_r`` is the pair's coupling (:func:`~.fit.scaled_coupling`)
    and ``D_L(f) = d0_L + d1_L log(f / f_mid)`` the joint's equivalent complex stiffness change
    at that level, allowed to vary smoothly with frequency (a friction joint under a broadband
    motion softens less at high frequency). The weights are the inverse variances of the changes
    (from the modal table's standard deviations). The pair with the lowest chi-square is located
    when the next pair's chi-square exceeds it by more than ``trend_sigma**2`` after both are
    divided by the best pair's reduced chi-square (when above 1: a model misfit beyond the
    noise makes the comparison no sharper than the misfit allows); its ``z`` is the square root
    of that difference.

    Parameters
    ----------
    table : ModalTable
        Frequencies and damping ratios with standard deviations at every level (rows in any order;
        the lowest level is the reference).
    couplings : dict
        ``(a, b) -> g`` with ``g`` of shape (n_modes,) in 1/kg (NaN for a mode without a mass:
        left out for every pair).
    settings : LevelSettings
        ``trend_sigma`` is the threshold.

    Returns
    -------
    pair : (str, str) or None
        The located pair, or None when no pair explains the changes clearly better than the next.
    evidence : list of dict
        Per pair (best first): ``pair``, ``chi2``, ``reduced_chi2``, ``z`` (the located pair's margin
        over the next; for the others their deficit to the best, negative), and ``stiffness_change``
        (the fitted ``D_L`` at ``f_mid`` per level, ``[re, im]`` in N/m).
    """
    if len(couplings) < 2:
        return None, []
    order = np.argsort(table.levels)
    lo = order[0]
    w = 2 * np.pi * table.frequency_hz
    om2 = w**2 * (1 + 2j * table.damping_ratio)
    sw = 2 * np.pi * table.frequency_std_hz
    s_re = 2 * w * sw
    s_im = np.hypot(4 * table.damping_ratio * w * sw, 2 * w**2 * table.damping_std)
    ok = np.all(np.isfinite(np.array(list(couplings.values()))), axis=0)
    if ok.sum() < 4:
        return None, []
    f_mid = float(np.exp(np.mean(np.log(table.frequency_hz[lo, ok]))))
    x = np.log(table.frequency_hz[lo, ok] / f_mid)
    rows = []
    for pair, g in couplings.items():
        g = np.asarray(g, float)[ok]
        chi2, dof, change = 0.0, 0, []
        for L in order[1:]:
            dy = om2[L, ok] - om2[lo, ok]
            sr = np.maximum(np.hypot(s_re[L, ok], s_re[lo, ok]), 1e-300)
            si = np.maximum(np.hypot(s_im[L, ok], s_im[lo, ok]), 1e-300)
            for part, y, sd in (("re", dy.real, sr), ("im", dy.imag, si)):
                a = np.stack([g, g * x], axis=1) / sd[:, None]
                coef, *_ = np.linalg.lstsq(a, y / sd, rcond=None)
                r = y / sd - a @ coef
                chi2 += float(r @ r)
                dof += y.size - 2
                if part == "re":
                    re0 = float(coef[0])
                else:
                    change.append([re0, float(coef[0])])
        rows.append(
            {"pair": list(pair), "chi2": chi2, "reduced_chi2": chi2 / max(dof, 1), "stiffness_change": change}
        )
    rows.sort(key=lambda e: e["chi2"])
    scale = max(rows[0]["reduced_chi2"], 1.0)
    for e in rows:
        e["z"] = -float(np.sqrt(max(e["chi2"] - rows[0]["chi2"], 0.0) / scale))
    margin = float(np.sqrt(max(rows[1]["chi2"] - rows[0]["chi2"], 0.0) / scale))
    rows[0]["z"] = margin
    located = margin > settings.trend_sigma
    return (tuple(rows[0]["pair"]) if located else None), rows
