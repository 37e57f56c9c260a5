"""Settings of the level-trend diagnosis (:func:`~exudyn_study.diagnose.levels.diagnose_levels`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from exudyn_study.errors import InputError

__all__ = ["LevelSettings"]


@dataclass(frozen=True)
class LevelSettings:
    """Settings of every stage of the level-trend diagnosis (defaults suit a shaker test).

    Parameters
    ----------
    excitation : {'auto', 'periodic', 'random'}
        How the FRFs are estimated. 'periodic': whole periods averaged at the excited lines
        (a multisine); 'random': one local-rational (LRM) estimate over the record, or H1 Welch
        averages when ``resolution_hz`` is given. 'auto': periodic when a period is declared or
        the drive repeats itself (normalised autocorrelation >= ``period_correlation``).
    period_s : float or None
        Declared period of a periodic drive in s (it must divide the record); None: detected.
    realisations : int
        Periodic drive: the record is this many equal blocks, each whole periods of one
        realisation of a random-phase multisine (same excited lines and amplitudes, new phases;
        the first period of each block is its transient). The FRF is the mean of the
        realisations' FRFs; the realisation-to-realisation scatter beyond the noise is the
        stochastic nonlinear distortion, which averaging over realisations reduces (Pintelon &
        Schoukens 2012, Section 4.3, the robust method).
    period_correlation : float
        Autocorrelation of the drive at one period above which it counts as periodic (-).
    band_hz : (float, float) or None
        Analysis band in Hz; default the contiguous excited band of the reference's drive.
    resolution_hz : float or None
        Random excitation only: Welch resolution in Hz; default one LRM estimate over the
        whole record (resolution 1 / record length).
    min_lines : float
        A mode should span at least this many lines in its half-power bandwidth; fewer
        gives a warning naming the mode and the resolution needed.
    max_order : int
        Highest PolyMAX model order for the reference model.
    reference_tolerance : float
        The reference model reproduces its own recording when, per channel, its misfit is within
        3 times the noise (rms over the lines of the misfit per line's standard deviation), or
        its relative FRF synthesis error is below this (-; 0.2 is an FRF correlation of about
        0.96, what modal test practice accepts as a good synthesis). Within the tolerance but
        beyond the noise, the diagnosis goes on with a flag: the lowest level may itself be
        nonlinear, and the FRF errors carry the reference's misfit.
    trend_sigma : float
        A trend in frequency or damping counts when its total change over the levels exceeds
        this many standard deviations (-).
    min_frequency_change : float
        ... and the relative frequency change exceeds this (-).
    min_damping_change : float
        ... and the relative damping change exceeds this (-).
    clearance_rise : float
        A relative frequency rise above this, starting only above the lowest levels, is read
        as a clearance closing rather than hardening (-).
    """

    excitation: str = "auto"
    period_s: float | None = None
    realisations: int = 1
    period_correlation: float = 0.98
    band_hz: tuple[float, float] | None = None
    resolution_hz: float | None = None
    min_lines: float = 3.0
    max_order: int = 40
    reference_tolerance: float = 0.2
    trend_sigma: float = 3.0
    min_frequency_change: float = 1e-3
    min_damping_change: float = 0.1
    clearance_rise: float = 0.02

    def __post_init__(self) -> None:
        if self.excitation not in ("auto", "periodic", "random"):
            raise InputError(f"excitation {self.excitation!r}; expected 'auto', 'periodic' or 'random'")
        if self.period_s is not None and not (math.isfinite(self.period_s) and self.period_s > 0):
            raise InputError(f"period {self.period_s!r} s; expected a positive period in s")
        if not (isinstance(self.realisations, int) and self.realisations >= 1):
            raise InputError(f"realisations {self.realisations!r}; expected an integer >= 1")
        if self.resolution_hz is not None and not (
            math.isfinite(self.resolution_hz) and self.resolution_hz > 0
        ):
            raise InputError(f"resolution {self.resolution_hz!r} Hz; expected a positive frequency in Hz")
        if self.band_hz is not None:
            lo, hi = (float(v) for v in self.band_hz)
            if not (0 <= lo < hi and math.isfinite(hi)):
                raise InputError(f"band {self.band_hz!r} Hz; expected two frequencies 0 <= low < high")
        if not (isinstance(self.max_order, int) and self.max_order >= 4):
            raise InputError(f"max_order {self.max_order!r}; expected an integer >= 4")
