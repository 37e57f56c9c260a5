"""Locate: where, in which band and whether level dependent the rig model misses the recordings.

A stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`: :func:`locate` turns a
:class:`~exudyn_study.diagnose.rig_state.Comparison` into a
:class:`~exudyn_study.diagnose.rig_state.Location` (the located sensors strongest first, the band,
the level dependence). Level dependence comes model-free from one drive at two levels
(:func:`level_pair`, :func:`distortion_shares`) or from the model's error across levels
(:func:`is_level_dependent`).
"""

from __future__ import annotations

import numpy as np

from exudyn_study.diagnose.rig_compare import BANDS_HZ, band_filter, drive_spectra, relative_errors
from exudyn_study.diagnose.rig_state import Comparison, Location, RigProblem


def level_pair(recs, stronger_in=None) -> tuple | None:
    """Return the two recordings of one drive at the most different levels: ``(c, weaker, stronger, n)``.

    Two drives are one drive at two levels if they are scaled copies in time (correlation
    > 0.9999 over their first ``n`` common samples) and their rms differs by more than
    20 %; ``c`` is the least-squares scale from the weaker to the stronger drive. None
    without such a pair. ``stronger_in``: only pairs whose stronger recording is one of these.

    Parameters
    ----------
    recs : sequence of RigRecording
        The recordings to search.
    stronger_in : sequence of RigRecording or None, optional
        Recordings the stronger one must be among (by identity; None: any).

    Returns
    -------
    tuple or None
        ``(c, weaker, stronger, n)``: the drives' scale, the two recordings and the number of common
        samples compared; None without such a pair.
    """
    best = None
    for a in recs:
        for b in recs:
            if b.drive_rms_m < 1.2 * a.drive_rms_m:
                continue
            if stronger_in is not None and not any(b is r for r in stronger_in):
                continue
            n = min(a.drive.samples.size, b.drive.samples.size)
            ua, ub = a.drive.samples[:n], b.drive.samples[:n]
            if float(np.corrcoef(ua, ub)[0, 1]) < 0.9999:
                continue
            c = float(ub @ ua / (ua @ ua))
            if best is None or c > best[0]:
                best = (c, a, b, n)
    return best


def distortion_shares(recs) -> tuple | None:
    """Per channel, the share of the response a linear structure cannot produce, from two levels of one drive.

    If two recordings' drives are scaled copies of each other in time (the thesis's test
    signal at 100 % and 50 %: correlation > 0.9999), any linear structure responds to the
    stronger one with exactly the scaled response of the weaker one, so
    ``y_b - c y_a`` (``c`` the drives' least-squares scale) holds only the level-dependent
    (nonlinear) part and noise: no model is needed. Returns
    ``rms(y_b - c y_a) / rms(y_b)`` per channel (band-limited, 3-60 Hz) of the pair with
    the largest level ratio, or None without such a pair (:func:`level_pair`).

    Parameters
    ----------
    recs : sequence of RigRecording
        The recordings to search for one drive at two levels.
    """
    pair = level_pair(recs)
    if pair is None:
        return None
    c, a, b, n = pair
    rows_a = [a.channels.index(ch) for ch in b.channels]
    d = band_filter(b.measured[:, :n] - c * a.measured[rows_a, :n])
    return np.sqrt(np.mean(d**2, axis=1)) * b.scale, b


def nonlinear_sensors(distortion, channels, located) -> list:
    """Located sensors with a local nonlinear share (:func:`distortion_shares`), strongest first.

    Parameters
    ----------
    distortion : tuple or None
        ``(share, stronger recording)`` of :func:`distortion_shares` (None: no pair, no sensor).
    channels : sequence of str
        The recordings' response channels (unused; the stronger recording names the rows of ``share``).
    located : sequence of str
        The located sensors.

    Returns
    -------
    list of str
        The located sensors whose share exceeds twice the median share and 0.5 %, strongest first.
    """
    if distortion is None:
        return []
    share, strong = distortion
    local = share > max(2.0 * float(np.median(share)), 0.005)
    by_name = {c: float(v) for c, v, ok in zip(strong.channels, share, local, strict=True) if ok}
    return sorted((c for c in located if c in by_name), key=lambda c: -by_name[c])


def is_level_dependent(recs, sims, rows, distortion=None) -> bool:
    """Whether the mismatch at the channels ``rows`` grows with the drive level.

    Pairs of recordings whose drives have the same spectral shape (one a scaled copy of the
    other, e.g. the thesis's test signal at 100 % and 50 %) and whose rms differs by more
    than 20 % are compared by the nominal model's relative error per channel
    (:func:`~exudyn_study.diagnose.rig_compare.relative_errors`): a linear mismatch gives
    the same relative error at every level (or a larger one at the lower level, where noise
    weighs more); a stiffening or softening element gives an error that grows with level
    (cubic: about as the level squared). Level dependent if the median ratio over the
    channels exceeds 1.5. Without such a pair, the H1 estimates of the lowest and highest
    level are compared (a bin counts where the difference exceeds 5 times its standard
    error and 5 % of the FRF; level dependent above 5 % of the bins).

    Besides, with ``distortion`` (:func:`distortion_shares`: the model-free nonlinear share
    per channel and the stronger recording), a channel among ``rows`` whose nonlinear share
    is local (above twice the median over all channels and above 0.5 %) and at least half of
    the current model's error there makes the mismatch level dependent: once linear findings
    have explained most of the error at a nonlinear element, what is left there grows with
    the level, even if other channels' linear error hides it in the median ratio.

    Parameters
    ----------
    recs : sequence of RigRecording
        The recordings (training, then held out).
    sims : sequence of numpy.ndarray
        The current model's simulation per recording, shape (n_channels, n_samples).
    rows : array_like of int
        Indices of the channels with significant mismatch.
    distortion : tuple or None, optional
        ``(share, stronger recording)`` of :func:`distortion_shares` (None: not used).

    Returns
    -------
    bool
        Whether the mismatch is level dependent.
    """
    if len(rows) == 0 or len(recs) < 2:
        return False
    if distortion is not None:
        share, strong = distortion
        k = next(i for i, r in enumerate(recs) if r is strong)
        err = relative_errors(strong, sims[k])
        local = (share > max(2.0 * float(np.median(share)), 0.005)) & (share > 0.5 * err)
        if local[np.asarray(rows, dtype=int)].any():
            return True
    k0 = 1000
    spectra = [drive_spectra(r.drive.samples[k0:], r.measured[rows, k0:]) for r in recs]
    f = spectra[0].f
    band = (f >= 5) & (f <= 55)
    errors = [relative_errors(r, s_)[rows] for r, s_ in zip(recs, sims, strict=True)]
    same_shape_pair = False
    for a in range(len(recs)):
        for b in range(len(recs)):
            if recs[b].drive_rms_m < 1.2 * recs[a].drive_rms_m:
                continue
            shape = np.log(spectra[b].suu[band] / spectra[a].suu[band])
            if float(np.median(np.abs(shape - np.median(shape)))) > 0.2:
                continue
            same_shape_pair = True
            ratio = errors[b] / np.maximum(errors[a], 1e-12)
            if float(np.median(ratio)) > 1.5:
                return True
    if same_shape_pair:
        return False
    lo = min(range(len(recs)), key=lambda i: recs[i].drive_rms_m)
    hi = max(range(len(recs)), key=lambda i: recs[i].drive_rms_m)
    if recs[hi].drive_rms_m < 1.2 * recs[lo].drive_rms_m:
        return False
    (h0, v0), (h1, v1) = ((spectra[i].h1, spectra[i].h1_variance()) for i in (lo, hi))
    z = np.abs(h1 - h0)[:, band] / np.sqrt(v0[:, band] + v1[:, band] + 1e-300)
    rel = np.abs(h1 - h0)[:, band] / np.maximum(np.abs(h0[:, band]), 1e-300)
    return bool(np.mean((z > 5) & (rel > 0.05)) > 0.05)


def locate(problem: RigProblem, comparison: Comparison) -> Location:
    """Return the located sensors (strongest first), the band and the level dependence of the mismatch.

    Parameters
    ----------
    problem : RigProblem
        The recordings and evaluators.
    comparison : Comparison
        The current model's comparison (:func:`~exudyn_study.diagnose.rig_compare.compare`); it must
        hold significant cells.

    Returns
    -------
    Location
    """
    significant, channels = comparison.significant, problem.channels
    strength = np.max([np.where(m.significant, m.effect, 0.0) for m in comparison.maps], axis=0).max(axis=1)
    located = tuple(channels[i] for i in np.argsort(-strength) if significant[i].any())  # strongest first
    bands = [BANDS_HZ[j] for j in np.flatnonzero(significant.any(axis=0))]
    band_hz = (min(b[0] for b in bands), max(b[1] for b in bands))
    # level dependence of what is left (a linear finding can uncover a nonlinear one)
    dependent = is_level_dependent(
        problem.train_recs + problem.hold_recs,
        comparison.sims_tr + comparison.sims_ho,
        np.flatnonzero(significant.any(axis=1)),
        problem.distortion,
    )
    return Location(
        located=located,
        band_hz=band_hz,
        level_dependent=bool(dependent),
        nonlinear_sensors=tuple(nonlinear_sensors(problem.distortion, channels, located)),
    )
