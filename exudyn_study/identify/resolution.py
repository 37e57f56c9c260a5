r"""Frequency resolution versus damping: the spectral-line check and a suggestion.

A mode of natural frequency :math:`f` and damping ratio :math:`\zeta` has a
half-power bandwidth of :math:`2\zeta f`. With line spacing :math:`\Delta f` it
spans :math:`n = 2\zeta f/\Delta f` lines. Below about five lines the Welch
spectral window (Hann: main lobe four lines wide) smooths the peak noticeably and
biases the damping upwards (the thesis's 47.6 Hz / 0.53 % mode at 0.2 Hz spans
about 2.5 lines). A finer resolution needs longer segments, hence fewer averages
from the same record: the suggestion takes both into account.

References
----------
Schmidt, H. (1985). Resolution bias errors in spectral density, frequency response
and coherence function measurements. J. Sound Vib. 101(3), 347-427.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exudyn_study.errors import InputError

__all__ = ["lines_in_half_power", "ResolutionAdvice", "suggest_resolution",
           "resolution_warnings", "MIN_LINES", "first_pass_resolution", "choose_resolution",
           "FIT_LINES", "PAIR_LINES", "MIN_AVERAGES", "HANN_LINES", "window_corrected_damping",
           "fft_friendly_resolution"]

#: spectral lines in the half-power bandwidth below which damping is flagged
MIN_LINES = 5.0
#: lines per half-power bandwidth the automatic choice aims at: the leakage-aware fit
#: (:class:`~exudyn_study.identify.lsfd.Leakage`) removes the window bias, so fewer lines
#: than :data:`MIN_LINES` suffice for the damping; below about two the peak's shape is lost
FIT_LINES = 2.5
#: lines between the two modes of the closest pair the automatic choice aims at
PAIR_LINES = 3.0
#: Welch averages the automatic choice keeps at least (the random error of an H estimate at
#: coherence 0.9 is then below 10 %)
MIN_AVERAGES = 12
#: averages of the first (survey) pass
SURVEY_AVERAGES = 30


#: half-power width of the Hann window's power kernel in lines (its 3 dB main-lobe width)
HANN_LINES = 1.44


def window_corrected_damping(frequency_hz, damping_ratio, resolution_hz: float) -> np.ndarray:
    r"""Return damping ratios with the broadening of a Hann-windowed Welch estimate removed.

    A Welch estimate is the FRF smoothed by the window's power kernel; a peak of half-power
    bandwidth :math:`B = 2\zeta f` then shows the width of a Voigt profile, a Lorentzian of
    width :math:`B` convolved with a kernel of width :math:`G` = :data:`HANN_LINES` lines,
    :math:`V \approx 0.5346 B + \sqrt{0.2166 B^2 + G^2}` (Olivero & Longbothum 1977).
    Inverting it gives the bandwidth behind a damping ratio fitted to the estimate (PolyMAX on
    a survey FRF); a measured width at or below the kernel's gives a quarter line.

    Parameters
    ----------
    frequency_hz, damping_ratio : array_like
        Natural frequencies (Hz) and damping ratios (-) fitted to the estimate.
    resolution_hz : float
        Line spacing of the estimate in Hz.

    Returns
    -------
    ndarray
        Damping ratios (-).

    References
    ----------
    Olivero, J. J., Longbothum, R. L. (1977). Empirical fits to the Voigt line width: a brief
    review. J. Quant. Spectrosc. Radiat. Transfer 17, 233-236.
    """
    fr = np.asarray(frequency_hz, float)
    v = 2 * np.asarray(damping_ratio, float) * fr
    g = HANN_LINES * float(resolution_hz)
    # 0.0692 B^2 - 1.0692 V B + (V^2 - G^2) = 0, the smaller root
    a, b, c = 0.5346**2 - 0.2166, -2 * 0.5346 * v, v**2 - g**2
    with np.errstate(invalid="ignore"):
        width = (-b - np.sqrt(np.maximum(b**2 - 4 * a * c, 0.0))) / (2 * a)
    width = np.where(v > g, width, 0.0)
    width = np.maximum(width, 0.25 * float(resolution_hz))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(fr > 0, width / (2 * fr), np.asarray(damping_ratio, float))


def fft_friendly_resolution(resolution_hz: float, sample_rate_hz: float) -> float:
    """Return the finest resolution at or above ``resolution_hz`` with a fast segment length.

    The FFT of a segment whose length has a large prime factor costs up to ten times that of
    a length of the form 2^a 3^b 5^c (30769 = 29 x 1061 samples: 0.084 s for 50 segments,
    30720: 0.008 s); the segment is shortened to the nearest such length, which coarsens the
    resolution by less than 2 % for segments of a thousand samples or more (and keeps at
    least as many averages).

    Parameters
    ----------
    resolution_hz : float
        Wanted resolution in Hz.
    sample_rate_hz : float
        Sampling rate in Hz.

    Returns
    -------
    float
        ``sample_rate_hz / n`` with ``n`` the largest 5-smooth length at or below
        ``round(sample_rate_hz / resolution_hz)``.
    """
    n = max(1, int(round(sample_rate_hz / resolution_hz)))
    best = 1
    p2 = 1
    while p2 <= n:
        p3 = p2
        while p3 <= n:
            p5 = p3
            while p5 <= n:
                best = max(best, p5)
                p5 *= 5
            p3 *= 3
        p2 *= 2
    return sample_rate_hz / best


def lines_in_half_power(frequency_hz, damping_ratio, resolution_hz: float) -> np.ndarray:
    """Return the number of lines in the half-power bandwidth, ``2 zeta f / df``.

    Parameters
    ----------
    frequency_hz : array_like
        Natural frequencies in Hz.
    damping_ratio : array_like
        Damping ratios (-).
    resolution_hz : float
        Line spacing in Hz.

    Returns
    -------
    ndarray
    """
    if not (np.isfinite(resolution_hz) and resolution_hz > 0):
        raise InputError(f"resolution_hz={resolution_hz!r}: expected a positive number in Hz")
    return 2 * np.asarray(damping_ratio, float) * np.asarray(frequency_hz, float) / resolution_hz


@dataclass(frozen=True)
class ResolutionAdvice:
    """A suggested resolution.

    Attributes
    ----------
    resolution_hz : float
        Suggested line spacing in Hz.
    lines : float
        Lines in the narrowest half-power bandwidth at that resolution.
    n_averages : int or None
        Welch averages the record allows at that resolution (None without a record length).
    feasible : bool
        Whether ``min_lines`` and ``min_averages`` can both be met.
    message : str
        One-line explanation.
    """

    resolution_hz: float
    lines: float
    n_averages: int | None
    feasible: bool
    message: str


def _averages(duration_s: float, resolution_hz: float, overlap: float) -> int:
    seg = 1.0 / resolution_hz
    if duration_s < seg:
        return 0
    return 1 + int(np.floor((duration_s - seg) / (seg * (1 - overlap)) + 1e-9))


def suggest_resolution(
    frequency_hz,
    damping_ratio,
    *,
    duration_s: float | None = None,
    min_lines: float = MIN_LINES,
    min_averages: int = 20,
    overlap: float = 0.5,
) -> ResolutionAdvice:
    r"""Suggest a resolution giving ``min_lines`` lines in the narrowest bandwidth.

    The narrowest half-power bandwidth :math:`\min 2\zeta f` sets
    ``df <= min(2 zeta f) / min_lines``; the value is rounded down to 1, 2 or 5
    times a power of ten. With ``duration_s`` the record must also give at least
    ``min_averages`` Welch averages; when both cannot be met the finest resolution
    that keeps ``min_averages`` is returned with ``feasible=False``.

    Parameters
    ----------
    frequency_hz, damping_ratio : array_like
        The identified (or expected) modes.
    duration_s : float, optional
        Record length in s.
    min_lines : float, optional
        Lines wanted in each half-power bandwidth (default 5).
    min_averages : int, optional
        Averages wanted for the variance of the estimate (default 20).
    overlap : float, optional
        Segment overlap fraction (default 0.5).

    Returns
    -------
    ResolutionAdvice
    """
    bw = 2 * np.asarray(damping_ratio, float) * np.asarray(frequency_hz, float)
    bw = bw[np.isfinite(bw) & (bw > 0)]
    if bw.size == 0:
        raise InputError("suggest_resolution: expected at least one mode with positive damping")
    narrow = float(bw.min())
    target = narrow / min_lines
    exp = np.floor(np.log10(target))
    nice = max(m * 10**exp for m in (1, 2, 5) if m * 10**exp <= target * (1 + 1e-12))
    if duration_s is None:
        return ResolutionAdvice(nice, narrow / nice, None, True,
                                f"{nice:g} Hz gives {narrow / nice:.1f} lines in the narrowest "
                                f"half-power bandwidth ({narrow:.3g} Hz)")
    n_avg = _averages(duration_s, nice, overlap)
    if n_avg >= min_averages:
        return ResolutionAdvice(nice, narrow / nice, n_avg, True,
                                f"{nice:g} Hz gives {narrow / nice:.1f} lines in the narrowest "
                                f"half-power bandwidth and {n_avg} averages over {duration_s:g} s")
    # finest resolution keeping min_averages: seg = duration / (1 + (m-1)(1-overlap))
    seg = duration_s / (1 + (min_averages - 1) * (1 - overlap))
    df = 1.0 / seg
    exp = np.floor(np.log10(df))
    cands = [m * 10**e for e in (exp, exp + 1) for m in (1, 2, 5) if m * 10**e >= df * (1 - 1e-12)]
    best = min(cands)
    return ResolutionAdvice(
        best, narrow / best, _averages(duration_s, best, overlap), False,
        f"{nice:g} Hz would be needed for {min_lines:g} lines but leaves only {n_avg} averages "
        f"in {duration_s:g} s; {best:g} Hz keeps {min_averages} averages "
        f"({narrow / best:.1f} lines): record at least "
        f"{(1 + (min_averages - 1) * (1 - overlap)) / nice:.0f} s for both",
    )


def resolution_warnings(frequency_hz, damping_ratio, resolution_hz: float, *,
                        duration_s: float | None = None,
                        min_lines: float = MIN_LINES) -> list[str]:
    """One message per mode with fewer than ``min_lines`` lines in its bandwidth.

    Parameters
    ----------
    frequency_hz, damping_ratio : array_like
        Identified modes.
    resolution_hz : float
        Resolution of the FRFs in Hz.
    duration_s : float, optional
        Record length in s (for the suggestion).
    min_lines : float, optional
        Threshold (default 5).

    Returns
    -------
    list of str
        Empty when every mode is resolved; else two messages: the modes concerned
        and the suggested resolution.
    """
    fr = np.asarray(frequency_hz, float)
    ze = np.asarray(damping_ratio, float)
    n = lines_in_half_power(fr, ze, resolution_hz)
    low = [(f, z, k) for f, z, k in zip(fr, ze, n, strict=True) if k < min_lines]
    if not low:
        return []
    listing = ", ".join(f"{f:.2f} Hz/{100 * z:.2f} % ({k:.1f} lines)" for f, z, k in low)
    adv = suggest_resolution(fr, ze, duration_s=duration_s, min_lines=min_lines)
    return [
        f"{len(low)} mode(s) span fewer than {min_lines:g} spectral lines in their half-power "
        f"bandwidth at {resolution_hz:g} Hz, so window leakage biases their damping: {listing}",
        f"suggested resolution: {adv.message}",
    ]


def _nice_up(x: float) -> float:
    """Smallest 1, 2 or 5 times a power of ten at or above ``x``."""
    e = np.floor(np.log10(x))
    return float(min(m * 10**k for k in (e, e + 1) for m in (1, 2, 5) if m * 10**k >= x * (1 - 1e-12)))


def _nice_down(x: float) -> float:
    """Largest 1, 2 or 5 times a power of ten at or below ``x``."""
    e = np.floor(np.log10(x))
    return float(max(m * 10**k for k in (e - 1, e) for m in (1, 2, 5) if m * 10**k <= x * (1 + 1e-12)))


def _finest_for_averages(duration_s: float, n_avg: int, overlap: float) -> float:
    return (1 + (n_avg - 1) * (1 - overlap)) / duration_s


def first_pass_resolution(duration_s: float, *, overlap: float = 0.5) -> float:
    """Return the resolution of the survey pass: the finest that keeps 30 averages.

    Parameters
    ----------
    duration_s : float
        Record length in s.
    overlap : float, optional
        Welch overlap (default 0.5).

    Returns
    -------
    float
        Resolution in Hz (1, 2 or 5 times a power of ten).
    """
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise InputError(f"duration_s={duration_s!r}: expected a positive record length in s")
    return _nice_up(_finest_for_averages(duration_s, SURVEY_AVERAGES, overlap))


def choose_resolution(frequency_hz, damping_ratio, duration_s: float, *,
                      overlap: float = 0.5) -> ResolutionAdvice:
    """Choose the FRF resolution from the modes of a survey pass and the record length.

    The resolution aims at :data:`FIT_LINES` lines in the narrowest half-power bandwidth and
    :data:`PAIR_LINES` lines between the two closest modes, but keeps at least
    :data:`MIN_AVERAGES` Welch averages (the variance of the estimate); it is never coarser
    than the survey resolution.

    Parameters
    ----------
    frequency_hz, damping_ratio : array_like
        Modes of the survey pass (Hz, -); may be empty.
    duration_s : float
        Record length in s.
    overlap : float, optional
        Welch overlap (default 0.5).

    Returns
    -------
    ResolutionAdvice
        ``feasible`` is False when the averages limit the resolution.
    """
    survey = first_pass_resolution(duration_s, overlap=overlap)
    fr = np.asarray(frequency_hz, float)
    ze = np.asarray(damping_ratio, float)
    ok = np.isfinite(fr) & np.isfinite(ze) & (ze > 0) & (fr > 0)
    fr, ze = fr[ok], ze[ok]
    # the finest resolution that keeps MIN_AVERAGES, exact (not rounded to a 1-2-5 value, which
    # would give away up to a factor 2.5 of resolution where the record is what limits it)
    floor = _finest_for_averages(duration_s, MIN_AVERAGES, overlap)
    if fr.size == 0:
        return ResolutionAdvice(survey, np.nan, _averages(duration_s, survey, overlap), True,
                                f"{survey:g} Hz ({SURVEY_AVERAGES} averages): no mode to resolve")
    want = float(np.min(2 * ze * fr)) / FIT_LINES
    why = f"{FIT_LINES:g} lines in the narrowest half-power bandwidth"
    if fr.size > 1:
        gaps = np.diff(np.sort(fr))
        pair = float(gaps.min()) / PAIR_LINES
        if pair < want:
            want, why = pair, f"{PAIR_LINES:g} lines between the closest modes ({gaps.min():.3g} Hz apart)"
    nice = min(_nice_down(want), survey)
    feasible = nice >= floor
    res = max(nice, floor)
    n_avg = _averages(duration_s, res, overlap)
    lines = float(np.min(2 * ze * fr)) / res
    msg = (f"{res:.4g} Hz for {why}" if feasible else
           f"{res:.4g} Hz, the finest that keeps {MIN_AVERAGES} averages ({nice:g} Hz would give {why})")
    return ResolutionAdvice(res, lines, n_avg, feasible,
                            f"{msg}: {lines:.1f} lines in the narrowest bandwidth, {n_avg} averages "
                            f"over {duration_s:g} s")
