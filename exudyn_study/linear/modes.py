"""Damped system modes of a linearised rig model, and their forms for comparison.

:class:`SystemModes` holds frequencies, damping ratios, complex shapes at the sensors and a
description of which component moves most; :func:`exudyn_study.model.system_modes`
computes them from a :class:`~exudyn_study.linear.LinearSystem` (the undamped
``K phi = w^2 M phi`` and the damped state-space eigenproblems). :func:`to_modal_model`
turns them into the identification module's :class:`~exudyn_study.identify.model.ModalModel`
so that computed and identified modes can be compared directly
(:func:`exudyn_study.linear.pair_modal_models`: MAC and frequency); :func:`modes_table`
prints them as the thesis's table.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from exudyn_study.identify.model import ModalModel, Mode

__all__ = [
    "SystemModes",
    "to_modal_model",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SystemModes:
    """Modes of the constrained system, sorted by natural frequency.

    Attributes
    ----------
    undamped_frequency_hz : ndarray, shape (n_modes,)
        From ``K phi = w^2 M phi``.
    frequency_hz : ndarray, shape (n_modes,)
        Natural frequency ``|lambda| / 2 pi`` of each damped pole (oscillatory poles only).
    damping_ratio : ndarray, shape (n_modes,)
        ``-Re(lambda) / |lambda|``.
    damped_frequency_hz : ndarray
        ``Im(lambda) / 2 pi``.
    shapes : ndarray, complex, shape (n_sensors, n_modes)
        Damped mode shapes (displacement) at the sensors, largest coefficient 1.
    coordinates : ndarray, complex, shape (n, n_modes)
        Damped mode shapes in the projected coordinates ``z``.
    energy_share : list of dict component -> share (sums to 1)
    direction : list of dict component -> 'X'|'Y'|'Z' (dominant direction)
    descriptions : list of str
    sensor_names : tuple of str
    """

    undamped_frequency_hz: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    damped_frequency_hz: np.ndarray
    shapes: np.ndarray
    coordinates: np.ndarray
    energy_share: list
    direction: list
    descriptions: list
    sensor_names: tuple


def to_modal_model(modes: SystemModes, metadata: dict | None = None) -> ModalModel:
    """Return the modes as a :class:`~exudyn_study.identify.model.ModalModel` (modes JSON schema).

    Parameters
    ----------
    modes : SystemModes
        Damped system modes.
    metadata : dict, optional
        Added to the model's metadata (after ``{"source": "exudyn_study.linear.modes"}``).

    Returns
    -------
    ModalModel
        One mode per system mode: frequency (Hz), damping ratio (capped below 1), complex shape
        per sensor name, description.
    """
    out = []
    for j in range(modes.frequency_hz.size):
        shape = {n: complex(modes.shapes[i, j]) for i, n in enumerate(modes.sensor_names)}
        out.append(Mode(frequency_hz=float(modes.frequency_hz[j]),
                        damping_ratio=float(min(modes.damping_ratio[j], 0.999999)),
                        shape=shape, description=modes.descriptions[j]))
    meta = {"source": "exudyn_study.linear.modes"}
    meta.update(metadata or {})
    return ModalModel(tuple(out), meta)


def modes_table(modes, fmt: str = "text") -> str:
    """Format the thesis-style table (mode, frequencies, damping, description) as text or markdown.

    Parameters
    ----------
    modes : SystemModes
        Damped system modes.
    fmt : {'text', 'markdown'}
        Fixed-width text columns, or a markdown table (any other value gives text).

    Returns
    -------
    str
        One line per mode: undamped and damped frequency (Hz), damping (%), description.
    """
    rows = [(j + 1, modes.undamped_frequency_hz[j] if j < modes.undamped_frequency_hz.size else float("nan"),
             modes.frequency_hz[j], 100 * modes.damping_ratio[j], modes.descriptions[j])
            for j in range(modes.frequency_hz.size)]
    if fmt == "markdown":
        lines = ["| Mode | Undamped f (Hz) | f (Hz) | Damping (%) | Mode shape |", "|---|---|---|---|---|"]
        lines += [f"| {n} | {fu:.2f} | {f:.2f} | {z:.2f} | {d} |" for n, fu, f, z, d in rows]
    else:
        lines = [f"{'mode':>4} {'f0 (Hz)':>9} {'f (Hz)':>9} {'zeta (%)':>9}  description"]
        lines += [f"{n:4d} {fu:9.2f} {f:9.2f} {z:9.2f}  {d}" for n, fu, f, z, d in rows]
    return "\n".join(lines)
