"""The linearised system and what is computed on it without time integration in Exudyn.

``system``: :class:`LinearSystem` (constraint-projected M, C, K with the drive as input and
the sensors as outputs) and its state-space form; ``response``: exact sampled time responses
and FRFs; ``modes``: damped system modes, their descriptions and the modes-JSON form;
``pairing``: the one mode pairing (MAC and frequency, Hungarian assignment);
``nonlinear``: local nonlinear elements simulated on the linearised system.
A rig model is linearised by :func:`exudyn_study.model.linearisation`.
"""

from exudyn_study.linear.modes import (
    SystemModes,
    modes_table,
    to_modal_model,
)
from exudyn_study.linear.pairing import ModePair, Pairing, pair_modal_models, pair_modes
from exudyn_study.linear.response import (
    free_decay_linear,
    frf_linear,
    frf_linear_at_resolution,
    modal_initial_state,
    simulate_linear,
)
from exudyn_study.linear.system import LinearSystem, spline_inputs, state_space

__all__ = ["LinearSystem", "state_space", "spline_inputs", "simulate_linear", "frf_linear",
           "frf_linear_at_resolution", "free_decay_linear", "modal_initial_state", "SystemModes",
           "to_modal_model", "modes_table", "ModePair", "Pairing",
           "pair_modes", "pair_modal_models"]
