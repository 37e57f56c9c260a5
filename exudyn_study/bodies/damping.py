"""Modal damping functions of flexible bodies (thesis Section 6).

A damping function maps the frequencies of a flexible body's (orthogonalised) modes to a
critical damping ratio per mode, exactly what MSC Adams lets a user set on a flexible
body. All functions are pure NumPy and vectorised over modes.

- :func:`adams_default`: 1 % below 100 Hz, 10 % to 1000 Hz, 100 % above (eq. 42);
- :func:`adams_step`: Adams' cubic STEP from ``h0`` at ``x0`` to ``h1`` at ``x1``;
  the Scania reference is 16.6 % at 0 Hz to 100 % at 450 Hz (Figure 17);
- :func:`constant`: one ratio for every mode;
- :class:`PerBody`: one constant per body (thesis Table 6 for Model 3);
- :class:`PerModeTable`: an explicit ratio per mode (what the calibration produces).

``DAMPING_FUNCTIONS`` names the standard choices for the command line.

A ratio of 1 (critical) is not accepted by Exudyn's damped eigen-solver in a useful
way and is clipped to :data:`MAX_RATIO` (0.999), the largest value a body takes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from exudyn_study.errors import InputError

__all__ = [
    "MAX_RATIO",
    "adams_default",
    "adams_step",
    "step_reference",
    "constant",
    "PerBody",
    "PerModeTable",
    "THESIS_TABLE6",
    "DAMPING_FUNCTIONS",
    "damping_function",
    "validate_ratios",
]

#: Largest damping ratio given to a flexible-body mode (critical damping, 100 %, is
#: represented by this value).
MAX_RATIO = 0.999

DampingFunction = Callable[[np.ndarray], np.ndarray]


def validate_ratios(ratios: Sequence[float] | np.ndarray, what: str = "damping ratio") -> np.ndarray:
    """Return ``ratios`` as a float array; raise on NaN or values outside [0, 1).

    Parameters
    ----------
    ratios : array_like of float
        Damping ratios (fractions of critical damping, 0.02 for 2 %), any shape.
    what : str
        What the ratios are, for the error message (e.g. 'per-body damping ratio').

    Returns
    -------
    ndarray
        ``ratios`` as floats, same shape.

    Raises
    ------
    InputError
        Naming the first offending entry and the accepted range.
    """
    values = np.asarray(ratios, dtype=float)
    bad = ~np.isfinite(values) | (values < 0.0) | (values >= 1.0)
    if bad.any():
        i = int(np.flatnonzero(bad.ravel())[0])
        raise InputError(
            f"{what} [{i}] = {values.ravel()[i]!r}; expected a fraction of critical damping in [0, 1) "
            "(e.g. 0.02 for 2 %)"
        )
    return values


def _frequencies(frequencies_hz) -> np.ndarray:
    f = np.asarray(frequencies_hz, dtype=float)
    if not np.all(np.isfinite(f)) or np.any(f < 0):
        raise InputError("mode frequencies must be finite and >= 0 Hz")
    return f


def adams_default(frequencies_hz) -> np.ndarray:
    """MSC Adams default modal damping (thesis eq. 42).

    1 % for ``f < 100 Hz``, 10 % for ``100 <= f < 1000 Hz``, 100 % (clipped to
    :data:`MAX_RATIO`) above.

    Parameters
    ----------
    frequencies_hz : array_like
        Mode frequencies (Hz).

    Returns
    -------
    ndarray
        Damping ratio per mode.
    """
    f = _frequencies(frequencies_hz)
    return np.where(f < 100.0, 0.01, np.where(f < 1000.0, 0.10, MAX_RATIO))


def adams_step(frequencies_hz, x0: float, h0: float, x1: float, h1: float) -> np.ndarray:
    """Adams' STEP function: cubic blend from ``h0`` at ``x0`` to ``h1`` at ``x1``.

    ``h0 + (h1 - h0) d^2 (3 - 2 d)`` with ``d = (f - x0) / (x1 - x0)`` clipped to [0, 1].

    Parameters
    ----------
    frequencies_hz : array_like
    x0, x1 : float
        Start and end of the transition (Hz), ``x1 > x0``.
    h0, h1 : float
        Ratios at and below ``x0`` and at and above ``x1``, in [0, 1].
    """
    if not x1 > x0:
        raise InputError(f"STEP: x1 = {x1!r} must be greater than x0 = {x0!r}")
    for name, h in (("h0", h0), ("h1", h1)):
        if not (math.isfinite(h) and 0.0 <= h <= 1.0):
            raise InputError(f"STEP: {name} = {h!r}; expected a damping ratio in [0, 1]")
    f = _frequencies(frequencies_hz)
    d = np.clip((f - x0) / (x1 - x0), 0.0, 1.0)
    return np.minimum(h0 + (h1 - h0) * d * d * (3.0 - 2.0 * d), MAX_RATIO)


def step_reference(frequencies_hz) -> np.ndarray:
    """Scania's reference STEP damping: 16.6 % at 0 Hz to 100 % at 450 Hz (Figure 17).

    Parameters
    ----------
    frequencies_hz : array_like
        Mode frequencies (Hz), finite and >= 0.

    Returns
    -------
    ndarray
        Damping ratio per mode (clipped to :data:`MAX_RATIO`), shape of ``frequencies_hz``.
    """
    return adams_step(frequencies_hz, 0.0, 0.166, 450.0, 1.0)


def constant(ratio: float) -> DampingFunction:
    """Return a damping function that gives every mode the same ``ratio``.

    Parameters
    ----------
    ratio : float
        Damping ratio of every mode, in [0, 1) (0.02 for 2 %).

    Returns
    -------
    callable
        ``f(frequencies_hz) -> ndarray`` of ``ratio``, shape of ``frequencies_hz``.

    Raises
    ------
    InputError
        For a ratio outside [0, 1).
    """
    validate_ratios([ratio])
    return lambda frequencies_hz: np.full(np.shape(_frequencies(frequencies_hz)), float(ratio))


@dataclass(frozen=True)
class PerBody:
    """One constant damping ratio per flexible body (thesis Table 6 for Model 3).

    Parameters
    ----------
    ratios : mapping body component name -> ratio
        E.g. ``{'frame': 0.015, 'bracket_left': 0.06, ...}``.
    default : float or None
        Ratio for bodies not in ``ratios``; None makes an unknown body an error.
    """

    ratios: Mapping[str, float]
    default: float | None = None

    def __post_init__(self) -> None:
        validate_ratios(list(self.ratios.values()), "per-body damping ratio")
        if self.default is not None:
            validate_ratios([self.default], "default damping ratio")

    def for_body(self, body: str) -> DampingFunction:
        """Return the damping function of ``body``.

        Parameters
        ----------
        body : str
            Flexible-body component name (a key of ``ratios``).

        Returns
        -------
        callable
            A :func:`constant` damping function of the body's ratio (or of ``default``).

        Raises
        ------
        InputError
            For a body not in the table when there is no ``default``.
        """
        if body in self.ratios:
            return constant(self.ratios[body])
        if self.default is None:
            raise InputError(f"no damping ratio for body {body!r}; the table has {sorted(self.ratios)}")
        return constant(self.default)


@dataclass(frozen=True)
class PerModeTable:
    """An explicit damping ratio per flexible-body mode (e.g. from the calibration).

    Parameters
    ----------
    ratios : sequence of float
        Ratio of mode 1, 2, ... of the body.
    beyond : float
        Ratio for modes past the end of the table (thesis: 100 % for higher modes).
    """

    ratios: Sequence[float]
    beyond: float = MAX_RATIO
    _values: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_values", validate_ratios(self.ratios, "per-mode damping ratio"))
        validate_ratios([self.beyond], "damping ratio beyond the table")

    def __call__(self, frequencies_hz) -> np.ndarray:
        """Ratios for the body's modes (in order)."""
        f = _frequencies(frequencies_hz)
        out = np.full(f.shape, self.beyond)
        n = min(len(self._values), f.size)
        out.ravel()[:n] = self._values[:n]
        return out


#: Thesis Table 6: the per-body damping chosen for Model 3.
THESIS_TABLE6 = PerBody(
    {"frame": 0.015, "bracket_left": 0.06, "bracket_right": 0.005, "tank_left": 0.02, "tank_right": 0.02}
)

#: Named damping functions for the command line.
DAMPING_FUNCTIONS: Mapping[str, DampingFunction] = MappingProxyType(
    {
        "adams-default": adams_default,
        "step": step_reference,
        "constant-1": constant(0.01),
        "constant-2": constant(0.02),
    }
)


def damping_function(name: str) -> DampingFunction:
    """Look up a named damping function.

    Parameters
    ----------
    name : str
        A key of :data:`DAMPING_FUNCTIONS` ('adams-default', 'step', 'constant-1', 'constant-2').

    Returns
    -------
    callable
        ``f(frequencies_hz) -> ndarray`` of damping ratios.

    Raises
    ------
    InputError
        For an unknown name, listing the known ones.
    """
    try:
        return DAMPING_FUNCTIONS[name]
    except KeyError:
        raise InputError(
            f"damping {name!r} is unknown; expected one of {sorted(DAMPING_FUNCTIONS)} "
            "(or a per-body / per-mode table from the Python API)"
        ) from None


def parse_damping(name: str):
    """Parse a damping name from the command line (``table6`` is thesis Table 6).

    Parameters
    ----------
    name : str
        'table6' or a key of :data:`DAMPING_FUNCTIONS`.

    Returns
    -------
    str or PerBody
        ``name`` itself, or :data:`THESIS_TABLE6` for 'table6'.

    Raises
    ------
    InputError
        For an unknown name.
    """
    from exudyn_study.bodies.damping import THESIS_TABLE6, damping_function

    if name == "table6":
        return THESIS_TABLE6
    damping_function(name)  # validates
    return name
