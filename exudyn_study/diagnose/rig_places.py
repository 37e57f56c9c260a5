"""Search the whole structure: every place of the flexible bodies screened by a low-rank update.

Part of the locate stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig`. A point mass, a spring
or a damper to ground at one point changes the linearised system by a rank-3 term: with ``U = N P^T``
(``P`` the point's displacement map, ``N`` the null space of the constraints; shape (n, 3)) and the
point's drive motion ``a = P r``, the local element of dynamic stiffness ``-mu(omega)``,
``mu = omega^2 m - k - i omega c``, changes ``D(omega) z = F(omega) u`` by ``-mu U U^T`` and its
forcing by ``mu U a``. Sherman-Morrison-Woodbury gives the change of the sensor accelerations
without a new eigen-solve or factorisation::

    w = (I - mu U^T D^-1 U)^-1 (U^T z0 + a)        (the point's total displacement, 3)
    dy = -omega^2 mu (S N^T D^-1 U) w             (S: the sensors' displacement map)

``D^-1 = L diag(1 / (i omega - lambda)) R`` from one complex eigen-decomposition of the state-space
matrix, so a place costs two small products per frequency: thousands of places in seconds.
:func:`screen_places` scores each place and element against the measured transmissibilities
(the coherence-weighted log-magnitude residual of
:class:`~exudyn_study.diagnose.rig_evaluate.SpectralEvaluator`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal as sps

from exudyn_study.diagnose.rig_compare import BAND_HZ, RATE_HZ, band_sos

__all__ = [
    "Places",
    "structure_places",
    "LocalSensitivity",
    "screen_places",
    "PlaceScorer",
    "TimeScorer",
    "ELEMENT_AMOUNTS",
    "scale_amounts",
    "score_places_task",
    "PLACE_SPACING_M",
    "TMD_TUNINGS_HZ",
]

#: candidate places: one mesh node per cube of this edge (m) on every flexible body but the foundation
#: (with the sensors' nodes)
PLACE_SPACING_M = 0.15


@dataclass(frozen=True)
class Places:
    """Candidate places of local elements.

    Attributes
    ----------
    names : tuple of str
        Location names the catalogue's point entries accept (a sensor, or ``'body#node'``).
    positions : numpy.ndarray
        Global positions (m), shape (n_places, 3).
    bodies : tuple of str
        The body of each place.
    maps : tuple of numpy.ndarray
        Each place's displacement map on the model's ODE2 coordinates, shape (3, n_q).
    """

    names: tuple
    positions: np.ndarray
    bodies: tuple
    maps: tuple


def structure_places(
    model, spacing_m: float = PLACE_SPACING_M, skip=("rear_foundation",), markers: dict | None = None
) -> Places:
    """Return every sensor's node, the frame interfaces and a mesh node per ``spacing_m`` cube of each body.

    The model is assembled. Per cube the node nearest the centroid of the body's nodes in it; bodies
    in ``skip`` are left out (the rig's foundation is not the specimen). A sensor's place is named by
    the sensor (one per point: the first sensor there); an interface (a patch where a component is
    attached, such as ``'chassis.front_strut'``) by its location name, with its marker's displacement
    map (the patch's mean motion), when ``markers`` holds it.

    Parameters
    ----------
    model : Model
        The assembled model (its sensors and flexible bodies).
    spacing_m : float, optional
        Edge length (m) of the cubes one mesh node is taken per (default :data:`PLACE_SPACING_M`).
    skip : tuple of str, optional
        Bodies left out (default: the rig's foundation, ``'rear_foundation'``).
    markers : dict, optional
        Location -> (Exudyn marker, global position) of the model's point locations (the diagnosis's
        :class:`~exudyn_study.diagnose.rig_state.ModelState` ``markers``); its locations that are no
        sensor (the interfaces) become places too (None: none).

    Returns
    -------
    Places
        Names (sensor or ``'body#node'``), positions (m), bodies and displacement maps (3, n_q) of the places.
    """
    from exudyn_study.model.linearisation import body_displacement_map

    n_q = int(model.mbs.systemData.ODE2Size())
    names, positions, bodies, maps = [], [], [], []
    for name, att in model.sensors.items():
        handle = model.bodies[att.body]
        pos = np.asarray(handle.body.node_positions_m[att.node], dtype=float) + np.asarray(handle.position_m)
        if any(np.linalg.norm(pos - q) < 1e-6 for q in positions):
            continue
        idx, mat = body_displacement_map(model, att.body, np.array([att.node]))
        full = np.zeros((3, n_q))
        full[:, idx] = mat
        names.append(name)
        positions.append(pos)
        bodies.append(att.body)
        maps.append(full)
    if markers:
        from exudyn_study.linear.nonlinear import marker_displacement_map

        for loc, (marker, pos) in markers.items():
            if loc in model.sensors or loc.split(".", 1)[0] in skip:
                continue
            names.append(loc)
            positions.append(np.asarray(pos, dtype=float))
            bodies.append(loc.split(".", 1)[0])
            maps.append(np.asarray(marker_displacement_map(model, marker), dtype=float))
    for b, handle in model.bodies.items():
        if b in skip:
            continue
        x = np.asarray(handle.body.node_positions_m, dtype=float) + np.asarray(handle.position_m, dtype=float)
        cells = np.floor(x / spacing_m).astype(int)
        _, first, inverse = np.unique(cells, axis=0, return_index=True, return_inverse=True)
        for c in range(first.size):
            members = np.flatnonzero(inverse.ravel() == c)
            centre = x[members].mean(axis=0)
            node = int(members[np.argmin(np.linalg.norm(x[members] - centre, axis=1))])
            idx, mat = body_displacement_map(model, b, np.array([node]))
            full = np.zeros((3, n_q))
            full[:, idx] = mat
            names.append(f"{b}#{node}")
            positions.append(x[node])
            bodies.append(b)
            maps.append(full)
    return Places(tuple(names), np.array(positions).reshape(-1, 3), tuple(bodies), tuple(maps))


class LocalSensitivity:
    """The nominal FRFs and what a local element at a place changes in them (see the module docstring).

    Parameters
    ----------
    lin : LinearSystem
        The current model's linearisation.
    freq_hz : numpy.ndarray
        Frequencies (Hz), shape (n_f,).
    rows : sequence of int
        Sensor indices (rows of ``lin.sensor_map``) of the recorded channels.
    """

    def __init__(self, lin, freq_hz, rows):
        import scipy.linalg as sla

        from exudyn_study.linear.response import frf_linear

        self.f = np.asarray(freq_hz, dtype=float)
        self.omega = 2.0 * math.pi * self.f
        n = lin.mass.shape[0]
        minv = np.linalg.inv(lin.mass)
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ lin.stiffness, -minv @ lin.damping]])
        lam, v = sla.eig(a)
        vinv = np.linalg.inv(v)
        self.left = v[:n, :]  # D^-1 = left diag(1 / (s - lam)) right
        self.right = vinv[:, n:] @ minv
        self.pole = 1.0 / (1j * self.omega[None, :] - lam[:, None])  # (2n, n_f)
        s = 1j * self.omega
        force = -(lin.b0[:, None] + s[None, :] * lin.b1[:, None] + (s**2)[None, :] * lin.b2[:, None])
        self.z0 = self.left @ (self.pole * (self.right @ force))  # (n, n_f)
        self.null = lin.nullspace
        self.drive = lin.drive_shape
        self.sensor_left = lin.sensor_map[list(rows)] @ self.null.T @ self.left  # (n_s, 2n)
        self.h0 = frf_linear(lin, self.f)[list(rows), 0, :]

    @classmethod
    def of_evaluator(cls, lin, ev_spectral) -> LocalSensitivity:
        """Return the sensitivity at a spectral evaluator's frequencies and recorded channels.

        Parameters
        ----------
        lin : LinearSystem
            The current model's linearisation.
        ev_spectral : SpectralEvaluator
            Its frequencies ``f``; the channels of its first recording are the rows.

        Returns
        -------
        LocalSensitivity
        """
        names = list(lin.sensor_names)
        return cls(lin, ev_spectral.f, [names.index(c) for c in ev_spectral.recs[0].channels])

    def at(self, place_map: np.ndarray) -> tuple:
        """Return what a place contributes independently of the element: ``(U^T D^-1 U, S N^T D^-1 U, c)``.

        Parameters
        ----------
        place_map : numpy.ndarray
            The place's displacement map onto the full coordinates, shape (3, n_q).

        Returns
        -------
        tuple of numpy.ndarray
            ``(U^T D^-1 U, S N^T D^-1 U, c)``: shapes (n_f, 3, 3), (n_f, n_s, 3) and (n_f, 3).
        """
        return self.at_reduced(*self.reduced(place_map))

    def reduced(self, place_map: np.ndarray) -> tuple:
        """Return what :meth:`at_reduced` takes of a place: ``(N P^T, P r)``.

        Parameters
        ----------
        place_map : numpy.ndarray
            The place's displacement map onto the full coordinates, shape (3, n_q).

        Returns
        -------
        tuple of numpy.ndarray
            The place's map on the independent coordinates, shape (n, 3), and its displacement per
            unit drive, shape (3,).
        """
        return self.null @ place_map.T, place_map @ self.drive

    def at_reduced(self, u: np.ndarray, drive_motion: np.ndarray) -> tuple:
        """Return what :meth:`at` returns, from the place's map on the independent coordinates.

        Parameters
        ----------
        u : numpy.ndarray
            ``N P^T``: the place's displacement map on the independent coordinates, shape (n, 3).
        drive_motion : numpy.ndarray
            ``P r``: the place's displacement per unit drive, shape (3,).

        Returns
        -------
        tuple of numpy.ndarray
            As :meth:`at`.
        """
        ul, ru = u.T @ self.left, self.right @ u  # (3, 2n), (2n, 3)
        n_f, n_s = self.pole.shape[1], self.sensor_left.shape[0]
        # sums over the modes k as one product each: (pairs, k) @ (k, n_f)
        outer_a = (ul[:, None, :] * ru.T[None, :, :]).reshape(9, -1)
        a_mat = (outer_a @ self.pole).reshape(3, 3, n_f).transpose(2, 0, 1)
        outer_b = (self.sensor_left[:, None, :] * ru.T[None, :, :]).reshape(3 * n_s, -1)
        b_mat = (outer_b @ self.pole).reshape(n_s, 3, n_f).transpose(2, 0, 1)
        c_vec = (u.T @ self.z0).T + np.asarray(drive_motion)[None, :]  # (n_f, 3)
        return a_mat, b_mat, c_vec

    def frf(self, place, mu: np.ndarray) -> np.ndarray:
        """Return the FRFs with a local element of ``mu(omega)`` at a place, shape (n_s, n_f).

        ``place``: the place's displacement map (3, n_q) or what :meth:`at` returned for it; ``mu``
        shape (n_f,), or (n_elements, n_f) for several elements at once (then (n_elements, n_s, n_f)).

        Parameters
        ----------
        place : numpy.ndarray or tuple
            The place's displacement map, shape (3, n_q), or what :meth:`at` returned for it.
        mu : numpy.ndarray
            The element's ``mu(omega)`` (N/m, complex; :func:`element_mu`), shape (n_f,), or
            (n_elements, n_f) for several elements at once.
        """
        a_mat, b_mat, c_vec = self.at(place) if isinstance(place, np.ndarray) else place
        mu = np.asarray(mu)
        batch = mu.ndim == 2
        mu = np.atleast_2d(mu)  # (g, n_f)
        lhs = np.eye(3)[None, None] - mu[:, :, None, None] * a_mat[None]
        w = solve3(lhs, np.broadcast_to(c_vec, lhs.shape[:2] + (3,)))
        # (g, f, s): one batched matrix-vector product per element and frequency (einsum is several
        # times slower here)
        dy = -(self.omega[None, :] ** 2 * mu)[:, :, None] * np.matmul(b_mat[None], w[..., None])[..., 0]
        out = self.h0[None] + np.transpose(dy, (0, 2, 1))
        return out if batch else out[0]


def solve3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve many 3x3 systems ``a x = b`` at once by Cramer's rule (vectorised; no LAPACK call per system).

    Parameters
    ----------
    a : numpy.ndarray
        Matrices, shape (..., 3, 3).
    b : numpy.ndarray
        Right-hand sides, shape (..., 3).

    Returns
    -------
    numpy.ndarray
        Solutions, shape (..., 3) (inf or nan where a matrix is singular).
    """
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = (
        (a[..., i, 0], a[..., i, 1], a[..., i, 2]) for i in range(3)
    )
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    # the cofactors (cross products of the rows): x = adj(a) b / det(a)
    c00, c01, c02 = a11 * a22 - a12 * a21, a12 * a20 - a10 * a22, a10 * a21 - a11 * a20
    c10, c11, c12 = a21 * a02 - a22 * a01, a22 * a00 - a20 * a02, a20 * a01 - a21 * a00
    c20, c21, c22 = a01 * a12 - a02 * a11, a02 * a10 - a00 * a12, a00 * a11 - a01 * a10
    det = a00 * c00 + a01 * c01 + a02 * c02
    x = np.stack(
        (c00 * b0 + c10 * b1 + c20 * b2, c01 * b0 + c11 * b1 + c21 * b2, c02 * b0 + c12 * b1 + c22 * b2),
        axis=-1,
    )
    return x / det[..., None]


def element_mu(
    omega: np.ndarray,
    mass_kg=0.0,
    stiffness_n_per_m=0.0,
    damping_n_s_per_m=0.0,
    frequency_hz=None,
    damping_ratio=0.0,
) -> np.ndarray:
    """Return ``mu(omega)`` of a local element at a point.

    A point mass and a spring-damper to ground: ``mu = omega^2 m - k - i omega c``. With
    ``frequency_hz``, a tuned mass-damper instead (``mass_kg`` on a spring-damper of that tuning and
    ``damping_ratio``; its own coordinates condensed): ``mu = omega^2 m z / (z - omega^2 m)`` with
    ``z = k_t + i omega c_t``, which tends to the point mass's ``omega^2 m`` for a stiff spring.
    """
    if frequency_hz is not None:
        w_t = 2.0 * math.pi * frequency_hz
        z = mass_kg * w_t**2 + 1j * omega * 2.0 * damping_ratio * mass_kg * w_t
        return omega**2 * mass_kg * z / (z - omega**2 * mass_kg)
    return omega**2 * mass_kg - stiffness_n_per_m - 1j * omega * damping_n_s_per_m


#: tunings (Hz) of the tuned mass-dampers screened at every place: log-spaced over the diagnosed band,
#: 12 % apart (a resonator detuned by half a step still takes most of the change it makes in the
#: log-magnitude FRF: the screen only ranks places, the fit finds the tuning)
TMD_TUNINGS_HZ = tuple(float(f) for f in np.round(np.geomspace(5.0, 58.0, 22), 2))

#: elements screened at every place: kind -> list of parameter sets (a coarse grid). A tuned
#: mass-damper's change of the FRFs is a resonance near its tuning, which neither a point mass nor a
#: spring-damper to ground makes: its place is screened with its own grid (mass x tuning).
SCREEN_ELEMENTS = {
    "added_mass": [{"mass_kg": m} for m in (2.0, 5.0, 12.0, 30.0)],
    # dampings a factor of about 3 apart: a dashpot's place ranks by its share, which a grid value far
    # from its damping understates (nearby places with more or less motion then rank above it)
    "local_element": [
        {"stiffness_n_per_m": k, "damping_n_s_per_m": c}
        for k in (0.0, 1e5, 1e6)
        for c in (300.0, 1e3, 3e3, 1e4)
    ],
    "tuned_mass_damper": [
        {"mass_kg": m, "frequency_hz": f, "damping_ratio": 0.08} for f in TMD_TUNINGS_HZ for m in (3.0, 9.0)
    ],
}


#: chunks the places are split into on a Dask cluster (locally: one per worker)
SCHEDULER_CHUNKS = 4


def screen_places(lin, places: Places, ev_spectral, gains=None, elements=None, pool=None) -> list:
    """Score a local element at every place against the measured transmissibilities.

    Parameters
    ----------
    lin : LinearSystem
        The current model.
    places : Places
    ev_spectral : SpectralEvaluator
        Its frequencies, the measured log transmissibilities and weights (one or more recordings).
    gains : numpy.ndarray or OutputChain, optional
        The output gains found so far.
    elements : dict, optional
        Kind -> parameter sets (default :data:`SCREEN_ELEMENTS`).
    pool : EvaluationPool or None, optional
        Workers the places are split over (:meth:`~exudyn_study.diagnose.rig_pool.EvaluationPool.map_shared`;
        None: this process). Each place's score is the same arithmetic either way.

    Returns
    -------
    list of dict
        Per place and kind, the best parameter set: ``place``, ``position_m``, ``kind``, ``values``,
        ``share`` (of the current residual it removes); best first.
    """
    elements = elements or SCREEN_ELEMENTS
    sens = LocalSensitivity.of_evaluator(lin, ev_spectral)
    scorer = PlaceScorer.of_evaluator(sens, ev_spectral, gains, elements)
    # what each place needs: its map on the independent coordinates and its motion per unit drive
    reduced = [sens.reduced(m) for m in places.maps]
    parallel = pool is not None and pool.parallel
    n_chunks = (pool.workers or SCHEDULER_CHUNKS) if parallel else 1
    bounds = np.linspace(0, len(reduced), n_chunks + 1).astype(int)
    chunks = [list(range(a, b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]
    tasks = [[reduced[i] for i in c] for c in chunks]
    if parallel and len(tasks) > 1:
        parts = pool.map_shared(score_places_task, scorer, tasks)
    else:
        parts = [scorer.score(t) for t in tasks]
    out = []
    for chunk, part in zip(chunks, parts, strict=True):
        for i, best in zip(chunk, part, strict=True):
            for kind, k, share in best:
                out.append(
                    {
                        "place": places.names[i],
                        "position_m": [float(v) for v in places.positions[i]],
                        "kind": kind,
                        "values": dict(elements[kind][k]),
                        "share": share,
                    }
                )
    out.sort(key=lambda d: -d["share"])
    return out


class PlaceScorer:
    """Scores local elements at places against measured transmissibilities (what a worker receives).

    Parameters
    ----------
    sens : LocalSensitivity
        The current model's nominal FRFs and their low-rank updates.
    log_h : list of numpy.ndarray
        Per recording, the measured log transmissibilities, shape (n_s, n_f).
    weight : list of numpy.ndarray
        Per recording, their weights, shape (n_s, n_f).
    channels : list of tuple of str
        Per recording, its channels in row order.
    gains : numpy.ndarray or OutputChain or None
        The output gains found so far.
    elements : dict
        Kind -> parameter sets.
    """

    def __init__(self, sens, log_h, weight, channels, gains, elements):
        self.sens = sens
        self.log_h, self.weight, self.channels = log_h, weight, channels
        self.gains = gains
        self.kinds = list(elements)
        self.mus = {k: np.array([element_mu(sens.omega, **v) for v in grid]) for k, grid in elements.items()}
        self.rss0 = float(self.rss(sens.h0[None])[0])

    @classmethod
    def of_evaluator(cls, sens, ev_spectral, gains, elements) -> PlaceScorer:
        """Return the scorer against a spectral evaluator's measured transmissibilities.

        Parameters
        ----------
        sens : LocalSensitivity
            The current model's nominal FRFs at the evaluator's frequencies.
        ev_spectral : SpectralEvaluator
            Its ``log_h``, ``weight`` and recordings (their channels).
        gains : numpy.ndarray or OutputChain or None
            The output gains found so far.
        elements : dict
            Kind -> parameter sets.

        Returns
        -------
        PlaceScorer
        """
        return cls(
            sens,
            [np.asarray(x) for x in ev_spectral.log_h],
            [np.asarray(w) for w in ev_spectral.weight],
            [tuple(r.channels) for r in ev_spectral.recs],
            gains,
            elements,
        )

    def rss(self, h: np.ndarray) -> np.ndarray:
        """Return the weighted log-magnitude residual of FRF sets over the recordings.

        Parameters
        ----------
        h : numpy.ndarray
            FRF sets, shape (g, n_s, n_f).

        Returns
        -------
        numpy.ndarray
            Per set, the mean squared weighted log-magnitude error summed over the recordings, (g,).
        """
        from exudyn_study.diagnose.rig_hypotheses import apply_output_frf

        total = np.zeros(h.shape[0])
        gains, f = self.gains, self.sens.f
        for channels, log_h, w in zip(self.channels, self.log_h, self.weight, strict=True):
            if gains is None or isinstance(gains, np.ndarray):  # a gain per channel: one product
                hm = h if gains is None else h * np.asarray(gains)[None, :, None]
            else:
                hm = np.array([apply_output_frf(x, gains, channels, f) for x in h])
            e = w[None] * (np.log(np.abs(hm) + 1e-300) - log_h[None])
            e[~np.any(hm != 0.0, axis=2)] = 0.0  # a dead channel found: no information (SpectralEvaluator)
            total += np.sum(e**2, axis=(1, 2)) / e[0].size
        return total

    def score(self, reduced: list) -> list:
        """Per place, ``(kind, index of the best parameter set, share)`` for each kind with a finite best.

        Parameters
        ----------
        reduced : list of tuple
            Per place, ``(u, drive_motion)`` as :meth:`LocalSensitivity.at_reduced` takes them.

        Returns
        -------
        list of list of tuple
            Per place, one ``(kind, k, share)`` per kind.
        """
        out = []
        for u, drive_motion in reduced:
            prep = self.sens.at_reduced(u, drive_motion)
            best = []
            for kind in self.kinds:
                with np.errstate(all="ignore"):
                    values = self.rss(self.sens.frf(prep, self.mus[kind]))
                values = np.where(np.isfinite(values), values, np.inf)
                k = int(np.argmin(values))
                if np.isfinite(values[k]):
                    share = max(0.0, 1.0 - float(values[k]) / self.rss0) if self.rss0 > 0 else 0.0
                    best.append((kind, k, share))
            out.append(best)
        return out


#: a local element's amounts (scaled together; a resonator's tuning and damping ratio are not amounts)
ELEMENT_AMOUNTS = ("mass_kg", "stiffness_n_per_m", "damping_n_s_per_m")


def scale_amounts(values: dict, factor: float) -> dict:
    """Return a local element's parameters with its amounts (:data:`ELEMENT_AMOUNTS`) times ``factor``.

    Parameters
    ----------
    values : dict
        The element's parameters (:func:`element_mu`).
    factor : float
        The factor.

    Returns
    -------
    dict
        The parameters, the amounts scaled.
    """
    return {k: v * factor if k in ELEMENT_AMOUNTS else v for k, v in values.items()}


class TimeScorer:
    """Score a local element at places by the residual of the time histories (the convolution evaluator).

    The structure screen and the place refinement score on log transmissibilities, whose estimation
    noise (a per cent of the residual or so) hides the difference between neighbouring nodes once a
    point finding explains nearly everything: a heavy mass a few centimetres off its node then still
    leaves tens of times the noise floor in the time histories. Here the element's FRFs at a place
    (the low-rank update of :class:`LocalSensitivity` up to :data:`BAND_EDGE_HZ`, the nominal FRFs
    above it, where the band filter leaves nothing) are convolved with the recorded drives and compared
    with the recordings exactly as ``ev`` compares a system
    (:meth:`~exudyn_study.diagnose.rig_evaluate.Evaluator.residual_of_frfs`).

    Parameters
    ----------
    lin : LinearSystem
        The current model's linearisation.
    ev : Evaluator
        A convolution evaluator (not ``exact``) of training recordings.
    gains : numpy.ndarray or OutputChain or None
        The output gains found so far.
    """

    #: the element's FRF change is computed up to this frequency (Hz); the 3-60 Hz band filter leaves
    #: nothing above it
    BAND_EDGE_HZ = 75.0

    def __init__(self, lin, ev, gains):
        from exudyn_study.linear.response import frf_linear

        self.ev, self.gains = ev, gains
        self.parts = []
        for f, rows in zip(ev.frequencies(), ev.idx, strict=True):
            band = f <= self.BAND_EDGE_HZ
            self.parts.append((LocalSensitivity(lin, f[band], rows), frf_linear(lin, f)[rows, 0, :], band))
        sims = ev.simulate_frfs([h0 for _, h0, _ in self.parts], gains)
        r0 = ev.residual_of_simulations(sims)
        #: the current model's residual sum of squares on ``ev``
        self.rss0 = float(r0 @ r0)
        # for the amounts' search: per recording, the spectrum of the current model's residual and of the
        # drive in the band, and the channels' weights
        self.spectral = []
        bands = [band for _, _, band in self.parts]
        for (n, n_fft, f, spec), r, sim, band in zip(ev.spectra, ev.recs, sims, bands, strict=True):
            fb = f[band]
            in_band = fb >= 0.5 * BAND_HZ[0]
            res = np.fft.rfft(r.measured - sim, n_fft, axis=1)[:, : f.size][:, band][:, in_band]
            # the zero-phase band-pass acts twice: its magnitude to the fourth on the power
            _, bp = sps.sosfreqz(band_sos(), worN=fb[in_band], fs=RATE_HZ)
            weight = np.asarray(r.scale, dtype=float)[:, None] ** 2 * np.abs(bp)[None, :] ** 4 / (n * n_fft)
            self.spectral.append((in_band, res, spec[band][in_band], weight, tuple(r.channels), fb[in_band]))

    def rss(self, place_map: np.ndarray, elements: list) -> np.ndarray:
        """Return the residual sum of squares with each element of ``elements`` at a place.

        Parameters
        ----------
        place_map : numpy.ndarray
            The place's displacement map onto the full coordinates, shape (3, n_q).
        elements : list of dict
            Parameter sets of :func:`element_mu` (a point mass, a tuned mass-damper or a spring-damper to
            ground).

        Returns
        -------
        numpy.ndarray
            Per element, the residual sum of squares on ``ev`` (inf where it cannot be simulated), shape
            (n_elements,).
        """
        per_recording = []
        for sens, _, _ in self.parts:
            mus = np.array([element_mu(sens.omega, **v) for v in elements])
            with np.errstate(all="ignore"):
                per_recording.append(sens.frf(sens.at(place_map), mus))  # (g, n_s, n_band)
        out = np.full(len(elements), np.inf)
        for g in range(len(elements)):
            frfs = []
            for (_, h0, band), h_band in zip(self.parts, per_recording, strict=True):
                h = h0.copy()
                h[:, band] = h_band[g]
                frfs.append(h)
            if all(np.all(np.isfinite(h)) for h in frfs):
                r = self.ev.residual_of_frfs(frfs, self.gains)
                out[g] = float(r @ r) if np.all(np.isfinite(r)) else np.inf
        return out

    def best(self, place_map: np.ndarray, values: dict, span: float = 1.5) -> tuple:
        """Return the residual with the element at a place at its best amounts, and those values.

        The element's amounts (mass, stiffness, damping; a resonator keeps its tuning and damping ratio)
        are scaled by one factor within ``1 / span`` to ``span``, searched on the residual's spectrum
        weighted by the band filter (the change of the response taken in full, without the cuts at the
        record's ends), and the residual is then evaluated exactly at the factor found. The amounts
        matter sharply: a heavy mass on a thin wall tunes the wall's own modes, and 2 % off its value
        leaves a thousand times the residual of the right one at the right node.

        Parameters
        ----------
        place_map : numpy.ndarray
            The place's displacement map onto the full coordinates, shape (3, n_q).
        values : dict
            The element's parameters (:func:`element_mu`) the factor scales.
        span : float, optional
            The factor's range.

        Returns
        -------
        tuple
            ``(rss, values)``: the residual sum of squares on ``ev`` (inf where it cannot be simulated)
            and the element's parameters at the factor found.
        """
        from scipy.optimize import minimize_scalar

        from exudyn_study.diagnose.rig_hypotheses import apply_output_frf

        preps = [sens.at(place_map) for sens, _, _ in self.parts]

        def scaled(a: float) -> dict:
            return scale_amounts(values, a)

        def cost(log_a: float) -> float:
            total = 0.0
            for (sens, _, _), prep, (in_band, res, spec, weight, channels, f) in zip(
                self.parts, preps, self.spectral, strict=True
            ):
                with np.errstate(all="ignore"):
                    h = sens.frf(prep, element_mu(sens.omega, **scaled(math.exp(log_a))))[:, in_band]
                dh = apply_output_frf(h - sens.h0[:, in_band], self.gains, channels, f)
                total += float(np.sum(weight * np.abs(res - dh * spec[None, :]) ** 2))
            return total if math.isfinite(total) else math.inf

        found = minimize_scalar(cost, bounds=(-math.log(span), math.log(span)), method="bounded",
                                options={"xatol": 1e-3})
        best_values = scaled(math.exp(float(found.x)))
        return float(self.rss(place_map, [best_values])[0]), best_values

    def polish(self, place_map: np.ndarray, values: dict, span: float = 1.06) -> tuple:
        """Return :meth:`best`'s result refined on the exact residual (the factor within a few per cent).

        The spectrum :meth:`best` searches leaves out the cuts at the record's ends, which shifts the
        amount found by a few per cent on short records of lightly damped structures; the exact residual
        is searched around it.

        Parameters
        ----------
        place_map : numpy.ndarray
            The place's displacement map onto the full coordinates, shape (3, n_q).
        values : dict
            The element's parameters (:func:`element_mu`), as :meth:`best` returned them.
        span : float, optional
            The factor's range.

        Returns
        -------
        tuple
            ``(rss, values)`` as :meth:`best`.
        """
        from scipy.optimize import minimize_scalar

        def scaled(a: float) -> dict:
            return scale_amounts(values, a)

        found = minimize_scalar(
            lambda log_a: float(self.rss(place_map, [scaled(math.exp(log_a))])[0]),
            bounds=(-math.log(span), math.log(span)),
            method="bounded",
            options={"xatol": 1e-3},
        )
        return float(found.fun), scaled(math.exp(float(found.x)))


def score_places_task(scorer: PlaceScorer, reduced: list) -> list:
    """:meth:`PlaceScorer.score` in a worker (BLAS on one thread).

    Parameters
    ----------
    scorer : PlaceScorer
        The scorer (sent once per screen).
    reduced : list of tuple
        The chunk's places, as :meth:`PlaceScorer.score` takes them.

    Returns
    -------
    list
        As :meth:`PlaceScorer.score`.
    """
    from exudyn_study.infra.blas import single_threaded_blas

    with single_threaded_blas():
        return scorer.score(reduced)
