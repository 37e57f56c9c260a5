"""The identification checks itself: where the fitted model misses the data, look for a missing pole.

After LSFD, the misfit of every line is compared with the noise of the estimate (the
inverse standard error of the FRF from its coherence and averages,
:func:`~exudyn_study.identify.frf.frf_weights`; per-channel rms weights when the FRFs carry no
noise information), as the channel mean of the squared weighted residual, relative to its
median over the band (the level of the lines the model fits). Contiguous lines where it stays
above ``threshold`` form *misfit bands*. A mode the selection missed leaves such a band: a bump
of the data the model does not follow.

For the worst misfit band three candidates are tried:

1. from the stabilisation diagram: the most persistent rejected cluster in the band (its
   poles were there, the selection rules turned them down);
2. a local re-identification: PolyMAX on the band widened by its width (at least ten lines)
   each side; its accepted clusters in and around the band replace the modes there. A wide
   band holding many modes needs a high order to resolve a dense group in it (eight modes in
   6-12.5 Hz of a 2-60 Hz band: the global diagram shows five of them, one as a 12 %-damped
   pole standing for three); the local fit resolves them at a modest order;
3. from the same local diagram: its most persistent cluster no selected mode explains (added).

The model is refitted as a whole with each; the candidate kept is the one that lowers the
band's misfit most, by at least half, without raising the median fit error, with physical
poles (a half-power bandwidth of at least a quarter line: a narrower pole fits a noise spike),
real-mode-like shapes (MPC >= 0.7), no copy of a neighbour's shape within a half-power
bandwidth, and no neighbour within the narrower half-power bandwidth turned complex by it (a
pole that splits one mode into two). The misfit is then measured again and the next band
taken, up to ``max_added`` changes.

Finally a mode is questioned on its own evidence when its shape is complex (MPC < 0.9) or it
lies within another mode's half-power bandwidth: it is removed when the model without it fits
the lines around it within the noise threshold and the band as a whole as well (its residue
carries nothing beyond the noise). What was added, replaced and removed, from where and by how
much it changed the fit, is reported; bands where nothing helped are reported as poorly fitted.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify.frf import FRF, frf_weights
from exudyn_study.identify.lsfd import LSFDResult
from exudyn_study.identify.mac import mac, mpc
from exudyn_study.identify.polymax import Poles, pole_to_modal, polymax
from exudyn_study.identify.selection import Cluster, Selection, select_modes

__all__ = ["SelfCheck", "misfit_bands", "self_check"]


@dataclass(frozen=True)
class SelfCheck:
    """What the self-check found and did.

    Attributes
    ----------
    added : tuple of dict
        One entry per added mode: ``frequency_hz``, ``damping_ratio``, ``band_hz`` (the misfit
        band), ``source`` ('diagram', 'local re-identification' or 'local refit'),
        ``misfit_before``, ``misfit_after`` (the band's mean misfit relative to the noise
        level, -).
    poor_fit_bands_hz : tuple of (float, float)
        Misfit bands where no pole could be added, in Hz.
    threshold : float
        Misfit (relative to the band median) above which a line counts as poorly fitted.
    removed : tuple of dict
        One entry per removed mode: ``frequency_hz``, ``damping_ratio``, ``band_hz``,
        ``reason`` (replaced by a local re-identification, or not supported by the fit).
    """

    added: tuple[dict, ...]
    poor_fit_bands_hz: tuple[tuple[float, float], ...]
    threshold: float
    removed: tuple[dict, ...] = ()

    def as_dict(self) -> dict:
        """Return a JSON-ready summary."""
        return {"added": list(self.added),
                "added_hz": [round(a["frequency_hz"], 4) for a in self.added],
                "removed": list(self.removed),
                "removed_hz": [round(a["frequency_hz"], 4) for a in self.removed],
                "poor_fit_bands_hz": [list(b) for b in self.poor_fit_bands_hz],
                "threshold": self.threshold}


def _line_misfit(frf: FRF, fit: LSFDResult, sel: np.ndarray, level: float | None = None) -> np.ndarray:
    """Channel mean of the squared weighted residual per line, relative to ``level``.

    ``level`` defaults to the band median of the residual itself (the noise level of a model
    that fits); another model's level compares two models on one scale.
    """
    h = frf.H[:, :, sel]
    if np.any(frf.coherence[:, :, sel] < 0.9999):
        # the coherence sets the relative noise of every line (the averages only scale it,
        # and the misfit is taken relative to its median): measured FRFs from a file that
        # carry the coherence but not the number of averages are weighted the same way
        w = frf_weights(frf)[:, :, sel]
    else:
        rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=-1, keepdims=True))
        w = np.where(rms > 0, 1.0 / np.where(rms > 0, rms, 1.0), 0.0) * np.ones(h.shape)
    r = np.mean(np.abs(h - fit.synthesised) ** 2 * w**2, axis=(0, 1))
    med = np.median(r) if level is None else level
    return r / med if med > 0 else np.zeros_like(r)


def misfit_bands(ratio: np.ndarray, freq_hz: np.ndarray, *, threshold: float = 8.0,
                 smooth_lines: int = 3, min_lines: int = 3) -> list[tuple[int, int, float]]:
    """Return contiguous runs of lines whose smoothed misfit exceeds ``threshold``.

    Parameters
    ----------
    ratio : ndarray, shape (n_freq,)
        Misfit per line relative to the noise level (-).
    freq_hz : ndarray, shape (n_freq,)
        Lines in Hz (for the order of the result only).
    threshold : float, optional
        Level above which a line is poorly fitted (default 8).
    smooth_lines : int, optional
        Width of the running mean in lines (default 3).
    min_lines : int, optional
        Shortest run reported (default 3).

    Returns
    -------
    list of (int, int, float)
        First and last line index of every run and its mean misfit, worst first.
    """
    if ratio.size != freq_hz.size:
        raise InputError(f"ratio of {ratio.size} lines for {freq_hz.size} frequencies: expected equal")
    k = max(1, int(smooth_lines))
    sm = np.convolve(ratio, np.ones(k) / k, mode="same")
    bad = sm > threshold
    runs = []
    i = 0
    while i < bad.size:
        if bad[i]:
            j = i
            while j + 1 < bad.size and bad[j + 1]:
                j += 1
            if j - i + 1 >= min_lines:
                runs.append((i, j, float(np.mean(ratio[i:j + 1]))))
            i = j + 1
        else:
            i += 1
    return sorted(runs, key=lambda r: -r[2])


def self_check(
    frf: FRF,
    fit: LSFDResult,
    poles: Poles,
    selection: Selection,
    band_hz: tuple[float, float],
    refit: Callable[[np.ndarray], LSFDResult],
    *,
    clusters: Sequence[Cluster] | None = None,
    threshold: float = 8.0,
    max_added: int = 3,
    max_refits: int = 12,
    max_damping: float = 0.2,
    exclude_hz: Sequence[float] = (),
    min_lines: float = 0.25,
    min_mpc: float = 0.7,
) -> tuple[SelfCheck, LSFDResult, list[Cluster]]:
    """Close the loop after LSFD: add missing poles where the model misfits beyond the noise.

    Parameters
    ----------
    frf : FRF
        The fitted FRFs.
    fit : LSFDResult
        The fit of the selected modes.
    poles : Poles
        The stabilisation diagram.
    selection : Selection
        The automatic selection (its rejected clusters are the first candidates).
    band_hz : (float, float)
        Fitted band in Hz.
    refit : callable
        ``refit(start_poles) -> LSFDResult``: the pipeline's fit (refinement, leakage, weights)
        for a set of starting poles in rad/s.
    clusters : sequence of Cluster, optional
        The clusters the poles of ``fit`` stand for, in their order (default the accepted
        clusters of ``selection`` when their number matches, else clusters made from the
        fitted poles).
    threshold : float, optional
        Misfit level relative to the noise that marks a band (default 8: a missing mode
        leaves tens; leakage and noise at a well-fitted lightly damped peak a few).
    max_added : int, optional
        Most changes made (modes added, or bands re-identified) (default 3).
    max_refits : int, optional
        Most trial refits over all misfit bands and the drop test (default 12): every trial
        refits the whole model.
    max_damping : float, optional
        Largest damping ratio of an added mode (default 0.2).
    exclude_hz : sequence of float, optional
        Frequencies (Hz) the user dropped: no mode is added within 2 % of them.
    min_lines : float, optional
        Narrowest half-power bandwidth of an added mode, in spectral lines (default 0.25):
        a narrower pole fits a noise spike of one or two lines, not a mode.
    min_mpc : float, optional
        Lowest modal phase collinearity of an added mode's shape (default 0.7).

    Returns
    -------
    SelfCheck
        What was added, removed and where the fit stays poor.
    LSFDResult
        The final fit (``fit`` when nothing was changed).
    list of Cluster
        The clusters the poles of the final fit stand for, in their order.
    """
    sel = (frf.freq_hz >= band_hz[0]) & (frf.freq_hz <= band_hz[1])
    f = frf.freq_hz[sel]
    if clusters is None:
        clusters = selection.modes if len(selection.modes) == fit.poles.size else ()
    clusters = list(clusters) if len(clusters) == fit.poles.size else \
        [_pole_cluster(p) for p in fit.poles]
    budget = [int(max_refits)]

    def trial(start):
        if budget[0] <= 0:
            return None
        budget[0] -= 1
        try:
            return refit(start)
        except InputError:
            return None

    def physical(new: LSFDResult, k: np.ndarray) -> bool:
        """Whether the new model's modes ``k`` look like modes (damping, bandwidth, MPC)."""
        f_new, z_new = pole_to_modal(new.poles[k])
        return bool(np.all((z_new > 0) & (z_new < max_damping)
                           & (2 * z_new * f_new >= min_lines * frf.resolution_hz))
                    and np.all(mpc(new.shapes[:, k]) >= min_mpc))

    added, removed, tried = [], [], []
    changes = 0
    ratio = _line_misfit(frf, fit, sel)
    while changes < max_added and budget[0] > 0:
        runs = [r for r in misfit_bands(ratio, f, threshold=threshold)
                if not any(abs(f[r[0]] - a) < 1e-9 and abs(f[r[1]] - b) < 1e-9 for a, b in tried)]
        if not runs:
            break
        i0, i1, before = runs[0]
        lo, hi = float(f[i0]), float(f[i1])
        tried.append((lo, hi))
        best = None
        for source, cands, drop, diagram in _candidates(frf, poles, selection, fit, lo, hi,
                                                        band_hz, clusters):
            fn = np.array([c.frequency_hz for c in cands])
            if any(np.any(np.abs(fn - x) <= 0.02 * x) for x in exclude_hz):
                continue
            zeta = pole_to_modal(np.array([c.pole for c in cands]))[1]
            if not np.all((zeta > 0) & (zeta < max_damping)):
                continue
            if any(_copies_neighbour(fit, c, diagram, drop) for c in cands):
                continue
            keep = np.setdiff1d(np.arange(fit.poles.size), drop)
            new = trial(np.concatenate([fit.poles[keep], [c.pole for c in cands]]))
            if new is None:
                continue
            r_new = _line_misfit(frf, new, sel)
            band_after = float(np.mean(r_new[i0:i1 + 1]))
            fresh = np.arange(keep.size, new.poles.size)
            ok = (band_after <= 0.5 * before
                  and np.median(new.fit_error) <= 1.05 * np.median(fit.fit_error)
                  and physical(new, fresh)
                  and _neighbours_stay_real(fit, new, keep))
            if ok and (best is None or band_after < best[0]):
                best = (band_after, source, cands, keep, new, r_new)
        if best is None:
            continue
        band_after, source, cands, keep, new, r_new = best
        f_new, z_new = pole_to_modal(new.poles[keep.size:])
        for k in np.setdiff1d(np.arange(fit.poles.size), keep):
            removed.append({"frequency_hz": float(fit.frequency_hz[k]),
                            "damping_ratio": float(fit.damping_ratio[k]),
                            "band_hz": [lo, hi], "reason": f"replaced by the {source}"})
        for fk, zk in zip(f_new, z_new, strict=True):
            added.append({"frequency_hz": float(fk), "damping_ratio": float(zk),
                          "band_hz": [lo, hi], "source": source,
                          "misfit_before": before, "misfit_after": band_after})
        clusters = [clusters[k] for k in keep] + list(cands)
        fit, ratio = new, r_new
        changes += 1
    fit, clusters, ratio, dropped = _drop_unsupported(frf, fit, clusters, ratio, sel, trial,
                                                      threshold)
    removed += dropped
    runs = misfit_bands(ratio, f, threshold=threshold)
    poor = sorted((float(f[i0]), float(f[i1])) for i0, i1, _ in runs)
    return SelfCheck(tuple(added), tuple(poor), threshold, tuple(removed)), fit, clusters


def _neighbours_stay_real(old: LSFDResult, new: LSFDResult, keep: np.ndarray) -> bool:
    """Whether the kept modes beside a new pole stay as real-mode-like (MPC) as they were.

    A pole added beside a mode it duplicates splits that mode's residues between the two:
    both shapes turn complex (measured: MPC 0.9 -> 0.72 and 0.74 for two poles at one 3 %
    mode), while a genuinely missing mode frees its neighbour from what it had to absorb.
    Checked are the kept modes within the narrower half-power bandwidth of a new pole.
    """
    f_old, z_old = old.frequency_hz[keep], old.damping_ratio[keep]
    f_new, z_new = new.frequency_hz[keep.size:], new.damping_ratio[keep.size:]
    near = np.zeros(keep.size, bool)
    for fk, zk in zip(f_new, z_new, strict=True):
        near |= np.abs(f_old - fk) <= np.minimum(z_old, zk) * fk
    inside = np.flatnonzero(near)
    if inside.size == 0:
        return True
    before = mpc(old.shapes[:, keep[inside]])
    after = mpc(new.shapes[:, inside])
    return bool(np.min(after) >= min(np.min(before), 0.9) - 0.05)


def _pole_cluster(pole: complex) -> Cluster:
    """Return a cluster standing for one given pole (no diagram members)."""
    fn, zeta = pole_to_modal(np.array([pole]))
    return Cluster(members=np.zeros(0, int), frequency_hz=float(fn[0]), damping_ratio=float(zeta[0]),
                   frequency_std_hz=0.0, damping_std=0.0, pole=complex(pole), n_orders=0,
                   coverage=0.0, accepted=True, reason="given")


def _drop_unsupported(frf, fit, clusters, ratio, sel, trial, threshold):
    """Remove modes whose own evidence does not support them.

    A mode is questioned when its shape is not real-mode-like (MPC below 0.9), when it lies
    within the half-power bandwidth of the narrower of itself and another mode, or within two
    bandwidths of the wider with a similar shape (MAC above 0.8): the footprints of
    over-modelling and of one mode fitted twice (a shadow pole beside a lightly damped peak
    the window smooths). It is removed when the model
    without it fits as well: on the current model's noise scale, the misfit around it (two
    half-power bandwidths, at least three lines each side) stays below ``threshold`` and the
    band median rises by less than 10 %.
    """
    f = frf.freq_hz[sel]
    dropped = []
    fr, ze = pole_to_modal(fit.poles)
    phase = mpc(fit.shapes)
    order = np.argsort(phase)  # least real-mode-like first
    similar = mac(fit.shapes, fit.shapes) > 0.8
    for k in order:
        others = np.delete(np.arange(fr.size), k)
        gap = np.abs(fr[others] - fr[k])
        close = np.any((gap <= np.minimum(ze[others], ze[k]) * fr[k])
                       | ((gap <= 2 * np.maximum(ze[others], ze[k]) * fr[k]) & similar[k, others]))
        if not (phase[k] < 0.9 or close) or fit.poles.size < 2 or clusters[k].reason == "pinned":
            continue
        new = trial(np.delete(fit.poles, k))
        if new is None:
            break
        level = float(np.median(_line_misfit(frf, fit, sel, level=1.0)))
        r_new = _line_misfit(frf, new, sel, level=level)
        half = max(2 * ze[k] * fr[k], 3 * frf.resolution_hz)
        near = (f >= fr[k] - half) & (f <= fr[k] + half)
        if np.mean(r_new[near]) < threshold and np.median(r_new) <= 1.1:
            dropped.append({"frequency_hz": float(fr[k]), "damping_ratio": float(ze[k]),
                            "band_hz": [float(fr[k] - half), float(fr[k] + half)],
                            "reason": f"no support: MPC {phase[k]:.2f}, the fit without it is "
                                      "as good"})
            clusters = [c for i, c in enumerate(clusters) if i != k]
            fit, ratio = new, _line_misfit(frf, new, sel)
            # indices changed: question the rest against the new model
            rest_fit, rest_clusters, rest_ratio, rest = _drop_unsupported(
                frf, fit, clusters, ratio, sel, trial, threshold)
            return rest_fit, rest_clusters, rest_ratio, dropped + rest
    return fit, clusters, ratio, dropped


def _explained(fit: LSFDResult, f_hz: float, rel: float = 0.003, skip=()) -> bool:
    fr = np.delete(pole_to_modal(fit.poles)[0], np.asarray(skip, int))
    return bool(np.any(np.abs(fr - f_hz) <= rel * f_hz))


def _candidates(frf, poles, selection, fit, lo, hi, band_hz, clusters):
    """Candidates for a misfit band lo..hi Hz: ``(source, clusters, dropped modes, diagram)``.

    1. the most persistent rejected cluster of the diagram near the band (added);
    2. a local re-identification: PolyMAX on the band widened by its width (at least ten
       lines) each side, its accepted clusters in the band and half the margin around it
       replace the modes there (a mode the global fit placed between two close ones, or a
       heavily damped mode the global diagram shows only at its highest orders);
    3. the most persistent cluster of that local diagram no mode explains (added).
    """
    width = max(hi - lo, 4 * frf.resolution_hz)
    near = [c for c in selection.clusters
            if not c.accepted and c.reason in ("persistence", "consistency", "satellite")
            and lo - 0.5 * width <= c.frequency_hz <= hi + 0.5 * width
            and not _explained(fit, c.frequency_hz)]
    for c in sorted(near, key=lambda c: -c.n_orders)[:1]:
        yield "diagram", [c], np.zeros(0, int), poles
    margin = max(width, 10 * frf.resolution_hz)
    a, b = max(band_hz[0], lo - margin), min(band_hz[1], hi + margin)
    n_lines = int(np.sum((frf.freq_hz >= a) & (frf.freq_hz <= b)))
    pmax = min(60, (n_lines * frf.H.shape[0]) // 2 - 1)
    if pmax < 6:
        return
    try:
        local = polymax(frf.H, frf.freq_hz, range(2, pmax + 1), band_hz=(a, b))
        loc_sel = select_modes(local)
    except InputError:
        return
    c_lo, c_hi = max(a, lo - 0.5 * margin), min(b, hi + 0.5 * margin)
    inner = [c for c in loc_sel.modes if c_lo <= c.frequency_hz <= c_hi]
    fr = pole_to_modal(fit.poles)[0]
    drop = np.flatnonzero((fr >= c_lo) & (fr <= c_hi))
    pinned = any(clusters[k].reason == "pinned" for k in drop)  # the user's modes stay
    changed = len(inner) != drop.size or not all(_explained(fit, c.frequency_hz) for c in inner)
    if inner and not pinned and changed:
        yield "local re-identification", inner, drop, local
    loc_min = min(5, max(3, len(local.orders) // 10))
    found = [c for c in loc_sel.clusters
             if lo - 0.5 * width <= c.frequency_hz <= hi + 0.5 * width and c.n_orders >= loc_min
             and not _explained(fit, c.frequency_hz)]
    for c in sorted(found, key=lambda c: -c.n_orders)[:1]:
        yield "local refit", [c], np.zeros(0, int), local


def _copies_neighbour(fit: LSFDResult, cand: Cluster, poles: Poles, drop=()) -> bool:
    """Whether the candidate lies within a half-power bandwidth of a mode with the same shape.

    ``poles`` is the diagram the candidate's members index; with participation vectors (several
    references) shapes cannot be compared and any candidate that close counts as a copy. Modes
    in ``drop`` (replaced by the candidate's set) are not compared.
    """
    fr, ze = pole_to_modal(fit.poles)
    vec = poles.vector[cand.members]
    for k, (f_k, z_k) in enumerate(zip(fr, ze, strict=True)):
        if k in drop:
            continue
        if abs(cand.frequency_hz - f_k) <= max(z_k, 1e-3) * f_k:
            if poles.vector_kind != "shape":
                return True
            if float(np.median(mac(vec.T, fit.shapes[:, k:k + 1]))) > 0.9:
                return True
    return False
