"""Damping calibration: flexible-body modal damping for the system's damped modes to match targets.

The flexible bodies' modal damping is chosen so that the system's damped modes match
identified (target) modes (thesis Section 6).

``system``: the rig seam (:class:`CalibrationSystem`, :func:`system_from_model`);
``design``: the design variables (:class:`DampingDesign`); ``linearised``: the system
linearised once with a damping matrix affine in the variables, its modes and their
derivatives; ``optimise``: :func:`calibrate` (pairing, bounded least squares);
``result``: :class:`CalibrationResult` and its JSON. Modes are paired by
:func:`exudyn_study.linear.pair_modes`.
"""

from exudyn_study.calibrate.design import DampingDesign
from exudyn_study.calibrate.linearised import (
           DesignModes,
           LinearisedSystem,
           exudyn_damped_modes,
           linearise_design,
)
from exudyn_study.calibrate.optimise import calibrate
from exudyn_study.calibrate.result import FORMAT_NAME, CalibrationResult, ModeRow
from exudyn_study.calibrate.system import CalibrationSystem, SensorPoint, system_from_model
from exudyn_study.linear.pairing import Pairing, pair_modes

__all__ = ["SensorPoint", "CalibrationSystem", "DampingDesign", "LinearisedSystem", "DesignModes", "Pairing",
           "ModeRow", "CalibrationResult", "linearise_design", "pair_modes", "calibrate",
           "exudyn_damped_modes", "system_from_model", "FORMAT_NAME"]
