"""Explain stage: plain-language text of a level-trend finding, and the figures of the report."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from exudyn_study.diagnose.levels.screen import NONLINEAR, ModeTrend
from exudyn_study.diagnose.schema import Diagnosis, Finding

__all__ = [
    "explain_finding",
    "diagnosis_without_law",
    "diagnosis_with_law",
    "plot_amplitude",
    "plot_overlays",
]

_WORDS = {
    "joint_friction": "micro-slip friction (frequency down, damping up with amplitude)",
    "joint_softening": "softening without added damping",
    "joint_stiffening": "hardening (frequency up with amplitude)",
    "joint_clearance": "a clearance closing (frequency up beyond a threshold amplitude)",
    "joint_damping": "damping rising with amplitude at constant frequency",
}


def explain_finding(
    physics: str,
    trends: list[ModeTrend],
    pair,
    proof: dict,
    holdout: list[str],
    located_by: str | None = None,
) -> str:
    """One paragraph: what changes with level, where, and how much the model improves on held-out levels.

    Parameters
    ----------
    physics : str
        The dominant screened outcome (one of :data:`~.screen.NONLINEAR`); the modes with this
        outcome are described with their frequency and damping changes.
    trends : list of ModeTrend
        Every mode's screened trend.
    pair : (str, str) or None
        The located sensor pair, or None when no pair's relative motion changed significantly.
    proof : dict
        Errors per level label, from :func:`~.fit.prove`.
    holdout : list of str
        Labels of the held-out levels whose error before and after is quoted.
    located_by : str, optional
        'eigenvalue sensitivity' or 'relative motion': the evidence that located ``pair``.

    Returns
    -------
    str
        The paragraph.
    """
    moving = [t for t in trends if t.outcome == physics]
    modes = "; ".join(
        f"mode {t.mode} at {t.frequency_hz:.4g} Hz: frequency {100 * t.frequency_change:+.2f} % "
        f"({t.frequency_z:+.1f} sigma), damping {100 * t.damping_change:+.0f} % ({t.damping_z:+.1f} sigma)"
        for t in moving
    )
    if pair and located_by == "eigenvalue sensitivity":
        where = (
            f"between sensors {pair[0]} and {pair[1]}: a stiffness change across that pair, weighted by each "
            "mode's coupling to it, explains every mode's change of frequency and damping across the levels "
            "better than across any other pair"
        )
    elif pair:
        where = (
            f"between sensors {pair[0]} and {pair[1]}, whose relative motion in these modes changes most "
            "with level"
        )
    else:
        where = "at no single sensor pair (the relative motions do not change significantly)"
    ho = "; ".join(f"{k}: {proof[k]['mean_before']:.3g} -> {proof[k]['mean_after']:.3g}" for k in holdout)
    return (
        f"The modal parameters change with drive level as {_WORDS.get(physics, physics)}: {modes}. "
        f"The level dependence sits {where}. One joint law across that pair (Jenkins micro-slip "
        "or a power-law "
        "stiffness, fitted on the training levels) predicts the held-out levels from their drive "
        "alone: relative FRF error "
        f"{ho}."
    )


def diagnosis_without_law(trends: list[ModeTrend], channels, band, meta: dict) -> Diagnosis | None:
    """Return the diagnosis when no joint law is fitted (no level dependence, or one channel), else None.

    Three diagnoses end here: a level dependence seen with a single response channel (reported as
    unexplained: one channel holds no relative motion to locate or model it); modes that scatter
    between levels without a trend (unexplained, not level dependent); nothing (no mismatch).

    Parameters
    ----------
    trends : list of ModeTrend
        Every mode's screened trend.
    channels : sequence of str
        The response channels (the location of an unexplained entry).
    band : (float, float)
        The analysis band in Hz.
    meta : dict
        The diagnosis metadata; its ``'summary'`` is set here, and it becomes the returned
        diagnosis's metadata.

    Returns
    -------
    Diagnosis or None
        None when some mode is level dependent and there are at least two channels: the joint
        law is to be located, fitted and proven.
    """
    nonlin = [t for t in trends if t.outcome in NONLINEAR]
    if nonlin and len(channels) < 2:
        meta["summary"] = (
            f"{nonlin[0].outcome} in the modal trends (one channel: not located, no joint law fitted)"
        )
        modes = ", ".join(
            f"{t.mode} ({t.frequency_hz:.4g} Hz): {t.outcome}, frequency {100 * t.frequency_change:+.2f} %, "
            f"damping {100 * t.damping_change:+.0f} %"
            for t in nonlin
        )
        text = (
            f"modes {modes}; one response channel holds no relative motion, so the joint is neither located "
            "nor modelled"
        )
        un = {
            "location": {"sensors": list(channels)},
            "band_hz": list(band),
            "level_dependent": True,
            "explanation": text,
        }
        return Diagnosis(True, (), (un,), meta)
    if nonlin:
        return None
    mis = [t for t in trends if t.outcome == "linear_mismodelled"]
    if not mis:
        meta["summary"] = (
            "no level dependence: every mode keeps its frequency and damping across the levels "
            "within their uncertainty, and the reference model reproduces its recording"
        )
        return Diagnosis(False, (), (), meta)
    meta["summary"] = "linear but mis-modelled: modes scatter between levels without a trend"
    text = (
        "modes "
        + ", ".join(f"{t.mode} ({t.frequency_hz:.4g} Hz)" for t in mis)
        + " change between levels beyond their uncertainty but not with the level: a linear effect the "
        "reference model does not hold (time variance, temperature, a changed set-up)"
    )
    un = {
        "location": {"sensors": list(channels)},
        "band_hz": list(band),
        "level_dependent": False,
        "explanation": text,
    }
    return Diagnosis(True, (), (un,), meta)


def diagnosis_with_law(
    physics, trends, pair, law, proof, model, labels, train, holdout, band, meta
) -> Diagnosis:
    """Return the finding with its proof, or an unexplained mismatch if the law misses held-out levels.

    The law is taken as the explanation only when it lowers the mean relative FRF error of the
    held-out levels below the reference model's; otherwise the level dependence is reported as
    unexplained and the rejected fit kept in ``meta['fit_rejected']``. An accepted finding carries
    flags for doubts: a pair that was not located, held-out levels the law does not improve,
    degenerate modal masses, a reference model beyond the noise of its own recording.

    Parameters
    ----------
    physics : str
        The dominant screened outcome (one of :data:`~.screen.NONLINEAR`), the finding's physics.
    trends : list of ModeTrend
        Every mode's screened trend; the level-dependent modes give the finding's band.
    pair : (str, str) or None
        The located sensor pair, or None (the law was then fitted across the best-ranked pair,
        ``law.pair``, and the finding is flagged as not located).
    law : JointLaw
        The fitted joint law; its parameters become the finding's.
    proof : dict
        Errors per level label, from :func:`~.fit.prove`.
    model : ReferenceModel
        The reference model, for its self-check and degenerate-mass flags.
    labels : list of str
        Labels of all levels, indexed by ``train`` and ``holdout``.
    train, holdout : list of int
        Indices into ``labels`` of the training and the held-out levels.
    band : (float, float)
        The analysis band in Hz (named in the error metric).
    meta : dict
        The diagnosis metadata; ``'joint_law'`` and ``'summary'`` (and ``'fit_rejected'``) are set
        here, and it becomes the returned diagnosis's metadata.

    Returns
    -------
    Diagnosis
        With one finding, or with one unexplained level-dependent mismatch.
    """
    ho_labels, tr_labels = [labels[i] for i in holdout], [labels[i] for i in train]
    fit = {
        "train_before": float(np.mean([proof[k]["mean_before"] for k in tr_labels])),
        "train_after": float(np.mean([proof[k]["mean_after"] for k in tr_labels])),
        "holdout_before": float(np.mean([proof[k]["mean_before"] for k in ho_labels])),
        "holdout_after": float(np.mean([proof[k]["mean_after"] for k in ho_labels])),
        "metric": (
            f"relative FRF error ||H_model - H_meas|| / ||H_meas|| in {band[0]:.4g}-{band[1]:.4g} Hz per "
            "channel, mean over channels; held-out levels predicted from their drive alone"
        ),
        "per_level": {
            k: {
                "before": v["before"],
                "after": v["after"],
                "mean_before": v["mean_before"],
                "mean_after": v["mean_after"],
                "floor": v["floor"],
                "mean_floor": v["mean_floor"],
                "mean_noise_floor": v["mean_noise_floor"],
                "mean_own_fit": v["mean_own_fit"],
                "held_out": k in ho_labels,
                "relative_displacement_predicted_m": v["sigma_predicted_m"],
                "relative_displacement_measured_m": v["sigma_measured_m"],
            }
            for k, v in proof.items()
        },
    }
    params = {
        k: {
            "value": float(v["value"]),
            "unit": v["unit"],
            "std": float(v["std"]) if np.isfinite(v["std"]) else None,
        }
        for k, v in law.parameters.items()
    }
    meta["joint_law"] = {
        "kind": law.kind,
        "pair": list(law.pair),
        "shape": {k: np.asarray(v).tolist() for k, v in law.shape.items()},
        "modes": [
            {"mode": r + 1, "f0_hz": float(f), "zeta0": float(z), "coupling_rad2_per_s2": float(c)}
            for r, f, z, c in zip(law.modes, law.f0_hz, law.zeta0, law.coupling, strict=True)
        ],
    }
    location = {"sensors": list(pair) if pair else [], "interface": f"{pair[0]}-{pair[1]}" if pair else None}
    fmodes = [t for t in trends if t.outcome in NONLINEAR]
    mband = (float(min(t.frequency_hz for t in fmodes)), float(max(t.frequency_hz for t in fmodes)))
    text = explain_finding(physics, trends, pair, proof, ho_labels, meta.get("located_by"))
    if not fit["holdout_after"] < fit["holdout_before"]:
        # a law that does not predict the held-out levels better than the reference explains nothing
        meta["fit_rejected"] = fit
        meta["summary"] = f"{physics} in the modal trends, but no joint law predicts the held-out levels"
        text += " The law does not reduce the held-out error, so it is not taken as an explanation."
        un = {"location": location, "band_hz": list(mband), "level_dependent": True, "explanation": text}
        return Diagnosis(True, (), (un,), meta)
    flags = []
    if pair is None:
        flags.append(
            f"not located: the law is fitted across the best-ranked pair {law.pair[0]}-{law.pair[1]}, "
            "whose change is not significant"
        )
    worse = [k for k in ho_labels if proof[k]["mean_after"] >= proof[k]["mean_before"]]
    if worse:
        flags.append(f"the fitted model does not improve the held-out level(s) {', '.join(worse)}")
    flags.extend(model.degenerate)
    beyond = [c for c, v in model.check.items() if not v["within_noise"]]
    if beyond:
        errs = ", ".join(f"{model.check[c]['relative_error']:.2f}" for c in beyond)
        flags.append(
            "the reference model misfits its own recording beyond the noise at "
            f"{', '.join(beyond)} (relative error {errs}): the lowest level may itself be nonlinear; "
            "the trends are relative to it"
        )
    finding = Finding(physics, location, mband, True, text, params, fit, tuple(flags))
    meta["summary"] = f"{physics}" + (f" between {pair[0]} and {pair[1]}" if pair else " (not located)")
    return Diagnosis(True, (finding,), (), meta)


def plot_amplitude(table, trends, path: Path) -> Path:
    """Plot frequency and damping of each level-dependent mode (else all) against amplitude (1-sigma bars).

    At most 6 modes, one column each: frequency (Hz) above, damping ratio (%) below, against
    the mode's rms amplitude on a log axis.

    Parameters
    ----------
    table : ModalTable
        Modal parameters per level with their standard deviations and amplitudes.
    trends : list of ModeTrend
        One per mode of ``table`` in its order; modes whose outcome is not 'linear' are
        plotted, or all modes when every one is linear.
    path : path-like
        Image file to write (the format from its suffix, e.g. ``.png``).

    Returns
    -------
    path-like
        ``path``.
    """
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
    """Measured, nominal (reference model) and fitted FRF magnitudes per level at the sensors ``show``.

    One row per level and one column per sensor, each titled with its relative FRF error before
    and after.

    Parameters
    ----------
    proof : dict
        Errors and FRFs per level label, from :func:`~.fit.prove`.
    labels : list of str
        Levels to plot (keys of ``proof``), one row each.
    channels : sequence of str
        All response channels, in the order of the FRF arrays' first axis.
    show : list of str
        The channels to plot, one column each.
    unit : str
        The FRF unit for the axis label, e.g. ``'m/s^2/N'``.
    path : path-like
        Image file to write (the format from its suffix, e.g. ``.png``).
    band_hz : (float, float), optional
        Frequency axis limits in Hz (default: the lines of the data).

    Returns
    -------
    path-like
        ``path``.
    """
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
