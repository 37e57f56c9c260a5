"""Results of the damage grid: cells, the grid, its reading, tables and plots.

:class:`GridResult` holds one :class:`CellResult` per model, damping and drive signal of
:func:`exudyn_study.sweep.damage_grid.run_grid` and says what they mean:
:meth:`GridResult.reading` ranks the dampings per sensor group (:func:`sensor_group`) by the
factor by which each misses the measured pseudo damage, :meth:`GridResult.pairing_report`
gives each calibration's pairing of model and rig modes, and the CSV and plot writers give
the long tables and the bar plots like thesis Figures 22-27.
"""

from __future__ import annotations

import csv
import math
import os
import re
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.signals.fatigue import RelativeDamage

__all__ = ["SENSOR_GROUPS", "BAND", "sensor_group", "CellResult", "GridResult"]

#: sensor groups of the grid's reading, in the order they are reported
SENSOR_GROUPS = ("frame and cross members", "tanks", "brackets", "rear attachments")
#: the acceptance band of relative pseudo damage (ratios)
BAND = (0.5, 2.0)


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
                        cases, out / f"model{m}_{file_slug(s)}_dampings.png",
                        title=f"Model {m}, {s}: relative pseudo damage by damping"))
            for d in dampings:
                cases = {c.signal: c.damage for c in self.cells if c.model == m and c.damping == d}
                if len(cases) > 1:
                    written.append(plot_relative_pseudo_damage(
                        cases, out / f"model{m}_{file_slug(d)}_signals.png",
                        title=f"Model {m}, {d} damping: relative pseudo damage by signal"))
            written.append(plot_damage_summary(
                self.group_ratios(m), out / f"model{m}_summary.png",
                title=f"Model {m}: relative pseudo damage by sensor group and damping\n"
                      f"(signals: {', '.join(signals)})"))
        return written


def file_slug(text: str) -> str:
    """Return ``text`` with every run of characters unsafe in a file name replaced by ``-``."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text)
