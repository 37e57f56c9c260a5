"""Bar plots of relative pseudo damage, after thesis Figs 22-27.

One group of bars per sensor, one bar per case (e.g. damping function), a line at
100 % (simulation = measurement). Uses matplotlib's object API (no pyplot state) and
writes the figure atomically.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.signals.fatigue import RelativeDamage

__all__ = ["plot_relative_pseudo_damage", "plot_damage_summary"]


def plot_relative_pseudo_damage(
    results: Mapping[str, RelativeDamage] | Sequence[RelativeDamage] | RelativeDamage,
    path: str | os.PathLike,
    *,
    channels: Sequence[str] | None = None,
    title: str | None = None,
    log: bool | None = None,
    dpi: int = 150,
) -> Path:
    """Plot relative pseudo damage per sensor as grouped bars and save the figure.

    Parameters
    ----------
    results : mapping label -> RelativeDamage, or sequence, or one RelativeDamage
        The cases to compare (e.g. ``{'Adams default': r1, 'STEP': r2, 'suggested':
        r3}``); a sequence is labelled ``case 1, case 2, ...``.
    path : str or path-like
        Output image; the suffix chooses the format (``.png``, ``.pdf``, ``.svg``).
    channels : sequence of str, optional
        Sensors to show, in this order. Default: the first result's channels.
    title : str, optional
        Axes title.
    log : bool, optional
        Logarithmic y axis. Default: log when the ratios span more than a factor 20
        (the thesis's figures range from ~10 % to several 1000 %), linear otherwise.
    dpi : int, optional
        Resolution of raster output.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    InputError
        If there are no results, or a requested channel is missing from a result.
    """
    from matplotlib.figure import Figure

    if isinstance(results, RelativeDamage):
        results = {"simulation": results}
    elif not isinstance(results, Mapping):
        results = {f"case {i + 1}": r for i, r in enumerate(results)}
    if not results:
        raise InputError("plot_relative_pseudo_damage: no results to plot")
    for label, r in results.items():
        if not isinstance(r, RelativeDamage):
            raise InputError(f"result {label!r} is a {type(r).__name__}; expected a RelativeDamage")
    first = next(iter(results.values()))
    names = list(channels) if channels is not None else list(first.names)
    pct = np.array([[100.0 * r[n].ratio for n in names] for r in results.values()])
    finite = pct[np.isfinite(pct) & (pct > 0)]
    if log is None:
        log = finite.size > 0 and finite.max() / finite.min() > 20.0

    n_cases, n_ch = pct.shape
    fig = Figure(figsize=(max(6.0, (0.25 + 0.1 * n_cases) * n_ch + 3.5), 4.2))
    ax = fig.add_subplot()
    width = 0.8 / n_cases
    xpos = np.arange(n_ch)
    for k, (label, row) in enumerate(zip(results, pct, strict=True)):
        ax.bar(xpos - 0.4 + (k + 0.5) * width, np.nan_to_num(row, nan=0.0), width, label=label)
    ax.axhline(100.0, color="k", lw=1.0, ls="--", label="100 % (= measured)")
    if log:
        ax.set_yscale("log")
        lo = 10 ** math.floor(math.log10(min(finite.min(), 100.0)))
        hi = 10 ** math.ceil(math.log10(max(finite.max(), 100.0)))
        ax.set_ylim(lo, hi)
    else:
        ax.set_ylim(0.0, 1.1 * max(finite.max() if finite.size else 100.0, 100.0))
    ax.set_xticks(xpos, names, rotation=60, ha="right", fontsize=8)
    ax.set_ylabel(f"relative pseudo damage [%]  (beta = {first.beta:g})")
    ax.set_xlim(-0.6, n_ch - 0.4)
    ax.grid(axis="y", which="major", alpha=0.4)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    if title:
        ax.set_title(title)
    fig.tight_layout()

    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise InputError(f"plot path {str(path)!r}: directory does not exist")
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{path.name}.", suffix=f".tmp.{fmt}")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=dpi, format=fmt)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def plot_damage_summary(
    ratios: Mapping[str, Mapping[str, Sequence[float]]],
    path: str | os.PathLike,
    *,
    title: str | None = None,
    band: tuple[float, float] = (50.0, 200.0),
    dpi: int = 150,
) -> Path:
    """Plot relative pseudo damage per sensor group and case: every value and the group's median.

    Parameters
    ----------
    ratios : mapping group -> mapping case -> sequence of float
        Relative pseudo damage as ratios (1 = measured), e.g. per sensor group (frame,
        tanks, ...) and damping the values over its sensors and signals.
    path : str or path-like
        Output image (suffix chooses the format).
    title : str, optional
    band : (float, float)
        Acceptance band in percent, shaded (default 50-200 %).
    dpi : int

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InputError
        If there is nothing to plot or the directory does not exist.
    """
    from matplotlib.figure import Figure

    groups = [g for g, cases in ratios.items() if cases]
    if not groups:
        raise InputError("plot_damage_summary: no ratios to plot")
    cases = list(dict.fromkeys(c for g in groups for c in ratios[g]))
    fig = Figure(figsize=(max(8.0, 0.45 * len(groups) * len(cases) + 4.0), 4.6))
    ax = fig.add_subplot()
    ax.axhspan(*band, color="0.85", zorder=0, label=f"{band[0]:g}-{band[1]:g} %")
    ax.axhline(100.0, color="k", lw=1.0, ls="--", zorder=1, label="100 % (= measured)")
    width = 0.8 / len(cases)
    rng = np.random.default_rng(0)  # fixed jitter: the same figure for the same data
    allv = []
    for gi, g in enumerate(groups):
        for ci, c in enumerate(cases):
            v = 100.0 * np.asarray(ratios[g].get(c, ()), dtype=float)
            v = v[np.isfinite(v) & (v > 0)]
            if not v.size:
                continue
            allv.append(v)
            x0 = gi - 0.4 + (ci + 0.5) * width
            ax.scatter(x0 + (rng.random(v.size) - 0.5) * 0.6 * width, v, s=10, color=f"C{ci}", alpha=0.5,
                       zorder=2, linewidths=0)
            ax.plot([x0 - 0.4 * width, x0 + 0.4 * width], [np.median(v)] * 2, color=f"C{ci}", lw=3,
                    zorder=3, label=c if gi == 0 or c not in ax.get_legend_handles_labels()[1] else None)
    ax.set_yscale("log")
    if allv:
        cat = np.concatenate(allv)
        lo = 10 ** math.floor(math.log10(min(cat.min(), band[0])))
        hi = 10 ** math.ceil(math.log10(max(cat.max(), band[1])))
        ax.set_ylim(lo, hi)
    ax.set_xticks(np.arange(len(groups)), groups)
    ax.set_xlim(-0.6, len(groups) - 0.4)
    ax.set_ylabel("relative pseudo damage [%]")
    ax.grid(axis="y", which="major", alpha=0.4)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False,
              title="bar: median; dots: sensors x signals", title_fontsize=7)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise InputError(f"plot path {str(path)!r}: directory does not exist")
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{path.name}.", suffix=f".tmp.{fmt}")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=dpi, format=fmt)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
