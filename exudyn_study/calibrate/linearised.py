"""The calibration's linearised system: damping affine in the design variables.

:func:`linearise_design` linearises a :class:`~exudyn_study.calibrate.CalibrationSystem`
once with Exudyn and writes its damping matrix as
``C(x) = damping_fixed + basis @ diag(weight * x[variable]) @ basis.T``; a
:class:`LinearisedSystem` then gives the damped modes for any ``x`` and their derivatives
(:class:`DesignModes`) without another Exudyn call. :func:`exudyn_damped_modes` is
Exudyn's own eigenvalue solution, the check of this one.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from exudyn_study.calibrate.design import DampingDesign
from exudyn_study.calibrate.system import (
    CalibrationSystem,
    _modal_coordinates,
    _reduced_damping,
    _sensor_matrix,
)
from exudyn_study.errors import InputError

log = logging.getLogger(__name__)


TWO_PI = 2.0 * math.pi


#: eigenvalues with |Im| below this fraction of the largest |lambda| are not oscillating modes
_IMAG_RTOL = 1e-9


#: modes below this frequency (Hz) are rigid-body / constraint-drift zeros
_RIGID_HZ = 1e-3


@dataclass(frozen=True, eq=False)
class DesignModes:
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

    def held(self, sensors) -> LinearisedSystem:
        """Return this system with the measured displacement of ``sensors`` held at zero.

        An EMA on transmissibilities (responses over a reference acceleration) sees the poles
        of the structure with its reference point held, not those of the structure on its
        drive: the calibration compares like with like by holding the EMA's reference. The
        admissible motions are the null space ``T`` of the sensors' output rows; mass,
        stiffness, damping and the design basis are projected onto it (``T^T M T``, ...), so
        the damping stays affine in the design variables.

        Parameters
        ----------
        sensors : sequence of str
            Sensor names of :attr:`sensor_names` (empty: the system itself).

        Returns
        -------
        LinearisedSystem

        Raises
        ------
        InputError
            A name that is not a sensor of the system.
        """
        names = list(sensors)
        if not names:
            return self
        missing = [n for n in names if n not in self.sensor_names]
        if missing:
            raise InputError(f"held sensor(s) {missing}: not sensors of the system; it has "
                             f"{list(self.sensor_names)}")
        t = sla.null_space(self.output[[self.sensor_names.index(n) for n in names]])
        return LinearisedSystem(
            mass=t.T @ self.mass @ t, stiffness=t.T @ self.stiffness @ t,
            damping_fixed=t.T @ self.damping_fixed @ t, basis=t.T @ self.basis, weight=self.weight,
            variable=self.variable, output=self.output @ t, sensor_names=self.sensor_names,
            n_variables=self.n_variables)

    def damping_matrix(self, x) -> np.ndarray:
        """System damping matrix ``C(x)`` (null-space coordinates).

        Parameters
        ----------
        x : array_like
            Design vector of shape ``(n_variables,)``: the damping variables (modal damping ratios) that
            scale the variable part of the damping.

        Returns
        -------
        numpy.ndarray
            Damping matrix ``C(x)`` in the null-space coordinates, square of the system's size.
        """
        x = np.asarray(x, float)
        return self.damping_fixed + (self.basis * (self.weight * x[self.variable])) @ self.basis.T

    def modes(self, x, derivatives: bool = False) -> DesignModes:
        """Damped modes for design vector ``x`` (one dense eigen-solve).

        Parameters
        ----------
        x : array_like, shape (n_variables,)
        derivatives : bool
            Also compute the exact derivatives of damping ratio and frequency.

        Returns
        -------
        DesignModes
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
        return DesignModes(
            eigenvalue=lam_k,
            frequency_hz=radius / TWO_PI,
            damping_ratio=-lam_k.real / radius,
            vectors=vec,
            shapes=shapes,
            d_damping=d_zeta,
            d_frequency_hz=d_freq,
        )


def linearise_design(system: CalibrationSystem, design: DampingDesign) -> LinearisedSystem:
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

    Parameters
    ----------
    mbs : exudyn.MainSystem
        Assembled Exudyn system whose damped eigenvalues are computed.

    Returns
    -------
    frequency_hz : numpy.ndarray
        Damped natural frequencies in Hz (absolute value of each eigenvalue over 2 pi), ascending.
    damping_ratio : numpy.ndarray
        Damping ratio of each mode (dimensionless), same shape as ``frequency_hz``.
    """
    values, _ = mbs.ComputeODE2Eigenvalues(computeComplexEigenvalues=True, useAbsoluteValues=False)
    values = np.asarray(values)
    scale = max(np.abs(values).max(), 1.0)
    values = values[(values.imag > _IMAG_RTOL * scale) & (np.abs(values) > TWO_PI * _RIGID_HZ)]
    values = values[np.argsort(np.abs(values))]
    return np.abs(values) / TWO_PI, -values.real / np.abs(values)
