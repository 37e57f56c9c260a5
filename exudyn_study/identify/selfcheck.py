"""The identification checks itself: where the fitted model misses the data, look for a missing pole.

After LSFD, the misfit of every line is compared with the noise of the estimate (the
inverse standard error of the FRF from its coherence and averages,
:func:`~exudyn_study.identify.frf.frf_weights`; per-channel rms weights when the FRFs carry no
noise information), as the channel mean of the squared weighted residual, relative to its
median over the band (the level of the lines the model fits). Contiguous lines where it stays
above ``threshold`` form *misfit bands*. A mode the selection missed leaves such a band: a bump
of the data the model does not follow.

For each misfit band (worst first) two candidate poles are tried:

1. from the stabilisation diagram: the most persistent rejected cluster in the band (its
   poles were there, the selection rules turned them down);
2. from a local refit: PolyMAX on the band widened to both sides, its most persistent
   cluster that no selected mode already explains.

The model is refitted as a whole with each; the candidate kept is the one that lowers the
band's misfit most, by at least half, without raising the median fit error, with a physical
damping (a half-power bandwidth of at least a quarter line: a narrower pole fits a noise spike),
a real-mode-like shape (MPC >= 0.7) that is not a copy of a neighbour's within a half-power
bandwidth. What was
added, from where and by how much it improved the fit is reported; bands where nothing could be
added are reported as poorly fitted.
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
        band), ``source`` ('diagram' or 'local refit'), ``misfit_before``, ``misfit_after``
        (the band's mean misfit relative to the noise level, -).
    poor_fit_bands_hz : tuple of (float, float)
        Misfit bands where no pole could be added, in Hz.
    threshold : float
        Misfit (relative to the band median) above which a line counts as poorly fitted.
    """

    added: tuple[dict, ...]
    poor_fit_bands_hz: tuple[tuple[float, float], ...]
    threshold: float

    def as_dict(self) -> dict:
        """Return a JSON-ready summary."""
        return {"added": list(self.added),
                "added_hz": [round(a["frequency_hz"], 4) for a in self.added],
                "poor_fit_bands_hz": [list(b) for b in self.poor_fit_bands_hz],
                "threshold": self.threshold}


def _line_misfit(frf: FRF, fit: LSFDResult, sel: np.ndarray) -> np.ndarray:
    """Channel mean of the squared weighted residual per line, relative to its band median."""
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
    med = np.median(r)
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
    threshold: float = 8.0,
    max_added: int = 3,
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
    threshold : float, optional
        Misfit level relative to the noise that marks a band (default 8: a missing mode
        leaves tens; leakage and noise at a well-fitted lightly damped peak a few).
    max_added : int, optional
        Most modes added (default 3).
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
        What was added and where the fit stays poor.
    LSFDResult
        The final fit (``fit`` when nothing was added).
    list of Cluster
        The clusters of the added modes, in the order their poles were appended to ``fit``.
    """
    sel = (frf.freq_hz >= band_hz[0]) & (frf.freq_hz <= band_hz[1])
    f = frf.freq_hz[sel]
    ratio = _line_misfit(frf, fit, sel)
    runs = misfit_bands(ratio, f, threshold=threshold)
    added, added_clusters = [], []
    for i0, i1, before in runs:
        if len(added) >= max_added:
            break
        lo, hi = float(f[i0]), float(f[i1])
        best = None
        for source, cand, diagram in _candidates(frf, poles, selection, fit, lo, hi, band_hz):
            fn, zeta = pole_to_modal(np.array([cand.pole]))
            if any(abs(fn[0] - x) <= 0.02 * x for x in exclude_hz):
                continue
            if not (0 < zeta[0] < max_damping) or _copies_neighbour(fit, cand, diagram):
                continue
            try:
                new = refit(np.concatenate([fit.poles, [cand.pole]]))
            except InputError:
                continue
            band_after = float(np.mean(_line_misfit(frf, new, sel)[i0:i1 + 1]))
            f_new, z_new = pole_to_modal(new.poles[-1:])
            ok = (band_after <= 0.5 * before
                  and np.median(new.fit_error) <= 1.05 * np.median(fit.fit_error)
                  and 2 * z_new[0] * f_new[0] >= min_lines * frf.resolution_hz
                  and float(mpc(new.shapes[:, -1:])[0]) >= min_mpc)
            if ok and (best is None or band_after < best[0]):
                best = (band_after, source, cand, new)
        if best is None:
            continue
        band_after, source, cand, new = best
        f_new, z_new = pole_to_modal(new.poles[-1:])
        added.append({"frequency_hz": float(f_new[0]), "damping_ratio": float(z_new[0]),
                      "band_hz": [lo, hi], "source": source,
                      "misfit_before": before, "misfit_after": band_after})
        added_clusters.append(cand)
        fit = new
    if added:  # where the final model still misfits
        ratio = _line_misfit(frf, fit, sel)
        runs = misfit_bands(ratio, f, threshold=threshold)
    poor = sorted((float(f[i0]), float(f[i1])) for i0, i1, _ in runs)
    return SelfCheck(tuple(added), tuple(poor), threshold), fit, added_clusters


def _explained(fit: LSFDResult, f_hz: float, rel: float = 0.003) -> bool:
    fr = pole_to_modal(fit.poles)[0]
    return bool(np.any(np.abs(fr - f_hz) <= rel * f_hz))


def _candidates(frf, poles, selection, fit, lo, hi, band_hz):
    """Candidate clusters for a misfit band lo..hi Hz: diagram first, then a local refit."""
    width = max(hi - lo, 4 * frf.resolution_hz)
    near = [c for c in selection.clusters
            if not c.accepted and c.reason in ("persistence", "consistency", "satellite")
            and lo - 0.5 * width <= c.frequency_hz <= hi + 0.5 * width
            and not _explained(fit, c.frequency_hz)]
    for c in sorted(near, key=lambda c: -c.n_orders)[:1]:
        yield "diagram", c, poles
    a, b = max(band_hz[0], lo - 2 * width), min(band_hz[1], hi + 2 * width)
    n_lines = int(np.sum((frf.freq_hz >= a) & (frf.freq_hz <= b)))
    pmax = min(40, (n_lines * frf.H.shape[0]) // 2 - 1)
    if pmax < 6:
        return
    try:
        local = polymax(frf.H, frf.freq_hz, range(2, pmax + 1), band_hz=(a, b))
        loc_sel = select_modes(local, min_orders=3)
    except InputError:
        return
    found = [c for c in loc_sel.clusters
             if lo - 0.5 * width <= c.frequency_hz <= hi + 0.5 * width and c.n_orders >= 5
             and not _explained(fit, c.frequency_hz)]
    for c in sorted(found, key=lambda c: -c.n_orders)[:1]:
        yield "local refit", c, local


def _copies_neighbour(fit: LSFDResult, cand: Cluster, poles: Poles) -> bool:
    """Whether the candidate lies within a half-power bandwidth of a mode with the same shape.

    ``poles`` is the diagram the candidate's members index; with participation vectors (several
    references) shapes cannot be compared and any candidate that close counts as a copy.
    """
    fr, ze = pole_to_modal(fit.poles)
    vec = poles.vector[cand.members]
    for k, (f_k, z_k) in enumerate(zip(fr, ze, strict=True)):
        if abs(cand.frequency_hz - f_k) <= max(z_k, 1e-3) * f_k:
            if poles.vector_kind != "shape":
                return True
            if float(np.median(mac(vec.T, fit.shapes[:, k:k + 1]))) > 0.9:
                return True
    return False
