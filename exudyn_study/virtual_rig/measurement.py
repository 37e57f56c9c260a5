"""The virtual rig's measurement chain: an imperfect servo drive and the accelerometer channels.

Two stages turn an ideal simulation into what the rig's acquisition would have recorded
(thesis Section 3.3, Appendix A; Section 5.1, Figure 13):

:func:`servo_response`
    The servo-hydraulic actuator does not follow its command: a documented analogue
    transfer function from commanded to achieved piston displacement,

    ``H(s) = L(s) * prod_k N_k(s)``, with a second-order loop roll-off
    ``L = w_b^2 / (s^2 + 2 zeta_b w_b s + w_b^2)`` (``zeta_b = 0.7``) and one notch per
    drop-off, ``N_k = (s^2 + 2 zeta_z w_k s + w_k^2) / (s^2 + 2 zeta_p w_k s + w_k^2)``,
    ``zeta_p = width_k / (2 f_k)`` and ``zeta_z = zeta_p * 10^(-depth_k / 20)``: at ``f_k``
    the notch attenuates by ``depth_k`` dB, and its -3 dB-of-depth width is about
    ``width_k`` Hz. The defaults put the drop-offs of Figure 13 at 12 Hz and 26 Hz (the
    thesis explains them by the first system mode and a resonance of the connection
    between cylinder and chassis, Section 5.1). A seeded tracking error (white noise
    shaped by ``H``, given rms) is added. ``H`` is applied exactly in the frequency
    domain (zero-padded FFT: linear, not circular, convolution).

:func:`measure`
    Per acceleration channel, the acquisition at an internal rate ``R * 1000 Hz``:
    the ideal signal is band-limited interpolated to the internal rate (if it is given at
    the output rate), Gaussian sensor noise of a given density is added, the signal is
    converted to volts by the channel's Appendix-A sensitivity (V/(m/s^2)), low-pass
    filtered by the anti-alias filter (Butterworth magnitude of order ``aa_order`` at
    ``aa_cutoff_ratio * 1000 Hz``; zero phase, i.e. a linear-phase decimation filter whose
    group delay the acquisition compensates, as delta-sigma data acquisition systems do),
    decimated to 1000 Hz, clipped to the ADC range and quantised (``adc_bits`` over
    ``+-adc_range_v``), then divided by the sensitivity again (the test software stores
    m/s^2). The drive channel (the controller's displacement at 204.8 Hz) gets optional
    white measurement noise. Channel names, directions, positions and metadata are kept;
    ``measurement_chain`` (JSON of the parameters) is added to the metadata.

Everything is pure NumPy/SciPy (no exudyn), seeded and deterministic.

Examples
--------
>>> import numpy as np
>>> from exudyn_study.virtual_rig.measurement import ServoParameters, servo_response
>>> x = np.random.default_rng(0).standard_normal(4000) * 1e-4
>>> servo_response(x, 1000.0, ServoParameters(tracking_noise_rms_m=0.0)).shape
(4000,)
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft

from exudyn_study.errors import InputError
from exudyn_study.recording.types import Channel, Recording

__all__ = [
    "ServoParameters",
    "AcquisitionParameters",
    "servo_frf",
    "servo_response",
    "anti_alias_gain",
    "measure",
    "OUTPUT_RATE_HZ",
]

#: accelerometer output rate of the rig's acquisition (thesis Section 3.3)
OUTPUT_RATE_HZ = 1000.0
_LOOP_DAMPING = 0.7  # damping ratio of the servo loop's second-order roll-off


def _check_range(owner: str, name: str, value, lower: float, upper: float, unit: str,
                 open_lower: bool = False) -> float:
    """``value`` as float if ``lower <= value <= upper`` (``lower < value`` if open), else InputError."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    ok = math.isfinite(v) and (v > lower if open_lower else v >= lower) and v <= upper
    if not ok:
        lo = "(" if open_lower else "["
        raise InputError(f"{owner}.{name} = {value!r}; expected a value in {lo}{lower:g}, {upper:g}] {unit}")
    return v


@dataclass(frozen=True)
class ServoParameters:
    """Servo-hydraulic drive: how the achieved piston displacement departs from the command.

    Parameters
    ----------
    notch_frequencies_hz : tuple of float
        Centre frequency of each drop-off, Hz, each in [1, 200]. Default (12, 26): thesis Fig. 13.
    notch_depths_db : tuple of float
        Attenuation at each centre, dB, each in [0, 40]. Defaults 6 dB and 9 dB.
    notch_widths_hz : tuple of float
        Width of each drop-off (pole bandwidth ``2 zeta_p f``), Hz, each in (0, 20].
    bandwidth_hz : float
        Natural frequency of the loop's second-order roll-off (damping 0.7), Hz, in [20, 1000].
    tracking_noise_rms_m : float
        Rms of the random tracking error (white noise shaped by the servo response), m,
        in [0, 1e-3].
    seed : int
        Seed of the tracking error (>= 0).

    Raises
    ------
    InputError
        Naming the parameter, its value and the accepted bounds.
    """

    notch_frequencies_hz: tuple = (12.0, 26.0)
    notch_depths_db: tuple = (6.0, 9.0)
    notch_widths_hz: tuple = (3.0, 4.0)
    bandwidth_hz: float = 120.0
    tracking_noise_rms_m: float = 0.5e-6
    seed: int = 0

    def __post_init__(self) -> None:
        own = "ServoParameters"
        lists = {}
        for name, lo, hi, unit, open_lo in (("notch_frequencies_hz", 1.0, 200.0, "Hz", False),
                                           ("notch_depths_db", 0.0, 40.0, "dB", False),
                                           ("notch_widths_hz", 0.0, 20.0, "Hz", True)):
            raw = getattr(self, name)
            try:
                vals = tuple(raw)
            except TypeError:
                raise InputError(f"{own}.{name} = {raw!r}; expected a sequence of values in {unit}") from None
            lists[name] = tuple(_check_range(own, name, v, lo, hi, unit, open_lo) for v in vals)
            object.__setattr__(self, name, lists[name])
        n = {k: len(v) for k, v in lists.items()}
        if len(set(n.values())) != 1:
            raise InputError(f"{own}: notch_frequencies_hz, notch_depths_db and notch_widths_hz have lengths "
                             f"{list(n.values())}; expected one value per notch in each")
        object.__setattr__(self, "bandwidth_hz", _check_range(own, "bandwidth_hz", self.bandwidth_hz, 20.0,
                                                              1000.0, "Hz"))
        object.__setattr__(self, "tracking_noise_rms_m", _check_range(
            own, "tracking_noise_rms_m", self.tracking_noise_rms_m, 0.0, 1e-3, "m"))
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise InputError(f"{own}.seed = {self.seed!r}; expected an integer >= 0")


@dataclass(frozen=True)
class AcquisitionParameters:
    """Accelerometer channels and data acquisition (thesis Section 3.3, Appendix A).

    Parameters
    ----------
    output_rate_hz : float
        Rate of the recorded accelerations, Hz, in [100, 100000] (rig: 1000 Hz).
    oversampling : int
        Internal rate = ``oversampling * output_rate_hz`` (1 to 64); the anti-alias
        filter runs there before decimation.
    aa_order : int
        Order of the Butterworth anti-alias magnitude, 2 to 16.
    aa_cutoff_ratio : float
        Cut-off (-3 dB) as a fraction of the output rate, in [0.1, 0.5) (0.4: 400 Hz).
    noise_density : float
        One-sided sensor noise density, (m/s^2)/sqrt(Hz), in [0, 0.1]. Default 3e-4
        (an ICP accelerometer of ~0.5 mg broadband resolution).
    adc_bits : int
        ADC word length, 8 to 32 (default 24).
    adc_range_v : float
        ADC full scale +-V, in (0, 100] (default 10 V). Values beyond it clip (with a warning).
    drive_noise_rms_m : float
        White noise on the drive displacement channel, m, in [0, 1e-3].
    seed : int
        Seed of all noise (>= 0); channel ``i`` uses an independent stream.

    Raises
    ------
    InputError
        Naming the parameter, its value and the accepted bounds.
    """

    output_rate_hz: float = OUTPUT_RATE_HZ
    oversampling: int = 4
    aa_order: int = 8
    aa_cutoff_ratio: float = 0.4
    noise_density: float = 3e-4
    adc_bits: int = 24
    adc_range_v: float = 10.0
    drive_noise_rms_m: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        own = "AcquisitionParameters"
        for name, lo, hi in (("oversampling", 1, 64), ("aa_order", 2, 16), ("adc_bits", 8, 32),
                             ("seed", 0, 2**63 - 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise InputError(f"{own}.{name} = {v!r}; expected an integer in [{lo}, {hi}]")
        object.__setattr__(self, "output_rate_hz", _check_range(own, "output_rate_hz", self.output_rate_hz,
                                                                100.0, 1e5, "Hz"))
        r = _check_range(own, "aa_cutoff_ratio", self.aa_cutoff_ratio, 0.1, 0.5, "(fraction of output rate)")
        if r >= 0.5:
            raise InputError(f"{own}.aa_cutoff_ratio = {r!r}; expected a value in [0.1, 0.5) (below Nyquist)")
        object.__setattr__(self, "aa_cutoff_ratio", r)
        object.__setattr__(self, "noise_density", _check_range(own, "noise_density", self.noise_density, 0.0,
                                                               0.1, "(m/s^2)/sqrt(Hz)"))
        object.__setattr__(self, "adc_range_v", _check_range(own, "adc_range_v", self.adc_range_v, 0.0, 100.0,
                                                             "V", open_lower=True))
        object.__setattr__(self, "drive_noise_rms_m", _check_range(own, "drive_noise_rms_m",
                                                                   self.drive_noise_rms_m, 0.0, 1e-3, "m"))

    @property
    def internal_rate_hz(self) -> float:
        """Rate of the acquisition before decimation, Hz."""
        return self.oversampling * self.output_rate_hz

    @property
    def lsb_v(self) -> float:
        """ADC quantisation step, V."""
        return 2.0 * self.adc_range_v / 2.0**self.adc_bits


def servo_frf(freq_hz, params: ServoParameters = ServoParameters()) -> np.ndarray:
    """Achieved / commanded displacement of the servo drive at ``freq_hz`` (complex, dimensionless).

    Parameters
    ----------
    freq_hz : array_like
        Frequencies in Hz.
    params : ServoParameters

    Returns
    -------
    ndarray, complex, shape of ``freq_hz``
    """
    s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    wb = 2 * np.pi * params.bandwidth_hz
    h = wb**2 / (s**2 + 2 * _LOOP_DAMPING * wb * s + wb**2)
    for f, depth, width in zip(params.notch_frequencies_hz, params.notch_depths_db, params.notch_widths_hz,
                               strict=True):
        w = 2 * np.pi * f
        zp = width / (2 * f)
        zz = zp * 10 ** (-depth / 20)
        h = h * (s**2 + 2 * zz * w * s + w**2) / (s**2 + 2 * zp * w * s + w**2)
    return h


def _apply_frf(x: np.ndarray, fs: float, gain) -> np.ndarray:
    """Linear convolution of ``x`` (last axis) with the filter whose FRF is ``gain(f)`` (zero-padded FFT)."""
    n = x.shape[-1]
    nfft = sfft.next_fast_len(2 * n, real=True)
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    return sfft.irfft(sfft.rfft(x, nfft, axis=-1) * gain(f), nfft, axis=-1)[..., :n]


def servo_response(command, fs: float, params: ServoParameters = ServoParameters()) -> np.ndarray:
    """Achieved piston displacement for a commanded one.

    Parameters
    ----------
    command : array_like, shape (n_samples,)
        Commanded displacement, m.
    fs : float
        Its sampling rate, Hz (> 2x the highest notch frequency).
    params : ServoParameters

    Returns
    -------
    ndarray, shape (n_samples,)
        Achieved displacement, m: the command through :func:`servo_frf` plus the seeded
        tracking error (same filter, rms ``params.tracking_noise_rms_m``).

    Raises
    ------
    InputError
        On non-finite samples, a bad rate or notches above the Nyquist frequency.
    """
    x = np.asarray(command, dtype=float)
    if x.ndim != 1 or x.size < 4:
        raise InputError(f"servo_response: command of shape {x.shape}; expected a 1-D array of >= 4 samples")
    if not np.all(np.isfinite(x)):
        i = int(np.flatnonzero(~np.isfinite(x))[0])
        raise InputError(f"servo_response: command has a non-finite sample at index {i}")
    fs = float(fs)
    if not (math.isfinite(fs) and fs > 2 * max(params.notch_frequencies_hz, default=0.0)):
        raise InputError(f"servo_response: fs = {fs!r} Hz; expected more than twice the highest notch "
                         f"({max(params.notch_frequencies_hz, default=0.0):g} Hz)")
    y = _apply_frf(x, fs, lambda f: servo_frf(f, params))
    if params.tracking_noise_rms_m > 0:
        e = _apply_frf(np.random.default_rng([params.seed, 7]).standard_normal(x.size), fs,
                       lambda f: servo_frf(f, params))
        y = y + params.tracking_noise_rms_m * e / max(float(np.std(e)), 1e-300)
    return y


def anti_alias_gain(freq_hz, params: AcquisitionParameters = AcquisitionParameters()) -> np.ndarray:
    """Magnitude of the anti-alias filter at ``freq_hz`` (Butterworth of order ``aa_order``).

    Parameters
    ----------
    freq_hz : array_like
        Frequencies (Hz), any shape.
    params : AcquisitionParameters
        The acquisition chain (``aa_order``, ``aa_cutoff_ratio``, ``output_rate_hz``).

    Returns
    -------
    ndarray, shape of ``freq_hz``
        Filter gain (dimensionless, 1 at 0 Hz).
    """
    fc = params.aa_cutoff_ratio * params.output_rate_hz
    return 1.0 / np.sqrt(1.0 + (np.asarray(freq_hz, dtype=float) / fc) ** (2 * params.aa_order))


def _sensitivity(ch: Channel) -> float:
    if ch.sensitivity is not None:
        return float(ch.sensitivity)
    from exudyn_study.model.sensors import SENSORS

    by_name = {s.name: s.sensitivity for s in SENSORS}
    if ch.name in by_name:
        return float(by_name[ch.name])
    raise InputError(f"measure: channel {ch.name!r} has no sensitivity and is not an Appendix-A sensor; "
                     "give the Channel a sensitivity in V/(m/s^2)")


def _acquire(ch: Channel, params: AcquisitionParameters, rng: np.random.Generator) -> tuple[np.ndarray, int]:
    """One acceleration channel through the chain; returns (m/s^2 at the output rate, clipped samples)."""
    fs_int = params.internal_rate_hz
    ratio = ch.sample_rate_hz / params.output_rate_hz
    k = int(round(ratio))
    if abs(ratio - k) > 1e-9 or k < 1:
        raise InputError(f"measure: channel {ch.name!r} sampled at {ch.sample_rate_hz:g} Hz; expected an "
                         f"integer multiple of the output rate {params.output_rate_hz:g} Hz")
    x = np.asarray(ch.data, dtype=float)
    if k != params.oversampling:
        # band-limited (Fourier) resampling to the internal rate: the ideal signal carries
        # nothing above its own Nyquist frequency
        n_int = int(round(x.size * params.oversampling / k))
        from scipy.signal import resample as fourier_resample

        x = fourier_resample(x, n_int)
    if params.noise_density > 0:
        x = x + params.noise_density * math.sqrt(fs_int / 2.0) * rng.standard_normal(x.size)
    sens = _sensitivity(ch)
    v = _apply_zero_phase(x * sens, fs_int, lambda f: anti_alias_gain(f, params))
    v = v[:: params.oversampling]
    clipped = int(np.count_nonzero(np.abs(v) > params.adc_range_v))
    v = np.clip(v, -params.adc_range_v, params.adc_range_v)
    v = np.round(v / params.lsb_v) * params.lsb_v
    return v / sens, clipped


def _apply_zero_phase(x: np.ndarray, fs: float, gain) -> np.ndarray:
    """Zero-phase filtering by a real magnitude ``gain(f)`` (reflect-padded FFT to limit end effects)."""
    n = x.size
    pad = min(n - 1, int(0.05 * fs))
    xp = np.concatenate([x[pad:0:-1], x, x[-2:-pad - 2:-1]]) if pad > 0 else x
    nfft = sfft.next_fast_len(xp.size, real=True)
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    y = sfft.irfft(sfft.rfft(xp, nfft) * gain(f), nfft)[: xp.size]
    return y[pad: pad + n]


def measure(recording: Recording, params: AcquisitionParameters = AcquisitionParameters(),
            servo: ServoParameters | None = None) -> Recording:
    """Pass an ideal recording through the rig's acquisition chain.

    Parameters
    ----------
    recording : Recording
        Ideal accelerations (m/s^2, at the output rate or an integer multiple of it) and,
        optionally, a drive channel.
    params : AcquisitionParameters
    servo : ServoParameters, optional
        If the drive the recording was simulated with came through :func:`servo_response`,
        its parameters (written to the metadata only).

    Returns
    -------
    Recording
        Same channel names, order, directions, positions and sensitivities; accelerations
        at ``params.output_rate_hz``; metadata of the input plus ``measurement_chain``
        (JSON string of the parameters).

    Raises
    ------
    InputError
        On a rate that is not an integer multiple of the output rate, or an
        acceleration channel without a known sensitivity.

    Warns
    -----
    UserWarning
        If any sample exceeds the ADC range (it is clipped).
    """
    if not isinstance(recording, Recording):
        raise InputError(f"measure: recording of type {type(recording).__name__}; expected Recording")
    seeds = np.random.SeedSequence([params.seed, 11]).spawn(len(recording))
    out, clipped = [], {}
    for ch, ss in zip(recording, seeds, strict=True):
        rng = np.random.default_rng(ss)
        if ch.quantity == "acceleration" and ch.role == "response":
            data, n_clip = _acquire(ch, params, rng)
            if n_clip:
                clipped[ch.name] = n_clip
            out.append(dataclasses.replace(ch, data=data, sample_rate_hz=params.output_rate_hz))
        elif ch.role == "drive" and params.drive_noise_rms_m > 0:
            out.append(dataclasses.replace(
                ch, data=ch.data + params.drive_noise_rms_m * rng.standard_normal(ch.n_samples)))
        else:
            out.append(ch)
    if clipped:
        warnings.warn(f"measure: samples beyond the ADC range +-{params.adc_range_v:g} V were clipped: "
                      f"{clipped}", stacklevel=2)
    chain = {"acquisition": dataclasses.asdict(params)}
    if servo is not None:
        chain["servo"] = dataclasses.asdict(servo)
    meta = dict(recording.metadata)
    meta["measurement_chain"] = json.dumps(chain, sort_keys=True)
    return Recording(tuple(out), meta)
