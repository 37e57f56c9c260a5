"""Responses of the linearised system without time integration in Exudyn.

:func:`simulate_linear` integrates the system *exactly* on the drive's cubic spline (one
matrix exponential of the augmented system per fine interval; a generalisation of
first-order hold), :func:`frf_linear` gives the drive -> sensor-acceleration FRFs by complex
modal superposition, and :func:`frf_linear_at_resolution` the FRF a Welch estimate with a
given window expects.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla
from scipy import signal as sps

from exudyn_study.linear.system import spline_inputs, state_space


def simulate_linear(lin, drive, chunk: int = 8192) -> np.ndarray:
    """Exact sampled sensor accelerations of the linearised model, shape (n_sensors, N).

    Parameters
    ----------
    lin : exudyn_study.linear.modes.LinearSystem
    drive : exudyn_study.model.Drive
        With its signal set; outputs at its sample instants. The input over an output
        interval is the sum of its ``drive.upsampling`` fine cubics, each through the
        exact map of its fine interval.
    chunk : int
        Samples per block (memory bound).
    """
    a, b, c, d = state_space(lin)
    factor = int(round(drive.spline_rate_hz / drive.sample_rate_hz))
    h = 1.0 / drive.spline_rate_hz
    m2 = a.shape[0]
    big = np.zeros((m2 + 4, m2 + 4))
    big[:m2, :m2], big[:m2, m2:] = a, b
    big[m2, m2 + 1] = big[m2 + 1, m2 + 2] = big[m2 + 2, m2 + 3] = 1.0
    e = sla.expm(big * h)
    gamma = e[:m2, m2:]
    lam, v = sla.eig(a)
    mu = np.exp(lam * h)
    vinv_gamma = np.linalg.solve(v, gamma)
    cv = c @ v
    # complex-conjugate pairs: keep Im >= 0, weight 2 for Im > 0 (the output is real)
    keep = lam.imag >= 0.0
    weight = np.where(lam.imag > 0.0, 2.0, 1.0)[keep]
    mu, vinv_gamma, cv = mu[keep], vinv_gamma[keep], cv[:, keep] * weight
    # over one output interval: xi <- mu^factor xi + sum_j mu^(factor-1-j) V^-1 Gamma psi(fine knot j)
    to_end = mu[:, None] ** np.arange(factor - 1, -1, -1)  # (modes, factor)
    vinv_gamma = (to_end[:, :, None] * vinv_gamma[:, None, :]).reshape(mu.size, factor * 4)
    mu = mu**factor
    psi_fine = spline_inputs(drive)
    psi = psi_fine[:, ::factor]  # at the output instants
    n_t = psi.shape[1]
    out = np.empty((c.shape[0], n_t))
    xi = np.zeros(mu.size, dtype=complex)
    for k0 in range(0, n_t, chunk):
        k1 = min(n_t, k0 + chunk)
        # psi at the fine knots of each output interval, (L, factor, 4); none after the last sample
        m = min(k1, n_t - 1) - k0
        fine = np.zeros((k1 - k0, factor, 4))
        fine[:m] = psi_fine[:, k0 * factor: (k0 + m) * factor].T.reshape(m, factor, 4)
        g = vinv_gamma @ fine.reshape(k1 - k0, factor * 4).T  # (modes, L)
        states = np.empty_like(g)
        for j in range(mu.size):
            w, _ = sps.lfilter([1.0], [1.0, -mu[j]], g[j], zi=[mu[j] * xi[j]])
            states[j, 0] = xi[j]
            states[j, 1:] = w[:-1]
            xi[j] = w[-1]
        out[:, k0:k1] = (cv @ states).real + d @ psi[:, k0:k1]
    return out


def frf_linear(lin, frequencies_hz) -> np.ndarray:
    """Drive displacement -> sensor acceleration FRFs by complex modal superposition.

    Parameters
    ----------
    lin : LinearSystem
        The linearised system.
    frequencies_hz : array_like, shape (n_freq,)
        Frequencies (Hz).

    Returns
    -------
    ndarray, complex, shape (n_sensors, 1, n_freq)
        ``H[n_out, n_in, n_freq]`` in (m/s^2)/m.
    """
    f = np.asarray(frequencies_hz, dtype=float)
    a, b, c, d = state_space(lin)
    lam, v = sla.eig(a)
    g = np.linalg.solve(v, b)
    cv = c @ v
    w = 2.0 * np.pi * f
    s = 1j * w
    psi = np.vstack([np.ones_like(s), s, s**2, s**3])  # (4, n_f)
    modal = (g @ psi) / (s[None, :] - lam[:, None])
    return (cv @ modal + d @ psi)[:, None, :]


# --------------------------------------------------------------------------------------- checks
def modal_initial_state(modes, index: int, amplitude: float = 1e-4):
    """(z0, v0) that start the free vibration of damped mode ``index`` alone.

    ``z(t) = Re(a phi exp(lambda t))``: ``z0 = Re(a phi)``, ``v0 = Re(a lambda phi)``
    with ``phi`` the mode's coordinates (:attr:`SystemModes.coordinates`).

    Parameters
    ----------
    modes : SystemModes
        Damped modes of the linearised system.
    index : int
        Index of the mode (0-based, in ``modes`` order).
    amplitude : float
        Largest modulus of the scaled mode coordinates (m or rad, per coordinate).

    Returns
    -------
    z0, v0 : ndarray, shape (n,)
        Initial coordinates and velocities of the linearised system.
    """
    phi = np.asarray(modes.coordinates)[:, index]
    phi = amplitude * phi / np.abs(phi).max()
    w = 2.0 * np.pi * modes.frequency_hz[index]
    z = modes.damping_ratio[index]
    lam = complex(-z * w, w * math.sqrt(max(1.0 - z * z, 0.0)))
    return phi.real.copy(), (lam * phi).real.copy()


def free_decay_linear(lin, initial_state, n_samples: int, rate_hz: float = 1000.0) -> np.ndarray:
    """Exact sampled sensor accelerations of the unforced linear system from ``(z0, v0)``.

    Parameters
    ----------
    lin : LinearSystem
        The linearised system (``n = lin.size`` coordinates).
    initial_state : tuple of two array_like, shape (n,)
        ``(z0, v0)``: initial coordinates and velocities (e.g. :func:`modal_initial_state`).
    n_samples : int
        Number of output samples, the first at t = 0.
    rate_hz : float
        Output sample rate (Hz).

    Returns
    -------
    ndarray, shape (n_sensors, n_samples)
        Sensor accelerations (m/s^2); the drive is at rest.
    """
    a, _, c, _ = state_space(lin)
    x0 = np.concatenate([np.asarray(initial_state[0], float), np.asarray(initial_state[1], float)])
    lam, v = sla.eig(a)
    xi0 = np.linalg.solve(v, x0)
    t = np.arange(n_samples) / rate_hz
    return ((c @ v) @ (xi0[:, None] * np.exp(lam[:, None] * t[None, :]))).real


def frf_linear_at_resolution(lin, frequencies_hz, nperseg: int = 16384, rate_hz: float = 1000.0,
                             oversample: int = 16, half_width_bins: int = 6) -> np.ndarray:
    """Modal FRF as a Welch H1 estimate with a Hann window of ``nperseg`` samples sees it.

    For a white drive, the expected cross spectrum is the true one convolved with the
    window's power kernel ``|W(f)|^2``, and the drive's spectrum is flat, so the expected
    H1 is ``sum_d |W(d)|^2 H(f + d) / sum_d |W(d)|^2``. Comparing an estimate with this
    separates estimator bias at lightly damped peaks (half-power bandwidth of the order of
    the resolution) from disagreement between simulation and model.

    Parameters
    ----------
    lin : LinearSystem
        The linearised system.
    frequencies_hz : array_like, shape (n_freq,)
        Frequencies (Hz) of the estimate.
    nperseg : int
        Welch segment length (samples).
    rate_hz : float
        Sample rate of the estimate (Hz).
    oversample : int
        Points of the window kernel per frequency line.
    half_width_bins : int
        Half width of the kernel's main part kept in the convolution (frequency lines).

    Returns
    -------
    ndarray, complex, shape (n_sensors, n_freq)
        Expected H1 in (m/s^2)/m.
    """
    f = np.asarray(frequencies_hz, dtype=float)
    df = rate_hz / nperseg
    w = sps.get_window("hann", nperseg)
    kern = np.abs(np.fft.fft(w, oversample * nperseg)) ** 2
    m = half_width_bins * oversample
    kern = np.concatenate([kern[-m:], kern[: m + 1]])
    delta = np.arange(-m, m + 1) * df / oversample
    grid = (f[:, None] + delta[None, :]).ravel()
    h = frf_linear(lin, np.abs(grid))[:, 0, :].reshape(-1, f.size, delta.size)
    h = np.where((f[:, None] + delta[None, :] < 0)[None], np.conj(h), h)
    return (h * kern[None, None, :]).sum(axis=2) / kern.sum()
