"""Signals: drive signals, resampling, relative pseudo damage and drive iteration.

The rig's drive signals and resampling (``drives``), relative pseudo damage
(``fatigue``, ``fatigue_plots``) and drive iteration (``drive_iteration``).

The drive-signal functions are re-exported here (``from exudyn_study.signals import white_noise``).
"""

from exudyn_study.signals.drives import (
    DEFAULT_RMS_M,
    SIGNALS,
    WHITE_NOISE_BAND_HZ,
    acceleration_rms_of_flat_band,
    drive_signal,
    psd,
    rational_ratio,
    resample,
    test_signal,
    test_signal_50,
    test_signal_shape,
    white_noise,
)

__all__ = ["DEFAULT_RMS_M", "WHITE_NOISE_BAND_HZ", "SIGNALS", "white_noise", "test_signal", "test_signal_50",
           "drive_signal", "test_signal_shape", "resample", "rational_ratio", "psd",
           "acceleration_rms_of_flat_band"]
