r"""Poly-reference least-squares complex frequency-domain estimator (PolyMAX).

The FRF matrix in a band is fitted, for a sequence of model orders, with a right
matrix-fraction model in the z-domain (real polynomial coefficients)

.. math:: H_o(\omega) = N_o(z) D(z)^{-1}, \quad z = e^{j \omega \Delta t},
          \quad N_o(z) = \sum_{r=0}^{p} \beta_{o,r} z^r,
          \quad D(z) = \sum_{r=0}^{p} \alpha_r z^r,\ \alpha_p = I,

whose linearised least-squares problem is reduced to the denominator coefficients
only (Peeters et al. 2004, eqs. 5-10). The poles are the eigenvalues of the block
companion matrix of :math:`D`; each pole carries a vector used for the stability
check: its participation vector when there are several references, else the
estimate of its mode shape from the numerator, :math:`N_o(z_k)`.

Each pole is compared with the nearest pole of the previous order; it is stable in
frequency, damping and vector when the relative change is below the tolerances
(defaults 1 %, 5 % and 2 % (1 - MAC), Testlab's defaults).

References
----------
Peeters, B., Van der Auweraer, H., Guillaume, P., Leuridan, J. (2004). The PolyMAX
frequency-domain method: a new standard for modal parameter estimation? Shock and
Vibration 11, 395-409.

Guillaume, P., Verboven, P., Vanlanduit, S., Van der Auweraer, H., Peeters, B.
(2003). A poly-reference implementation of the least-squares complex frequency-domain
estimator. Proc. IMAC XXI.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from exudyn_study.errors import InputError
from exudyn_study.identify._checks import as_frf, band_mask, callable_module

__all__ = ["Poles", "polymax", "pole_to_modal", "modal_to_pole", "STABILITY_DEFAULTS"]

#: default stability tolerances: relative frequency, relative damping, 1 - MAC of vectors
STABILITY_DEFAULTS = {"tol_frequency": 0.01, "tol_damping": 0.05, "tol_vector": 0.02}
#: a band is shifted in the z-domain model so that it starts at this fraction of its width above
#: 0 Hz (see :func:`polymax`); bands starting lower are fitted as they are
SHIFT_MARGIN = 0.1


def pole_to_modal(pole: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Return undamped natural frequency in Hz and damping ratio of continuous poles.

    Parameters
    ----------
    pole : array_like of complex
        Poles :math:`\lambda = -\zeta\omega_n + j\omega_n\sqrt{1-\zeta^2}` in rad/s.

    Returns
    -------
    frequency_hz, damping_ratio : ndarray
        :math:`|\lambda| / 2\pi` and :math:`-\mathrm{Re}\,\lambda / |\lambda|`.
    """
    pole = np.asarray(pole, dtype=complex)
    wn = np.abs(pole)
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = -pole.real / wn
    return wn / (2 * np.pi), zeta


def modal_to_pole(frequency_hz, damping_ratio) -> np.ndarray:
    r"""Return the continuous pole (upper half plane, rad/s) of a mode.

    Parameters
    ----------
    frequency_hz : array_like
        Undamped natural frequency in Hz.
    damping_ratio : array_like
        Viscous damping ratio (-), below 1.

    Returns
    -------
    ndarray of complex
        :math:`-\zeta\omega_n + j\omega_n\sqrt{1-\zeta^2}`.
    """
    wn = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
    zeta = np.asarray(damping_ratio, dtype=float)
    return -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)


@dataclass(frozen=True, eq=False)
class Poles:
    """All poles of a PolyMAX run over model orders, flat (one row per pole).

    Attributes
    ----------
    order : ndarray of int, shape (n_poles,)
        Model order p (denominator degree) the pole belongs to.
    pole : ndarray of complex, shape (n_poles,)
        Continuous-time pole in rad/s (upper half plane only).
    frequency_hz, damping_ratio : ndarray, shape (n_poles,)
        Undamped natural frequency (Hz) and damping ratio (-) of the pole.
    vector : ndarray of complex, shape (n_poles, n_vector)
        Participation vector (n_vector = n_in) when there are several references,
        else the numerator mode-shape estimate (n_vector = n_out).
    stable_frequency, stable_damping, stable_vector : ndarray of bool, shape (n_poles,)
        Stability against the nearest pole of the previous order (frequency within
        ``tol_frequency``; damping and vector only count where frequency is stable).
    orders : tuple of int
        The model orders that were computed, ascending.
    band_hz : tuple of float
        Fitted band (fmin, fmax) in Hz.
    tolerances : dict
        The stability tolerances used.
    vector_kind : str
        'participation' or 'shape'.
    resolution_hz : float or None
        Line spacing of the fitted FRFs in Hz.
    """

    order: np.ndarray
    pole: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    vector: np.ndarray
    stable_frequency: np.ndarray
    stable_damping: np.ndarray
    stable_vector: np.ndarray
    orders: tuple[int, ...]
    band_hz: tuple[float, float]
    tolerances: dict
    vector_kind: str
    resolution_hz: float | None = None

    @property
    def stable(self) -> np.ndarray:
        """Poles stable in frequency, damping and vector, with 0 < damping < 1."""
        return (
            self.stable_frequency
            & self.stable_damping
            & self.stable_vector
            & (self.damping_ratio > 0)
            & (self.damping_ratio < 1)
        )

    @property
    def symbol(self) -> np.ndarray:
        """Testlab-like stability symbol per pole: 'o', 'f', 'd', 'v' or 's'."""
        sym = np.full(self.order.shape, "o", dtype="<U1")
        sym[self.stable_frequency] = "f"
        sym[self.stable_frequency & self.stable_damping] = "d"
        sym[self.stable_frequency & self.stable_vector] = "v"
        sym[self.stable] = "s"
        return sym

    def at_order(self, order: int) -> np.ndarray:
        """Return the indices of the poles of one model order."""
        return np.flatnonzero(self.order == order)

    def subset(self, index) -> Poles:
        """Return a :class:`Poles` holding only the poles ``index`` (mask or indices)."""
        fields = ("order", "pole", "frequency_hz", "damping_ratio", "vector",
                  "stable_frequency", "stable_damping", "stable_vector")
        return dataclasses.replace(self, **{f: getattr(self, f)[index] for f in fields})


def _mac_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC between matching rows of two complex arrays ``a[n, m]``, ``b[n, m]``."""
    num = np.abs(np.sum(np.conj(a) * b, axis=-1)) ** 2
    den = np.sum(np.abs(a) ** 2, axis=-1) * np.sum(np.abs(b) ** 2, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, 0.0)


def _lag_sums(frf_w: np.ndarray, z: np.ndarray, pmax: int):
    """Toeplitz generators of the reduced normal equations.

    Returns ``r0[m]``, ``q[o, i, m]`` and ``t[i, j, m]`` for lags m = -pmax..pmax
    (index m + pmax): sums over frequency of z^m, z^m H_oi and z^m sum_o conj(H_oi) H_oj.
    """
    lags = np.arange(-pmax, pmax + 1)
    zl = z[:, None] ** lags[None, :]  # [nf, 2p+1]
    r0 = zl.sum(axis=0)
    q = frf_w @ zl  # [n_out, n_in, 2p+1]
    p_ij = np.einsum("oik,ojk->ijk", np.conj(frf_w), frf_w)
    t = p_ij @ zl
    return r0, q, t


def _inverse_sqrt(r: np.ndarray) -> np.ndarray:
    """Return W with ``W @ W.T`` = inverse (or pseudo-inverse) of the SPD matrix ``r``.

    Cholesky when ``r`` is well conditioned; otherwise (a narrow band maps onto a
    short arc of the unit circle and the z^r basis becomes nearly dependent at high
    order) an eigen-decomposition dropping eigenvalues below 1e-12 of the largest.
    """
    try:
        c = np.linalg.cholesky(r)
        w = scipy.linalg.solve_triangular(c, np.eye(r.shape[0]), lower=True).T
        if np.all(np.isfinite(w)) and np.linalg.cond(c) < 1e7:
            return w
    except np.linalg.LinAlgError:
        pass
    lam, v = np.linalg.eigh(r)
    keep = lam > 1e-12 * lam.max()
    return v[:, keep] / np.sqrt(lam[keep])


def _toeplitz_index(n: int) -> np.ndarray:
    """Index array ``[r, s] -> (s - r) + (n - 1)`` for lags stored from -(n-1)."""
    r = np.arange(n)
    return r[None, :] - r[:, None] + (n - 1)


def polymax(
    frf: np.ndarray,
    freq_hz: np.ndarray,
    orders: Iterable[int] = range(2, 41),
    *,
    band_hz: tuple[float, float] | None = None,
    weights: np.ndarray | None = None,
    tol_frequency: float = STABILITY_DEFAULTS["tol_frequency"],
    tol_damping: float = STABILITY_DEFAULTS["tol_damping"],
    tol_vector: float = STABILITY_DEFAULTS["tol_vector"],
) -> Poles:
    """Estimate poles over model orders with PolyMAX (poly-reference LSCF).

    Parameters
    ----------
    frf : ndarray of complex, shape (n_out, n_in, n_freq)
        FRF matrix (any consistent unit, e.g. (m/s^2)/(m/s^2) transmissibilities).
    freq_hz : ndarray, shape (n_freq,)
        Equidistant frequency lines in Hz.
    orders : iterable of int, optional
        Model orders p (degree of the matrix denominator; p * n_in poles each,
        half of them in the upper half plane). Default 2..40.
    band_hz : (float, float), optional
        Band (fmin, fmax) in Hz to fit; default all lines above 0 Hz.
    weights : ndarray, shape (n_out,), optional
        Weight per output; default 1 / rms(|H_o|) over the band, so that every
        channel counts equally whatever its amplitude.
    tol_frequency, tol_damping, tol_vector : float, optional
        Stability tolerances: relative frequency change, relative damping change,
        and 1 - MAC of the pole vectors between consecutive orders.

    Returns
    -------
    Poles
        Poles of all orders with stability flags.

    Raises
    ------
    InputError
        On inconsistent shapes, non-finite FRFs, non-equidistant or too few lines,
        a band outside the data, or invalid orders/tolerances.

    Notes
    -----
    The sampling time of the z-domain model is ``1 / (2 fmax)`` so that the band
    maps onto the upper half of the unit circle. A band that starts above a tenth of its
    width (:data:`SHIFT_MARGIN`) is first shifted down to start there (the poles are shifted
    back): mapped as it is, a narrow band far from 0 Hz covers a short arc on which the
    real-coefficient basis ``z^r`` is nearly dependent at high order (30-50 Hz at order 30:
    condition number 1.8e14), and the diagram then follows the round-off of the linear
    algebra (the BLAS kernel and thread count). The reduced normal matrices are
    Toeplitz in the polynomial index and are built once for the highest order from
    lag sums; every order is a leading sub-block.

    References
    ----------
    Peeters et al. (2004), Shock and Vibration 11, 395-409.
    """
    frf, freq_hz = as_frf(frf, freq_hz)
    orders = sorted({int(p) for p in orders})
    if not orders or orders[0] < 1:
        raise InputError(f"orders {orders!r}: expected model orders >= 1")
    for name, tol in (("tol_frequency", tol_frequency), ("tol_damping", tol_damping),
                      ("tol_vector", tol_vector)):
        if not (np.isfinite(tol) and tol > 0):
            raise InputError(f"{name}={tol!r}: expected a positive number")
    sel = band_mask(freq_hz, band_hz)
    f = freq_hz[sel]
    h = frf[:, :, sel]
    n_out, n_in, nf = h.shape
    pmax = orders[-1]
    if nf * n_out < 2 * (pmax + 1):
        raise InputError(
            f"orders up to {pmax}: the band {f[0]:.4g}-{f[-1]:.4g} Hz holds {nf} lines for "
            f"{n_out} outputs, too few; lower the maximum order or widen the band"
        )
    if weights is None:
        rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=(1, 2)))
        weights = np.where(rms > 0, 1.0 / np.where(rms > 0, rms, 1.0), 0.0)
    else:
        weights = np.asarray(weights, dtype=float)
        if weights.shape != (n_out,) or not np.all(np.isfinite(weights)) or np.any(weights < 0):
            raise InputError(
                f"weights of shape {weights.shape}: expected {n_out} finite non-negative values"
            )
    # the z-domain model: z = exp(j 2 pi (f - shift) dt), dt = 1 / (2 (fmax - shift)); a band far from
    # 0 Hz is shifted (see Notes), a pole lam' of the shifted model is lam' + j 2 pi shift
    shift_hz = max(0.0, f[0] - SHIFT_MARGIN * (f[-1] - f[0]))
    dt = 1.0 / (2.0 * (f[-1] - shift_hz))
    z = np.exp(1j * 2 * np.pi * (f - shift_hz) * dt)

    hw = h * weights[:, None, None]
    r0, q_w, t_l = _lag_sums(hw, z, pmax)
    q_raw = h @ (z[:, None] ** np.arange(-pmax, pmax + 1)[None, :])

    rows = []
    prev = None
    for p in orders:
        n1 = p + 1
        qdim = n1 * n_in
        lag = _toeplitz_index(n1) + (pmax - p)  # -> into arrays with lags from -pmax
        r_mat = np.real(r0[lag])  # [n1, n1]
        # S_o[r, (s, j)] = -Re sum_k z^(s-r) w_o H_oj ; layout [n1, n_out, n1, n_in]
        s_w = -np.real(q_w[:, :, lag]).transpose(2, 0, 3, 1)
        t_mat = np.real(t_l[:, :, lag]).transpose(2, 0, 3, 1).reshape(qdim, qdim)
        w_half = _inverse_sqrt(r_mat)  # R^+ = W W^T
        g = (w_half.T @ s_w.reshape(n1, -1)).reshape(-1, n_out, qdim)
        m_mat = t_mat - np.einsum("rok,rol->kl", g, g)
        pn = p * n_in
        try:
            a_low = -np.linalg.solve(m_mat[:pn, :pn], m_mat[:pn, pn:])
        except np.linalg.LinAlgError:
            a_low = -np.linalg.lstsq(m_mat[:pn, :pn], m_mat[:pn, pn:], rcond=None)[0]
        alpha = np.vstack([a_low, np.eye(n_in)]).reshape(n1, n_in, n_in)  # alpha[r]
        # block companion matrix (eigenvalues = roots of det D(z))
        comp = np.zeros((pn, pn))
        if p > 1:
            comp[: pn - n_in, n_in:] = np.eye(pn - n_in)
        comp[pn - n_in:, :] = -np.concatenate([alpha[r] for r in range(p)], axis=1)
        zr = np.linalg.eigvals(comp)
        zr = zr[np.isfinite(zr) & (np.abs(zr) > 0)]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            lam_model = np.log(zr) / dt
        lam = lam_model + 2j * np.pi * shift_hz
        fr, zeta = pole_to_modal(lam)
        keep = (lam_model.imag > 0) & (fr >= f[0]) & (fr <= f[-1])
        zr, lam, fr, zeta = zr[keep], lam[keep], fr[keep], zeta[keep]
        order_idx = np.argsort(fr)
        zr, lam, fr, zeta = zr[order_idx], lam[order_idx], fr[order_idx], zeta[order_idx]
        # vectors: right/left null vectors of D(z_k)
        dz = np.einsum("rij,kr->kij", alpha, zr[:, None] ** np.arange(n1)[None, :])
        if n_in > 1:
            u, _, vh = np.linalg.svd(dz)
            right = np.conj(vh[:, -1, :])  # D l = 0
            left = np.conj(u[:, :, -1])  # m^H D = 0 -> participation (input side)
        else:
            right = np.ones((len(zr), 1), complex)
            left = right
        if n_in > 1:
            vec = left
        else:
            # beta_o = -R^-1 S'_o alpha with unweighted S'
            s_raw = -np.real(q_raw[:, :, lag]).transpose(2, 0, 3, 1).reshape(n1, n_out * qdim)
            b = -(w_half @ (w_half.T @ s_raw)).reshape(n1, n_out, n1 * n_in)
            beta = b @ alpha.reshape(qdim, n_in)  # [n1, n_out, n_in]
            numer = np.einsum("roi,kr->koi", beta, zr[:, None] ** np.arange(n1)[None, :])
            vec = np.einsum("koi,ki->ko", numer, right)
        sf = np.zeros(len(lam), bool)
        sd = np.zeros(len(lam), bool)
        sv = np.zeros(len(lam), bool)
        if prev is not None and len(prev[0]) and len(lam):
            pf, pz, pv = prev
            near = np.argmin(np.abs(fr[:, None] - pf[None, :]), axis=1)
            sf = np.abs(fr - pf[near]) <= tol_frequency * fr
            with np.errstate(invalid="ignore", divide="ignore"):
                sd = sf & (np.abs(zeta - pz[near]) <= tol_damping * np.abs(zeta))
            sv = sf & (1.0 - _mac_rows(vec, pv[near]) <= tol_vector)
        prev = (fr, zeta, vec)
        rows.append((np.full(len(lam), p), lam, fr, zeta, vec, sf, sd, sv))

    cat = [np.concatenate([r[i] for r in rows]) for i in range(8)]
    n_vec = n_in if n_in > 1 else n_out
    vectors = cat[4].reshape(-1, n_vec) if cat[4].size else np.zeros((0, n_vec), complex)
    return Poles(
        order=cat[0].astype(int),
        pole=cat[1].astype(complex),
        frequency_hz=cat[2].astype(float),
        damping_ratio=cat[3].astype(float),
        vector=vectors,
        stable_frequency=cat[5].astype(bool),
        stable_damping=cat[6].astype(bool),
        stable_vector=cat[7].astype(bool),
        orders=tuple(orders),
        band_hz=(float(f[0]), float(f[-1])),
        tolerances={"tol_frequency": tol_frequency, "tol_damping": tol_damping,
                    "tol_vector": tol_vector},
        vector_kind="participation" if n_in > 1 else "shape",
        resolution_hz=float(np.median(np.diff(f))) if f.size > 1 else None,
    )


# calling the module calls the function (see _checks.callable_module)
callable_module(__name__, polymax)
