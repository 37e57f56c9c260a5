r"""Least-squares frequency-domain (LSFD) residues, shapes, synthesis and pole refinement.

With the poles fixed, every FRF is linear in its residues and residual terms:

.. math:: H_{oi}(\omega) = \sum_k \frac{R_{oik}}{j\omega-\lambda_k}
          + \frac{R^*_{oik}}{j\omega-\lambda^*_k}
          + L_{oi} (j\omega)^{a} + U_{oi} (j\omega)^{b},

where the lower residual :math:`L` stands for the modes below the band and the
upper residual :math:`U` for those above it; the powers depend on the FRF form
(receptance: a=-2, b=0; mobility: a=-1, b=1; accelerance or acceleration
transmissibility: a=0, b=2). Residues and residuals are solved in the real
least-squares sense (Peeters et al. 2004, Section 3.3). The mode shape of mode k is
the dominant left singular vector of its residue matrix ``R[:, :, k]`` and the
participation vector the right one.

:func:`refine_poles` adjusts the poles so that the synthesised FRFs fit the
measured ones best (a nonlinear least-squares fit of the continuous-time
pole-residue model, residues eliminated by variable projection, Golub & Pereyra
1973). PolyMAX fits a discrete-time (z-domain) model, so its poles carry a small
model bias; the refined poles are those of the continuous model itself.

References
----------
Peeters, B., Van der Auweraer, H., Guillaume, P., Leuridan, J. (2004). The PolyMAX
frequency-domain method. Shock and Vibration 11, 395-409.

Golub, G. H., Pereyra, V. (1973). The differentiation of pseudo-inverses and
nonlinear least squares problems whose variables separate. SIAM J. Numer. Anal.
10(2), 413-432.

Ewins, D. J. (2000). Modal Testing: Theory, Practice and Application, 2nd ed.,
Research Studies Press, Section 4.4 (residual terms).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from exudyn_study.errors import InputError
from exudyn_study.identify._checks import as_frf, band_mask, callable_module
from exudyn_study.identify.polymax import modal_to_pole, pole_to_modal

__all__ = [
    "FRF_FORMS", "Leakage", "LSFDResult", "lsfd", "refine_poles", "synthesise",
    "welch_expectation", "fit_modal_model",
]

logger = logging.getLogger(__name__)

#: FRF form -> powers of (j omega) of the lower and upper residual terms
FRF_FORMS = {"receptance": (-2, 0), "mobility": (-1, 1), "accelerance": (0, 2)}


@dataclass(frozen=True, eq=False)
class LSFDResult:
    """Residues, shapes and synthesised FRFs for fixed poles.

    Attributes
    ----------
    poles : ndarray of complex, shape (n_modes,)
        Poles in rad/s (upper half plane).
    residues : ndarray of complex, shape (n_out, n_in, n_modes)
        Residues in FRF unit times rad/s.
    lower, upper : ndarray, shape (n_out, n_in)
        Real coefficients of the lower and upper residual terms (zeros if unused).
    shapes : ndarray of complex, shape (n_out, n_modes)
        Mode shapes (dominant left singular vector of each residue matrix), scaled
        so that the largest-magnitude component is 1 + 0j.
    participation : ndarray of complex, shape (n_in, n_modes)
        Participation vectors with ``residues[:, :, k] ~ shapes[:, k] participation[:, k]^T``.
    freq_hz : ndarray, shape (n_freq,)
        Lines of the fitted band in Hz.
    synthesised : ndarray of complex, shape (n_out, n_in, n_freq)
        Synthesised FRFs on ``freq_hz``.
    fit_error : ndarray, shape (n_out,)
        Relative rms error ``||H_o - H_syn,o|| / ||H_o||`` per output over the band
        and all inputs (-).
    frf_form : str
        FRF form used for the residual terms.
    """

    poles: np.ndarray
    residues: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    shapes: np.ndarray
    participation: np.ndarray
    freq_hz: np.ndarray
    synthesised: np.ndarray
    fit_error: np.ndarray
    frf_form: str

    @property
    def frequency_hz(self) -> np.ndarray:
        """Undamped natural frequencies in Hz, shape (n_modes,)."""
        return pole_to_modal(self.poles)[0]

    @property
    def damping_ratio(self) -> np.ndarray:
        """Damping ratios (-), shape (n_modes,)."""
        return pole_to_modal(self.poles)[1]


@dataclass(frozen=True)
class Leakage:
    r"""Welch settings of an estimated FRF, for the leakage-aware pole basis.

    For a white reference signal, the expected Welch H1 estimate is the DFT of the
    sampled impulse response multiplied by the normalised autocorrelation of the
    window (the lag window) :math:`\rho[m]`:

    .. math:: E[H_1](\omega_l) = \sum_{m=0}^{N-1} h[m]\,\rho[m]\,e^{-j2\pi lm/N},
              \quad \rho[m] = \frac{\sum_n w[n]w[n+m]}{\sum_n w[n]^2}

    (Bendat & Piersol 2010, Section 8.5 for the spectral-window convolution). A
    pole term :math:`R/(j\omega-\lambda)`, i.e. :math:`h(t) = R e^{\lambda t}`,
    is therefore fitted with the basis
    :math:`\sum_m \Delta t\, e^{\lambda m \Delta t}\rho[m] e^{-j2\pi lm/N}`
    instead of :math:`1/(j\omega-\lambda)`. This removes the resolution (leakage)
    bias of the damping for H1 exactly in expectation, and approximately for
    H2 and Hv, whose peaks are smoothed by the same spectral window.

    Attributes
    ----------
    sample_rate_hz : float
        Sampling rate of the time data in Hz.
    n_segment : int
        Welch segment length in samples (resolution = fs / n_segment).
    window : str
        Window name (:func:`scipy.signal.get_window`).
    """

    sample_rate_hz: float
    n_segment: int
    window: str = "hann"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.sample_rate_hz) and self.sample_rate_hz > 0):
            raise InputError(f"sample_rate_hz={self.sample_rate_hz!r}: expected > 0")
        if int(self.n_segment) != self.n_segment or self.n_segment < 8:
            raise InputError(f"n_segment={self.n_segment!r}: expected an integer >= 8")

    def lag_window(self) -> np.ndarray:
        """Normalised window autocorrelation rho[m], m = 0..n_segment-1."""
        return _lag_window(self.window, int(self.n_segment))

    def pole_term(self, poles, freq_hz) -> np.ndarray:
        r"""Return the expected Welch H1 estimate of the unit pole terms :math:`1/(j\omega-\lambda)`.

        Parameters
        ----------
        poles : array_like of complex, shape (n_poles,)
            Poles in rad/s.
        freq_hz : array_like, shape (n_freq,)
            Frequency lines in Hz (multiples of ``sample_rate_hz / n_segment``).

        Returns
        -------
        ndarray of complex, shape (n_freq, n_poles)
        """
        return _pole_basis(np.atleast_1d(np.asarray(poles, complex)),
                           np.asarray(freq_hz, float), self)

    def kernel(self, oversample: int = 16, half_width: int = 8) -> tuple[np.ndarray, np.ndarray]:
        """Spectral window ``|W|^2`` (unit sum) at offsets in lines, for smoothing.

        Returns
        -------
        offsets : ndarray
            Offsets in frequency lines, ``-half_width .. half_width`` in steps of
            ``1 / oversample``.
        weights : ndarray
            Kernel weights summing to 1.
        """
        return _kernel(self.window, int(self.n_segment), int(oversample), int(half_width))


@functools.lru_cache(maxsize=16)
def _kernel(window: str, n: int, oversample: int, half_width: int) -> tuple[np.ndarray, np.ndarray]:
    import scipy.signal

    w = scipy.signal.get_window(window, n)
    off = np.arange(-half_width * oversample, half_width * oversample + 1) / oversample
    spec = np.exp(-2j * np.pi * np.outer(off, np.arange(n)) / n) @ w
    k = np.abs(spec) ** 2
    k = k / k.sum()
    off.setflags(write=False)
    k.setflags(write=False)
    return off, k


@functools.lru_cache(maxsize=8)
def _lag_window(window: str, n: int) -> np.ndarray:
    import scipy.signal

    w = scipy.signal.get_window(window, n)
    a = np.fft.irfft(np.abs(np.fft.rfft(w, 2 * n)) ** 2, 2 * n)[:n]
    a = a / a[0]
    a.setflags(write=False)
    return a


@functools.lru_cache(maxsize=8)
def _lag_expansion(window: str, n: int) -> np.ndarray | None:
    r"""Coefficients ``c[p, k]`` with :math:`\rho[m] = \sum c_{pk} (m/n)^p e^{j 2\pi k m / n}`, or None.

    The lag window of a cosine-sum window (Hann, Hamming, Blackman, rectangular) is exactly
    such a sum with p in {0, 1} and |k| <= 2, which gives the leakage-aware pole basis in
    closed form (:func:`_pole_basis`); None when the expansion is not exact to round-off.
    """
    rho = _lag_window(window, n)
    m = np.arange(n)
    ks = np.arange(-2, 3)
    a = np.concatenate([(m / n)[:, None] ** p * np.exp(2j * np.pi * np.outer(m, ks) / n)
                        for p in (0, 1)], axis=1)
    c = np.linalg.lstsq(a, rho.astype(complex), rcond=None)[0]
    if np.max(np.abs(a @ c - rho)) > 1e-11:
        return None
    c = c.reshape(2, ks.size)
    c.setflags(write=False)
    return c


def _pole_basis(poles: np.ndarray, freq_hz: np.ndarray, leakage: Leakage | None):
    r"""Basis functions of the pole terms, ``[n_freq, n_poles]``.

    With ``leakage`` the term of pole :math:`\lambda` at line :math:`l` is
    :math:`\Delta t \sum_{m<N} \rho[m] e^{\lambda m \Delta t} e^{-j2\pi lm/N}`; for a
    cosine-sum window (:func:`_lag_expansion`) it is summed in closed form, geometric sums
    :math:`\sum r^m` and :math:`\sum (m/N) r^m` with :math:`r^N = e^{\lambda N \Delta t}`
    (O(n_freq n_poles) instead of one length-N FFT per pole); otherwise by FFT.
    """
    if leakage is None:
        jw = 2j * np.pi * freq_hz
        return 1.0 / (jw[:, None] - poles[None, :])
    dt = 1.0 / leakage.sample_rate_hz
    n = int(leakage.n_segment)
    lines = np.rint(freq_hz * n * dt).astype(int)
    coef = _lag_expansion(leakage.window, n)
    if coef is None:
        m = np.arange(n)
        g = dt * np.exp(poles[:, None] * (m[None, :] * dt)) * leakage.lag_window()[None, :]
        return np.fft.fft(g, axis=1)[:, lines].T
    theta = 2 * np.pi / n
    rn = np.exp(poles * (n * dt))[None, None, :]  # r^N, the same for every line and k
    ks = np.arange(-2, 3)
    r = np.exp(poles[None, :] * dt - 1j * theta * lines[:, None])[None] \
        * np.exp(1j * theta * ks)[:, None, None]
    q = 1 - r  # |1 - r| >= zeta omega dt: round-off eps / (zeta omega dt) < 1e-11 here
    s0 = (1 - rn) / q
    s1 = r / q * (s0 - n * rn / r) / n
    out = np.tensordot(coef[0], s0, axes=(0, 0)) + np.tensordot(coef[1], s1, axes=(0, 0))
    return dt * out


def _pole_basis_derivative(poles: np.ndarray, freq_hz: np.ndarray, leakage: Leakage | None):
    """Return the derivative of :func:`_pole_basis` with respect to each pole, ``[n_freq, n_poles]``.

    Exact for plain pole terms; a central difference in the (analytic) pole otherwise,
    with a step of 1e-6 |pole|, far below any pole's distance to the real axis scale.
    """
    if leakage is None:
        jw = 2j * np.pi * freq_hz
        return 1.0 / (jw[:, None] - poles[None, :]) ** 2
    h = 1e-6 * np.abs(poles)
    return (_pole_basis(poles + h, freq_hz, leakage)
            - _pole_basis(poles - h, freq_hz, leakage)) / (2 * h)[None, :]


def _basis(poles: np.ndarray, freq_hz: np.ndarray, powers, leakage=None) -> np.ndarray:
    """Real-coefficient basis ``A[n_freq, 2 n_modes + n_res]`` (complex values)."""
    jw = 2j * np.pi * freq_hz
    b1 = _pole_basis(poles, freq_hz, leakage)
    b2 = _pole_basis(np.conj(poles), freq_hz, leakage)
    cols = [b1 + b2, 1j * (b1 - b2)]
    cols += [(jw**p)[:, None] for p in powers]
    return np.concatenate(cols, axis=1)


def _solve(a: np.ndarray, h2: np.ndarray, w: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray]:
    """Real (weighted) LS solution of ``a @ c = h2``.

    ``a`` is complex ``[nf, n_col]``, ``h2`` complex ``[nf, n_rhs]``; ``w`` (optional,
    real ``[nf, n_rhs]``) weights every line of every right-hand side, which then
    has its own normal equations. Normal equations of the column-scaled real
    problem, solved by Cholesky (the columns are few and well separated; LAPACK's
    QR/SVD drivers are avoided because their threading overhead dominates at these
    sizes). Returns ``c[n_col, n_rhs]`` and the unweighted fit ``a @ c``.
    """
    ar = np.vstack([a.real, a.imag])
    hr = np.vstack([h2.real, h2.imag])
    if w is not None:
        ww = np.vstack([w, w]).T  # [n_rhs, 2 nf]
        aw = ww[:, :, None] * ar[None, :, :]  # [n_rhs, 2 nf, n_col]
        norm = np.linalg.norm(aw, axis=1)  # [n_rhs, n_col]
        norm[norm == 0] = 1.0
        aw /= norm[:, None, :]
        g = np.matmul(aw.transpose(0, 2, 1), aw)
        b = np.matmul(aw.transpose(0, 2, 1), (ww * hr.T)[:, :, None])[..., 0]
        try:
            c = np.linalg.solve(g, b[..., None])[..., 0]
        except np.linalg.LinAlgError:
            c = np.stack([np.linalg.lstsq(g[r], b[r], rcond=None)[0] for r in range(g.shape[0])])
        c = (c / norm).T
        return c, a @ c
    norm = np.linalg.norm(ar, axis=0)
    norm[norm == 0] = 1.0
    an = ar / norm
    try:
        c = scipy.linalg.cho_solve(scipy.linalg.cho_factor(an.T @ an), an.T @ hr)
    except np.linalg.LinAlgError:
        c = np.linalg.lstsq(an, hr, rcond=None)[0]
    c = c / norm[:, None]
    return c, a @ c


def _line_weights(weights, shape: tuple[int, int, int], sel: np.ndarray) -> np.ndarray | None:
    """Return per-line weights ``[nf_band, n_out * n_in]``, or None for per-output ones.

    ``weights`` has shape (n_out,) (None is returned: they do not change a
    per-column LS solution) or (n_out, n_in, n_freq).
    """
    if weights is None:
        return None
    w = np.asarray(weights, dtype=float)
    n_out, n_in, n_freq = shape
    if w.shape == (n_out,):
        return None
    if w.shape != (n_out, n_in, n_freq) or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise InputError(
            f"weights of shape {w.shape}: expected ({n_out},) or ({n_out}, {n_in}, {n_freq}) "
            "finite non-negative values"
        )
    return w[:, :, sel].reshape(n_out * n_in, -1).T


def _check_poles(poles) -> np.ndarray:
    poles = np.atleast_1d(np.asarray(poles, dtype=complex))
    if poles.ndim != 1 or poles.size == 0:
        raise InputError(f"poles of shape {poles.shape}: expected a non-empty 1-D array")
    if not np.all(np.isfinite(poles)) or np.any(poles.imag <= 0):
        raise InputError("poles: expected finite poles in the upper half plane (Im > 0)")
    return poles


def _powers(frf_form: str, residuals: bool):
    if frf_form not in FRF_FORMS:
        raise InputError(f"frf_form {frf_form!r}: expected one of {', '.join(FRF_FORMS)}")
    return FRF_FORMS[frf_form] if residuals else ()


def lsfd(
    frf: np.ndarray,
    freq_hz: np.ndarray,
    poles: np.ndarray,
    *,
    band_hz: tuple[float, float] | None = None,
    frf_form: str = "accelerance",
    residuals: bool = True,
    leakage: Leakage | None = None,
    weights: np.ndarray | None = None,
) -> LSFDResult:
    """Fit residues and residual terms to FRFs for given poles (LSFD).

    Parameters
    ----------
    frf : ndarray of complex, shape (n_out, n_in, n_freq)
        Measured FRFs.
    freq_hz : ndarray, shape (n_freq,)
        Frequency lines in Hz.
    poles : ndarray of complex, shape (n_modes,)
        Poles in rad/s, upper half plane.
    band_hz : (float, float), optional
        Band to fit in Hz (default: all lines above 0 Hz).
    frf_form : {'accelerance', 'mobility', 'receptance'}, optional
        Sets the residual terms; 'accelerance' also fits acceleration
        transmissibilities (default).
    residuals : bool, optional
        Fit lower and upper residual terms (default True).
    leakage : Leakage, optional
        Welch settings of ``frf``: fit the leakage-aware pole basis (see
        :class:`Leakage`); ``synthesised`` then includes the window smoothing.
        Default None: plain pole terms.
    weights : ndarray, shape (n_out, n_in, n_freq), optional
        Weight of every line, e.g. the inverse standard error of the FRF estimate
        (:func:`~exudyn_study.identify.frf.frf_weights`); default unweighted.

    Returns
    -------
    LSFDResult

    Raises
    ------
    InputError
        On bad shapes, non-finite data, poles off the upper half plane, an unknown
        ``frf_form`` or a band outside the data.
    """
    frf, freq_hz = as_frf(frf, freq_hz)
    poles = _check_poles(poles)
    powers = _powers(frf_form, residuals)
    sel = band_mask(freq_hz, band_hz)
    f = freq_hz[sel]
    h = frf[:, :, sel]
    n_out, n_in, nf = h.shape
    n_modes = poles.size
    a = _basis(poles, f, powers, leakage)
    if a.shape[1] > 2 * nf:
        raise InputError(
            f"{n_modes} modes and {len(powers)} residual terms need more than the {nf} "
            "lines of the band"
        )
    c, syn = _solve(a, h.reshape(n_out * n_in, nf).T,
                    _line_weights(weights, frf.shape, sel))
    res = (c[:n_modes] + 1j * c[n_modes:2 * n_modes]).T.reshape(n_out, n_in, n_modes)
    lower = np.zeros((n_out, n_in))
    upper = np.zeros((n_out, n_in))
    if powers:
        lower = c[2 * n_modes].reshape(n_out, n_in)
        upper = c[2 * n_modes + 1].reshape(n_out, n_in)
    syn = syn.T.reshape(n_out, n_in, nf)
    shapes = np.zeros((n_out, n_modes), complex)
    part = np.zeros((n_in, n_modes), complex)
    for k in range(n_modes):
        # dominant singular pair via the small n_in x n_in Hermitian matrix R^H R
        r_k = res[:, :, k]
        _, evec = np.linalg.eigh(r_k.conj().T @ r_k)
        v = evec[:, -1]
        psi = r_k @ v
        lvec = np.conj(v)
        ref = psi[np.argmax(np.abs(psi))]
        if ref != 0:
            shapes[:, k] = psi / ref
            part[:, k] = lvec * ref
    num = np.sqrt(np.sum(np.abs(h - syn) ** 2, axis=(1, 2)))
    den = np.sqrt(np.sum(np.abs(h) ** 2, axis=(1, 2)))
    with np.errstate(invalid="ignore", divide="ignore"):
        err = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return LSFDResult(
        poles=poles, residues=res, lower=lower, upper=upper, shapes=shapes,
        participation=part, freq_hz=f, synthesised=syn, fit_error=err, frf_form=frf_form,
    )


def synthesise(result: LSFDResult, freq_hz: np.ndarray) -> np.ndarray:
    """Evaluate the fitted modal model of ``result`` at other frequencies.

    Parameters
    ----------
    result : LSFDResult
        Output of :func:`lsfd`.
    freq_hz : ndarray, shape (n_freq,)
        Frequencies in Hz.

    Returns
    -------
    ndarray of complex, shape (n_out, n_in, n_freq)
    """
    f = np.asarray(freq_hz, dtype=float)
    jw = 2j * np.pi * f
    p = result.poles
    h = result.residues @ (1.0 / (jw[None, :] - p[:, None]))
    h = h + np.conj(result.residues) @ (1.0 / (jw[None, :] - np.conj(p)[:, None]))
    lo, up = FRF_FORMS[result.frf_form]
    with np.errstate(divide="ignore", invalid="ignore"):
        h = h + result.lower[:, :, None] * jw**lo + result.upper[:, :, None] * jw**up
    return h


def _levenberg_marquardt(normal, cost, x0: np.ndarray, *, max_iter: int = 200,
                         tol: float = 1e-8) -> tuple[np.ndarray, bool]:
    """Minimise a sum of squares from its normal equations (Levenberg-Marquardt).

    ``normal(x) -> (J^T J, J^T r, cost)``, ``cost(x) -> sum r^2``. Marquardt's scaling by the
    diagonal of J^T J makes the steps invariant to the parameters' units; the damping is
    lowered after a step that reduces the cost and raised otherwise. Converged when a step
    changes the cost or the scaled parameters by less than ``tol`` (relative).
    """
    x = np.asarray(x0, dtype=float).copy()
    jtj, jtr, c0 = normal(x)
    mu = 1e-3
    for _ in range(int(max_iter)):
        d = np.maximum(np.diag(jtj), np.finfo(float).tiny)
        try:
            step = np.linalg.solve(jtj + mu * np.diag(d), -jtr)
        except np.linalg.LinAlgError:
            mu *= 10.0
            continue
        if not np.all(np.isfinite(step)):
            return x, False
        c1 = cost(x + step)
        if np.isfinite(c1) and c1 < c0:
            small = np.sqrt(np.sum(d * step**2)) <= tol * max(np.sqrt(np.sum(d * x**2)), np.sqrt(c0))
            x = x + step
            done = (c0 - c1) <= tol * c0 or small
            jtj, jtr, c0 = normal(x)
            if done:
                return x, True
            mu = max(mu / 3.0, 1e-12)
        else:
            mu *= 4.0
            if mu > 1e12:
                return x, True  # no descent left: x is a minimum to the precision of the model
    return x, False


def refine_poles(
    frf: np.ndarray,
    freq_hz: np.ndarray,
    poles: np.ndarray,
    *,
    band_hz: tuple[float, float] | None = None,
    frf_form: str = "accelerance",
    residuals: bool = True,
    weights: np.ndarray | None = None,
    leakage: Leakage | None = None,
    max_nfev: int = 200,
) -> np.ndarray:
    """Refine poles by nonlinear least squares on the pole-residue model.

    Minimises ``sum_o w_o^2 ||H_o - H_syn,o(poles)||^2`` over the natural
    frequencies and damping ratios, with the residues and residual terms of every
    trial eliminated by linear least squares (variable projection).

    Parameters
    ----------
    frf : ndarray of complex, shape (n_out, n_in, n_freq)
        Measured FRFs.
    freq_hz : ndarray, shape (n_freq,)
        Frequency lines in Hz.
    poles : ndarray of complex, shape (n_modes,)
        Starting poles in rad/s (e.g. from PolyMAX).
    band_hz : (float, float), optional
        Band in Hz (default all lines above 0 Hz).
    frf_form : str, optional
        See :func:`lsfd`.
    residuals : bool, optional
        Fit residual terms (default True).
    weights : ndarray, shape (n_out,) or (n_out, n_in, n_freq), optional
        Weight per output, or per line (e.g. the inverse standard error of the
        FRF estimate, :func:`~exudyn_study.identify.frf.frf_weights`, which makes
        the fit a maximum-likelihood one for Gaussian FRF errors); default
        1 / rms(|H_o|) per output.
    leakage : Leakage, optional
        Welch settings of ``frf`` for the leakage-aware basis (see :class:`Leakage`).
    max_nfev : int, optional
        Maximum number of function evaluations of the optimiser.

    Returns
    -------
    ndarray of complex, shape (n_modes,)
        Refined poles, same order as ``poles``. If the optimiser moves a pole by
        more than half the distance to its neighbour, or drives a damping ratio to the
        bound of the search (0.9: a pole that left the data to absorb a broad misfit),
        the starting poles are returned unchanged (the fit is not trusted).
    """
    frf, freq_hz = as_frf(frf, freq_hz)
    poles = _check_poles(poles)
    powers = _powers(frf_form, residuals)
    sel = band_mask(freq_hz, band_hz)
    f = freq_hz[sel]
    h = frf[:, :, sel]
    n_out, n_in, nf = h.shape
    w_line = _line_weights(weights, frf.shape, sel)
    if w_line is None:
        if weights is None:
            rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=(1, 2)))
            weights = np.where(rms > 0, 1.0 / np.where(rms > 0, rms, 1.0), 0.0)
        hw = (h * np.asarray(weights)[:, None, None]).reshape(n_out * n_in, nf).T
    else:
        hw = h.reshape(n_out * n_in, nf).T
    fn0, z0 = pole_to_modal(poles)
    z0 = np.clip(z0, 1e-5, 0.5)

    z_max = 0.9  # the optimiser may try any step: keep trial poles underdamped and finite
    n = poles.size
    # real stacked data and line weights of every right-hand side (output x reference)
    hr = np.vstack([hw.real, hw.imag]).T  # [n_rhs, 2 nf]
    wr = np.ones_like(hr) if w_line is None else np.vstack([w_line, w_line]).T
    whr = wr * hr

    def unpack(x):
        fn = fn0 * (1 + np.clip(x[:n], -0.5, 0.5))
        zeta = np.minimum(z0 * np.exp(np.minimum(x[n:], 50.0)), z_max)
        return fn, zeta

    cache = {}

    def evaluate(x):
        """Variable projection at x: residual, projector pieces and the pole derivatives."""
        key = x.tobytes()
        if key in cache:
            return cache[key]
        fn, zeta = unpack(x)
        lam = modal_to_pole(fn, zeta)
        a = _basis(lam, f, powers, leakage)
        ar = np.vstack([a.real, a.imag])  # [2 nf, n_col]
        aw = wr[:, :, None] * ar[None, :, :]  # [n_rhs, 2 nf, n_col]
        norm = np.linalg.norm(aw, axis=1)
        norm[norm == 0] = 1.0
        aw /= norm[:, None, :]
        g = np.matmul(aw.transpose(0, 2, 1), aw)
        rhs = np.matmul(aw.transpose(0, 2, 1), whr[:, :, None])
        try:
            cn = np.linalg.solve(g, rhs)[..., 0]
        except np.linalg.LinAlgError:
            cn = np.stack([np.linalg.lstsq(g[r], rhs[r, :, 0], rcond=None)[0]
                           for r in range(g.shape[0])])
        r_vec = whr - np.matmul(aw, cn[:, :, None])[..., 0]  # [n_rhs, 2 nf]
        cache.clear()
        cache[key] = (r_vec, lam, fn, zeta, aw, g, cn / norm)
        return cache[key]

    def resid(x):
        return evaluate(x)[0].ravel()

    def normal(x):
        """Return J^T J, J^T r and the cost of Kaufman's variable-projection Jacobian at x.

        J = -(I - P) W (dA/dtheta) c with P the projector onto the weighted basis; as
        (I - P) is a symmetric projector and r = (I - P) W h, J^T J = V^T V - B^T G^-1 B and
        J^T r = -V^T r with V = W (dA/dtheta) c and B = A_w^T V: the Jacobian itself
        ([n_rhs * 2 n_freq, 2 n_modes]) is never formed.
        """
        r_vec, lam, fn, zeta, aw, g, c = evaluate(x)
        w = 2 * np.pi * fn
        root = np.sqrt(1 - zeta**2)
        dlam_dw = -zeta + 1j * root
        dlam_dz = -w - 1j * w * zeta / root
        dlam = np.concatenate([
            dlam_dw * 2 * np.pi * fn0 * (np.abs(x[:n]) < 0.5),
            dlam_dz * zeta * (zeta < z_max),
        ])  # [2 n]: d lambda_k / d x_j, pole k = j mod n
        db1 = _pole_basis_derivative(lam, f, leakage)  # [nf, n]
        db2 = _pole_basis_derivative(np.conj(lam), f, leakage)
        k = np.tile(np.arange(n), 2)
        d1 = db1[:, k] * dlam[None, :]  # d b1_k / d x_j
        d2 = db2[:, k] * np.conj(dlam)[None, :]
        col_re, col_im = d1 + d2, 1j * (d1 - d2)  # derivatives of the two columns of pole k
        dar_re = np.vstack([col_re.real, col_re.imag])  # [2 nf, 2 n]
        dar_im = np.vstack([col_im.real, col_im.imag])
        v = dar_re[None, :, :] * c[:, k][:, None, :] + dar_im[None, :, :] * c[:, n + k][:, None, :]
        v *= wr[:, :, None]  # [n_rhs, 2 nf, 2 n]
        b = np.matmul(aw.transpose(0, 2, 1), v)  # [n_rhs, n_col, 2 n]
        jtj = np.einsum("rfi,rfj->ij", v, v, optimize=True) \
            - np.einsum("rci,rcj->ij", b, np.linalg.solve(g, b), optimize=True)
        jtr = -np.einsum("rfi,rf->i", v, r_vec, optimize=True)
        return jtj, jtr, float(np.sum(r_vec**2))

    x, converged = _levenberg_marquardt(normal, lambda x: float(np.sum(evaluate(x)[0] ** 2)),
                                        np.zeros(2 * n), max_iter=max_nfev)
    new = modal_to_pole(*unpack(x))
    fn_new = pole_to_modal(new)[0]
    order = np.argsort(fn0)
    gaps = np.diff(fn0[order])
    half = np.full(poles.size, np.inf)
    if gaps.size:
        half[order] = 0.5 * np.minimum(np.r_[np.inf, gaps], np.r_[gaps, np.inf])
    z_new = unpack(x)[1]
    if (not converged or np.any(np.abs(fn_new - fn0) > half) or not np.all(np.isfinite(new))
            or np.any(z_new >= 0.99 * z_max)):
        logger.warning(
            "refine_poles: the refinement moved a pole by more than half the distance to its "
            "neighbour or to the damping bound (or did not converge); keeping the %d starting "
            "poles, whose damping carries the window-leakage bias. Two of them probably stand for one mode.",
            poles.size,
        )
        return poles
    return new


def welch_expectation(
    result: LSFDResult, freq_hz: np.ndarray, leakage: Leakage, estimator: str
) -> np.ndarray:
    r"""Return the expected Welch estimate of the modal model in ``result``.

    The model FRF :math:`H` is smoothed by the spectral window
    :math:`K = |W|^2` (unit sum): :math:`E[H_1] = K * H`,
    :math:`E[H_v] = (K*H)/|K*H| \sqrt{K*|H|^2}`, :math:`E[H_2] = (K*|H|^2)/(K*H)^*`
    (ratios of expected spectra, single reference per column).

    Parameters
    ----------
    result : LSFDResult
        Modal model (poles, residues, residual terms; plain pole terms).
    freq_hz : ndarray, shape (n_freq,)
        Lines in Hz at which to evaluate.
    leakage : Leakage
        Welch settings.
    estimator : {'H1', 'H2', 'Hv'}
        Estimator whose expectation is returned.

    Returns
    -------
    ndarray of complex, shape (n_out, n_in, n_freq)
    """
    if estimator not in ("H1", "H2", "Hv"):
        raise InputError(f"estimator {estimator!r}: expected 'H1', 'H2' or 'Hv'")
    return _welch_expectations(result, freq_hz, leakage, (estimator,))[0]


def _welch_expectations(result: LSFDResult, freq_hz: np.ndarray, leakage: Leakage,
                        estimators: tuple[str, ...]) -> list[np.ndarray]:
    """Return the expected Welch estimates of several estimators from one model evaluation."""
    f = np.asarray(freq_hz, dtype=float)
    df = leakage.sample_rate_hz / leakage.n_segment
    # the kernel is sampled at a quarter of a line, finer where a half-power bandwidth
    # (2 |Re lambda| / 2 pi) spans less than a line: at least four samples per bandwidth
    lines_bw = float(np.min(np.abs(result.poles.real))) / (np.pi * df) if result.poles.size else 1.0
    oversample = int(np.clip(np.ceil(4.0 / max(min(lines_bw, 1.0), 1e-3)), 4, 16))
    off, k = leakage.kernel(oversample=oversample, half_width=4)
    # the model on one fine grid (step df / oversample) covering every line's kernel; line l
    # uses the samples l * oversample + j, j = 0 .. n_off - 1
    half = (off.size - 1) // 2
    lines = np.rint((f - f[0]) / df).astype(int) if f.size else np.zeros(0, int)
    fine = f[0] + (np.arange(lines[-1] * oversample + off.size) - half) * (df / oversample) \
        if f.size else np.zeros(0)
    h_fine = synthesise(result, fine)
    idx = lines[:, None] * oversample + np.arange(off.size)[None, :]  # [nf, n_off]
    e_h = h_fine[:, :, idx] @ k
    e_hh = (np.abs(h_fine) ** 2)[:, :, idx] @ k if set(estimators) - {"H1"} else None
    out = []
    for est in estimators:
        if est == "H1":
            out.append(e_h)
        elif est == "Hv":
            out.append(e_h / np.maximum(np.abs(e_h), np.finfo(float).tiny) * np.sqrt(e_hh))
        else:
            out.append(e_hh / np.conj(e_h))
    return out


def fit_modal_model(
    frf: np.ndarray,
    freq_hz: np.ndarray,
    poles: np.ndarray,
    *,
    band_hz: tuple[float, float] | None = None,
    frf_form: str = "accelerance",
    leakage: Leakage | None = None,
    estimator: str = "H1",
    refine: bool = True,
    iterations: int = 3,
    weights: np.ndarray | None = None,
) -> LSFDResult:
    """Refine poles and fit residues, correcting the estimator's resolution bias.

    Without ``leakage`` this is :func:`refine_poles` followed by :func:`lsfd`.
    With ``leakage`` the pole terms are leakage-aware (see :class:`Leakage`); for
    H2 and Hv, whose expectation is not linear in the FRF, the data are first
    mapped to their H1 equivalent with the current model,
    ``H_meas * E[H1] / E[H_est]`` (:func:`welch_expectation`), and the residues are
    refitted ``iterations`` times (a fixed-point iteration on the bias), the poles
    refined once, on the mapped data of the second-to-last of them (the starting poles
    set the first map; the last map is that of the refined poles).

    Parameters
    ----------
    frf : ndarray of complex, shape (n_out, n_in, n_freq)
        Estimated FRFs.
    freq_hz : ndarray, shape (n_freq,)
        Lines in Hz.
    poles : ndarray of complex, shape (n_modes,)
        Starting poles in rad/s.
    band_hz : (float, float), optional
        Fitted band in Hz.
    frf_form : str, optional
        See :func:`lsfd`.
    leakage : Leakage, optional
        Welch settings of ``frf``; None fits plain pole terms.
    estimator : {'H1', 'H2', 'Hv'}, optional
        Estimator that produced ``frf``.
    refine : bool, optional
        Refine the poles by nonlinear least squares (default True).
    iterations : int, optional
        Bias-correction iterations for H2/Hv (default 3).
    weights : ndarray, shape (n_out, n_in, n_freq), optional
        Weight of every line for the pole refinement and the residues, e.g.
        :func:`~exudyn_study.identify.frf.frf_weights`; default per-output
        1 / rms weights for the poles and unweighted residues.

    Returns
    -------
    LSFDResult
        Residues of the underlying (unsmoothed) modal model; ``synthesised`` and
        ``fit_error`` compare the model's expected estimate with ``frf``.
    """
    frf, freq_hz = as_frf(frf, freq_hz)
    poles = _check_poles(poles)
    kw = {"band_hz": band_hz, "frf_form": frf_form, "leakage": leakage}
    mapped = leakage is not None and estimator in ("H2", "Hv")
    # with a bias map the poles are refined once, on the mapped data of the last iteration
    p = refine_poles(frf, freq_hz, poles, weights=weights, **kw) if refine and not mapped else poles
    res = lsfd(frf, freq_hz, p, weights=weights, **kw)
    if mapped:
        sel = band_mask(freq_hz, band_hz)
        n_it = max(0, int(iterations))
        for it in range(n_it):
            e1, ee = _welch_expectations(res, freq_hz[sel], leakage, ("H1", estimator))
            with np.errstate(invalid="ignore", divide="ignore"):
                corr = np.where(np.abs(ee) > 0, e1 / np.where(ee == 0, 1, ee), 1.0)
            h_eq = frf.copy()
            h_eq[:, :, sel] = frf[:, :, sel] * corr
            w_eq = None
            if weights is not None and np.ndim(weights) == 3:
                # the mapped data carry the same relative error: scale the weights
                w_eq = np.array(weights, dtype=float)
                with np.errstate(invalid="ignore", divide="ignore"):
                    w_eq[:, :, sel] = np.nan_to_num(w_eq[:, :, sel] / np.abs(corr))
            elif weights is not None:
                w_eq = weights
            # the map converges with the residues; the poles are refined once, on the
            # second-to-last pass, so that the last map is that of the refined poles
            if refine and it == max(n_it - 2, 0):
                p = refine_poles(h_eq, freq_hz, p, weights=w_eq, **kw)
            res = lsfd(h_eq, freq_hz, p, weights=w_eq, **kw)
        # report the fit against the data as measured
        syn = welch_expectation(res, freq_hz[sel], leakage, estimator)
        h = frf[:, :, sel]
        num = np.sqrt(np.sum(np.abs(h - syn) ** 2, axis=(1, 2)))
        den = np.sqrt(np.sum(np.abs(h) ** 2, axis=(1, 2)))
        err = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
        res = dataclasses.replace(res, synthesised=syn, fit_error=err)
    return res


# calling the module calls the function (see _checks.callable_module)
callable_module(__name__, lsfd)
