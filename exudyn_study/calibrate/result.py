"""The calibration's result: the Tables 5/7 analogue and its JSON (``format`` 'exudyn_study.calibration')."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FORMAT_NAME = "exudyn_study.calibration"


FORMAT_VERSION = 1


@dataclass(frozen=True)
class ModeRow:
    """One row of the Tables 5/7 analogue (ratios as fractions; None where not applicable).

    Attributes
    ----------
    mode : int or None
        Model mode number in the band (1-based), None for an unpaired target.
    frequency_hz, damping_ratio : float or None
        Achieved model mode.
    target_frequency_hz, target_damping_ratio : float or None
        Paired target mode (None for an unpaired model mode).
    mac : float or None
        MAC of the pair at the shared sensors (None without shapes).
    error : float or None
        ``damping_ratio - target_damping_ratio``.
    """

    mode: int | None
    frequency_hz: float | None
    damping_ratio: float | None
    target_frequency_hz: float | None
    target_damping_ratio: float | None
    mac: float | None
    error: float | None


def _f(v):
    return None if v is None or not np.isfinite(v) else float(v)


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """Outcome of :func:`calibrate`: the Tables 5/7 analogue and the chosen body damping.

    Attributes
    ----------
    rows : tuple of ModeRow
        Model modes in the band (paired or not) and unpaired targets, by frequency.
    variable_names : tuple of str
    variables : ndarray
        Chosen design variables (fractions).
    body_damping : mapping str -> ndarray
        Chosen damping ratio of every mode of every calibrated body.
    body_frequencies_hz : mapping str -> ndarray
    design_mask : mapping str -> ndarray of bool
        Which body modes were design variables (the others fixed).
    success : bool
    message : str
    n_evaluations : int
        Eigen-solves (residual and Jacobian share one).
    n_pairings : int
        Least-squares solves (a new one whenever re-pairing changed the pairs).
    wall_time_s : float
        Calibration time, linearisation included.
    linearise_time_s, evaluation_time_s : float
        Time of the one linearisation and mean time of one eigen-solve with derivatives.
    exudyn_check : float or None
        With ``verify=True``: largest |damping ratio difference| between the linear basis
        and Exudyn's eigenvalues of the system rebuilt with the chosen damping.
    settings : mapping
    """

    rows: tuple[ModeRow, ...]
    variable_names: tuple[str, ...]
    variables: np.ndarray
    body_damping: Mapping[str, np.ndarray]
    body_frequencies_hz: Mapping[str, np.ndarray]
    design_mask: Mapping[str, np.ndarray]
    success: bool
    message: str
    n_evaluations: int
    n_pairings: int
    wall_time_s: float
    linearise_time_s: float
    evaluation_time_s: float
    exudyn_check: float | None
    settings: Mapping

    @property
    def paired(self) -> tuple[ModeRow, ...]:
        """Rows with both a model and a target mode."""
        return tuple(r for r in self.rows if r.error is not None)

    @property
    def max_abs_error(self) -> float:
        """Largest |achieved - target| damping ratio over the paired modes (fraction)."""
        return max((abs(r.error) for r in self.paired), default=float("nan"))

    @property
    def unpaired_targets(self) -> tuple[ModeRow, ...]:
        """Target modes no model mode could be paired with."""
        return tuple(r for r in self.rows if r.mode is None)

    @property
    def unpaired_model(self) -> tuple[ModeRow, ...]:
        """Model modes in the band without a target."""
        return tuple(r for r in self.rows if r.mode is not None and r.target_damping_ratio is None)

    def table(self) -> str:
        """Text table (thesis Tables 5/7 layout), ratios in percent."""

        def fmt(v, spec):
            return "-" if v is None else format(v, spec)

        lines = [
            f"{'mode':>4} {'f model Hz':>10} {'zeta %':>7} {'f target Hz':>11} {'target %':>8} "
            f"{'error pp':>8} {'MAC':>5}"
        ]

        def pct(v):
            return None if v is None else 100 * v

        for r in self.rows:
            lines.append(
                f"{fmt(r.mode, '4d'):>4} {fmt(r.frequency_hz, '10.2f'):>10} "
                f"{fmt(pct(r.damping_ratio), '7.3f'):>7} "
                f"{fmt(r.target_frequency_hz, '11.2f'):>11} {fmt(pct(r.target_damping_ratio), '8.3f'):>8} "
                f"{fmt(pct(r.error), '8.4f'):>8} {fmt(r.mac, '5.2f'):>5}"
            )
        return "\n".join(lines)

    def to_dict(self, metadata: Mapping | None = None) -> dict:
        """JSON-ready dict (``format`` 'exudyn_study.calibration'); ratios as fractions.

        Parameters
        ----------
        metadata : mapping, optional
            Free-form, JSON-serialisable (model, target file, ...).
        """
        modes = [
            {
                "mode": r.mode,
                "frequency_hz": r.frequency_hz,
                "damping_ratio": r.damping_ratio,
                "target_frequency_hz": r.target_frequency_hz,
                "target_damping_ratio": r.target_damping_ratio,
                "mac": r.mac,
                "error": r.error,
            }
            for r in self.rows
            if r.mode is not None
        ]
        unpaired = [
            {"target_frequency_hz": r.target_frequency_hz, "target_damping_ratio": r.target_damping_ratio}
            for r in self.unpaired_targets
        ]
        return {
            "format": FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "metadata": dict(metadata or {}),
            "modes": modes,
            "unpaired_targets": unpaired,
            "body_damping": {
                b: {
                    "frequency_hz": self.body_frequencies_hz[b].tolist(),
                    "damping_ratio": np.asarray(r).tolist(),
                    "design_variable": self.design_mask[b].tolist(),
                }
                for b, r in self.body_damping.items()
            },
            "variables": dict(zip(self.variable_names, map(float, self.variables), strict=True)),
            "convergence": {
                "success": bool(self.success),
                "message": self.message,
                "n_evaluations": int(self.n_evaluations),
                "n_pairings": int(self.n_pairings),
                "wall_time_s": float(self.wall_time_s),
                "linearise_time_s": float(self.linearise_time_s),
                "evaluation_time_s": float(self.evaluation_time_s),
                "max_abs_error": _f(self.max_abs_error),
                "exudyn_check": self.exudyn_check,
            },
            "settings": dict(self.settings),
        }

    def to_json(self, metadata: Mapping | None = None) -> str:
        """Serialise :meth:`to_dict` to JSON text.

        Parameters
        ----------
        metadata : Mapping, optional
            Extra JSON-serialisable entries passed to :meth:`to_dict` (None: none).

        Returns
        -------
        str
            The result as indented JSON text.
        """
        return json.dumps(self.to_dict(metadata), indent=1)

    def write_json(self, path: str | os.PathLike, metadata: Mapping | None = None) -> Path:
        """Write :meth:`to_json` atomically to ``path``; returns the path.

        Parameters
        ----------
        path : str or os.PathLike
            File to write; its directory must exist. An existing file is replaced.
        metadata : Mapping, optional
            Extra JSON-serialisable entries passed to :meth:`to_dict` (None: none).

        Returns
        -------
        pathlib.Path
            The written path.
        """
        path = Path(path)
        text = self.to_json(metadata)
        fd, tmp = tempfile.mkstemp(
            dir=path.parent if str(path.parent) else ".", prefix=".calib-", suffix=".json"
        )
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return path

    def plot(self, path: str | os.PathLike | None = None, max_frequency_hz: float | None = None):
        """Chosen body damping against body mode frequency (like thesis Figure 18).

        Parameters
        ----------
        path : path-like, optional
            Save the figure there (PNG by suffix).
        max_frequency_hz : float, optional
            Right end of the frequency axis (default: 1.5 x the highest design mode, or all).

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib

        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7.5, 4.2))
        design_f = [f[self.design_mask[b]] for b, f in self.body_frequencies_hz.items()]
        top = max((f.max() for f in design_f if f.size), default=None)
        f_all = max(f.max() for f in self.body_frequencies_hz.values())
        all_design = all(m.all() for m in self.design_mask.values())
        fmax = max_frequency_hz or (1.05 * f_all if all_design or not top else min(1.5 * top, 1.05 * f_all))
        for k, (b, f) in enumerate(self.body_frequencies_hz.items()):
            r = 100 * np.asarray(self.body_damping[b])
            dm = self.design_mask[b]
            color = f"C{k % 10}"
            sel = f <= fmax
            ax.plot(f[sel], r[sel], "-", color=color, lw=0.8, alpha=0.6)
            ax.plot(f[dm & sel], r[dm & sel], "o", color=color, label=f"{b} (calibrated)")
            if np.any(~dm & sel):
                ax.plot(f[~dm & sel], r[~dm & sel], "o", mfc="none", color=color, label=f"{b} (fixed)")
        ax.set_xlabel("flexible-body mode frequency (Hz)")
        ax.set_ylabel("modal damping ratio (%)")
        ax.set_xlim(0, fmax)
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(
            f"Calibrated flexible-body damping: {len(self.paired)} paired modes, "
            f"max error {100 * self.max_abs_error:.3f} pp"
        )
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=120)
            plt.close(fig)
        return fig
