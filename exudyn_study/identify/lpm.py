"""FRF estimation by local rational / polynomial models (LRM, LPM): no leakage, no window bias.

A Welch estimate (:mod:`exudyn_study.identify.frf`) cuts the record into windowed segments.
At a lightly damped resonance whose half-power bandwidth ``2 zeta f`` is of the order of the
line spacing, the window smears the peak (an 0.4 %-damped mode at 12 Hz has a bandwidth of
0.1 Hz; a 16 s Hann segment has 0.06 Hz lines) and the response to input from before the
segment leaks in. Both errors are systematic and do not average away.

The LPM (Pintelon, Schoukens et al. 2010) takes one DFT of the whole record instead and, in a
small band of ``2 n + 1`` lines around every line ``k``, fits

    Y(k + r) = H(k + r) U(k + r) + T(k + r),   r = -n .. n,

with ``H`` and ``T`` polynomials of degree ``R`` in ``r``. ``T`` is the transient (leakage)
term: the difference between the response's initial and final state seen by the DFT, a
smooth function of frequency. Its estimate ``H(k)`` is free of leakage to the order of the
polynomial; the line spacing is ``1 / T_record`` (0.0127 Hz for 79 s), so the local band is
narrow against any modal bandwidth. The residual of the local fit gives the noise variance of
``H(k)`` per line, from which a coherence-like quality measure follows.

A polynomial cannot follow a peak narrower than its band: for a 0.3 %-damped mode at 12 Hz
(7 lines wide at 0.0125 Hz) a degree-2 LPM over 9 lines is 0.74 dB low at the peak. The local
rational method (McKelvey and Guérin 2012) fits ``H = N / D`` and ``T = M / D`` instead, linear
in the coefficients after multiplying by ``D`` (``D(0) = 1``):

    D(r) Y(k + r) = N(r) U(k + r) + M(r),    H(k) = N(0),

which is exact for a resonance inside the band. It is the default (``method='lrm'``); with
output noise its estimate is slightly biased (``Y`` appears on both sides), the LPM is not.

One reference is fitted at a time: with several references that are responses to one common
drive (the thesis's ``ARFVZ``/``ARFHZ``), ``H[:, i, :]`` uses reference ``i`` alone, as the
Welch estimators' ``mimo=False``.

References
----------
Pintelon, R., Schoukens, J., Vandersteen, G., Barbé, K. (2010). Estimation of nonparametric
noise and FRF models for multivariable systems - Part I: theory. Mechanical Systems and Signal
Processing 24(3), 573-595.

McKelvey, T., Guérin, G. (2012). Non-parametric frequency response estimation using a local
rational model. IFAC Proceedings 45(16), 49-54.
"""

from __future__ import annotations

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.identify.frf import FRF, _check_time

__all__ = ["estimate_frf_lpm"]


def estimate_frf_lpm(
    reference,
    response,
    sample_rate_hz: float,
    *,
    half_width: int = 4,
    degree: int = 2,
    fmin_hz: float = 0.0,
    fmax_hz: float | None = None,
    skip_s: float = 0.0,
    method: str = "lrm",
    outputs: tuple[str, ...] = (),
    inputs: tuple[str, ...] = (),
) -> FRF:
    """Estimate FRFs from one record by the local rational (default) or polynomial method.

    Parameters
    ----------
    reference : ndarray, shape (n_in, n_samples) or (n_samples,)
        Reference (input) time data, e.g. the drive displacement in m.
    response : ndarray, shape (n_out, n_samples)
        Response time data, e.g. accelerations in m/s^2.
    sample_rate_hz : float
        Sampling rate of both, in Hz.
    half_width : int, optional
        ``n``: the local band has ``2 n + 1`` lines (default 4). Needs more lines
        than parameters: ``2 n + 1 > 2 (R + 1)`` (LPM), ``> 3 R + 2`` (LRM).
    degree : int, optional
        ``R``: degree of the local polynomials ``N``, ``M`` (and ``D``) (default 2).
    method : {'lrm', 'lpm'}, optional
        Local rational (default) or local polynomial model.
    fmin_hz, fmax_hz : float, optional
        Frequency range of the result (default 0 to Nyquist).
    skip_s : float, optional
        Seconds dropped at the start (e.g. a drive ramp); the transient term handles the rest.
    outputs, inputs : tuple of str, optional
        Channel names carried into the result.

    Returns
    -------
    FRF
        ``estimator='LRM'`` or ``'LPM'``, ``resolution_hz = fs / n_samples``, ``n_averages = 1``,
        ``window='none'``; ``coherence`` is ``1 - noise / total`` power of the local fit
        (1 for a noise-free linear system).

    Raises
    ------
    InputError
        Non-finite data, different lengths, a bad rate, or a local band too small for the
        polynomial degree.
    """
    u = _check_time(reference, "reference")
    y = _check_time(response, "response")
    if not (np.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise InputError(f"sample_rate_hz {sample_rate_hz!r}: expected a finite rate > 0 Hz")
    if u.shape[1] != y.shape[1]:
        raise InputError(
            f"reference has {u.shape[1]} samples, response {y.shape[1]}: expected records of the same length"
        )
    if method not in ("lrm", "lpm"):
        raise InputError(f"method {method!r}: expected 'lrm' (local rational) or 'lpm' (local polynomial)")
    n_par = 2 * (degree + 1) + (degree if method == "lrm" else 0)
    n_lines = 2 * half_width + 1
    if degree < 0 or n_lines <= n_par:
        raise InputError(
            f"LPM half_width {half_width} and degree {degree}: the {n_lines} local lines must exceed the "
            f"{n_par} parameters; use a larger half_width"
        )
    k0 = int(round(skip_s * sample_rate_hz))
    u, y = u[:, k0:], y[:, k0:]
    n_samples = u.shape[1]
    spectrum_u = np.fft.rfft(u, axis=1)
    spectrum_y = np.fft.rfft(y, axis=1)
    freq = np.fft.rfftfreq(n_samples, 1.0 / sample_rate_hz)
    fmax = freq[-1] if fmax_hz is None else float(fmax_hz)
    lines = np.flatnonzero((freq >= fmin_hz) & (freq <= fmax))
    lines = lines[(lines >= half_width) & (lines < freq.size - half_width)]
    if lines.size == 0:
        raise InputError(
            f"LPM: no frequency line in {fmin_hz}-{fmax} Hz; widen the range or use a longer record"
        )

    offsets = np.arange(-half_width, half_width + 1)
    powers = np.vander(offsets, degree + 1, increasing=True).astype(complex)  # (L, R+1)
    idx = lines[:, None] + offsets[None, :]  # (K, L)
    n_out, n_in = y.shape[0], u.shape[0]
    h = np.empty((n_out, n_in, lines.size), dtype=complex)
    coherence = np.empty((n_out, n_in, lines.size))
    y_local = spectrum_y[:, idx]  # (n_out, K, L)
    dof = n_lines - n_par
    for i in range(n_in):
        u_local = spectrum_u[i, idx]  # (K, L)
        base = np.concatenate(
            [u_local[:, :, None] * powers[None], np.broadcast_to(powers, u_local.shape + (degree + 1,))],
            axis=2,
        )  # (K, L, 2 (R+1))
        if method == "lpm":
            regressor = np.broadcast_to(base, (n_out,) + base.shape)
        else:  # LRM: D(r) Y = N(r) U + M(r), D(0) = 1
            regressor = np.concatenate(
                [
                    np.broadcast_to(base, (n_out,) + base.shape),
                    -y_local[..., None] * powers[None, None, :, 1:],
                ],
                axis=3,
            )
        q, r = np.linalg.qr(regressor)  # (n_out, K, L, P), (n_out, K, P, P)
        coef = np.linalg.solve(r, np.conj(np.swapaxes(q, 2, 3)) @ y_local[..., None])[..., 0]  # (n_out, K, P)
        residual = y_local - (regressor @ coef[..., None])[..., 0]
        noise = np.sum(np.abs(residual) ** 2, axis=2) / dof  # (n_out, K)
        total = np.mean(np.abs(y_local) ** 2, axis=2)
        h[:, i] = coef[:, :, 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            coherence[:, i] = np.clip(1.0 - noise / total, 0.0, 1.0)
    return FRF(
        freq_hz=freq[lines],
        H=h,
        coherence=coherence,
        estimator=method.upper(),
        resolution_hz=float(sample_rate_hz / n_samples),
        n_averages=1,
        outputs=tuple(outputs),
        inputs=tuple(inputs),
        mimo=False,
        sample_rate_hz=float(sample_rate_hz),
        window="none",
    )
