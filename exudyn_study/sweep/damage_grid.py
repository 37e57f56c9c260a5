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

import csv
import json
import logging
import math
import os
import re
import tempfile
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify.model import write_modes_json
from exudyn_study.infra.atomic import write_text_atomic
from exudyn_study.infra.blas import single_threaded_blas
from exudyn_study.infra.progress import StatusProgress
from exudyn_study.recording.io import read_recording
from exudyn_study.recording.types import Recording
from exudyn_study.signals.fatigue import DEFAULT_BETA, RelativeDamage, relative_pseudo_damage
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
#: sensor groups of the grid's reading, in the order they are reported
SENSOR_GROUPS = ("frame and cross members", "tanks", "brackets", "rear attachments")
#: the acceptance band of relative pseudo damage (ratios)
BAND = (0.5, 2.0)
#: drive signals of the grid (thesis Section 7)
GRID_SIGNALS = ("white-noise", "test", "test-50")
#: rate in Hz at which pseudo damage is counted (the thesis's simulation rate, Section 7.2)
DAMAGE_RATE_HZ = 204.8



def sensor_group(name: str) -> str:
    """Return the sensor group of a thesis sensor (one of :data:`SENSOR_GROUPS`).

    Tanks and brackets are the sensors on those components; the rear attachments are the
    frame's sensors at its rear supports (ARVBZ, ARHBZ); every other frame sensor (side
    members, cross members, the tank and bracket mounts on the frame) is "frame and cross
    members". A name not in thesis Appendix A counts as frame.

    Parameters
    ----------
    name : str
        Sensor name (thesis Appendix A, e.g. ``"ASVZ"``).

    Returns
    -------
    str
    """
    from exudyn_study.model.sensors import sensor

    try:
        s = sensor(name)
    except InputError:
        return SENSOR_GROUPS[0]
    if s.component.startswith("tank"):
        return "tanks"
    if s.component.startswith("bracket"):
        return "brackets"
    if s.description.lower().startswith("rear attachment"):
        return "rear attachments"
    return SENSOR_GROUPS[0]


def _miss(ratio) -> np.ndarray:
    """Factor by which a simulation misses the measured damage: ``exp |log ratio|`` (1 = exact)."""
    r = np.asarray(ratio, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.exp(np.abs(np.log(r)))


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
        Files written (CSV, plots, calibrations, reading).
    calibrations : mapping (model, damping) -> dict
        Each calibrated column's calibration (:meth:`CalibrationResult.to_dict`: the pairing
        with MAC and frequencies, the unpaired target modes, the chosen ratios).
    notes : tuple of str
        What the grid could not run and why (e.g. the diagnosed column on another model).
    """

    cells: tuple[CellResult, ...]
    control: tuple[str, ...]
    beta: float
    rate_hz: float
    wall_time_s: float
    files: tuple[Path, ...] = ()
    calibrations: Mapping = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def cell(self, model: int, damping: str, signal: str) -> CellResult:
        """Return the cell of (model, damping, signal).

        Parameters
        ----------
        model : int
            Model variant (1, 2 or 3).
        damping : str
            Damping name (one of :data:`DAMPING_NAMES`).
        signal : str
            Drive signal name.

        Returns
        -------
        CellResult
            The result of that cell.

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

    def group_ratios(self, model: int) -> dict[str, dict[str, np.ndarray]]:
        """Relative damage of one model by sensor group and damping, over the group's sensors and the signals.

        Parameters
        ----------
        model : int
            Model variant (1, 2 or 3).

        Returns
        -------
        dict group -> dict damping -> ndarray of ratios (1 = measured)
        """
        out: dict[str, dict[str, list]] = {}
        for c in self.cells:
            if c.model != model:
                continue
            for ch in c.damage.channels:
                out.setdefault(sensor_group(ch.name), {}).setdefault(c.damping, []).append(ch.ratio)
        order = [g for g in SENSOR_GROUPS if g in out]
        return {g: {d: np.asarray(v, float) for d, v in out[g].items()} for g in order}

    def median_ratio(self, model: int, damping: str, signal: str | None = None) -> float:
        """Return the median relative damage (ratio) of a column over its sensors (and signals, if None).

        Parameters
        ----------
        model : int
            Model variant (1, 2 or 3).
        damping : str
            The damping column (e.g. ``"step"``, ``"suggested"``).
        signal : str, optional
            One drive signal; None takes every signal of the grid.

        Returns
        -------
        float
            The median of simulated / measured pseudo damage (1 = measured).
        """
        r = [c.damage.ratios for c in self.cells
             if c.model == model and c.damping == damping and (signal is None or c.signal == signal)]
        if not r:
            raise InputError(f"no cell model {model}, damping {damping!r}"
                             + ("" if signal is None else f", signal {signal!r}") + " in the grid")
        r = np.concatenate(r)
        r = r[np.isfinite(r)]
        return float(np.median(r)) if r.size else math.nan

    def reading(self) -> str:
        """Read the grid per model and sensor group: which damping predicts the measured damage best.

        For each model and sensor group the dampings are ranked by the median over the
        group's sensors and signals of the miss factor ``exp |log(D_sim / D_meas)|`` (1: the
        simulation's damage equals the measured one; 2: off by a factor of two either way);
        the text gives each column's median relative damage, the best one and by how much it
        beats the next, the sensors within 50-200 %, and says where no damping brings the
        group within 50-200 %.
        """
        lines = []
        dampings = list(dict.fromkeys(c.damping for c in self.cells))
        for m in dict.fromkeys(c.model for c in self.cells):
            cols = [d for d in dampings if any(c.model == m and c.damping == d for c in self.cells)]
            lines.append(f"Model {m} (median relative damage over all sensors and signals: "
                         + ", ".join(f"{d} {100 * self.median_ratio(m, d):.0f} %" for d in cols) + ")")
            for g, per in self.group_ratios(m).items():
                miss = {d: float(np.nanmedian(_miss(v))) for d, v in per.items()}
                ranked = sorted(miss, key=miss.get)
                best = ranked[0]
                med = {d: 100 * float(np.nanmedian(v)) for d, v in per.items()}
                inside = {d: int(np.sum((v >= BAND[0]) & (v <= BAND[1]))) for d, v in per.items()}
                n = len(per[best])
                text = (f"  {g}: best {best} (median {med[best]:.0f} %, off by x{miss[best]:.2f}, "
                        f"{inside[best]}/{n} sensor-signals within 50-200 %)")
                if len(ranked) > 1:
                    nxt = ranked[1]
                    text += (f"; next {nxt} ({med[nxt]:.0f} %, x{miss[nxt]:.2f}): "
                             f"{miss[nxt] / miss[best]:.2f} times further off")
                others = ", ".join(f"{d} {med[d]:.0f} %" for d in ranked[2:])
                if others:
                    text += f"; then {others}"
                lines.append(text)
                if not any(BAND[0] <= med[d] / 100 <= BAND[1] for d in per):
                    if "diagnosed" in per:
                        hint = ("the diagnosed model does not reach it either: what is missing there is not "
                                "yet modelled (see the diagnosis's unexplained mismatch)")
                    else:
                        hint = ("no damping reaches it: the model lacks physics the rig has there; run the "
                                "diagnosis (exudyn-study diagnose) and add its column (diagnosis=...)")
                    lines.append(f"    no column within 50-200 % for the {g}: {hint}")
        lines.extend(self.notes)
        return "\n".join(lines)

    def pairing_report(self) -> str:
        """Per calibrated column the pairing of model and target modes (MAC, frequency error, unpaired)."""
        lines = []
        for (m, d), cal in self.calibrations.items():
            meta = cal.get("metadata", {})
            conv = cal.get("convergence", {})
            lines.append(f"Model {m}, {d}: calibrated on {meta.get('target', 'target')}, "
                         f"{len(cal.get('variables', {}))} variables, max |damping error| "
                         f"{100 * (conv.get('max_abs_error') or math.nan):.3f} pp")
            lines.append(f"  {'f model Hz':>10} {'zeta %':>7} {'f target Hz':>11} {'target %':>8} "
                         f"{'df %':>6} {'MAC':>5}")
            for r in cal.get("modes", []):
                if r["target_frequency_hz"] is None:
                    continue
                df = 100 * (r["frequency_hz"] / r["target_frequency_hz"] - 1)
                mac_ = "-" if r["mac"] is None else f"{r['mac']:.2f}"
                lines.append(f"  {r['frequency_hz']:10.2f} {100 * r['damping_ratio']:7.2f} "
                             f"{r['target_frequency_hz']:11.2f} {100 * r['target_damping_ratio']:8.2f} "
                             f"{df:6.1f} {mac_:>5}")
            un = cal.get("unpaired_targets", [])
            lines.append("  target modes without a partner: " + (", ".join(
                f"{u['target_frequency_hz']:.2f} Hz ({100 * u['target_damping_ratio']:.2f} %)" for u in un)
                if un else "none"))
        return "\n".join(lines)

    def write_csv(self, path: str | os.PathLike, iterations: bool = False) -> Path:
        """Write :meth:`rows` (or :meth:`iteration_rows`) to a CSV file atomically.

        Parameters
        ----------
        path : str or os.PathLike
            CSV file to write; its directory must exist. An existing file is replaced.
        iterations : bool, default False
            Whether to write the drive iteration rows instead of the damage rows.

        Returns
        -------
        pathlib.Path
            The written path.
        """
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
        there is more than one case to compare; per model a summary by sensor group and
        damping (``model<m>_summary.png``).

        Parameters
        ----------
        out_dir : str or os.PathLike
            Existing directory the PNG files are written to.

        Returns
        -------
        list of pathlib.Path
            The written figure files.
        """
        from exudyn_study.signals.fatigue_plots import plot_damage_summary, plot_relative_pseudo_damage

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
            written.append(plot_damage_summary(
                self.group_ratios(m), out / f"model{m}_summary.png",
                title=f"Model {m}: relative pseudo damage by sensor group and damping\n"
                      f"(signals: {', '.join(signals)})"))
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


def _run_grid(measured, models, dampings, signals, iterate, out_dir, *, control, channels, beta, rate_hz,
              max_iter, tol, reg, calibrations, target, diagnosis, builder, probe_builder, mesh_size,
              cache_dir, plots, say) -> GridResult:
    from exudyn_study.model import VARIANTS

    t_start = time.perf_counter()
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
    from exudyn_study.diagnose.fitted import apply_diagnosis, diagnosis_variant, load_diagnosis

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

    if builder is None:
        from exudyn_study.model import build_model

        def builder(variant, damping):
            return build_model(variant, damping=damping, mesh_size=mesh_size, cache_dir=cache_dir,
                               exudyn_mesh="used")

        if probe_builder is None:
            def probe_builder(variant, damping):  # the calibration reads sensors at every mesh node
                return build_model(variant, damping=damping, mesh_size=mesh_size, cache_dir=cache_dir)
    probe_builder = probe_builder or builder

    notes: list[str] = []
    need_target = "diagnosed" in dampings or any(
        d in CALIBRATED and variant not in calibrations for d in dampings for variant in models)
    if target is None and need_target:
        if "white-noise" in recs:
            t0 = time.perf_counter()
            target = ema_target(recs["white-noise"])
            say(f"EMA of the white-noise recording: {len(target)} modes "
                f"({', '.join(f'{f:.1f}' for f in target.frequency_hz)} Hz) "
                f"in {time.perf_counter() - t0:.1f} s")
        else:
            target = table1_target()
            notes.append("no white-noise recording: the calibrated columns are calibrated on thesis Table 1 "
                         "(frequencies only, no shapes)")
            say(notes[-1])

    def fitted(model):  # the body damping is calibrated: a modal_damping finding would scale it again
        return apply_diagnosis(model, diagnosis, exclude=("modal_damping",))

    plants: dict[tuple[int, str], ModelPlant] = {}
    cal_results: dict[tuple[int, str], dict] = {}

    def plant_for(variant: int, name: str) -> ModelPlant:
        key = (variant, name)
        if key not in plants:
            t0 = time.perf_counter()
            diagnosed = name == "diagnosed"
            if diagnosed or (name in CALIBRATED and variant not in calibrations):
                probe = probe_builder(variant, "adams-default")
                if diagnosed:
                    probe = fitted(probe)
                cal = calibration_dict(calibrate_model(probe, target), probe, target)
                cal_results[key] = cal
                spec = damping_from_calibration(cal)
            else:
                spec = resolve_damping(variant, name, calibrations.get(variant))
            model = builder(variant, spec)
            plants[key] = ModelPlant(fitted(model) if diagnosed else model, label=name)
            say(f"model {variant}, damping {name}: built and linearised in {time.perf_counter() - t0:.1f} s")
        return plants[key]

    cells = []
    for variant in models:
        for name in dampings:
            if name == "diagnosed" and diagnosed_variant not in (None, variant):
                notes.append(f"model {variant}: no diagnosed column (the diagnosis was made on model "
                             f"{diagnosed_variant})")
                continue
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
                with warnings.catch_warnings():  # its notes stay on dmg; the grid's reading weighs them
                    warnings.simplefilter("ignore", UserWarning)
                    dmg = relative_pseudo_damage(sim, rec, beta=beta, channels=names, rate_hz=rate_hz)
                cell = CellResult(variant, name, s, dmg, errors, conv, time.perf_counter() - t0)
                cells.append(cell)
                r = 100 * dmg.ratios
                say(f"model {variant}, {name}, {s}: "
                    + (f"{errors.shape[0]} runs, control error {100 * cell.final_error:.1f} %, "
                       if errors is not None else "measured drive, ")
                    + f"relative damage median {np.nanmedian(r):.0f} % ({cell.wall_s:.1f} s)")
    result = GridResult(tuple(cells), control, beta, rate_hz, time.perf_counter() - t_start,
                        calibrations=dict(cal_results), notes=tuple(dict.fromkeys(notes)))
    if out is not None:
        files = [result.write_csv(out / "damage_grid.csv")]
        if iterate:
            files.append(result.write_csv(out / "drive_iterations.csv", iterations=True))
        for (m, d), cal in cal_results.items():
            files.append(write_text_atomic(out / f"calibration_model{m}_{_slug(d)}.json",
                                           json.dumps(cal, indent=1), "calibration JSON"))
        if target is not None and need_target:
            files.append(write_modes_json(target, out / "calibration_target_modes.json"))
        if cal_results:
            files.append(write_text_atomic(out / "pairing.txt", result.pairing_report() + "\n", "pairing"))
        files.append(write_text_atomic(out / "reading.txt", result.reading() + "\n", "grid reading"))
        if plots:
            files.extend(result.plot(out))
        result = replace(result, wall_time_s=time.perf_counter() - t_start, files=tuple(files))
    return result
