r"""Automatic calibration of flexible-body modal damping against identified system modes.

The thesis (Section 6) chose the modal damping ratio of every free-free flexible-body mode by
hand so that the *assembled* model's damped modes carried the identified damping (Tables 5
and 7), and recommended an optimiser as future work (Sections 8-9). This module is that
optimiser.

Method
------
1. **Design** (:class:`DampingDesign`): which flexible-body modal damping ratios are free.
   Models 1/2: one variable per body mode below a cut-off frequency, a fixed function above
   (the thesis: 100 %); Model 3: one variable per body. Bounds ``[0, MAX_RATIO]``.
2. **Linearise once** (:func:`linearise`): Exudyn's ``ComputeLinearizedSystem`` projected into
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

import json
import logging
import math
import os
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg as sla
from scipy.optimize import least_squares, linear_sum_assignment

from .blas import single_threaded_blas as _single_threaded_blas
from .damping import MAX_RATIO, validate_ratios
from .errors import InputError, StudyError
from .identify.mac import mac
from .identify.model import ModalModel

__all__ = [
    "SensorPoint",
    "CalibrationSystem",
    "DampingDesign",
    "LinearisedSystem",
    "SystemModes",
    "Pairing",
    "ModeRow",
    "CalibrationResult",
    "linearise",
    "pair_modes",
    "calibrate",
    "exudyn_damped_modes",
    "system_from_model",
    "FORMAT_NAME",
]

log = logging.getLogger(__name__)

FORMAT_NAME = "exudyn_study.calibration"
FORMAT_VERSION = 1
TWO_PI = 2.0 * math.pi
#: finite-difference step for the sensor output matrix (coordinates in m, -, sqrt(kg) m)
_FD_STEP = 1e-6
#: eigenvalues with |Im| below this fraction of the largest |lambda| are not oscillating modes
_IMAG_RTOL = 1e-9
#: modes below this frequency (Hz) are rigid-body / constraint-drift zeros
_RIGID_HZ = 1e-3
_INFEASIBLE = 1e6




# ---------------------------------------------------------------------------- the seam


@dataclass(frozen=True)
class SensorPoint:
    """A measuring point: a mesh node of a flexible body and a measuring direction.

    Parameters
    ----------
    body : str
        Name of the flexible body (a key of :attr:`CalibrationSystem.bodies`).
    node : int
        Mesh node index of the body.
    direction : sequence of 3 float
        Measuring direction in global coordinates (normalised on construction).
    """

    body: str
    node: int
    direction: tuple[float, float, float]

    def __post_init__(self) -> None:
        d = np.asarray(self.direction, dtype=float).ravel()
        if d.size != 3 or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
            raise InputError(
                f"sensor on {self.body!r}: direction {self.direction!r}: expected a nonzero 3-vector"
            )
        if int(self.node) < 0:
            raise InputError(f"sensor on {self.body!r}: node {self.node!r}: expected a mesh node index >= 0")
        object.__setattr__(self, "node", int(self.node))
        object.__setattr__(self, "direction", tuple(float(v) for v in d / np.linalg.norm(d)))


@dataclass(frozen=True)
class CalibrationSystem:
    """An assembled Exudyn system with named flexible bodies and sensors.

    Parameters
    ----------
    mbs : exudyn.MainSystem
        Assembled, in the configuration to linearise about (its initial state).
    bodies : mapping str -> exudyn_study.flexbody.FlexibleBodyHandle
        The flexible bodies whose modal damping is calibrated (others may exist in ``mbs``;
        their damping stays as built).
    sensors : mapping str -> SensorPoint
        Measuring points, named like the target's shape channels.
    owner : object, optional
        Whatever must stay alive for ``mbs`` to stay valid (its ``exudyn.SystemContainer``
        or the rig's model object).
    """

    mbs: object
    bodies: Mapping[str, object]
    sensors: Mapping[str, SensorPoint] = field(default_factory=dict)
    owner: object = field(default=None, repr=False, compare=False)


SystemBuilder = Callable[[Mapping[str, np.ndarray]], CalibrationSystem]


# ---------------------------------------------------------------------------- design


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
        Upper bound of every variable (default :data:`~exudyn_study.damping.MAX_RATIO`).

    Notes
    -----
    Use :meth:`per_mode` (Models 1/2) or :meth:`per_body` (Model 3) rather than the
    constructor.
    """

    body_frequencies_hz: Mapping[str, np.ndarray]
    assignment: Mapping[str, np.ndarray]
    fixed_ratios: Mapping[str, np.ndarray]
    variable_names: tuple[str, ...]
    upper: float = MAX_RATIO

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

    @classmethod
    def per_mode(cls, bodies, cutoff_hz: float, above=MAX_RATIO) -> DampingDesign:
        """One variable per body mode below ``cutoff_hz``; a fixed damping above (Models 1/2).

        Parameters
        ----------
        bodies : mapping str -> ndarray or ReducedBody or FlexibleBodyHandle
            Body name -> its mode frequencies (Hz) or an object with ``frequencies_hz``.
        cutoff_hz : float
            Modes with ``f < cutoff_hz`` are design variables.
        above : float or callable
            Ratio of the modes at and above the cut-off, or a damping function of frequency
            (e.g. :func:`exudyn_study.damping.adams_default`). Default: 100 % (clipped to
            :data:`~exudyn_study.damping.MAX_RATIO`), as in the thesis.

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
        """One variable per body, applied to all of its modes (Model 3, thesis Table 6).

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
        """Design vector from per-body ratios (mean over the modes a variable sets)."""
        acc = np.zeros(self.n_variables)
        cnt = np.zeros(self.n_variables)
        for b, a in self.assignment.items():
            r = np.asarray(ratios[b], float).ravel()
            np.add.at(acc, a[a >= 0], r[a >= 0])
            np.add.at(cnt, a[a >= 0], 1.0)
        return acc / cnt


# ---------------------------------------------------------------------------- linearisation


@dataclass(frozen=True, eq=False)
class SystemModes:
    """Damped modes of the linearised system, sorted by frequency.

    Attributes
    ----------
    eigenvalue : ndarray, shape (k,)
        ``lambda`` with ``Im > 0`` (rad/s).
    frequency_hz, damping_ratio : ndarray, shape (k,)
        ``|lambda| / 2 pi`` and ``-Re lambda / |lambda|``.
    vectors : ndarray, shape (n, k)
        Displacement part of the eigenvectors in the constraint null-space coordinates,
        unit norm.
    shapes : ndarray, shape (n_sensors, k)
        Complex shapes at the sensors, largest coefficient scaled to 1.
    d_damping, d_frequency_hz : ndarray, shape (k, n_variables) or None
        Derivatives of damping ratio and frequency with respect to the design variables.
    """

    eigenvalue: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    vectors: np.ndarray
    shapes: np.ndarray
    d_damping: np.ndarray | None = None
    d_frequency_hz: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class LinearisedSystem:
    """Linearised constrained system with a damping matrix affine in the design variables.

    ``C(x) = damping_fixed + basis @ diag(weight * x[variable]) @ basis.T``.

    Attributes
    ----------
    mass, stiffness, damping_fixed : ndarray, shape (n, n)
        In the constraint null-space coordinates.
    basis : ndarray, shape (n, m)
        Null-space columns of the design modal coordinates.
    weight : ndarray, shape (m,)
        ``2 omega`` (rad/s) of each design entry.
    variable : ndarray of int, shape (m,)
        Design variable of each entry.
    output : ndarray, shape (n_sensors, n)
        Sensor displacement per null-space coordinate.
    sensor_names : tuple of str
    n_variables : int
    """

    mass: np.ndarray
    stiffness: np.ndarray
    damping_fixed: np.ndarray
    basis: np.ndarray
    weight: np.ndarray
    variable: np.ndarray
    output: np.ndarray
    sensor_names: tuple[str, ...]
    n_variables: int
    _minv_k: np.ndarray = field(init=False, repr=False)
    _minv_c0: np.ndarray = field(init=False, repr=False)
    _minv_b: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        factor = sla.cho_factor(self.mass)
        object.__setattr__(self, "_minv_k", sla.cho_solve(factor, self.stiffness))
        object.__setattr__(self, "_minv_c0", sla.cho_solve(factor, self.damping_fixed))
        object.__setattr__(self, "_minv_b", sla.cho_solve(factor, self.basis))

    @property
    def size(self) -> int:
        """Number of independent coordinates ``n``."""
        return self.mass.shape[0]

    def damping_matrix(self, x) -> np.ndarray:
        """System damping matrix ``C(x)`` (null-space coordinates)."""
        x = np.asarray(x, float)
        return self.damping_fixed + (self.basis * (self.weight * x[self.variable])) @ self.basis.T

    def modes(self, x, derivatives: bool = False) -> SystemModes:
        """Damped modes for design vector ``x`` (one dense eigen-solve).

        Parameters
        ----------
        x : array_like, shape (n_variables,)
        derivatives : bool
            Also compute the exact derivatives of damping ratio and frequency.

        Returns
        -------
        SystemModes
        """
        x = np.asarray(x, float)
        n = self.size
        gain = self.weight * x[self.variable]
        minv_c = self._minv_c0 + (self._minv_b * gain) @ self.basis.T
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -self._minv_k
        a[n:, n:] = -minv_c
        if derivatives:
            lam, left, right = sla.eig(a, left=True, right=True, check_finite=False)
        else:
            lam, right = sla.eig(a, check_finite=False)
        scale = max(np.abs(lam).max(), 1.0)
        keep = (lam.imag > _IMAG_RTOL * scale) & (np.abs(lam) > TWO_PI * _RIGID_HZ)
        idx = np.flatnonzero(keep)
        idx = idx[np.argsort(np.abs(lam[idx]))]
        lam_k = lam[idx]
        radius = np.abs(lam_k)
        vec = right[:n, idx]
        vec = vec / np.linalg.norm(vec, axis=0)
        shapes = self.output @ vec
        if shapes.size:
            big = shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])]
            shapes = shapes / np.where(np.abs(big) > 0, big, 1.0)
        d_zeta = d_freq = None
        if derivatives:
            v = right[:, idx]
            w = left[:, idx]
            denom = np.einsum("ij,ij->j", w.conj(), v)
            # dA_j v (lower half) = -M^-1 C_j v_velocity ; w^H dA_j v per design entry e:
            proj_w = w[n:].conj().T @ self._minv_b  # (k, m)
            proj_v = (self.basis.T @ v[n:]).T  # (k, m)
            per_entry = -(proj_w * proj_v) * self.weight  # (k, m)
            d_lam = np.zeros((idx.size, self.n_variables), complex)
            np.add.at(d_lam.T, self.variable, per_entry.T)
            d_lam /= denom[:, None]
            re, im = lam_k.real[:, None], lam_k.imag[:, None]
            r = radius[:, None]
            d_r = (re * d_lam.real + im * d_lam.imag) / r
            d_zeta = -(d_lam.real * r - re * d_r) / r**2
            d_freq = d_r / TWO_PI
        return SystemModes(
            eigenvalue=lam_k,
            frequency_hz=radius / TWO_PI,
            damping_ratio=-lam_k.real / radius,
            vectors=vec,
            shapes=shapes,
            d_damping=d_zeta,
            d_frequency_hz=d_freq,
        )


def _reduced_damping(mbs, handle) -> np.ndarray:
    """Return the body's reduced damping matrix as held by Exudyn (dense, modal-node size)."""
    value = mbs.GetObjectParameter(handle.object_number, "dampingMatrixReduced")
    if hasattr(value, "Convert2DenseMatrix"):
        return np.atleast_2d(np.asarray(value.Convert2DenseMatrix(), float))
    if isinstance(value, Mapping):
        n = int(value.get("numberOfRows", 0))
        out = np.zeros((n, n))
        for i, j, v in np.asarray(value.get("triplets", []), float).reshape(-1, 3):
            out[int(i), int(j)] += v
        return out
    return np.atleast_2d(np.asarray(value, float))


def _modal_coordinates(mbs, handle) -> np.ndarray:
    """Return the global ODE2 indices of the modal node; the body's flexible modes are the last ``n_modes``.

    (An FFRF body's modal node holds its flexible modes only; the rig's linear CMS body
    puts six rigid-body modes first.)
    """
    import exudyn as exu

    count = len(np.atleast_1d(mbs.GetNodeOutput(handle.modal_node, exu.OutputVariableType.Coordinates)))
    if count < handle.body.n_modes:
        raise InputError(
            f"body {handle.body.name!r}: modal node has {count} coordinates < {handle.body.n_modes} modes"
        )
    return mbs.GetNodeODE2Index(handle.modal_node) + np.arange(count)


def _sensor_matrix(mbs, bodies, sensors: Mapping[str, SensorPoint]) -> np.ndarray:
    """Linearised sensor displacements per ODE2 coordinate, by central differences in Exudyn."""
    import exudyn as exu

    cur = exu.ConfigurationType.Current
    pos_type = exu.OutputVariableType.Position
    q0 = np.array(mbs.systemData.GetODE2Coordinates(configuration=cur), float)
    out = np.zeros((len(sensors), q0.size))
    names = list(sensors)
    by_body: dict[str, list[int]] = {}
    for k, s in enumerate(sensors.values()):
        by_body.setdefault(s.body, []).append(k)
    try:
        for body, rows in by_body.items():
            h = bodies[body]
            coords = []
            for node in (h.rigid_node, h.modal_node):
                start = mbs.GetNodeODE2Index(node)
                count = len(np.atleast_1d(mbs.GetNodeOutput(node, exu.OutputVariableType.Coordinates)))
                coords.extend(range(start, start + count))
            for c in coords:
                col = []
                for sign in (1.0, -1.0):
                    q = q0.copy()
                    q[c] += sign * _FD_STEP
                    mbs.systemData.SetODE2Coordinates(q, configuration=cur)
                    col.append(
                        [
                            mbs.GetObjectOutputSuperElement(
                                h.object_number, pos_type, sensors[names[k]].node, configuration=cur
                            )
                            for k in rows
                        ]
                    )
                diff = (np.asarray(col[0], float) - np.asarray(col[1], float)) / (2 * _FD_STEP)
                for j, k in enumerate(rows):
                    out[k, c] = diff[j] @ np.asarray(sensors[names[k]].direction)
    finally:
        mbs.systemData.SetODE2Coordinates(q0, configuration=cur)
    return out


def linearise(system: CalibrationSystem, design: DampingDesign) -> LinearisedSystem:
    """Linearise ``system`` once and split its damping into fixed and design parts.

    Parameters
    ----------
    system : CalibrationSystem
        Assembled Exudyn system; linearised about its current (= initial) configuration.
    design : DampingDesign
        Every body of the design must be in ``system.bodies`` with the same number of modes.

    Returns
    -------
    LinearisedSystem

    Raises
    ------
    InputError
        A design body is missing from the system, has a different number of modes, or a
        sensor names an unknown body or node.
    """
    import exudyn as exu

    mbs = system.mbs
    for b, f in design.body_frequencies_hz.items():
        if b not in system.bodies:
            raise InputError(f"design body {b!r} is not in the system; it has {sorted(system.bodies)}")
        if system.bodies[b].body.n_modes != f.size:
            raise InputError(
                f"design body {b!r}: {f.size} modes in the design, "
                f"{system.bodies[b].body.n_modes} in the system"
            )
    for name, s in system.sensors.items():
        if s.body not in system.bodies:
            raise InputError(
                f"sensor {name!r}: body {s.body!r} is not in the system; it has {sorted(system.bodies)}"
            )
        if s.node >= system.bodies[s.body].body.n_nodes:
            raise InputError(
                f"sensor {name!r}: node {s.node} >= {system.bodies[s.body].body.n_nodes} nodes of {s.body!r}"
            )
    if not mbs.systemIsConsistent:
        mbs.Assemble()
    result = mbs.ComputeLinearizedSystem(
        exu.SimulationSettings(), projectIntoConstraintNullspace=True, returnConstraintNullspace=True
    )
    m, k, d = (np.asarray(v, float) for v in result[:3])
    n_full = mbs.systemData.ODE2Size()
    null = np.asarray(result[4], float) if len(result) > 4 and np.size(result[4]) else np.eye(n_full)
    damping = d.copy()
    cols, weight, var = [], [], []
    fixed_cols, fixed_gain = [], []
    for b, handle in system.bodies.items():
        if b not in design.assignment:
            continue  # not calibrated: its damping stays as built
        node_idx = _modal_coordinates(mbs, handle)
        built = _reduced_damping(mbs, handle)
        if built.shape != (node_idx.size, node_idx.size):
            raise InputError(
                f"body {b!r}: damping matrix {built.shape} does not match "
                f"its {node_idx.size} modal coordinates"
            )
        nn = null[:, node_idx]
        damping -= nn @ built @ nn.T  # remove what the builder set
        nb = nn[:, node_idx.size - handle.body.n_modes :]
        omega2 = 2.0 * TWO_PI * design.body_frequencies_hz[b]
        a = design.assignment[b]
        free = a >= 0
        cols.append(nb[:, free])
        weight.append(omega2[free])
        var.append(a[free])
        fixed_cols.append(nb[:, ~free])
        fixed_gain.append(omega2[~free] * design.fixed_ratios[b][~free])
    fc = np.concatenate(fixed_cols, axis=1)
    damping += (fc * np.concatenate(fixed_gain)) @ fc.T
    output = (
        _sensor_matrix(mbs, system.bodies, system.sensors) @ null.T
        if system.sensors
        else np.zeros((0, m.shape[0]))
    )
    log.info(
        "linearised: %d coordinates (%d before constraints), %d design entries",
        m.shape[0],
        n_full,
        sum(map(len, var)),
    )
    return LinearisedSystem(
        mass=0.5 * (m + m.T),
        stiffness=k,
        damping_fixed=damping,
        basis=np.concatenate(cols, axis=1),
        weight=np.concatenate(weight),
        variable=np.concatenate(var).astype(int),
        output=output,
        sensor_names=tuple(system.sensors),
        n_variables=design.n_variables,
    )


def exudyn_damped_modes(mbs) -> tuple[np.ndarray, np.ndarray]:
    """Exudyn's own damped eigen-analysis: (frequency_hz, damping_ratio), sorted by frequency.

    ``ComputeODE2Eigenvalues(computeComplexEigenvalues=True)`` with constraints projected;
    conjugates, overdamped (real) pairs and rigid-body zeros removed. The reference the
    linear damping basis is checked against.
    """
    values, _ = mbs.ComputeODE2Eigenvalues(computeComplexEigenvalues=True, useAbsoluteValues=False)
    values = np.asarray(values)
    scale = max(np.abs(values).max(), 1.0)
    values = values[(values.imag > _IMAG_RTOL * scale) & (np.abs(values) > TWO_PI * _RIGID_HZ)]
    values = values[np.argsort(np.abs(values))]
    return np.abs(values) / TWO_PI, -values.real / np.abs(values)


# ---------------------------------------------------------------------------- pairing


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
    mac_min: float = 0.5,
    freq_tol: float = 0.3,
    freq_weight: float = 1.0,
) -> Pairing:
    """Pair model modes to target modes by MAC and frequency (Hungarian assignment).

    Parameters
    ----------
    model_frequency_hz : array_like, shape (n_model,)
    target_frequency_hz : array_like, shape (n_target,)
    model_shapes, target_shapes : ndarray, shape (n_dof, n_model) / (n_dof, n_target), optional
        Shapes at the same DOFs. Without them (either None or no DOF) pairing is by frequency.
    mac_min : float
        Smallest MAC of an admissible pair.
    freq_tol : float
        Largest relative frequency difference ``|f_m - f_t| / f_t`` of an admissible pair.
    freq_weight : float
        Weight of the relative frequency difference against ``1 - MAC`` in the cost.

    Returns
    -------
    Pairing
    """
    fm = np.asarray(model_frequency_hz, float).ravel()
    ft = np.asarray(target_frequency_hz, float).ravel()
    rel = np.abs(fm[:, None] - ft[None, :]) / ft[None, :]
    use_shapes = model_shapes is not None and target_shapes is not None and np.shape(model_shapes)[0] > 0
    if use_shapes:
        macs = mac(model_shapes, target_shapes)
        cost = (1.0 - macs) + freq_weight * rel
        bad = (macs < mac_min) | (rel > freq_tol)
    else:
        macs = np.full(rel.shape, np.nan)
        cost = rel.copy()
        bad = rel > freq_tol
    cost[bad] = _INFEASIBLE
    pm, pt = (np.array([], int), np.array([], int)) if cost.size == 0 else linear_sum_assignment(cost)
    ok = cost[pm, pt] < _INFEASIBLE if cost.size else np.array([], bool)
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


# ---------------------------------------------------------------------------- result


@dataclass(frozen=True)
class ModeRow:
    """One row of the Tables 5/7 analogue (ratios as fractions; None where not applicable).

    Attributes
    ----------
    mode : int or None
        Model mode number in the band (1-based), None for an unpaired target.
    frequency_hz, damping_ratio : float or None
        Achieved model mode.
    target_frequency_hz, target_damping_ratio : float or None
        Paired target mode (None for an unpaired model mode).
    mac : float or None
        MAC of the pair at the shared sensors (None without shapes).
    error : float or None
        ``damping_ratio - target_damping_ratio``.
    """

    mode: int | None
    frequency_hz: float | None
    damping_ratio: float | None
    target_frequency_hz: float | None
    target_damping_ratio: float | None
    mac: float | None
    error: float | None


def _f(v):
    return None if v is None or not np.isfinite(v) else float(v)


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """Outcome of :func:`calibrate`: the Tables 5/7 analogue and the chosen body damping.

    Attributes
    ----------
    rows : tuple of ModeRow
        Model modes in the band (paired or not) and unpaired targets, by frequency.
    variable_names : tuple of str
    variables : ndarray
        Chosen design variables (fractions).
    body_damping : mapping str -> ndarray
        Chosen damping ratio of every mode of every calibrated body.
    body_frequencies_hz : mapping str -> ndarray
    design_mask : mapping str -> ndarray of bool
        Which body modes were design variables (the others fixed).
    success : bool
    message : str
    n_evaluations : int
        Eigen-solves (residual and Jacobian share one).
    n_pairings : int
        Least-squares solves (a new one whenever re-pairing changed the pairs).
    wall_time_s : float
        Calibration time, linearisation included.
    linearise_time_s, evaluation_time_s : float
        Time of the one linearisation and mean time of one eigen-solve with derivatives.
    exudyn_check : float or None
        With ``verify=True``: largest |damping ratio difference| between the linear basis
        and Exudyn's eigenvalues of the system rebuilt with the chosen damping.
    settings : mapping
    """

    rows: tuple[ModeRow, ...]
    variable_names: tuple[str, ...]
    variables: np.ndarray
    body_damping: Mapping[str, np.ndarray]
    body_frequencies_hz: Mapping[str, np.ndarray]
    design_mask: Mapping[str, np.ndarray]
    success: bool
    message: str
    n_evaluations: int
    n_pairings: int
    wall_time_s: float
    linearise_time_s: float
    evaluation_time_s: float
    exudyn_check: float | None
    settings: Mapping

    @property
    def paired(self) -> tuple[ModeRow, ...]:
        """Rows with both a model and a target mode."""
        return tuple(r for r in self.rows if r.error is not None)

    @property
    def max_abs_error(self) -> float:
        """Largest |achieved - target| damping ratio over the paired modes (fraction)."""
        return max((abs(r.error) for r in self.paired), default=float("nan"))

    @property
    def unpaired_targets(self) -> tuple[ModeRow, ...]:
        """Target modes no model mode could be paired with."""
        return tuple(r for r in self.rows if r.mode is None)

    @property
    def unpaired_model(self) -> tuple[ModeRow, ...]:
        """Model modes in the band without a target."""
        return tuple(r for r in self.rows if r.mode is not None and r.target_damping_ratio is None)

    def table(self) -> str:
        """Text table (thesis Tables 5/7 layout), ratios in percent."""

        def fmt(v, spec):
            return "-" if v is None else format(v, spec)

        lines = [
            f"{'mode':>4} {'f model Hz':>10} {'zeta %':>7} {'f target Hz':>11} {'target %':>8} "
            f"{'error pp':>8} {'MAC':>5}"
        ]

        def pct(v):
            return None if v is None else 100 * v

        for r in self.rows:
            lines.append(
                f"{fmt(r.mode, '4d'):>4} {fmt(r.frequency_hz, '10.2f'):>10} "
                f"{fmt(pct(r.damping_ratio), '7.3f'):>7} "
                f"{fmt(r.target_frequency_hz, '11.2f'):>11} {fmt(pct(r.target_damping_ratio), '8.3f'):>8} "
                f"{fmt(pct(r.error), '8.4f'):>8} {fmt(r.mac, '5.2f'):>5}"
            )
        return "\n".join(lines)

    def to_dict(self, metadata: Mapping | None = None) -> dict:
        """JSON-ready dict (``format`` 'exudyn_study.calibration'); ratios as fractions.

        Parameters
        ----------
        metadata : mapping, optional
            Free-form, JSON-serialisable (model, target file, ...).
        """
        modes = [
            {
                "mode": r.mode,
                "frequency_hz": r.frequency_hz,
                "damping_ratio": r.damping_ratio,
                "target_frequency_hz": r.target_frequency_hz,
                "target_damping_ratio": r.target_damping_ratio,
                "mac": r.mac,
                "error": r.error,
            }
            for r in self.rows
            if r.mode is not None
        ]
        unpaired = [
            {"target_frequency_hz": r.target_frequency_hz, "target_damping_ratio": r.target_damping_ratio}
            for r in self.unpaired_targets
        ]
        return {
            "format": FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "metadata": dict(metadata or {}),
            "modes": modes,
            "unpaired_targets": unpaired,
            "body_damping": {
                b: {
                    "frequency_hz": self.body_frequencies_hz[b].tolist(),
                    "damping_ratio": np.asarray(r).tolist(),
                    "design_variable": self.design_mask[b].tolist(),
                }
                for b, r in self.body_damping.items()
            },
            "variables": dict(zip(self.variable_names, map(float, self.variables), strict=True)),
            "convergence": {
                "success": bool(self.success),
                "message": self.message,
                "n_evaluations": int(self.n_evaluations),
                "n_pairings": int(self.n_pairings),
                "wall_time_s": float(self.wall_time_s),
                "linearise_time_s": float(self.linearise_time_s),
                "evaluation_time_s": float(self.evaluation_time_s),
                "max_abs_error": _f(self.max_abs_error),
                "exudyn_check": self.exudyn_check,
            },
            "settings": dict(self.settings),
        }

    def to_json(self, metadata: Mapping | None = None) -> str:
        """Serialise :meth:`to_dict` to JSON text."""
        return json.dumps(self.to_dict(metadata), indent=1)

    def write_json(self, path: str | os.PathLike, metadata: Mapping | None = None) -> Path:
        """Write :meth:`to_json` atomically to ``path``; returns the path."""
        path = Path(path)
        text = self.to_json(metadata)
        fd, tmp = tempfile.mkstemp(
            dir=path.parent if str(path.parent) else ".", prefix=".calib-", suffix=".json"
        )
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return path

    def plot(self, path: str | os.PathLike | None = None, max_frequency_hz: float | None = None):
        """Chosen body damping against body mode frequency (like thesis Figure 18).

        Parameters
        ----------
        path : path-like, optional
            Save the figure there (PNG by suffix).
        max_frequency_hz : float, optional
            Right end of the frequency axis (default: 1.5 x the highest design mode, or all).

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib

        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7.5, 4.2))
        design_f = [f[self.design_mask[b]] for b, f in self.body_frequencies_hz.items()]
        top = max((f.max() for f in design_f if f.size), default=None)
        f_all = max(f.max() for f in self.body_frequencies_hz.values())
        all_design = all(m.all() for m in self.design_mask.values())
        fmax = max_frequency_hz or (1.05 * f_all if all_design or not top else min(1.5 * top, 1.05 * f_all))
        for k, (b, f) in enumerate(self.body_frequencies_hz.items()):
            r = 100 * np.asarray(self.body_damping[b])
            dm = self.design_mask[b]
            color = f"C{k % 10}"
            sel = f <= fmax
            ax.plot(f[sel], r[sel], "-", color=color, lw=0.8, alpha=0.6)
            ax.plot(f[dm & sel], r[dm & sel], "o", color=color, label=f"{b} (calibrated)")
            if np.any(~dm & sel):
                ax.plot(f[~dm & sel], r[~dm & sel], "o", mfc="none", color=color, label=f"{b} (fixed)")
        ax.set_xlabel("flexible-body mode frequency (Hz)")
        ax.set_ylabel("modal damping ratio (%)")
        ax.set_xlim(0, fmax)
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(
            f"Calibrated flexible-body damping: {len(self.paired)} paired modes, "
            f"max error {100 * self.max_abs_error:.3f} pp"
        )
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=120)
            plt.close(fig)
        return fig


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
        tf, tz, _, _ = _target_arrays(target, ())
        prior_v = (
            np.full(design.n_variables, float(np.mean(tz)))
            if prior is None
            else np.broadcast_to(np.asarray(prior, float), (design.n_variables,)).copy()
        )
        validate_ratios(prior_v, "prior damping ratio")
        prior_v = np.minimum(prior_v, design.upper)
        x_start = (
            prior_v.copy()
            if x0 is None
            else validate_ratios(np.asarray(x0, float).ravel(), "start damping ratio")
        )
        if x_start.size != design.n_variables:
            raise InputError(f"x0 has {x_start.size} values; the design has {design.n_variables} variables")
        x_start = np.minimum(x_start, design.upper)
        w_t = np.ones(tf.size) if weights is None else np.asarray(weights, float).ravel()
        if w_t.size != tf.size or not np.all(np.isfinite(w_t)) or np.any(w_t < 0):
            raise InputError(f"weights: expected {tf.size} finite values >= 0 (one per target mode)")
        if regularization < 0 or not math.isfinite(regularization):
            raise InputError(f"regularization={regularization!r}: expected a finite value >= 0")

        if builder is not None:
            system = builder(design.ratios(x_start))
            if not isinstance(system, CalibrationSystem):
                raise InputError("builder: expected it to return a CalibrationSystem")
        t_lin = time.perf_counter()
        lin = linearise(system, design)
        t_lin = time.perf_counter() - t_lin
        tf, tz, channels, t_shapes = _target_arrays(target, lin.sensor_names)
        rows_idx = [lin.sensor_names.index(c) for c in channels]
        band = (tf.min() / (1 + freq_tol), tf.max() * (1 + freq_tol))

        def in_band(m: SystemModes) -> np.ndarray:
            return np.flatnonzero((m.frequency_hz >= band[0]) & (m.frequency_hz <= band[1]))

        def pair(m: SystemModes) -> tuple[np.ndarray, Pairing]:
            band_idx = in_band(m)
            shapes = m.shapes[rows_idx][:, band_idx] if t_shapes is not None else None
            p = pair_modes(
                m.frequency_hz[band_idx],
                tf,
                shapes,
                t_shapes,
                mac_min=mac_min,
                freq_tol=freq_tol,
                freq_weight=freq_weight,
            )
            return band_idx, p

        n_eval = 0
        eval_time = 0.0
        cache: dict[bytes, SystemModes] = {}

        def evaluate(x) -> SystemModes:
            nonlocal n_eval, eval_time
            key = np.asarray(x, float).tobytes()
            if key not in cache:
                cache.clear()
                t0 = time.perf_counter()
                cache[key] = lin.modes(x, derivatives=True)
                eval_time += time.perf_counter() - t0
                n_eval += 1
            return cache[key]

        x = x_start
        modes = evaluate(x)
        band_idx, pairing = pair(modes)
        if len(pairing) == 0:
            raise InputError(
                f"target: none of its {tf.size} modes ({tf.min():.3g}-{tf.max():.3g} Hz) "
                "pairs with a model mode "
                f"(model modes in {band[0]:.3g}-{band[1]:.3g} Hz: {band_idx.size}; mac_min={mac_min}, "
                f"freq_tol={freq_tol}); is the target in the model's frequency band?"
            )
        alpha = float(regularization)
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

            def tracked(m: SystemModes, ref_vec=ref_vec, ref_f=ref_f) -> np.ndarray:
                macs = mac(ref_vec, m.vectors)
                rel = np.abs(m.frequency_hz[None, :] - ref_f[:, None]) / ref_f[:, None]
                _, cols = linear_sum_assignment((1.0 - macs) + freq_weight * rel)
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
                bounds=(0.0, design.upper),
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
                pairing = new
                break
            log.info("re-pairing after solve %d: %s -> %s", n_pairings, old, key)
            seen.append(old)
            pairing = new

        # ---- table
        rows: list[ModeRow] = []
        paired_by_model = dict(zip(pairing.model_index.tolist(), range(len(pairing)), strict=True))
        for j, mi in enumerate(band_idx):
            f_m, z_m = float(modes.frequency_hz[mi]), float(modes.damping_ratio[mi])
            if j in paired_by_model:
                p = paired_by_model[j]
                ti = int(pairing.target_index[p])
                rows.append(
                    ModeRow(
                        j + 1, f_m, z_m, float(tf[ti]), float(tz[ti]), _f(pairing.mac[p]), z_m - float(tz[ti])
                    )
                )
            else:
                rows.append(ModeRow(j + 1, f_m, z_m, None, None, None, None))
        for ti in pairing.unpaired_target:
            rows.append(ModeRow(None, None, None, float(tf[ti]), float(tz[ti]), None, None))
        rows.sort(key=lambda r: r.frequency_hz if r.frequency_hz is not None else r.target_frequency_hz)

        ratios = design.ratios(np.clip(x, 0.0, design.upper))
        check = None
        if verify:
            if builder is None:
                raise InputError("verify=True needs a builder (a callable), not an already built system")
            f_ex, z_ex = exudyn_damped_modes(builder(ratios).mbs)
            diffs = []
            for mi in band_idx:
                k = int(
                    np.argmin(
                        np.abs(f_ex - modes.frequency_hz[mi]) / modes.frequency_hz[mi]
                        + np.abs(z_ex - modes.damping_ratio[mi])
                    )
                )
                diffs.append(abs(z_ex[k] - modes.damping_ratio[mi]))
            check = float(max(diffs)) if diffs else None
        settings = {
            "regularization": alpha,
            "prior": prior_v.tolist(),
            "mac_min": mac_min,
            "freq_tol": freq_tol,
            "freq_weight": freq_weight,
            "band_hz": list(band),
            "channels": list(channels),
            "n_coordinates": lin.size,
            "n_variables": design.n_variables,
            "n_targets": int(tf.size),
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
            n_evaluations=n_eval,
            n_pairings=n_pairings,
            wall_time_s=time.perf_counter() - t_start,
            linearise_time_s=t_lin,
            evaluation_time_s=eval_time / max(n_eval, 1),
            exudyn_check=check,
            settings=settings,
        )
        log.info(
            "calibration: %d paired, max error %.2e, %d evaluations, %.2f s",
            len(result.paired),
            result.max_abs_error,
            n_eval,
            result.wall_time_s,
        )
        return result


# ---------------------------------------------------------------------------- rig adapter

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def system_from_model(model) -> CalibrationSystem:
    """Adapt a rig model (``exudyn_study.model.build_model``) to a :class:`CalibrationSystem`.

    Expects ``model.mbs`` (assembled), ``model.bodies`` (name -> FlexibleBodyHandle) and
    ``model.sensors`` (name -> object with a body name ``body``/``component``, a mesh node
    ``node``/``mesh_node``/``node_index`` and a ``direction`` given as a 3-vector or
    'X'/'Y'/'Z'). Sensors that do not fit are skipped with a log message.

    Raises
    ------
    StudyError
        If the model lacks ``mbs`` or ``bodies``.
    """
    for attr in ("mbs", "bodies"):
        if not hasattr(model, attr):
            raise StudyError(f"model has no {attr!r}; calibration needs model.mbs and model.bodies")
    sensors = {}
    for name, s in dict(getattr(model, "sensors", {}) or {}).items():
        if isinstance(s, SensorPoint):
            sensors[name] = s
            continue
        body = next((getattr(s, a) for a in ("body", "component") if hasattr(s, a)), None)
        node = next((getattr(s, a) for a in ("node", "mesh_node", "node_index") if hasattr(s, a)), None)
        direction = getattr(s, "direction", None)
        if isinstance(direction, str):
            direction = _AXES.get(direction.upper())
        if body in model.bodies and node is not None and direction is not None:
            sensors[name] = SensorPoint(str(body), int(node), tuple(direction))
        else:
            log.info("sensor %r skipped for calibration shapes (no body/node/direction)", name)
    return CalibrationSystem(model.mbs, dict(model.bodies), sensors, owner=model)
