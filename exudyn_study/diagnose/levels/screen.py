"""Screen stage: the level dependence of every mode, read from its trend across the levels.

For each mode the relative changes of frequency and damping from the lowest level are
compared with their combined standard deviations (the lowest level's and the level's own):
a change counts when it exceeds ``trend_sigma`` standard deviations and the minimum change of
:class:`LevelSettings`, and the trend is the sign of the change at the highest level, which
must agree with the weighted slope over all levels (no single level decides). The outcomes:

``joint_friction``
    frequency down and damping up with amplitude: micro-slip in a joint (Jenkins/Iwan);
``joint_softening``
    frequency down, damping unchanged;
``joint_stiffening``
    frequency up (a hardening contact);
``joint_clearance``
    frequency up by more than ``clearance_rise``, flat over the lowest levels: a gap closing;
``joint_damping``
    damping up, frequency unchanged;
``linear_mismodelled``
    no trend, but the levels scatter beyond their uncertainty (the modal model does not
    hold from level to level although nothing grows with level);
``linear``
    no trend and no excess scatter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exudyn_study.diagnose.levels.amplitude import ModalTable
from exudyn_study.diagnose.levels.settings import LevelSettings

__all__ = ["ModeTrend", "screen_trends", "dominant_outcome", "NONLINEAR"]

#: outcomes that are a level dependence (the fit stage models them)
NONLINEAR = ("joint_friction", "joint_softening", "joint_stiffening", "joint_clearance", "joint_damping")


@dataclass(frozen=True)
class ModeTrend:
    """Level dependence of one mode.

    Attributes
    ----------
    mode : int
        1-based.
    frequency_hz : float
        At the lowest level.
    outcome : str
        One of the module docstring's outcomes.
    frequency_change, damping_change : float
        Relative change from the lowest to the highest level (-).
    frequency_z, damping_z : float
        Those changes in standard deviations.
    scatter_chi2 : float
        Reduced chi-square of the frequencies about their weighted mean (no-trend check).
    """

    mode: int
    frequency_hz: float
    outcome: str
    frequency_change: float
    damping_change: float
    frequency_z: float
    damping_z: float
    scatter_chi2: float


def _slope_sign(x, y, s) -> float:
    w = 1.0 / np.maximum(s, 1e-300) ** 2
    xm = np.sum(w * x) / np.sum(w)
    ym = np.sum(w * y) / np.sum(w)
    return float(np.sign(np.sum(w * (x - xm) * (y - ym))))


def screen_trends(table: ModalTable, settings: LevelSettings) -> list[ModeTrend]:
    """Classify every mode's level dependence (see the module docstring).

    Parameters
    ----------
    table : ModalTable
        Frequency, damping, their standard deviations and the amplitude of every mode at every
        level; with 3 or more levels a trend must also agree with the weighted slope over all of
        them.
    settings : LevelSettings
        The thresholds: ``trend_sigma``, ``min_frequency_change``, ``min_damping_change`` and
        ``clearance_rise``.

    Returns
    -------
    list of ModeTrend
        One per mode of the table, in its order.
    """
    order = np.argsort(table.levels)
    lo, hi = order[0], order[-1]
    x = np.log(np.maximum(table.amplitude, 1e-300))
    out = []
    for r in range(table.frequency_hz.shape[1]):
        f, fs = table.frequency_hz[:, r], table.frequency_std_hz[:, r]
        z, zs = table.damping_ratio[:, r], table.damping_std[:, r]
        df = f[hi] / f[lo] - 1.0
        dz = z[hi] / z[lo] - 1.0
        sdf = np.hypot(fs[hi], fs[lo]) / f[lo]
        sdz = np.hypot(zs[hi], zs[lo]) / z[lo]
        fz, zz = df / max(sdf, 1e-300), dz / max(sdz, 1e-300)
        f_sig = abs(fz) > settings.trend_sigma and abs(df) > settings.min_frequency_change
        z_sig = abs(zz) > settings.trend_sigma and abs(dz) > settings.min_damping_change
        if len(order) >= 3:
            f_sig = f_sig and _slope_sign(x[:, r], f, fs) == np.sign(df)
            z_sig = z_sig and _slope_sign(x[:, r], z, zs) == np.sign(dz)
        w = 1.0 / np.maximum(fs, 1e-300) ** 2
        fm = np.sum(w * f) / np.sum(w)
        chi = float(np.sum(w * (f - fm) ** 2) / max(len(f) - 1, 1))
        if f_sig and df < 0:
            outcome = "joint_friction" if (z_sig and dz > 0) else "joint_softening"
        elif f_sig and df > 0:
            flat = (
                abs(f[order[1]] / f[lo] - 1.0) < settings.min_frequency_change if len(order) >= 3 else False
            )
            outcome = "joint_clearance" if (df > settings.clearance_rise and flat) else "joint_stiffening"
        elif z_sig and dz > 0:
            outcome = "joint_damping"
        else:
            outcome = (
                "linear_mismodelled"
                if chi > 1.0 + 3.0 * np.sqrt(2.0 / max(len(f) - 1, 1)) + 3.0
                else "linear"
            )
        out.append(ModeTrend(r + 1, float(f[lo]), outcome, float(df), float(dz), float(fz), float(zz), chi))
    return out


def dominant_outcome(trends: list[ModeTrend]) -> str:
    """Return the level-dependent outcome with the largest summed significance over the modes.

    The significance of a mode is ``|frequency_z| + |damping_z|``; the outcome whose modes sum to
    the most is the one the joint law is fitted for.

    Parameters
    ----------
    trends : list of ModeTrend
        The screened modes (:func:`screen_trends`); at least one must have an outcome in
        :data:`NONLINEAR`.

    Returns
    -------
    str
        One of :data:`NONLINEAR`.

    Raises
    ------
    ValueError
        If no mode has a level-dependent outcome.
    """
    score: dict[str, float] = {}
    for t in trends:
        if t.outcome in NONLINEAR:
            score[t.outcome] = score.get(t.outcome, 0.0) + abs(t.frequency_z) + abs(t.damping_z)
    return max(score, key=score.get)
