"""HTML report of a diagnosis with its figures (matplotlib, Agg, written to files).

:func:`write_report` writes ``index.html`` and PNGs into a directory:

- ``residual_map.png``: normalised residual ``|T_model - T|^2 / sigma^2`` per sensor and
  frequency, one panel per recording (1 is the noise level);
- ``frf_overlay.png``: measured vs nominal vs fitted transmissibility magnitude at the located
  sensors, on the held-out recordings first;
- ``errors.png``: FRF error per channel before and after, training and held-out;
- ``pseudo_damage.png``: pseudo damage of the nominal and the fitted model relative to the
  measured one (the measured, 1 by definition, is the line at 1), when given.

The bar charts are at most ``_MAX_WIDTH_IN`` wide and wrap their channels into rows, so their
labels stay readable at the page width. The page gives a summary first (the findings, how sure,
the error before -> after, the unexplained mismatch), then one card per finding, the fitted but
not identifiable physics apart (a flag containing "not identifiable": not counted as findings),
one before/after table per distinct fit (findings of one joint refit share it), the figures and
the candidates. Table columns in which every value is empty or "-" are left out.

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

from exudyn_study.diagnose.schema import NOT_IDENTIFIABLE, Diagnosis
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
    height_in = 1.1 + 0.16 * n * max(1, len(chans))  # a 7-pt label per channel row
    fig = _figure(9.0, height_in)
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
    # a colour bar about 4 in tall, not the whole stack of recordings
    fig.colorbar(im, ax=list(axes), shrink=min(0.8, 4.0 / height_in), aspect=15,
                 label="log10 residual / noise")
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


#: channels per row of a per-channel bar chart: with the figure width capped at ``_MAX_WIDTH_IN`` the
#: labels stay readable when the PNG is shown at the page width (about 1100 px)
_CHANNELS_PER_ROW = 14
#: widest figure (in): 10 in at 110 dpi is about 1100 px, the page width, so no figure is shrunk
_MAX_WIDTH_IN = 10.0


def _rows_of(chans: list, per_row: int = _CHANNELS_PER_ROW) -> list[list]:
    """Split the channels into rows of at most ``per_row``, of balanced length."""
    n_rows = max(1, -(-len(chans) // per_row))
    size = -(-len(chans) // n_rows) if chans else 0
    return [chans[i : i + size] for i in range(0, len(chans), size)] if size else [[]]


def _bar_figure(n_chans: int, per_channel_in: float):
    """Figure with one bar-chart panel per row of channels, its width capped at ``_MAX_WIDTH_IN``."""
    rows = max(1, -(-n_chans // _CHANNELS_PER_ROW))
    longest = -(-n_chans // rows) if n_chans else 1
    width = min(_MAX_WIDTH_IN, max(6.0, per_channel_in * longest + 1.5))
    fig = _figure(width, 0.6 + 2.4 * rows)
    # one y scale for all rows: bars of different rows compare directly
    return fig, fig.subplots(rows, 1, squeeze=False, sharey=True)[:, 0]


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
        after_name = f"all {len(diagnosis.findings)} fitted physics"
    else:
        after_name = diagnosis.findings[0].physics
    if not per:
        return None
    chans = list(next(iter(per.values())))
    groups = {"train": list(data.get("train", [])), "held-out": list(data.get("holdout", []))}
    if not any(lab in per for labs in groups.values() for lab in labs):
        # the figures data do not say which recordings are training or held-out: one group of all
        groups = {"all recordings": list(per)}
    colours = {
        ("train", "before"): "#f4a582",
        ("train", "after"): "#92c5de",
        ("held-out", "before"): "#ca0020",
        ("held-out", "after"): "#0571b0",
        ("all recordings", "before"): "#888888",
        ("all recordings", "after"): "#0571b0",
    }
    series = []
    for g, labs in groups.items():
        labs = [lab for lab in labs if lab in per]
        for when in ("before", "after"):
            if labs:
                vals = {ch: float(np.mean([per[lab][ch][when] for lab in labs])) for ch in chans}
                series.append((f"{g}, {when}", colours[(g, when)], vals))
    fig, axes = _bar_figure(len(chans), 0.65)
    width = 0.8 / max(len(series), 1)
    drawn = [v for _, _, vals in series for v in vals.values()]
    kind = "FRF error" if "FRF" in str(fit.get("metric", "")) else "error"
    for ax, row in zip(axes, _rows_of(chans), strict=True):
        x = np.arange(len(row))
        for j, (name, colour, vals) in enumerate(series):
            off = (j - (len(series) - 1) / 2) * width
            ax.bar(x + off, [vals[ch] for ch in row], width, color=colour, label=name)
        _log_axis_if_spread(ax, drawn)
        ax.set_xticks(x)
        ax.set_xticklabels(row, rotation=30 if len(row) > 8 else 0, ha="right" if len(row) > 8 else "center",
                           fontsize=8)
        ax.set_xlim(-0.6, max(len(row), 4) - 0.4)
        ax.set_ylabel(f"relative {kind} (-)", fontsize=8)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].set_title(f"{kind} per channel, nominal (before) vs with {after_name} (after)", fontsize=9)
    axes[0].legend(fontsize=7, ncol=len(series))
    fig.tight_layout()
    return _save(fig, path)


def _log_axis_if_spread(ax, values) -> None:
    """Log y axis when the positive values span more than two decades (a linear one hides the small)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v) & (v > 0)]
    if v.size and v.max() / v.min() > 100:
        ax.set_yscale("log")


def _pseudo_damage(data: Mapping, path: Path) -> Path | None:
    """Pseudo damage of the models relative to the measured one, per channel.

    The measured pseudo damage is the reference (1 by definition): it is the dotted line at 1, not a
    bar. The bars are the nominal model and the model with the fitted physics.
    """
    pd = data.get("pseudo_damage")
    if not pd:
        return None
    chans = list(pd)
    kinds = [k for k in ("before", "after") if any(k in pd[c] for c in chans)]
    if not kinds:
        return None
    fig, axes = _bar_figure(len(chans), 0.5)
    width = 0.8 / len(kinds)
    names = {"before": "nominal model", "after": "with the fitted physics"}
    colours = {"before": "#ca0020", "after": "#0571b0"}
    drawn = [pd[c].get(k, np.nan) for c in chans for k in kinds] + [1.0]
    for ax, row in zip(axes, _rows_of(chans), strict=True):
        x = np.arange(len(row))
        for j, k in enumerate(kinds):
            ax.bar(
                x + (j - (len(kinds) - 1) / 2) * width,
                [pd[c].get(k, np.nan) for c in row],
                width,
                color=colours[k],
                label=names[k],
            )
        _log_axis_if_spread(ax, drawn)
        ax.axhline(1.0, color="k", lw=0.9, ls=":", label="measured (= 1)")
        ax.set_xticks(x)
        ax.set_xticklabels(row, rotation=30 if len(row) > 8 else 0, ha="right" if len(row) > 8 else "center",
                           fontsize=8)
        ax.set_xlim(-0.6, max(len(row), 4) - 0.4)
        ax.set_ylabel("pseudo damage / measured (-)", fontsize=8)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].set_title("pseudo damage of the model relative to the measured one (1: as measured)", fontsize=9)
    axes[0].legend(fontsize=7, ncol=3)
    fig.tight_layout()
    return _save(fig, path)


_CSS = """
body{font-family:"Helvetica Neue",Arial,"DejaVu Sans",sans-serif;font-size:15px;line-height:1.45;
 color:#222;max-width:1100px;margin:0 auto;padding:0 16px 40px}
h1{font-size:1.6em;margin:.6em 0 .2em}h2{font-size:1.25em;margin:1.4em 0 .4em;
 border-bottom:2px solid #ddd;padding-bottom:.15em}h3{font-size:1.05em;margin:1em 0 .3em}
table{border-collapse:collapse;margin:.3em 0 .8em;font-size:13px}
th,td{border:1px solid #d4d4d4;padding:2px 8px;text-align:left;vertical-align:top}
th{background:#eef1f5}tr:nth-child(even) td{background:#f8f8f8}
td.num{text-align:right;font-variant-numeric:tabular-nums}
.card{border:1px solid #ccd;border-left:5px solid #2a6fb0;border-radius:4px;padding:6px 14px;
 margin:10px 0;background:#fff}
.card.weak{border-left-color:#b07a00;background:#fffbf0}.card.unexplained{border-left-color:#999}
.card h3{margin:.3em 0}.card p{margin:.3em 0}.facts{font-size:14px}
.flag{display:inline-block;background:#fff1cc;color:#6b4a00;border:1px solid #e0b84d;
 border-radius:3px;padding:0 5px;margin:1px 0;font-size:12px}
.flag.bad{background:#fde2e2;color:#8a1010;border-color:#d88}
.ok{color:#1b6e2a}.muted{color:#666;font-size:13px}
.lead{font-size:1.05em;background:#f3f6fa;border:1px solid #dde3ea;padding:6px 12px;border-radius:4px}
img{max-width:100%;height:auto;display:block;margin:4px 0 12px}
details{margin:.4em 0}summary{cursor:pointer;color:#2a6fb0}
pre{font-size:11px;max-height:500px;overflow:auto;background:#f6f6f6;padding:6px}
"""



class _Html(str):
    """Table cell or text that is already HTML (not escaped again)."""


def _cell(c) -> str:
    return c if isinstance(c, _Html) else html.escape(str(c))


def _empty(c) -> bool:
    return c is None or str(c).strip() in ("", "-")


def _table(rows, header, numeric=()) -> str:
    """HTML table; columns in which every cell is empty or "-" are left out.

    Parameters
    ----------
    rows : sequence of sequences
        Cells (str, or ``_Html`` for cells that are already HTML).
    header : sequence of str
    numeric : collection of int, optional
        Indices of columns aligned right (numbers).
    """
    rows = [list(r) for r in rows]
    keep = [j for j in range(len(header)) if any(not _empty(r[j]) for r in rows)]
    head = "".join(f"<th>{html.escape(str(header[j]))}</th>" for j in keep)
    body = "".join(
        "<tr>"
        + "".join(f"<td class='num'>{_cell(r[j])}</td>" if j in numeric else f"<td>{_cell(r[j])}</td>"
                  for j in keep)
        + "</tr>"
        for r in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _not_identifiable(f) -> bool:
    return not f.identifiable


def _where(loc) -> str:
    """Place of a finding, unexplained mismatch or candidate: component, interface, sensors."""
    if isinstance(loc, str):
        return loc
    if not isinstance(loc, Mapping):
        return "-"
    parts = [str(loc[k]) for k in ("component", "interface") if loc.get(k)]
    sensors = loc.get("sensors") or []
    if isinstance(sensors, str):
        sensors = [sensors]
    if sensors and not (len(parts) == 1 and parts[0] == "-".join(sensors)):
        parts.append("sensors " + ", ".join(map(str, sensors)))
    elif sensors and not parts:
        parts.append(", ".join(map(str, sensors)))
    return "; ".join(parts) or "-"


def _band(band) -> str:
    return "-" if band is None else f"{band[0]:.4g}-{band[1]:.4g} Hz"


def _flags_html(flags) -> _Html:
    return _Html(
        " ".join(
            f"<span class='flag{' bad' if NOT_IDENTIFIABLE in t.lower() else ''}'>{html.escape(t)}</span>"
            for t in flags
        )
    )


def _param_text(name: str, p: Mapping) -> str:
    """``name = value unit (± std)`` with an at-bound mark."""
    unit = "" if p["unit"] in ("", "1", "-") else f" {p['unit']}"
    txt = f"{name} = {_fmt(p['value'])}{unit}"
    if p.get("std") is not None and p["value"]:
        pct = 100 * abs(p["std"] / p["value"])  # 0.3 % stays 0.3 %, not 0 %
        txt += f" (±{pct:.1f}%)" if pct < 10 else f" (±{pct:.0f}%)"
    if p.get("at_bound"):
        txt += " [at bound]"
    return txt


def _member_name(f) -> str:
    return f.physics + (" (not identifiable)" if _not_identifiable(f) else "")


def _fit_key(f) -> str:
    return json.dumps(f.to_dict()["fit"], sort_keys=True)


def _fit_groups(findings) -> list[tuple[dict, list]]:
    """Group the findings by identical fit dicts (a joint refit gives all its findings one fit)."""
    groups: dict[str, tuple[dict, list]] = {}
    for f in findings:
        groups.setdefault(_fit_key(f), (f.fit, []))[1].append(f)
    return list(groups.values())


def _arrow(before, after) -> str:
    return f"{_fmt(before)} → {_fmt(after)}"


def _fit_section(fit: Mapping, members: list, number: int, n_groups: int) -> str:
    """Return the before/after table of one fit, shown once for all the findings fitted with it."""
    names = ", ".join(_member_name(f) for f in members)
    title = f"Fit {number}" if n_groups > 1 else "Fit"
    out = [f"<h3>{title}: {'fitted together: ' if len(members) > 1 else ''}{html.escape(names)}</h3>"]
    out.append(
        _table(
            [
                ("training", _fmt(fit["train_before"]), _fmt(fit["train_after"])),
                ("held-out", _fmt(fit["holdout_before"]), _fmt(fit["holdout_after"])),
            ],
            ("recordings", "nominal model", "with the fitted physics"),
            numeric=(1, 2),
        )
    )
    out.append(f"<p class='muted'>metric: {html.escape(str(fit['metric']))}</p>")
    per = fit.get("per_channel") or {}
    if per:
        rows = [
            (lab, ch, _fmt(v["before"]), _fmt(v["after"])) for lab, d in per.items() for ch, v in d.items()
        ]
        out.append(
            "<details><summary>per recording and channel</summary>"
            + _table(rows, ("recording", "channel", "before", "after"), numeric=(2, 3))
            + "</details>"
        )
    return "\n".join(out)


def _facts(loc, band, level_dependent: bool, extra: str = "") -> _Html:
    """One line of the evidence's place: component, interface, sensors, band, level dependence."""
    items = [
        ("component", loc.get("component")),
        ("interface", loc.get("interface")),
        ("sensors", ", ".join(loc.get("sensors") or [])),
        ("band", None if band is None else _band(band)),
        ("level dependent", "yes" if level_dependent else "no"),
    ]
    text = " · ".join(f"<b>{k}</b> {html.escape(str(v))}" for k, v in items if not _empty(v))
    return _Html(f"<p class='facts'>{text}{' · ' + extra if extra else ''}</p>")


def _finding_card(f, fit_no: dict, n_groups: int, weak: bool = False) -> str:
    """One finding: where, its band and sensors, its parameters, flags and explanation."""
    out = [f"<div class='card{' weak' if weak else ''}'><h3>{html.escape(f.physics)}</h3>"]
    fit_ref = f"fit {fit_no[_fit_key(f)]}" if n_groups > 1 else "the fit"
    out.append(
        _facts(
            f.location,
            f.band_hz,
            f.level_dependent,
            f"{fit_ref} under <a href='#fits'>Error before and after</a>",
        )
    )
    if f.flags:
        out.append(f"<p>{_flags_html(f.flags)}</p>")
    if f.parameters:
        out.append(
            _table(
                [
                    (
                        k,
                        _fmt(p["value"]),
                        p["unit"],
                        _fmt(p["std"]),
                        "-" if p["std"] is None or not p["value"] else f"{abs(p['std'] / p['value']):.1%}",
                        _Html("<span class='flag'>at bound</span>") if p.get("at_bound") else "-",
                    )
                    for k, p in f.parameters.items()
                ],
                ("parameter", "value", "unit", "std", "relative std", "at bound"),
                numeric=(1, 3, 4),
            )
        )
    out.append(f"<p>{html.escape(f.explanation)}</p></div>")
    return "\n".join(out)


def _summary(diagnosis: Diagnosis, found: list, weak: list, groups: list) -> list[str]:
    """Return the summary: what is missing, how sure, the error before -> after, what is unexplained."""
    out = ["<h2>Summary</h2>"]
    if not diagnosis.mismatch_found:
        out.append("<p class='lead ok'>No statistically significant mismatch: no missing physics found.</p>")
        return out
    if found:
        out.append(
            _table(
                [
                    (
                        f.physics,
                        _where(f.location),
                        _band(f.band_hz),
                        "; ".join(_param_text(k, p) for k, p in f.parameters.items()) or "-",
                        _flags_html(f.flags) if f.flags else _Html("<span class='ok'>none</span>"),
                    )
                    for f in found
                ],
                ("missing physics", "where", "band", "parameters", "flags"),
            )
        )
    else:
        out.append("<p class='lead'>No modelled physics explains the mismatch.</p>")
    if weak:
        out.append(
            "<p><span class='flag bad'>not identifiable</span> also fitted, but the data do not determine "
            f"them (not counted as findings): {html.escape(', '.join(f.physics for f in weak))}</p>"
        )
    final = diagnosis.metadata.get("final_holdout_error")
    rows = []
    for i, (fit, members) in enumerate(groups, 1):
        label = ", ".join(_member_name(f) for f in members)
        rows.append(
            (
                (f"fit {i}: " if len(groups) > 1 else "") + label,
                _arrow(fit["train_before"], fit["train_after"]),
                _arrow(fit["holdout_before"], fit["holdout_after"]),
            )
        )
    if rows:
        out.append("<h3>Error, nominal model → with the fitted physics</h3>")
        out.append(_table(rows, ("fitted physics", "training", "held-out"), numeric=(1, 2)))
        metrics = {str(fit["metric"]) for fit, _ in groups}
        if len(metrics) == 1:
            out.append(f"<p class='muted'>metric: {html.escape(metrics.pop())}</p>")
        if final:
            vals = final if isinstance(final, list) else [final]
            out.append(
                "<p class='muted'>held-out error of the final model with all findings: "
                + html.escape(", ".join(_fmt(v) for v in vals))
                + "</p>"
            )
    if diagnosis.unexplained:  # where and which band here; the explanation once, in its own section
        out.append("<h3>Unexplained mismatch</h3>")
        out.append(
            _table(
                [
                    (
                        _where(u["location"]),
                        _band(u.get("band_hz")),
                        "yes" if u.get("level_dependent") else "no",
                        _Html("<a href='#unexplained'>below</a>"),
                    )
                    for u in diagnosis.unexplained
                ],
                ("where", "band", "level dependent", "why"),
            )
        )
    return out


def _candidates(cands) -> str:
    """Candidates table: physics, place, scores, status (accepted, or the reason of the rejection)."""
    rows = []
    for c in cands:
        loc = c.get("location")
        if loc is None and (c.get("interface") or c.get("sensors")):
            loc = {"interface": c.get("interface"), "sensors": c.get("sensors") or []}
        status = (
            _Html(f"<span class='muted'>rejected: {html.escape(str(c['rejected']))}</span>")
            if c.get("rejected")
            else _Html("<span class='ok'>accepted</span>")
        )
        rows.append(
            (
                _fmt(c.get("round")),
                c.get("physics", "-"),
                "-" if loc is None else _where(loc),
                _fmt(c.get("signature_score")),
                _fmt(c.get("bic")),
                _fmt(c.get("improvement")),
                _fmt(c.get("holdout_after", c.get("holdout_error_after"))),
                status,
            )
        )
    return _table(
        rows,
        (
            "round", "physics", "place", "signature score", "BIC (train)", "improvement", "held-out error",
            "status",
        ),
        numeric=(3, 4, 5, 6),
    )


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
    found = [f for f in diagnosis.findings if not _not_identifiable(f)]
    weak = [f for f in diagnosis.findings if _not_identifiable(f)]
    groups = _fit_groups(diagnosis.findings)
    fit_no = {_fit_key(members[0]): i for i, (_, members) in enumerate(groups, 1)}
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'>"
        f"<title>exudyn_study diagnosis</title><style>{_CSS}</style></head><body>",
        "<h1>Diagnosis</h1>",
        f"<p class='lead'><b>{html.escape(diagnosis.summary)}</b></p>",
    ]
    parts += _summary(diagnosis, found, weak, groups)
    if found:
        parts.append(f"<h2>Findings ({len(found)})</h2>")
        parts += [_finding_card(f, fit_no, len(groups)) for f in found]
    if weak:
        parts.append("<h2>Fitted but not identifiable (not counted as findings)</h2>")
        parts.append(
            "<p class='muted'>Fitted with the findings, but the recordings do not determine their "
            "parameters; the values below are not evidence of the physics.</p>"
        )
        parts += [_finding_card(f, fit_no, len(groups), weak=True) for f in weak]
    if diagnosis.unexplained:
        parts.append(f"<h2 id='unexplained'>Unexplained mismatch ({len(diagnosis.unexplained)})</h2>")
    for u in diagnosis.unexplained:
        parts.append("<div class='card unexplained'>")
        parts.append(_facts(u["location"], u.get("band_hz"), bool(u.get("level_dependent"))))
        parts.append(f"<p>{html.escape(u.get('explanation', ''))}</p></div>")
    if groups:
        parts.append("<h2 id='fits'>Error before and after</h2>")
        parts += [_fit_section(fit, members, i, len(groups)) for i, (fit, members) in enumerate(groups, 1)]
    titles = {
        "residual_map.png": "Residual of the nominal model per sensor and frequency",
        "frf_overlay.png": "Measured, nominal and fitted response at the located sensors",
        "errors.png": "Error per channel, before and after",
        "pseudo_damage.png": "Pseudo damage relative to the measured",
    }
    if any(p is not None for p in figs.values()):
        parts.append("<h2>Figures</h2>")
    for name, p in figs.items():
        if p is not None:
            parts.append(f"<h3>{html.escape(titles[name])}</h3><img src='{name}' alt='{name}'>")
    if meta.get("candidates"):
        parts.append("<h2>Candidates</h2>")
        parts.append(_candidates(meta["candidates"]))
    if meta:
        parts.append("<h2>Input</h2>")
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
        if isinstance(levels, Mapping) and levels:
            unit = meta.get("level_unit", "m/s^2")
            what = "force" if unit == "N" else "drive acceleration"
            parts.append(
                _table(
                    [(k, _fmt(v)) for k, v in levels.items()],
                    ("recording", f"{what} rms ({unit})"),
                    numeric=(1,),
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
