"""Drive signals of the test rig, anti-aliased resampling and a PSD helper.

The rig's hydraulic cylinder is displacement controlled (thesis Section 3.2). Three
drive signals were used (thesis Sections 5.1 and 7, Figs 13 and 19):

``'white-noise'``
    band-limited white noise, flat displacement PSD over 3-60 Hz (the modal
    identification signal);
``'test'``
    a road-like test signal with more energy at 5-26 Hz and just below 40 Hz;
``'test-50'``
    the same test signal at 50 % amplitude.

All are displacements in m, synthesised by shaping the spectrum of seeded Gaussian
noise with the FFT, so the band is exact: the discrete spectrum is zero outside it
(the signal is periodic over its duration). The measured drive of the thesis
(Fig. 13) deviates from the desired flat PSD with drop-offs near 12 and 26 Hz; that
is the rig's doing, not part of the desired signal, and is what the drive iteration
(:mod:`exudyn_study.signals.drive_iteration`) compensates for.

Default amplitude
-----------------
:data:`DEFAULT_RMS_M` is 0.25 mm rms. For a flat displacement PSD over
[f1, f2] = [3, 60] Hz the drive-point acceleration is
``a_rms = x_rms * (2 pi)^2 * sqrt((f2^5 - f1^5) / (5 (f2 - f1)))``, i.e.
about 16 m/s^2 (1.7 g) rms for 0.25 mm, so Gaussian peaks (~4 sigma) near 65 m/s^2;
resonant amplification at the tanks and brackets then stays within the 30 g range of
the rig's accelerometers (thesis Section 3.3). At 1 mm rms the drive point alone would
see ~65 m/s^2 rms and the responses ~100 m/s^2 rms, beyond that range
(``../shared/NOTES-exudyn.md``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from fractions import Fraction

import numpy as np
from scipy import signal as sps

from exudyn_study.errors import InputError

__all__ = [
    "DEFAULT_RMS_M",
    "WHITE_NOISE_BAND_HZ",
    "SIGNALS",
    "white_noise",
    "test_signal",
    "test_signal_50",
    "drive_signal",
    "test_signal_shape",
    "resample",
    "rational_ratio",
    "psd",
    "acceleration_rms_of_flat_band",
]

#: default drive rms displacement in m (see the module docstring for the reasoning)
DEFAULT_RMS_M = 0.25e-3

#: band of the identification white noise in Hz (thesis Section 5.1)
WHITE_NOISE_BAND_HZ = (3.0, 60.0)

#: test signal: PSD boost of the 5-26 Hz band and of the bump just below 40 Hz
_TEST_LOW_BAND_HZ = (5.0, 26.0)
_TEST_BUMP_HZ = 38.0  # centre of the bump "just below 40 Hz" (thesis Fig. 19)
_TEST_BUMP_WIDTH_HZ = 2.0  # Gaussian standard deviation of the bump
_TEST_BOOST = 10.0  # PSD factor (10 dB) in the boosted regions


def _check_common(duration_s: float, sample_rate_hz: float, rms_m: float, seed: int) -> int:
    """Validate the shared signal arguments; return the number of samples."""
    for label, value in (("duration_s", duration_s), ("sample_rate_hz", sample_rate_hz)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise InputError(f"{label} {value!r}; expected a finite number > 0")
    if not (isinstance(rms_m, (int, float)) and math.isfinite(rms_m) and rms_m > 0):
        raise InputError(f"rms_m {rms_m!r}; expected a finite rms displacement > 0 m")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed {seed!r}; expected an integer >= 0 (signals are reproducible)")
    f_high = WHITE_NOISE_BAND_HZ[1]
    if sample_rate_hz <= 2 * f_high:
        raise InputError(
            f"sample_rate_hz {sample_rate_hz!r}; expected > {2 * f_high:g} Hz so the "
            f"{f_high:g} Hz band edge is below Nyquist"
        )
    n = int(round(duration_s * sample_rate_hz))
    if duration_s < 1.0:
        raise InputError(
            f"duration_s {duration_s!r}; expected >= 1 s to resolve the "
            f"{WHITE_NOISE_BAND_HZ[0]:g} Hz band edge"
        )
    return n


def _shaped_noise(
    n: int, sample_rate_hz: float, rms_m: float, seed: int, shape: Callable
) -> np.ndarray:
    """Seeded Gaussian noise whose amplitude spectrum is multiplied by ``shape(f)``.

    ``shape`` gives the *PSD* shape (>= 0, zero outside the band); the amplitude is its
    square root. The result is scaled to exactly ``rms_m``.
    """
    rng = np.random.default_rng(int(seed))
    spectrum = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, d=1.0 / sample_rate_hz)
    spectrum *= np.sqrt(np.clip(shape(f), 0.0, None))
    x = np.fft.irfft(spectrum, n=n)
    rms = float(np.sqrt(np.mean(x**2)))
    if rms == 0.0:
        raise InputError(
            f"signal of {n} samples at {sample_rate_hz} Hz has no spectral line in its band; "
            "use a longer duration"
        )
    return x * (rms_m / rms)


def _white_shape(f: np.ndarray) -> np.ndarray:
    lo, hi = WHITE_NOISE_BAND_HZ
    return ((f >= lo) & (f <= hi)).astype(float)


def test_signal_shape(f_hz: np.ndarray) -> np.ndarray:
    """Relative displacement PSD of the test signal (1 = white-noise level).

    Flat over 3-60 Hz, times 10 (10 dB) over 5-26 Hz, plus a Gaussian bump of height
    10 centred at 38 Hz (standard deviation 2 Hz), after thesis Fig. 19.

    Parameters
    ----------
    f_hz : ndarray
        Frequencies in Hz.

    Returns
    -------
    ndarray
        PSD shape, same shape as ``f_hz``, zero outside 3-60 Hz.
    """
    f = np.asarray(f_hz, dtype=float)
    lo, hi = _TEST_LOW_BAND_HZ
    shape = 1.0 + (_TEST_BOOST - 1.0) * ((f >= lo) & (f <= hi))
    shape = shape + (_TEST_BOOST - 1.0) * np.exp(
        -0.5 * ((f - _TEST_BUMP_HZ) / _TEST_BUMP_WIDTH_HZ) ** 2
    )
    return shape * _white_shape(f)


def white_noise(
    duration_s: float,
    sample_rate_hz: float,
    rms_m: float = DEFAULT_RMS_M,
    seed: int = 0,
) -> np.ndarray:
    """Band-limited white-noise displacement, flat PSD over 3-60 Hz.

    Parameters
    ----------
    duration_s : float
        Length in s (>= 1 s).
    sample_rate_hz : float
        Sampling rate in Hz (> 120 Hz).
    rms_m : float, optional
        Rms displacement in m (default :data:`DEFAULT_RMS_M`, 0.25 mm).
    seed : int, optional
        Seed of the random generator; equal seeds give identical signals.

    Returns
    -------
    ndarray, shape (round(duration_s * sample_rate_hz),)
        Displacement in m with exactly ``rms_m`` rms and zero mean.

    Raises
    ------
    InputError
        On a non-positive duration, rate or rms, a rate that puts 60 Hz above
        Nyquist, or a negative or non-integer seed.
    """
    n = _check_common(duration_s, sample_rate_hz, rms_m, seed)
    return _shaped_noise(n, sample_rate_hz, rms_m, seed, _white_shape)


def test_signal(
    duration_s: float,
    sample_rate_hz: float,
    rms_m: float = DEFAULT_RMS_M,
    seed: int = 0,
) -> np.ndarray:
    """Road-like test displacement: more energy at 5-26 Hz and just below 40 Hz.

    The PSD follows :func:`test_signal_shape` (band 3-60 Hz).

    Parameters
    ----------
    duration_s : float
        Length in s (>= 1 s).
    sample_rate_hz : float
        Sampling rate in Hz (> 120 Hz).
    rms_m : float, optional
        Rms displacement in m (default :data:`DEFAULT_RMS_M`, 0.25 mm).
    seed : int, optional
        Seed of the random generator; equal seeds give identical signals.

    Returns
    -------
    ndarray, shape (round(duration_s * sample_rate_hz),)
        Displacement in m with exactly ``rms_m`` rms.

    Raises
    ------
    InputError
        As :func:`white_noise`.
    """
    n = _check_common(duration_s, sample_rate_hz, rms_m, seed)
    return _shaped_noise(n, sample_rate_hz, rms_m, seed, test_signal_shape)


def test_signal_50(
    duration_s: float,
    sample_rate_hz: float,
    rms_m: float = DEFAULT_RMS_M,
    seed: int = 0,
) -> np.ndarray:
    """The test signal at 50 % amplitude: ``0.5 * test_signal(...)`` with the same seed.

    ``rms_m`` is the rms of the full-amplitude test signal, so the result has
    ``rms_m / 2`` rms and is sample by sample half of :func:`test_signal`.

    Parameters
    ----------
    duration_s : float
        Length in s (>= 1 s).
    sample_rate_hz : float
        Sampling rate in Hz (> 120 Hz).
    rms_m : float, optional
        Rms displacement in m of the full-amplitude signal (default :data:`DEFAULT_RMS_M`).
    seed : int, optional
        Seed of the random generator; equal seeds give identical signals.

    Returns
    -------
    ndarray, shape (round(duration_s * sample_rate_hz),)
        Displacement in m.
    """
    return 0.5 * test_signal(duration_s, sample_rate_hz, rms_m, seed)


# the test functions are not pytest tests
test_signal.__test__ = False  # type: ignore[attr-defined]
test_signal_50.__test__ = False  # type: ignore[attr-defined]
test_signal_shape.__test__ = False  # type: ignore[attr-defined]

#: signal name -> function (duration_s, sample_rate_hz, rms_m, seed) -> x[n_samples] in m
SIGNALS: dict[str, Callable[..., np.ndarray]] = {
    "white-noise": white_noise,
    "test": test_signal,
    "test-50": test_signal_50,
}


def drive_signal(
    name: str,
    duration_s: float,
    sample_rate_hz: float,
    rms_m: float = DEFAULT_RMS_M,
    seed: int = 0,
) -> np.ndarray:
    """Return the drive signal ``name`` from :data:`SIGNALS`.

    Parameters
    ----------
    name : {'white-noise', 'test', 'test-50'}
        Signal name.
    duration_s, sample_rate_hz, rms_m, seed
        As :func:`white_noise`.

    Returns
    -------
    ndarray, shape (round(duration_s * sample_rate_hz),)
        Displacement in m.

    Raises
    ------
    InputError
        For an unknown name (the message lists the known ones) or bad arguments.
    """
    try:
        fn = SIGNALS[name]
    except (KeyError, TypeError):
        raise InputError(
            f"drive signal {name!r} is unknown; expected one of {', '.join(SIGNALS)}"
        ) from None
    return fn(duration_s, sample_rate_hz, rms_m, seed)


def acceleration_rms_of_flat_band(rms_m: float, band_hz: tuple[float, float]) -> float:
    """Rms acceleration in m/s^2 of a displacement with flat PSD over ``band_hz``.

    ``a_rms = x_rms (2 pi)^2 sqrt((f2^5 - f1^5) / (5 (f2 - f1)))``; used to choose a
    realistic drive amplitude.

    Parameters
    ----------
    rms_m : float
        Rms displacement (m).
    band_hz : tuple of 2 float
        ``(f1, f2)``: the band of the flat displacement PSD (Hz), ``f2 > f1``.

    Returns
    -------
    float
        Rms acceleration (m/s^2).
    """
    f1, f2 = band_hz
    return rms_m * (2 * math.pi) ** 2 * math.sqrt((f2**5 - f1**5) / (5 * (f2 - f1)))


# ---------------------------------------------------------------------------------------
# Resampling and PSD
# ---------------------------------------------------------------------------------------


def rational_ratio(from_hz: float, to_hz: float, max_denominator: int = 100_000) -> tuple[int, int]:
    """Return ``(up, down)`` with ``to_hz / from_hz == up / down`` in lowest terms.

    Rates are read as the decimals they print as, so 1000 Hz -> 204.8 Hz gives
    exactly (128, 625).

    Parameters
    ----------
    from_hz, to_hz : float
        Source and target sample rates (Hz), finite and > 0.
    max_denominator : int
        Largest ``up`` or ``down`` accepted.

    Returns
    -------
    up, down : int
        Upsampling and downsampling factors.

    Raises
    ------
    InputError
        If the ratio needs a denominator above ``max_denominator`` (an irrational-
        looking ratio; resample to a rate with a simpler ratio).
    """
    for label, value in (("from_hz", from_hz), ("to_hz", to_hz)):
        if not (
            isinstance(value, (int, float, np.floating, np.integer))
            and math.isfinite(value)
            and value > 0
        ):
            raise InputError(f"{label} {value!r}; expected a finite sample rate > 0 Hz")
    ratio = Fraction(repr(float(to_hz))) / Fraction(repr(float(from_hz)))
    if ratio.denominator > max_denominator or ratio.numerator > max_denominator:
        raise InputError(
            f"resampling {from_hz!r} Hz -> {to_hz!r} Hz needs the ratio {ratio}, beyond "
            f"{max_denominator}; choose rates with a simpler rational ratio"
        )
    return ratio.numerator, ratio.denominator


def resample(
    x: np.ndarray,
    from_hz: float,
    to_hz: float,
    *,
    axis: int = -1,
    passband: float = 0.8,
    attenuation_db: float = 80.0,
) -> np.ndarray:
    """Resample with a polyphase anti-aliasing filter (rational factor up/down).

    The linear-phase Kaiser FIR filter is flat (ripple ~1e-4) up to
    ``passband * f_N`` and attenuates by ``attenuation_db`` from ``f_N`` on, with
    ``f_N = min(from_hz, to_hz) / 2``: nothing above the new Nyquist frequency aliases
    into the result. 1000 Hz -> 204.8 Hz (thesis Section 7.2) uses up/down = 128/625,
    pass band to 81.9 Hz.

    Parameters
    ----------
    x : ndarray, shape (..., n_samples, ...)
        Signals; resampled along ``axis``.
    from_hz, to_hz : float
        Present and wanted sampling rate in Hz.
    axis : int, optional
        Time axis (default last, matching ``x[n_channels, n_samples]``).
    passband : float, optional
        Pass-band edge as a fraction of the lower Nyquist frequency, in (0, 1).
    attenuation_db : float, optional
        Stop-band attenuation in dB (> 20).

    Returns
    -------
    ndarray
        Resampled signals; the time axis has ``ceil(n_samples * up / down)`` samples,
        the first at the same instant as the input's first sample.

    Raises
    ------
    InputError
        On bad rates, ``passband`` or ``attenuation_db``, or non-finite samples.

    References
    ----------
    .. [1] Crochiere, R. E. and Rabiner, L. R., *Multirate Digital Signal Processing*,
       Prentice-Hall, 1983 (polyphase rational resampling).
    .. [2] Kaiser, J. F., "Nonrecursive digital filter design using the I0-sinh window
       function", Proc. IEEE ISCAS, 1974.
    """
    up, down = rational_ratio(from_hz, to_hz)
    if not 0.0 < passband < 1.0:
        raise InputError(f"passband {passband!r}; expected a fraction in (0, 1)")
    if not attenuation_db > 20.0:
        raise InputError(f"attenuation_db {attenuation_db!r}; expected > 20 dB")
    x = np.asarray(x, dtype=np.float64)
    if not np.all(np.isfinite(x)):
        idx = np.argwhere(~np.isfinite(x))[0]
        raise InputError(
            f"resample: x has non-finite samples, the first at index {tuple(int(v) for v in idx)}"
        )
    if up == down:
        return x.copy()
    # filter designed at the intermediate rate up * from_hz, normalised to its Nyquist
    f_nyq_low = min(from_hz, to_hz) / 2.0
    nyq_mid = up * from_hz / 2.0
    width = (1.0 - passband) * f_nyq_low / nyq_mid
    numtaps, beta = sps.kaiserord(attenuation_db, width)
    numtaps |= 1  # odd length: zero group delay after resample_poly's centring
    cutoff = 0.5 * (1.0 + passband) * f_nyq_low / nyq_mid
    h = sps.firwin(numtaps, cutoff, window=("kaiser", beta))
    return sps.resample_poly(x, up, down, axis=axis, window=h)


def psd(
    x: np.ndarray,
    fs: float,
    resolution_hz: float = 0.2,
    *,
    axis: int = -1,
    detrend: str | bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """One-sided power spectral density by Welch's method.

    Hann window, segments of ``round(fs / resolution_hz)`` samples, 50 % overlap,
    no detrending by default (removing each segment's plain mean before the Hann
    window leaks in-band power into the lowest bins at about 1e-3 of the band level).

    Parameters
    ----------
    x : ndarray, shape (..., n_samples)
        Signals in unit U (e.g. m for displacement).
    fs : float
        Sampling rate in Hz.
    resolution_hz : float, optional
        Frequency resolution in Hz (default 0.2 Hz, as the thesis's FRFs).
    axis : int, optional
        Time axis.
    detrend : {False, 'constant', 'linear'}, optional
        Per-segment detrending passed to :func:`scipy.signal.welch`.

    Returns
    -------
    f_hz : ndarray, shape (n_freq,)
        Frequencies in Hz.
    pxx : ndarray, shape (..., n_freq)
        PSD in U^2/Hz (m^2/Hz for displacement); ``sum(pxx) * df`` is the variance.

    Raises
    ------
    InputError
        If the signal is shorter than one segment or the arguments are out of range.

    References
    ----------
    .. [1] Welch, P. D., "The use of fast Fourier transform for the estimation of power
       spectra", IEEE Trans. Audio Electroacoust. 15 (1967) 70-73.
    """
    if not (math.isfinite(fs) and fs > 0):
        raise InputError(f"fs {fs!r}; expected a sample rate > 0 Hz")
    if not (math.isfinite(resolution_hz) and 0 < resolution_hz < fs / 2):
        raise InputError(f"resolution_hz {resolution_hz!r}; expected 0 < resolution < fs/2")
    x = np.asarray(x, dtype=np.float64)
    nperseg = int(round(fs / resolution_hz))
    if x.shape[axis] < nperseg:
        raise InputError(
            f"psd: {x.shape[axis]} samples is shorter than one segment of {nperseg} samples "
            f"for {resolution_hz} Hz resolution at {fs} Hz; use a coarser resolution"
        )
    return sps.welch(
        x,
        fs=fs,
        window="hann",
        nperseg=nperseg,
        noverlap=nperseg // 2,
        detrend=detrend,
        axis=axis,
        scaling="density",
    )
