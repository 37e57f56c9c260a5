"""Compare a rig model with recordings: residuals, their significance, error metrics.

The first stage of :func:`~exudyn_study.diagnose.rig.diagnose_rig` is :func:`compare` (a model
against all recordings: a :class:`~exudyn_study.diagnose.rig_state.Comparison`); the functions
below it are its numerics.

A recording's drive channel (the controller's piston displacement, 204.8 Hz) drives the
model (:func:`~exudyn_study.simulate.simulate_linear`, exact); the residual is
``e = a_measured - a_simulated`` per channel.

Significance (:func:`significance_map`) uses the fact that a model error leaves a residual
*coherent with the drive* (``e = (H_true - H_model) u + noise``), while a right model leaves
only measurement noise, which is not: the magnitude-squared coherence ``g2`` between drive
and residual over ``n_d`` independent Welch segments has, under "nothing missing", the
distribution ``P(g2 > x) = (1 - x)^(n_d - 1)``. Per channel and band the mean coherence is
compared with its null mean ``1/n_d`` (z-score over the band's bins), and a mismatch counts
only if it is significant (``z > z_threshold``, Bonferroni-sized for all channel-band cells)
*and* its coherent residual amplitude is at least ``min_effect`` of the response in that
band (smaller errors are below what a rig model can be asked for: 0.5 % by default).

Error metric (:func:`relative_errors`): per channel the band-limited (3-60 Hz) rms of the
residual over that of the measurement; the summary is their quadratic mean over channels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import signal as sps

from exudyn_study.errors import InputError

__all__ = [
    "RigRecording",
    "prepare",
    "band_filter",
    "significance_map",
    "relative_errors",
    "BANDS_HZ",
    "METRIC",
    "summary_error",
    "DriveSpectra",
    "drive_spectra",
    "compare",
    "Comparison",
]

RATE_HZ = 1000.0
SKIP_S = 1.0  # start-up (fade-in) not compared
BAND_HZ = (3.0, 60.0)
#: bands of the residual map (Hz)
BANDS_HZ = (
    (3.0, 8.0),
    (8.0, 13.0),
    (13.0, 18.0),
    (18.0, 24.0),
    (24.0, 30.0),
    (30.0, 37.0),
    (37.0, 45.0),
    (45.0, 52.0),
    (52.0, 60.0),
)
METRIC = (
    "relative band-limited (3-60 Hz) rms error of the simulated accelerations, per channel "
    "rms(a_sim - a_meas) / rms(a_meas); summary: quadratic mean over channels"
)


@dataclass
class RigRecording:
    """A recording prepared for comparison: drive at 1000 Hz, accelerations in model sensor order.

    Parameters
    ----------
    name : str
        Name of the recording.
    drive : Drive
        The recorded drive (piston displacement, m) resampled to 1000 Hz.
    measured : numpy.ndarray
        Measured accelerations (m/s^2), shape (n_channels, n_samples) at 1000 Hz.
    channels : tuple of str
        Channel name of each row of ``measured`` (model sensor names).
    drive_rms_m : float
        Standard deviation of the drive (m).
    filtered : numpy.ndarray, optional
        ``measured`` through :func:`band_filter`, shape (n_channels, n_kept) (None: not computed).
    scale : numpy.ndarray, optional
        1 / band-limited rms of ``measured`` per channel (s^2/m), shape (n_channels,) (None: not computed).
    """

    name: str
    drive: object  # exudyn_study.model.Drive
    measured: np.ndarray  # (n_channels, n)
    channels: tuple
    drive_rms_m: float
    filtered: np.ndarray = field(default=None, repr=False)  # band-passed measured, edges cut
    scale: np.ndarray = field(default=None, repr=False)  # 1 / rms(filtered) per channel


def band_sos():
    """Return the second-order sections of the 3-60 Hz band-pass :func:`band_filter` applies (zero phase).

    Returns
    -------
    numpy.ndarray
        Butterworth band-pass of order 4, shape (n_sections, 6).
    """
    return sps.butter(4, BAND_HZ, btype="bandpass", fs=RATE_HZ, output="sos")


def band_filter(x: np.ndarray) -> np.ndarray:
    """Zero-phase 3-60 Hz band-pass, the start-up and 0.5 s at the end cut, decimated by 4.

    Parameters
    ----------
    x : numpy.ndarray
        Signals at 1000 Hz along the last axis, shape (..., n_samples).

    Returns
    -------
    numpy.ndarray
        Filtered signals at 250 Hz, shape (..., n_kept).
    """
    y = sps.sosfiltfilt(band_sos(), x, axis=-1)
    k0, k1 = int(SKIP_S * RATE_HZ), y.shape[-1] - int(0.5 * RATE_HZ)
    return y[..., k0:k1:4]


def prepare(recording, sensor_names, name: str = "", max_duration_s: float | None = None) -> RigRecording:
    """Align a recording with the model's sensors and resample its drive to 1000 Hz.

    Parameters
    ----------
    recording : Recording
        The recording: channels with ``role`` (one ``'drive'``, ``'response'`` accelerations at 1000 Hz).
    sensor_names : sequence of str
        The model's sensor names.
    name : str, optional
        Name of the recording, in messages and the result (default empty).
    max_duration_s : float or None, optional
        Longest compared duration (s), besides the skipped start and end (None: the whole recording).

    Raises
    ------
    InputError
        No drive channel, a channel the model lacks, a wrong acceleration rate, NaN.

    Returns
    -------
    RigRecording
        The recording aligned with the model's sensors.
    """
    from exudyn_study.model.rig import Drive
    from exudyn_study.signals.drives import resample

    who = f"recording {name!r}" if name else "recording"
    drives = [ch for ch in recording if ch.role == "drive"]
    if not drives:
        raise InputError(
            f"{who} has no drive channel (role 'drive'); the diagnosis replays the recorded drive"
        )
    acc = [ch for ch in recording if ch.role == "response" and ch.quantity == "acceleration"]
    unknown = [ch.name for ch in acc if ch.name not in sensor_names]
    if unknown:
        raise InputError(
            f"{who}: channels {unknown} are not sensors of the model; the model has "
            f"{list(sensor_names)[:6]}...: use the model the recordings were taken on"
        )
    if not acc:
        raise InputError(f"{who} has no acceleration channels")
    for ch in acc:
        if abs(ch.sample_rate_hz - RATE_HZ) > 1e-9:
            raise InputError(f"{who}: channel {ch.name} at {ch.sample_rate_hz} Hz; expected {RATE_HZ} Hz")
    d = drives[0]
    u = np.asarray(d.data, dtype=float)
    if abs(d.sample_rate_hz - RATE_HZ) > 1e-9:
        u = resample(u, d.sample_rate_hz, RATE_HZ)
    n = min(u.size, min(ch.n_samples for ch in acc))
    if max_duration_s is not None:
        n = min(n, int((max_duration_s + SKIP_S + 0.5) * RATE_HZ))
    if n < int(6 * RATE_HZ):
        raise InputError(f"{who} lasts {n / RATE_HZ:.1f} s; expected at least 6 s")
    meas = np.array([ch.data[:n] for ch in acc], dtype=float)
    if not (np.all(np.isfinite(meas)) and np.all(np.isfinite(u[:n]))):
        raise InputError(f"{who} has non-finite samples; clean or cut the recording")
    drive = Drive()
    drive.set_signal(u[:n], RATE_HZ)
    filt = band_filter(meas)
    rms = np.sqrt(np.mean(filt**2, axis=1))
    return RigRecording(
        name,
        drive,
        meas,
        tuple(ch.name for ch in acc),
        float(np.std(u[:n])),
        filt,
        1.0 / np.maximum(rms, 1e-12),
    )


@dataclass
class DriveSpectra:
    """Welch spectra of a drive ``u`` and responses ``y`` (rows): auto, cross, H1 and coherence.

    Attributes
    ----------
    f : ndarray (n_f,)
        Frequencies, Hz.
    suu : ndarray (n_f,)
    suy : ndarray (n_y, n_f)
        Cross spectra drive -> response.
    syy : ndarray (n_y, n_f)
    n_segments : int
        Independent segments (the degrees of freedom of the estimates).
    """

    f: np.ndarray
    suu: np.ndarray
    suy: np.ndarray
    syy: np.ndarray
    n_segments: int

    @property
    def h1(self) -> np.ndarray:
        """H1 estimate ``suy / suu`` (response per unit drive)."""
        return self.suy / self.suu[None, :]

    @property
    def coherence(self) -> np.ndarray:
        """Magnitude-squared coherence, in [0, 1)."""
        return np.clip(np.abs(self.suy) ** 2 / (self.suu[None, :] * self.syy + 1e-300), 0.0, 1.0 - 1e-9)

    def h1_variance(self) -> np.ndarray:
        """Variance of the H1 estimate, ``|H|^2 (1 - g2) / (2 n_d g2)`` (Bendat & Piersol)."""
        g2 = self.coherence
        return np.abs(self.h1) ** 2 * (1 - g2) / (2 * self.n_segments * np.maximum(g2, 1e-6))


def drive_spectra(u: np.ndarray, y: np.ndarray, nperseg: int = 4096, overlap: bool = True) -> DriveSpectra:
    """Welch spectra (Hann, ``nperseg`` samples, 50 % or no overlap) of drive ``u`` and responses ``y``.

    The recordings are at :data:`RATE_HZ`; ``y`` has one response per row. With overlap the
    segments are about half as independent: ``n_segments`` counts ``2 n / nperseg - 1``
    overlapped ones as is (the convention of the H1 variance used here), without overlap
    ``n / nperseg``.

    Parameters
    ----------
    u : numpy.ndarray
        Drive, shape (n_samples,), at 1000 Hz.
    y : numpy.ndarray
        Responses, shape (n_y, n_samples) (or (n_samples,) for one).
    nperseg : int, optional
        Welch segment length in samples (default 4096).
    overlap : bool, optional
        Whether segments overlap by 50 % (default True) or not at all.

    Returns
    -------
    DriveSpectra
        Auto and cross spectra and the number of independent segments.
    """
    y = np.atleast_2d(y)
    noverlap = None if overlap else 0
    f, suu = sps.welch(u, RATE_HZ, nperseg=nperseg, noverlap=noverlap)
    _, suy = sps.csd(u[None, :], y, RATE_HZ, nperseg=nperseg, noverlap=noverlap)
    _, syy = sps.welch(y, RATE_HZ, nperseg=nperseg, noverlap=noverlap)
    n_d = max(2, 2 * u.size // nperseg - 1) if overlap else max(2, u.size // nperseg)
    return DriveSpectra(f, suu, suy, syy, n_d)


def relative_errors(rec: RigRecording, simulated: np.ndarray) -> np.ndarray:
    """Per-channel band-limited relative rms error (see :data:`METRIC`).

    Parameters
    ----------
    rec : RigRecording
        The recording.
    simulated : numpy.ndarray
        Simulated channels, shape (n_channels, n_samples), rows as ``rec.channels``.

    Returns
    -------
    numpy.ndarray
        Relative error per channel, shape (n_channels,) (1 = 100 %).
    """
    e = band_filter(rec.measured - simulated)
    return np.sqrt(np.mean(e**2, axis=1)) * rec.scale


def summary_error(per_channel: np.ndarray) -> float:
    """Quadratic mean over channels.

    Parameters
    ----------
    per_channel : array_like
        Relative error per channel, shape (n_channels,).

    Returns
    -------
    float
        The quadratic mean.
    """
    return float(np.sqrt(np.mean(np.asarray(per_channel) ** 2)))


@dataclass
class SignificanceMap:
    """Per channel x band: z-score of drive-residual coherence, coherent residual share, significant cells."""

    channels: tuple
    bands_hz: tuple
    z: np.ndarray
    effect: np.ndarray  # coherent residual amplitude / response amplitude in the band
    significant: np.ndarray
    n_segments: int
    z_threshold: float


def significance_map(
    rec: RigRecording,
    simulated: np.ndarray,
    nperseg: int = 4096,
    min_effect: float = 0.005,
    p_value: float = 1e-3,
) -> SignificanceMap:
    """Where the residual is significantly coherent with the drive (see the module docstring).

    Parameters
    ----------
    rec : RigRecording
        The recording.
    simulated : numpy.ndarray
        Simulated channels, shape (n_channels, n_samples), rows as ``rec.channels``.
    nperseg : int, optional
        Welch segment length in samples at 1000 Hz, without overlap (default 4096).
    min_effect : float, optional
        Least coherent residual amplitude relative to the response in a band for a cell to count
        (default 0.005, i.e. 0.5 %).
    p_value : float, optional
        Family-wise false-alarm probability over all channel-band cells (default 1e-3).

    Returns
    -------
    SignificanceMap
        Per channel and band: z-score, coherent residual share and significance.
    """
    k0 = int(SKIP_S * RATE_HZ)
    u = rec.drive.samples[k0:]
    e = (rec.measured - simulated)[:, k0:]
    y = rec.measured[:, k0:]
    res = drive_spectra(u, e, nperseg, overlap=False)
    f, see, n_d = res.f, res.syy, res.n_segments
    syy = drive_spectra(u, y, nperseg, overlap=False).syy
    g2 = np.abs(res.suy) ** 2 / (res.suu[None, :] * see + 1e-300)
    coherent = (
        np.maximum(g2 - 1.0 / n_d, 0.0) * see
    )  # residual power coherent with the drive, null bias removed
    n_cells = len(rec.channels) * len(BANDS_HZ)
    # one-sided z threshold for a family-wise p_value over all cells (Bonferroni)
    from scipy.stats import norm

    z_thr = float(norm.isf(p_value / n_cells))
    z = np.zeros((len(rec.channels), len(BANDS_HZ)))
    eff = np.zeros_like(z)
    mean0 = 1.0 / n_d
    var0 = (n_d - 1) / (n_d**2 * (n_d + 1))  # variance of Beta(1, n_d - 1)
    for j, (lo, hi) in enumerate(BANDS_HZ):
        b = (f >= lo) & (f < hi)
        nb = int(b.sum())
        z[:, j] = (g2[:, b].mean(axis=1) - mean0) / math.sqrt(var0 / nb)
        eff[:, j] = np.sqrt(coherent[:, b].sum(axis=1) / np.maximum(syy[:, b].sum(axis=1), 1e-300))
    sig = (z > z_thr) & (eff > min_effect)
    return SignificanceMap(rec.channels, BANDS_HZ, z, eff, sig, n_d, z_thr)


@dataclass(frozen=True)
class Comparison:
    """The current model against the recordings.

    Attributes
    ----------
    sims_tr, sims_ho : list of numpy.ndarray
        Exact simulations at the training and held-out recordings' channels, each (n_channels, n_samples).
    maps : list of SignificanceMap
        Per recording (training, then held out): residual significance per channel x band.
    significant : numpy.ndarray of bool
        (n_channels, n_bands): significant in any recording.
    """

    sims_tr: list
    sims_ho: list
    maps: list
    significant: np.ndarray


def compare(problem, system, gains):
    """Compare ``system`` (with output ``gains``) with the training and held-out recordings.

    Parameters
    ----------
    problem : RigProblem
        The recordings, their exact evaluators and the significance settings
        (:class:`~exudyn_study.diagnose.rig_state.RigProblem`).
    system : LinearSystem or NonlinearSystem
        The model.
    gains : numpy.ndarray or None
        Output gain per channel (None: all one).

    Returns
    -------
    Comparison
        Exact simulations, the significance map per recording and the cells significant in any.
    """
    st = problem.settings
    sims_tr = problem.ev_train.simulate_exact(system, gains)
    sims_ho = problem.ev_hold.simulate_exact(system, gains)
    maps = [
        significance_map(r, s_, min_effect=st.min_effect, p_value=problem.p_cell)
        for r, s_ in zip(problem.train_recs + problem.hold_recs, sims_tr + sims_ho, strict=True)
    ]
    sig = np.zeros((len(problem.channels), len(BANDS_HZ)), dtype=bool)
    for m in maps:
        sig |= m.significant
    return Comparison(sims_tr, sims_ho, maps, sig)
