"""The virtual test rig: truth models with physics the nominal models leave out, measured like the rig.

>>> from exudyn_study.virtual_rig import SCENARIOS
>>> {"none", "thesis", "added_mass"} <= set(SCENARIOS)
True
"""

from exudyn_study.virtual_rig.run import (
    DEFAULT_DURATION_S,
    build_truth,
    recording_name,
    run_virtual_test,
    truth_name,
    virtual_recording,
)
from exudyn_study.virtual_rig.scenario import THESIS_TABLE1, Augment, Scenario
from exudyn_study.virtual_rig.scenarios import (
    BLIND_EFFECTS,
    HELD_BACK_SEED,
    SCENARIOS,
    SURFACE_REGIONS,
    WIDE_EFFECTS,
    random_scenario,
    register_scenario,
    scenario,
    wide_scenario,
)

__all__ = [
    "DEFAULT_DURATION_S",
    "build_truth",
    "recording_name",
    "run_virtual_test",
    "truth_name",
    "virtual_recording",
    "BLIND_EFFECTS",
    "SCENARIOS",
    "THESIS_TABLE1",
    "Augment",
    "Scenario",
    "random_scenario",
    "wide_scenario",
    "WIDE_EFFECTS",
    "HELD_BACK_SEED",
    "SURFACE_REGIONS",
    "register_scenario",
    "scenario",
]
