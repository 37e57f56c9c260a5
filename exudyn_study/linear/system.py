"""The linearised system: constraint-projected M, C, K with the drive as input and sensors as outputs.

:class:`LinearSystem` is what :func:`exudyn_study.model.linearise` returns and what every
frequency-domain and exact time-domain computation works on; :func:`state_space` gives
its first-order form with the drive's cubic-spline coefficients as inputs
(:func:`spline_inputs`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------------------------------- linear path
def spline_inputs(drive) -> np.ndarray:
    """Psi = (u, u', u'', u''') at the spline's knots (u''' of the interval starting there).

    Shape (4, (N - 1) upsampling + 1): the knots of the drive's fine grid (every
    ``drive.upsampling``-th is a sample instant).

    Parameters
    ----------
    drive : exudyn_study.model.Drive
        With its signal set (its spline coefficients and ``spline_rate_hz``).

    Returns
    -------
    ndarray, shape (4, n_knots)
        Displacement (m), velocity (m/s), acceleration (m/s^2) and jerk (m/s^3) at each knot.
    """
    c = drive._coef  # (4, n_knots - 1): c0 dt^3 + c1 dt^2 + c2 dt + c3
    n = c.shape[1] + 1
    psi = np.zeros((4, n))
    psi[0, :-1], psi[1, :-1], psi[2, :-1], psi[3, :-1] = c[3], c[2], 2.0 * c[1], 6.0 * c[0]
    h = 1.0 / drive.spline_rate_hz
    last = c[:, -1]
    psi[0, -1] = ((last[0] * h + last[1]) * h + last[2]) * h + last[3]
    psi[1, -1] = (3.0 * last[0] * h + 2.0 * last[1]) * h + last[2]
    psi[2, -1] = 6.0 * last[0] * h + 2.0 * last[1]
    psi[3, -1] = 6.0 * last[0]
    return psi


def state_space(lin):
    """Return the first-order form ``x' = A x + B psi``, ``y = C x + D psi`` of ``lin``.

    The state is ``x = [z; z']``, the input ``psi = (u, u', u'', u''')`` (:func:`spline_inputs`:
    the drive displacement and its derivatives), the output ``y`` the sensor accelerations
    ``S q''`` (m/s^2), including the rigid drive motion ``S r u''``.

    Parameters
    ----------
    lin : LinearSystem
        The linearised system (``n = lin.size`` independent coordinates).

    Returns
    -------
    a : ndarray, shape (2n, 2n)
        ``A``.
    b : ndarray, shape (2n, 4)
        ``B``; the column of the jerk ``u'''`` is zero.
    c : ndarray, shape (n_sensors, 2n)
        ``C``.
    d : ndarray, shape (n_sensors, 4)
        ``D``.
    """
    n = lin.size
    minv = np.linalg.inv(lin.mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ lin.stiffness, -minv @ lin.damping]])
    b = np.zeros((2 * n, 4))
    b[n:, 0], b[n:, 1], b[n:, 2] = -minv @ lin.b0, -minv @ lin.b1, -minv @ lin.b2
    so = lin.sensor_output  # (n_s, n)
    c = so @ a[n:, :]
    d = np.zeros((so.shape[0], 4))
    d[:, :3] = so @ b[n:, :3]
    d[:, 2] += lin.sensor_drive
    return a, b, c, d


@dataclass(frozen=True)
class LinearSystem:
    """The linearised, constrained model: ``M z'' + C z' + K z = -b2 u'' - b1 u' - b0 u``.

    With ``q = r u + N^T z`` (``q``: Exudyn's ODE2 coordinates, ``u``: drive displacement)
    and ``b_k = N X r`` for ``X = M, C, K``. Sensor accelerations are ``S q''``.

    Attributes
    ----------
    mass, damping, stiffness : ndarray, shape (n, n)
        Projected matrices (SI).
    nullspace : ndarray, shape (n, n_q)
        Rows span the admissible coordinate increments.
    drive_shape : ndarray, shape (n_q,)
        ``r``, coordinates per metre of drive.
    b0, b1, b2 : ndarray, shape (n,)
        Drive forcing vectors (see above).
    sensor_map : ndarray, shape (n_sensors, n_q)
        ``S``.
    sensor_names : tuple of str
    metadata : dict
    full_mass, full_damping, full_stiffness : ndarray, shape (n_q, n_q), or None
        The unprojected matrices in Exudyn's ODE2 coordinates (SI), kept for checks and for
        adding terms before projection; None when not supplied.
    """

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    nullspace: np.ndarray
    drive_shape: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    b2: np.ndarray
    sensor_map: np.ndarray
    sensor_names: tuple
    metadata: dict = field(default_factory=dict)
    full_mass: np.ndarray | None = field(default=None, repr=False)  # unprojected (n_q, n_q)
    full_damping: np.ndarray | None = field(default=None, repr=False)
    full_stiffness: np.ndarray | None = field(default=None, repr=False)

    @property
    def size(self) -> int:
        """Number of independent coordinates ``n``."""
        return self.mass.shape[0]

    @property
    def sensor_output(self) -> np.ndarray:
        """``S N^T``, shape (n_sensors, n): sensor accelerations per unit ``z''``."""
        return self.sensor_map @ self.nullspace.T

    @property
    def sensor_drive(self) -> np.ndarray:
        """``S r``, shape (n_sensors,): sensor accelerations per unit ``u''`` (rigid drive motion)."""
        return self.sensor_map @ self.drive_shape
