"""The thesis's simulation study (Section 7): drive iteration and relative pseudo damage.

For every model variant x damping x drive signal the study

1. iterates the drive on the model so that its accelerations at the control sensors
   (``ARFVZ``, ``ARFHZ``, next to the drive linkage) match the measured ones
   (:func:`iterate_model_drive`, time waveform replication of
   :mod:`exudyn_study.signals.drive_iteration`, Section 7.1), or, with ``iterate=False``, drives
   the model with the measured drive channel;
2. simulates the model with that drive into a recording (``method='linear'``);
3. computes the relative pseudo damage ``D_sim / D_meas`` of every z sensor against the
   measured recording (rainflow + Basquin, beta = 5, counted at 204.8 Hz as the thesis:
   :func:`exudyn_study.signals.fatigue.relative_pseudo_damage`).

:func:`run_grid` does the whole grid, writes a long-format CSV, an iteration CSV and bar
plots like thesis Figures 22-27, and returns a :class:`GridResult`.

Plant and speed
---------------
A :class:`ModelPlant` is a built model linearised once (:func:`exudyn_study.linear.modes.linearise`);
a drive -> response run is :func:`exudyn_study.simulate.simulate_linear` (exact for the
linearised model; the model's local nonlinearities and output gains are honoured as in
:func:`exudyn_study.simulate.simulate`), so a run costs well under a second for 80 s
without the 1-4 s linearisation ``simulate`` repeats on every call;
:meth:`ModelPlant.recording` gives the recording ``simulate(..., method='linear')`` gives. The FRF the
iteration inverts defaults to the model's own (:func:`exudyn_study.simulate.frf_linear` on
the Welch grid): exact and free; ``frf='identify'`` identifies it by a white-noise run as a
rig controller would. Iteration runs at the accelerometer rate (1000 Hz); the drive in the
written recording is at the controller's 204.8 Hz as in every simulated recording.

Damping choices
---------------
``'adams-default'``, ``'step'`` (16.6 % to 100 % at 450 Hz), ``'constant-1'``,
``'constant-2'``, ``'table6'`` (thesis Table 6, Model 3), ``'suggested'`` and ``'diagnosed'``
(:mod:`exudyn_study.sweep.grid_damping`):

- ``'suggested'``: the thesis's question. The model's flexible-body damping is calibrated
  (:func:`~exudyn_study.sweep.grid_damping.calibrate_model`) so that its system modes carry the
  damping of the rig's EMA: the white-noise recording identified with each reference
  (:func:`~exudyn_study.sweep.grid_damping.ema_target`), model and rig modes paired by MAC at
  the sensors and frequency; one ratio per body mode below 500 Hz (Model 3: of each of its
  bodies). A calibration file per model replaces it (``calibrations``).
- ``'diagnosed'``: the model a rig diagnosis fitted (``diagnosis``: its findings applied,
  :func:`exudyn_study.diagnose.fitted.apply_diagnosis`, but for ``modal_damping`` findings:
  the body damping is calibrated), calibrated the same way; only for the model variant the
  diagnosis was made on.

Every calibration's pairing (MAC, frequency error, unpaired rig modes) is kept in
:attr:`GridResult.calibrations` and written next to the grid.

Reading
-------
:meth:`GridResult.reading` says per sensor group (:func:`sensor_group`: frame and cross
members, tanks, brackets, rear attachments) which damping predicts the measured damage best,
as the median over the group's sensors and the signals of the factor by which the simulation
misses (``exp |log ratio|``), and where no damping brings the group within 50-200 %.

Cells run one after another: the machine's cores are better spent on the linear algebra,
and every cell is a few seconds.
"""

from __future__ import annotations

import json
import logging
import math
import os
import re
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify.model import write_modes_json
from exudyn_study.infra.atomic import write_text_atomic
from exudyn_study.infra.blas import single_threaded_blas
from exudyn_study.infra.progress import StatusProgress
from exudyn_study.recording.io import read_recording
from exudyn_study.recording.types import Recording
from exudyn_study.signals.fatigue import DEFAULT_BETA, relative_pseudo_damage
from exudyn_study.sweep.grid_damping import (
    CALIBRATED,
    DAMPING_NAMES,
    calibrate_model,
    calibration_dict,
    damping_from_calibration,
    ema_target,
    resolve_damping,
    table1_target,
)
from exudyn_study.sweep.grid_result import (
    SENSOR_GROUPS,
    CellResult,
    GridResult,
    file_slug,
    sensor_group,
)
from exudyn_study.sweep.plant import CONTROL, ModelPlant, iterate_model_drive

__all__ = [
    "GRID_DAMPINGS",
    "SENSOR_GROUPS",
    "sensor_group",
    "GRID_SIGNALS",
    "DAMAGE_RATE_HZ",
    "CellResult",
    "GridResult",
    "measured_recordings",
    "run_grid",
]

log = logging.getLogger(__name__)

#: damping functions of the grid (thesis Section 6: the two references and the suggested one)
GRID_DAMPINGS = ("adams-default", "step", "suggested")
#: drive signals of the grid (thesis Section 7)
GRID_SIGNALS = ("white-noise", "test", "test-50")
#: rate in Hz at which pseudo damage is counted (the thesis's simulation rate, Section 7.2)
DAMAGE_RATE_HZ = 204.8




# ---------------------------------------------------------------------------------------
# The grid
# ---------------------------------------------------------------------------------------

_SIGNAL_FILE = re.compile(r"^(?P<stem>.*)_(?P<signal>white-noise|test-50|test)\.(h5|hdf5|uff|unv)$")


def measured_recordings(directory: str | os.PathLike,
                        signals: Sequence[str] | None = None) -> dict[str, Path]:
    """Find one measured recording per signal in ``directory``: ``<anything>_<signal>.h5``.

    Parameters
    ----------
    directory : path
    signals : sequence of str, optional
        Signals required (default: every signal found).

    Returns
    -------
    dict signal -> Path

    Raises
    ------
    InputError
        Missing directory, a required signal without a file, or two files for one signal.
    """
    d = Path(directory)
    if not d.is_dir():
        raise InputError(f"measured directory {str(d)!r} does not exist")
    found: dict[str, list[Path]] = {}
    for p in sorted(d.iterdir()):
        m = _SIGNAL_FILE.match(p.name)
        if m and p.is_file():
            found.setdefault(m["signal"], []).append(p)
    wanted = list(signals) if signals is not None else sorted(
        found, key=lambda s: GRID_SIGNALS.index(s))  # the thesis's order
    if not wanted:
        raise InputError(f"measured directory {str(d)!r} has no '<name>_<signal>.h5' recordings "
                         f"(signals {list(GRID_SIGNALS)})")
    out = {}
    for s in wanted:
        paths = found.get(s, [])
        if not paths:
            raise InputError(f"measured directory {str(d)!r} has no recording for signal {s!r} "
                             f"(expected a file named '<name>_{s}.h5')")
        if len(paths) > 1:
            raise InputError(f"measured directory {str(d)!r} has {len(paths)} recordings for signal {s!r}: "
                             f"{', '.join(p.name for p in paths)}; keep one")
        out[s] = paths[0]
    return out


def _check_positive(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{name} {value!r}; expected a finite value > 0")
    return v


def run_grid(
    measured: Mapping[str, Recording | str | os.PathLike],
    models: Sequence[int] = (1, 2, 3),
    dampings: Sequence[str] | None = None,
    signals: Sequence[str] | None = None,
    iterate: bool = True,
    out_dir: str | os.PathLike | None = None,
    *,
    control: Sequence[str] = CONTROL,
    channels: Sequence[str] | None = None,
    beta: float = DEFAULT_BETA,
    rate_hz: float = DAMAGE_RATE_HZ,
    max_iter: int = 5,
    tol: float = 0.05,
    reg: float = 0.05,
    calibrations: Mapping[int, str | os.PathLike | Mapping] | None = None,
    target=None,
    diagnosis=None,
    builder: Callable[[int, object], object] | None = None,
    probe_builder: Callable[[int, object], object] | None = None,
    mesh_size="production",
    cache_dir=None,
    plots: bool = True,
    progress: Callable[[str], None] | None = None,
) -> GridResult:
    """Relative pseudo damage for models x dampings x signals against measured recordings.

    Parameters
    ----------
    measured : mapping signal -> Recording or path
        The measured recording of each drive signal (e.g. from :func:`measured_recordings`).
    models : sequence of int
        Model variants (default 1, 2, 3).
    dampings : sequence of str, optional
        Damping names (:data:`DAMPING_NAMES`; default adams-default, step, suggested, and
        diagnosed when a ``diagnosis`` is given).
    signals : sequence of str, optional
        Signals to run (default: every key of ``measured``).
    iterate : bool
        Iterate the drive on the control sensors (default); False drives each model with
        the measured recording's drive channel.
    out_dir : path, optional
        Write ``damage_grid.csv``, ``drive_iterations.csv`` and the plots there.
    control : sequence of str
        Control channels of the iteration (default ``ARFVZ``, ``ARFHZ``).
    channels : sequence of str, optional
        Channels to compare (default: the z-direction sensors of the model); each must be
        in every measured recording.
    beta : float
        Basquin exponent (> 0, default 5).
    rate_hz : float
        Rate in Hz at which damage is counted (default 204.8 Hz, the thesis's).
    max_iter, tol, reg
        Drive iteration: at most ``max_iter`` updates, stop below ``tol`` relative rms
        error, relative Tikhonov regularisation.
    calibrations : mapping model -> calibration, optional
        Calibration file or dict per model for ``'suggested'`` (see :func:`resolve_damping`);
        without one the model is calibrated against ``target``.
    target : ModalModel, optional
        Target modes of the calibrated columns. Default: the EMA of the measured white-noise
        recording (:func:`~exudyn_study.sweep.grid_damping.ema_target`); without a white-noise
        recording, thesis Table 1 (frequencies only).
    diagnosis : Diagnosis, mapping or path, optional
        A rig diagnosis (``exudyn-study diagnose --json``) whose fitted model is the
        ``'diagnosed'`` column (on the model variant it was made on).
    builder : callable, optional
        ``builder(variant, damping) -> Model`` (not assembled); default
        :func:`exudyn_study.model.build_model` with ``mesh_size``, ``cache_dir`` and the
        used-node Exudyn mesh. Models are built once per (model, damping).
    probe_builder : callable, optional
        The same with the whole Exudyn mesh, for the calibration (default: ``builder`` when
        one is given, else ``build_model`` with the whole mesh).
    mesh_size : {'production', 'coarse'} or float
        Mesh of every body for the default builders (a float: maximum element size in m).
    cache_dir : path, optional
        Flexible-body cache of the default builders (default ``$EXUDYN_STUDY_CACHE`` or
        ``~/.cache/exudyn_study``).
    plots : bool
        Write bar plots into ``out_dir`` (default True).
    progress : callable, optional
        Called with a short line per step.

    Returns
    -------
    GridResult

    Raises
    ------
    InputError
        Before any model is built: an unknown model, damping or signal, a measured
        recording that is missing, unreadable, has non-finite data or lacks a control
        channel, ``beta <= 0``, a missing output directory, ``'diagnosed'`` without a
        diagnosis or a diagnosis without the entries of its fitted model. Later: a compared channel
        missing from a measured recording, a calibration for another mesh.
    """
    with single_threaded_blas(), StatusProgress("damage grid") as status:

        def say(text: str) -> None:
            status(text)
            if progress is None:
                log.info("%s", text)
            else:
                progress(text)

        return _run_grid(measured, models, dampings, signals, iterate, out_dir, control=control,
                         channels=channels, beta=beta, rate_hz=rate_hz, max_iter=max_iter, tol=tol, reg=reg,
                         calibrations=calibrations, target=target, diagnosis=diagnosis, builder=builder,
                         probe_builder=probe_builder, mesh_size=mesh_size, cache_dir=cache_dir,
                         plots=plots, say=say)


@dataclass(frozen=True)
class _GridInputs:
    """The grid's checked inputs: everything :func:`run_grid` validates before building a model."""

    models: list
    dampings: list
    signals: list
    recordings: dict
    calibrations: dict
    out: Path | None
    diagnosis: object
    diagnosed_variant: int | None


def _check_inputs(measured, models, dampings, signals, iterate, out_dir, control, calibrations,
                  diagnosis) -> _GridInputs:
    """Check every input of the grid and read the measured recordings (InputError on the first fault)."""
    from exudyn_study.diagnose.fitted import diagnosis_variant, load_diagnosis
    from exudyn_study.model import VARIANTS

    models = [int(m) if isinstance(m, (int, np.integer)) or str(m).isdigit() else m for m in models]
    bad = [m for m in models if m not in VARIANTS]
    if bad:
        raise InputError(f"model {bad[0]!r} is unknown; expected one of {list(VARIANTS)}")
    diagnosed_variant = None
    if diagnosis is not None:
        diagnosis = load_diagnosis(diagnosis)
        diagnosed_variant = diagnosis_variant(diagnosis)
    dampings = list(GRID_DAMPINGS + (("diagnosed",) if diagnosis is not None else ())
                    if dampings is None else dampings)
    if "diagnosed" in dampings and diagnosis is None:
        raise InputError("damping 'diagnosed' needs a diagnosis (exudyn-study diagnose --json FILE)")
    for d in dampings:
        if d not in DAMPING_NAMES:
            raise InputError(f"damping {d!r} is unknown; expected one of {list(DAMPING_NAMES)}")
    if not isinstance(measured, Mapping) or not measured:
        raise InputError("measured: expected a mapping signal -> Recording or recording file")
    signals = list(measured) if signals is None else list(signals)
    missing = [s for s in signals if s not in measured]
    if missing:
        raise InputError(
            f"signal(s) {', '.join(missing)} have no measured recording; given: {', '.join(measured)}")
    calibrations = dict(calibrations or {})
    unknown = sorted(set(calibrations) - set(models), key=str)
    if unknown:
        raise InputError(f"calibrations for model(s) {unknown} not in the grid's models {models}")
    out = None
    if out_dir is not None:
        out = Path(out_dir)
        if not out.is_dir():
            raise InputError(f"out_dir {str(out)!r} does not exist; create it first")
    recs: dict[str, Recording] = {}
    for s in signals:
        r = measured[s]
        rec = r if isinstance(r, Recording) else read_recording(r)  # InputError: missing file, NaN samples
        where = f"measured recording for {s!r}" + ("" if isinstance(r, Recording) else f" ({str(r)!r})")
        absent = [c for c in control if c not in rec.names]
        if absent:
            raise InputError(f"{where}: control channel(s) {', '.join(absent)} missing; it has "
                             f"{', '.join(rec.names[:10])}{', ...' if len(rec) > 10 else ''}")
        if not iterate:
            try:
                _ = rec.drive
            except InputError as exc:
                raise InputError(f"{where}: {exc} (needed with iterate=False)") from None
        recs[s] = rec
    return _GridInputs(models, dampings, signals, recs, calibrations, out, diagnosis, diagnosed_variant)


def _default_builders(builder, probe_builder, mesh_size, cache_dir):
    """Return the grid's model builders: the used-node Exudyn mesh, and the whole mesh for calibrations."""
    if builder is None:
        from exudyn_study.model import build_model

        def builder(variant, damping):
            return build_model(variant, damping=damping, mesh_size=mesh_size, cache_dir=cache_dir,
                               exudyn_mesh="used")

        if probe_builder is None:
            def probe_builder(variant, damping):  # the calibration reads sensors at every mesh node
                return build_model(variant, damping=damping, mesh_size=mesh_size, cache_dir=cache_dir)
    return builder, probe_builder or builder


def _grid_target(target, recordings, notes, say):
    """Return the calibrated columns' target modes: given, the white-noise EMA, or thesis Table 1."""
    if target is not None:
        return target
    if "white-noise" in recordings:
        t0 = time.perf_counter()
        target = ema_target(recordings["white-noise"])
        say(f"EMA of the white-noise recording: {len(target)} modes "
            f"({', '.join(f'{f:.1f}' for f in target.frequency_hz)} Hz) "
            f"in {time.perf_counter() - t0:.1f} s")
        return target
    notes.append("no white-noise recording: the calibrated columns are calibrated on thesis Table 1 "
                 "(frequencies only, no shapes)")
    say(notes[-1])
    return table1_target()


class _Plants:
    """Each (model, damping) of the grid built, calibrated where its column asks, and linearised once."""

    def __init__(self, inputs: _GridInputs, target, builder, probe_builder, say) -> None:
        self.inputs, self.target, self.say = inputs, target, say
        self.builder, self.probe_builder = builder, probe_builder
        self.plants: dict[tuple[int, str], ModelPlant] = {}
        self.calibrations: dict[tuple[int, str], dict] = {}

    def _fitted(self, model):
        """Apply the diagnosis's findings but modal_damping (the body damping is calibrated instead)."""
        from exudyn_study.diagnose.fitted import apply_diagnosis

        return apply_diagnosis(model, self.inputs.diagnosis, exclude=("modal_damping",))

    def __call__(self, variant: int, name: str) -> ModelPlant:
        key = (variant, name)
        if key not in self.plants:
            t0 = time.perf_counter()
            diagnosed = name == "diagnosed"
            if diagnosed or (name in CALIBRATED and variant not in self.inputs.calibrations):
                probe = self.probe_builder(variant, "adams-default")
                if diagnosed:
                    probe = self._fitted(probe)
                cal = calibration_dict(calibrate_model(probe, self.target), probe, self.target)
                self.calibrations[key] = cal
                spec = damping_from_calibration(cal)
            else:
                spec = resolve_damping(variant, name, self.inputs.calibrations.get(variant))
            model = self.builder(variant, spec)
            self.plants[key] = ModelPlant(self._fitted(model) if diagnosed else model, label=name)
            self.say(f"model {variant}, damping {name}: built and linearised in "
                     f"{time.perf_counter() - t0:.1f} s")
        return self.plants[key]


def _run_cell(plant: ModelPlant, variant: int, name: str, signal: str, rec: Recording, names, iterate,
              control, *, max_iter, tol, reg, beta, rate_hz) -> CellResult:
    """One cell: the drive (iterated on the control sensors, or the measured one), the run, the damage."""
    absent = [n for n in names if n not in rec.names]
    if absent:
        raise InputError(
            f"measured recording for {signal!r} lacks compared channel(s) {', '.join(absent)}; "
            "pass channels=... to compare a common subset")
    t0 = time.perf_counter()
    if iterate:
        res = iterate_model_drive(plant, rec, control, max_iter=max_iter, tol=tol, reg=reg)
        drive, errors, conv = res.drive, res.errors, res.converged
    else:
        from exudyn_study.signals.drives import resample
        from exudyn_study.simulate.drive import OUTPUT_RATE_HZ

        d = rec.drive
        drive = d.data if d.sample_rate_hz == OUTPUT_RATE_HZ else resample(
            d.data, d.sample_rate_hz, OUTPUT_RATE_HZ)
        errors, conv = None, None
    sim = plant.recording(drive, {"signal": signal, "drive": "iterated" if iterate else "measured"})
    with warnings.catch_warnings():  # its notes stay on the damage; the grid's reading weighs them
        warnings.simplefilter("ignore", UserWarning)
        dmg = relative_pseudo_damage(sim, rec, beta=beta, channels=names, rate_hz=rate_hz)
    return CellResult(variant, name, signal, dmg, errors, conv, time.perf_counter() - t0)


def _write_grid_files(result: GridResult, out: Path, iterate: bool, calibrations: dict, target,
                      plots: bool) -> list[Path]:
    """Write the grid's tables, calibrations, target modes, pairing, reading and plots into ``out``."""
    files = [result.write_csv(out / "damage_grid.csv")]
    if iterate:
        files.append(result.write_csv(out / "drive_iterations.csv", iterations=True))
    for (m, d), cal in calibrations.items():
        files.append(write_text_atomic(out / f"calibration_model{m}_{file_slug(d)}.json",
                                       json.dumps(cal, indent=1), "calibration JSON"))
    if target is not None:
        files.append(write_modes_json(target, out / "calibration_target_modes.json"))
    if calibrations:
        files.append(write_text_atomic(out / "pairing.txt", result.pairing_report() + "\n", "pairing"))
    files.append(write_text_atomic(out / "reading.txt", result.reading() + "\n", "grid reading"))
    if plots:
        files.extend(result.plot(out))
    return files


def _run_grid(measured, models, dampings, signals, iterate, out_dir, *, control, channels, beta, rate_hz,
              max_iter, tol, reg, calibrations, target, diagnosis, builder, probe_builder, mesh_size,
              cache_dir, plots, say) -> GridResult:
    t_start = time.perf_counter()
    beta = _check_positive("beta", beta)
    rate_hz = _check_positive("rate_hz", rate_hz)
    if not (isinstance(max_iter, int) and max_iter >= 0):
        raise InputError(f"max_iter {max_iter!r}; expected an integer >= 0")
    tol = _check_positive("tol", tol)
    control = tuple(control)
    inputs = _check_inputs(measured, models, dampings, signals, iterate, out_dir, control, calibrations,
                           diagnosis)
    builder, probe_builder = _default_builders(builder, probe_builder, mesh_size, cache_dir)
    notes: list[str] = []
    need_target = "diagnosed" in inputs.dampings or any(
        d in CALIBRATED and variant not in inputs.calibrations
        for d in inputs.dampings for variant in inputs.models)
    if need_target:
        target = _grid_target(target, inputs.recordings, notes, say)
    plant_for = _Plants(inputs, target, builder, probe_builder, say)

    cells = []
    for variant in inputs.models:
        for name in inputs.dampings:
            if name == "diagnosed" and inputs.diagnosed_variant not in (None, variant):
                notes.append(f"model {variant}: no diagnosed column (the diagnosis was made on model "
                             f"{inputs.diagnosed_variant})")
                continue
            plant = plant_for(variant, name)
            names = list(channels) if channels is not None else [
                n for n in plant.sensor_names if plant.model.sensors[n].sensor.direction == "Z"]
            for s in inputs.signals:
                cell = _run_cell(plant, variant, name, s, inputs.recordings[s], names, iterate, control,
                                 max_iter=max_iter, tol=tol, reg=reg, beta=beta, rate_hz=rate_hz)
                cells.append(cell)
                r = 100 * cell.damage.ratios
                runs = cell.iteration_errors
                say(f"model {variant}, {name}, {s}: "
                    + (f"{runs.shape[0]} runs, control error {100 * cell.final_error:.1f} %, "
                       if runs is not None else "measured drive, ")
                    + f"relative damage median {np.nanmedian(r):.0f} % ({cell.wall_s:.1f} s)")
    result = GridResult(tuple(cells), control, beta, rate_hz, time.perf_counter() - t_start,
                        calibrations=dict(plant_for.calibrations), notes=tuple(dict.fromkeys(notes)))
    if inputs.out is not None:
        files = _write_grid_files(result, inputs.out, iterate, plant_for.calibrations,
                                  target if need_target else None, plots)
        result = replace(result, wall_time_s=time.perf_counter() - t_start, files=tuple(files))
    return result
