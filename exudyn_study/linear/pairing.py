"""Pairing of model modes with target (identified) modes: one assignment for every caller.

Modes are paired one-to-one by the Hungarian assignment
(``scipy.optimize.linear_sum_assignment``) on the cost
``(1 - MAC) + frequency_weight * |f_model - f_target| / f_target``; a pair is admissible
when ``MAC >= min_mac`` and the relative frequency difference is at most
``max_frequency_error``. Without shapes on common degrees of freedom the pairing is by
frequency alone. :func:`pair_modes` works on arrays (the calibration's inner loop);
:func:`pair_modal_models` on two :class:`~exudyn_study.identify.model.ModalModel` objects
(shapes matched by channel name).

References
----------
Allemang, R. J. (2003). The modal assurance criterion - twenty years of use and abuse.
Sound and Vibration 37(8).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from exudyn_study.errors import InputError
from exudyn_study.identify.mac import mac
from exudyn_study.identify.model import ModalModel

__all__ = ["Pairing", "pair_modes", "ModePair", "pair_modal_models"]

#: cost of an inadmissible pair (larger than any admissible cost)
INFEASIBLE_COST = 1e6


@dataclass(frozen=True, eq=False)
class Pairing:
    """Model-to-target mode pairs.

    Attributes
    ----------
    model_index, target_index : ndarray of int, shape (p,)
        Paired indices into the model and target mode lists, sorted by target.
    mac : ndarray, shape (p,)
        MAC of each pair (NaN when pairing by frequency only).
    unpaired_model, unpaired_target : ndarray of int
        Indices left without a partner.
    """

    model_index: np.ndarray
    target_index: np.ndarray
    mac: np.ndarray
    unpaired_model: np.ndarray
    unpaired_target: np.ndarray

    def __len__(self) -> int:
        return int(self.model_index.size)


def pair_modes(
    model_frequency_hz,
    target_frequency_hz,
    model_shapes=None,
    target_shapes=None,
    *,
    min_mac: float = 0.5,
    max_frequency_error: float = 0.3,
    frequency_weight: float = 1.0,
) -> Pairing:
    """Pair model modes to target modes by MAC and frequency (Hungarian assignment).

    Parameters
    ----------
    model_frequency_hz : array_like, shape (n_model,)
        Model mode frequencies (Hz).
    target_frequency_hz : array_like, shape (n_target,)
        Target mode frequencies (Hz).
    model_shapes, target_shapes : ndarray, shape (n_dof, n_model) / (n_dof, n_target), optional
        Shapes at the same DOFs. Without them (either None or no DOF) pairing is by frequency.
    min_mac : float
        Smallest MAC of an admissible pair, in [0, 1].
    max_frequency_error : float
        Largest relative frequency difference ``|f_m - f_t| / f_t`` of an admissible pair.
    frequency_weight : float
        Weight of the relative frequency difference against ``1 - MAC`` in the cost.

    Returns
    -------
    Pairing

    Raises
    ------
    InputError
        If ``min_mac`` is outside [0, 1].
    """
    if not 0.0 <= min_mac <= 1.0:
        raise InputError(f"min_mac {min_mac!r}: expected a value in [0, 1]")
    fm = np.asarray(model_frequency_hz, float).ravel()
    ft = np.asarray(target_frequency_hz, float).ravel()
    rel = np.abs(fm[:, None] - ft[None, :]) / ft[None, :]
    use_shapes = model_shapes is not None and target_shapes is not None and np.shape(model_shapes)[0] > 0
    if use_shapes:
        macs = mac(model_shapes, target_shapes)
        cost = (1.0 - macs) + frequency_weight * rel
        bad = (macs < min_mac) | (rel > max_frequency_error)
    else:
        macs = np.full(rel.shape, np.nan)
        cost = rel.copy()
        bad = rel > max_frequency_error
    cost[bad] = INFEASIBLE_COST
    pm, pt = (np.array([], int), np.array([], int)) if cost.size == 0 else linear_sum_assignment(cost)
    ok = cost[pm, pt] < INFEASIBLE_COST if cost.size else np.array([], bool)
    pm, pt = pm[ok], pt[ok]
    order = np.argsort(pt)
    pm, pt = pm[order], pt[order]
    return Pairing(
        model_index=pm,
        target_index=pt,
        mac=macs[pm, pt] if pm.size else np.array([]),
        unpaired_model=np.setdiff1d(np.arange(fm.size), pm),
        unpaired_target=np.setdiff1d(np.arange(ft.size), pt),
    )


@dataclass(frozen=True)
class ModePair:
    """A model mode paired with a reference (identified) mode.

    Attributes
    ----------
    model_index, reference_index : int
        Indices into the model's and the reference's modes.
    mac : float or None
        MAC of the pair (None when paired by frequency only).
    frequency_error : float
        ``(f_model - f_ref) / f_ref``.
    """

    model_index: int
    reference_index: int
    mac: float | None
    frequency_error: float


def pair_modal_models(model_modes: ModalModel, reference: ModalModel, min_mac: float = 0.5,
                      max_frequency_error: float = 0.3,
                      channels: Sequence[str] | None = None) -> list[ModePair]:
    """Pair the modes of two modal models (:func:`pair_modes` on their common channels).

    Parameters
    ----------
    model_modes, reference : ModalModel
        Model (computed) and reference (identified) modes.
    min_mac, max_frequency_error : float
        Admissible pairs, as in :func:`pair_modes`.
    channels : sequence of str, optional
        Channels whose shape coefficients are compared (default: the reference's channels
        that the model has too). With fewer than two, pairing is by frequency.

    Returns
    -------
    list of ModePair
        Ordered by reference mode.
    """
    if channels is None:
        channels = [ch for ch in reference.channels if ch in set(model_modes.channels)]
    channels = list(channels)
    use_shapes = len(channels) >= 2 and len(model_modes) and len(reference)
    shapes = (model_modes.shapes(channels), reference.shapes(channels)) if use_shapes else (None, None)
    p = pair_modes(model_modes.frequency_hz, reference.frequency_hz, *shapes, min_mac=min_mac,
                   max_frequency_error=max_frequency_error)
    fm, fr = model_modes.frequency_hz, reference.frequency_hz
    return [ModePair(int(i), int(j), None if not use_shapes else float(m), float((fm[i] - fr[j]) / fr[j]))
            for i, j, m in zip(p.model_index, p.target_index, p.mac, strict=False)]
