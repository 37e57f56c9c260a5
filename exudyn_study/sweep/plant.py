"""A rig model as the plant of a drive iteration.

A :class:`ModelPlant` is a built model linearised once; :func:`iterate_model_drive` iterates
its drive until the control channels follow a measured recording (thesis Section 7.2).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.infra.blas import (
    single_threaded_blas,
)
from exudyn_study.recording.types import Recording
from exudyn_study.signals.drive_iteration import (
    DriveFRF,
    DriveIterationResult,
    iterate_drive,
    target_from_recording,
)

#: control sensors of the drive iteration (thesis Section 7.1: the frame side members next
#: to the drive point)
CONTROL = ("ARFVZ", "ARFHZ")


@dataclass(frozen=True, eq=False)
class ModelPlant:
    """A rig model linearised once: drive (m) -> sensor accelerations (m/s^2).

    Parameters
    ----------
    model : exudyn_study.model.Model
        A built model (assembled by the linearisation if not yet).
    lin : exudyn_study.linear.modes.LinearSystem, optional
        Its linearisation (computed if not given).
    label : str, optional
        Damping label for recordings and tables (default: the model's metadata).

    Other Parameters
    ----------------
    _gather : numpy.ndarray, optional
        Gather vectors of the model's local nonlinearities, shape ``(n_elements, n_q)``
        (:func:`exudyn_study.linear.nonlinear.gather_vectors`); set after construction,
        not to be given.
    _last : dict, optional
        Last simulated drive and its responses (keys ``drive``, ``acc``), reused by
        :meth:`recording`; internal, not to be given.

    Notes
    -----
    Drives are sampled at :data:`exudyn_study.simulate.OUTPUT_RATE_HZ` (1000 Hz) and
    faded in exactly as :func:`exudyn_study.simulate.simulate` does, so the responses of
    :meth:`responses` are those of :meth:`recording` for the same drive.
    """

    model: object
    lin: object = None
    label: str = ""
    _gather: np.ndarray | None = field(default=None, repr=False)
    _last: dict = field(default_factory=dict, repr=False)  # last drive and all its responses

    def __post_init__(self) -> None:
        from exudyn_study.model.linearisation import linearise

        if self.lin is None:
            with single_threaded_blas():
                object.__setattr__(self, "lin", linearise(self.model))
        if not self.label:
            object.__setattr__(self, "label", str(self.model.metadata.get("damping", "")))
        elements = list(getattr(self.model, "local_nonlinearities", []))
        if elements:
            from exudyn_study.linear.nonlinear import gather_vectors

            object.__setattr__(self, "_gather", gather_vectors(self.model, elements))

    @property
    def sensor_names(self) -> tuple[str, ...]:
        """Sensor names of the model (rows of :meth:`responses` with ``names=None``)."""
        return tuple(self.lin.sensor_names)

    def indices(self, names: Sequence[str], what: str = "control channel") -> list[int]:
        """Row indices of ``names`` among the model's sensors.

        Parameters
        ----------
        names : sequence of str
            Sensor names.
        what : str, default "control channel"
            What the names are, for the error message.

        Returns
        -------
        list of int
            Index of each name in :attr:`sensor_names`, in the order of ``names``.

        Raises
        ------
        InputError
            If a name is not a sensor of the model.
        """
        missing = [n for n in names if n not in self.sensor_names]
        if missing:
            raise InputError(
                f"{what}(s) {', '.join(missing)} not among the model's sensors "
                f"({', '.join(self.sensor_names[:10])}{', ...' if len(self.sensor_names) > 10 else ''})"
            )
        return [self.sensor_names.index(n) for n in names]

    def responses(self, drive: np.ndarray, names: Sequence[str] | None = None) -> np.ndarray:
        """Sensor accelerations for a drive at 1000 Hz, shape (n_names, n_samples), m/s^2.

        Parameters
        ----------
        drive : ndarray, shape (n_samples,)
            Piston displacement in m at :data:`~exudyn_study.simulate.OUTPUT_RATE_HZ`.
        names : sequence of str, optional
            Sensors to return (default all, in model order).
        """
        from exudyn_study.linear.response import simulate_linear
        from exudyn_study.simulate.drive import OUTPUT_RATE_HZ, prepare_drive

        drive = np.asarray(drive, dtype=float)
        last = self._last.get("drive")
        if last is not None and last.shape == drive.shape and np.array_equal(last, drive):
            acc = self._last["acc"]  # the iteration's best drive, simulated again for the recording
        else:
            x = prepare_drive(drive, sample_rate_hz=OUTPUT_RATE_HZ)
            self.model.drive.set_signal(x, OUTPUT_RATE_HZ)
            elements = list(getattr(self.model, "local_nonlinearities", []))
            with single_threaded_blas():
                if elements:
                    from exudyn_study.linear.nonlinear import simulate_local_nonlinear

                    laws = [el.law for el in elements]
                    acc = simulate_local_nonlinear(self.lin, self.model.drive, self._gather, laws)
                else:
                    acc = simulate_linear(self.lin, self.model.drive)
            self._last.update(drive=drive.copy(), acc=acc)
        idx = list(range(len(self.sensor_names))) if names is None else self.indices(names, "sensor")
        out = np.array(acc[idx], dtype=float)
        gains = getattr(self.model, "output_gains", {})
        for row, i in enumerate(idx):
            out[row] *= float(gains.get(self.sensor_names[i], 1.0))
        return out

    def frf(self, names: Sequence[str], resolution_hz: float = 0.2) -> DriveFRF:
        """Exact drive -> ``names`` acceleration FRF of the linearisation on a Welch grid at 1000 Hz.

        Parameters
        ----------
        names : sequence of str
            Response sensors.
        resolution_hz : float
            Grid spacing in Hz (the grid is ``0 .. 500 Hz``, ``1000 / resolution_hz`` even).
        """
        from exudyn_study.linear.response import frf_linear
        from exudyn_study.simulate.drive import OUTPUT_RATE_HZ

        if not (math.isfinite(resolution_hz) and resolution_hz > 0):
            raise InputError(f"resolution_hz {resolution_hz!r}; expected a resolution > 0 Hz")
        idx = self.indices(names)
        nperseg = int(round(OUTPUT_RATE_HZ / resolution_hz))
        nperseg += nperseg % 2
        f = np.linspace(0.0, OUTPUT_RATE_HZ / 2, nperseg // 2 + 1)
        with single_threaded_blas():
            h = frf_linear(self.lin, f)[idx, 0, :]
        gains = getattr(self.model, "output_gains", {})
        h = h * np.array([float(gains.get(n, 1.0)) for n in names])[:, None]
        return DriveFRF(f, h, OUTPUT_RATE_HZ)

    def recording(self, drive: np.ndarray, metadata: Mapping | None = None) -> Recording:
        """Simulate the model with a drive at 1000 Hz into a Recording.

        The same recording as ``simulate(model, drive, method='linear',
        drive_rate_hz=1000)`` (every sensor at 1000 Hz, the drive at 204.8 Hz, the same
        metadata) without linearising again; the metadata get the plant's damping label
        and ``metadata`` on top.

        Parameters
        ----------
        drive : numpy.ndarray
            Drive displacement in m, sampled at 1000 Hz, shape ``(n_samples,)``.
        metadata : Mapping, optional
            Metadata entries set on top of the model's and the simulation's (None: none).

        Returns
        -------
        Recording
            Every sensor's acceleration (m/s^2) at 1000 Hz and the drive displacement (m) at
            204.8 Hz.
        """
        from exudyn_study import __version__ as version
        from exudyn_study.recording.types import Channel
        from exudyn_study.signals.drives import resample
        from exudyn_study.simulate.drive import DRIVE_RATE_HZ, OUTPUT_RATE_HZ, prepare_drive

        t0 = time.perf_counter()
        acc = self.responses(drive)
        x = prepare_drive(drive, sample_rate_hz=OUTPUT_RATE_HZ)
        channels = []
        for name, row in zip(self.sensor_names, acc, strict=True):
            s = self.model.sensors[name].sensor
            channels.append(Channel(name, "acceleration", "m/s^2", s.direction, s.position_m, OUTPUT_RATE_HZ,
                                    row, sensitivity=s.sensitivity))
        channels.append(Channel("drive", "displacement", "m", "Z", None, DRIVE_RATE_HZ,
                                resample(x, OUTPUT_RATE_HZ, DRIVE_RATE_HZ), role="drive"))
        meta = {k: v for k, v in self.model.metadata.items() if isinstance(v, (str, int, float))}
        meta.update(source="simulation", method="linear", signal="given", seed=0,
                    duration_s=float((x.size - 1) / OUTPUT_RATE_HZ), package_version=str(version),
                    wall_s=float(time.perf_counter() - t0), damping=self.label)
        meta.update(metadata or {})
        return Recording(tuple(channels), meta)


def iterate_model_drive(
    plant: ModelPlant,
    measured: Recording,
    control: Sequence[str] = CONTROL,
    *,
    frf: str | DriveFRF = "model",
    frf_plant: ModelPlant | None = None,
    max_iter: int = 10,
    tol: float = 0.05,
    reg: float = 0.05,
    resolution_hz: float = 0.2,
    update_frf: bool = True,
) -> DriveIterationResult:
    """Iterate the drive of ``plant`` until its control accelerations match ``measured``.

    ``D_0 = H^+ A_m``, ``D_{k+1} = D_k + H^+ (A_m - A_k)`` (thesis Section 7.1), with H
    updated from the runs (:func:`exudyn_study.signals.drive_iteration.iterate_drive`).

    Parameters
    ----------
    plant : ModelPlant
        The model to drive.
    measured : Recording
        The measured (desired) recording; its control channels are the target A_m
        (resampled, anti-aliased, to 1000 Hz if recorded at another rate).
    control : sequence of str
        Control channels (default ``ARFVZ``, ``ARFHZ``).
    frf : {'model', 'identify'} or DriveFRF
        The initial H: the exact FRF of ``frf_plant`` (default: of ``plant``), a
        white-noise identification run of ``plant``, or a given FRF at 1000 Hz.
    frf_plant : ModelPlant, optional
        Model whose FRF is inverted when ``frf='model'`` (e.g. a nominal model that lacks
        a rig resonance of ``plant``).
    max_iter, tol, reg, resolution_hz, update_frf
        See :func:`~exudyn_study.signals.drive_iteration.iterate_drive`.

    Returns
    -------
    DriveIterationResult
        Drive at 1000 Hz (m), control response, relative rms error per run and channel.

    Raises
    ------
    InputError
        A control channel missing from the recording or the model, an unknown ``frf``,
        a recording too short for the FRF resolution.
    """
    from exudyn_study.simulate.drive import OUTPUT_RATE_HZ

    control = tuple(control)
    if not control:
        raise InputError("control: expected at least one control channel (e.g. ARFVZ ARFHZ)")
    if not isinstance(measured, Recording):
        raise InputError(f"measured is a {type(measured).__name__}; expected a Recording")
    target, fs = target_from_recording(measured, control, rate_hz=OUTPUT_RATE_HZ)
    plant.indices(control)
    if isinstance(frf, DriveFRF):
        h = frf
    elif frf == "model":
        h = (frf_plant or plant).frf(control, resolution_hz)
    elif frf == "identify":
        h = None
    else:
        raise InputError(f"frf {frf!r}; expected 'model', 'identify' or a DriveFRF")

    def simulate(drive: np.ndarray) -> np.ndarray:
        return plant.responses(drive, control)

    return iterate_drive(simulate, target, fs, frf=h, resolution_hz=resolution_hz, reg=reg, tol=tol,
                         max_iter=max_iter, update_frf=update_frf, control_names=control)


def rms_errors(response: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Relative rms error per channel, ``rms(target - response) / rms(target)``.

    Parameters
    ----------
    response : numpy.ndarray
        Simulated responses, shape ``(n_channels, n_samples)`` (or ``(n_samples,)`` for one channel).
    target : numpy.ndarray
        Target responses, same shape as ``response``.

    Returns
    -------
    numpy.ndarray
        Relative rms error of each channel, shape ``(n_channels,)``.
    """
    target = np.atleast_2d(target)
    return np.sqrt(np.mean((target - np.atleast_2d(response)) ** 2, axis=1) / np.mean(target**2, axis=1))


