"""Automatic selection of physical poles from a stabilisation diagram.

A physical mode shows up at (nearly) the same frequency, damping and shape at every
model order once the order suffices; a computational pole does not. The selection
therefore

1. keeps the candidate poles: stable in frequency and vector against the previous
   order, with a damping ratio in ``(0, max_damping)``;
2. clusters them hierarchically (average linkage) with a scale-free distance,
   ``max(|f_i - f_j| / f / tol_frequency, (1 - MAC_ij) / tol_mac)``, where poles
   of
   the same model order are kept apart (one pole per order and mode); the cut is
   at distance 1, so two modes a little more than ``tol_frequency`` apart are
   resolved (1 % by default: modes 2 % apart are two clusters);
3. accepts the clusters that behave like a physical pole from the order where they
   appear on, wherever that is (a 5 %-damped mode or one of a close pair may only
   stabilise at high order): present at ``min_orders`` orders or more, at a share
   ``min_persistence`` of the orders from their first one to the highest, and in the
   top quarter of the orders (a pole that stands for two close modes at low order
   disappears when the order is high enough to split it, and its two successors take
   over); consistent in frequency and damping (their spread across orders, 1.4826 median
   absolute deviations, below ``tol_frequency`` / 2 and ``max_damping_spread``). Each is
   reported with the median of its members as estimate and their standard deviation as
   uncertainty;
4. rejects *satellites*: an accepted cluster closer than ``satellite_frequency``
   (relative) or than ``satellite_bandwidths`` half-power bandwidths (at most
   ``satellite_lines`` spectral lines) to an accepted cluster present at more orders, with the
   same shape (median MAC over the member pairs above ``satellite_mac``). A lightly
   damped mode resolved by few spectral lines is smoothed by the spectral window into a peak no single
   pole pair fits, and over-modelling then adds a consistent extra pole pair
   beside it with the mode's own shape. Two genuine modes that close would need
   distinct shapes to be told apart from the data at all;
5. rejects clusters within ``edge_lines`` spectral lines of a band edge.

No absolute frequency window and no user frequency enters; the user may still pin
(force) or drop modes near given frequencies (:func:`select_modes`).

References
----------
Reynders, E., Houbrechts, J., De Roeck, G. (2012). Fully automated (operational)
modal analysis. Mechanical Systems and Signal Processing 29, 228-250.

Neu, E., Janser, F., Khatibi, A. A., Orifici, A. C. (2017). Fully automated
operational modal analysis using multi-stage clustering. Mechanical Systems and
Signal Processing 84, 308-323.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.cluster.hierarchy
import scipy.spatial.distance

from exudyn_study.errors import InputError
from exudyn_study.identify.mac import mac
from exudyn_study.identify.polymax import Poles

__all__ = ["Cluster", "Selection", "select_modes"]


@dataclass(frozen=True, eq=False)
class Cluster:
    """A cluster of poles across model orders.

    Attributes
    ----------
    members : ndarray of int
        Indices into the :class:`~exudyn_study.identify.polymax.Poles` arrays.
    frequency_hz, damping_ratio : float
        Medians over the members (Hz, -).
    frequency_std_hz, damping_std : float
        Standard deviations over the members (Hz, -): the spread across orders.
    pole : complex
        Median pole in rad/s (median of real and imaginary parts).
    n_orders : int
        Number of distinct model orders represented (persistence from low orders).
    coverage : float
        Fraction of the upper half of the computed model orders (orders at or
        above the median order) represented in the cluster.
    accepted : bool
        Selected as a physical mode.
    reason : str
        Why it was accepted or rejected ('automatic', 'pinned', 'persistence',
        'consistency', 'satellite', 'edge', 'dropped').
    """

    members: np.ndarray
    frequency_hz: float
    damping_ratio: float
    frequency_std_hz: float
    damping_std: float
    pole: complex
    n_orders: int
    coverage: float
    accepted: bool
    reason: str


@dataclass(frozen=True, eq=False)
class Selection:
    """Result of :func:`select_modes`.

    Attributes
    ----------
    clusters : tuple of Cluster
        All clusters, by ascending frequency (accepted and rejected).
    settings : dict
        The selection parameters used.
    """

    clusters: tuple[Cluster, ...]
    settings: dict

    @property
    def modes(self) -> tuple[Cluster, ...]:
        """The accepted clusters, by ascending frequency."""
        return tuple(c for c in self.clusters if c.accepted)

    @property
    def poles(self) -> np.ndarray:
        """Median poles of the accepted clusters, rad/s, shape (n_modes,)."""
        return np.array([c.pole for c in self.modes], dtype=complex)


def _make_cluster(p: Poles, idx: np.ndarray, upper: np.ndarray, accepted: bool, reason: str):
    fr = p.frequency_hz[idx]
    ze = p.damping_ratio[idx]
    lam = p.pole[idx]
    return Cluster(
        members=np.asarray(idx, dtype=int),
        frequency_hz=float(np.median(fr)),
        damping_ratio=float(np.median(ze)),
        frequency_std_hz=float(np.std(fr, ddof=1)) if idx.size > 1 else 0.0,
        damping_std=float(np.std(ze, ddof=1)) if idx.size > 1 else 0.0,
        pole=complex(np.median(lam.real), np.median(lam.imag)),
        n_orders=int(len(np.unique(p.order[idx]))),
        coverage=_coverage(p, idx, upper),
        accepted=accepted,
        reason=reason,
    )


def _coverage(p: Poles, idx: np.ndarray, upper: np.ndarray) -> float:
    return float(np.isin(upper, p.order[idx]).sum()) / max(1, upper.size)


def select_modes(
    poles: Poles,
    *,
    tol_frequency: float = 0.01,
    tol_mac: float = 0.2,
    min_orders: int = 5,
    min_persistence: float = 0.6,
    max_damping_spread: float = 0.25,
    max_damping: float = 0.2,
    satellite_frequency: float = 0.015,
    satellite_mac: float = 0.9,
    satellite_bandwidths: float = 1.0,
    satellite_lines: float = 5.0,
    edge_lines: float = 2.0,
    pin_hz: Sequence[float] = (),
    drop_hz: Sequence[float] = (),
) -> Selection:
    """Select the physical modes of a stabilisation diagram automatically.

    Parameters
    ----------
    poles : Poles
        Output of :func:`~exudyn_study.identify.polymax.polymax`.
    tol_frequency : float, optional
        Relative frequency distance that separates clusters (default 0.01).
    tol_mac : float, optional
        1 - MAC distance that separates clusters (default 0.2).
    min_orders : int, optional
        Orders a cluster must be present at (default 5).
    min_persistence : float, optional
        Share of the orders from a cluster's first order to the highest at which it must
        be present (default 0.6); it must also be present at this share of the top
        quarter of the orders.
    max_damping_spread : float, optional
        Largest relative standard deviation of the damping across the cluster's orders
        (default 0.25).
    max_damping : float, optional
        Upper bound of plausible damping ratios (default 0.2).
    satellite_frequency, satellite_mac : float, optional
        Satellite rejection: relative frequency distance (default 0.015) and MAC
        (default 0.9) below/above which the cluster present at fewer orders is
        rejected.
    satellite_bandwidths : float, optional
        The satellite distance is at least this many half-power bandwidths
        (``2 zeta f``) of the better-covered cluster (default 1): same-shape poles
        that close to a mode resolved by few lines are one peak smoothed by the
        spectral window, not two modes.
    satellite_lines : float, optional
        The bandwidth term reaches at most this many spectral lines (default 5, the
        lines per half-power bandwidth from which the window no longer smooths a
        peak, :mod:`~exudyn_study.identify.resolution`; no cap without a known
        resolution). Uncapped, a whole bandwidth beside a well-damped mode took a
        genuine mode for a satellite: the thesis rig's left-bracket modes at 32.8 Hz
        (5.5 %, 18 lines per bandwidth at 0.2 Hz) and 36.8 Hz, 11 % apart with the
        same shape at the sensors (MAC > 0.9), as the thesis's modes 6 and 7 ("left
        mudguard bracket x and z", Table 1); half a bandwidth let the satellite of a
        1.2 % mode 2 % away through.
    edge_lines : float, optional
        Clusters closer than this many spectral lines to an edge of the fitted
        band are rejected (default 2; reason 'edge'): a peak cut by the band edge
        cannot be told from the edge effects of the estimate (e.g. H2 where the
        excitation starts) and the residual terms; widen the band to fit it.
    pin_hz : sequence of float, optional
        Frequencies (Hz) of modes to force into the selection: the nearest cluster
        within ``2 * tol_frequency`` is accepted even if its coverage is low.
    drop_hz : sequence of float, optional
        Frequencies (Hz) of accepted modes to remove (nearest within
        ``2 * tol_frequency``).

    Returns
    -------
    Selection

    Raises
    ------
    InputError
        On invalid settings, or a pin/drop frequency with no cluster near it.
    """
    for name, val in (("tol_frequency", tol_frequency), ("tol_mac", tol_mac),
                      ("max_damping", max_damping)):
        if not (np.isfinite(val) and val > 0):
            raise InputError(f"{name}={val!r}: expected a positive number")
    if not 0 < min_persistence <= 1:
        raise InputError(f"min_persistence={min_persistence!r}: expected a fraction in (0, 1]")
    if int(min_orders) < 1:
        raise InputError(f"min_orders={min_orders!r}: expected at least 1")
    orders = np.asarray(poles.orders)
    upper = orders[orders >= np.median(orders)]
    cand = np.flatnonzero(
        poles.stable_frequency & poles.stable_vector
        & (poles.damping_ratio > 0) & (poles.damping_ratio < max_damping)
    )
    clusters: list[Cluster] = []
    if cand.size == 1:
        clusters.append(_make_cluster(poles, cand, upper, False, "persistence"))
    elif cand.size > 1:
        fr = poles.frequency_hz[cand]
        rel = np.abs(fr[:, None] - fr[None, :]) / np.maximum(fr[:, None], fr[None, :])
        vec = poles.vector[cand]
        dmac = 1.0 - mac(vec.T, vec.T)
        dist = np.maximum(rel / tol_frequency, dmac / tol_mac)
        same = poles.order[cand][:, None] == poles.order[cand][None, :]
        dist[same] = np.maximum(dist[same], 100.0)
        np.fill_diagonal(dist, 0.0)
        link = scipy.cluster.hierarchy.linkage(
            scipy.spatial.distance.squareform(dist, checks=False), method="average"
        )
        labels = scipy.cluster.hierarchy.fcluster(link, t=1.0, criterion="distance")
        for lab in np.unique(labels):
            idx = cand[labels == lab]
            # one pole per order: keep the member nearest the cluster median
            keep = []
            med = np.median(poles.frequency_hz[idx])
            for o in np.unique(poles.order[idx]):
                io = idx[poles.order[idx] == o]
                keep.append(io[np.argmin(np.abs(poles.frequency_hz[io] - med))])
            idx = np.array(sorted(keep))
            ok, reason = _persistent(poles, idx, orders, min_orders, min_persistence,
                                     tol_frequency, max_damping_spread)
            if ok and poles.resolution_hz:
                f_med = float(np.median(poles.frequency_hz[idx]))
                lo, hi = poles.band_hz
                if min(f_med - lo, hi - f_med) < edge_lines * poles.resolution_hz:
                    ok, reason = False, "edge"
            clusters.append(_make_cluster(poles, idx, upper, ok, reason))
    clusters.sort(key=lambda c: c.frequency_hz)
    # satellites: same shape, very close to a better-covered accepted cluster. The
    # shape similarity of two clusters is the median MAC over all pairs of their
    # members: one representative pole per cluster would make the test depend on
    # which member happens to lie nearest the median (a rounding-level tie).
    by_cov = sorted(range(len(clusters)), key=lambda i: -clusters[i].n_orders)
    for a_pos, i in enumerate(by_cov):
        if not clusters[i].accepted:
            continue
        for j in by_cov[:a_pos]:
            cj, ci = clusters[j], clusters[i]
            if not cj.accepted:
                continue
            rel = abs(ci.frequency_hz - cj.frequency_hz) / max(ci.frequency_hz, cj.frequency_hz)
            band = satellite_bandwidths * 2 * cj.damping_ratio
            if poles.resolution_hz:
                band = min(band, satellite_lines * poles.resolution_hz / cj.frequency_hz)
            near = max(satellite_frequency, band)
            if rel < near and _cluster_mac(poles, ci, cj) > satellite_mac:
                clusters[i] = _replace(ci, accepted=False, reason="satellite")
                break

    def nearest(f_hz: float, accepted_only: bool) -> int:
        best, dbest = -1, np.inf
        for i, c in enumerate(clusters):
            if accepted_only and not c.accepted:
                continue
            d = abs(c.frequency_hz - f_hz) / f_hz
            if d <= 2 * tol_frequency and d < dbest:
                best, dbest = i, d
        return best

    for f_hz in drop_hz:
        i = nearest(float(f_hz), True)
        if i < 0:
            raise InputError(
                f"drop_hz {f_hz:g} Hz: no selected mode within {2 * tol_frequency:.0%}; "
                f"selected: {', '.join(f'{c.frequency_hz:.2f}' for c in clusters if c.accepted)}"
            )
        clusters[i] = _replace(clusters[i], accepted=False, reason="dropped")
    for f_hz in pin_hz:
        i = nearest(float(f_hz), False)
        if i < 0:
            raise InputError(
                f"pin_hz {f_hz:g} Hz: no stable poles within {2 * tol_frequency:.0%} of it in "
                "the stabilisation diagram; widen the orders or check the band"
            )
        clusters[i] = _replace(clusters[i], accepted=True, reason="pinned")
    settings = {"tol_frequency": tol_frequency, "tol_mac": tol_mac,
                "min_orders": int(min_orders), "min_persistence": min_persistence,
                "max_damping_spread": max_damping_spread, "max_damping": max_damping,
                "satellite_frequency": satellite_frequency, "satellite_mac": satellite_mac,
                "satellite_bandwidths": satellite_bandwidths, "satellite_lines": satellite_lines,
                "edge_lines": edge_lines,
                "pin_hz": [float(x) for x in pin_hz], "drop_hz": [float(x) for x in drop_hz]}
    return Selection(clusters=tuple(clusters), settings=settings)


def _persistent(poles: Poles, idx: np.ndarray, orders: np.ndarray, min_orders: int,
                min_persistence: float, tol_frequency: float, max_damping_spread: float):
    """Whether a cluster behaves like a physical pole from its first order on; and why not."""
    present = np.unique(poles.order[idx])
    if present.size < min_orders:
        return False, "persistence"
    from_first = orders[orders >= present[0]]
    top = orders[orders >= np.quantile(orders, 0.75)]
    if (np.isin(from_first, present).mean() < min_persistence
            or np.isin(top, present).mean() < min_persistence):
        return False, "persistence"
    # robust spread (1.4826 MAD): the first orders of a cluster may still be converging
    fr = poles.frequency_hz[idx]
    ze = poles.damping_ratio[idx]
    if _mad(fr) > 0.5 * tol_frequency * np.median(fr):
        return False, "consistency"
    if _mad(ze) > max_damping_spread * np.median(ze):
        return False, "consistency"
    return True, "automatic"


def _mad(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def _cluster_mac(poles: Poles, a: Cluster, b: Cluster) -> float:
    """Median MAC between the pole vectors of the members of two clusters."""
    va = poles.vector[a.members]
    vb = poles.vector[b.members]
    return float(np.median(mac(va.T, vb.T)))


def _replace(c: Cluster, **kw) -> Cluster:
    import dataclasses

    return dataclasses.replace(c, **kw)
