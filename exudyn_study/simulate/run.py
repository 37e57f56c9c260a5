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
    The linearised system of :func:`exudyn_study.linear.modes.linearise` integrated *exactly*:
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
import time

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.linear.response import simulate_linear
from exudyn_study.recording.types import Recording
from exudyn_study.simulate.drive import DRIVE_RATE_HZ, OUTPUT_RATE_HZ, prepare_drive
from exudyn_study.simulate.exudyn_path import IntegratorSettings, simulate_exudyn
from exudyn_study.simulate.reduced import REDUCED_SETTINGS, simulate_exudyn_reduced

__all__ = [
    "METHODS",
    "simulate",
]

log = logging.getLogger(__name__)

METHODS = ("exudyn", "exudyn-reduced", "linear")


# --------------------------------------------------------------------------------------- recordings
def simulate(model, signal="white-noise", duration_s: float = 80.0, method: str = "exudyn", seed: int = 0,
             rms_m: float | None = None, drive_rate_hz: float | None = None,
             settings: IntegratorSettings | None = None, progress: bool = False) -> Recording:
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
    settings : IntegratorSettings, optional
        Time-integration settings of the Exudyn methods (default ``IntegratorSettings()``; for
        'exudyn-reduced' the default means ``REDUCED_SETTINGS``).
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
    from exudyn_study import __version__ as version
    from exudyn_study.model.linearisation import linearise
    from exudyn_study.recording.types import Channel
    from exudyn_study.signals.drives import resample

    if method not in METHODS:
        raise InputError(f"method {method!r}; expected one of {list(METHODS)}")
    if getattr(model, "local_nonlinearities", None) and method != "linear":
        names = [el.name for el in model.local_nonlinearities]
        raise InputError(
            f"the model has local nonlinear elements {names}; method {method!r} integrates only its "
            "Exudyn items: use method='linear' (linear model + local nonlinearities)")
    if settings is None:
        settings = IntegratorSettings()
    x = prepare_drive(signal, duration_s, rms_m, seed, drive_rate_hz)
    if method == "exudyn":
        acc, stats = simulate_exudyn(model, x, settings, progress=progress)
    elif method == "exudyn-reduced":
        model.drive.set_signal(x, OUTPUT_RATE_HZ)
        if settings == IntegratorSettings():
            settings = REDUCED_SETTINGS
        acc, stats = simulate_exudyn_reduced(linearise(model), model.drive, settings)
    else:
        t0 = time.perf_counter()
        model.drive.set_signal(x, OUTPUT_RATE_HZ)
        lin = linearise(model)
        elements = list(getattr(model, "local_nonlinearities", []))
        if elements:
            from exudyn_study.linear.nonlinear import gather_vectors, simulate_local_nonlinear

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
    for i, name in enumerate(model.sensors):
        if name in gains:
            acc[i] = acc[i] * float(gains[name])
    for fault in getattr(model, "output_faults", ()):  # acquisition faults (physics.sensor_faults)
        acc = fault.apply(acc, tuple(model.sensors), OUTPUT_RATE_HZ)
    channels = []
    for i, name in enumerate(model.sensors):
        s = model.sensors[name].sensor
        channels.append(Channel(name, "acceleration", "m/s^2", s.direction, s.position_m, OUTPUT_RATE_HZ,
                                acc[i], sensitivity=s.sensitivity))
    channels.append(Channel("drive", "displacement", "m", "Z", None, DRIVE_RATE_HZ, drive_out, role="drive"))
    meta = {k: v for k, v in model.metadata.items() if isinstance(v, (str, int, float))}
    meta.update(
        source="simulation", method=method, signal=signal if isinstance(signal, str) else "given",
        seed=int(seed), duration_s=float((x.size - 1) / OUTPUT_RATE_HZ), package_version=str(version),
        wall_s=float(stats["wall_s"]))
    if method.startswith("exudyn"):
        meta.update(step_s=settings.step_s, spectral_radius=settings.radius(method == "exudyn"))
    return Recording(tuple(channels), meta)

