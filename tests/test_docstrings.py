"""Every parameter of the public API is documented in its numpydoc docstring.

The public API is every name in a module's ``__all__``, or, for a module without ``__all__``, its
module-level functions and classes whose names do not start with an underscore. For a function the
parameters are those of its signature; for a class those of its constructor (a dataclass's ``__init__``
fields), each to be listed under Parameters, Other Parameters or Attributes of the class docstring (or
of ``__init__``'s, or of a base class in the package for inherited fields), and every public method
defined in the class body is checked like a function.
``self``, ``cls``, ``*args`` and ``**kwargs`` are not required.

Only imports: nothing is meshed, built or simulated (the modules import ngsolve and exudyn lazily).
The approach follows python-control's ``control/tests/docstrings_test.py``.
"""

from __future__ import annotations

import dataclasses
import enum
import importlib
import inspect
import pkgutil
import warnings

import pytest
from numpydoc.docscrape import NumpyDocString

import exudyn_study

#: Sections whose entries count as documenting a parameter.
SECTIONS = ("Parameters", "Other Parameters", "Attributes")

#: Qualified names (``module.function``, ``module.Class`` or ``module.Class.method``, named where they are
#: defined) whose undocumented parameters are skipped: they live in code that other changes are editing
#: (identify, cli, recording, infra, sweep, calibrate, diagnose, physics, linear.pairing,
#: signals.fatigue*, virtual_rig.scenarios); each is documented by its owning change, after whose merge its
#: entry is removed here. ``test_pending_names_exist`` fails on an entry that no longer names anything.
PENDING: set[str] = {
    # diagnose rig stages: the functions the pipeline-stage split made public (rig_evaluate, rig_fit,
    # rig_fit_together, rig_places, rig_screen, rig_state, ...); their Parameters sections are still to write
    "exudyn_study.diagnose.rig_evaluate.DistortionEvaluator",
    "exudyn_study.diagnose.rig_evaluate.DistortionEvaluator.residual_vector",
    "exudyn_study.diagnose.rig_evaluate.Evaluator",
    "exudyn_study.diagnose.rig_evaluate.Evaluator.errors",
    "exudyn_study.diagnose.rig_evaluate.Evaluator.residual_vector",
    "exudyn_study.diagnose.rig_evaluate.Evaluator.simulate",
    "exudyn_study.diagnose.rig_evaluate.Evaluator.simulate_exact",
    "exudyn_study.diagnose.rig_evaluate.SpectralEvaluator",
    "exudyn_study.diagnose.rig_evaluate.SpectralEvaluator.residual_vector",
    "exudyn_study.diagnose.rig_evaluate.aic",
    "exudyn_study.diagnose.rig_evaluate.catalogue_default",
    "exudyn_study.diagnose.rig_evaluate.combined_gains",
    "exudyn_study.diagnose.rig_evaluate.decay_time",
    "exudyn_study.diagnose.rig_evaluate.effective_samples",
    "exudyn_study.diagnose.rig_evaluate.fit_hypothesis",
    "exudyn_study.diagnose.rig_evaluate.fit_per_recording",
    "exudyn_study.diagnose.rig_evaluate.holdout_error",
    "exudyn_study.diagnose.rig_evaluate.holdout_errors",
    "exudyn_study.diagnose.rig_evaluate.per_recording",
    "exudyn_study.diagnose.rig_evaluate.response_ratio",
    "exudyn_study.diagnose.rig_evaluate.safe_residual",
    "exudyn_study.diagnose.rig_evaluate.set_offsets",
    "exudyn_study.diagnose.rig_explain.explain",
    "exudyn_study.diagnose.rig_explain.explain_local_element",
    "exudyn_study.diagnose.rig_explain.figures_before",
    "exudyn_study.diagnose.rig_explain.make_finding",
    "exudyn_study.diagnose.rig_explain.model_transmissibility",
    "exudyn_study.diagnose.rig_explain.modes_hz",
    "exudyn_study.diagnose.rig_explain.point_of",
    "exudyn_study.diagnose.rig_explain.recording_label",
    "exudyn_study.diagnose.rig_explain.residual_carriers",
    "exudyn_study.diagnose.rig_explain.shifted_modes",
    "exudyn_study.diagnose.rig_explain.unexplained_entry",
    "exudyn_study.diagnose.rig_fit.batch_of",
    "exudyn_study.diagnose.rig_fit.check_drift",
    "exudyn_study.diagnose.rig_fit.choose_batch",
    "exudyn_study.diagnose.rig_fit.fit_generic",
    "exudyn_study.diagnose.rig_fit.fit_nonlinear",
    "exudyn_study.diagnose.rig_fit.fit_on_distortion",
    "exudyn_study.diagnose.rig_fit.fit_one",
    "exudyn_study.diagnose.rig_fit.fit_round",
    "exudyn_study.diagnose.rig_fit.judge",
    "exudyn_study.diagnose.rig_fit.polish",
    "exudyn_study.diagnose.rig_fit_together.JointFit",
    "exudyn_study.diagnose.rig_fit_together.final_refit",
    "exudyn_study.diagnose.rig_fit_together.fit_together",
    "exudyn_study.diagnose.rig_fit_together.member_neutral",
    "exudyn_study.diagnose.rig_fit_together.prior_starts",
    "exudyn_study.diagnose.rig_fit_together.refit_findings",
    "exudyn_study.diagnose.rig_hypotheses.GroundElementHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.GroundElementHypothesis.carried",
    "exudyn_study.diagnose.rig_hypotheses.GroundElementHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.OutputChain",
    "exudyn_study.diagnose.rig_hypotheses.OutputChain.apply",
    "exudyn_study.diagnose.rig_hypotheses.OutputChain.apply_frf",
    "exudyn_study.diagnose.rig_hypotheses.OutputChain.of",
    "exudyn_study.diagnose.rig_hypotheses.OutputChain.then",
    "exudyn_study.diagnose.rig_hypotheses.PointResonatorHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.PointResonatorHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.SensorFaultHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.SensorFaultHypothesis.gains",
    "exudyn_study.diagnose.rig_hypotheses.SensorFaultHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.apply_output",
    "exudyn_study.diagnose.rig_hypotheses.apply_output_frf",
    "exudyn_study.diagnose.rig_locate.distortion_shares",
    "exudyn_study.diagnose.rig_locate.is_level_dependent",
    "exudyn_study.diagnose.rig_locate.level_pair",
    "exudyn_study.diagnose.rig_locate.nonlinear_sensors",
    "exudyn_study.diagnose.rig_places.LocalSensitivity.at",
    "exudyn_study.diagnose.rig_places.LocalSensitivity.frf",
    "exudyn_study.diagnose.rig_places.structure_places",
    "exudyn_study.diagnose.rig_prove.prove",
    "exudyn_study.diagnose.rig_prove.relative_damage",
    "exudyn_study.diagnose.rig_screen.candidate_context",
    "exudyn_study.diagnose.rig_screen.hypotheses_of",
    "exudyn_study.diagnose.rig_screen.measured_peaks",
    "exudyn_study.diagnose.rig_screen.residual_shares",
    "exudyn_study.diagnose.rig_screen.screen",
    "exudyn_study.diagnose.rig_screen.screen_score",
    "exudyn_study.diagnose.rig_state.ModelState.builder",
    "exudyn_study.diagnose.rig_state.Progress.done",
    "exudyn_study.diagnose.rig_state.RigProblem.wants",
    "exudyn_study.diagnose.rig_state.Screening.judged_on",
    "exudyn_study.diagnose.rig_state.assembled_state",
    "exudyn_study.diagnose.rig_state.build_with_findings",
    "exudyn_study.diagnose.rig_state.carry",
    "exudyn_study.diagnose.rig_state.model_state",
    "exudyn_study.physics.sensor_faults.SensorFault.apply",
    "exudyn_study.physics.sensor_faults.SensorFault.apply_frf",
    # calibrate/ (6)
    "exudyn_study.calibrate.design.DampingDesign.variables_from_ratios",
    "exudyn_study.calibrate.linearised.LinearisedSystem.damping_matrix",
    "exudyn_study.calibrate.linearised.exudyn_damped_modes",
    "exudyn_study.calibrate.result.CalibrationResult.to_json",
    "exudyn_study.calibrate.result.CalibrationResult.write_json",
    "exudyn_study.calibrate.system.system_from_model",
    # cli/ (23)
    "exudyn_study.cli.calibrate.configure",
    "exudyn_study.cli.calibrate.run",
    "exudyn_study.cli.damage.configure",
    "exudyn_study.cli.damage.run",
    "exudyn_study.cli.demo.configure",
    "exudyn_study.cli.demo.run",
    "exudyn_study.cli.diagnose.configure",
    "exudyn_study.cli.diagnose.run",
    "exudyn_study.cli.identify.configure",
    "exudyn_study.cli.identify.run",
    "exudyn_study.cli.iterate_drive.configure",
    "exudyn_study.cli.iterate_drive.run",
    "exudyn_study.cli.main",
    "exudyn_study.cli.modes.configure",
    "exudyn_study.cli.modes.run",
    "exudyn_study.cli.reduce.configure",
    "exudyn_study.cli.reduce.run",
    "exudyn_study.cli.simulate.configure",
    "exudyn_study.cli.simulate.run",
    "exudyn_study.cli.sweep.configure",
    "exudyn_study.cli.sweep.run",
    "exudyn_study.cli.virtual_test.configure",
    "exudyn_study.cli.virtual_test.run",
    # diagnose/ (57)
    "exudyn_study.diagnose.generic.ReducedModel",
    "exudyn_study.diagnose.generic.ReducedModel.coupling",
    "exudyn_study.diagnose.generic.ReducedModel.transmissibility",
    "exudyn_study.diagnose.generic.check_recordings",
    "exudyn_study.diagnose.rig_candidates.CandidateContext.component_sensors",
    "exudyn_study.diagnose.rig_candidates.CandidateContext.entry",
    "exudyn_study.diagnose.rig_candidates.RigCandidate",
    "exudyn_study.diagnose.rig_candidates.unregister_rig_candidate",
    "exudyn_study.diagnose.rig_compare.RigRecording",
    "exudyn_study.diagnose.rig_compare.band_filter",
    "exudyn_study.diagnose.rig_compare.drive_spectra",
    "exudyn_study.diagnose.rig_compare.prepare",
    "exudyn_study.diagnose.rig_compare.relative_errors",
    "exudyn_study.diagnose.rig_compare.significance_map",
    "exudyn_study.diagnose.rig_compare.summary_error",
    "exudyn_study.diagnose.rig_hypotheses.AddedMassHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.AddedMassHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.AffineHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.AffineHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.CompositeHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.CompositeHypothesis.member_values",
    "exudyn_study.diagnose.rig_hypotheses.CompositeHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.ConnectorHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.ConnectorHypothesis.linearisation_values",
    "exudyn_study.diagnose.rig_hypotheses.ConnectorHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.HeldHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.HeldHypothesis.full",
    "exudyn_study.diagnose.rig_hypotheses.HeldHypothesis.gains",
    "exudyn_study.diagnose.rig_hypotheses.HeldHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.Hypothesis",
    "exudyn_study.diagnose.rig_hypotheses.Hypothesis.carried",
    "exudyn_study.diagnose.rig_hypotheses.Hypothesis.entry_values",
    "exudyn_study.diagnose.rig_hypotheses.Hypothesis.fit_values",
    "exudyn_study.diagnose.rig_hypotheses.Hypothesis.gains",
    "exudyn_study.diagnose.rig_hypotheses.Hypothesis.linearisation_values",
    "exudyn_study.diagnose.rig_hypotheses.Hypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.LocalElementHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.LocalElementHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.ModalDampingHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.ModalDampingHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.NonlinearSystem",
    "exudyn_study.diagnose.rig_hypotheses.SensorGainHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.SensorGainHypothesis.gains",
    "exudyn_study.diagnose.rig_hypotheses.SensorGainHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.SloshingHypothesis",
    "exudyn_study.diagnose.rig_hypotheses.SloshingHypothesis.damper_n_s_per_m",
    "exudyn_study.diagnose.rig_hypotheses.SloshingHypothesis.damping_matrix",
    "exudyn_study.diagnose.rig_hypotheses.SloshingHypothesis.system",
    "exudyn_study.diagnose.rig_hypotheses.SloshingHypothesis.unit_dampers",
    "exudyn_study.diagnose.rig_hypotheses.project",
    "exudyn_study.diagnose.schema.Diagnosis.from_dict",
    "exudyn_study.diagnose.schema.Diagnosis.write_json",
    "exudyn_study.diagnose.schema.Finding.from_dict",
    "exudyn_study.diagnose.schema.read_json",
    "exudyn_study.diagnose.testbench.DeadZoneSpring.residual",
    "exudyn_study.diagnose.testbench.drive_signal",
    # identify/ (13)
    "exudyn_study.identify._checks.as_frf",
    "exudyn_study.identify._checks.band_mask",
    "exudyn_study.identify._checks.callable_module",
    "exudyn_study.identify.frf.n_averages",
    "exudyn_study.identify.lsfd.Leakage.kernel",
    "exudyn_study.identify.mac.automac",
    "exudyn_study.identify.mac.mcf",
    "exudyn_study.identify.model.ModalModel.from_json",
    "exudyn_study.identify.model.ModalModel.shapes",
    "exudyn_study.identify.model.Mode.from_dict",
    "exudyn_study.identify.model.Mode.shape_vector",
    "exudyn_study.identify.polymax.Poles.at_order",
    "exudyn_study.identify.polymax.Poles.subset",
    # infra/ (7)
    "exudyn_study.infra.atomic.write_text_atomic",
    "exudyn_study.infra.blas.one_blas_thread",
    "exudyn_study.infra.cache.cache_dir",
    "exudyn_study.infra.cache.cached",
    "exudyn_study.infra.cache.load_entry",
    "exudyn_study.infra.cache.recipe_key",
    "exudyn_study.infra.cache.store_entry",
    # physics/ (12)
    "exudyn_study.physics.catalogue.Augmentation.apply",
    "exudyn_study.physics.catalogue.Parameter.check",
    "exudyn_study.physics.catalogue.PhysicsEntry.parameter",
    "exudyn_study.physics.catalogue.entry",
    "exudyn_study.physics.catalogue.register",
    "exudyn_study.physics.catalogue.unregister",
    "exudyn_study.physics.entries_more.component_joints",
    "exudyn_study.physics.mesh.exudyn_mesh_nodes",
    "exudyn_study.physics.mesh.require_super_element",
    "exudyn_study.physics.rubber.pad_spring_matrix",
    "exudyn_study.physics.rubber.rubber_body",
    "exudyn_study.physics.rubber.rubber_pad_location_check",
    # recording/ (2)
    "exudyn_study.recording.types.Recording.channel",
    "exudyn_study.recording.types.Recording.select",
    # signals.fatigue (1)
    "exudyn_study.signals.fatigue.RelativeDamage.to_json",
    # sweep/ (21)
    "exudyn_study.sweep.config.ParameterRange.sample",
    "exudyn_study.sweep.config.expand_points",
    "exudyn_study.sweep.config.parse_config",
    "exudyn_study.sweep.config.point_key",
    "exudyn_study.sweep.damage_grid.GridResult.cell",
    "exudyn_study.sweep.damage_grid.GridResult.plot",
    "exudyn_study.sweep.damage_grid.GridResult.write_csv",
    "exudyn_study.sweep.damage_grid.run_grid",
    "exudyn_study.sweep.engine.read_rows",
    "exudyn_study.sweep.engine.summary_table",
    "exudyn_study.sweep.plant.ModelPlant",
    "exudyn_study.sweep.plant.ModelPlant.indices",
    "exudyn_study.sweep.plant.ModelPlant.recording",
    "exudyn_study.sweep.plant.rms_errors",
    "exudyn_study.sweep.plots.family_columns",
    "exudyn_study.sweep.plots.save_sweep_plot",
    "exudyn_study.sweep.tasks.Parameter.coerce",
    "exudyn_study.sweep.tasks.TaskRegistry.get",
    "exudyn_study.sweep.tasks.TaskRegistry.register",
    "exudyn_study.sweep.tasks.damping_sensitivity",
    "exudyn_study.sweep.tasks.get_task",
    # virtual_rig.scenarios (3)
    "exudyn_study.virtual_rig.scenarios.random_scenario",
    "exudyn_study.virtual_rig.scenarios.register_scenario",
    "exudyn_study.virtual_rig.scenarios.scenario",
}


def _modules():
    """Yield every module of the package (``__main__`` modules excluded: importing one runs it)."""
    yield exudyn_study
    for info in pkgutil.walk_packages(exudyn_study.__path__, "exudyn_study."):
        if info.name.rsplit(".", 1)[-1] == "__main__":
            continue
        yield importlib.import_module(info.name)


def _public_objects(module):
    """Yield the public functions and classes of ``module`` (its ``__all__`` when it has one)."""
    if hasattr(module, "__all__"):
        names = list(module.__all__)
    else:
        names = [
            n for n, obj in vars(module).items()
            if not n.startswith("_") and getattr(obj, "__module__", None) == module.__name__
        ]
    for name in names:
        obj = getattr(module, name)
        if (inspect.isfunction(obj) or inspect.isclass(obj)) and getattr(obj, "__module__", "").startswith(
            "exudyn_study"
        ):
            yield obj


def _qualified(obj) -> str:
    return f"{obj.__module__}.{obj.__qualname__}"


def _documented(*docstrings: str | None) -> tuple[set[str], list[str]]:
    """Names listed in the parameter sections of ``docstrings``, and parse errors."""
    names: set[str] = set()
    errors = []
    for doc in docstrings:
        if not doc:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # unknown sections: a matter for the docs build, not this test
            try:
                parsed = NumpyDocString(inspect.cleandoc(doc))
            except Exception as exc:  # numpydoc raises ValueError (and others) on malformed sections
                errors.append(f"docstring not parseable ({exc})")
                continue
        for section in SECTIONS:
            for entry in parsed[section]:
                names.update(n.strip().lstrip("*") for n in entry.name.split(","))
    return names, errors


def _signature(obj) -> inspect.Signature | None:
    try:
        return inspect.signature(obj)
    except (TypeError, ValueError):  # builtins without a signature (e.g. exception classes)
        return None


def _required(sig: inspect.Signature | None) -> list[str]:
    if sig is None:
        return []
    return [
        name for name, p in sig.parameters.items()
        if name not in ("self", "cls")
        and p.kind not in (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    ]


def _class_parameters(cls) -> list[str]:
    """Constructor parameters and public dataclass fields of ``cls`` (none for enums and exceptions)."""
    if issubclass(cls, (enum.Enum, BaseException)):
        return []
    own_init = "__init__" in vars(cls) or dataclasses.is_dataclass(cls)
    names = _required(_signature(cls)) if own_init else []
    if dataclasses.is_dataclass(cls):
        public = [f.name for f in dataclasses.fields(cls) if not f.name.startswith("_")]
        names += [n for n in public if n not in names]
    return names


def _methods(cls):
    """(name, function) of the public methods defined in the body of ``cls``.

    Properties have no parameters; a dataclass field whose default is a function is a field.
    """
    fields = {f.name for f in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()
    for name, attr in vars(cls).items():
        if name.startswith("_") or name in fields:
            continue
        if isinstance(attr, (staticmethod, classmethod)):
            attr = attr.__func__
        if inspect.isfunction(attr):
            yield name, attr


def _checks():
    """Yield (qualified name, parameter names, documented names, parse errors) of the public API."""
    seen = set()
    for module in _modules():
        for obj in _public_objects(module):
            if obj in seen:
                continue
            seen.add(obj)
            if inspect.isclass(obj):
                own = [c for c in obj.__mro__ if c.__module__.startswith("exudyn_study")]
                docs = [c.__doc__ for c in own]
                docs += [getattr(vars(c).get("__init__"), "__doc__", None) for c in own]
                yield _qualified(obj), _class_parameters(obj), *_documented(*docs)
                for name, method in _methods(obj):
                    yield (f"{_qualified(obj)}.{name}", _required(_signature(method)),
                           *_documented(method.__doc__))
            else:
                yield _qualified(obj), _required(_signature(obj)), *_documented(obj.__doc__)


def _resolve(qualified: str):
    """Return the object named by ``qualified`` (``module.Class.method``), or None if it names nothing."""
    parts = qualified.split(".")
    for i in range(len(parts) - 1, 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr, None)
            if obj is None:
                return None
        return obj
    return None


def test_public_parameters_are_documented():
    problems = []
    for qualified, parameters, documented, errors in _checks():
        if qualified in PENDING:
            continue
        problems += [f"{qualified}: {e}" for e in errors]
        problems += [
            f"{qualified}: parameter {p!r} is not documented" for p in parameters if p not in documented
        ]
    assert not problems, f"{len(problems)} docstring problems:\n" + "\n".join(problems)


@pytest.mark.parametrize("qualified", sorted(PENDING))
def test_pending_names_exist(qualified):
    assert _resolve(qualified) is not None, f"PENDING entry {qualified!r} names nothing: remove it"


def test_the_check_sees_an_undocumented_parameter():
    """The parser and the walk catch what they should (guards against a check that passes vacuously)."""

    def f(a, b, c, *args, d=1, **kwargs):
        """Do nothing.

        Parameters
        ----------
        a, b : float
            Two numbers (m).
        """

    documented, errors = _documented(f.__doc__)
    assert not errors
    assert [p for p in _required(_signature(f)) if p not in documented] == ["c", "d"]
    assert sum(len(params) for _, params, _, _ in _checks()) > 500
