"""HTML report of a diagnosis with its figures (matplotlib, Agg, written to files).

:func:`write_report` writes ``index.html`` and PNGs into a directory:

- ``residual_map.png``: normalised residual ``|T_model - T|^2 / sigma^2`` per sensor and
  frequency, one panel per recording (1 is the noise level);
- ``frf_overlay.png``: measured vs nominal vs fitted transmissibility magnitude at the located
  sensors, on the held-out recordings first;
- ``errors.png``: FRF error per channel before and after, training and held-out;
- ``pseudo_damage.png``: pseudo-damage bars (measured / nominal / fitted) when given.

Every file is written to a temporary name and renamed, ``index.html`` last, so a reader
never sees a half-written report.
"""

from __future__ import annotations

import html
import json
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from exudyn_study.diagnose.schema import Diagnosis
from exudyn_study.errors import InputError

__all__ = ["write_report"]


def _figure(width: float, height: float):
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height))


def _save(fig, path: Path) -> Path:
    from exudyn_study.infra.atomic import atomic_write

    return atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, bbox_inches="tight", format="png"),
                        "figure")


def _unit(data: Mapping) -> str:
    return str(data.get("level_unit", "m/s^2")).replace("^2", "$^2$")


def _residual_map(data: Mapping, path: Path) -> Path | None:
    rmap = data.get("residual_map")
    if rmap is None:
        return None
    rmap = np.asarray(rmap, float)
    labels, freq, chans = list(data["labels"]), np.asarray(data["freq_hz"]), list(data["channels"])
    levels = np.asarray(data.get("levels", np.full(len(labels), np.nan)))
    order = np.argsort(levels) if np.all(np.isfinite(levels)) else np.arange(len(labels))
    # the reference is listed first and may repeat in the training set: show each label once
    seen, keep = set(), []
    for i in order:
        if labels[i] not in seen:
            seen.add(labels[i])
            keep.append(int(i))
    n = len(keep)
    fig = _figure(9.0, 1.1 + 1.0 * n * max(1, len(chans)) / 5)
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    z = np.log10(np.maximum(rmap[keep], 1e-3))
    vmax = max(2.0, float(np.nanpercentile(z, 99.5)))
    im = None
    for ax, i, zi in zip(axes, keep, z, strict=True):
        im = ax.pcolormesh(
            freq, np.arange(len(chans)), zi, vmin=-1.0, vmax=vmax, cmap="magma", shading="nearest"
        )
        ax.set_yticks(range(len(chans)))
        ax.set_yticklabels(chans, fontsize=7)
        role = (
            "held-out"
            if labels[i] in data.get("holdout", [])
            else ("train" if labels[i] in data.get("train", []) else "reference")
        )
        ax.set_ylabel(
            f"{labels[i]}\n{levels[i]:.3g} {_unit(data)}\n({role})",
            fontsize=7,
            rotation=0,
            ha="right",
            va="center",
        )
        for lo, _ in np.asarray(data.get("bands_hz", []))[1:]:
            ax.axvline(lo, color="w", lw=0.5, alpha=0.5)
    axes[-1].set_xlabel("frequency (Hz)")
    axes[0].set_title(
        "residual vs nominal model: log10(|T_model - T|^2 / sigma^2)  (0: at the noise level)", fontsize=9
    )
    fig.colorbar(im, ax=list(axes), shrink=0.8, label="log10 residual / noise")
    return _save(fig, path)


def _frf_overlay(data: Mapping, path: Path) -> Path | None:
    after = data.get("after_T") or {}
    nominal = data.get("nominal_T") or {}
    measured = data.get("measured") or {}
    chans = list(data.get("channels", []))
    sensors = [s for s in data.get("located_sensors", []) if s in chans][:3]
    lv = dict(zip(data.get("labels", []), np.asarray(data.get("levels", []), float), strict=False))
    # held-out recordings first, then the training recordings from the highest level down
    train = sorted(data.get("train", []), key=lambda lab: -lv.get(lab, 0.0))
    recs = [
        lab
        for lab in list(data.get("holdout", [])) + train
        if lab in measured and (lab in after or lab in nominal)
    ]
    recs = list(dict.fromkeys(recs))[:3]
    if not sensors or not recs:
        return None
    freq = np.asarray(data["freq_hz"])
    fig = _figure(3.6 * len(recs), 2.6 * len(sensors))
    axes = fig.subplots(len(sensors), len(recs), squeeze=False, sharex=True)
    levels = dict(zip(data.get("labels", []), np.asarray(data.get("levels", [])), strict=False))
    physics = str(data.get("physics", "the fit"))
    n_found = physics.count(" + ") + 1
    # a long list of findings would cover the plots: name them in the title of the report instead
    after_label = f"with {physics}" if len(physics) <= 40 else f"with the {n_found} findings"
    for r, s in enumerate(sensors):
        si = chans.index(s)
        for c, lab in enumerate(recs):
            ax = axes[r, c]
            ax.semilogy(freq, np.abs(measured[lab][si]), color="k", lw=1.2, label="measured")
            if nominal.get(lab) is not None:
                ax.semilogy(freq, np.abs(nominal[lab][si]), color="tab:red", lw=0.9, ls="--", label="nominal")
            if after.get(lab) is not None:
                ax.semilogy(freq, np.abs(after[lab][si]), color="tab:blue", lw=0.9, label=after_label)
            role = "held-out" if lab in data.get("holdout", []) else "train"
            lv = levels.get(lab, np.nan)
            ax.set_title(f"{s}, {lab}\n({role}, {lv:.3g} {_unit(data)})", fontsize=8)
            ax.grid(True, which="both", alpha=0.3)
            if c == 0:
                # a force drive gives accelerance (m/s^2 per N); a base drive a transmissibility
                force = data.get("level_unit") == "N"
                ax.set_ylabel("|H| (m/s$^2$/N)" if force else "|T| (acc / drive acc)")
            if r == len(sensors) - 1:
                ax.set_xlabel("frequency (Hz)")
    axes[0, 0].legend(fontsize=7)
    return _save(fig, path)


def _errors(diagnosis: Diagnosis, data: Mapping, path: Path) -> Path | None:
    if not diagnosis.findings:
        return None
    fit = diagnosis.findings[0].fit
    per = fit.get("per_channel") or {}
    if not per:
        return None
    # several findings: "after" is the final model with all of them (the first finding's own fit is
    # that of its round only), on the held-out recordings
    final = diagnosis.metadata.get("final_holdout_per_channel") if len(diagnosis.findings) > 1 else None
    if final:
        per = {
            lab: {ch: {"before": v["before"], "after": final[lab][ch]} for ch, v in chans_.items()}
            for lab, chans_ in per.items()
            if lab in final
        }
        after_name = f"the {len(diagnosis.findings)} findings"
    else:
        after_name = diagnosis.findings[0].physics
    chans = list(next(iter(per.values())))
    groups = {"train": list(data.get("train", [])), "held-out": list(data.get("holdout", []))}
    fig = _figure(_bar_width_in(len(chans), 1.1), 3.2)
    ax = fig.subplots()
    x = np.arange(len(chans))
    width = 0.2
    drawn = []
    colours = {
        ("train", "before"): "#f4a582",
        ("train", "after"): "#92c5de",
        ("held-out", "before"): "#ca0020",
        ("held-out", "after"): "#0571b0",
    }
    k = 0
    for g, labs in groups.items():
        labs = [lab for lab in labs if lab in per]
        if not labs:
            continue
        for when in ("before", "after"):
            vals = [np.mean([per[lab][ch][when] for lab in labs]) for ch in chans]
            ax.bar(x + (k - 1.5) * width, vals, width, color=colours[(g, when)], label=f"{g}, {when}")
            drawn += vals
            k += 1
    _log_axis_if_spread(ax, drawn)
    ax.set_xticks(x)
    many = len(chans) > 12
    ax.set_xticklabels(chans, rotation=45 if many else 0, ha="right" if many else "center",
                       fontsize=7 if many else None)
    kind = "FRF error" if "FRF" in str(fit.get("metric", "")) else "error"
    ax.set_ylabel(f"relative {kind} (-)")
    ax.set_title(
        f"{kind} per channel, nominal (before) vs with {after_name} (after)", fontsize=9
    )
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, axis="y", alpha=0.3)
    return _save(fig, path)


def _bar_width_in(n_channels: int, per_channel_in: float) -> float:
    """Figure width of a per-channel bar chart (in): grows with the channels, capped for 42 sensors."""
    return min(24.0, max(6.0, per_channel_in * n_channels + 2))


def _log_axis_if_spread(ax, values) -> None:
    """Log y axis when the positive values span more than two decades (a linear one hides the small)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v) & (v > 0)]
    if v.size and v.max() / v.min() > 100:
        ax.set_yscale("log")


def _pseudo_damage(data: Mapping, path: Path) -> Path | None:
    pd = data.get("pseudo_damage")
    if not pd:
        return None
    chans = list(pd)
    kinds = [k for k in ("measured", "before", "after") if any(k in pd[c] for c in chans)]
    fig = _figure(_bar_width_in(len(chans), 1.0), 3.2)
    ax = fig.subplots()
    x = np.arange(len(chans))
    width = 0.8 / max(len(kinds), 1)
    names = {"measured": "measured", "before": "nominal model", "after": "with the fitted physics"}
    for j, k in enumerate(kinds):
        ax.bar(
            x + (j - (len(kinds) - 1) / 2) * width,
            [pd[c].get(k, np.nan) for c in chans],
            width,
            label=names[k],
        )
    _log_axis_if_spread(ax, [pd[c].get(k, np.nan) for c in chans for k in kinds])
    ax.axhline(1.0, color="k", lw=0.8, ls=":")
    ax.set_xticks(x)
    ax.set_xticklabels(chans, rotation=45, ha="right", fontsize=7)
    ax.set_ylabel("relative pseudo damage (-)")
    ax.legend(fontsize=7)
    ax.grid(True, axis="y", alpha=0.3)
    return _save(fig, path)


def _table(rows, header) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def write_report(
    diagnosis: Diagnosis, out_dir: str | os.PathLike, figures_data: Mapping | None = None
) -> Path:
    """Write ``index.html`` and the figures of ``diagnosis`` into ``out_dir``.

    Parameters
    ----------
    diagnosis : Diagnosis
    out_dir : str or path-like
        Directory (created if missing; its parent must exist).
    figures_data : mapping, optional
        Arrays for the figures, as filled by ``diagnose_generic(..., figures=dict)``:
        ``channels``, ``freq_hz``, ``labels``, ``levels``, ``residual_map`` (n_rec, n_ch, n_f),
        ``bands_hz``, ``measured``/``nominal_T``/``after_T`` (label -> T[n_ch, n_f]),
        ``train``, ``holdout``, ``located_sensors``, ``physics``; optional ``pseudo_damage``
        (channel -> {'measured', 'before', 'after'}). Missing items skip their figure.

    Returns
    -------
    Path
        The written ``index.html``.

    Raises
    ------
    InputError
        If ``diagnosis`` is not a Diagnosis or the parent of ``out_dir`` does not exist.
    """
    if not isinstance(diagnosis, Diagnosis):
        raise InputError(f"diagnosis of type {type(diagnosis).__name__}; expected a Diagnosis")
    out = Path(out_dir)
    if not out.parent.is_dir():
        raise InputError(f"report directory {str(out)!r}: parent {str(out.parent)!r} does not exist")
    out.mkdir(exist_ok=True)
    data = dict(figures_data or {})
    figs = {
        "residual_map.png": _residual_map(data, out / "residual_map.png"),
        "frf_overlay.png": _frf_overlay(data, out / "frf_overlay.png"),
        "errors.png": _errors(diagnosis, data, out / "errors.png"),
        "pseudo_damage.png": _pseudo_damage(data, out / "pseudo_damage.png"),
    }
    meta = diagnosis.metadata
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>exudyn_study diagnosis</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #bbb;padding:3px 8px;font-size:90%}img{max-width:100%}</style></head><body>",
        "<h1>Diagnosis</h1>",
        f"<p><b>{html.escape(diagnosis.summary)}</b></p>",
    ]
    if meta:
        rows = [
            (k, meta[k])
            for k in ("model", "reference", "train", "holdout", "band_hz", "wall_time_s")
            if k in meta
        ]
        parts.append(
            _table(
                [(k, _fmt(v) if not isinstance(v, list) else ", ".join(map(_fmt, v))) for k, v in rows],
                ("input", "value"),
            )
        )
        levels = meta.get("levels") or meta.get("levels_m_s2")
        if levels:
            unit = meta.get("level_unit", "m/s^2")
            what = "force" if unit == "N" else "drive acceleration"
            parts.append("<h3>Excitation levels</h3>")
            parts.append(
                _table([(k, _fmt(v)) for k, v in levels.items()], ("recording", f"{what} rms ({unit})"))
            )
    for f in diagnosis.findings:
        parts.append(f"<h2>Finding: {html.escape(f.physics)}</h2>")
        loc = f.location
        parts.append(
            _table(
                [
                    ("interface", loc.get("interface") or "-"),
                    ("component", loc.get("component") or "-"),
                    ("sensors", ", ".join(loc["sensors"])),
                    ("band (Hz)", "-" if f.band_hz is None else f"{f.band_hz[0]:.4g}-{f.band_hz[1]:.4g}"),
                    ("level dependent", "yes" if f.level_dependent else "no"),
                ],
                ("where", ""),
            )
        )
        parts.append(f"<p>{html.escape(f.explanation)}</p>")
        if f.flags:
            parts.append("<ul>" + "".join(f"<li>{html.escape(t)}</li>" for t in f.flags) + "</ul>")
        parts.append(
            _table(
                [
                    (k, _fmt(p["value"]), p["unit"], _fmt(p["std"]), "at bound" if p.get("at_bound") else "")
                    for k, p in f.parameters.items()
                ],
                ("parameter", "value", "unit", "std", ""),
            )
        )
        parts.append("<h3>Error before and after</h3>")
        parts.append(
            _table(
                [
                    ("training", _fmt(f.fit["train_before"]), _fmt(f.fit["train_after"])),
                    ("held-out", _fmt(f.fit["holdout_before"]), _fmt(f.fit["holdout_after"])),
                ],
                ("recordings", "nominal model", "with the fitted physics"),
            )
        )
        parts.append(f"<p><small>metric: {html.escape(str(f.fit['metric']))}</small></p>")
        per = f.fit.get("per_channel") or {}
        if per:
            rows = [
                (lab, ch, _fmt(v["before"]), _fmt(v["after"]))
                for lab, d in per.items()
                for ch, v in d.items()
            ]
            parts.append(
                "<details><summary>per recording and channel</summary>"
                + _table(rows, ("recording", "channel", "before", "after"))
                + "</details>"
            )
    for u in diagnosis.unexplained:
        parts.append("<h2>Unexplained mismatch</h2>")
        parts.append(f"<p>{html.escape(u.get('explanation', ''))}</p>")
    if not diagnosis.mismatch_found:
        parts.append("<p>No statistically significant mismatch: no missing physics found.</p>")
    for name, p in figs.items():
        if p is not None:
            parts.append(f"<h3>{html.escape(name[:-4].replace('_', ' '))}</h3><img src='{name}'>")
    if meta.get("candidates"):
        parts.append("<h3>Candidates</h3>")
        parts.append(
            _table(
                [
                    (
                        c["physics"],
                        _fmt(c.get("signature_score")),
                        _fmt(c.get("bic")),
                        c.get("rejected") or "accepted",
                    )
                    for c in meta["candidates"]
                ],
                ("physics", "signature score", "BIC (train)", "status"),
            )
        )
    parts.append(
        "<details><summary>diagnosis JSON</summary><pre>"
        + html.escape(json.dumps(diagnosis.to_dict(), indent=1))
        + "</pre></details>"
    )
    parts.append("</body></html>")
    from exudyn_study.infra.atomic import write_text_atomic

    return write_text_atomic(out / "index.html", "\n".join(parts), "report")
