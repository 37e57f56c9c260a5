r"""Automatic calibration of flexible-body modal damping against identified system modes.

The thesis (Section 6) chose the modal damping ratio of every free-free flexible-body mode by
hand so that the *assembled* model's damped modes carried the identified damping (Tables 5
and 7), and recommended an optimiser as future work (Sections 8-9). This module is that
optimiser.

Method
------
1. **Design** (:class:`DampingDesign`): which flexible-body modal damping ratios are free.
   one variable per body mode below a cut-off frequency, a fixed function above (the
   thesis: 100 %); or one variable per body (thesis Table 6 layout). Bounds ``[0, MAX_RATIO]``.
2. **Linearise once** (:func:`linearise_design`): Exudyn's ``ComputeLinearizedSystem`` projected into
   the constraint null space ``N`` gives ``M``, ``K`` and ``D``. Exudyn's reduced-order FFRF
   body applies its reduced damping matrix to the modal coordinates only, and at zero
   velocity no other velocity term survives linearisation, so the system damping matrix is
   *affine* in the body ratios:

   .. math:: C(x) = C_0 + \sum_e 2\,\omega_e\,x_{v(e)}\, n_e n_e^T,

   where ``e`` runs over the (body, mode) entries tied to variable ``v(e)``, ``n_e`` is the
   column of ``N`` of that modal coordinate, and ``C_0`` holds every other damper (bushings,
   joints) plus the fixed modes. The damping the system was built with is read back from
   Exudyn and subtracted, so the builder's own damping does not matter. Verified against
   ``ComputeODE2Eigenvalues(computeComplexEigenvalues=True)`` in the tests.
3. **Evaluate** (:meth:`LinearisedSystem.modes`): one dense eigen-solve of the first-order
   form ``A = [[0, I], [-M^-1 K, -M^-1 C(x)]]`` with left and right eigenvectors. Under-critical
   modes (``Im lambda > 0``) give ``f = |lambda| / 2 pi`` (undamped natural frequency, as in
   thesis Table 1) and ``zeta = -Re lambda / |lambda|``; overdamped pairs disappear, as the
   thesis's mode 10 did. Exact derivatives from the eigenvalue sensitivity
   ``d lambda / d x_j = w^H (dA/dx_j) v / (w^H v)``, equivalent to the quadratic-eigenproblem
   form ``-(y^H lambda C_j x) / (y^H (2 lambda M + C) x)``.
4. **Pair** (:func:`pair_modes`): Hungarian assignment (``scipy.optimize.linear_sum_assignment``)
   on ``cost = (1 - MAC) + freq_weight * |f_model - f_target| / f_target`` with MAC of the
   shapes at the sensors shared by model and target; a pair is allowed only when
   ``MAC >= mac_min`` and the relative frequency difference is at most ``freq_tol``. Without
   target shapes, pairing is by frequency alone. Unpaired modes are reported.
5. **Optimise** (:func:`calibrate`): ``scipy.optimize.least_squares`` (trust-region
   reflective, bounded, analytic Jacobian) on ``r_k = w_k (zeta_model,k - zeta_target,k)``.
   During one solve every paired model mode is *tracked* by the MAC of its full eigenvector
   with the one it had when paired (frequencies may cross while damping changes); after
   convergence the pairing with the target is redone, and the solve repeated if it changed.

Regularisation
--------------
With one variable per body mode the problem is usually under-determined (Models 1/2: more
body modes below the cut-off than identified modes) and some variables barely affect any
paired mode. The residual is therefore augmented by ``alpha (x - prior)``, a weak Tikhonov
pull towards a prior damping (default: the mean target damping ratio, a physically plausible
value for a body mode no target constrains). This selects, among the many exact solutions,
the one closest to the prior (a minimum-change solution) and keeps unobservable variables at
a sensible value instead of letting them drift to a bound. With the default ``alpha = 1e-3``
the bias on the fitted system damping is of order ``alpha**2 |x - prior| / s**2`` (``s`` the
sensitivity of a mode to its variables), far below 0.01 percentage points unless a target is
essentially uncontrollable. A smoothness penalty across frequency was not chosen: body modes
of different shape have no reason to have similar damping (the thesis's Figure 18 is not
smooth either).

Seam to the rig models
----------------------
:func:`calibrate` takes a :class:`CalibrationSystem` (an assembled ``mbs``, the flexible-body
handles by name and the sensor points) or a builder
``builder(damping_ratios: Mapping[str, ndarray]) -> CalibrationSystem``, called once with the
starting ratios (and once more with the result when ``verify=True``). The rig's
``build_model`` plugs in through :func:`system_from_model`. Sensors are
:class:`SensorPoint` (body name, mesh node, measuring direction); their linearised
displacement is evaluated by Exudyn itself (central differences of the node position).

References
----------
Thesis Section 6 (Tables 1, 5, 6, 7; Figure 18). Adhikari, S. (2006). Damping modelling using
generalized proportional damping. J. Sound Vib. 293 (eigenvalue derivatives of non-classically
damped systems). Allemang, R. J. (2003). The modal assurance criterion - twenty years of use
and abuse. Sound and Vibration 37(8).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares, linear_sum_assignment

from exudyn_study.bodies.damping import validate_ratios
from exudyn_study.calibrate.design import DampingDesign
from exudyn_study.calibrate.linearised import DesignModes, exudyn_damped_modes, linearise_design
from exudyn_study.calibrate.result import CalibrationResult, ModeRow, _f
from exudyn_study.calibrate.system import CalibrationSystem
from exudyn_study.errors import InputError
from exudyn_study.identify.mac import mac
from exudyn_study.identify.model import ModalModel
from exudyn_study.infra.blas import single_threaded_blas as _single_threaded_blas
from exudyn_study.linear.pairing import Pairing, pair_modes

__all__ = [
    "calibrate",
]

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------- the seam


SystemBuilder = Callable[[Mapping[str, np.ndarray]], CalibrationSystem]


# ---------------------------------------------------------------------------- optimiser


def _target_arrays(target: ModalModel, sensor_names: Sequence[str]):
    if not isinstance(target, ModalModel) or len(target) == 0:
        raise InputError("target: expected a ModalModel with at least one mode")
    channels = [c for c in target.channels if c in set(sensor_names)]
    shapes = target.shapes(channels) if channels else None
    return target.frequency_hz, target.damping_ratio, channels, shapes


def calibrate(
    system: CalibrationSystem | SystemBuilder,
    design: DampingDesign,
    target: ModalModel,
    *,
    x0=None,
    prior=None,
    regularization: float = 1e-3,
    weights=None,
    mac_min: float = 0.5,
    freq_tol: float = 0.3,
    freq_weight: float = 1.0,
    max_pairings: int = 5,
    max_evaluations: int = 200,
    verify: bool = False,
    hold: Sequence[str] = (),
) -> CalibrationResult:
    """Choose flexible-body modal damping so that the system modes have the target damping.

    Parameters
    ----------
    system : CalibrationSystem or callable
        The assembled system, or ``builder(ratios: Mapping[str, ndarray]) -> CalibrationSystem``
        (called with the starting ratios, and with the result when ``verify``).
    design : DampingDesign
        Design variables and fixed ratios.
    target : ModalModel
        Identified modes (``frequency_hz``, ``damping_ratio``, optional ``shape`` whose
        channel names match ``system.sensors``).
    x0 : array_like, optional
        Start (fractions); default ``prior``.
    prior : float or array_like, optional
        Regularisation target; default the mean target damping ratio.
    regularization : float
        ``alpha`` of the Tikhonov rows ``alpha (x - prior)`` (see module docstring); 0 switches
        it off.
    weights : array_like, shape (n_target,), optional
        Residual weight per target mode (default 1).
    mac_min, freq_tol, freq_weight : float
        Pairing thresholds and cost weight (:func:`pair_modes`).
    max_pairings : int
        Largest number of least-squares solves (re-pairing loop).
    max_evaluations : int
        Eigen-solve budget per least-squares solve.
    verify : bool
        Rebuild with the chosen damping (needs a builder) and compare the damped modes with
        Exudyn's ``ComputeODE2Eigenvalues``.
    hold : sequence of str
        Sensors whose measured displacement is held at zero in the model's modes
        (:meth:`LinearisedSystem.held`): the EMA's reference, when the target was identified
        from transmissibilities. Default none.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    InputError
        No target mode can be paired with a model mode (e.g. none in the model's band),
        start/prior outside [0, 1), wrong weights.
    """
    with _single_threaded_blas():
        t_start = time.perf_counter()
        builder = None if isinstance(system, CalibrationSystem) else system
        prior_v, x_start, w_t = _checked_start(design, target, x0, prior, weights, regularization)
        if verify and hold:
            raise InputError("verify=True compares with Exudyn's eigenvalues of the system as built; "
                             "it cannot check a calibration with held sensors (hold=...)")
        if builder is not None:
            system = builder(design.ratios(x_start))
            if not isinstance(system, CalibrationSystem):
                raise InputError("builder: expected it to return a CalibrationSystem")
        t_lin = time.perf_counter()
        lin = linearise_design(system, design).held(hold)
        t_lin = time.perf_counter() - t_lin
        pairer = _Pairer(target, lin.sensor_names, mac_min, freq_tol, freq_weight)
        evaluate = _Evaluations(lin)
        x, modes, band_idx, pairing, n_pairings, success, message = _solve(
            evaluate, pairer, design, x_start, prior_v, w_t, float(regularization), max_pairings,
            max_evaluations)
        rows = _mode_rows(modes, band_idx, pairing, pairer.tf, pairer.tz)
        ratios = design.ratios(np.clip(x, design.lower, design.upper))
        check = None
        if verify:
            if builder is None:
                raise InputError("verify=True needs a builder (a callable), not an already built system")
            check = _exudyn_damping_check(builder(ratios).mbs, modes, band_idx)
        settings = {
            "regularization": float(regularization),
            "prior": prior_v.tolist(),
            "mac_min": mac_min,
            "freq_tol": freq_tol,
            "freq_weight": freq_weight,
            "band_hz": list(pairer.band),
            "channels": list(pairer.channels),
            "n_coordinates": lin.size,
            "n_variables": design.n_variables,
            "n_targets": int(pairer.tf.size),
            "held_sensors": list(hold),
        }
        result = CalibrationResult(
            rows=tuple(rows),
            variable_names=design.variable_names,
            variables=np.asarray(x, float),
            body_damping=ratios,
            body_frequencies_hz=dict(design.body_frequencies_hz),
            design_mask={b: a >= 0 for b, a in design.assignment.items()},
            success=success,
            message=message,
            n_evaluations=evaluate.count,
            n_pairings=n_pairings,
            wall_time_s=time.perf_counter() - t_start,
            linearise_time_s=t_lin,
            evaluation_time_s=evaluate.seconds / max(evaluate.count, 1),
            exudyn_check=check,
            settings=settings,
        )
        log.info(
            "calibration: %d paired, max error %.2e, %d evaluations, %.2f s",
            len(result.paired),
            result.max_abs_error,
            evaluate.count,
            result.wall_time_s,
        )
        return result


def _checked_start(design: DampingDesign, target: ModalModel, x0, prior, weights, regularization):
    """Return the prior, the start (both clipped to the bounds) and the per-target weights, checked."""
    _, tz, _, _ = _target_arrays(target, ())
    prior_v = (
        np.full(design.n_variables, float(np.mean(tz)))
        if prior is None
        else np.broadcast_to(np.asarray(prior, float), (design.n_variables,)).copy()
    )
    validate_ratios(prior_v, "prior damping ratio")
    prior_v = np.clip(prior_v, design.lower, design.upper)
    x_start = (
        prior_v.copy()
        if x0 is None
        else validate_ratios(np.asarray(x0, float).ravel(), "start damping ratio")
    )
    if x_start.size != design.n_variables:
        raise InputError(f"x0 has {x_start.size} values; the design has {design.n_variables} variables")
    x_start = np.clip(x_start, design.lower, design.upper)
    w_t = np.ones(tz.size) if weights is None else np.asarray(weights, float).ravel()
    if w_t.size != tz.size or not np.all(np.isfinite(w_t)) or np.any(w_t < 0):
        raise InputError(f"weights: expected {tz.size} finite values >= 0 (one per target mode)")
    if regularization < 0 or not math.isfinite(regularization):
        raise InputError(f"regularization={regularization!r}: expected a finite value >= 0")
    return prior_v, x_start, w_t


class _Pairer:
    """Pairs the model's modes in the target's band with the target modes (MAC at shared sensors)."""

    def __init__(self, target: ModalModel, sensor_names, mac_min, freq_tol, freq_weight) -> None:
        self.tf, self.tz, self.channels, self.shapes = _target_arrays(target, sensor_names)
        self.rows = [list(sensor_names).index(c) for c in self.channels]
        self.band = (self.tf.min() / (1 + freq_tol), self.tf.max() * (1 + freq_tol))
        self.mac_min, self.freq_tol, self.freq_weight = mac_min, freq_tol, freq_weight

    def __call__(self, m: DesignModes) -> tuple[np.ndarray, Pairing]:
        band_idx = np.flatnonzero((m.frequency_hz >= self.band[0]) & (m.frequency_hz <= self.band[1]))
        shapes = m.shapes[self.rows][:, band_idx] if self.shapes is not None else None
        p = pair_modes(
            m.frequency_hz[band_idx],
            self.tf,
            shapes,
            self.shapes,
            min_mac=self.mac_min,
            max_frequency_error=self.freq_tol,
            frequency_weight=self.freq_weight,
        )
        return band_idx, p


class _Evaluations:
    """The damped modes with derivatives at one design point, the last one kept, counted and timed."""

    def __init__(self, lin) -> None:
        self.lin = lin
        self.count = 0
        self.seconds = 0.0
        self._key: bytes | None = None
        self._modes: DesignModes | None = None

    def __call__(self, x) -> DesignModes:
        key = np.asarray(x, float).tobytes()
        if key != self._key:
            t0 = time.perf_counter()
            self._modes = self.lin.modes(x, derivatives=True)
            self.seconds += time.perf_counter() - t0
            self.count += 1
            self._key = key
        return self._modes


def _solve(evaluate: _Evaluations, pair: _Pairer, design: DampingDesign, x_start, prior_v, w_t,
           alpha: float, max_pairings: int, max_evaluations: int):
    """Least squares on the paired modes' damping, re-paired after each solve until the pairing holds.

    Returns the design point, its modes, the band's mode indices, the final pairing, the number
    of solves, and the last solve's success and message.
    """
    x = x_start
    modes = evaluate(x)
    band_idx, pairing = pair(modes)
    tf, tz = pair.tf, pair.tz
    if len(pairing) == 0:
        raise InputError(
            f"target: none of its {tf.size} modes ({tf.min():.3g}-{tf.max():.3g} Hz) "
            "pairs with a model mode "
            f"(model modes in {pair.band[0]:.3g}-{pair.band[1]:.3g} Hz: {band_idx.size}; "
            f"mac_min={pair.mac_min}, freq_tol={pair.freq_tol}); is the target in the model's frequency band?"
        )
    eye = np.eye(design.n_variables)
    n_pairings = 0
    message, success = "", False
    seen: list[tuple] = []
    while True:
        n_pairings += 1
        ref_vec = modes.vectors[:, band_idx[pairing.model_index]]
        ref_f = modes.frequency_hz[band_idx[pairing.model_index]]
        t_idx = pairing.target_index
        wt = w_t[t_idx]

        def tracked(m: DesignModes, ref_vec=ref_vec, ref_f=ref_f) -> np.ndarray:
            # the paired modes followed by the MAC of their full eigenvectors (frequencies may cross)
            macs = mac(ref_vec, m.vectors)
            rel = np.abs(m.frequency_hz[None, :] - ref_f[:, None]) / ref_f[:, None]
            _, cols = linear_sum_assignment((1.0 - macs) + pair.freq_weight * rel)
            return cols

        def fun(xv, t_idx=t_idx, wt=wt, tracked=tracked):
            m = evaluate(xv)
            r = wt * (m.damping_ratio[tracked(m)] - tz[t_idx])
            return np.concatenate([r, alpha * (xv - prior_v)]) if alpha > 0 else r

        def jac(xv, wt=wt, tracked=tracked):
            m = evaluate(xv)
            j = wt[:, None] * m.d_damping[tracked(m)]
            return np.vstack([j, alpha * eye]) if alpha > 0 else j

        sol = least_squares(
            fun,
            x,
            jac=jac,
            bounds=(design.lower, design.upper),
            method="trf",
            ftol=1e-14,
            xtol=1e-14,
            gtol=1e-14,
            max_nfev=max_evaluations,
        )
        x = sol.x
        success, message = bool(sol.success), str(sol.message)
        modes = evaluate(x)
        tracked_cols = tracked(modes)
        band_idx, new = pair(modes)
        key = (tuple(band_idx[new.model_index]), tuple(new.target_index))
        old = (tuple(tracked_cols), tuple(t_idx))
        if key == old or n_pairings >= max_pairings or key in seen:
            return x, modes, band_idx, new, n_pairings, success, message
        log.info("re-pairing after solve %d: %s -> %s", n_pairings, old, key)
        seen.append(old)
        pairing = new


def _mode_rows(modes: DesignModes, band_idx, pairing: Pairing, tf, tz) -> list[ModeRow]:
    """One row per model mode in the band (with its target partner) and per unpaired target mode."""
    rows: list[ModeRow] = []
    paired_by_model = dict(zip(pairing.model_index.tolist(), range(len(pairing)), strict=True))
    for j, mi in enumerate(band_idx):
        f_m, z_m = float(modes.frequency_hz[mi]), float(modes.damping_ratio[mi])
        if j in paired_by_model:
            p = paired_by_model[j]
            ti = int(pairing.target_index[p])
            z_t = float(tz[ti])
            rows.append(ModeRow(j + 1, f_m, z_m, float(tf[ti]), z_t, _f(pairing.mac[p]), z_m - z_t))
        else:
            rows.append(ModeRow(j + 1, f_m, z_m, None, None, None, None))
    for ti in pairing.unpaired_target:
        rows.append(ModeRow(None, None, None, float(tf[ti]), float(tz[ti]), None, None))
    rows.sort(key=lambda r: r.frequency_hz if r.frequency_hz is not None else r.target_frequency_hz)
    return rows


def _exudyn_damping_check(mbs, modes: DesignModes, band_idx) -> float | None:
    """Largest damping difference between the band's modes and Exudyn's own damped eigenvalues."""
    f_ex, z_ex = exudyn_damped_modes(mbs)
    diffs = []
    for mi in band_idx:
        k = int(
            np.argmin(
                np.abs(f_ex - modes.frequency_hz[mi]) / modes.frequency_hz[mi]
                + np.abs(z_ex - modes.damping_ratio[mi])
            )
        )
        diffs.append(abs(z_ex[k] - modes.damping_ratio[mi]))
    return float(max(diffs)) if diffs else None
