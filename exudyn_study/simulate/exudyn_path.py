"""``method='exudyn'``: Exudyn's implicit integration of the assembled model.

Generalised-alpha with numerical damping :data:`CONSTRAINED_SPECTRAL_RADIUS` (the joints
and the prescribed drive are index-3 constraints: without numerical damping their
accelerations carry a growing step-to-step oscillation), a constant step, modified Newton
with a tolerance scaled to the residual's rounding floor (:func:`newton_absolute_tolerance`).
The drive is prescribed once per step through a parameter read by a symbolic offset.
Settings are :class:`IntegratorSettings`; ``benchmarks/bench_simulation.py`` measures
their error against the exact linear solution.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass

import numpy as np

from exudyn_study.errors import InputError, SimulationError
from exudyn_study.simulate.drive import OUTPUT_RATE_HZ

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
        """Return the spectral radius used: the given one or the path's default (``spectral_radius``).

        Parameters
        ----------
        constrained : bool
            True for the constrained full-model path (default :data:`CONSTRAINED_SPECTRAL_RADIUS`),
            False for the reduced path (default 1, no numerical damping).

        Returns
        -------
        float
            Generalised-alpha spectral radius at infinity, in [0, 1].
        """
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
            f"the simulation diverged at t = {k / OUTPUT_RATE_HZ:.4f} s (sensor accelerations non-finite "
            f"or above {settings.divergence_limit:g} m/s^2); try a smaller step")
    stats = {"wall_s": wall, "cpu_s": cpu, "real_time_factor": duration / wall if wall > 0 else float("inf"),
             "cpu_real_time_factor": duration / cpu if cpu > 0 else float("inf"), "steps": n_steps}
    solver = mbs.sys.get("dynamicSolver")
    if solver is not None:
        stats.update(newton_iterations=int(solver.it.newtonStepsCount),
                     jacobians=int(solver.it.newtonJacobiCount))
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
    bar = _progress_action(duration, actions) if progress else None
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
    out = _sensor_accelerations(model, drive_samples.size)
    return out, _checked_stats(out, settings, mbs, wall, cpu, duration, n_steps)


def _progress_action(duration_s: float, actions: list):
    """Add a pre-step action that advances a tqdm bar once per simulated second; return the bar."""
    from tqdm import tqdm

    from exudyn_study.infra.progress import progress_disabled

    bar = tqdm(total=int(duration_s), unit="s", desc="exudyn", file=sys.stderr, disable=progress_disabled())
    state = {"next": 1.0}

    def show_progress(t):
        if t >= state["next"]:
            bar.update(1)
            state["next"] += 1.0

    actions.append(show_progress)
    return bar


def _sensor_accelerations(model, n_samples: int) -> np.ndarray:
    """Read the sensors' stored accelerations along their directions, shape (n_sensors, n_samples)."""
    mbs = model.mbs
    names = list(model.sensors)
    out = np.empty((len(names), n_samples))
    cache = {}
    for i, name in enumerate(names):
        att = model.sensors[name]
        if att.exudyn_sensor not in cache:
            cache[att.exudyn_sensor] = np.asarray(mbs.GetSensorStoredData(att.exudyn_sensor))
        data = cache[att.exudyn_sensor]
        if data.shape[0] < n_samples:
            raise SimulationError(f"sensor {name}: {data.shape[0]} samples stored, expected {n_samples}")
        coordinate_map = getattr(att, "coordinate_map", None)
        if coordinate_map is None:
            out[i] = data[:n_samples, 1:4] @ att.direction
        else:  # coordinate accelerations of a constant-matrix body
            out[i] = data[:n_samples, 1:] @ (att.direction @ coordinate_map)
    return out


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
