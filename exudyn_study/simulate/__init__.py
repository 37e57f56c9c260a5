"""Simulate a rig model into a :class:`~exudyn_study.recording.Recording`.

:func:`simulate` (``run``) prepares the drive (``drive``) and runs one of three paths:
``exudyn`` (``exudyn_path``: Exudyn's implicit integration of the assembled model),
``exudyn-reduced`` (``reduced``: Exudyn's integration of the constraint-projected
linearisation) or ``linear`` (:func:`exudyn_study.linear.simulate_linear`: exact
discretisation of the linearisation). ``checks`` holds the accuracy measures the tests and
benchmarks compare the paths with.
"""

from exudyn_study.simulate.drive import DRIVE_RATE_HZ, OUTPUT_RATE_HZ, prepare_drive
from exudyn_study.simulate.exudyn_path import (
    CONSTRAINED_SPECTRAL_RADIUS,
    IntegratorSettings,
    newton_absolute_tolerance,
    simulate_exudyn,
)
from exudyn_study.simulate.reduced import REDUCED_STEP_S, simulate_exudyn_reduced
from exudyn_study.simulate.run import METHODS, simulate

__all__ = ["OUTPUT_RATE_HZ", "DRIVE_RATE_HZ", "METHODS", "IntegratorSettings", "CONSTRAINED_SPECTRAL_RADIUS",
           "newton_absolute_tolerance", "REDUCED_STEP_S", "prepare_drive", "simulate", "simulate_exudyn",
           "simulate_exudyn_reduced"]
