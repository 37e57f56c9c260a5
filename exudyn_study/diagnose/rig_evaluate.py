"""Evaluators and the least-squares fit shared by the stages of the rig diagnosis.

An evaluator simulates a candidate's system against prepared recordings
(:class:`~exudyn_study.diagnose.rig_compare.RigRecording`) and returns a residual vector:

- :class:`Evaluator`: time histories, by convolution (screening) or exact discretisation (fits,
  errors, significance);
- :class:`SpectralEvaluator`: log-magnitude transmissibilities (a model far off);
- :class:`DistortionEvaluator`: the level-dependent share of one drive at two levels (nonlinear
  candidates).

:func:`fit_hypothesis` fits a :class:`~exudyn_study.diagnose.rig_hypotheses.Hypothesis` on any of
them (bounded least squares in log parameters). Package-internal API of :mod:`exudyn_study.diagnose`.
"""

from __future__ import annotations

import math

import numpy as np

from exudyn_study.diagnose.rig_compare import (
    RATE_HZ,
    band_filter,
    drive_spectra,
    relative_errors,
    summary_error,
)
from exudyn_study.diagnose.rig_hypotheses import (
    Hypothesis,
    NonlinearSystem,
    OutputChain,
    apply_output,
    apply_output_frf,
    log_bounds,
    to_params,
    to_x,
)


class Evaluator:
    """Simulate a system against prepared recordings; residual vector and errors.

    ``exact=True``: :func:`~exudyn_study.simulate.simulate_linear` (fits, errors, significance).
    Otherwise (screening) the response from rest is the linear convolution of the drive
    with the model's impulse response, computed as ``irfft(H(f) U(f))`` with the drive zero-padded by
    ``pad_s`` (longer than the slowest mode's decay) after a 1 s fade from its last value
    to zero (by causality the extension does not change the response within the record;
    it only keeps the padded drive band-limited). The recorded drive is band-limited to
    102.4 Hz (204.8 Hz channel), so
    ``H`` is evaluated only up to :data:`F_MAX_HZ`: about 10x cheaper than the exact
    discretisation (:func:`~exudyn_study.simulate.simulate_linear`), which it matches to
    the drive's band limit, except where slow or undamped rig modes (< 3 Hz) wrap around:
    good enough to rank candidates, not to fit them.

    Parameters
    ----------
    recordings : list of RigRecording
        Prepared recordings to simulate against.
    sensor_names : sequence of str
        The model's sensor names, in the order of its outputs.
    pad_s : float, optional
        Zero padding (s) of the drive for the convolution, longer than the slowest mode's decay
        (default 30 s; see :func:`decay_time`).
    exact : bool, optional
        Whether every simulation is the exact discretisation instead of the convolution (default False).
    """

    F_MAX_HZ = 110.0

    def __init__(self, recordings, sensor_names, pad_s: float = 30.0, exact: bool = False):
        from exudyn_study.diagnose.rig_compare import RATE_HZ

        self.exact = exact
        self.pad_s = pad_s
        self.recs = recordings
        self.sensor_names = tuple(sensor_names)
        self.idx = [np.array([self.sensor_names.index(c) for c in r.channels]) for r in recordings]
        self._cache = {}
        self._filtered = {}  # recording index -> (simulation, its filtered residual): residual_vector
        self.offset = None  # per recording: added to linear simulations (see set_offsets)
        self.version = 0  # counts the changes of ``offset`` (a worker pool resends the evaluator then)
        self.spectra = []
        for r in recordings:
            n = r.drive.samples.size
            m = int(1.0 * RATE_HZ)
            fade = r.drive.samples[-1] * (0.5 + 0.5 * np.cos(np.pi * np.arange(1, m + 1) / m))
            u = np.concatenate([r.drive.samples, fade])
            n_fft = 1 << int(math.ceil(math.log2(n + pad_s * RATE_HZ)))
            spec = np.fft.rfft(u, n_fft)
            f = np.fft.rfftfreq(n_fft, 1.0 / RATE_HZ)
            keep = f <= self.F_MAX_HZ
            self.spectra.append((n, n_fft, f[keep], spec[keep]))

    def __getstate__(self):
        """Return the evaluator's state without its caches (what a worker process needs)."""
        state = dict(self.__dict__)
        state.update(_cache={}, _filtered={})
        state.pop("_offsets", None)
        return state

    def simulate(self, lin, gains=None):
        """Simulate ``lin`` (output ``gains``) at each recording; list of (n_channels, n_samples) arrays.

        Parameters
        ----------
        lin : LinearSystem or NonlinearSystem
            The system (a nonlinear one is simulated exactly).
        gains : numpy.ndarray or OutputChain or None, optional
            Output gain per channel or a chain of acquisition stages (None: all one).

        Returns
        -------
        list of numpy.ndarray
            Per recording, the simulated channels, shape (n_channels, n_samples).
        """
        from exudyn_study.linear.response import frf_linear

        if self.exact or isinstance(lin, NonlinearSystem):
            return self.simulate_exact(lin, gains)
        key = id(lin)
        if key in self._cache and self._cache[key][0] is lin:
            base = self._cache[key][1]
        else:
            freqs = self.frequencies()
            frfs = [frf_linear(lin, f)[idx, 0, :] for f, idx in zip(freqs, self.idx, strict=True)]
            base = self._convolve(frfs)
            self._cache = {key: (lin, base)}
        return self._through_outputs(base, gains)

    def _convolve(self, frfs: list) -> list:
        """Return the response from rest (offsets added) of the recorded channels with FRFs ``frfs``.

        ``frfs``: per recording, the drive-to-channel FRFs at its frequencies up to :data:`F_MAX_HZ`,
        shape (n_channels, n_f).
        """
        base = []
        for (n, n_fft, f, spec), h in zip(self.spectra, frfs, strict=True):
            full = np.zeros((h.shape[0], n_fft // 2 + 1), dtype=complex)
            full[:, : f.size] = h * spec[None, :]
            base.append(np.fft.irfft(full, n_fft, axis=1)[:, :n])
        if self.offset is not None:
            base = [b + o for b, o in zip(base, self.offset, strict=True)]
        return base

    def frequencies(self) -> list:
        """Return per recording the frequencies (Hz) at which the convolution takes the FRFs.

        Returns
        -------
        list of numpy.ndarray
            Per recording, shape (n_f,): the padded record's FFT frequencies up to :data:`F_MAX_HZ`.
        """
        return [f for _, _, f, _ in self.spectra]

    def simulate_frfs(self, frfs: list, gains=None) -> list:
        """Return :meth:`simulate` of a linear system given by its FRFs (the convolution).

        Parameters
        ----------
        frfs : list of numpy.ndarray
            Per recording, the FRFs from the drive to its channels at :meth:`frequencies`, shape
            (n_channels, n_f).
        gains : numpy.ndarray or OutputChain or None, optional
            Output gain per channel or a chain of acquisition stages (None: all one).

        Returns
        -------
        list of numpy.ndarray
            As :meth:`simulate`.
        """
        return self._through_outputs(self._convolve(frfs), gains)

    def residual_of_frfs(self, frfs: list, gains=None) -> np.ndarray:
        """Return :meth:`residual_vector` of a linear system given by its FRFs (the convolution).

        Parameters
        ----------
        frfs : list of numpy.ndarray
            Per recording, the FRFs from the drive to its channels at :meth:`frequencies`, shape
            (n_channels, n_f).
        gains : numpy.ndarray or OutputChain or None, optional
            Output gain per channel or a chain of acquisition stages (None: all one).

        Returns
        -------
        numpy.ndarray
            As :meth:`residual_vector`.
        """
        return self.residual_of_simulations(self.simulate_frfs(frfs, gains))

    def _through_outputs(self, base: list, gains) -> list:
        """Return the channels ``base`` (per recording) through the output ``gains`` (None: unchanged)."""
        if gains is None:
            return base
        return [apply_output(b, gains, r.channels, RATE_HZ) for b, r in zip(base, self.recs, strict=True)]

    def simulate_exact(self, lin, gains=None):
        """Simulate by exact discretisation (:func:`~exudyn_study.simulate.simulate_linear`).

        Parameters
        ----------
        lin : LinearSystem or NonlinearSystem
            The system (a nonlinear one by time integration of its local elements).
        gains : numpy.ndarray or OutputChain or None, optional
            Output gain per channel or a chain of acquisition stages (None: all one).

        Returns
        -------
        list of numpy.ndarray
            Per recording, the simulated channels, shape (n_channels, n_samples).
        """
        from exudyn_study.linear.response import simulate_linear

        key = ("exact", id(lin))
        if key in self._cache and self._cache[key][0] is lin:
            base = self._cache[key][1]
        elif isinstance(lin, NonlinearSystem):
            from exudyn_study.linear.nonlinear import simulate_local_nonlinear

            base = [
                simulate_local_nonlinear(lin.lin, r.drive, lin.gather, lin.laws, lin.substeps)[idx]
                for r, idx in zip(self.recs, self.idx, strict=True)
            ]
            self._cache = {key: (lin, base)}
        else:
            base = [simulate_linear(lin, r.drive)[idx] for r, idx in zip(self.recs, self.idx, strict=True)]
            if self.offset is not None:
                base = [b + o for b, o in zip(base, self.offset, strict=True)]
            self._cache = {key: (lin, base)}
        return self._through_outputs(base, gains)

    def residual_vector(self, lin, gains=None):
        """Band-limited, per-channel scaled residual of all recordings, flattened.

        Parameters
        ----------
        lin : LinearSystem or NonlinearSystem
            The system.
        gains : numpy.ndarray or OutputChain or None, optional
            Output gain per channel or a chain of acquisition stages (None: all one).

        Returns
        -------
        numpy.ndarray
            The residuals of all recordings, each scaled by 1 / sqrt(its size), concatenated, shape (n_rows,).
        """
        return self.residual_of_simulations(self.simulate(lin, gains))

    def residual_of_simulations(self, sims: list) -> np.ndarray:
        """Return :meth:`residual_vector` of simulations of the recorded channels.

        Parameters
        ----------
        sims : list of numpy.ndarray
            Per recording, the simulated channels, shape (n_channels, n_samples), as :meth:`simulate`
            gives them.

        Returns
        -------
        numpy.ndarray
            As :meth:`residual_vector`.
        """
        parts = []
        for k, (r, sim) in enumerate(zip(self.recs, sims, strict=True)):
            e = self._filtered_residual(k, r, sim)
            dead = ~np.any(sim != 0.0, axis=1)
            if dead.any():  # a channel the acquisition chain records as nothing (a dead sensor found): its
                e = e.copy()  # noise says nothing of the structure and would stay in every later residual
                e[dead] = 0.0
            parts.append(e.ravel() / math.sqrt(e.size))
        return np.concatenate(parts)

    def _filtered_residual(self, k: int, r, sim: np.ndarray) -> np.ndarray:
        """Band-limited, per-channel scaled residual of recording ``k`` (rows filtered only where needed).

        The band filter acts on each channel alone, so a channel whose simulation equals (bit for bit)
        that of the last fully filtered simulation keeps its filtered residual: a sensor-fault
        candidate changes one or two channels of the current model's simulation, and only those are
        filtered for it. Not-a-number rows never compare equal and are filtered.
        """
        ref = self._filtered.get(k)
        if ref is not None and ref[0].shape == sim.shape:
            same = np.all(sim == ref[0], axis=1)
            if same.all():
                return ref[1]
            if same.any():
                rows = ~same
                e = ref[1].copy()
                e[rows] = band_filter(r.measured[rows] - sim[rows]) * r.scale[rows, None]
                return e
        e = band_filter(r.measured - sim) * r.scale[:, None]
        self._filtered[k] = (sim, e)
        return e

    def errors(self, sims):
        """Per recording, the relative error per channel of the simulations ``sims``.

        Parameters
        ----------
        sims : list of numpy.ndarray
            Per recording, the simulated channels, shape (n_channels, n_samples), as :meth:`simulate` gives.

        Returns
        -------
        list of numpy.ndarray
            Per recording, the relative band-limited rms error per channel, shape (n_channels,).
        """
        return [relative_errors(r, s) for r, s in zip(self.recs, sims, strict=True)]


class SpectralEvaluator:
    """Residual of log-magnitude transmissibilities: model FRF against the recordings' H1 estimates.

    When the model is far off (resonances misplaced: a time-domain error above 100 %), a
    least-squares fit of time histories prefers a model that switches the response off over
    one that puts part of the resonances right. The log-magnitude distance of the
    transmissibilities does not: each channel and frequency bin (3-60 Hz, Welch H1, weighted
    by the coherence ``g2 / (1 - g2)`` capped at 0.99) counts by its ratio. Linear systems
    only (a nonlinear system is judged by its tangent); ``residual_vector`` has the
    :class:`Evaluator` interface, so screening and fitting work unchanged. A system whose mass
    matrix is not positive definite raises :class:`~exudyn_study.errors.SimulationError` (its FRF
    exists, its time response diverges: a fit must not go there).

    Parameters
    ----------
    recordings : list of RigRecording
        Prepared recordings whose H1 transmissibilities are the targets.
    sensor_names : sequence of str
        The model's sensor names, in the order of its outputs.
    nperseg : int, optional
        Welch segment length in samples at 1000 Hz (default 4096).
    """

    def __init__(self, recordings, sensor_names, nperseg: int = 4096):
        self.recs = recordings
        self.sensor_names = tuple(sensor_names)
        self.idx = [np.array([self.sensor_names.index(c) for c in r.channels]) for r in recordings]
        self.log_h, self.weight = [], []
        k0 = 1000
        for r in recordings:
            sp = drive_spectra(r.drive.samples[k0:], r.measured[:, k0:], nperseg)
            band = (sp.f >= 3.0) & (sp.f <= 60.0)
            self.f = sp.f[band]
            g2 = np.minimum(sp.coherence[:, band], 0.99)
            self.log_h.append(np.log(np.abs(sp.h1[:, band]) + 1e-300))
            self.weight.append(np.sqrt(g2 / (1.0 - g2) / np.mean(g2 / (1.0 - g2))))
        self.n_effective = int(sum(w.size for w in self.weight))

    def residual_vector(self, lin, gains=None):
        """Coherence-weighted log-magnitude residual of the transmissibilities, flattened.

        Parameters
        ----------
        lin : LinearSystem or NonlinearSystem
            The system (a nonlinear one by its linear tangent).
        gains : numpy.ndarray or OutputChain or None, optional
            Output gain per channel or a chain of acquisition stages (None: all one).

        Returns
        -------
        numpy.ndarray
            The weighted log-magnitude residuals of all recordings, concatenated, shape (n_rows,).

        Raises
        ------
        SimulationError
            If the system's mass matrix is not positive definite.
        """
        from exudyn_study.errors import SimulationError
        from exudyn_study.linear.response import frf_linear

        lin = getattr(lin, "lin", lin)
        try:  # an FRF exists for any mass matrix; a structure's is positive definite
            np.linalg.cholesky(0.5 * (lin.mass + lin.mass.T))
        except np.linalg.LinAlgError:
            raise SimulationError(
                "the model's mass matrix is not positive definite (a negative-mass compensation, e.g. a "
                "slosh mass, takes off more than its body has there): it has no physical response"
            ) from None
        h = frf_linear(lin, self.f)[:, 0, :]
        parts = []
        for r, idx, log_h, w in zip(self.recs, self.idx, self.log_h, self.weight, strict=True):
            hm = apply_output_frf(h[idx], gains, r.channels, self.f)
            e = w * (np.log(np.abs(hm) + 1e-300) - log_h)
            # a channel the acquisition chain records as nothing (a dead sensor found): its recording says
            # nothing of the structure, and its log distance to the noise (~700) would drown every other
            e[~np.any(hm != 0.0, axis=1)] = 0.0
            parts.append(e.ravel() / math.sqrt(e.size))
        return np.concatenate(parts)


class DistortionEvaluator:
    """Residual of the level-dependent share of the response: measured against simulated.

    For one drive at two levels (:func:`level_pair`: weaker ``a``, stronger ``b``, scale
    ``c``) the difference ``y_b - c y_a`` of the measured responses holds only what a linear
    structure cannot produce (:func:`distortion_shares`); the same difference of a model's
    simulations holds only its nonlinear part. Their residual (band-limited, scaled per
    channel as the training residual) fits a nonlinear candidate's parameters whatever linear
    error the model still has: the linear parts cancel in both. ``residual_vector`` has the
    :class:`Evaluator` interface (a linear system leaves the whole measured difference).

    Parameters
    ----------
    pair : tuple
        ``(c, a, b, n)`` of :func:`~exudyn_study.diagnose.rig_locate.level_pair`: the level ratio, the
        weaker and the stronger recording (RigRecording) and the number of samples compared.
    sensor_names : sequence of str
        The model's sensor names, in the order of its outputs.
    pad_s : float
        Zero padding (s) passed to the inner exact :class:`Evaluator`.
    """

    def __init__(self, pair, sensor_names, pad_s: float):
        from exudyn_study.diagnose.rig_compare import BAND_HZ, RATE_HZ

        c, a, b, n = pair
        self.c = c
        self.ev = Evaluator([a, b], sensor_names, pad_s, exact=True)
        self.recs = [a, b]
        self.rows_a = np.array([a.channels.index(ch) for ch in b.channels])
        self.scale = b.scale
        self.target = band_filter(b.measured[:, :n] - c * a.measured[self.rows_a, :n]) * self.scale[:, None]
        self.n = n
        self.n_effective = int(2 * (BAND_HZ[1] - BAND_HZ[0]) * self.target.shape[1] * 4 / RATE_HZ) * len(
            b.channels
        )

    def residual_vector(self, system, gains=None):
        """Residual of the measured against the simulated level-dependent share, flattened.

        Parameters
        ----------
        system : LinearSystem or NonlinearSystem
            The system, simulated exactly at both levels.
        gains : numpy.ndarray or OutputChain or None, optional
            Output gain per channel or a chain of acquisition stages (None: all one).

        Returns
        -------
        numpy.ndarray
            The scaled residual, flattened, shape (n_channels * n_kept,).
        """
        sim_a, sim_b = self.ev.simulate_exact(system, gains)
        model = band_filter(sim_b[:, : self.n] - self.c * sim_a[self.rows_a, : self.n]) * self.scale[:, None]
        e = self.target - model
        return e.ravel() / math.sqrt(e.size)


def fit_hypothesis(
    h: Hypothesis, ev: Evaluator, channels, max_nfev=30, jac=None, info: dict | None = None, pool=None
):
    """Fit ``h`` on ``ev`` from ``h.start``: (p, std, rss, at_bound, nfev).

    ``jac``: a Jacobian callable in the fitting variable (default finite differences: one
    evaluation per parameter and iteration); ``info`` gets the final Jacobian (``'jac'``).
    ``pool``: the finite differences' evaluations run on its workers (the same points and
    arithmetic: the result is the serial fit's).

    Parameters
    ----------
    h : Hypothesis
        The candidate; the fit starts at ``h.start``.
    ev : Evaluator or SpectralEvaluator or DistortionEvaluator
        Gives the residual vector of a system.
    channels : sequence of str
        The simulated channels, in row order (for the candidate's output gains).
    max_nfev : int, optional
        Maximum number of residual evaluations of the least-squares solver (default 30).
    jac : callable or None, optional
        Jacobian ``jac(x)`` in the fitting variable (None: two-point finite differences).
    info : dict or None, optional
        If given, receives the final Jacobian under ``'jac'``.
    pool : EvaluationPool or None, optional
        Workers for the finite-difference evaluations (:mod:`~exudyn_study.diagnose.rig_pool`;
        None: this process).

    Returns
    -------
    tuple
        ``(p, std, rss, at_bound, nfev)``: fitted parameters, their standard deviations (shape
        (n_params,) each), residual sum of squares, whether each parameter ended at a bound, and the
        number of evaluations. At an unstable start: the start, infinite deviations, ``rss = inf``,
        all at bound.
    """
    from scipy.optimize import least_squares

    pos, lo, hi = log_bounds(h)
    x0 = np.clip(to_x(h, h.start), lo + 1e-9, hi - 1e-9)
    r_start = safe_residual(h, ev, channels, to_params(h, x0))
    if r_start is None:  # the candidate's system is unstable or singular at its start
        return to_params(h, x0), np.full(x0.size, np.inf), math.inf, np.ones(x0.size, bool), 1
    if x0.size == 0:  # nothing to fit (a swap of two channels): its residual as it stands
        if info is not None:
            info["jac"] = np.zeros((r_start.size, 0))
        return np.zeros(0), np.zeros(0), float(r_start @ r_start), np.zeros(0, bool), 1
    penalty = np.full(r_start.size, 10.0 / math.sqrt(r_start.size))

    def fun(x):
        r = safe_residual(h, ev, channels, to_params(h, x))
        return penalty if r is None else r  # an unstable parameter set: far worse than any response

    workers = None
    if pool is not None and jac is None:
        workers = pool.mapper(h, ev, channels, (penalty.size, float(penalty[0])))
    res = least_squares(
        fun,
        x0,
        jac="2-point" if jac is None else jac,
        bounds=(lo, hi),
        diff_step=1e-3,
        max_nfev=max_nfev,
        x_scale=1.0,
        workers=workers,
    )
    if info is not None:
        info["jac"] = res.jac
    p = to_params(h, res.x)
    n_eff = effective_samples(ev)
    rss = float(2 * res.cost)
    dof = max(1, n_eff - p.size)
    try:
        cov_x = np.linalg.inv(res.jac.T @ res.jac) * rss / dof
        std_x = np.sqrt(np.maximum(np.diag(cov_x), 0.0))
    except np.linalg.LinAlgError:
        std_x = np.full(p.size, np.inf)
    std_p = np.where(pos, p * std_x, std_x)
    at_bound = (res.x <= lo + 1e-3) | (res.x >= hi - 1e-3)
    return p, std_p, rss, at_bound, res.nfev


def safe_residual(h: Hypothesis, ev: Evaluator, channels, p):
    """Return the candidate's residual vector at ``p`` (None where its system is unstable or singular).

    Parameters
    ----------
    h : Hypothesis
        The candidate.
    ev : Evaluator or SpectralEvaluator or DistortionEvaluator
        Gives the residual vector of a system.
    channels : sequence of str
        The simulated channels, in row order.
    p : array_like
        Parameter values, shape (n_params,).

    Returns
    -------
    numpy.ndarray or None
        The residual vector, or None if the simulation fails or is not finite.
    """
    from exudyn_study.errors import SimulationError, StudyError

    try:
        with np.errstate(all="ignore"):
            system = h.system(p)
    except (SimulationError, StudyError, np.linalg.LinAlgError, ValueError):
        return None
    return system_residual(ev, system, combined_gains(h, p, channels))


def system_residual(ev, system, gains):
    """Return ``ev``'s residual vector of ``system`` with output ``gains`` (None if it cannot be simulated).

    Given the system object (not a candidate's parameters), a simulation of it that follows
    (``ev.simulate(system, gains)``) is taken from the evaluator's cache instead of being made again.

    Parameters
    ----------
    ev : Evaluator or SpectralEvaluator or DistortionEvaluator
        Gives the residual vector of a system.
    system : LinearSystem or NonlinearSystem
        The system.
    gains : numpy.ndarray or OutputChain or None
        Output gain per channel or a chain of acquisition stages (None: all one).

    Returns
    -------
    numpy.ndarray or None
        The residual vector, or None if the simulation fails or is not finite.
    """
    from exudyn_study.errors import SimulationError, StudyError

    try:
        with np.errstate(all="ignore"):
            r = ev.residual_vector(system, gains)
    except (SimulationError, StudyError, np.linalg.LinAlgError, ValueError):
        return None
    return r if np.all(np.isfinite(r)) else None


def per_recording(ev) -> list:
    """One evaluator per recording of ``ev`` (same residual rows as ``ev``'s part of that recording).

    Returns an empty list for an evaluator that is not per recording (the level-dependent share).

    Parameters
    ----------
    ev : Evaluator or SpectralEvaluator or DistortionEvaluator
        The pooled evaluator.
    """
    if isinstance(ev, SpectralEvaluator):
        return [SpectralEvaluator([r], ev.sensor_names) for r in ev.recs]
    if not isinstance(ev, Evaluator):
        return []
    out = []
    for i, r in enumerate(ev.recs):
        sub = Evaluator([r], ev.sensor_names, ev.pad_s, exact=ev.exact)
        sub.offset = None if ev.offset is None else [ev.offset[i]]
        out.append(sub)
    return out


def decay_time(lin, factor: float = 5.0, floor_s: float = 4.0) -> float:
    """Zero padding for the convolution: ``factor`` times the slowest decay time of the modes below 200 Hz.

    Parameters
    ----------
    lin : LinearSystem
        The system whose modes (0.5-200 Hz) are examined.
    factor : float, optional
        Multiple of the slowest decay time ``-1 / Re(lambda)`` (default 5).
    floor_s : float, optional
        Least padding (s), also the result without modes in that range (default 4 s).

    Returns
    -------
    float
        Padding (s), at most 60 s.
    """
    from exudyn_study.linear.system import state_space

    a = state_space(lin)[0]
    lam = np.linalg.eigvals(a)
    lam = lam[(np.abs(lam) > 2 * math.pi * 0.5) & (np.abs(lam) < 2 * math.pi * 200)]
    if lam.size == 0:
        return floor_s
    slowest = float(np.max(-1.0 / np.minimum(lam.real, -1e-9)))
    return float(min(60.0, max(floor_s, factor * slowest)))


def effective_samples(ev: Evaluator) -> int:
    """Independent residual samples: 2 x bandwidth x duration per channel.

    Parameters
    ----------
    ev : Evaluator or SpectralEvaluator or DistortionEvaluator
        The evaluator (its ``n_effective`` if it has one).

    Returns
    -------
    int
        Number of independent residual samples.
    """
    from exudyn_study.diagnose.rig_compare import BAND_HZ, RATE_HZ

    if hasattr(ev, "n_effective"):
        return ev.n_effective
    n = 0
    for r in ev.recs:
        dur = r.filtered.shape[1] * 4 / RATE_HZ
        n += int(2 * (BAND_HZ[1] - BAND_HZ[0]) * dur) * len(r.channels)
    return n


def aic(rss: float, k: int, n_eff: int) -> float:
    """Akaike information criterion of a residual sum of squares ``rss`` with ``k`` parameters.

    Parameters
    ----------
    rss : float
        Residual sum of squares.
    k : int
        Number of fitted parameters.
    n_eff : int
        Number of independent samples (:func:`effective_samples`).

    Returns
    -------
    float
        ``n_eff ln(rss / n_eff) + 2 k`` (lower is better).
    """
    return n_eff * math.log(max(rss, 1e-300) / n_eff) + 2 * k


def catalogue_default(physics: str, name: str) -> float:
    """Return the catalogue default of parameter ``name`` of entry ``physics``.

    Parameters
    ----------
    physics : str
        Name of the catalogue entry.
    name : str
        Name of the entry's parameter.

    Returns
    -------
    float
        The parameter's default value, in its unit.
    """
    from exudyn_study.physics.catalogue import entry

    return float(entry(physics).parameter(name).default)


def holdout_error(ev_hold: Evaluator, system, gains) -> float:
    """Mean over the held-out recordings of the summary error of ``system`` (``ev_hold``'s simulation).

    The joint fit judges its members with the convolution (``exact=False``): a member taken
    out at its neutral values (a joint as stiff as the catalogue allows) has modes far above
    the band that the exact discretisation cannot always resolve (non-finite), the FRF can.

    Parameters
    ----------
    ev_hold : Evaluator
        Evaluator of the held-out recordings.
    system : LinearSystem or NonlinearSystem
        The model.
    gains : numpy.ndarray or OutputChain or None
        Output gain per channel or a chain of acquisition stages (None: all one).

    Returns
    -------
    float
        Mean summary error (relative rms, 1 = 100 %).
    """
    return float(np.mean(holdout_errors(ev_hold, system, gains)))


def holdout_errors(ev_hold: Evaluator, system, gains) -> np.ndarray:
    """Per held-out recording, the summary error of ``system`` (see :func:`holdout_error`).

    Parameters
    ----------
    ev_hold : Evaluator
        Evaluator of the held-out recordings.
    system : LinearSystem or NonlinearSystem
        The model.
    gains : numpy.ndarray or OutputChain or None
        Output gain per channel or a chain of acquisition stages (None: all one).

    Returns
    -------
    numpy.ndarray
        Summary error per held-out recording, shape (n_recordings,).
    """
    return np.array([summary_error(e) for e in ev_hold.errors(ev_hold.simulate(system, gains))])


def response_ratio(recs, sims) -> float:
    """Median over channels of the band-limited rms of the simulation over that of the measurement.

    Parameters
    ----------
    recs : list of RigRecording
        The recordings (their ``scale``: 1 / band-limited rms of the measurement per channel).
    sims : list of numpy.ndarray
        Per recording, the simulated channels, shape (n_channels, n_samples).

    Returns
    -------
    float
        The median ratio (1: the simulation is as strong as the measurement).
    """
    ratios = [
        np.sqrt(np.mean(band_filter(s_) ** 2, axis=1)) * r.scale for r, s_ in zip(recs, sims, strict=True)
    ]
    return float(np.median(np.concatenate(ratios)))


def set_offsets(evaluators, system) -> None:
    """Carry the current model's nonlinear elements into linear candidates (first order).

    With local nonlinear elements in the current model, a linear candidate's response is
    taken as its linear response plus the current model's nonlinear correction (exact
    nonlinear minus linear-tangent simulation, per recording): the correction's change with
    a linear candidate is of second order. Exact simulations of the accepted model follow.

    The nonlinear simulation (a time integration, the costliest step of a diagnosis with nonlinear
    findings) is made once per set of recordings (evaluators of the same recordings share it), and
    an evaluator set back to one of the last :data:`OFFSET_MEMO` systems it had (a rejected round, a
    joint refit not adopted) takes its offsets from then.

    Parameters
    ----------
    evaluators : iterable of Evaluator
        Evaluators whose ``offset`` and cache are set.
    system : LinearSystem or NonlinearSystem
        The current model (a linear one clears the offsets).
    """
    shared = {}  # the recordings' identities -> the nonlinear simulations of ``system``
    for ev in evaluators:
        memo = [m for m in getattr(ev, "_offsets", []) if m[0] is not system]
        hit = [m for m in getattr(ev, "_offsets", []) if m[0] is system]
        ev._filtered = {}
        if hit:
            ev.offset, ev._cache = hit[0][1], dict(hit[0][2])
        else:
            ev.offset = None
            ev._cache = {}
            if isinstance(system, NonlinearSystem):
                key = tuple(id(r) for r in ev.recs)
                if key not in shared:
                    shared[key] = ev.simulate_exact(system)
                nonlinear = shared[key]
                tangent = ev.simulate(system.lin)
                ev.offset = [a - b for a, b in zip(nonlinear, tangent, strict=True)]
                ev._cache = {("exact", id(system)): (system, nonlinear)}  # compare() needs them next
        ev._offsets = [(system, ev.offset, dict(ev._cache))] + memo[: OFFSET_MEMO - 1]
        ev.version = getattr(ev, "version", 0) + 1


#: systems whose offsets an evaluator keeps (:func:`set_offsets`)
OFFSET_MEMO = 2


def combined_gains(h: Hypothesis, p, channels):
    """Return the candidate's output gains times those already found (None: all one).

    Parameters
    ----------
    h : Hypothesis
        The candidate (its ``base_gains``, if any, are the gains already found).
    p : array_like
        Parameter values, shape (n_params,).
    channels : sequence of str
        The simulated channels, in row order.

    Returns
    -------
    numpy.ndarray or OutputChain or None
        Gain per channel, a chain of acquisition stages (earlier ones first), or None.
    """
    base = getattr(h, "base_gains", None)
    g = h.gains(p, channels)
    if g is None:
        return base
    if base is None:
        return g
    if isinstance(g, np.ndarray) and isinstance(base, np.ndarray):
        return g * base
    return OutputChain.of(base).then(g)  # the faults found before, then this one


#: a parameter's drift matters when a recording's residual grows by more than this share with the
#: parameter at another recording's estimate
DRIFT_MATERIAL = 0.01


def _drift_matters(h: Hypothesis, subs, channels, est, fitted_rss, j: int) -> bool:
    """Whether recording ``k``'s fit gets worse with parameter ``j`` at another recording's estimate.

    Estimates far apart in a direction the recordings hardly see (a support's fore-aft stiffness
    anywhere in its rigid range) are not a drift of the physics: each recording fits the other's value
    within :data:`DRIFT_MATERIAL` of its own residual.
    """
    for k, sub in enumerate(subs):
        for other in range(len(subs)):
            if other == k:
                continue
            q = np.array(est[k], dtype=float)
            q[j] = est[other, j]
            r = safe_residual(h, sub, channels, q)
            if r is None or float(r @ r) > (1.0 + DRIFT_MATERIAL) * fitted_rss[k]:
                return True
    return False


def fit_per_recording(h: Hypothesis, p, firm_good, ev, channels, st, jac=None, pool=None) -> dict | None:
    """Fit ``h`` on each recording of ``ev`` alone and tell whether its parameters drift between them.

    Each recording's fit starts at the pooled fit ``p``: with ``jac`` (the pooled Jacobian in the
    fitting variable) it takes chord steps with that recording's rows of it; otherwise finite
    differences, and (one-parameter candidates) the best point of the candidate's screening grid on
    that recording is a second start (the lower residual wins); ``st.drift_nfev`` evaluations each.

    Criterion, per parameter that is identifiable in the pooled fit (``firm_good``) and per pair of
    recordings ``a``, ``b``: the estimates differ by more than ``st.drift_sigma`` combined standard
    deviations and by more than ``st.drift_rel_tol`` of their value; in ``log p`` for a positive
    parameter::

        |ln p_a - ln p_b| > max(drift_sigma * sqrt((s_a / p_a)^2 + (s_b / p_b)^2), ln(1 + drift_rel_tol))

    The first condition alone would reject on the small standard deviations of long records, which
    the residual's correlation makes optimistic; the second alone would reject parameters a
    recording barely sees. A parameter that meets both still does not drift if every recording fits
    the other recordings' estimate of it (its own estimates of the rest kept) within
    :data:`DRIFT_MATERIAL` of its own residual: the estimates differ along a direction the data hardly
    see.

    Parameters
    ----------
    h : Hypothesis
        The candidate; its ``start`` is restored afterwards.
    p : array_like
        The pooled fit's parameters, shape (n_params,).
    firm_good : array_like of bool
        Per parameter, whether it is identifiable in the pooled fit (only those are tested).
    ev : Evaluator or SpectralEvaluator
        The pooled evaluator (split with :func:`per_recording`).
    channels : sequence of str
        The simulated channels, in row order.
    st : RigDiagnosisSettings
        Settings (``drift_nfev``, ``drift_sigma``, ``drift_rel_tol``).
    jac : numpy.ndarray or None, optional
        The pooled Jacobian in the fitting variable, shape (n_rows, n_params) (None: finite differences).
    pool : EvaluationPool or None, optional
        Workers for the finite differences (None: this process).

    Returns
    -------
    dict or None
        ``per_recording`` (name -> list of values), ``std`` (name -> list), ``drifting`` (names) and
        ``text``; None with fewer than two recordings or a recording the candidate cannot simulate.
    """
    subs = per_recording(ev)
    if len(subs) < 2:
        return None
    p = np.asarray(p, dtype=float)
    parts = [safe_residual(h, sub, channels, p) for sub in subs]
    if any(r is None for r in parts):
        return None
    sizes = np.cumsum([0] + [r.size for r in parts])
    use_jac = jac is not None and jac.shape[0] == sizes[-1]
    start = h.start
    estimates, stds, fitted_rss = [], [], []
    try:
        for k, sub in enumerate(subs):
            rows = slice(sizes[k], sizes[k + 1])
            starts = [p]
            if not use_jac and h.screen_grid and len(h.names) == 1:
                # a resonance's residual has a local minimum per mode it can tune to: the recording's own
                # best grid point is a second start (a 4 kg mass fitted from a pooled 13 kg stays there)
                grid = [np.atleast_1d(np.asarray(g, dtype=float)) for g in h.screen_grid]
                grid = [g for g in grid if g.size == p.size]
                rss = [safe_residual(h, sub, channels, g) for g in grid]
                rss = [math.inf if r is None else float(r @ r) for r in rss]
                if grid and math.isfinite(min(rss)):
                    starts.append(grid[int(np.argmin(rss))])
            best = None
            for p_start in starts:
                h.start = np.clip(p_start, h.lower, h.upper)
                p_k, s_k, rss_k, _, _ = fit_hypothesis(
                    h,
                    sub,
                    channels,
                    st.drift_nfev,
                    jac=(lambda x, j=jac[rows]: j) if use_jac else None,
                    pool=pool,
                )
                if best is None or rss_k < best[2]:
                    best = (p_k, s_k, rss_k)
            estimates.append(best[0])
            stds.append(best[1])
            fitted_rss.append(best[2])
    finally:
        h.start = start
    est, sd = np.array(estimates), np.array(stds)
    drifting = []
    for j, name in enumerate(h.names):
        if not firm_good[j]:
            continue
        for a in range(len(subs)):
            for b in range(a + 1, len(subs)):
                pa, pb, sa, sb = est[a, j], est[b, j], sd[a, j], sd[b, j]
                if not (np.isfinite(sa) and np.isfinite(sb)):
                    continue
                if pa > 0 and pb > 0:
                    d, sigma = abs(math.log(pa / pb)), math.hypot(sa / pa, sb / pb)
                    tol = math.log1p(st.drift_rel_tol)
                else:
                    ref = max(abs(pa), abs(pb), 1e-300)
                    d, sigma, tol = abs(pa - pb) / ref, math.hypot(sa, sb) / ref, st.drift_rel_tol
                if d > max(st.drift_sigma * sigma, tol) and name not in drifting:
                    drifting.append(name)
    drifting = [n for n in drifting if _drift_matters(h, subs, channels, est, fitted_rss, h.names.index(n))]
    text = "; ".join(
        f"{n}: " + ", ".join(f"{v:.3g} +- {e:.2g}" for v, e in zip(est[:, j], sd[:, j], strict=True))
        for j, n in enumerate(h.names)
        if n in drifting
    )
    return {
        "per_recording": {n: est[:, j].tolist() for j, n in enumerate(h.names)},
        "std": {n: sd[:, j].tolist() for j, n in enumerate(h.names)},
        "drifting": drifting,
        "text": text,
    }
