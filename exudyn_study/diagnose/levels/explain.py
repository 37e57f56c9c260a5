"""Explain stage: plain-language text of a level-trend finding, and the figures of the report."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from exudyn_study.diagnose.levels.screen import ModeTrend

__all__ = ["explain_finding", "plot_amplitude", "plot_overlays"]

_WORDS = {
    "joint_friction": "micro-slip friction (frequency down, damping up with amplitude)",
    "joint_softening": "softening without added damping",
    "joint_stiffening": "hardening (frequency up with amplitude)",
    "joint_clearance": "a clearance closing (frequency up beyond a threshold amplitude)",
    "joint_damping": "damping rising with amplitude at constant frequency",
}


def explain_finding(physics: str, trends: list[ModeTrend], pair, proof: dict, holdout: list[str]) -> str:
    """One paragraph: what changes with level, where, and how much the model improves on held-out levels."""
    moving = [t for t in trends if t.outcome == physics]
    modes = "; ".join(
        f"mode {t.mode} at {t.frequency_hz:.4g} Hz: frequency {100 * t.frequency_change:+.2f} % "
        f"({t.frequency_z:+.1f} sigma), damping {100 * t.damping_change:+.0f} % ({t.damping_z:+.1f} sigma)"
        for t in moving
    )
    where = (
        f"between sensors {pair[0]} and {pair[1]}, whose relative motion in these modes changes most with "
        "level"
        if pair
        else "at no single sensor pair (the relative motions do not change significantly)"
    )
    ho = "; ".join(f"{k}: {proof[k]['mean_before']:.3g} -> {proof[k]['mean_after']:.3g}" for k in holdout)
    return (
        f"The modal parameters change with drive level as {_WORDS.get(physics, physics)}: {modes}. "
        f"The level dependence sits {where}. One joint law across that pair (Jenkins micro-slip "
        "or a power-law "
        "stiffness, fitted on the training levels) predicts the held-out levels from their drive "
        "alone: relative FRF error "
        f"{ho}."
    )


def plot_amplitude(table, trends, path: Path) -> Path:
    """Plot frequency and damping of each level-dependent mode (else all) against amplitude (1-sigma bars)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    modes = [t.mode - 1 for t in trends if t.outcome not in ("linear",)] or list(range(len(trends)))
    modes = modes[:6]
    fig, ax = plt.subplots(2, len(modes), figsize=(3.2 * len(modes) + 1, 5.5), squeeze=False)
    for k, r in enumerate(modes):
        a = table.amplitude[:, r]
        o = np.argsort(a)
        ax[0, k].errorbar(
            a[o], table.frequency_hz[o, r], yerr=table.frequency_std_hz[o, r], marker="o", capsize=3
        )
        ax[1, k].errorbar(
            a[o],
            100 * table.damping_ratio[o, r],
            yerr=100 * table.damping_std[o, r],
            marker="o",
            capsize=3,
            color="C3",
        )
        ax[0, k].set_title(f"mode {r + 1}: {trends[r].outcome}", fontsize=9)
        ax[1, k].set_xlabel(f"rms amplitude at {table.amplitude_channel[r]} ({table.amplitude_unit})")
        for a_ in ax[:, k]:
            a_.set_xscale("log")
            a_.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            a_.grid(True, alpha=0.3)
    ax[0, 0].set_ylabel("frequency (Hz)")
    ax[1, 0].set_ylabel("damping ratio (%)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_overlays(
    proof: dict, labels: list[str], channels, show: list[str], unit: str, path: Path, band_hz=None
) -> Path:
    """Measured, nominal (reference model) and fitted FRF magnitudes per level at the sensors ``show``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    idx = [list(channels).index(s) for s in show]
    fig, ax = plt.subplots(
        len(labels), len(idx), figsize=(4.2 * len(idx), 2.4 * len(labels) + 0.6), squeeze=False, sharex=True
    )
    for i, lab in enumerate(labels):
        p = proof[lab]
        for k, c in enumerate(idx):
            a = ax[i, k]
            a.semilogy(p["freq_hz"], np.abs(p["H_measured"][c]), "k.", ms=2, label="measured")
            a.semilogy(p["freq_hz"], np.abs(p["H_nominal"][c]), "C0-", lw=0.9, label="nominal (reference)")
            a.semilogy(p["freq_hz"], np.abs(p["H_fitted"][c]), "C3--", lw=0.9, label="fitted")
            a.set_title(
                f"{lab}: {channels[c]} (err {p['before'][channels[c]]:.2g} -> {p['after'][channels[c]]:.2g})",
                fontsize=8,
            )
            a.set_ylabel(f"|H| ({unit})", fontsize=8)
            if band_hz is not None:
                a.set_xlim(*band_hz)
    ax[0, 0].legend(fontsize=7)
    for a in ax[-1]:
        a.set_xlabel("frequency (Hz)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
