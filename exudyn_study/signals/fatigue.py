"""Pseudo damage: rainflow counting, Basquin's S-N law and Palmgren-Miner summation.

Thesis Section 2.7: a signal is split by rainflow counting into blocks i of p_i cycles
of amplitude s_i; with Basquin's law ``N = C s^-beta`` and the Palmgren-Miner rule the
pseudo damage is

    D = sum_i p_i / N_i = C^-1 sum_i p_i s_i^beta.

Relative pseudo damage is ``D_simulated / D_measured`` per channel (thesis Section 7:
beta = 5 for all z-direction sensors; the 1000 Hz measured responses resampled to the
204.8 Hz of the simulation). ``C`` defaults to 1 so damages are relative numbers in
(unit of the signal)^beta, e.g. (m/s^2)^5 for accelerations; only ratios are
meaningful. No fatigue limit is applied (part A of the S-N curve only, as the thesis).

Cycle counting uses the maintained ``rainflow`` package (ASTM E1049-85 Section 5.4.4,
with half cycles for the residue); it is not re-implemented here. Signals are reduced
to their turning points with NumPy first, which gives the same cycles as ``rainflow``'s
own reversal detection but much faster on 1000 Hz data.

References
----------
.. [1] ASTM E1049-85 (reapproved 2017), *Standard Practices for Cycle Counting in
   Fatigue Analysis*, Section 5.4.4 (rainflow counting).
.. [2] Basquin, O. H., "The exponential law of endurance tests", Proc. ASTM 10 (1910)
   625-630.
.. [3] Miner, M. A., "Cumulative damage in fatigue", J. Appl. Mech. 12 (1945) A159-A164.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import rainflow

from exudyn_study.errors import InputError
from exudyn_study.recording.types import Recording
from exudyn_study.signals.drives import resample

__all__ = [
    "DEFAULT_BETA",
    "ChannelDamage",
    "RelativeDamage",
    "plausibility_notes",
    "rainflow_cycles",
    "cycles_to_failure",
    "pseudo_damage",
    "relative_pseudo_damage",
]

#: Basquin exponent used in the thesis (Section 7, "based on previous experience")
DEFAULT_BETA = 5.0


def _check_beta_c(beta: float, C: float) -> tuple[float, float]:
    try:
        beta_f, c_f = float(beta), float(C)
    except (TypeError, ValueError) as exc:
        raise InputError(f"beta {beta!r} / C {C!r}: expected numbers") from exc
    if not (math.isfinite(beta_f) and beta_f > 0):
        raise InputError(f"beta {beta!r}; expected a Basquin exponent > 0 (the thesis uses 5)")
    if not (math.isfinite(c_f) and c_f > 0):
        raise InputError(f"C {C!r}; expected a Basquin constant > 0 (default 1)")
    return beta_f, c_f


def _turning_points(x: np.ndarray) -> np.ndarray:
    """First, last and every reversal of ``x`` (plateaus collapsed), as ``rainflow.reversals``."""
    if x.size < 3:
        return x
    keep = np.r_[True, np.diff(x) != 0]
    y = x[keep]  # consecutive equal samples collapsed
    if y.size < 3:
        return y
    d = np.diff(y)
    rev = np.flatnonzero(d[:-1] * d[1:] < 0) + 1
    return y[np.r_[0, rev, y.size - 1]]


def rainflow_cycles(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rainflow-count one signal (ASTM E1049-85, Section 5.4.4).

    Parameters
    ----------
    x : ndarray, shape (n_samples,)
        Signal (any unit U), finite.

    Returns
    -------
    ranges : ndarray, shape (n_cycles,)
        Cycle ranges (peak to valley) in U; the amplitude is ``range / 2``.
    counts : ndarray, shape (n_cycles,)
        1.0 for a full cycle, 0.5 for a half cycle (the residue).
    means : ndarray, shape (n_cycles,)
        Cycle means in U.

    Raises
    ------
    InputError
        If ``x`` is not 1-D or has non-finite samples.

    References
    ----------
    .. [1] ASTM E1049-85, Section 5.4.4, and the ``rainflow`` package
       (https://github.com/iamlikeme/rainflow).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1:
        raise InputError(f"rainflow_cycles: x of shape {x.shape}; expected a 1-D signal")
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise InputError(
            f"rainflow_cycles: signal has non-finite samples, the first at index {int(bad[0])}"
        )
    cycles = list(rainflow.extract_cycles(_turning_points(x)))
    if not cycles:
        empty = np.zeros(0)
        return empty, empty.copy(), empty.copy()
    arr = np.array([(c[0], c[2], c[1]) for c in cycles], dtype=np.float64)
    return arr[:, 0], arr[:, 1], arr[:, 2]


def cycles_to_failure(amplitude: np.ndarray, beta: float = DEFAULT_BETA, C: float = 1.0):
    """Basquin's law ``N = C s^-beta`` (thesis Eq. 40).

    Parameters
    ----------
    amplitude : array_like
        Stress (or pseudo-stress) amplitude s > 0, in U.
    beta : float, optional
        Basquin exponent, > 0 (default 5).
    C : float, optional
        Basquin constant in U^beta, > 0 (default 1).

    Returns
    -------
    ndarray
        Cycles to failure, same shape as ``amplitude`` (inf where s = 0).

    References
    ----------
    .. [1] Basquin, O. H., Proc. ASTM 10 (1910) 625-630.
    """
    beta, C = _check_beta_c(beta, C)
    s = np.asarray(amplitude, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return C * s ** (-beta)


def pseudo_damage(x: np.ndarray, beta: float = DEFAULT_BETA, C: float = 1.0) -> np.ndarray:
    """Pseudo damage per channel, ``D = C^-1 sum_i p_i s_i^beta`` (thesis Eq. 41).

    Cycles come from rainflow counting (half cycles count 0.5), ``s_i`` is the cycle
    amplitude (half the range), and Basquin's law gives ``N_i = C s_i^-beta``.

    Parameters
    ----------
    x : ndarray, shape (n_channels, n_samples) or (n_samples,)
        Time data in unit U (e.g. m/s^2).
    beta : float, optional
        Basquin exponent, > 0 (default 5).
    C : float, optional
        Basquin constant in U^beta, > 0 (default 1: damage is relative).

    Returns
    -------
    D : ndarray, shape (n_channels,) (0-d for 1-D input)
        Pseudo damage, dimensionless when C carries U^beta.

    Raises
    ------
    InputError
        On ``beta <= 0``, ``C <= 0``, more than 2 dimensions, or non-finite samples (the
        message names the channel index and the first bad sample).

    Examples
    --------
    A cosine of amplitude 2 over 10 full cycles: D = 10 * 2^5 = 320.

    >>> import numpy as np
    >>> t = np.arange(201) / 20
    >>> float(pseudo_damage(2 * np.cos(2 * np.pi * t), beta=5))
    320.0

    References
    ----------
    .. [1] ASTM E1049-85, Section 5.4.4 (rainflow counting).
    .. [2] Basquin, O. H., Proc. ASTM 10 (1910) 625-630.
    .. [3] Miner, M. A., J. Appl. Mech. 12 (1945) A159-A164.
    """
    beta, C = _check_beta_c(beta, C)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim not in (1, 2):
        raise InputError(
            f"pseudo_damage: x of shape {x.shape}; expected (n_channels, n_samples) or (n_samples,)"
        )
    x2 = np.atleast_2d(x)
    bad = np.argwhere(~np.isfinite(x2))
    if bad.size:
        ch, i = (int(v) for v in bad[0])
        raise InputError(
            f"pseudo_damage: channel {ch} has a non-finite sample at index {i}; "
            "expected finite data"
        )
    out = np.empty(x2.shape[0])
    for k, row in enumerate(x2):  # rainflow counting is sequential per channel
        ranges, counts, _ = rainflow_cycles(row)
        out[k] = np.sum(counts * (0.5 * ranges) ** beta) / C
    return out[0] if x.ndim == 1 else out


# ---------------------------------------------------------------------------------------
# Relative pseudo damage between two recordings
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ChannelDamage:
    """Pseudo damage of one channel in a simulated and a measured recording.

    Parameters
    ----------
    name : str
        Channel name.
    damage_simulated, damage_measured : float
        Pseudo damages D_sim and D_meas (``C = 1``: in U^beta).
    ratio : float
        Relative pseudo damage ``D_sim / D_meas`` (nan if D_meas is 0).
    """

    name: str
    damage_simulated: float
    damage_measured: float
    ratio: float

    @property
    def percent(self) -> float:
        """Relative pseudo damage in percent."""
        return 100.0 * self.ratio


@dataclass(frozen=True)
class RelativeDamage:
    """Relative pseudo damage per channel (thesis Section 7, Figs 22-27).

    Parameters
    ----------
    channels : tuple of ChannelDamage
        One entry per compared channel, in comparison order.
    beta : float
        Basquin exponent used.
    rate_hz : float
        Common sample rate in Hz at which both recordings were counted.
    C : float, optional
        Basquin constant (default 1).
    info : mapping str -> str | int | float, optional
        Provenance, e.g. the sources of the two recordings.
    notes : tuple of str, optional
        Plausibility notes on the comparison (:func:`plausibility_notes`): recordings of
        different length, relative damage off by orders of magnitude.
    """

    channels: tuple[ChannelDamage, ...]
    beta: float
    rate_hz: float
    C: float = 1.0
    info: Mapping[str, str | int | float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "channels", tuple(self.channels))
        names = [c.name for c in self.channels]
        if len(set(names)) != len(names):
            raise InputError(f"RelativeDamage: repeated channel names in {names}")
        object.__setattr__(self, "info", dict(self.info))
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))

    @property
    def names(self) -> tuple[str, ...]:
        """Channel names."""
        return tuple(c.name for c in self.channels)

    @property
    def ratios(self) -> np.ndarray:
        """Relative pseudo damage per channel, shape (n_channels,)."""
        return np.array([c.ratio for c in self.channels])

    def __getitem__(self, name: str) -> ChannelDamage:
        for c in self.channels:
            if c.name == name:
                return c
        raise InputError(f"channel {name!r} not in the result; available: {', '.join(self.names)}")

    def as_dict(self) -> dict:
        """JSON-ready dictionary (nan ratios become None).

        Returns
        -------
        dict
            ``{'beta', 'C', 'rate_hz', 'info', 'notes', 'channels': {name: {
            'pseudo_damage_simulated', 'pseudo_damage_measured',
            'relative_pseudo_damage'}}}``.
        """

        def num(v: float):
            return float(v) if math.isfinite(v) else None

        return {
            "beta": self.beta,
            "C": self.C,
            "rate_hz": self.rate_hz,
            "info": dict(self.info),
            "notes": list(self.notes),
            "channels": {
                c.name: {
                    "pseudo_damage_simulated": num(c.damage_simulated),
                    "pseudo_damage_measured": num(c.damage_measured),
                    "relative_pseudo_damage": num(c.ratio),
                }
                for c in self.channels
            },
        }

    def to_json(self, indent: int | None = 2) -> str:
        """Return :meth:`as_dict` as a JSON string."""
        return json.dumps(self.as_dict(), indent=indent, allow_nan=False)


#: relative pseudo damage beyond this factor either way is noted as implausible for a model of the
#: same structure: with beta = 5 it is an amplitude ratio above 2.5, a missed or spurious resonance
#: rather than a damping question
IMPLAUSIBLE_DAMAGE_FACTOR = 100.0


def plausibility_notes(names, ratios, beta: float, simulated_s: float, measured_s: float) -> tuple[str, ...]:
    """Return notes on a relative pseudo damage that is suspect before it is read.

    Pseudo damage grows in proportion to the duration counted, so recordings of different length
    bias every ratio by the length ratio; a ratio beyond :data:`IMPLAUSIBLE_DAMAGE_FACTOR` either
    way means an rms amplitude ratio of about ``ratio ** (1 / beta)``, which damping alone does
    not explain.

    Parameters
    ----------
    names : sequence of str
        Channel names.
    ratios : array_like
        Relative pseudo damage per channel (fraction; 1 = as measured).
    beta : float
        Basquin exponent of the count.
    simulated_s, measured_s : float
        Durations of the two recordings in s.

    Returns
    -------
    tuple of str
        One sentence per note; empty when nothing is suspect.
    """
    notes = []
    longer, shorter = max(simulated_s, measured_s), min(simulated_s, measured_s)
    if shorter > 0 and longer > 1.01 * shorter:
        notes.append(
            f"the simulated recording is {simulated_s:g} s and the measured one {measured_s:g} s: every "
            f"ratio is scaled by about {simulated_s / measured_s:.3g} (pseudo damage grows with the "
            "duration counted); compare recordings of equal length")
    r = np.asarray(ratios, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        off = np.where(np.isfinite(r) & (r > 0), np.maximum(r, 1.0 / r), np.nan)
    far = [i for i in np.flatnonzero(off > IMPLAUSIBLE_DAMAGE_FACTOR)]
    if far:
        worst = max(far, key=lambda i: off[i])
        listed = ", ".join(str(names[i]) for i in far[:6]) + (", ..." if len(far) > 6 else "")
        notes.append(
            f"{len(far)} of {r.size} channel(s) off by more than x{IMPLAUSIBLE_DAMAGE_FACTOR:g} ({listed}); "
            f"the worst, {names[worst]}, at {100 * r[worst]:.3g} % is an rms amplitude ratio of about "
            f"{r[worst] ** (1.0 / beta):.2g}: a resonance the model misses or adds, not a damping "
            "question (exudyn-study diagnose locates it)")
    return tuple(notes)


def _channel_names(
    simulated: Recording, measured: Recording, channels: Iterable[str] | None
) -> list[str]:
    if channels is None:
        sim = [c.name for c in simulated.response_channels]
        meas = {c.name for c in measured.response_channels}
        only_sim = [n for n in sim if n not in meas]
        only_meas = sorted(meas - set(sim))
        if only_sim or only_meas:
            raise InputError(
                "recordings have different channel sets: only in simulated: "
                f"{', '.join(only_sim) or '-'}, only in measured: {', '.join(only_meas) or '-'} "
                "(pass channels=... to compare a common subset)"
            )
        if not sim:
            raise InputError("recordings have no response channels to compare")
        return sim
    names = [channels] if isinstance(channels, str) else list(channels)
    if not names:
        raise InputError("channels is empty; expected at least one channel name")
    for label, rec in (("simulated", simulated), ("measured", measured)):
        missing = [n for n in names if n not in rec.names]
        if missing:
            raise InputError(
                f"channel(s) {', '.join(missing)} missing from the {label} recording; "
                f"it has {', '.join(rec.names[:8])}{', ...' if len(rec.names) > 8 else ''}"
            )
    return names


def relative_pseudo_damage(
    simulated: Recording,
    measured: Recording,
    beta: float = DEFAULT_BETA,
    channels: Sequence[str] | None = None,
    rate_hz: float | None = None,
    C: float = 1.0,
) -> RelativeDamage:
    """Relative pseudo damage ``D_sim / D_meas`` per channel.

    Channels sampled above the common rate are resampled to it with the anti-aliased
    polyphase filter of :func:`exudyn_study.signals.resample` (thesis Section 7.2:
    measured 1000 Hz -> 204.8 Hz), so both signals are counted at the same rate.

    Parameters
    ----------
    simulated, measured : Recording
        The two recordings. Channels are matched by name.
    beta : float, optional
        Basquin exponent, > 0 (default 5).
    channels : sequence of str, optional
        Channels to compare (e.g. the z sensors). Default: all response channels,
        which must then be the same set in both recordings.
    rate_hz : float, optional
        Common rate in Hz; default the lowest rate among the compared channels of both
        recordings. Must not exceed any channel's rate (no upsampling).
    C : float, optional
        Basquin constant, > 0 (default 1; cancels in the ratio).

    Returns
    -------
    RelativeDamage
        Per channel D_sim, D_meas and their ratio.

    Raises
    ------
    InputError
        If the channel sets differ (``channels=None``) or a named channel is missing
        from one recording, ``beta <= 0``, ``rate_hz`` is above a channel's rate, or
        the recordings are not :class:`~exudyn_study.recording.Recording`.

    Warns
    -----
    UserWarning
        If the compared channels' durations differ by more than 1 % (damage scales
        with duration), or a measured damage is zero (ratio nan).

    References
    ----------
    .. [1] ASTM E1049-85, Section 5.4.4; Basquin (1910); Miner (1945).
    """
    beta, C = _check_beta_c(beta, C)
    for label, rec in (("simulated", simulated), ("measured", measured)):
        if not isinstance(rec, Recording):
            raise InputError(f"{label} is a {type(rec).__name__}; expected a Recording")
    names = _channel_names(simulated, measured, channels)
    sim_ch = [simulated.channel(n) for n in names]
    meas_ch = [measured.channel(n) for n in names]
    lowest = min(c.sample_rate_hz for c in sim_ch + meas_ch)
    if rate_hz is None:
        rate = lowest
    else:
        rate = float(rate_hz)
        if not (math.isfinite(rate) and 0 < rate <= lowest):
            slowest = min(sim_ch + meas_ch, key=lambda c: c.sample_rate_hz)
            raise InputError(
                f"rate_hz {rate_hz!r}; expected 0 < rate_hz <= {lowest:g} Hz (channel "
                f"{slowest.name!r} is sampled at {lowest:g} Hz; no upsampling)"
            )

    def at_rate(chans) -> list[np.ndarray]:
        out = []
        # group by rate so each group is resampled in one vectorised call
        by_rate: dict[tuple[float, int], list[int]] = {}
        for i, c in enumerate(chans):
            by_rate.setdefault((c.sample_rate_hz, c.n_samples), []).append(i)
        data: list[np.ndarray | None] = [None] * len(chans)
        for (fs, _), idx in by_rate.items():
            block = np.stack([chans[i].data for i in idx])
            if fs != rate:
                block = resample(block, fs, rate)
            for j, i in enumerate(idx):
                data[i] = block[j]
        out.extend(data)  # type: ignore[arg-type]
        return out

    d_sim = [float(pseudo_damage(x, beta, C)) for x in at_rate(sim_ch)]
    d_meas = [float(pseudo_damage(x, beta, C)) for x in at_rate(meas_ch)]
    results = []
    for n, ds, dm in zip(names, d_sim, d_meas, strict=True):
        if dm == 0.0:
            warnings.warn(
                f"channel {n!r}: measured pseudo damage is 0 (constant signal); ratio is nan",
                stacklevel=2,
            )
            ratio = math.nan
        else:
            ratio = ds / dm
        results.append(ChannelDamage(n, ds, dm, ratio))
    notes = plausibility_notes(names, [c.ratio for c in results], beta,
                               max(c.duration_s for c in sim_ch), max(c.duration_s for c in meas_ch))
    for note in notes:
        warnings.warn(note, stacklevel=2)
    info = {
        f"{label}_{key}": value
        for label, rec in (("simulated", simulated), ("measured", measured))
        for key, value in rec.metadata.items()
        if key in ("source", "model", "damping", "signal", "seed")
    }
    return RelativeDamage(tuple(results), beta, rate, C, info, notes)
