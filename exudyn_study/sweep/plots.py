"""Sensitivity plot of a sweep: a task's output family against one swept parameter.

The family is every output whose name starts with the task's ``plot_prefix`` (e.g.
``rpd.<sensor>``: relative pseudo damage per z sensor). One panel per combination of the
other swept parameters (e.g. per drive signal); replicates (swept ``seed``) are averaged.

- numeric swept parameter: one line per family member against the parameter;
- categorical swept parameter (e.g. the damping function): grouped bars, one group per
  family member, one bar per value (the layout of the thesis's damage figures).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.sweep.config import SweepConfig
from exudyn_study.sweep.tasks import Task

__all__ = ["plot_sweep", "save_sweep_plot", "family_columns"]

MAX_PANELS = 6


def family_columns(rows: Sequence[Mapping[str, Any]], task: Task) -> list[str]:
    """Output columns plotted for ``task`` (its ``plot_prefix`` family, else its summary).

    Parameters
    ----------
    rows : sequence of mapping
        Result rows; their keys are the candidate columns.
    task : Task
        The sweep's task.

    Returns
    -------
    list of str
        The columns of the rows that start with ``task.plot_prefix`` (in the order of the rows'
        keys), or, if there are none, the outputs of ``task.summary`` present in the rows (in the
        order of the summary).
    """
    names: list[str] = []
    for r in rows:
        names.extend(k for k in r if k not in names)
    if task.plot_prefix:
        fam = [n for n in names if n.startswith(task.plot_prefix)]
        if fam:
            return fam
    return [n for n in task.summary if n in names]


#: what a task's output family is, by its prefix (the x axis of a grouped-bar plot)
FAMILY_LABELS = {"rpd.": "z sensor", "f.": "mode"}


def _config_order(config: SweepConfig, names: Sequence[str], values: Sequence[Any]) -> list:
    """Sort key of a combination of parameter values: their positions in the configuration."""
    key = []
    for name, value in zip(names, values, strict=True):
        spec = next((p for p in config.parameters if p.name == name), None)
        grid = spec.grid_values() if spec is not None else []
        key.append((grid.index(value), "") if value in grid else (len(grid), str(value)))
    return key


def _line_styles(n: int) -> list[tuple]:
    """``n`` distinguishable (colour, line style, marker) triples: ten colours times three styles."""
    import matplotlib.pyplot as plt

    colors = plt.get_cmap("tab10").colors
    styles = [("-", "o"), ("--", "s"), (":", "^")]
    return [(colors[i % 10], *styles[(i // 10) % 3]) for i in range(n)]


def _numeric(values: Sequence[Any]) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def plot_sweep(rows: Sequence[Mapping[str, Any]], config: SweepConfig, task: Task, x: str | None = None):
    """Plot the output family of ``task`` against the swept parameter ``x``.

    Parameters
    ----------
    rows : sequence of mapping
        Result rows (failed rows are skipped).
    config : SweepConfig
    task : Task
    x : str, optional
        Swept parameter on the horizontal axis; default the first swept numeric
        parameter, else the first swept one (``seed`` excluded).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    InputError
        If ``x`` is not swept, nothing is swept, or no row succeeded.
    """
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    swept = [s for s in config.swept if s != "seed"]
    if not swept:
        raise InputError("plot: no parameter is swept (besides seed); nothing to plot against")
    if not ok:
        raise InputError("plot: no successful point to plot")
    if x is None:
        numeric = [s for s in swept if _numeric([r[s] for r in ok])]
        x = numeric[0] if numeric else swept[0]
    if x not in swept:
        raise InputError(f"--plot-x {x!r}: expected one of the swept parameters {swept}")
    family = family_columns(ok, task)
    if not family:
        raise InputError(f"plot: task {task.name!r} has no outputs to plot")
    others = [s for s in swept if s != x]
    groups = sorted({tuple(r[o] for o in others) for r in ok}, key=lambda g: _config_order(config, others, g))
    groups = groups[:MAX_PANELS]
    xs = list(dict.fromkeys(r[x] for r in ok))
    is_num = _numeric(xs)
    xs = sorted(xs) if is_num else sorted(xs, key=lambda v: _config_order(config, [x], [v]))
    ncol = min(len(groups), 2 if len(groups) > 1 else 1)
    nrow = math.ceil(len(groups) / ncol)
    width = 7.5 * ncol if not is_num else 6 * ncol + 2
    fig, axes = plt.subplots(nrow, ncol, figsize=(width, 3.8 * nrow + 0.4),
                             squeeze=False, layout="constrained")
    all_vals = [r[c] for r in ok for c in family if isinstance(r.get(c), (int, float))]
    positive = [v for v in all_vals if v is not None and v > 0 and math.isfinite(v)]
    logy = bool(positive) and len(positive) == len(all_vals) and max(positive) / min(positive) > 100
    styles = _line_styles(len(family))
    family_label = FAMILY_LABELS.get(task.plot_prefix, "output")
    for ax, group in zip(axes.ravel(), groups, strict=False):
        sel = [r for r in ok if tuple(r[o] for o in others) == group]
        # mean over replicates (seed) for each x value and family member
        table = np.full((len(xs), len(family)), np.nan)
        for i, xv in enumerate(xs):
            at = [r for r in sel if r[x] == xv]
            if at:
                table[i] = [np.nanmean([float(r.get(c, np.nan)) for r in at]) for c in family]
        if is_num:
            for j, name in enumerate(family):
                color, line, marker = styles[j]
                ax.plot(xs, table[:, j], ls=line, marker=marker, ms=3, lw=1, color=color,
                        label=name.removeprefix(task.plot_prefix))
            ax.set_xlabel(x)
            if min(xs) > 0 and max(xs) / min(xs) >= 10:
                ax.set_xscale("log")
                ax.minorticks_off()
            if len(xs) <= 12:
                ax.set_xticks(xs, [f"{v:.3g}" for v in xs])
        else:
            width = 0.8 / len(xs)
            pos = np.arange(len(family))
            for i, xv in enumerate(xs):
                ax.bar(pos + (i - (len(xs) - 1) / 2) * width, table[i], width,
                       color=plt.get_cmap("viridis")(i / max(len(xs) - 1, 1)), label=f"{x} = {xv}")
            ax.set_xticks(pos, [n.removeprefix(task.plot_prefix) for n in family], rotation=90,
                            fontsize=7)
            ax.set_xlabel(family_label)
        if task.plot_prefix == "rpd.":
            ax.axhline(1.0, color="k", lw=0.8, ls="--")
        if logy:
            ax.set_yscale("log")
        ax.set_ylabel(task.plot_label or "output")
        title = ", ".join(f"{o} = {v}" for o, v in zip(others, group, strict=True))
        if title:
            ax.set_title(title, fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
    for ax in axes.ravel()[len(groups):]:
        ax.set_visible(False)
    handles, labels = axes.ravel()[0].get_legend_handles_labels()
    if is_num:
        fig.legend(handles, labels, loc="outside right center", fontsize=7,
                   ncols=2 if len(family) > 16 else 1)
    else:
        fig.legend(handles, labels, loc="outside lower center", fontsize=8, ncols=min(len(xs), 6))
    what = task.plot_label or ", ".join(family)
    fig.suptitle(f"{what} per {family_label} against {x} (sweep {config.name!r}, task {task.name!r})",
                 fontsize=10)
    return fig


def save_sweep_plot(rows, config, task, path, x=None) -> None:
    """:func:`plot_sweep` written to ``path`` (PNG, 150 dpi).

    Parameters
    ----------
    rows : sequence of mapping
        Result rows (failed rows are skipped).
    config : SweepConfig
        The sweep's configuration.
    task : Task
        The sweep's task.
    path : str or os.PathLike
        PNG file to write.
    x : str, optional
        Swept parameter on the horizontal axis (default: see :func:`plot_sweep`).

    Raises
    ------
    InputError
        If ``x`` is not swept, nothing is swept, or no row succeeded.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig = plot_sweep(rows, config, task, x)
    fig.savefig(path, dpi=150)
    plt.close(fig)

