"""Level-trend diagnosis of a structure tested at several drive levels, as stages over data.

:func:`diagnose_levels` lists its stages; each is a module with functions over frozen data:

1. **compare** (:mod:`.frf`, :mod:`.reference`): FRFs per level that fit the excitation (whole
   periods at the excited lines for a multisine, with noise and distortion levels; LRM or H1
   for random), the contiguous excited band, the reference model (PolyMAX + LSFD with residual
   terms) from the lowest level, and its check against its own recording: a misfit stops the
   diagnosis with the band and modes that fail;
2. **amplitude** (:mod:`.amplitude`): every mode's frequency, damping and amplitude per level
   with standard deviations (the table a nonlinear-GVT engineer looks at first);
3. **screen** (:mod:`.screen`): the level dependence of every mode from its trend across the
   levels (friction, softening, hardening, clearance, damping, linear but mis-modelled);
4. **locate** (:mod:`.locate`): the sensor pair whose relative motion carries the change;
5. **fit** and **prove** (:mod:`.fit`): an amplitude law per level-dependent mode fitted on the
   training levels; held-out levels predicted from their drive alone; FRF error per channel
   and level before and after;
6. **explain** (:mod:`.explain`): the text and the figures.

It returns a :class:`~exudyn_study.diagnose.schema.Diagnosis` like the other paths; the JSON
metadata hold the modal table, the trends, the location evidence and the reference check.
Imports neither exudyn nor ngsolve.
"""

from __future__ import annotations

import itertools
import logging
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from exudyn_study.diagnose.levels.amplitude import ModalTable, fit_modes_per_level
from exudyn_study.diagnose.levels.explain import (
    diagnosis_with_law,
    diagnosis_without_law,
    plot_amplitude,
    plot_overlays,
)
from exudyn_study.diagnose.levels.fit import JointLaw, fit_joint_law, prove, scaled_coupling
from exudyn_study.diagnose.levels.frf import LevelFRF, estimate_level_frf, excited_band
from exudyn_study.diagnose.levels.locate import locate_by_sensitivity, locate_pair
from exudyn_study.diagnose.levels.reference import ReferenceModel, check_reference, identify_reference
from exudyn_study.diagnose.levels.screen import NONLINEAR, ModeTrend, dominant_outcome, screen_trends
from exudyn_study.diagnose.levels.settings import LevelSettings
from exudyn_study.diagnose.schema import Diagnosis
from exudyn_study.errors import InputError
from exudyn_study.infra.blas import one_blas_thread
from exudyn_study.recording.types import Recording

__all__ = [
    "LevelSettings",
    "LevelFRF",
    "ReferenceModel",
    "ModalTable",
    "ModeTrend",
    "JointLaw",
    "diagnose_levels",
    "diagnose_level_frfs",
    "write_level_figures",
    "write_level_report",
]

log = logging.getLogger(__name__)


def _split_levels(n: int, train, holdout, what: str) -> tuple[list[int], list[int]]:
    """Check the training and held-out indices of ``n`` levels (``what`` names them in the message)."""
    train, holdout = [int(i) for i in train], [int(i) for i in holdout]
    if n < 3:
        raise InputError(f"{n} {what}; a level trend needs at least 3 drive levels")
    if (
        set(train) & set(holdout)
        or not train
        or not holdout
        or min(train + holdout) < 0
        or max(train + holdout) >= n
    ):
        raise InputError(
            f"train {train} and holdout {holdout}: expected disjoint, non-empty indices in 0..{n - 1}"
        )
    return train, holdout


def _bar(total: int, desc: str, enabled: bool):
    from tqdm import tqdm

    from exudyn_study.infra.progress import progress_disabled

    # on a terminal only (or EXUDYN_STUDY_PROGRESS=1), as every bar of the package
    return tqdm(total=total, desc=desc, file=sys.stderr, disable=True if not enabled else progress_disabled(),
                leave=False)


def _drive_point(rec: Recording) -> str | None:
    d = rec.drive
    if d.quantity != "force" or d.position_m is None:
        return None
    for c in rec.response_channels:
        if c.position_m is not None and np.allclose(c.position_m, d.position_m, atol=1e-6):
            return c.name
    return None


@one_blas_thread  # thousands of small local fits: BLAS threads only slow them down on a shared machine
def diagnose_levels(
    recordings: Sequence[Recording],
    train: Sequence[int],
    holdout: Sequence[int],
    *,
    labels: Sequence[str] | None = None,
    interfaces: Sequence[tuple[str, str]] | None = None,
    settings: LevelSettings | None = None,
    progress: bool = True,
    state: dict | None = None,
) -> Diagnosis:
    """Diagnose a structure from recordings at several drive levels (stages in the module docstring).

    Parameters
    ----------
    recordings : sequence of Recording
        One per drive level, same channels; one drive channel each (force in N, a table
        acceleration or a shaker voltage), accelerometers as responses.
    train, holdout : sequence of int
        Indices into ``recordings`` for fitting and for the proof (disjoint; the lowest level
        is the reference and should be among ``train``).
    labels : sequence of str, optional
        Names of the recordings (default their metadata 'source' or 'level i').
    interfaces : sequence of (str, str), optional
        Candidate sensor pairs for the location (default every pair).
    settings : LevelSettings, optional
    progress : bool
        Progress bars on stderr (default True).
    state : dict, optional
        If given, filled with the stages' data (for the figures, :func:`write_level_figures`).

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        Fewer than 3 levels, overlapping or out-of-range train/holdout indices, channels that
        differ between recordings, bad FRF settings (see :func:`.frf.estimate_level_frf`), a band
        outside the data, or a reference model that does not reproduce its own recording.
    """
    t0 = time.perf_counter()
    settings = settings or LevelSettings()
    recs = list(recordings)
    n = len(recs)
    train, holdout = _split_levels(n, train, holdout, "recording(s)")
    labels = (
        list(labels)
        if labels is not None
        else [str(r.metadata.get("source", f"level {i}")) for i, r in enumerate(recs)]
    )
    names0 = recs[0].names
    for lab, r in zip(labels, recs, strict=True):
        if r.names != names0:
            raise InputError(
                f"recording {lab!r} has channels {list(r.names)}, the first {list(names0)}; "
                "record every level with the same channels"
            )
    # ---- compare: FRFs per level, band, reference model and its self-check
    bar = _bar(n, "FRFs per level", progress)
    frfs = []
    for lab, r in zip(labels, recs, strict=True):
        frfs.append(estimate_level_frf(r, lab, settings))
        bar.update(1)
    bar.close()
    ref_i = int(np.argmin([f.level for f in frfs]))
    return diagnose_level_frfs(
        frfs,
        train,
        holdout,
        drive_point=_drive_point(recs[ref_i]),
        interfaces=interfaces,
        settings=settings,
        progress=progress,
        state=state,
        t_start=t0,
    )


@one_blas_thread
def diagnose_level_frfs(
    frfs: Sequence[LevelFRF],
    train: Sequence[int],
    holdout: Sequence[int],
    *,
    drive_point: str | None = None,
    interfaces: Sequence[tuple[str, str]] | None = None,
    settings: LevelSettings | None = None,
    progress: bool = True,
    state: dict | None = None,
    t_start: float | None = None,
) -> Diagnosis:
    """Diagnose from measured FRFs per level: the stages after the FRF estimate (e.g. a test export).

    Parameters
    ----------
    frfs : sequence of LevelFRF
        One per level, same channels; ``sigma`` the FRFs' standard deviations (from the test
        software's coherence or repeated runs), ``U`` the drive's amplitude per line.
    train, holdout : sequence of int
        As in :func:`diagnose_levels`.
    drive_point : str, optional
        The accelerometer at the force (force drive): scales the modes to kg.
    interfaces, settings, progress, state
        As in :func:`diagnose_levels`.
    t_start : float, optional
        ``time.perf_counter()`` at the start, for the wall time in the JSON.

    Returns
    -------
    Diagnosis
        With one response channel the trends are reported but nothing is located or fitted.
    """
    t0 = time.perf_counter() if t_start is None else t_start
    settings = settings or LevelSettings()
    frfs = list(frfs)
    n = len(frfs)
    train, holdout = _split_levels(n, train, holdout, "level(s)")
    labels = [f.label for f in frfs]
    dp = drive_point
    ref_i = int(np.argmin([f.level for f in frfs]))
    ref = frfs[ref_i]
    band = excited_band(ref, settings.band_hz)
    model = identify_reference(ref, band, settings, drive_point=dp)
    check_reference(model, ref)
    res_msgs = _resolution_warnings(model, ref, settings)
    for m in res_msgs:
        warnings.warn(m, stacklevel=2)
    # ---- amplitude-dependent modal parameters, screen, locate
    bar = _bar(n, "modal parameters per level", progress)
    table = fit_modes_per_level(model, frfs, progress=bar.update)
    bar.close()
    trends = screen_trends(table, settings)
    pair, evidence, sens = _locate(table, trends, model, ref.channels, dp, settings, interfaces)
    meta = _metadata(labels, frfs, ref_i, band, model, table, trends, evidence, res_msgs, train, holdout)
    meta["location_sensitivity"] = sens
    meta["located_by"] = (
        None
        if pair is None
        else (
            "eigenvalue sensitivity"
            if sens and tuple(sens[0]["pair"]) == pair and sens[0]["z"] > settings.trend_sigma
            else "relative motion"
        )
    )
    if state is not None:
        state.update(
            frfs=frfs,
            model=model,
            table=table,
            trends=trends,
            pair=pair,
            labels=labels,
            train=train,
            holdout=holdout,
        )
    done = diagnosis_without_law(trends, ref.channels, band, meta)
    if done is not None:
        meta["wall_time_s"] = time.perf_counter() - t0
        return done
    # ---- fit and prove
    physics = dominant_outcome(trends)
    fit_pair = pair or tuple(evidence[0]["pair"])
    g = scaled_coupling(model, fit_pair, dp) if dp is not None else None
    law = fit_joint_law(table, trends, physics, fit_pair, frfs, model, train, g)
    proof = prove(model, law, frfs, table)
    if state is not None:
        state.update(proof=proof, law=law, physics=physics)
    # ---- explain
    meta["wall_time_s"] = time.perf_counter() - t0
    return diagnosis_with_law(physics, trends, pair, law, proof, model, labels, train, holdout, band, meta)


def _locate(table, trends, model, channels, dp, settings, interfaces):
    """Locate the joint: by eigenvalue sensitivity with mass-normalised shapes, else by relative motion.

    Returns ``(pair, relative-motion evidence, sensitivity evidence)``; the sensitivity ranking
    (:func:`~.locate.locate_by_sensitivity`) needs a force drive with a drive-point accelerometer and
    decides when it locates a pair, the relative-motion ranking (:func:`~.locate.locate_pair`) otherwise.
    """
    pair, evidence = locate_pair(table, trends, channels, settings, interfaces)
    if dp is None or not any(t.outcome in NONLINEAR for t in trends):
        return pair, evidence, []
    pairs = [tuple(p) for p in interfaces] if interfaces else list(itertools.combinations(channels, 2))
    couplings = {p: scaled_coupling(model, p, dp) for p in pairs}
    by_sens, sens = locate_by_sensitivity(table, couplings, settings)
    return (by_sens or pair), evidence, sens


def _resolution_warnings(model: ReferenceModel, ref: LevelFRF, settings: LevelSettings) -> list[str]:
    """One message when modes span fewer than ``min_lines`` lines of their half-power bandwidth."""
    bw = 2.0 * model.damping_ratio * model.frequency_hz
    lines = bw / ref.resolution_hz
    low = np.flatnonzero(lines < settings.min_lines)
    if not low.size:
        return []
    need = settings.min_lines / max(float(np.min(bw[low])), 1e-12)
    modes = ", ".join(
        f"{model.frequency_hz[k]:.4g} Hz/{100 * model.damping_ratio[k]:.2f} % ({lines[k]:.1f} lines)"
        for k in low
    )
    how = (
        f"a drive period of at least {need:.3g} s"
        if ref.excitation == "periodic"
        else f"a record (or --resolution segment) of at least {need:.3g} s"
    )
    return [
        f"{low.size} mode(s) span fewer than {settings.min_lines:g} lines of their half-power bandwidth at "
        f"{ref.resolution_hz:.4g} Hz, so their damping is poorly resolved: {modes}; resolving "
        f"them needs {how}"
    ]


def _metadata(
    labels,
    frfs: list[LevelFRF],
    ref_i,
    band,
    model: ReferenceModel,
    table: ModalTable,
    trends,
    evidence,
    res_msgs,
    train,
    holdout,
) -> dict:
    ref = frfs[ref_i]
    unit = f"{ref.response_unit}/{ref.drive_unit}"
    return {
        "path": "levels",
        "model": f"modal:{labels[ref_i]}",
        "reference": labels[ref_i],
        "train": [labels[i] for i in train],
        "holdout": [labels[i] for i in holdout],
        "levels": {lab: f.level for lab, f in zip(labels, frfs, strict=True)},
        "level_unit": ref.drive_unit,
        "frf_unit": unit,
        "excitation": ref.excitation,
        "resolution_hz": ref.resolution_hz,
        "periods_averaged": ref.n_periods if ref.excitation == "periodic" else None,
        "band_hz": list(band),
        "distortion_estimated": ref.distortion is not None,
        "resolution_warnings": list(res_msgs),
        "reference_model": {
            "modes": [
                {"frequency_hz": float(f), "damping_ratio": float(z)}
                for f, z in zip(model.frequency_hz, model.damping_ratio, strict=True)
            ],
            "check": model.check,
            "modal_mass_kg": None
            if model.modal_mass_kg is None
            else [None if not np.isfinite(m) else float(m) for m in model.modal_mass_kg],
            "degenerate_masses": list(model.degenerate),
        },
        "modal_table": table.rows(),
        "trends": [t.__dict__ for t in trends],
        "location_evidence": evidence,
    }


def write_level_figures(state: dict, directory: str | Path) -> list[Path]:
    """Write the amplitude plot and the FRF overlays of a :func:`diagnose_levels` run into a directory.

    ``state`` is the dict that run filled; returns the written PNG paths.

    Parameters
    ----------
    state : dict
        The ``state`` filled by :func:`diagnose_levels` (or :func:`diagnose_level_frfs`): the
        FRFs, reference model, modal table, trends, located pair, labels, train and holdout
        indices, and, when a joint law was fitted, the law and its proof.
    directory : str or path-like
        Directory for the figures, created (with its parents) if missing.

    Returns
    -------
    list of Path
        ``modal_vs_amplitude.png``, and ``frf_overlays.png`` when a joint law was fitted (the
        located pair's sensors, else every channel, around the law's modes).
    """
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    out = [plot_amplitude(state["table"], state["trends"], d / "modal_vs_amplitude.png")]
    if "proof" in state:
        frf = state["frfs"][0]
        show = list(state["pair"]) if state["pair"] else list(frf.channels)
        labs = [state["labels"][i] for i in sorted(set(state["train"]) | set(state["holdout"]))]
        nl = list(state["law"].modes)
        f = state["model"].frequency_hz
        lo = max(f[min(nl)] * 0.9, state["model"].band_hz[0]) if nl else None
        hi = min(f[max(nl)] * 1.1, state["model"].band_hz[1]) if nl else None
        unit = f"{frf.response_unit}/{frf.drive_unit}"
        out.append(
            plot_overlays(
                state["proof"],
                labs,
                list(frf.channels),
                show,
                unit,
                d / "frf_overlays.png",
                (lo, hi) if nl else None,
            )
        )
    return out


def write_level_report(diagnosis: Diagnosis, state: dict, directory: str | Path) -> Path:
    """Write ``index.html``: the modal table, the trends, the location evidence, the proof and the figures.

    Parameters
    ----------
    diagnosis : Diagnosis
        From :func:`diagnose_levels`.
    state : dict
        The ``state`` that run filled.
    directory : str or path-like
        Created if missing (its parent must exist).

    Returns
    -------
    Path
        The written ``index.html``.

    Raises
    ------
    InputError
        If the parent of ``directory`` does not exist.
    """
    import html

    from exudyn_study.infra.atomic import write_text_atomic

    d = Path(directory)
    if not d.parent.is_dir():
        raise InputError(f"report directory {str(d)!r}: parent {str(d.parent)!r} does not exist")
    figs = write_level_figures(state, d)
    meta = diagnosis.metadata
    esc = html.escape
    rows = "".join(
        f"<tr><td>{esc(r['recording'])}</td><td>{r['mode']}</td><td>{r['frequency_hz']:.4f} &plusmn; "
        f"{r['frequency_std_hz']:.4f}</td><td>{100 * r['damping_ratio']:.3f} &plusmn; "
        f"{100 * r['damping_std']:.3f}</td>"
        f"<td>{r['amplitude']:.3g} {esc(r['amplitude_unit'])}</td></tr>"
        for r in meta.get("modal_table", [])
    )
    trends = "".join(
        f"<tr><td>{t['mode']}</td><td>{t['frequency_hz']:.4g}</td><td>{esc(t['outcome'])}</td>"
        f"<td>{100 * t['frequency_change']:+.2f} % ({t['frequency_z']:+.1f} &sigma;)</td>"
        f"<td>{100 * t['damping_change']:+.0f} % ({t['damping_z']:+.1f} &sigma;)</td></tr>"
        for t in meta.get("trends", [])
    )
    loc = "".join(
        f"<tr><td>{esc('-'.join(e['pair']))}</td><td>{e['score']:+.3f}</td><td>{e['z']:+.1f}</td></tr>"
        for e in meta.get("location_evidence", [])
    )
    sens = "".join(
        f"<tr><td>{esc('-'.join(e['pair']))}</td><td>{e['reduced_chi2']:.2f}</td><td>{e['z']:+.1f}</td></tr>"
        for e in meta.get("location_sensitivity", [])
    )
    check = "".join(
        f"<tr><td>{esc(c)}</td><td>{v['relative_error']:.3f}</td><td>{v['misfit_in_noise_units']:.1f}</td>"
        f"<td>{'yes' if v['passed'] else 'no'}</td></tr>"
        for c, v in meta.get("reference_model", {}).get("check", {}).items()
    )
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>exudyn_study level diagnosis</title>",
        "<style>body{font-family:sans-serif;max-width:1200px;margin:auto}table{border-collapse:collapse;"
        "margin:6px 0}td,th{border:1px solid #bbb;padding:2px 7px;font-size:88%}img{max-width:100%}</style>"
        "</head><body><h1>Level-trend diagnosis</h1>",
        f"<p><b>{esc(diagnosis.summary)}</b></p>",
        f"<p>Excitation {esc(str(meta.get('excitation')))}, band "
        f"{meta['band_hz'][0]:.4g}-{meta['band_hz'][1]:.4g} "
        f"Hz, resolution {meta['resolution_hz']:.4g} Hz, FRFs in {esc(meta['frf_unit'])}; reference "
        f"{esc(meta['reference'])}.</p>",
    ]
    for f in diagnosis.findings:
        parts.append(f"<h2>Finding: {esc(f.physics)}</h2><p>{esc(f.explanation)}</p>")
        if f.flags:
            parts.append("<ul>" + "".join(f"<li>{esc(x)}</li>" for x in f.flags) + "</ul>")
        prm = "".join(
            f"<tr><td>{esc(k)}</td><td>{v['value']:.4g}</td><td>{esc(v['unit'])}</td>"
            f"<td>{'-' if v['std'] is None else format(v['std'], '.2g')}</td></tr>"
            for k, v in f.parameters.items()
        )
        parts.append(
            f"<table><tr><th>parameter</th><th>value</th><th>unit</th><th>std</th></tr>{prm}</table>"
        )
        lv = "".join(
            f"<tr><td>{esc(k)}</td><td>{'held out' if v['held_out'] else 'train'}</td>"
            f"<td>{v['mean_before']:.3f}</td><td>{v['mean_after']:.3f}</td>"
            f"<td>{v['mean_floor']:.3f}</td></tr>"
            for k, v in f.fit["per_level"].items()
        )
        parts.append(
            "<h3>Proof: relative FRF error per level (mean over channels)</h3><table><tr><th>level</th>"
            "<th>role</th><th>reference model</th><th>with the joint law</th><th>noise + distortion</th>"
            f"</tr>{lv}</table>"
        )
    for u in diagnosis.unexplained:
        parts.append(f"<h2>Unexplained</h2><p>{esc(u['explanation'])}</p>")
    parts += [
        "<h2>Reference model check</h2><table><tr><th>channel</th><th>relative error</th>"
        f"<th>misfit / noise</th><th>passed</th></tr>{check}</table>",
        f"<h2>Level trends</h2><table><tr><th>mode</th><th>f (Hz)</th><th>outcome</th><th>frequency</th>"
        f"<th>damping</th></tr>{trends}</table>",
        f"<h2>Location evidence</h2><p>Located by: {esc(str(meta.get('located_by')))}.</p>"
        "<h3>Relative motion in the level-dependent modes</h3>"
        f"<table><tr><th>pair</th><th>score</th><th>z</th></tr>{loc}</table>",
    ]
    if sens:
        parts.append(
            "<h3>Eigenvalue sensitivity (every mode's change against its coupling to the pair)</h3>"
            f"<table><tr><th>pair</th><th>reduced chi-square</th><th>z</th></tr>{sens}</table>"
        )
    parts += [f"<h2>{esc(p.stem.replace('_', ' '))}</h2><img src='{p.name}'>" for p in figs]
    parts.append(
        "<h2>Modal parameters per level</h2><table><tr><th>recording</th><th>mode</th><th>f (Hz)</th>"
        f"<th>damping (%)</th><th>amplitude</th></tr>{rows}</table></body></html>"
    )
    return write_text_atomic(d / "index.html", "".join(parts), "diagnosis report")
