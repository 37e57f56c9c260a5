"""Diagnosis: locate the mismatch between a model and recordings, name the left-out physics, model it.

Both paths return a :class:`~exudyn_study.diagnose.schema.Diagnosis` (JSON schema in
:mod:`.schema`):

- :func:`~exudyn_study.diagnose.generic.diagnose_generic`: any structure tested at several
  excitation levels; the nominal model is a linear modal model identified from the
  lowest-level recording; finds, names and fits joint nonlinearities (friction micro-slip,
  stiffening, clearance) across sensor-pair interfaces;
- :func:`exudyn_study.diagnose.rig.diagnose_rig`: the chassis on the rig (model variants 1-3),
  as stages (compare, locate, screen, fit, prove, explain: ``rig_<stage>`` modules, state in
  :mod:`.rig_state`, settings :class:`~exudyn_study.diagnose.rig_settings.RigDiagnosisSettings`);
  its candidates come from a registry (catalogue entry -> factory of hypotheses):
  :func:`register_rig_candidate` adds a user's own entry without touching the pipeline.

:mod:`.report` writes the HTML report with figures, :mod:`.testbench` simulates a small
two-beam structure with a bolted lap joint at several levels (a structure of our own for
tests and benchmarks). The generic path imports neither exudyn nor ngsolve; the rig path
imports exudyn when it runs.
"""

from exudyn_study.diagnose.generic import GenericSettings, check_recordings, diagnose_generic
from exudyn_study.diagnose.rig import RigDiagnosisSettings, diagnose_rig
from exudyn_study.diagnose.rig_candidates import register_rig_candidate, unregister_rig_candidate
from exudyn_study.diagnose.schema import Diagnosis, Finding, read_json

__all__ = [
    "Diagnosis",
    "Finding",
    "read_json",
    "diagnose_generic",
    "diagnose_rig",
    "RigDiagnosisSettings",
    "GenericSettings",
    "check_recordings",
    "register_rig_candidate",
    "unregister_rig_candidate",
]
