"""The drive of a simulation: the piston displacement samples at the accelerometers' rate.

:func:`prepare_drive` turns a signal name, an array or a recording's drive channel into
samples at :data:`OUTPUT_RATE_HZ`, resampled from the rig controller's
:data:`DRIVE_RATE_HZ` where needed and faded in so that the model starts at rest.
"""

from __future__ import annotations

import math

import numpy as np

from exudyn_study.errors import InputError

#: accelerometer sampling rate of the rig (thesis Section 3.3)
OUTPUT_RATE_HZ = 1000.0
#: rate of the drive channel in recordings (the rig controller's 204.8 Hz, thesis Section 7.2)
DRIVE_RATE_HZ = 204.8


def _ramp(n: int, rate_hz: float, ramp_s: float) -> np.ndarray:
    """Half-cosine fade-in over ``ramp_s`` (zero value and slope at t = 0)."""
    w = np.ones(n)
    m = min(n, int(round(ramp_s * rate_hz)))
    if m > 1:
        w[:m] = 0.5 - 0.5 * np.cos(np.pi * np.arange(m) / m)
    return w


def prepare_drive(signal="white-noise", duration_s: float = 80.0, rms_m: float | None = None, seed: int = 0,
                  sample_rate_hz: float | None = None, ramp_s: float = 0.25) -> np.ndarray:
    """Drive displacement samples at :data:`OUTPUT_RATE_HZ` (m), faded in.

    Parameters
    ----------
    signal : str or array_like
        A name of :data:`exudyn_study.signals.SIGNALS` ('white-noise', 'test', 'test-50'),
        or drive samples in m (e.g. the drive channel of a measured recording).
    duration_s : float
        Duration for a named signal (s); ignored for samples.
    rms_m : float, optional
        Rms of a named signal (default :data:`exudyn_study.signals.DEFAULT_RMS_M`).
    seed : int
    sample_rate_hz : float, optional
        Rate of given samples: :data:`DRIVE_RATE_HZ` (resampled, anti-aliased) or
        :data:`OUTPUT_RATE_HZ`.
    ramp_s : float
        Fade-in time (s).

    Raises
    ------
    InputError
        Unknown signal name, NaN samples, a rate other than 204.8 or 1000 Hz.
    """
    from exudyn_study.signals.drives import DEFAULT_RMS_M, drive_signal, resample

    if isinstance(signal, str):
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise InputError(f"duration_s {duration_s!r}; expected a positive duration in s")
        x = drive_signal(signal, duration_s, OUTPUT_RATE_HZ, DEFAULT_RMS_M if rms_m is None else rms_m, seed)
    else:
        x = np.asarray(signal, dtype=float).ravel()
        bad = ~np.isfinite(x)
        if bad.any():
            raise InputError(
                f"drive signal has non-finite samples, the first at index {int(np.flatnonzero(bad)[0])}"
            )
        rates = (DRIVE_RATE_HZ, OUTPUT_RATE_HZ)
        if sample_rate_hz is None or not any(abs(sample_rate_hz - r) < 1e-9 for r in rates):
            raise InputError(
                f"drive signal sampled at {sample_rate_hz!r} Hz; expected {DRIVE_RATE_HZ} Hz "
                f"(the rig's drive channel) or {OUTPUT_RATE_HZ} Hz")
        if abs(sample_rate_hz - DRIVE_RATE_HZ) < 1e-9:
            x = resample(x, DRIVE_RATE_HZ, OUTPUT_RATE_HZ)
        if x.size < 8:
            raise InputError(f"drive signal of {x.size} samples; expected a longer signal")
    return x * _ramp(x.size, OUTPUT_RATE_HZ, ramp_s)


