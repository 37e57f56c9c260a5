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
``'constant-2'``, ``'table6'`` (thesis Table 6, Model 3) and ``'suggested'``:

- Model 3: thesis Table 6, unless a calibration file is given;
- Models 1/2: the thesis's suggested function (Figure 18) was chosen by hand so that the
  system modes carry the identified damping of Table 1; we use the calibration
  (:mod:`exudyn_study.calibrate`) that does this automatically: a calibration file
  (``exudyn-study calibrate --json``) when given, otherwise a calibration against thesis
  Table 1 run here (one variable per body mode below 500 Hz, 100 % above; ~2 s).

Cells run one after another: the machine's cores are better spent on the linear algebra,
and every cell is a few seconds.
"""

from __future__ import annotations

import csv
import logging
import math
import os
import re
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.infra.blas import single_threaded_blas
from exudyn_study.recording.io import read_recording
from exudyn_study.recording.types import Recording
from exudyn_study.signals.fatigue import DEFAULT_BETA, RelativeDamage, relative_pseudo_damage
from exudyn_study.sweep.grid_damping import DAMPING_NAMES, resolve_damping
from exudyn_study.sweep.plant import CONTROL, ModelPlant, iterate_model_drive

__all__ = [
    "GRID_DAMPINGS",
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
# The model as a plant of the drive iteration
# ---------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------
# Damping choices
# ---------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CellResult:
    """One cell of the grid: a model, damping and signal.

    Parameters
    ----------
    model : int
        Model variant.
    damping : str
        Damping name.
    signal : str
        Drive signal name (key of the measured recordings).
    damage : RelativeDamage
        Relative pseudo damage per compared channel.
    iteration_errors : ndarray, shape (n_runs, n_control), or None
        Relative rms error per iteration run and control channel (None: not iterated).
    converged : bool or None
        Whether the iteration reached its tolerance (None: not iterated).
    wall_s : float
        Wall time of the cell in s (model build excluded).
    """

    model: int
    damping: str
    signal: str
    damage: RelativeDamage
    iteration_errors: np.ndarray | None
    converged: bool | None
    wall_s: float

    @property
    def final_error(self) -> float:
        """Worst control channel's relative rms error of the drive used (nan: not iterated)."""
        if self.iteration_errors is None:
            return math.nan
        return float(self.iteration_errors.max(axis=1).min())


@dataclass(frozen=True, eq=False)
class GridResult:
    """The study grid: relative pseudo damage per model, damping, signal and sensor.

    Parameters
    ----------
    cells : tuple of CellResult
    control : tuple of str
        Control channels of the drive iteration.
    beta : float
        Basquin exponent.
    rate_hz : float
        Rate at which damage was counted.
    wall_time_s : float
        Wall time of :func:`run_grid`, model builds included.
    files : tuple of Path
        Files written (CSV, plots).
    """

    cells: tuple[CellResult, ...]
    control: tuple[str, ...]
    beta: float
    rate_hz: float
    wall_time_s: float
    files: tuple[Path, ...] = ()

    def cell(self, model: int, damping: str, signal: str) -> CellResult:
        """Return the cell of (model, damping, signal).

        Raises
        ------
        InputError
            If the grid has no such cell.
        """
        for c in self.cells:
            if (c.model, c.damping, c.signal) == (model, damping, signal):
                return c
        raise InputError(f"no cell model {model}, damping {damping!r}, signal {signal!r} in the grid")

    def rows(self) -> list[dict]:
        """Long-format table: one row per cell and channel.

        Columns: ``model, damping, signal, channel, pseudo_damage_simulated,
        pseudo_damage_measured, relative_pseudo_damage`` (a ratio; 1 = measured),
        ``iteration_error`` (worst control channel, relative rms).
        """
        out = []
        for c in self.cells:
            for ch in c.damage.channels:
                out.append({
                    "model": c.model, "damping": c.damping, "signal": c.signal, "channel": ch.name,
                    "pseudo_damage_simulated": ch.damage_simulated,
                    "pseudo_damage_measured": ch.damage_measured,
                    "relative_pseudo_damage": ch.ratio,
                    "iteration_error": c.final_error,
                })
        return out

    def iteration_rows(self) -> list[dict]:
        """One row per cell and iteration run: ``model, damping, signal, run, <control>...``."""
        out = []
        for c in self.cells:
            if c.iteration_errors is None:
                continue
            for k, row in enumerate(c.iteration_errors):
                out.append({"model": c.model, "damping": c.damping, "signal": c.signal, "run": k,
                            **{name: float(e) for name, e in zip(self.control, row, strict=True)}})
        return out

    def summary(self) -> str:
        """Text table per cell: iteration error and the spread of relative pseudo damage (%)."""
        head = (f"{'model':>5} {'damping':<14} {'signal':<11} {'runs':>4} {'ctrl err':>8} "
                f"{'median %':>9} {'min %':>8} {'max %':>9} {'in 50-200 %':>11} {'s':>6}")
        lines = [head]
        for c in self.cells:
            r = 100 * c.damage.ratios
            r = r[np.isfinite(r)]
            runs = "-" if c.iteration_errors is None else str(c.iteration_errors.shape[0])
            err = "-" if c.iteration_errors is None else f"{100 * c.final_error:.1f}%"
            inside = f"{int(np.sum((r >= 50) & (r <= 200)))}/{r.size}"
            lines.append(
                f"{c.model:>5} {c.damping:<14} {c.signal:<11} {runs:>4} {err:>8} "
                f"{np.median(r):9.1f} {r.min():8.1f} {r.max():9.1f} {inside:>11} {c.wall_s:6.1f}")
        return "\n".join(lines)

    def write_csv(self, path: str | os.PathLike, iterations: bool = False) -> Path:
        """Write :meth:`rows` (or :meth:`iteration_rows`) to a CSV file atomically."""
        rows = self.iteration_rows() if iterations else self.rows()
        fields = list(rows[0]) if rows else ["model", "damping", "signal"]
        path = Path(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        try:
            with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
                w = csv.DictWriter(fh, fieldnames=fields)
                w.writeheader()
                for row in rows:
                    w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
        return path

    def plot(self, out_dir: str | os.PathLike) -> list[Path]:
        """Bar plots like thesis Figures 22-27 into ``out_dir``.

        Per model and signal the dampings side by side (``model<m>_<signal>_dampings.png``,
        Figs 22-24 for white noise), and per model and damping the signals side by side
        (``model<m>_<damping>_signals.png``, Figs 25-27 for the suggested damping), where
        there is more than one case to compare.
        """
        from exudyn_study.signals.fatigue_plots import plot_relative_pseudo_damage

        out = Path(out_dir)
        written = []
        models = list(dict.fromkeys(c.model for c in self.cells))
        dampings = list(dict.fromkeys(c.damping for c in self.cells))
        signals = list(dict.fromkeys(c.signal for c in self.cells))
        for m in models:
            for s in signals:
                cases = {c.damping: c.damage for c in self.cells if c.model == m and c.signal == s}
                if len(cases) > 1 or len(dampings) == 1 and len(signals) == 1:
                    written.append(plot_relative_pseudo_damage(
                        cases, out / f"model{m}_{_slug(s)}_dampings.png",
                        title=f"Model {m}, {s}: relative pseudo damage by damping"))
            for d in dampings:
                cases = {c.signal: c.damage for c in self.cells if c.model == m and c.damping == d}
                if len(cases) > 1:
                    written.append(plot_relative_pseudo_damage(
                        cases, out / f"model{m}_{_slug(d)}_signals.png",
                        title=f"Model {m}, {d} damping: relative pseudo damage by signal"))
        return written


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text)


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
    dampings: Sequence[str] = GRID_DAMPINGS,
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
    builder: Callable[[int, object], object] | None = None,
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
    dampings : sequence of str
        Damping names (:data:`DAMPING_NAMES`; default adams-default, step, suggested).
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
        Calibration file or dict per model for ``'suggested'`` (see :func:`resolve_damping`).
    builder : callable, optional
        ``builder(variant, damping) -> Model`` (not assembled); default
        :func:`exudyn_study.model.build_model` with ``mesh_size``, ``cache_dir`` and the
        used-node Exudyn mesh. Models are built once per (model, damping).
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
        channel, ``beta <= 0``, a missing output directory. Later: a compared channel
        missing from a measured recording, a calibration for another mesh.
    """
    with single_threaded_blas():
        return _run_grid(measured, models, dampings, signals, iterate, out_dir, control=control,
                         channels=channels, beta=beta, rate_hz=rate_hz, max_iter=max_iter, tol=tol, reg=reg,
                         calibrations=calibrations, builder=builder, mesh_size=mesh_size, cache_dir=cache_dir,
                         plots=plots, progress=progress)


def _run_grid(measured, models, dampings, signals, iterate, out_dir, *, control, channels, beta, rate_hz,
              max_iter, tol, reg, calibrations, builder, mesh_size, cache_dir, plots, progress) -> GridResult:
    from exudyn_study.model import VARIANTS

    t_start = time.perf_counter()
    say = progress or (lambda text: log.info("%s", text))
    beta = _check_positive("beta", beta)
    rate_hz = _check_positive("rate_hz", rate_hz)
    if not (isinstance(max_iter, int) and max_iter >= 0):
        raise InputError(f"max_iter {max_iter!r}; expected an integer >= 0")
    tol = _check_positive("tol", tol)
    control = tuple(control)
    models = [int(m) if isinstance(m, (int, np.integer)) or str(m).isdigit() else m for m in models]
    bad = [m for m in models if m not in VARIANTS]
    if bad:
        raise InputError(f"model {bad[0]!r} is unknown; expected one of {list(VARIANTS)}")
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

    probe_builder = builder
    if builder is None:
        from exudyn_study.model import build_model

        def builder(variant, damping):
            return build_model(variant, damping=damping, mesh_size=mesh_size, cache_dir=cache_dir,
                               exudyn_mesh="used")

        def probe_builder(variant, damping):  # the calibration reads sensors at every mesh node
            return build_model(variant, damping=damping, mesh_size=mesh_size, cache_dir=cache_dir)

    plants: dict[tuple[int, str], ModelPlant] = {}

    def plant_for(variant: int, name: str) -> ModelPlant:
        key = (variant, name)
        if key not in plants:
            t0 = time.perf_counter()
            spec = resolve_damping(variant, name, calibrations.get(variant),
                                   probe=lambda: probe_builder(variant, "adams-default"))
            plants[key] = ModelPlant(builder(variant, spec), label=name)
            say(f"model {variant}, damping {name}: built and linearised in {time.perf_counter() - t0:.1f} s")
        return plants[key]

    cells = []
    for variant in models:
        for name in dampings:
            plant = plant_for(variant, name)
            names = list(channels) if channels is not None else [
                n for n in plant.sensor_names if plant.model.sensors[n].sensor.direction == "Z"]
            for s in signals:
                rec = recs[s]
                absent = [n for n in names if n not in rec.names]
                if absent:
                    raise InputError(
                        f"measured recording for {s!r} lacks compared channel(s) {', '.join(absent)}; "
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
                sim = plant.recording(drive, {"signal": s, "drive": "iterated" if iterate else "measured"})
                dmg = relative_pseudo_damage(sim, rec, beta=beta, channels=names, rate_hz=rate_hz)
                cell = CellResult(variant, name, s, dmg, errors, conv, time.perf_counter() - t0)
                cells.append(cell)
                r = 100 * dmg.ratios
                say(f"model {variant}, {name}, {s}: "
                    + (f"{errors.shape[0]} runs, control error {100 * cell.final_error:.1f} %, "
                       if errors is not None else "measured drive, ")
                    + f"relative damage median {np.nanmedian(r):.0f} % ({cell.wall_s:.1f} s)")
    result = GridResult(tuple(cells), control, beta, rate_hz, time.perf_counter() - t_start)
    if out is not None:
        files = [result.write_csv(out / "damage_grid.csv")]
        if iterate:
            files.append(result.write_csv(out / "drive_iterations.csv", iterations=True))
        if plots:
            files.extend(result.plot(out))
        result = GridResult(result.cells, control, beta, rate_hz, time.perf_counter() - t_start, tuple(files))
    return result
