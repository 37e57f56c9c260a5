"""The modal model of the level-trend diagnosis and the per-mode refit (reference and level stages).

``H(w) = sum_r R_r / (jw - p_r) + conj(R_r) / (jw - conj(p_r)) + lower + upper (jw)^2`` per channel
(accelerance form, one input). :func:`fit_mode` refits one mode's pole and residues around the mode
with the others held, optionally together with its neighbours over one window spanning theirs (two
modes whose half-power bands overlap share their tails, and a weak mode between two strong ones
is otherwise biased by whatever of their tails the held values miss): variable projection
(residues and a complex offset per channel linear, the poles nonlinear and each bounded to its
mode's window), every line weighted by the inverse of its noise
and distortion level; standard deviations from the Jacobian, scaled by the reduced chi-square
when above 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize

from exudyn_study.diagnose.levels.frf import LevelFRF

__all__ = ["ReferenceModel", "mode_term", "synthesise", "mode_window", "fit_mode", "pole_of"]


@dataclass(frozen=True, eq=False)
class ReferenceModel:
    """Linear modal model of the reference level (accelerance form, one input).

    Attributes
    ----------
    poles : ndarray of complex, shape (n_modes,)
        rad/s, upper half plane, ascending frequency.
    residues : ndarray of complex, shape (n_out, n_modes)
        ``H(w) = sum_r R_r / (jw - p_r) + conj(R_r) / (jw - conj(p_r)) + lower + upper (jw)^2``.
    lower, upper : ndarray, shape (n_out,)
        Residual terms.
    channels : tuple of str
    band_hz : (float, float)
    check : dict
        Per channel: ``relative_error``, ``noise_level`` (relative), ``tolerance``, ``passed``.
    modal_mass_kg : ndarray, shape (n_modes,) or None
        From the drive-point residues (force drive with a drive-point accelerometer).
    degenerate : tuple of str
        One message per mode whose mass is degenerate.
    """

    poles: np.ndarray
    residues: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    channels: tuple[str, ...]
    band_hz: tuple[float, float]
    check: dict
    modal_mass_kg: np.ndarray | None
    degenerate: tuple[str, ...]

    @property
    def frequency_hz(self) -> np.ndarray:
        """Undamped natural frequencies in Hz."""
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def damping_ratio(self) -> np.ndarray:
        """Damping ratios (-)."""
        return -self.poles.real / np.abs(self.poles)


def mode_term(residue: np.ndarray, pole: complex, freq_hz: np.ndarray) -> np.ndarray:
    """One mode's contribution ``R / (jw - p) + conj(R) / (jw - conj(p))``, shape (n_out, n_freq).

    Parameters
    ----------
    residue : ndarray of complex, shape (n_out,)
        The mode's residue ``R`` per channel, in the FRF's unit times rad/s (e.g.
        ``(m/s^2)/N * rad/s`` for an accelerance per newton).
    pole : complex
        The mode's pole ``p`` in rad/s (upper half plane); its conjugate is added.
    freq_hz : array_like, shape (n_freq,)
        Lines in Hz.

    Returns
    -------
    ndarray of complex, shape (n_out, n_freq)
        The mode's part of the FRFs, in the FRF's unit.
    """
    jw = 2j * np.pi * np.asarray(freq_hz, float)
    r = np.asarray(residue)[:, None]
    return r / (jw - pole) + np.conj(r) / (jw - np.conj(pole))


def synthesise(model: ReferenceModel, freq_hz: np.ndarray, poles: np.ndarray | None = None) -> np.ndarray:
    """FRFs of the model at ``freq_hz`` (optionally with other poles, same residues), (n_out, n_freq).

    Parameters
    ----------
    model : ReferenceModel
        Poles, residues and residual terms (``lower + upper (jw)^2``) of the modal model.
    freq_hz : array_like, shape (n_freq,)
        Lines in Hz.
    poles : ndarray of complex, shape (n_modes,), optional
        Poles in rad/s used instead of ``model.poles`` (same order, e.g. the poles of a level
        predicted by a joint law); the residues and residual terms stay the model's.

    Returns
    -------
    ndarray of complex, shape (n_out, n_freq)
        The synthesised FRFs in the model's unit (response per drive).
    """
    f = np.asarray(freq_hz, float)
    jw = 2j * np.pi * f
    p = model.poles if poles is None else np.asarray(poles)
    h = (
        model.lower[:, None]
        + model.upper[:, None] * jw**2
        + np.zeros((model.residues.shape[0], f.size), complex)
    )
    for k in range(p.size):
        h = h + mode_term(model.residues[:, k], p[k], f)
    return h


def mode_window(model: ReferenceModel, r: int, freq_hz: np.ndarray) -> np.ndarray:
    """Lines around mode ``r``: +-3 half-power bandwidths (at least +-5 lines), not past the neighbours.

    The window stops halfway to the neighbouring modes' frequencies; if that leaves fewer than
    7 lines, the 7 lines nearest the mode are taken instead, so that the mode's pole and its
    residues and offsets stay determined.

    Parameters
    ----------
    model : ReferenceModel
        The modal model whose frequencies and damping ratios place the window.
    r : int
        0-based index of the mode in ``model.poles``.
    freq_hz : ndarray, shape (n_freq,)
        Lines in Hz, ascending (their median spacing is the line step).

    Returns
    -------
    ndarray of bool, shape (n_freq,)
        True at the lines of the window.
    """
    f = model.frequency_hz
    z = model.damping_ratio
    step = float(np.median(np.diff(freq_hz)))
    half = max(3.0 * 2.0 * z[r] * f[r], 5.0 * step)
    lo, hi = f[r] - half, f[r] + half
    if r > 0:
        lo = max(lo, 0.5 * (f[r - 1] + f[r]))
    if r < f.size - 1:
        hi = min(hi, 0.5 * (f[r] + f[r + 1]))
    m = (freq_hz >= lo) & (freq_hz <= hi)
    if m.sum() < 7:  # too close to a neighbour: the nearest 7 lines
        m = np.zeros(freq_hz.size, bool)
        m[np.argsort(np.abs(freq_hz - f[r]))[:7]] = True
    return m


def _basis(poles, jw: np.ndarray) -> np.ndarray:
    """Real-parameter basis (Re R_k, Im R_k per pole, Re a, Im a) as complex columns, (n_freq, 2 n + 2)."""
    cols = []
    for pole in np.atleast_1d(poles):
        a = 1.0 / (jw - pole)
        b = 1.0 / (jw - np.conj(pole))
        cols += [a + b, 1j * a - 1j * b]
    cols += [np.ones_like(jw), 1j * np.ones_like(jw)]
    return np.stack(cols, axis=1)


def _solve(poles, jw, h, w, with_cov: bool = True):
    """Weighted LS of residues and offset per channel; returns (coef (n_out, 2 n + 2), wres, covs or None).

    The real parameters of every channel solve the normal equations ``Re(A^H W^2 A) x = Re(A^H W^2 h)``
    of the complex basis ``A`` (equal to those of the stacked real and imaginary parts), all channels
    at once, the columns scaled to unit norm first.
    """
    bas = _basis(poles, jw)
    w2 = w**2
    bw = bas.conj().T[None, :, :] * w2[:, None, :]  # (n_out, p, n_freq)
    g = (bw @ bas).real
    rhs = (bw @ h[:, :, None])[..., 0].real
    d = np.sqrt(np.maximum(np.diagonal(g, axis1=1, axis2=2), 1e-300))
    gs = g / (d[:, :, None] * d[:, None, :])
    try:
        coef = np.linalg.solve(gs, (rhs / d)[..., None])[..., 0] / d
    except np.linalg.LinAlgError:
        coef = np.array([np.linalg.lstsq(gs[c], rhs[c] / d[c], rcond=None)[0] for c in range(g.shape[0])]) / d
    r = w * (h - coef @ bas.T)
    res = np.concatenate([r.real, r.imag], axis=1).ravel()
    covs = None
    if with_cov:
        covs = [np.linalg.pinv(gs[c]) / np.outer(d[c], d[c]) for c in range(g.shape[0])]
    return coef, res, covs


def pole_of(theta) -> complex:
    """Pole in rad/s of (frequency in Hz, damping ratio).

    Parameters
    ----------
    theta : (float, float)
        Undamped natural frequency ``f`` in Hz and damping ratio ``zeta`` (-).

    Returns
    -------
    complex
        ``-zeta w + j w sqrt(1 - zeta^2)`` with ``w = 2 pi f`` (rad/s, upper half plane).
    """
    f, z = theta
    w = 2 * np.pi * f
    return complex(-z * w, w * np.sqrt(max(1 - z * z, 1e-12)))


def fit_mode(
    model: ReferenceModel,
    r: int,
    frf: LevelFRF,
    neighbours: int = 0,
    anchor: ReferenceModel | None = None,
):
    """Refit mode ``r`` on one level; returns (f, f_std, zeta, zeta_std, residues, residue_std, chi2).

    The other modes of ``model`` are subtracted at their current poles and residues; the fit
    runs over the mode's window (:func:`mode_window`) as described in the module docstring.

    Parameters
    ----------
    model : ReferenceModel
        The modal model giving the start values of mode ``r`` and the held other modes.
    r : int
        0-based index of the mode to refit.
    frf : LevelFRF
        The level's FRFs (in the model's channels and unit), with their noise and distortion
        levels as the weights.
    neighbours : int, optional
        Also refit this many modes on either side of ``r`` together with it, over one window
        spanning their windows, and return mode ``r``'s values (0: mode ``r`` alone).
    anchor : ReferenceModel, optional
        The model whose modes' windows bound the poles (default ``model``); the fit runs over
        those windows and ``model``'s together: repeated refits that start from their own
        results stay in the ``anchor``'s windows instead of walking off with a mode that drowns in
        noise, and a mode whose damping grew is still fitted over its wider band.

    Returns
    -------
    f, f_std : float
        Undamped natural frequency and its standard deviation in Hz.
    zeta, zeta_std : float
        Damping ratio and its standard deviation (-).
    residues : ndarray of complex, shape (n_out,)
        The mode's residues per channel (FRF unit times rad/s).
    residue_std : ndarray, shape (n_out,)
        Standard deviation of each residue (of its complex value).
    chi2 : float
        Reduced chi-square of the fit (about 1 when the misfit is within the noise).
    """
    group = [k for k in range(r - neighbours, r + neighbours + 1) if 0 <= k < model.poles.size]
    wins = [mode_window(model, k, frf.freq_hz) for k in group]
    # the bounds: the anchor's windows; the lines: the current windows and those (a mode whose damping
    # grew with level needs its wider window)
    bounds = wins if anchor is None else [mode_window(anchor, k, frf.freq_hz) for k in group]
    wins = [w | b for w, b in zip(wins, bounds, strict=True)]
    m = np.logical_or.reduce(wins)
    idx = np.flatnonzero(m)
    m[idx[0] : idx[-1] + 1] = True  # one contiguous window over the group
    f = frf.freq_hz[m]
    jw = 2j * np.pi * f
    others = synthesise(model, f)
    for k in group:
        others = others - mode_term(model.residues[:, k], model.poles[k], f)
    h = frf.H[:, m] - others
    w = 1.0 / np.maximum(frf.total_sigma[:, m], 1e-12 * np.abs(frf.H[:, m]).max())
    theta0, lo, hi = [], [], []
    for k, wk in zip(group, bounds, strict=True):
        fk = frf.freq_hz[wk]
        t0 = np.array(
            [np.clip(model.frequency_hz[k], fk[0], fk[-1]), min(max(model.damping_ratio[k], 1e-4), 0.2)]
        )
        theta0.append(t0)
        # each pole stays inside its mode's window and its damping in (0, 30 %]: a mode that left
        # the window (or drowned in noise) ends at a bound and is flagged by its large uncertainty
        lo.append([fk[0], 1e-5])
        hi.append([fk[-1], 0.3])
    theta0 = np.concatenate(theta0)
    scale = np.tile([1e-3, 0.1], len(group)) * theta0
    lo = (np.concatenate(lo) - theta0) / scale
    hi = (np.concatenate(hi) - theta0) / scale

    def poles_of(x):
        t = theta0 + x * scale
        return np.array([pole_of(t[2 * i : 2 * i + 2]) for i in range(len(group))])

    def fun(x):
        return _solve(poles_of(x), jw, h, w, with_cov=False)[1]

    sol = scipy.optimize.least_squares(fun, np.zeros(theta0.size), bounds=(lo, hi), method="trf")
    theta_all = theta0 + sol.x * scale
    coef, resid, covs = _solve(poles_of(sol.x), jw, h, w)
    dof = max(resid.size - theta0.size - (2 * len(group) + 2) * h.shape[0], 1)
    chi2 = float(resid @ resid / dof)
    s2 = max(chi2, 1.0)
    jac = sol.jac / scale
    i = group.index(r)
    try:
        cov = np.linalg.inv(jac.T @ jac) * s2
        std = np.sqrt(np.maximum(np.diag(cov), 0.0))[2 * i : 2 * i + 2]
    except np.linalg.LinAlgError:
        std = np.array([np.inf, np.inf])
    theta = theta_all[2 * i : 2 * i + 2]
    residues = coef[:, 2 * i] + 1j * coef[:, 2 * i + 1]
    rstd = np.array([np.sqrt(max(cv[2 * i, 2 * i] + cv[2 * i + 1, 2 * i + 1], 0.0) * s2) for cv in covs])
    return theta[0], std[0], theta[1], std[1], residues, rstd, chi2
