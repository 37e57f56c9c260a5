"""Simulate a rig model into a :class:`~exudyn_study.recording.Recording`.

Two paths share one drive (the piston displacement: samples at :data:`OUTPUT_RATE_HZ`,
faded in over ``ramp_s`` so that the model starts at rest and consistent, reconstructed
band-limited on a grid ``upsampling`` times finer and interpolated there by a natural cubic
spline, :class:`~exudyn_study.model.rig.Drive`):

``method='exudyn'`` (:func:`simulate_exudyn`)
    Exudyn's implicit time integration (generalised-alpha) of the assembled model.
    Accelerations of the sensors' mesh nodes are stored at 1000 Hz. Settings are in
    :class:`IntegratorSettings`; the defaults were chosen against the exact linear
    solution (``benchmarks/bench_simulation.py``): numerical damping rho_infinity =
    :data:`CONSTRAINED_SPECTRAL_RADIUS` (the joints and the prescribed drive are index-3
    constraints: without numerical damping their accelerations carry a growing
    step-to-step oscillation, which the 1 kHz output aliased into a drift), a constant
    step of 1/10 ms (the error is the integrator's period error; the same as the
    constraint-free path at the same step), modified Newton with the Jacobian kept and
    a Newton tolerance that the nearly linear problem meets in about two iterations,
    Eigen's sparse LU. The drive is prescribed once per step (a symbolic offset function
    reading a parameter set by the pre-step function) rather than by a Python call in
    every residual evaluation. Speed is mostly the model's: a model built with
    ``element='matrix'`` (constant-matrix flexible bodies,
    :func:`exudyn_study.model.build_model`) integrates Model 1 13x faster per step than
    the default super-element bodies (80 s white noise, one Newton iteration per step:
    92 vs 1216 us CPU per 1/10 ms step, 1.09x real time, 1.9 % max error below 70 Hz;
    ``benchmarks/bench_simulation.py``).

``method='exudyn-reduced'`` (:func:`simulate_exudyn_reduced`)
    Exudyn's generalised-alpha on the *constraint-projected linearisation* of the model
    (one ``ObjectGenericODE2`` with the projected M, C, K and the drive as a force):
    no markers, joints or Newton on constraints, so ~100x cheaper per step than the full
    model, which buys the small step that lightly damped modes need for accuracy.

``method='linear'`` (:func:`simulate_linear`)
    The linearised system of :func:`exudyn_study.modal.linearize` integrated *exactly*:
    within each interval of the drive's fine grid the drive is a cubic, so
    ``psi = (u, u', u'', u''')`` obeys ``psi' = J psi`` and one matrix exponential of the
    augmented system gives the exact discrete map (a generalisation of first-order hold);
    the ``upsampling`` fine intervals of an output interval are summed into one input. The
    state recursion runs mode by mode at the output rate (diagonalised, ``scipy.signal.lfilter``).

:func:`frf_linear` gives the drive -> sensor-acceleration FRFs of the linearised model by
complex modal superposition.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy import signal as sps

from .errors import InputError, SimulationError
from .recording import Recording

__all__ = [
    "OUTPUT_RATE_HZ",
    "DRIVE_RATE_HZ",
    "METHODS",
    "IntegratorSettings",
    "CONSTRAINED_SPECTRAL_RADIUS",
    "newton_absolute_tolerance",
    "REDUCED_STEP_S",
    "prepare_drive",
    "simulate",
    "simulate_exudyn",
    "simulate_exudyn_reduced",
    "simulate_linear",
    "frf_linear",
    "band_limited_rms_error",
    "modal_initial_state",
    "free_decay_linear",
    "log_decrement_damping",
    "estimate_frf",
    "frf_linear_at_resolution",
    "frf_db_error",
]

log = logging.getLogger(__name__)

#: accelerometer sampling rate of the rig (thesis Section 3.3)
OUTPUT_RATE_HZ = 1000.0
#: rate of the drive channel in recordings (the rig controller's 204.8 Hz, thesis Section 7.2)
DRIVE_RATE_HZ = 204.8
METHODS = ("exudyn", "exudyn-reduced", "linear")


#: generalised-alpha spectral radius of the constrained (full-model) path, see :class:`IntegratorSettings`
CONSTRAINED_SPECTRAL_RADIUS = 0.5
#: Newton absolute tolerance / the residual's rounding floor (:func:`newton_absolute_tolerance`)
ROUNDING_FLOOR_FACTOR = 30.0


@dataclass(frozen=True)
class IntegratorSettings:
    """Exudyn time-integration settings.

    Parameters
    ----------
    step_s : float
        Constant time step (s); must divide the output period 1 ms. The default 1/10 ms
        keeps 3 % rms below 70 Hz with a margin on Model 1 (production mesh, modes down
        to 0.4 % damping; 80 s white noise, rho 0.5: 1.9 % max at 1/10 ms, 2.95 % at 1/8 ms):
        the error is the integrator's period error, second order in h
        (``benchmarks/bench_simulation.py``).
    spectral_radius : float or None
        Generalised-alpha rho_infinity (1: trapezoidal rule, no numerical damping).
        None: 1 for the constraint-free linearisation (``'exudyn-reduced'``) and
        :data:`CONSTRAINED_SPECTRAL_RADIUS` for the full model. The full model has index-3
        constraints (the joints and the prescribed drive); with rho_infinity = 1 their
        accelerations carry an undamped oscillation at the step's Nyquist frequency whose
        amplitude grows linearly in time (measured on the mini frame: +-160 m/s^2 after
        0.5 s against a 0.4 m/s^2 response; cf. Arnold & Bruls 2007 on the algebraic
        variables of the scheme), which the 1 kHz output, sampling every (1 ms / h)-th
        step, aliases into a drift when that ratio is even. With rho_infinity 0.5 the full
        path agrees with the constraint-free path at the same step (Model 1 production,
        1/8 ms: 2.44 % vs 2.46 % max error against the exact solution; rho 0.8: 2.78 % vs
        1.73 %). :func:`simulate_exudyn` refuses rho_infinity = 1.
    modified_newton : bool
        Reuse the Jacobian across steps (recomputed only when Newton stalls).
    relative_tolerance : float
        Newton tolerance relative to a step's initial residual. The rig moves by
        fractions of a mm, so one iteration with the kept Jacobian already reduces the
        residual by ~1e-4 (the geometric nonlinearity of the small rotations); 1e-6 costs
        about two iterations per step and changes the accelerations by < 1e-4 relative
        compared with 1e-8 (three iterations).
    single_iteration : bool
        One Newton iteration per step with the kept Jacobian and no convergence check
        (Exudyn's ``newton.active = False``). Valid when every Exudyn item of the model is
        linear in the rig's small motion (the rig, linear CMS bodies, bushings): then the
        one iteration leaves the same ~1e-4 relative residual as the first of the
        converged iterations, and the accelerations are the same (Model 1 production,
        1/8 ms: 2.12 % max error vs the exact solution either way, 1.48x faster). Not for
        user-added nonlinear items (friction, contact, large motion): there the converged
        Newton (the default) is needed.
    absolute_tolerance : float or None
        Newton absolute tolerance (Exudyn's residual norm). None: scale-aware,
        :func:`newton_absolute_tolerance` (the residual's rounding floor grows with
        1 / h^2 and the model's size: a fixed 1e-10 is below it once a stiff connector
        is in the model).
    divergence_limit : float
        Sensor accelerations above this (m/s^2) count as divergence.
    sparse_solver : bool
        Eigen's sparse LU (``EigenSparse``) for Exudyn's Newton systems instead of its dense
        LU (``EXUdense``). A rig model has 150-250 unknowns, most of them coupled only
        locally: the back substitution with the kept factorisation and the product with
        a constant mass matrix are cheaper sparse (Model 1 with constant-matrix bodies,
        ``element='matrix'``: 138 -> 92 us per step; with super-element bodies ~7 %
        faster). The results agree to rounding. (:func:`simulate_exudyn_reduced`, one dense
        object, always uses the dense LU.)

    References
    ----------
    Arnold, M., Bruls, O. (2007). Convergence of the generalized-alpha scheme for
    constrained mechanical systems. Multibody System Dynamics 18, 185-202.
    """

    step_s: float = 1e-4
    spectral_radius: float | None = None
    modified_newton: bool = True
    relative_tolerance: float = 1e-6
    absolute_tolerance: float | None = None
    divergence_limit: float = 1e5
    single_iteration: bool = False
    sparse_solver: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.step_s) and 0 < self.step_s <= 1.0 / OUTPUT_RATE_HZ):
            raise InputError(f"step_s {self.step_s!r}; expected a step in (0, 1 ms]")
        ratio = (1.0 / OUTPUT_RATE_HZ) / self.step_s
        if abs(ratio - round(ratio)) > 1e-9:
            raise InputError(f"step_s {self.step_s!r}: must divide the output period of 1 ms")
        if self.spectral_radius is not None and not 0.0 <= self.spectral_radius <= 1.0:
            raise InputError(f"spectral_radius {self.spectral_radius!r}; expected a value in [0, 1] or None")
        if not (math.isfinite(self.relative_tolerance) and 0 < self.relative_tolerance < 1):
            raise InputError(f"relative_tolerance {self.relative_tolerance!r}; expected a value in (0, 1)")
        if self.absolute_tolerance is not None and not (
                math.isfinite(self.absolute_tolerance) and self.absolute_tolerance > 0):
            raise InputError(f"absolute_tolerance {self.absolute_tolerance!r}; expected a positive value or "
                             "None (scale-aware)")

    def radius(self, constrained: bool) -> float:
        """Return the spectral radius used: the given one or the path's default (``spectral_radius``)."""
        if self.spectral_radius is not None:
            return float(self.spectral_radius)
        return CONSTRAINED_SPECTRAL_RADIUS if constrained else 1.0


def newton_absolute_tolerance(step_s: float, spectral_radius: float, length_scale_m: float = 1.0) -> float:
    """Scale-aware Newton absolute tolerance of Exudyn's generalised-alpha.

    Exudyn's Newton residual contains the position constraints scaled by
    ``1 / (beta h^2)``; their rounding error is ``eps`` times the global coordinates (of the
    order of the model's size ``L``). The residual norm therefore cannot fall below
    ``c eps L / (beta h^2)``: measured on mini Model 3 with bushings, 2.3e-9 at h = 1/4 ms
    and 9.3e-9 at 1/8 ms (``c`` ~ 0.06 with ``L`` = 2.6 m, rho 1). A fixed tolerance of
    1e-10 fails at the first steps, where the drive is still ramping up and the relative
    criterion is out of reach too. The tolerance is :data:`ROUNDING_FLOOR_FACTOR` times
    ``eps L / (beta h^2)``, about 500 times the measured floor, never below 1e-10: 3.9e-6
    at the default 1/10 ms and rho 0.5 for L = 2.6 m, in force units an acceleration
    error of a few 1e-6 m/s^2 on unit modal masses and less on the rig's parts, against
    responses of 1-100 m/s^2.

    Parameters
    ----------
    step_s : float
        Time step (s).
    spectral_radius : float
        Generalised-alpha rho_infinity (sets beta).
    length_scale_m : float
        Largest global coordinate of the model (m).

    Returns
    -------
    float
    """
    rho = float(spectral_radius)
    alpha_m = (2.0 * rho - 1.0) / (rho + 1.0)
    alpha_f = rho / (rho + 1.0)
    gamma = 0.5 - alpha_m + alpha_f
    beta = 0.25 * (gamma + 0.5) ** 2
    floor = np.finfo(float).eps * max(float(length_scale_m), 1.0) / (beta * step_s**2)
    return max(1e-10, ROUNDING_FLOOR_FACTOR * floor)


def _ramp(n: int, rate_hz: float, ramp_s: float) -> np.ndarray:
    """Half-cosine fade-in over ``ramp_s`` (zero value and slope at t = 0)."""
    w = np.ones(n)
    m = min(n, int(round(ramp_s * rate_hz)))
    if m > 1:
        w[:m] = 0.5 - 0.5 * np.cos(np.pi * np.arange(m) / m)
    return w


def prepare_drive(signal="white-noise", duration_s: float = 80.0, rms_m: float | None = None, seed: int = 0,
                  sample_rate_hz: float | None = None, ramp_s: float = 0.25) -> np.ndarray:
    """Drive displacement samples at :data:`OUTPUT_RATE_HZ` (m), faded in.

    Parameters
    ----------
    signal : str or array_like
        A name of :data:`exudyn_study.signals.SIGNALS` ('white-noise', 'test', 'test-50'),
        or drive samples in m (e.g. the drive channel of a measured recording).
    duration_s : float
        Duration for a named signal (s); ignored for samples.
    rms_m : float, optional
        Rms of a named signal (default :data:`exudyn_study.signals.DEFAULT_RMS_M`).
    seed : int
    sample_rate_hz : float, optional
        Rate of given samples: :data:`DRIVE_RATE_HZ` (resampled, anti-aliased) or
        :data:`OUTPUT_RATE_HZ`.
    ramp_s : float
        Fade-in time (s).

    Raises
    ------
    InputError
        Unknown signal name, NaN samples, a rate other than 204.8 or 1000 Hz.
    """
    from .signals import DEFAULT_RMS_M, drive_signal, resample

    if isinstance(signal, str):
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise InputError(f"duration_s {duration_s!r}; expected a positive duration in s")
        x = drive_signal(signal, duration_s, OUTPUT_RATE_HZ, DEFAULT_RMS_M if rms_m is None else rms_m, seed)
    else:
        x = np.asarray(signal, dtype=float).ravel()
        bad = ~np.isfinite(x)
        if bad.any():
            raise InputError(f"drive signal has non-finite samples, the first at index {int(np.flatnonzero(bad)[0])}")
        if sample_rate_hz is None or not any(abs(sample_rate_hz - r) < 1e-9 for r in (DRIVE_RATE_HZ, OUTPUT_RATE_HZ)):
            raise InputError(
                f"drive signal sampled at {sample_rate_hz!r} Hz; expected {DRIVE_RATE_HZ} Hz (the rig's drive "
                f"channel) or {OUTPUT_RATE_HZ} Hz")
        if abs(sample_rate_hz - DRIVE_RATE_HZ) < 1e-9:
            x = resample(x, DRIVE_RATE_HZ, OUTPUT_RATE_HZ)
        if x.size < 8:
            raise InputError(f"drive signal of {x.size} samples; expected a longer signal")
    return x * _ramp(x.size, OUTPUT_RATE_HZ, ramp_s)


# --------------------------------------------------------------------------------------- linear path
def _spline_inputs(drive) -> np.ndarray:
    """psi = (u, u', u'', u''') at the spline's knots (u''' of the interval starting there).

    Shape (4, (N - 1) upsampling + 1): the knots of the drive's fine grid (every
    ``drive.upsampling``-th is a sample instant).
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


def _state_space(lin):
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


def simulate_linear(lin, drive, chunk: int = 8192) -> np.ndarray:
    """Exact sampled sensor accelerations of the linearised model, shape (n_sensors, N).

    Parameters
    ----------
    lin : exudyn_study.modal.LinearSystem
    drive : exudyn_study.model.Drive
        With its signal set; outputs at its sample instants. The input over an output
        interval is the sum of its ``drive.upsampling`` fine cubics, each through the
        exact map of its fine interval.
    chunk : int
        Samples per block (memory bound).
    """
    a, b, c, d = _state_space(lin)
    factor = int(round(drive.spline_rate_hz / drive.sample_rate_hz))
    h = 1.0 / drive.spline_rate_hz
    m2 = a.shape[0]
    big = np.zeros((m2 + 4, m2 + 4))
    big[:m2, :m2], big[:m2, m2:] = a, b
    big[m2, m2 + 1] = big[m2 + 1, m2 + 2] = big[m2 + 2, m2 + 3] = 1.0
    e = sla.expm(big * h)
    gamma = e[:m2, m2:]
    lam, v = sla.eig(a)
    mu = np.exp(lam * h)
    vinv_gamma = np.linalg.solve(v, gamma)
    cv = c @ v
    # complex-conjugate pairs: keep Im >= 0, weight 2 for Im > 0 (the output is real)
    keep = lam.imag >= 0.0
    weight = np.where(lam.imag > 0.0, 2.0, 1.0)[keep]
    mu, vinv_gamma, cv = mu[keep], vinv_gamma[keep], cv[:, keep] * weight
    # over one output interval: xi <- mu^factor xi + sum_j mu^(factor-1-j) V^-1 Gamma psi(fine knot j)
    to_end = mu[:, None] ** np.arange(factor - 1, -1, -1)  # (modes, factor)
    vinv_gamma = (to_end[:, :, None] * vinv_gamma[:, None, :]).reshape(mu.size, factor * 4)
    mu = mu**factor
    psi_fine = _spline_inputs(drive)
    psi = psi_fine[:, ::factor]  # at the output instants
    n_t = psi.shape[1]
    out = np.empty((c.shape[0], n_t))
    xi = np.zeros(mu.size, dtype=complex)
    for k0 in range(0, n_t, chunk):
        k1 = min(n_t, k0 + chunk)
        # psi at the fine knots of each output interval, (L, factor, 4); none after the last sample
        m = min(k1, n_t - 1) - k0
        fine = np.zeros((k1 - k0, factor, 4))
        fine[:m] = psi_fine[:, k0 * factor: (k0 + m) * factor].T.reshape(m, factor, 4)
        g = vinv_gamma @ fine.reshape(k1 - k0, factor * 4).T  # (modes, L)
        states = np.empty_like(g)
        for j in range(mu.size):
            w, _ = sps.lfilter([1.0], [1.0, -mu[j]], g[j], zi=[mu[j] * xi[j]])
            states[j, 0] = xi[j]
            states[j, 1:] = w[:-1]
            xi[j] = w[-1]
        out[:, k0:k1] = (cv @ states).real + d @ psi[:, k0:k1]
    return out


def frf_linear(lin, frequencies_hz) -> np.ndarray:
    """Drive displacement -> sensor acceleration FRFs by complex modal superposition.

    Returns
    -------
    ndarray, complex, shape (n_sensors, 1, n_freq)
        ``H[n_out, n_in, n_freq]`` in (m/s^2)/m.
    """
    f = np.asarray(frequencies_hz, dtype=float)
    a, b, c, d = _state_space(lin)
    lam, v = sla.eig(a)
    g = np.linalg.solve(v, b)
    cv = c @ v
    w = 2.0 * np.pi * f
    s = 1j * w
    psi = np.vstack([np.ones_like(s), s, s**2, s**3])  # (4, n_f)
    modal = (g @ psi) / (s[None, :] - lam[:, None])
    return (cv @ modal + d @ psi)[:, None, :]


# --------------------------------------------------------------------------------------- Exudyn path
def _simulation_settings(settings, duration: float, constrained: bool = True, length_scale_m: float = 1.0):
    """Exudyn settings of a constant-step generalised-alpha run of ``duration`` s.

    Sensors are written at :data:`OUTPUT_RATE_HZ`; no solution file, no console output.
    ``constrained``: the system has algebraic equations (selects the default spectral
    radius); ``length_scale_m``: for the scale-aware absolute tolerance.
    """
    import exudyn as exu

    rho = settings.radius(constrained)
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.startTime, ti.endTime, ti.numberOfSteps = 0.0, duration, int(round(duration / settings.step_s))
    ti.verboseMode = 0
    ti.generalizedAlpha.spectralRadius = rho
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.newton.useModifiedNewton = settings.modified_newton
    ti.newton.active = not settings.single_iteration
    ti.newton.relativeTolerance = settings.relative_tolerance
    ti.newton.absoluteTolerance = (newton_absolute_tolerance(settings.step_s, rho, length_scale_m)
                                   if settings.absolute_tolerance is None else settings.absolute_tolerance)
    ti.adaptiveStep = False
    ss.linearSolver.solverType = (exu.LinearSolverType.EigenSparse if settings.sparse_solver
                                  else exu.LinearSolverType.EXUdense)
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = 1.0 / OUTPUT_RATE_HZ
    ss.show.statistics = False
    ss.show.computationTime = False
    return ss


def _length_scale(model) -> float:
    """Largest global coordinate of the model's flexible-body nodes (m), at least 1."""
    scale = 1.0
    for handle in getattr(model, "bodies", {}).values():
        x = np.asarray(handle.body.node_positions_m, dtype=float) + np.asarray(handle.position_m, dtype=float)
        scale = max(scale, float(np.abs(x).max()))
    return scale


def _checked_stats(out: np.ndarray, settings, mbs, wall: float, cpu: float, duration: float,
                   n_steps: int) -> dict:
    """Raise SimulationError if ``out`` diverged; else the run's timing and Newton statistics."""
    bad = ~np.isfinite(out) | (np.abs(out) > settings.divergence_limit)
    if bad.any():
        k = int(np.flatnonzero(bad.any(axis=0))[0])
        raise SimulationError(
            f"the simulation diverged at t = {k / OUTPUT_RATE_HZ:.4f} s (sensor accelerations non-finite or above "
            f"{settings.divergence_limit:g} m/s^2); try a smaller step")
    stats = {"wall_s": wall, "cpu_s": cpu, "real_time_factor": duration / wall if wall > 0 else float("inf"),
             "cpu_real_time_factor": duration / cpu if cpu > 0 else float("inf"), "steps": n_steps}
    solver = mbs.sys.get("dynamicSolver")
    if solver is not None:
        stats.update(newton_iterations=int(solver.it.newtonStepsCount), jacobians=int(solver.it.newtonJacobiCount))
    return stats


def simulate_exudyn(model, drive_samples: np.ndarray, settings: IntegratorSettings = IntegratorSettings(),
                    progress: bool = False) -> tuple[np.ndarray, dict]:
    """Integrate the model in Exudyn; sensor accelerations at 1000 Hz, shape (n_sensors, N).

    Parameters
    ----------
    model : exudyn_study.model.Model
        Assembled here if needed (sensors were added by the builder).
    drive_samples : ndarray
        Drive at :data:`OUTPUT_RATE_HZ` (see :func:`prepare_drive`).
    settings : IntegratorSettings
    progress : bool
        Show a tqdm bar (simulated seconds).

    Returns
    -------
    accelerations : ndarray, shape (n_sensors, N)
    stats : dict
        'wall_s', 'cpu_s' (process CPU time: the figure on one core when the machine is
        shared), 'real_time_factor', 'cpu_real_time_factor' (simulated s per wall / CPU
        s), 'steps', 'newton_iterations', 'jacobians'.

    Raises
    ------
    InputError
        ``spectral_radius`` 1 on a model with constraints (see :class:`IntegratorSettings`).
    SimulationError
        When Exudyn fails or the response diverges (non-finite or above
        ``settings.divergence_limit``), with the time it happened.
    """
    import exudyn as exu

    drive_samples = np.asarray(drive_samples, dtype=float)
    model.drive.set_signal(drive_samples, OUTPUT_RATE_HZ)
    if not model.assembled:
        model.assemble()
    mbs = model.mbs
    n_ae = int(mbs.systemData.AEsize())
    if n_ae and settings.radius(True) >= 1.0:
        raise InputError(
            f"spectral_radius {settings.spectral_radius!r} with the model's {n_ae} constraint equations: "
            "without numerical damping the accelerations of the constrained system oscillate from step to "
            f"step with a growing amplitude; use spectral_radius <= {CONSTRAINED_SPECTRAL_RADIUS} (or None "
            "for the default) or method='exudyn-reduced'")
    duration = (drive_samples.size - 1) / OUTPUT_RATE_HZ
    ss = _simulation_settings(settings, duration, constrained=n_ae > 0, length_scale_m=_length_scale(model))
    n_steps = ss.timeIntegration.numberOfSteps
    actions = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=int(duration), unit="s", desc="exudyn", disable=None)
        state = {"next": 1.0}

        def show_progress(t):
            if t >= state["next"]:
                bar.update(1)
                state["next"] += 1.0

        actions.append(show_progress)
    restore_drive = _drive_offsets_per_step(model, settings.step_s, n_steps, actions)
    previous = mbs.GetPreStepUserFunction()
    if actions:
        def pre_step(mbs_, t):
            keep_going = True if previous == 0 else previous(mbs_, t)
            for action in actions:
                action(t)
            return keep_going

        mbs.SetPreStepUserFunction(pre_step)
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        mbs.SolveDynamic(ss, solverType=exu.DynamicSolverType.GeneralizedAlpha, storeSolver=True)
    except Exception as exc:  # Exudyn raises its own error types (SolverError, RuntimeError)
        t_fail = float(mbs.systemData.GetTime())
        raise SimulationError(f"Exudyn time integration failed at t = {t_fail:.4f} s: {exc}") from None
    finally:
        if bar is not None:
            bar.close()
        if actions:
            mbs.SetPreStepUserFunction(previous)
        restore_drive()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    names = list(model.sensors)
    out = np.empty((len(names), drive_samples.size))
    cache = {}
    for i, name in enumerate(names):
        att = model.sensors[name]
        if att.exudyn_sensor not in cache:
            data = np.asarray(mbs.GetSensorStoredData(att.exudyn_sensor))
            cache[att.exudyn_sensor] = data
        data = cache[att.exudyn_sensor]
        if data.shape[0] < drive_samples.size:
            raise SimulationError(
                f"sensor {name}: {data.shape[0]} samples stored, expected {drive_samples.size}")
        coordinate_map = getattr(att, "coordinate_map", None)
        if coordinate_map is None:
            out[i] = data[: drive_samples.size, 1:4] @ att.direction
        else:  # coordinate accelerations of a constant-matrix body
            out[i] = data[: drive_samples.size, 1:] @ (att.direction @ coordinate_map)
    return out, _checked_stats(out, settings, mbs, wall, cpu, duration, n_steps)


def _drive_offsets_per_step(model, step_s: float, n_steps: int, actions: list):
    """Prescribe the drive once per step instead of by a Python offset function in every residual.

    The drive joint's Python ``offsetUserFunction`` (called four times per step, ~20 % of
    a step of the constant-matrix Model 1) is replaced for the run by a symbolic
    (C++) function returning its ``offsetUserFunctionParameters``; an entry added to
    ``actions`` (run by the pre-step function, at the step's end time ``t_n+1``, where
    generalised-alpha enforces the constraints) sets that parameter to the drive at
    ``t_n+1``, taken from the drive evaluated once at all step times. The results are the
    same to rounding. Does nothing if the drive joint is not an ``ObjectJointGeneric`` with
    a Python offset function. Returns the function that restores the joint.
    """
    mbs = model.mbs
    joint = getattr(model.drive, "joint", None)
    if joint is None or mbs.GetObject(joint).get("objectType") != "JointGeneric":
        return lambda: None
    previous = mbs.GetObjectParameter(joint, "offsetUserFunction")
    if not (isinstance(previous, dict) and previous.get("type") == "Python"):
        return lambda: None
    from exudyn.advancedUtilities import CreateSymbolicUserFunction

    axis = int(model.drive.axis)

    def offset(mbs_, t, item_number, offsetUserFunctionParameters):  # noqa: N803 (Exudyn's argument name)
        return [offsetUserFunctionParameters[i] for i in range(6)]

    values = np.asarray(model.drive.evaluate(np.arange(n_steps + 1) * step_s), dtype=float)
    parameters = [0.0] * 6
    parameters[axis] = float(values[0])
    mbs.SetObjectParameter(joint, "offsetUserFunctionParameters", parameters)
    mbs.SetObjectParameter(joint, "offsetUserFunction", CreateSymbolicUserFunction(
        mbs, offset, "offsetUserFunction", joint))
    last = values.size - 1

    def set_offset(t):
        parameters[axis] = values[min(int(round(t / step_s)), last)]
        mbs.SetObjectParameter(joint, "offsetUserFunctionParameters", parameters)

    actions.append(set_offset)

    def restore():
        mbs.SetObjectParameter(joint, "offsetUserFunction", previous["function"])
        mbs.SetObjectParameter(joint, "offsetUserFunctionParameters", [0.0] * 6)

    return restore


#: default step of the reduced Exudyn path (see :func:`simulate_exudyn_reduced`)
REDUCED_STEP_S = 1.0 / 16e3


#: default settings of :func:`simulate_exudyn_reduced` (no constraints: no numerical damping needed)
REDUCED_SETTINGS = IntegratorSettings(step_s=REDUCED_STEP_S, spectral_radius=1.0)


def simulate_exudyn_reduced(lin, drive, settings: IntegratorSettings = REDUCED_SETTINGS,
                            initial_state=None) -> tuple[np.ndarray, dict]:
    """Exudyn time integration of the linearised, constraint-projected model.

    ``M z'' + C z' + K z = -b2 u'' - b1 u' - b0 u`` as one ``ObjectGenericODE2`` (dense
    matrices, the drive force from a user function), generalised-alpha with
    ``settings``; sensor accelerations ``S N^T z'' + S r u''`` at the drive's sample
    instants.

    Parameters
    ----------
    lin : exudyn_study.modal.LinearSystem
    drive : exudyn_study.model.Drive
        With its signal set (at :data:`OUTPUT_RATE_HZ`).
    settings : IntegratorSettings
        Default step 1/16 ms. The error is second order in h and, on weak channels,
        dominated by the kHz response (integrated with a period error, then aliased
        into the 1 kHz samples). Model 1 (0.12 m mesh), 42 channels, < 70 Hz rms error vs the
        exact solution: 1/4 ms 7.7 % (5.8x real time), 1/8 ms 1.9 % (3.2x), 1/16 ms
        0.5 % (1.6x), 1/32 ms 0.1 % (0.8x); at 1 ms 107 %. The mini test frame (a
        0.13 %-damped mode, a weak Y channel) needs 1/32 ms for 1.4 %.
    initial_state : (z0, v0), optional
        Initial independent coordinates and velocities (free-decay runs); default rest.

    Returns
    -------
    accelerations : ndarray, shape (n_sensors, N)
    stats : dict
        As :func:`simulate_exudyn`.
    """
    import exudyn as exu
    import exudyn.itemInterface as eii

    if abs(drive.sample_rate_hz - OUTPUT_RATE_HZ) > 1e-9:
        raise InputError(f"drive at {drive.sample_rate_hz} Hz; expected {OUTPUT_RATE_HZ} Hz")
    n = lin.size
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    z0, v0 = (np.zeros(n), np.zeros(n)) if initial_state is None else (
        np.asarray(initial_state[0], dtype=float), np.asarray(initial_state[1], dtype=float))
    node = mbs.AddNode(eii.NodeGenericODE2(numberOfODE2Coordinates=n, referenceCoordinates=[0.0] * n,
                                           initialCoordinates=z0.tolist(), initialCoordinates_t=v0.tolist()))
    bmat = -np.column_stack([lin.b0, lin.b1, lin.b2])
    coef = drive._coef
    rate = drive.spline_rate_hz
    last = coef.shape[1] - 1

    def force(mbs_, t, item, q, q_t):
        k = min(max(int(t * rate), 0), last)
        dt = t - k / rate
        c0, c1, c2, c3 = coef[0, k], coef[1, k], coef[2, k], coef[3, k]
        u = ((c0 * dt + c1) * dt + c2) * dt + c3
        v = (3.0 * c0 * dt + 2.0 * c1) * dt + c2
        a = 6.0 * c0 * dt + 2.0 * c1
        return bmat @ np.array([u, v, a])

    def container(mat):
        mc = exu.MatrixContainer()
        mc.SetWithDenseMatrix(np.asarray(mat, dtype=float), useDenseMatrix=True)
        return mc

    mbs.AddObject(eii.ObjectGenericODE2(nodeNumbers=[node], massMatrix=container(lin.mass),
                                        stiffnessMatrix=container(lin.stiffness),
                                        dampingMatrix=container(lin.damping), forceUserFunction=force))
    sensor = mbs.AddSensor(eii.SensorNode(nodeNumber=node, outputVariableType=exu.OutputVariableType.Coordinates_tt,
                                          storeInternal=True, writeToFile=False))
    mbs.Assemble()
    n_samples = drive.samples.size
    duration = (n_samples - 1) / OUTPUT_RATE_HZ
    ss = _simulation_settings(settings, duration, constrained=False)
    n_steps = ss.timeIntegration.numberOfSteps
    ss.linearSolver.solverType = exu.LinearSolverType.EXUdense
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        mbs.SolveDynamic(ss, solverType=exu.DynamicSolverType.GeneralizedAlpha, storeSolver=True)
    except Exception as exc:
        raise SimulationError(f"Exudyn time integration failed at t = {float(mbs.systemData.GetTime()):.4f} s: "
                              f"{exc}") from None
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    data = np.asarray(mbs.GetSensorStoredData(sensor))
    if data.shape[0] < n_samples:
        raise SimulationError(f"{data.shape[0]} samples stored, expected {n_samples}")
    t = np.arange(n_samples) / OUTPUT_RATE_HZ
    out = lin.sensor_output @ data[:n_samples, 1:].T + np.outer(lin.sensor_drive, drive.evaluate(t, 2))
    return out, _checked_stats(out, settings, mbs, wall, cpu, duration, n_steps)


# --------------------------------------------------------------------------------------- recordings
def simulate(model, signal="white-noise", duration_s: float = 80.0, method: str = "exudyn", seed: int = 0,
             rms_m: float | None = None, drive_rate_hz: float | None = None,
             settings: IntegratorSettings = IntegratorSettings(), progress: bool = False) -> Recording:
    """Simulate ``model`` on the rig and return a :class:`Recording`.

    Parameters
    ----------
    model : exudyn_study.model.Model
    signal : str or array_like
        Signal name or drive samples (see :func:`prepare_drive`).
    duration_s : float
    method : {'exudyn', 'exudyn-reduced', 'linear'}
    seed : int
    rms_m : float, optional
    drive_rate_hz : float, optional
        Rate of given drive samples.
    settings : IntegratorSettings
    progress : bool

    Returns
    -------
    Recording
        Accelerations of every sensor at 1000 Hz (Appendix-A names, directions,
        positions, sensitivities), the drive at 204.8 Hz, metadata (model, damping,
        signal, seed, method, package version).

    Raises
    ------
    InputError, SimulationError
    """
    from . import __version__ as version
    from .modal import linearize
    from .recording import Channel
    from .signals import resample

    if method not in METHODS:
        raise InputError(f"method {method!r}; expected one of {list(METHODS)}")
    if getattr(model, "local_nonlinearities", None) and method != "linear":
        names = [el.name for el in model.local_nonlinearities]
        raise InputError(f"the model has local nonlinear elements {names}; method {method!r} integrates only its "
                         "Exudyn items: use method='linear' (linear model + local nonlinearities)")
    x = prepare_drive(signal, duration_s, rms_m, seed, drive_rate_hz)
    if method == "exudyn":
        acc, stats = simulate_exudyn(model, x, settings, progress=progress)
    elif method == "exudyn-reduced":
        model.drive.set_signal(x, OUTPUT_RATE_HZ)
        if settings == IntegratorSettings():
            settings = REDUCED_SETTINGS
        acc, stats = simulate_exudyn_reduced(linearize(model), model.drive, settings)
    else:
        t0 = time.perf_counter()
        model.drive.set_signal(x, OUTPUT_RATE_HZ)
        lin = linearize(model)
        elements = list(getattr(model, "local_nonlinearities", []))
        if elements:
            from .physics.nonlinear import gather_vectors, simulate_local_nonlinear

            acc = simulate_local_nonlinear(lin, model.drive, gather_vectors(model, elements),
                                           [el.law for el in elements])
        else:
            acc = simulate_linear(lin, model.drive)
        wall = time.perf_counter() - t0
        stats = {"wall_s": wall, "real_time_factor": (x.size - 1) / OUTPUT_RATE_HZ / wall}
    drive_out = resample(x, OUTPUT_RATE_HZ, DRIVE_RATE_HZ)
    gains = getattr(model, "output_gains", {})
    unknown = sorted(set(gains) - set(model.sensors))
    if unknown:
        raise InputError(f"output gains for unknown sensor(s) {unknown}; the model has {list(model.sensors)}")
    acc = np.array(acc, copy=True) if gains else acc
    channels = []
    for i, name in enumerate(model.sensors):
        if name in gains:
            acc[i] = acc[i] * float(gains[name])
        s = model.sensors[name].sensor
        channels.append(Channel(name, "acceleration", "m/s^2", s.direction, s.position_m, OUTPUT_RATE_HZ, acc[i],
                                sensitivity=s.sensitivity))
    channels.append(Channel("drive", "displacement", "m", "Z", None, DRIVE_RATE_HZ, drive_out, role="drive"))
    meta = {k: v for k, v in model.metadata.items() if isinstance(v, (str, int, float))}
    meta.update(
        source="simulation", method=method, signal=signal if isinstance(signal, str) else "given",
        seed=int(seed), duration_s=float((x.size - 1) / OUTPUT_RATE_HZ), package_version=str(version),
        wall_s=float(stats["wall_s"]))
    if method.startswith("exudyn"):
        meta.update(step_s=settings.step_s, spectral_radius=settings.radius(method == "exudyn"))
    return Recording(tuple(channels), meta)


def band_limited_rms_error(x, reference, rate_hz: float = OUTPUT_RATE_HZ, f_max_hz: float = 70.0) -> np.ndarray:
    """Relative rms error per channel of ``x`` vs ``reference`` below ``f_max_hz`` (FFT band limit).

    Both shape (n_channels, n_samples); returns shape (n_channels,).
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    r = np.atleast_2d(np.asarray(reference, dtype=float))
    f = np.fft.rfftfreq(x.shape[1], 1.0 / rate_hz)
    mask = f <= f_max_hz
    ex = np.fft.rfft(x - r, axis=1)[:, mask]
    er = np.fft.rfft(r, axis=1)[:, mask]
    return np.sqrt(np.sum(np.abs(ex) ** 2, axis=1) / np.sum(np.abs(er) ** 2, axis=1))


# --------------------------------------------------------------------------------------- checks
def modal_initial_state(modes, index: int, amplitude: float = 1e-4):
    """(z0, v0) that start the free vibration of damped mode ``index`` alone.

    ``z(t) = Re(a phi exp(lambda t))``: ``z0 = Re(a phi)``, ``v0 = Re(a lambda phi)``
    with ``phi`` the mode's coordinates (:attr:`SystemModes.coordinates`).
    """
    phi = np.asarray(modes.coordinates)[:, index]
    phi = amplitude * phi / np.abs(phi).max()
    w = 2.0 * np.pi * modes.frequency_hz[index]
    z = modes.damping_ratio[index]
    lam = complex(-z * w, w * math.sqrt(max(1.0 - z * z, 0.0)))
    return phi.real.copy(), (lam * phi).real.copy()


def free_decay_linear(lin, initial_state, n_samples: int, rate_hz: float = OUTPUT_RATE_HZ) -> np.ndarray:
    """Exact sampled sensor accelerations of the unforced linear system from ``(z0, v0)``."""
    a, _, c, _ = _state_space(lin)
    x0 = np.concatenate([np.asarray(initial_state[0], float), np.asarray(initial_state[1], float)])
    lam, v = sla.eig(a)
    xi0 = np.linalg.solve(v, x0)
    t = np.arange(n_samples) / rate_hz
    return ((c @ v) @ (xi0[:, None] * np.exp(lam[:, None] * t[None, :]))).real


def log_decrement_damping(x, rate_hz: float = OUTPUT_RATE_HZ, skip_cycles: int = 2,
                          n_cycles: int | None = None) -> tuple[float, float]:
    """Damping ratio and frequency of a single-mode free decay by the logarithmic decrement.

    Positive peaks are located with parabolic interpolation, then ``ln(peak)`` is fitted
    linearly against peak time: slope ``-sigma``, mean spacing ``T_d``; the decrement per
    cycle ``delta = sigma T_d`` gives ``zeta = delta / sqrt(4 pi^2 + delta^2)``.

    Returns
    -------
    zeta : float
    frequency_hz : float
        Undamped natural frequency ``f_d / sqrt(1 - zeta^2)``.
    """
    x = np.asarray(x, dtype=float)
    k = np.flatnonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:]) & (x[1:-1] > 0)) + 1
    if k.size < skip_cycles + 4:
        raise InputError(f"free decay with {k.size} positive peaks; expected at least {skip_cycles + 4}")
    y0, y1, y2 = x[k - 1], x[k], x[k + 1]
    den = y0 - 2.0 * y1 + y2
    off = np.where(den != 0, 0.5 * (y0 - y2) / np.where(den != 0, den, 1.0), 0.0)
    peak = y1 - 0.25 * (y0 - y2) * off
    tp = (k + off) / rate_hz
    sel = slice(skip_cycles, None if n_cycles is None else skip_cycles + n_cycles)
    tp, peak = tp[sel], peak[sel]
    slope, _ = np.polyfit(tp, np.log(peak), 1)
    td = float(np.mean(np.diff(tp)))
    delta = -slope * td
    zeta = delta / math.sqrt(4.0 * math.pi**2 + delta**2)
    return float(zeta), float(1.0 / td / math.sqrt(1.0 - zeta**2))


def estimate_frf(drive, accelerations, rate_hz: float = OUTPUT_RATE_HZ, nperseg: int = 16384,
                 skip_s: float = 1.0, overlap: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """H1 estimate (Welch, Hann, ``overlap``) of drive -> each acceleration channel.

    Returns
    -------
    f : ndarray, shape (n_f,)
    H : ndarray, complex, shape (n_channels, n_f)
    """
    k0 = int(round(skip_s * rate_hz))
    u = np.asarray(drive, dtype=float)[k0:]
    y = np.atleast_2d(np.asarray(accelerations, dtype=float))[:, k0:]
    nov = int(overlap * nperseg)
    f, suu = sps.welch(u, rate_hz, nperseg=nperseg, noverlap=nov)
    _, suy = sps.csd(u[None, :], y, rate_hz, nperseg=nperseg, noverlap=nov)
    return f, suy / suu[None, :]


def frf_linear_at_resolution(lin, frequencies_hz, nperseg: int = 16384, rate_hz: float = OUTPUT_RATE_HZ,
                             oversample: int = 16, half_width_bins: int = 6) -> np.ndarray:
    """Modal FRF as a Welch H1 estimate with a Hann window of ``nperseg`` samples sees it.

    For a white drive, the expected cross spectrum is the true one convolved with the
    window's power kernel ``|W(f)|^2``, and the drive's spectrum is flat, so the expected
    H1 is ``sum_d |W(d)|^2 H(f + d) / sum_d |W(d)|^2``. Comparing an estimate with this
    separates estimator bias at lightly damped peaks (half-power bandwidth of the order of
    the resolution) from disagreement between simulation and model. Shape
    (n_sensors, n_freq).
    """
    f = np.asarray(frequencies_hz, dtype=float)
    df = rate_hz / nperseg
    w = sps.get_window("hann", nperseg)
    kern = np.abs(np.fft.fft(w, oversample * nperseg)) ** 2
    m = half_width_bins * oversample
    kern = np.concatenate([kern[-m:], kern[: m + 1]])
    delta = np.arange(-m, m + 1) * df / oversample
    grid = (f[:, None] + delta[None, :]).ravel()
    h = frf_linear(lin, np.abs(grid))[:, 0, :].reshape(-1, f.size, delta.size)
    h = np.where((f[:, None] + delta[None, :] < 0)[None], np.conj(h), h)
    return (h * kern[None, None, :]).sum(axis=2) / kern.sum()


def frf_db_error(h_est, h_model, f, band_hz=(3.5, 59.0), antiresonance_db: float = 6.0,
                 exclude_hz: float = 0.5, dynamic_range_db: float = 60.0, exclude_peaks_hz=()) -> np.ndarray:
    """Max |20 log10 |H_est / H_model|| per channel in ``band_hz`` outside antiresonances.

    A frequency counts as near an antiresonance when it is within ``exclude_hz`` of a
    local minimum of ``|H_model|`` that lies ``antiresonance_db`` or more below the
    smaller of the maxima on either side, or when ``|H_model|`` is more than
    ``dynamic_range_db`` below the channel's maximum in the band (there the estimate is
    window leakage from the resonances, as in a measurement). The default band keeps
    clear of the drive's 3 and 60 Hz band edges, where the input power falls off.
    ``exclude_peaks_hz``: resonances to leave out (``exclude_hz`` either side), e.g. those
    whose half-power bandwidth ``2 zeta f`` is narrower than the estimate's resolution,
    where any windowed estimate is biased low.
    """
    f = np.asarray(f)
    h_est, h_model = np.atleast_2d(h_est), np.atleast_2d(h_model)
    band = (f >= band_hz[0]) & (f <= band_hz[1])
    out = np.empty(h_model.shape[0])
    for i in range(h_model.shape[0]):
        mag = 20.0 * np.log10(np.abs(h_model[i]) + 1e-300)
        ok = band & (mag >= mag[band].max() - dynamic_range_db)
        for fp in exclude_peaks_hz:
            ok &= np.abs(f - fp) > exclude_hz
        mins = np.flatnonzero((mag[1:-1] < mag[:-2]) & (mag[1:-1] <= mag[2:])) + 1
        for j in mins:
            left, right = mag[:j].max(initial=-np.inf), mag[j + 1:].max(initial=-np.inf)
            if min(left, right) - mag[j] >= antiresonance_db:
                ok &= np.abs(f - f[j]) > exclude_hz
        err = np.abs(20.0 * np.log10(np.abs(h_est[i, ok]) / np.abs(h_model[i, ok])))
        out[i] = err.max() if err.size else np.nan
    return out
