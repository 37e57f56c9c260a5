"""Compare stage, first half: FRFs per level that fit the excitation, the band and the resolution.

Periodic drive (a multisine): the record is cut into whole periods, the first one dropped
(the transient), and the DFTs of the periods averaged at the excited lines,
``H = mean(Y_p) / mean(U_p)``. The period-to-period scatter of ``Y_p - H U_p`` gives the
noise variance of ``H`` (errors in input and output included); the power at the lines the
drive does not excite, above their own noise, is nonlinear distortion, interpolated to
the neighbouring excited lines as the stochastic distortion level of ``H`` (Pintelon &
Schoukens 2012, Sections 2.6 and 3.7). Several realisations of a random-phase multisine recorded
one after the other (``LevelSettings.realisations``): each is estimated so, the FRF is their
mean, and the realisation-to-realisation scatter beyond the noise is the stochastic distortion,
which the mean reduces by the number of realisations (the robust method, Section 4.3).
Random drive: one local rational (LRM) estimate over
the whole record (no window, no leakage), or H1 Welch averages at a given resolution; the
standard error follows from the coherence (Bendat & Piersol 2010, eq. 9.90).

References
----------
Pintelon, R., Schoukens, J. (2012). System Identification: A Frequency Domain Approach, 2nd ed.,
Wiley-IEEE Press.
Bendat, J. S., Piersol, A. G. (2010). Random Data, 4th ed., Wiley.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from exudyn_study.diagnose.levels.settings import LevelSettings
from exudyn_study.errors import InputError
from exudyn_study.recording.types import Recording

__all__ = ["LevelFRF", "detect_period", "estimate_level_frf", "excited_band"]


@dataclass(frozen=True, eq=False)
class LevelFRF:
    """FRFs of one recording (one drive level) at its usable lines.

    Attributes
    ----------
    label : str
    level : float
        Drive rms in ``drive_unit`` over the analysed part of the record.
    freq_hz : ndarray, shape (n_freq,)
        Lines in Hz (the excited lines for a periodic drive).
    H : ndarray of complex, shape (n_out, n_freq)
        Response per drive (``response_unit / drive_unit``).
    sigma : ndarray, shape (n_out, n_freq)
        Standard deviation of ``H`` from noise.
    distortion : ndarray, shape (n_out, n_freq), or None
        Standard deviation of the stochastic nonlinear distortion (periodic drive with
        non-excited lines in the band), else None.
    U : ndarray of complex, shape (n_freq,)
        Drive amplitude per line (peak amplitude of the line's sinusoid, ``drive_unit``).
    excitation : {'periodic', 'random'}
    resolution_hz : float
    n_periods : int
        Periods averaged (periodic) or 1 (random LRM) or Welch averages.
    channels : tuple of str
    drive_unit, response_unit : str
    """

    label: str
    level: float
    freq_hz: np.ndarray
    H: np.ndarray
    sigma: np.ndarray
    distortion: np.ndarray | None
    U: np.ndarray
    excitation: str
    resolution_hz: float
    n_periods: int
    channels: tuple[str, ...]
    drive_unit: str
    response_unit: str

    @property
    def total_sigma(self) -> np.ndarray:
        """Noise and distortion together, shape (n_out, n_freq)."""
        if self.distortion is None:
            return self.sigma
        return np.hypot(self.sigma, self.distortion)

    def select(self, mask: np.ndarray) -> LevelFRF:
        """Return the same FRFs at the lines where ``mask`` is True.

        Every per-line array (``freq_hz``, ``H``, ``sigma``, ``distortion``, ``U``) is cut to the
        selected lines; the label, level, units, resolution and period count are kept.

        Parameters
        ----------
        mask : ndarray of bool, shape (n_freq,)
            True at the lines to keep, e.g. ``(freq_hz >= lo) & (freq_hz <= hi)`` for a band in Hz.

        Returns
        -------
        LevelFRF
            A new object at the selected lines (this one is unchanged).
        """
        d = None if self.distortion is None else self.distortion[:, mask]
        return LevelFRF(
            self.label,
            self.level,
            self.freq_hz[mask],
            self.H[:, mask],
            self.sigma[:, mask],
            d,
            self.U[mask],
            self.excitation,
            self.resolution_hz,
            self.n_periods,
            self.channels,
            self.drive_unit,
            self.response_unit,
        )


def detect_period(u: np.ndarray, min_correlation: float = 0.98, min_periods: int = 2) -> int | None:
    """Period of a repeating drive in samples, or None.

    The normalised circular autocorrelation is searched for its highest peak at lags of at
    most ``n / min_periods``; the drive is periodic if that peak reaches ``min_correlation``
    and the record holds whole periods (a lag that divides the record; the lag is snapped
    to the nearest divisor within one sample).

    Parameters
    ----------
    u : array_like, shape (n,)
        The drive's samples (any unit: N, m/s^2, V); its mean is removed first.
    min_correlation : float, optional
        Normalised correlation (-) of the record with itself shifted by one period that makes
        the drive periodic; 0.98 accepts measurement noise and a slowly drifting shaker gain.
    min_periods : int, optional
        Whole periods the record must hold at least: the longest period searched is
        ``n // min_periods`` samples (2: a period can be checked against a second one).

    Returns
    -------
    int or None
        Samples per period (a divisor of ``n``), or None for a drive that does not repeat over
        whole periods, a constant drive or a record of fewer than 8 samples.
    """
    u = np.asarray(u, float) - np.mean(u)
    n = u.size
    if n < 8 or not np.any(u):
        return None
    spec = np.fft.rfft(u, 2 * n)
    r = np.fft.irfft(np.abs(spec) ** 2)[:n]
    r = r / r[0]
    lo = max(4, n // 1000)
    hi = n // min_periods
    if hi <= lo:
        return None
    lag = lo + int(np.argmax(r[lo : hi + 1]))
    # an exact period of m samples over n = k m samples correlates (n - m)/n in the linear estimate
    for cand in (lag, lag - 1, lag + 1):
        if cand > 0 and n % cand == 0:
            corr = float(
                np.dot(u[:-cand], u[cand:])
                / np.sqrt(np.dot(u[:-cand], u[:-cand]) * np.dot(u[cand:], u[cand:]))
            )
            if corr >= min_correlation:
                return cand
    return None


def _split(rec: Recording, label: str):
    drive = rec.drive
    resp = [c for c in rec.response_channels if c.quantity == "acceleration"] or list(rec.response_channels)
    if not resp:
        raise InputError(f"recording {label!r}: no response channel; map at least one accelerometer")
    names = tuple(c.name for c in resp)
    y, fs = rec.time_data(names)
    if drive.sample_rate_hz != fs or drive.n_samples != y.shape[1]:
        raise InputError(
            f"recording {label!r}: drive {drive.name!r} has {drive.n_samples} samples at "
            f"{drive.sample_rate_hz:g} Hz, "
            f"the responses {y.shape[1]} at {fs:g} Hz; give the drive on the responses' time base"
        )
    return np.asarray(drive.data, float), y, fs, names, drive.unit, resp[0].unit


def _periodic(u, y, fs, p: int):
    n_all = u.size // p
    first = 1 if n_all >= 3 else 0  # the first period holds the start transient
    up = np.fft.rfft(u[first * p : n_all * p].reshape(n_all - first, p), axis=-1) * (2.0 / p)
    yp = np.fft.rfft(y[:, first * p : n_all * p].reshape(y.shape[0], n_all - first, p), axis=-1) * (2.0 / p)
    m = n_all - first
    f = np.fft.rfftfreq(p, 1.0 / fs)
    um, ym = up.mean(axis=0), yp.mean(axis=1)
    amp = np.abs(um)
    exc = amp > 0.05 * np.max(amp[1:])
    exc[0] = False
    with np.errstate(divide="ignore", invalid="ignore"):
        h = ym / np.where(exc, um, 1.0)
    # noise: period-to-period scatter of the output error Y_p - H U_p (input and output noise together)
    e = yp - h[:, None, :] * up[None, :, :]
    # the variance of a few periods is itself uncertain (2 (m - 1) degrees of freedom): the noise spectrum is
    # smooth, so it is averaged over +-5 excited lines, which weights a fit without biasing it
    var_e = np.var(e, axis=1, ddof=1) if m > 1 else np.zeros((y.shape[0], amp.size))
    idx = np.flatnonzero(exc)
    if m > 1 and idx.size > 11:
        ker = np.ones(11) / 11.0
        norm = np.convolve(np.ones(idx.size), ker, mode="same")
        var_e[:, idx] = np.array([np.convolve(row, ker, mode="same") / norm for row in var_e[:, idx]])
    var_h = var_e / m / np.where(exc, amp, 1.0) ** 2
    # distortion: power at the non-excited lines above their noise, interpolated to the excited lines
    ne = ~exc
    ne[0] = False
    ex_idx = np.flatnonzero(exc)
    inside = ne & (np.arange(f.size) > ex_idx[0]) & (np.arange(f.size) < ex_idx[-1])
    dist = None
    if inside.sum() >= 3 and m > 1:
        noise_ne = np.var(yp[:, :, inside], axis=1, ddof=1) / m
        p_nl = np.maximum(np.abs(ym[:, inside]) ** 2 - noise_ne, 0.0)
        idx_ne = np.flatnonzero(inside)
        # smooth over +-5 detection lines, then interpolate to the excited lines
        ker = np.ones(11) / 11.0
        p_s = np.array(
            [
                np.convolve(row, ker, mode="same") / np.convolve(np.ones_like(row), ker, mode="same")
                for row in p_nl
            ]
        )
        p_ex = np.array([np.interp(ex_idx, idx_ne, row) for row in p_s])
        dist = np.zeros_like(amp, shape=(y.shape[0], f.size))
        dist[:, ex_idx] = np.sqrt(p_ex) / amp[ex_idx]
    return f, h, np.sqrt(var_h), dist, um, exc, m


def _random(u, y, fs, settings: LevelSettings, names):
    from exudyn_study.identify.frf import estimate_frf
    from exudyn_study.identify.lpm import estimate_frf_lpm

    if settings.resolution_hz is None:
        frf = estimate_frf_lpm(u, y, fs, outputs=names)
        n_avg = 1
        nfft = u.size
        # LRM 'coherence' is 1 - noise/total power of the local fit: the noise share of |H|^2
        coh = np.clip(frf.coherence[:, 0, :], 1e-6, 1.0)
        sig = np.abs(frf.H[:, 0, :]) * np.sqrt((1.0 - coh) / coh)
    else:
        if settings.resolution_hz < fs / u.size:
            raise InputError(
                f"resolution {settings.resolution_hz:g} Hz is finer than the record allows "
                f"({fs / u.size:.4g} Hz "
                f"for {u.size / fs:.4g} s); give --resolution >= {fs / u.size:.4g} Hz or leave it out"
            )
        frf = estimate_frf(
            u[None, :], y, fs, resolution_hz=settings.resolution_hz, estimator="H1", outputs=names
        )
        n_avg = frf.n_averages
        nfft = frf.n_segment
        coh = np.clip(frf.coherence[:, 0, :], 1e-6, 0.9999)
        sig = np.abs(frf.H[:, 0, :]) * np.sqrt((1.0 - coh) / (2.0 * n_avg * coh))
    f = frf.freq_hz
    seg = u[: nfft * (u.size // nfft)].reshape(-1, nfft)
    um = np.sqrt(np.mean(np.abs(np.fft.rfft(seg, axis=-1) * (2.0 / nfft)) ** 2, axis=0))[: f.size]
    return f, frf.H[:, 0, :], sig, None, um.astype(complex), n_avg, frf.resolution_hz


def estimate_level_frf(rec: Recording, label: str, settings: LevelSettings) -> LevelFRF:
    """FRFs of a recording against its drive, estimated as its excitation requires.

    Parameters
    ----------
    rec : Recording
        One drive channel (force in N, table acceleration, or a shaker voltage) and the
        response accelerometers, all at one rate and length.
    label : str
        Name for messages and the report.
    settings : LevelSettings

    Returns
    -------
    LevelFRF
        Over all lines with a drive (periodic: the excited lines; random: every line).

    Raises
    ------
    InputError
        A declared period that does not divide the record, a record of fewer than two
        periods, mismatched drive and responses, or a resolution finer than the record.
    """
    u, y, fs, names, du, ru = _split(rec, label)
    n_real = settings.realisations
    if n_real > 1:
        if settings.excitation == "random" or u.size % n_real:
            raise InputError(
                f"recording {label!r}: {u.size} samples do not split into {n_real} equal realisations of a "
                "periodic drive; give the number of multisine realisations recorded one after the other "
                "(--realisations), each of whole periods, or leave it at 1"
            )
        b = u.size // n_real
        parts = [
            _periodic_block(
                u[i * b : (i + 1) * b],
                y[:, i * b : (i + 1) * b],
                fs,
                settings,
                f"{label} realisation {i + 1}",
            )
            for i in range(n_real)
        ]
        if any(pt is None for pt in parts):
            raise InputError(
                f"recording {label!r}: a realisation's drive does not repeat itself over whole periods; "
                "declare the period (--period) or check --realisations"
            )
        return _combine_realisations(label, parts, fs, names, du, ru)
    if settings.excitation != "random":
        got = _periodic_block(u, y, fs, settings, label)
        if got is not None:
            f, h, sig, dist, um, exc, m, period = got
            dist_sel = None if dist is None else dist[:, exc]
            level = float(np.sqrt(0.5 * np.sum(np.abs(um[exc]) ** 2)))
            return LevelFRF(
                label,
                level,
                f[exc],
                h[:, exc],
                sig[:, exc],
                dist_sel,
                um[exc],
                "periodic",
                fs / period,
                m,
                names,
                du,
                ru,
            )
    f, h, sig, dist, um, n_avg, res = _random(u, y, fs, settings, names)
    keep = f > 0
    level = float(np.std(u))
    return LevelFRF(
        label,
        level,
        f[keep],
        h[:, keep],
        sig[:, keep],
        None,
        um[keep],
        "random",
        float(res),
        n_avg,
        names,
        du,
        ru,
    )


def _periodic_block(u, y, fs, settings: LevelSettings, label: str):
    """Return the periodic estimate of a block (:func:`_periodic`) and its period, or None (no repetition).

    Raises on a declared period that does not divide the block or a block of fewer than two periods,
    and (``excitation='periodic'``) on a drive that does not repeat.
    """
    n = u.size
    if settings.period_s is not None:
        p = settings.period_s * fs
        if abs(p - round(p)) > 1e-6 * p or n % int(round(p)):
            raise InputError(
                f"recording {label!r}: the declared period {settings.period_s:g} s ({p:.6g} "
                f"samples at {fs:g} Hz) "
                f"does not divide the record of {n} samples ({n / fs:g} s); give the drive's exact period or "
                "trim the record to whole periods"
            )
        period = int(round(p))
        if n // period < 2:
            raise InputError(
                f"recording {label!r}: {n // period} period of {settings.period_s:g} s; record at "
                "least two periods"
            )
    else:
        period = detect_period(u, settings.period_correlation)
        if period is None:
            if settings.excitation == "periodic" or settings.realisations > 1:
                if settings.realisations > 1:
                    return None
                raise InputError(
                    f"recording {label!r}: the drive does not repeat itself over whole periods; declare the "
                    "period (--period) or use --excitation random"
                )
            return None
    return (*_periodic(u, y, fs, period), period)


def _combine_realisations(label, parts, fs, names, du, ru) -> LevelFRF:
    """Mean FRF over realisations; noise from the periods, distortion from the scatter beyond it."""
    exc = parts[0][5]
    for i, pt in enumerate(parts[1:], start=2):
        if pt[7] != parts[0][7] or not np.array_equal(pt[5], exc):
            raise InputError(
                f"recording {label!r}: realisation {i} has another period or other excited lines than the "
                "first; the realisations of a random-phase multisine share period and amplitude spectrum"
            )
    f = parts[0][0]
    hs = np.array([pt[1][:, exc] for pt in parts])  # (R, n_out, n_exc)
    n_real = hs.shape[0]
    h = hs.mean(axis=0)
    var_noise = np.mean([pt[2][:, exc] ** 2 for pt in parts], axis=0) / n_real
    var_total = np.var(hs, axis=0, ddof=1) / n_real
    # a variance from a few realisations is itself uncertain: averaged over +-5 lines, as the noise is
    if var_total.shape[1] > 11:
        ker = np.ones(11) / 11.0
        norm = np.convolve(np.ones(var_total.shape[1]), ker, mode="same")
        var_total = np.array([np.convolve(row, ker, mode="same") / norm for row in var_total])
    dist = np.sqrt(np.maximum(var_total - var_noise, 0.0))
    amp = np.sqrt(np.mean([np.abs(pt[4][exc]) ** 2 for pt in parts], axis=0))
    level = float(np.sqrt(0.5 * np.sum(amp**2)))
    period = parts[0][7]
    return LevelFRF(
        label,
        level,
        f[exc],
        h,
        np.sqrt(var_noise),
        dist,
        amp.astype(complex),
        "periodic",
        fs / period,
        sum(pt[6] for pt in parts),
        names,
        du,
        ru,
    )


def excited_band(ref: LevelFRF, requested: tuple[float, float] | None) -> tuple[float, float]:
    """Return the contiguous excited band of the reference's drive, or the requested one checked against it.

    Random drive: the drive's amplitude per line, smoothed over about 1 % of the lines, within
    30 dB of its peak, and the longest contiguous run of such lines; periodic drive:
    the excited lines from the first to the last (gaps of detection lines are part of the band).

    Parameters
    ----------
    ref : LevelFRF
        The reference (lowest) level, whose drive amplitudes ``U`` per line define the band.
    requested : (float, float) or None
        Analysis band (low, high) in Hz asked for (``--band``), or None for the excited band.
        A requested band reaching beyond the excited band is accepted with a warning (those
        lines carry only noise).

    Returns
    -------
    (float, float)
        The band (low, high) in Hz: the excited band, or the requested one.

    Raises
    ------
    InputError
        A requested band that lies outside the data's lines or holds fewer than 8 of them.
    """
    f = ref.freq_hz
    if ref.excitation == "periodic":
        band = (float(f[0]), float(f[-1]))
    else:
        a = np.abs(ref.U)
        w = max(3, f.size // 100)
        s = np.convolve(a, np.ones(w) / w, mode="same")
        on = s > 10 ** (-30 / 20) * np.max(s)
        # longest contiguous run
        edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
        runs = edges.reshape(-1, 2)
        lo_i, hi_i = max(runs, key=lambda r: r[1] - r[0])
        band = (float(f[lo_i]), float(f[hi_i - 1]))
    if requested is None:
        return band
    lo, hi = float(requested[0]), float(requested[1])
    inside = (f >= lo) & (f <= hi)
    if lo >= f[-1] or hi <= f[0] or inside.sum() < 8:
        raise InputError(
            f"band {lo:g}-{hi:g} Hz lies outside the data of {ref.label!r} (lines {f[0]:.4g}-{f[-1]:.4g} Hz, "
            f"excited {band[0]:.4g}-{band[1]:.4g} Hz) or holds fewer than 8 lines; give --band "
            "inside the excited band"
        )
    if lo < band[0] - 1e-9 or hi > band[1] + 1e-9:
        import warnings

        warnings.warn(
            f"band {lo:g}-{hi:g} Hz reaches beyond the excited band {band[0]:.4g}-{band[1]:.4g} Hz of "
            f"{ref.label!r}: lines without excitation carry only noise",
            stacklevel=2,
        )
    return (lo, hi)


def level_rms(frf: LevelFRF) -> float:
    """Drive rms in the analysed lines (``sqrt(sum |U|^2 / 2)``)."""
    return float(math.sqrt(0.5 * np.sum(np.abs(frf.U) ** 2)))
