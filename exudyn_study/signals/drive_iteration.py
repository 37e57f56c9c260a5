"""Drive-signal iteration (time waveform replication), thesis Section 7.1, Fig. 21.

The rig is displacement controlled; the simulated response at the control sensors
(``ARFVZ``, ``ARFHZ``, next to the linkage) must match the measured one before the
responses elsewhere are compared. With H the FRF from the drive to the control
sensors and ``H^+`` a regularised pseudo-inverse,

    D_0     = H^+ A_m
    D_{k+1} = D_k + gain * H^+ (A_m - A_sim,k)

until the rms error at every control channel is below a tolerance or after N
iterations. This module is the pure algorithm: it takes a callable
``simulate(drive[n_samples]) -> response[n_control, n_samples]`` (an Exudyn model, a
linearised model, or any plant) and the measured target; it imports no solver.

FRF model
---------
H is estimated from a white-noise identification run of ``simulate`` (H1 over Welch
segments, :func:`estimate_frf`) or given. With ``update_frf=True`` (default) H is
re-estimated after every iteration from all (drive, response) pairs so far, as
time-waveform-replication software does; this matters when the initial H lacks
dynamics of the plant. A fixed H converges only where ``gain * H_plant / H_model``
lies in the disc ``|1 - z| < 1``; above a resonance the model misses (the rig's
~28 Hz resonance, thesis Fig. 20) the ratio's phase passes -90 deg and the fixed-H
iteration diverges there for any gain.

Inverse
-------
Tikhonov-regularised, frequency dependent: ``H^+ = (H^H H + lambda(f) I)^-1 H^H`` with
``lambda(f) = reg^2 * <|H|^2>(f)``, the squared FRF norm smoothed over +-1/6 octave;
so the steep f^2 trend of displacement -> acceleration is inverted fully while dips
(antiresonances) deeper than ``reg`` relative to their neighbourhood are limited.
Outside the drive band (default 3-60 Hz) the inverse is tapered to zero, so the
drive stays in band. The inverse is applied as a centred (non-causal) FIR filter
obtained from ``H^+`` on the Welch grid, windowed to its segment length.

References
----------
.. [1] Cryer, B. W., Nawrocki, P. E. and Lund, R. A., "A road simulation system for
   heavy duty vehicles", SAE Technical Paper 760361, 1976 (time waveform replication).
.. [2] De Cuyper, J., Coppens, D., Liefooghe, C., Swevers, J. and Verhaegen, M.,
   "Advanced drive file development methods for improved service load simulation on
   multi axial durability test rigs", Proc. ISMA, 1999.
.. [3] Bendat, J. S. and Piersol, A. G., *Random Data*, 4th ed., Wiley, 2010
   (H1 estimator, Section 9.2).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import signal as sps

from exudyn_study.errors import InputError, SimulationError
from exudyn_study.recording.types import Recording
from exudyn_study.signals.drives import DEFAULT_RMS_M, WHITE_NOISE_BAND_HZ, resample, white_noise

__all__ = [
    "DriveFRF",
    "DriveIterationResult",
    "estimate_frf",
    "identify_frf",
    "regularised_inverse",
    "apply_inverse",
    "iterate_drive",
    "target_from_recording",
]

logger = logging.getLogger(__name__)

_TAPER_HZ = 1.0  # width of the cosine taper of the inverse outside the drive band
_COHERENCE_MIN = 0.8  # keep the prior H where the updated estimate is less coherent


@dataclass(frozen=True, eq=False)
class DriveFRF:
    """FRF from the drive to the control channels.

    Parameters
    ----------
    freq_hz : ndarray, shape (n_freq,)
        Uniform frequency grid from 0 Hz to the Nyquist frequency (a Welch grid:
        ``n_freq = nperseg // 2 + 1``).
    H : ndarray, shape (n_control, 1, n_freq)
        Complex FRF, response unit per m of drive (e.g. (m/s^2)/m); layout
        ``H[n_out, n_in, n_freq]``. A 2-D ``H[n_control, n_freq]`` is accepted.
    sample_rate_hz : float
        Sampling rate the FRF belongs to, in Hz.

    Raises
    ------
    InputError
        On inconsistent shapes, a non-uniform grid or non-finite values.
    """

    freq_hz: np.ndarray
    H: np.ndarray
    sample_rate_hz: float

    def __post_init__(self) -> None:
        f = np.asarray(self.freq_hz, dtype=float)
        H = np.asarray(self.H, dtype=complex)
        if H.ndim == 2:
            H = H[:, None, :]
        if f.ndim != 1 or f.size < 3 or H.ndim != 3 or H.shape[1] != 1 or H.shape[2] != f.size:
            raise InputError(
                f"DriveFRF: freq_hz {f.shape} and H {np.shape(self.H)}; expected (n_freq,) "
                "and (n_control, 1, n_freq)"
            )
        df = np.diff(f)
        if f[0] != 0.0 or not np.allclose(df, df[0], rtol=1e-9):
            raise InputError("DriveFRF: freq_hz must be a uniform grid starting at 0 Hz")
        if not math.isclose(f[-1], self.sample_rate_hz / 2, rel_tol=1e-9):
            raise InputError(
                f"DriveFRF: the grid ends at {f[-1]} Hz; expected the Nyquist frequency "
                f"{self.sample_rate_hz / 2} Hz of sample_rate_hz {self.sample_rate_hz}"
            )
        if not np.all(np.isfinite(H)):
            raise InputError("DriveFRF: H has non-finite values")
        f.flags.writeable = False
        H.flags.writeable = False
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "H", H)
        object.__setattr__(self, "sample_rate_hz", float(self.sample_rate_hz))

    @property
    def nperseg(self) -> int:
        """Segment length in samples of the grid, ``2 (n_freq - 1)``."""
        return 2 * (self.freq_hz.size - 1)

    def at(self, freq_hz: np.ndarray) -> np.ndarray:
        """H interpolated (real and imaginary part, linear) at ``freq_hz``, shape (n_control, n).

        Parameters
        ----------
        freq_hz : array_like, shape (n,)
            Frequencies (Hz); beyond the grid the end values are held.

        Returns
        -------
        ndarray, complex, shape (n_control, n)
            Response of each control channel per unit drive, in the units of ``H``.
        """
        f = np.asarray(freq_hz, dtype=float)
        return np.array(
            [
                np.interp(f, self.freq_hz, h.real) + 1j * np.interp(f, self.freq_hz, h.imag)
                for h in self.H[:, 0, :]
            ]
        )


@dataclass(frozen=True, eq=False)
class DriveIterationResult:
    """Outcome of :func:`iterate_drive`.

    Parameters
    ----------
    drive : ndarray, shape (n_samples,)
        The final drive in m (the best iterate: lowest worst-channel error).
    response : ndarray, shape (n_control, n_samples)
        The simulated control response to ``drive``.
    errors : ndarray, shape (n_runs, n_control)
        Relative rms error ``rms(A_m - A_sim,k) / rms(A_m)`` per simulated drive
        ``D_k`` (row k) and control channel.
    converged : bool
        Whether the worst channel's error fell below the tolerance.
    tolerance : float
        The tolerance used.
    control_names : tuple of str
        Names of the control channels (or ``'control 0'``, ...).
    frf : DriveFRF
        The FRF model in use at the end.
    drives : tuple of ndarray
        Every iterate D_0, D_1, ... (shape (n_samples,) each).
    """

    drive: np.ndarray
    response: np.ndarray
    errors: np.ndarray
    converged: bool
    tolerance: float
    control_names: tuple[str, ...]
    frf: DriveFRF
    drives: tuple[np.ndarray, ...] = field(repr=False, default=())

    @property
    def n_iterations(self) -> int:
        """Number of updates after D_0 (simulation runs minus one)."""
        return int(self.errors.shape[0]) - 1

    @property
    def best_error(self) -> float:
        """Worst-channel relative rms error of the returned drive."""
        return float(self.errors.max(axis=1).min())

    def as_dict(self) -> dict:
        """JSON-ready summary: tolerance, convergence and the error table."""
        return {
            "converged": self.converged,
            "tolerance": self.tolerance,
            "iterations": self.n_iterations,
            "control_channels": list(self.control_names),
            "rms_error": [
                {name: float(e) for name, e in zip(self.control_names, row, strict=True)}
                for row in self.errors
            ],
        }


def _welch_nperseg(fs: float, resolution_hz: float, n: int) -> int:
    if not (math.isfinite(resolution_hz) and resolution_hz > 0):
        raise InputError(f"resolution_hz {resolution_hz!r}; expected a resolution > 0 Hz")
    nperseg = int(round(fs / resolution_hz))
    nperseg += nperseg % 2  # even: the grid ends at Nyquist
    if nperseg * 2 > n:
        raise InputError(
            f"{n} samples give fewer than 2 Welch segments of {nperseg} samples for "
            f"{resolution_hz} Hz resolution at {fs} Hz; use a longer signal or a coarser resolution"
        )
    return nperseg


def _cross_spectra(drive: np.ndarray, response: np.ndarray, fs: float, nperseg: int):
    kw = dict(fs=fs, window="hann", nperseg=nperseg, noverlap=nperseg // 2, detrend=False)
    f, s_dd = sps.csd(drive, drive, **kw)
    _, s_ad = sps.csd(drive[None, :], response, **kw)  # E[conj(D) A]
    _, s_aa = sps.csd(response, response, **kw)
    return f, s_dd.real, s_ad, s_aa.real


def estimate_frf(
    drive: np.ndarray, response: np.ndarray, sample_rate_hz: float, resolution_hz: float = 0.2
) -> tuple[DriveFRF, np.ndarray]:
    """H1 estimate of the FRF from the drive to each response channel (Welch).

    ``H1 = S_da / S_dd`` with Hann-windowed segments of ``fs / resolution_hz``
    samples and 50 % overlap.

    Parameters
    ----------
    drive : ndarray, shape (n_samples,)
        Drive displacement in m.
    response : ndarray, shape (n_control, n_samples)
        Responses (e.g. accelerations in m/s^2).
    sample_rate_hz : float
        Sampling rate in Hz of both.
    resolution_hz : float, optional
        Frequency resolution in Hz (default 0.2 Hz).

    Returns
    -------
    frf : DriveFRF
        ``H[n_control, 1, n_freq]``.
    coherence : ndarray, shape (n_control, n_freq)
        Ordinary coherence of drive and each response.

    Raises
    ------
    InputError
        On shape mismatches, non-finite data or a signal shorter than two segments.

    References
    ----------
    .. [1] Bendat, J. S. and Piersol, A. G., *Random Data*, Wiley, 2010, Section 9.2.
    """
    d, a = _check_pair(drive, response, "estimate_frf")
    nperseg = _welch_nperseg(sample_rate_hz, resolution_hz, d.size)
    f, s_dd, s_ad, s_aa = _cross_spectra(d, a, sample_rate_hz, nperseg)
    return _frf_from_spectra(f, s_dd, s_ad, s_aa, sample_rate_hz)


def _frf_from_spectra(f, s_dd, s_ad, s_aa, fs) -> tuple[DriveFRF, np.ndarray]:
    tiny = np.finfo(float).tiny
    H = s_ad / np.maximum(s_dd, tiny)
    coh = np.abs(s_ad) ** 2 / np.maximum(s_dd * s_aa, tiny)
    return DriveFRF(f, H[:, None, :], fs), np.clip(coh, 0.0, 1.0)


def _check_pair(drive, response, where: str) -> tuple[np.ndarray, np.ndarray]:
    d = np.asarray(drive, dtype=float)
    a = np.atleast_2d(np.asarray(response, dtype=float))
    if d.ndim != 1 or a.ndim != 2 or a.shape[1] != d.size:
        raise InputError(
            f"{where}: drive {d.shape} and response {a.shape}; expected (n_samples,) and "
            "(n_control, n_samples)"
        )
    for label, x in (("drive", d), ("response", a)):
        bad = np.argwhere(~np.isfinite(x))
        if bad.size:
            raise InputError(
                f"{where}: {label} has a non-finite value at index {tuple(int(v) for v in bad[0])}"
            )
    return d, a


def identify_frf(
    simulate: Callable[[np.ndarray], np.ndarray],
    sample_rate_hz: float,
    duration_s: float,
    *,
    rms_m: float = DEFAULT_RMS_M,
    seed: int = 0,
    resolution_hz: float = 0.2,
    n_control: int | None = None,
) -> tuple[DriveFRF, np.ndarray]:
    """Identify H by a band-limited white-noise run (3-60 Hz) of ``simulate``.

    Parameters
    ----------
    simulate : callable
        ``simulate(drive[n_samples]) -> response[n_control, n_samples]``.
    sample_rate_hz : float
        Rate in Hz of the drive and response.
    duration_s : float
        Length of the identification run in s.
    rms_m : float, optional
        Rms of the white-noise drive in m.
    seed : int, optional
        Seed of the white noise.
    resolution_hz : float, optional
        FRF resolution in Hz.
    n_control : int, optional
        Expected number of response channels (checked).

    Returns
    -------
    frf : DriveFRF
    coherence : ndarray, shape (n_control, n_freq)
    """
    d = white_noise(duration_s, sample_rate_hz, rms_m, seed)
    return estimate_frf(d, _run(simulate, d, n_control), sample_rate_hz, resolution_hz)


def _smoothed_power(f: np.ndarray, p: np.ndarray, octave_fraction: float = 1 / 6) -> np.ndarray:
    """Mean of ``p`` over [f 2^-a, f 2^a] for each f (a = octave_fraction)."""
    c = np.r_[0.0, np.cumsum(p)]
    lo = np.searchsorted(f, f * 2.0**-octave_fraction, side="left")
    hi = np.searchsorted(f, f * 2.0**octave_fraction, side="right")
    hi = np.maximum(hi, lo + 1)
    return (c[hi] - c[lo]) / (hi - lo)


def _band_mask(f: np.ndarray, band_hz: tuple[float, float]) -> np.ndarray:
    f1, f2 = band_hz
    mask = ((f >= f1) & (f <= f2)).astype(float)
    for edge, side in ((f1, -1.0), (f2, 1.0)):
        dist = side * (f - edge)
        taper = (dist > 0) & (dist < _TAPER_HZ)
        mask[taper] = np.cos(0.5 * np.pi * dist[taper] / _TAPER_HZ) ** 2
    return mask


def regularised_inverse(
    frf: DriveFRF,
    reg: float = 0.05,
    band_hz: tuple[float, float] = WHITE_NOISE_BAND_HZ,
) -> np.ndarray:
    """Tikhonov-regularised pseudo-inverse of H, frequency dependent.

    ``H^+(f) = (H^H H + lambda(f) I)^-1 H^H`` with ``lambda(f) = reg^2 <|H|^2>(f)``,
    ``<.>`` the mean over +-1/6 octave, tapered to zero outside ``band_hz``.

    Parameters
    ----------
    frf : DriveFRF
        ``H[n_control, 1, n_freq]``.
    reg : float, optional
        Relative regularisation (> 0): dips of ``|H|`` below ``reg`` times their
        neighbourhood are not inverted fully.
    band_hz : (float, float), optional
        Drive band in Hz; the inverse is zero outside it (1 Hz cosine taper).

    Returns
    -------
    ndarray, shape (1, n_control, n_freq)
        ``H^+[n_in, n_out, n_freq]``, m per response unit.

    Raises
    ------
    InputError
        On ``reg <= 0`` or a band outside (0, Nyquist).
    """
    if not (math.isfinite(reg) and reg > 0):
        raise InputError(f"reg {reg!r}; expected a relative regularisation > 0 (e.g. 0.05)")
    f1, f2 = band_hz
    if not (0 < f1 < f2 < frf.sample_rate_hz / 2):
        raise InputError(
            f"band_hz {band_hz!r}; expected 0 < f1 < f2 < {frf.sample_rate_hz / 2} Hz (Nyquist)"
        )
    H = frf.H[:, 0, :]  # (n_control, n_freq): one drive
    power = np.sum(np.abs(H) ** 2, axis=0)  # H^H H, scalar per frequency
    lam = reg**2 * _smoothed_power(frf.freq_hz, power)
    tiny = np.finfo(float).tiny
    inv = np.conj(H) / np.maximum(power + lam, tiny)
    inv *= _band_mask(frf.freq_hz, band_hz)
    return inv[None, :, :]


def _inverse_fir(h_inv: np.ndarray) -> np.ndarray:
    """Centred FIR kernels from H^+ on a Welch grid, shape (n_control, nperseg + 1)."""
    n_freq = h_inv.shape[-1]
    nperseg = 2 * (n_freq - 1)
    k = np.fft.irfft(h_inv[0], n=nperseg, axis=-1)  # circular impulse responses
    k = np.fft.fftshift(k, axes=-1)  # lag 0 at index nperseg // 2
    k = np.concatenate([k, k[:, :1]], axis=-1)  # odd length, symmetric support
    return k * sps.windows.tukey(nperseg + 1, alpha=0.5)[None, :]


def apply_inverse(h_inv: np.ndarray, response: np.ndarray) -> np.ndarray:
    """Drive increment ``H^+ e`` as a centred FIR filter over the whole record.

    Parameters
    ----------
    h_inv : ndarray, shape (1, n_control, n_freq)
        Regularised inverse from :func:`regularised_inverse`.
    response : ndarray, shape (n_control, n_samples)
        Response (or response error) to invert.

    Returns
    -------
    ndarray, shape (n_samples,)
        Drive in m.
    """
    kern = _inverse_fir(h_inv)
    c = (kern.shape[1] - 1) // 2
    e = np.atleast_2d(response)
    full = sps.fftconvolve(e, kern, axes=-1)  # (n_control, n + len - 1)
    return full[:, c : c + e.shape[1]].sum(axis=0)


def _run(simulate, drive: np.ndarray, n_control: int | None) -> np.ndarray:
    out = np.atleast_2d(np.asarray(simulate(drive), dtype=float))
    if out.ndim != 2 or out.shape[1] != drive.size or (n_control and out.shape[0] != n_control):
        raise InputError(
            f"simulate returned shape {out.shape}; expected ({n_control or 'n_control'}, "
            f"{drive.size}) for a drive of {drive.size} samples"
        )
    if not np.all(np.isfinite(out)):
        raise SimulationError("simulate returned non-finite responses (diverged?)")
    return out


def iterate_drive(
    simulate: Callable[[np.ndarray], np.ndarray],
    target: np.ndarray,
    sample_rate_hz: float,
    *,
    frf: DriveFRF | None = None,
    identification_s: float | None = None,
    resolution_hz: float = 0.2,
    band_hz: tuple[float, float] = WHITE_NOISE_BAND_HZ,
    reg: float = 0.05,
    gain: float = 1.0,
    tol: float = 0.05,
    max_iter: int = 10,
    update_frf: bool = True,
    control_names: Sequence[str] | None = None,
) -> DriveIterationResult:
    """Iterate the drive until the simulated control response matches the target.

    ``D_0 = H^+ A_m``; ``D_{k+1} = D_k + gain H^+ (A_m - A_sim,k)``; stop when the
    worst control channel's relative rms error ``rms(A_m - A_sim,k) / rms(A_m)`` is
    below ``tol`` or after ``max_iter`` updates (thesis Section 7.1, Fig. 21).

    Parameters
    ----------
    simulate : callable
        ``simulate(drive[n_samples]) -> response[n_control, n_samples]``, drive in m,
        response in the target's unit, same rate and length.
    target : ndarray, shape (n_control, n_samples)
        Measured control response A_m (e.g. ARFVZ, ARFHZ in m/s^2).
    sample_rate_hz : float
        Rate in Hz of drive, response and target.
    frf : DriveFRF, optional
        Initial FRF model. Default: identified from a white-noise run of
        ``simulate`` (:func:`identify_frf`).
    identification_s : float, optional
        Length of that run in s (default: the target's duration).
    resolution_hz : float, optional
        FRF resolution in Hz (default 0.2 Hz).
    band_hz : (float, float), optional
        Drive band in Hz (default 3-60 Hz).
    reg : float, optional
        Relative Tikhonov regularisation of the inverse (default 0.05).
    gain : float, optional
        Update gain in (0, 2) (default 1).
    tol : float, optional
        Relative rms error tolerance (default 0.05 = 5 %).
    max_iter : int, optional
        Maximum number of updates after D_0 (default 10, as the thesis).
    update_frf : bool, optional
        Re-estimate H after every run from all (drive, response) pairs (default
        True); False keeps H fixed, the plain scheme of thesis Fig. 21.
    control_names : sequence of str, optional
        Names of the control channels for the result.

    Returns
    -------
    DriveIterationResult
        Best drive, its response, and the error per run and control channel.

    Raises
    ------
    InputError
        On bad shapes or arguments, non-finite target data, or an FRF whose rate or
        channel count does not match.
    SimulationError
        If ``simulate`` returns non-finite values.
    """
    a_m = np.atleast_2d(np.asarray(target, dtype=float))
    if a_m.ndim != 2:
        raise InputError(f"target of shape {a_m.shape}; expected (n_control, n_samples)")
    bad = np.argwhere(~np.isfinite(a_m))
    if bad.size:
        raise InputError(
            f"target has a non-finite value at (channel, sample) {tuple(int(v) for v in bad[0])}"
        )
    n_control, n = a_m.shape
    names = (
        tuple(control_names)
        if control_names is not None
        else tuple(f"control {i}" for i in range(n_control))
    )
    if len(names) != n_control:
        raise InputError(f"control_names has {len(names)} names for {n_control} target channels")
    if not 0 < gain < 2:
        raise InputError(f"gain {gain!r}; expected 0 < gain < 2")
    if not (tol > 0 and int(max_iter) == max_iter and max_iter >= 0):
        raise InputError(f"tol {tol!r} / max_iter {max_iter!r}; expected tol > 0, max_iter >= 0")
    ref = np.sqrt(np.mean(a_m**2, axis=1))
    if np.any(ref == 0):
        raise InputError(
            f"target channel {names[int(np.argmin(ref))]!r} is identically zero; nothing to match"
        )

    if frf is None:
        frf, _ = identify_frf(
            simulate,
            sample_rate_hz,
            identification_s or n / sample_rate_hz,
            resolution_hz=resolution_hz,
            n_control=n_control,
        )
    if frf.H.shape[0] != n_control or not math.isclose(frf.sample_rate_hz, sample_rate_hz):
        raise InputError(
            f"frf has {frf.H.shape[0]} channels at {frf.sample_rate_hz} Hz; expected "
            f"{n_control} at {sample_rate_hz} Hz"
        )
    nperseg = frf.nperseg
    if 2 * nperseg > n:
        raise InputError(
            f"target of {n} samples is shorter than two FRF segments ({nperseg} samples)"
        )
    prior = frf
    h_inv = regularised_inverse(frf, reg, band_hz)
    spectra = None  # accumulated (s_dd, s_ad, s_aa) of all runs

    drive = apply_inverse(h_inv, a_m)
    drives, errors, responses = [], [], []
    for k in range(int(max_iter) + 1):
        a_k = _run(simulate, drive, n_control)
        err = np.sqrt(np.mean((a_m - a_k) ** 2, axis=1)) / ref
        drives.append(drive)
        errors.append(err)
        responses.append(a_k)
        logger.info("drive iteration %d: rms error %s", k, np.array2string(err, precision=4))
        if err.max() < tol or k == max_iter:
            break
        if update_frf:
            f, s_dd, s_ad, s_aa = _cross_spectra(drive, a_k, sample_rate_hz, nperseg)
            if spectra is None:
                spectra = [s_dd, s_ad, s_aa]
            else:
                spectra = [spectra[0] + s_dd, spectra[1] + s_ad, spectra[2] + s_aa]
            est, coh = _frf_from_spectra(f, *spectra, sample_rate_hz)
            keep = coh >= _COHERENCE_MIN
            H = np.where(keep[:, None, :], est.H, prior.H)
            frf = DriveFRF(f, H, sample_rate_hz)
            h_inv = regularised_inverse(frf, reg, band_hz)
        drive = drive + gain * apply_inverse(h_inv, a_m - a_k)

    errors_arr = np.array(errors)
    best = int(np.argmin(errors_arr.max(axis=1)))
    return DriveIterationResult(
        drive=drives[best],
        response=responses[best],
        errors=errors_arr,
        converged=bool(errors_arr[best].max() < tol),
        tolerance=float(tol),
        control_names=names,
        frf=frf,
        drives=tuple(drives),
    )


def target_from_recording(
    measured: Recording,
    control: Sequence[str] = ("ARFVZ", "ARFHZ"),
    rate_hz: float | None = None,
) -> tuple[np.ndarray, float]:
    """Control-channel target ``A_m[n_control, n_samples]`` from a measured recording.

    Parameters
    ----------
    measured : Recording
        The measured recording (responses at e.g. 1000 Hz).
    control : sequence of str, optional
        Control channels (default the thesis's ``ARFVZ``, ``ARFHZ``).
    rate_hz : float, optional
        Rate of the simulation in Hz; the target is resampled to it, anti-aliased
        (e.g. 1000 -> 204.8 Hz). Default: keep the recording's rate.

    Returns
    -------
    target : ndarray, shape (n_control, n_samples)
    rate_hz : float

    Raises
    ------
    InputError
        If a control channel is missing from the recording (the message names it and
        the available channels) or the channels have mixed rates.
    """
    if not isinstance(measured, Recording):
        raise InputError(f"measured is a {type(measured).__name__}; expected a Recording")
    missing = [c for c in control if c not in measured.names]
    if missing:
        raise InputError(
            f"control channel(s) {', '.join(missing)} missing from the recording; it has "
            f"{', '.join(measured.names[:10])}{', ...' if len(measured) > 10 else ''}"
        )
    x, fs = measured.time_data(list(control))
    if rate_hz is None or rate_hz == fs:
        return x, fs
    return resample(x, fs, rate_hz), float(rate_hz)
