"""Accuracy measures for simulated recordings: the tests and benchmarks compare the paths with these.

Band-limited RMS error against a reference, the logarithmic decrement of a free decay, a
Welch H1 FRF in the simulation's array layout and the largest dB error between an FRF
estimate and the model's FRF outside antiresonances.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal as sps

from exudyn_study.errors import InputError
from exudyn_study.simulate.drive import OUTPUT_RATE_HZ


def band_limited_rms_error(
    x, reference, rate_hz: float = OUTPUT_RATE_HZ, f_max_hz: float = 70.0
) -> np.ndarray:
    """Relative rms error per channel of ``x`` vs ``reference`` below ``f_max_hz`` (FFT band limit).

    Parameters
    ----------
    x : array_like, shape (n_channels, n_samples)
        The signal to judge (1-D: one channel).
    reference : array_like, shape (n_channels, n_samples)
        The reference, same units and sampling.
    rate_hz : float
        Sample rate (Hz).
    f_max_hz : float
        Highest frequency of the comparison (Hz).

    Returns
    -------
    ndarray, shape (n_channels,)
        ``||X - R|| / ||R||`` over the FFT lines up to ``f_max_hz`` (dimensionless).
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    r = np.atleast_2d(np.asarray(reference, dtype=float))
    f = np.fft.rfftfreq(x.shape[1], 1.0 / rate_hz)
    mask = f <= f_max_hz
    ex = np.fft.rfft(x - r, axis=1)[:, mask]
    er = np.fft.rfft(r, axis=1)[:, mask]
    return np.sqrt(np.sum(np.abs(ex) ** 2, axis=1) / np.sum(np.abs(er) ** 2, axis=1))


def log_decrement_damping(x, rate_hz: float = OUTPUT_RATE_HZ, skip_cycles: int = 2,
                          n_cycles: int | None = None) -> tuple[float, float]:
    """Damping ratio and frequency of a single-mode free decay by the logarithmic decrement.

    Positive peaks are located with parabolic interpolation, then ``ln(peak)`` is fitted
    linearly against peak time: slope ``-sigma``, mean spacing ``T_d``; the decrement per
    cycle ``delta = sigma T_d`` gives ``zeta = delta / sqrt(4 pi^2 + delta^2)``.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        The free decay (any unit).
    rate_hz : float
        Sample rate (Hz).
    skip_cycles : int
        Positive peaks left out at the start (the decay of other modes and the release).
    n_cycles : int, optional
        Peaks used after the skipped ones (default: all).

    Returns
    -------
    zeta : float
        Damping ratio.
    frequency_hz : float
        Undamped natural frequency ``f_d / sqrt(1 - zeta^2)``.
    """
    x = np.asarray(x, dtype=float)
    k = np.flatnonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:]) & (x[1:-1] > 0)) + 1
    if k.size < skip_cycles + 4:
        raise InputError(f"free decay with {k.size} positive peaks; expected at least {skip_cycles + 4}")
    y0, y1, y2 = x[k - 1], x[k], x[k + 1]
    den = y0 - 2.0 * y1 + y2
    off = np.where(den != 0, 0.5 * (y0 - y2) / np.where(den != 0, den, 1.0), 0.0)
    peak = y1 - 0.25 * (y0 - y2) * off
    tp = (k + off) / rate_hz
    sel = slice(skip_cycles, None if n_cycles is None else skip_cycles + n_cycles)
    tp, peak = tp[sel], peak[sel]
    slope, _ = np.polyfit(tp, np.log(peak), 1)
    td = float(np.mean(np.diff(tp)))
    delta = -slope * td
    zeta = delta / math.sqrt(4.0 * math.pi**2 + delta**2)
    return float(zeta), float(1.0 / td / math.sqrt(1.0 - zeta**2))


def estimate_frf(drive, accelerations, rate_hz: float = OUTPUT_RATE_HZ, nperseg: int = 16384,
                 skip_s: float = 1.0, overlap: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """H1 estimate (Welch, Hann, ``overlap``) of drive -> each acceleration channel.

    Parameters
    ----------
    drive : array_like, shape (n_samples,)
        Drive displacement (m), sampled with the accelerations.
    accelerations : array_like, shape (n_channels, n_samples)
        Sensor accelerations (m/s^2).
    rate_hz : float
        Sample rate (Hz).
    nperseg : int
        Welch segment length (samples).
    skip_s : float
        Initial time left out (s): the transient from rest.
    overlap : float
        Segment overlap as a fraction of ``nperseg``, in [0, 1).

    Returns
    -------
    f : ndarray, shape (n_f,)
        Frequencies (Hz).
    H : ndarray, complex, shape (n_channels, n_f)
        H1 in (m/s^2)/m.
    """
    k0 = int(round(skip_s * rate_hz))
    u = np.asarray(drive, dtype=float)[k0:]
    y = np.atleast_2d(np.asarray(accelerations, dtype=float))[:, k0:]
    nov = int(overlap * nperseg)
    f, suu = sps.welch(u, rate_hz, nperseg=nperseg, noverlap=nov)
    _, suy = sps.csd(u[None, :], y, rate_hz, nperseg=nperseg, noverlap=nov)
    return f, suy / suu[None, :]


def frf_db_error(h_est, h_model, f, band_hz=(3.5, 59.0), antiresonance_db: float = 6.0,
                 exclude_hz: float = 0.5, dynamic_range_db: float = 60.0, exclude_peaks_hz=()) -> np.ndarray:
    """Max |20 log10 |H_est / H_model|| per channel in ``band_hz`` outside antiresonances.

    A frequency counts as near an antiresonance when it is within ``exclude_hz`` of a
    local minimum of ``|H_model|`` that lies ``antiresonance_db`` or more below the
    smaller of the maxima on either side, or when ``|H_model|`` is more than
    ``dynamic_range_db`` below the channel's maximum in the band (there the estimate is
    window leakage from the resonances, as in a measurement). The default band keeps
    clear of the drive's 3 and 60 Hz band edges, where the input power falls off.
    ``exclude_peaks_hz``: resonances to leave out (``exclude_hz`` either side), e.g. those
    whose half-power bandwidth ``2 zeta f`` is narrower than the estimate's resolution,
    where any windowed estimate is biased low.

    Parameters
    ----------
    h_est : array_like, complex, shape (n_channels, n_f)
        The FRF estimate.
    h_model : array_like, complex, shape (n_channels, n_f)
        The model's FRF at the same frequencies, same units.
    f : array_like, shape (n_f,)
        Frequencies (Hz).
    band_hz : tuple of 2 float
        Compared band (Hz).
    antiresonance_db : float
        Depth (dB) below the smaller neighbouring maximum that makes a minimum an antiresonance.
    exclude_hz : float
        Half width (Hz) left out around antiresonances and ``exclude_peaks_hz``.
    dynamic_range_db : float
        Frequencies where ``|H_model|`` is this far (dB) below its maximum in the band are left out.
    exclude_peaks_hz : sequence of float
        Resonance frequencies (Hz) to leave out.

    Returns
    -------
    ndarray, shape (n_channels,)
        Largest absolute dB error per channel (NaN where no frequency is left).
    """
    f = np.asarray(f)
    h_est, h_model = np.atleast_2d(h_est), np.atleast_2d(h_model)
    band = (f >= band_hz[0]) & (f <= band_hz[1])
    out = np.empty(h_model.shape[0])
    for i in range(h_model.shape[0]):
        mag = 20.0 * np.log10(np.abs(h_model[i]) + 1e-300)
        ok = band & (mag >= mag[band].max() - dynamic_range_db)
        for fp in exclude_peaks_hz:
            ok &= np.abs(f - fp) > exclude_hz
        mins = np.flatnonzero((mag[1:-1] < mag[:-2]) & (mag[1:-1] <= mag[2:])) + 1
        for j in mins:
            left, right = mag[:j].max(initial=-np.inf), mag[j + 1:].max(initial=-np.inf)
            if min(left, right) - mag[j] >= antiresonance_db:
                ok &= np.abs(f - f[j]) > exclude_hz
        err = np.abs(20.0 * np.log10(np.abs(h_est[i, ok]) / np.abs(h_model[i, ok])))
        out[i] = err.max() if err.size else np.nan
    return out
