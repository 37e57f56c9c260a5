"""The calibration's design variables: which flexible-body modal damping ratios are free.

A :class:`DampingDesign` maps a vector ``x`` of variables to per-body, per-mode damping
ratios (one variable per body, per frequency band of a body, or per mode), with bounds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from exudyn_study.bodies.damping import MAX_RATIO, validate_ratios
from exudyn_study.errors import InputError

#: calibration layouts: one ratio per body mode below a cut-off (:meth:`DampingDesign.per_mode`),
#: or one ratio per body for all of its modes (:meth:`DampingDesign.per_body`, thesis Table 6)
CALIBRATION_DESIGNS = ("per-mode", "per-body")


@dataclass(frozen=True)
class DampingDesign:
    """Which flexible-body modal damping ratios are design variables.

    Parameters
    ----------
    body_frequencies_hz : mapping str -> ndarray
        Free-free mode frequencies (Hz) of every calibrated body, in the body's mode order.
    assignment : mapping str -> ndarray of int
        Per body and mode: the index of the design variable setting its ratio, or -1 for a
        fixed ratio.
    fixed_ratios : mapping str -> ndarray
        Per body and mode: the ratio used where ``assignment`` is -1 (ignored elsewhere).
    variable_names : tuple of str
        One name per design variable.
    upper : float
        Upper bound of every variable (default :data:`~exudyn_study.bodies.damping.MAX_RATIO`).
    lower : float
        Lower bound of every variable (default 0).

    Notes
    -----
    Use :meth:`per_mode` (one variable per body mode) or :meth:`per_body` (one per body, thesis
    Table 6) rather than the constructor.
    """

    body_frequencies_hz: Mapping[str, np.ndarray]
    assignment: Mapping[str, np.ndarray]
    fixed_ratios: Mapping[str, np.ndarray]
    variable_names: tuple[str, ...]
    upper: float = MAX_RATIO
    lower: float = 0.0

    def __post_init__(self) -> None:
        freqs = _body_frequencies(self.body_frequencies_hz)
        if set(self.assignment) != set(freqs) or set(self.fixed_ratios) != set(freqs):
            raise InputError(
                "damping design: assignment and fixed_ratios must name the same bodies as the frequencies"
            )
        names = tuple(str(n) for n in self.variable_names)
        if not names:
            raise InputError("damping design: no design variable (is the cut-off below every body mode?)")
        if not 0.0 < float(self.upper) < 1.0:
            raise InputError(f"damping design: upper bound {self.upper!r}: expected in (0, 1)")
        if not 0.0 <= float(self.lower) < float(self.upper):
            raise InputError(
                f"damping design: lower bound {self.lower!r}: expected in [0, upper = {self.upper!r})")
        assign, fixed = {}, {}
        used = np.zeros(len(names), bool)
        for b, f in freqs.items():
            a = np.asarray(self.assignment[b], dtype=int).ravel()
            r = validate_ratios(
                np.asarray(self.fixed_ratios[b], dtype=float).ravel(), f"fixed damping ratio of {b!r}"
            )
            if a.size != f.size or r.size != f.size:
                raise InputError(
                    f"damping design: body {b!r} has {f.size} modes; assignment/fixed ratios differ"
                )
            if np.any((a < -1) | (a >= len(names))):
                raise InputError(f"damping design: body {b!r}: variable index out of range")
            used[a[a >= 0]] = True
            assign[b], fixed[b] = a, r
        if not used.all():
            raise InputError(
                f"damping design: variable {names[int(np.flatnonzero(~used)[0])]!r} sets no mode"
            )
        object.__setattr__(self, "body_frequencies_hz", freqs)
        object.__setattr__(self, "assignment", assign)
        object.__setattr__(self, "fixed_ratios", fixed)
        object.__setattr__(self, "variable_names", names)
        object.__setattr__(self, "upper", float(self.upper))
        object.__setattr__(self, "lower", float(self.lower))

    @classmethod
    def per_mode(cls, bodies, cutoff_hz: float, above=MAX_RATIO) -> DampingDesign:
        """One variable per body mode below ``cutoff_hz``; a fixed damping above.

        Parameters
        ----------
        bodies : mapping str -> ndarray or ReducedBody or FlexibleBodyHandle
            Body name -> its mode frequencies (Hz) or an object with ``frequencies_hz``.
        cutoff_hz : float
            Modes with ``f < cutoff_hz`` are design variables.
        above : float or callable
            Ratio of the modes at and above the cut-off, or a damping function of frequency
            (e.g. :func:`exudyn_study.bodies.damping.adams_default`). Default: 100 % (clipped to
            :data:`~exudyn_study.bodies.damping.MAX_RATIO`), as in the thesis.

        Returns
        -------
        DampingDesign
        """
        freqs = _body_frequencies(bodies)
        if not (math.isfinite(cutoff_hz) and cutoff_hz > 0):
            raise InputError(f"cutoff_hz={cutoff_hz!r}: expected a frequency > 0 Hz")
        assign, fixed, names = {}, {}, []
        for b, f in freqs.items():
            a = np.full(f.size, -1)
            for i in np.flatnonzero(f < cutoff_hz):
                a[i] = len(names)
                names.append(f"{b}:mode{i + 1}")
            assign[b] = a
            fixed[b] = np.asarray(above(f), float) if callable(above) else np.full(f.size, float(above))
        return cls(freqs, assign, fixed, tuple(names))

    @classmethod
    def per_body(cls, bodies) -> DampingDesign:
        """One variable per body, applied to all of its modes (thesis Table 6 layout).

        Parameters
        ----------
        bodies : mapping str -> ndarray or ReducedBody or FlexibleBodyHandle

        Returns
        -------
        DampingDesign
        """
        freqs = _body_frequencies(bodies)
        assign = {b: np.full(f.size, k) for k, (b, f) in enumerate(freqs.items())}
        fixed = {b: np.zeros(f.size) for b, f in freqs.items()}
        return cls(freqs, assign, fixed, tuple(freqs))

    @property
    def n_variables(self) -> int:
        """Number of design variables."""
        return len(self.variable_names)

    def ratios(self, x) -> dict[str, np.ndarray]:
        """Damping ratio of every mode of every body for design vector ``x``.

        Parameters
        ----------
        x : array_like, shape (n_variables,)
            Design variables (fractions of critical damping, in [0, 1)).

        Returns
        -------
        dict str -> ndarray
        """
        x = validate_ratios(np.asarray(x, dtype=float).ravel(), "design variable")
        if x.size != self.n_variables:
            raise InputError(
                f"design vector has {x.size} values; the design has {self.n_variables} variables"
            )
        out = {}
        for b, a in self.assignment.items():
            r = self.fixed_ratios[b].copy()
            r[a >= 0] = x[a[a >= 0]]
            out[b] = r
        return out

    def variables_from_ratios(self, ratios: Mapping[str, np.ndarray]) -> np.ndarray:
        """Design vector from per-body ratios (mean over the modes a variable sets).

        Parameters
        ----------
        ratios : Mapping[str, numpy.ndarray]
            Per-body modal damping ratios (dimensionless), keyed by body name; each array holds one
            ratio per mode of that body, in the order of :attr:`assignment`.

        Returns
        -------
        numpy.ndarray
            Design vector of shape ``(n_variables,)``: for each variable the mean of the ratios of the
            modes it sets.
        """
        acc = np.zeros(self.n_variables)
        cnt = np.zeros(self.n_variables)
        for b, a in self.assignment.items():
            r = np.asarray(ratios[b], float).ravel()
            np.add.at(acc, a[a >= 0], r[a >= 0])
            np.add.at(cnt, a[a >= 0], 1.0)
        return acc / cnt


def _body_frequencies(bodies) -> dict[str, np.ndarray]:
    out = {}
    if not isinstance(bodies, Mapping) or not bodies:
        raise InputError("bodies: expected a non-empty mapping body name -> mode frequencies (or body)")
    for name, b in bodies.items():
        f = getattr(b, "frequencies_hz", None)
        if f is None and hasattr(b, "body"):
            f = getattr(b.body, "frequencies_hz", None)
        f = np.asarray(b if f is None else f, dtype=float).ravel()
        if f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0):
            raise InputError(f"body {name!r}: mode frequencies must be finite and > 0 Hz")
        out[str(name)] = f
    return out
