"""Sweep tasks: a registry of named functions, each with declared parameters.

A task is a plain function ``fn(*, seed, **parameters) -> mapping`` that computes the
outputs of one sweep point. Its parameters are declared with types, units, bounds or
choices and defaults (:class:`Parameter`), so a sweep configuration is checked before
anything runs. Outputs are a flat mapping ``name -> number | str | bool``; a nested
mapping (e.g. one value per sensor) is flattened to ``'outer.inner'`` columns.

Built-in tasks (:data:`TASKS`):

``body_frequencies``
    Frequencies of a reduced flexible body as a function of mesh size, water mass and
    joint model, through :func:`exudyn_study.bodies.flexible_body` (cached on disk).
    The bodies are built once, in parallel, before the points run (:attr:`Task.artefact`).
``damping_sensitivity``
    Relative pseudo damage per z sensor for a damping function, on the **linear modal
    surrogate** of the rig (see :func:`damping_sensitivity`).
``sleep_cpu``
    A fixed amount of CPU-bound NumPy work, for tests and benchmarks.

Users register their own tasks with :func:`register_task`; the function must be
importable by the worker processes (defined at module level in an importable module,
or in the ``__main__`` of a script guarded by ``if __name__ == '__main__'``).
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from exudyn_study.errors import InputError

log = logging.getLogger(__name__)

__all__ = [
    "Parameter",
    "Task",
    "TaskRegistry",
    "TASKS",
    "register_task",
    "get_task",
    "body_frequencies",
    "damping_sensitivity",
    "sleep_cpu",
    "DAMPING_CHOICES",
]

_TYPES = {"float": (int, float), "int": (int,), "str": (str,), "bool": (bool,), "any": (object,)}
_REQUIRED = object()


@dataclass(frozen=True)
class Parameter:
    """A declared task parameter.

    Parameters
    ----------
    name : str
        Keyword of the task function.
    type : {'float', 'int', 'str', 'bool', 'any'}
        Accepted type (an integral float is accepted for 'int', an int for 'float').
    unit : str
        SI unit, '' for dimensionless or non-physical values.
    bounds : (float, float) or None
        Closed interval of accepted numbers (``None`` ends are open).
    choices : tuple or None
        Accepted values (e.g. model variants, signal names).
    default : object
        Value used when the configuration does not set it; omit to make it required.
    doc : str
        One line for ``--help``-style listings and error messages.
    check : callable or None
        ``check(value) -> value`` for checks beyond the above; raises
        :class:`~exudyn_study.errors.InputError`.
    """

    name: str
    type: str = "float"
    unit: str = ""
    bounds: tuple[float | None, float | None] | None = None
    choices: tuple | None = None
    default: Any = _REQUIRED
    doc: str = ""
    check: Callable[[Any], Any] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.type not in _TYPES:
            raise InputError(f"parameter {self.name!r}: type {self.type!r}; expected one of {list(_TYPES)}")
        if self.choices is not None:
            object.__setattr__(self, "choices", tuple(self.choices))

    @property
    def required(self) -> bool:
        """True if the parameter has no default."""
        return self.default is _REQUIRED

    def describe(self) -> str:
        """One-line description: name, type, unit and accepted values."""
        parts = [f"{self.name} ({self.type}{', ' + self.unit if self.unit else ''})"]
        if self.choices is not None:
            parts.append(f"one of {list(self.choices)}")
        if self.bounds is not None:
            parts.append(f"in [{self.bounds[0]}, {self.bounds[1]}]")
        if not self.required:
            parts.append(f"default {self.default!r}")
        return " ".join(parts)

    def coerce(self, value: Any, where: str) -> Any:
        """Return ``value`` converted to the declared type, or raise naming ``where``.

        Parameters
        ----------
        value : Any
            Value as given in the configuration.
        where : str
            Key the value came from (for example ``'study.settings.ratio'``), named in the error.

        Returns
        -------
        Any
            ``value`` converted to the declared type (an integral float becomes an int for an ``int``
            parameter) and passed through the parameter's ``check``.

        Raises
        ------
        InputError
            On a wrong type, a value outside the bounds or not among the choices.
        """
        t = self.type
        if t == "float":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InputError(f"{where} = {value!r}: expected a number ({self.describe()})")
            value = float(value)
            if not math.isfinite(value):
                raise InputError(f"{where} = {value!r}: expected a finite number ({self.describe()})")
        elif t == "int":
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            if isinstance(value, bool) or not isinstance(value, int):
                raise InputError(f"{where} = {value!r}: expected an integer ({self.describe()})")
        elif t == "str":
            if not isinstance(value, str):
                raise InputError(f"{where} = {value!r}: expected a string ({self.describe()})")
        elif t == "bool":
            if not isinstance(value, bool):
                raise InputError(f"{where} = {value!r}: expected true or false ({self.describe()})")
        if self.choices is not None and value not in self.choices:
            raise InputError(f"{where} = {value!r} is unknown; expected one of {list(self.choices)}")
        if self.bounds is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
            lo, hi = self.bounds
            if (lo is not None and value < lo) or (hi is not None and value > hi):
                raise InputError(f"{where} = {value!r} is out of bounds; expected {self.describe()}")
        if self.check is not None:
            try:
                value = self.check(value)
            except InputError as exc:
                raise InputError(f"{where} = {value!r}: {exc}") from None
        return value


@dataclass(frozen=True)
class Task:
    """A registered sweep task.

    Parameters
    ----------
    name : str
        Registry name, used as ``[study] task = ...`` in a configuration.
    function : callable
        ``function(*, seed, **parameters) -> mapping of outputs``; must be picklable by
        reference (module level).
    parameters : tuple of Parameter
        Declared parameters (``seed`` is implicit and must not be declared).
    artefact : callable or None
        ``artefact(parameters) -> (key, builder, args) | None``: an expensive artefact
        the point needs (e.g. a reduced body). The engine calls ``builder(*args)`` once
        per distinct ``key``, in parallel, before running the points, so the points hit
        the on-disk cache instead of building the same artefact concurrently.
    plot_prefix : str
        Outputs named ``plot_prefix + something`` form the family plotted per swept
        parameter (e.g. ``'rpd.'`` for relative pseudo damage per sensor).
    plot_label : str
        Axis label of that family.
    summary : tuple of str
        Outputs shown in the summary table.
    """

    name: str
    function: Callable[..., Mapping[str, Any]]
    parameters: tuple[Parameter, ...] = ()
    artefact: Callable[[Mapping[str, Any]], tuple | None] | None = None
    plot_prefix: str = ""
    plot_label: str = ""
    summary: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            raise InputError(f"task {self.name!r}: parameter names repeat in {names}")
        if "seed" in names:
            raise InputError(f"task {self.name!r}: 'seed' is implicit; do not declare it")
        object.__setattr__(self, "parameters", tuple(self.parameters))

    @property
    def parameter_map(self) -> Mapping[str, Parameter]:
        """Parameters by name."""
        return MappingProxyType({p.name: p for p in self.parameters})


class TaskRegistry:
    """Named tasks; :data:`TASKS` is the default registry, pre-filled with the built-ins."""

    def __init__(self) -> None:
        self._tasks: dict[str, Task] = {}

    def register(self, task: Task, replace: bool = False) -> Task:
        """Add ``task``; a name already taken is an error unless ``replace``.

        Parameters
        ----------
        task : Task
            Task to add, under ``task.name``.
        replace : bool, default False
            Whether to replace a task already registered under the same name.

        Returns
        -------
        Task
            ``task``.

        Raises
        ------
        InputError
            If the name is taken and ``replace`` is False.
        """
        if task.name in self._tasks and not replace:
            raise InputError(f"task {task.name!r} is already registered (pass replace=True to override)")
        self._tasks[task.name] = task
        return task

    def get(self, name: str) -> Task:
        """Return the task called ``name``.

        Parameters
        ----------
        name : str
            Name of the task.

        Returns
        -------
        Task
            The registered task.

        Raises
        ------
        InputError
            For an unknown name, listing the registered ones.
        """
        try:
            return self._tasks[name]
        except (KeyError, TypeError):
            raise InputError(
                f"study.task = {name!r} is unknown; registered tasks: {sorted(self._tasks)} "
                "(register your own with exudyn_study.sweep.register_task)"
            ) from None

    def names(self) -> tuple[str, ...]:
        """Return the registered task names, sorted."""
        return tuple(sorted(self._tasks))

    def __contains__(self, name: object) -> bool:
        return name in self._tasks


#: The default task registry (built-ins below; users add theirs with :func:`register_task`).
TASKS = TaskRegistry()


def register_task(
    name: str,
    function: Callable[..., Mapping[str, Any]],
    parameters: Sequence[Parameter] = (),
    *,
    registry: TaskRegistry | None = None,
    replace: bool = False,
    **options: Any,
) -> Task:
    """Register ``function`` as sweep task ``name``.

    Parameters
    ----------
    name : str
        Name used in ``[study] task = ...``.
    function : callable
        ``function(*, seed, **parameters) -> mapping of outputs``.
    parameters : sequence of Parameter
        Declared parameters with types, units, bounds/choices and defaults.
    registry : TaskRegistry, optional
        Default :data:`TASKS`.
    replace : bool
        Replace a task of the same name.
    **options
        ``artefact``, ``plot_prefix``, ``plot_label``, ``summary`` of :class:`Task`.

    Returns
    -------
    Task
    """
    return (registry or TASKS).register(Task(name, function, tuple(parameters), **options), replace)


def get_task(name: str, registry: TaskRegistry | None = None) -> Task:
    """Look up a task by name in ``registry`` (default :data:`TASKS`).

    Parameters
    ----------
    name : str
        Name of the task.
    registry : TaskRegistry, optional
        Registry to search (default :data:`TASKS`).

    Returns
    -------
    Task
        The registered task.

    Raises
    ------
    InputError
        If no task is registered under ``name``.
    """
    return (registry or TASKS).get(name)


# ---------------------------------------------------------------------------------------
# sleep_cpu: fixed CPU work (tests, benchmark)
# ---------------------------------------------------------------------------------------


def sleep_cpu(*, seed: int, seconds: float = 0.2, size: int = 20_000, pid_dir: str = "",
              run_log: str = "", fail: bool = False) -> dict[str, Any]:
    """Burn ``seconds`` of this process's CPU time on NumPy work; return a seeded checksum.

    The amount of work is fixed in CPU time (``time.process_time``), not wall time, so a
    busy machine makes the task slower, as for a real computation.

    Parameters
    ----------
    seed : int
        Seed of the checksum data.
    seconds : float
        CPU time to consume (s).
    size : int
        Length of the work array.
    pid_dir : str
        If not empty, a file ``<pid>`` is created in this directory when the task starts
        (tests use it to kill a worker).
    run_log : str
        If not empty, a file ``<seed>.<pid>.<start time in ns>`` is created in this directory
        when the task starts (tests count the executions of each point with it).
    fail : bool
        Raise ``RuntimeError`` (tests of failed rows).

    Returns
    -------
    dict
        ``checksum`` (depends only on ``seed`` and ``size``) and ``cpu_s``.
    """
    if pid_dir:
        open(os.path.join(pid_dir, str(os.getpid())), "w").close()
    if run_log:
        open(os.path.join(run_log, f"{seed}.{os.getpid()}.{time.time_ns()}"), "w").close()
    if fail:
        raise RuntimeError("sleep_cpu asked to fail")
    x = np.random.default_rng(seed).standard_normal(size)
    checksum = float(np.sum(np.sin(x) * np.cos(3 * x)))
    t0 = time.process_time()
    y = x.copy()
    while time.process_time() - t0 < seconds:
        for _ in range(20):
            y = np.sin(y) + np.cos(y) * 0.5
    return {"checksum": checksum, "cpu_s": time.process_time() - t0}


TASKS.register(
    Task(
        "sleep_cpu",
        sleep_cpu,
        (
            Parameter("seconds", "float", "s", (0.0, 3600.0), default=0.2, doc="CPU time per point"),
            Parameter("size", "int", "", (1, 10_000_000), default=20_000, doc="work array length"),
            Parameter("pid_dir", "str", default="", doc="directory for a <pid> file (tests)"),
            Parameter("run_log", "str", default="", doc="directory for one file per execution (tests)"),
            Parameter("fail", "bool", default=False, doc="raise (tests)"),
        ),
        summary=("checksum",),
    )
)


# ---------------------------------------------------------------------------------------
# body_frequencies: reduced flexible bodies (cached)
# ---------------------------------------------------------------------------------------


def _mesh_size(value: Any) -> Any:
    if isinstance(value, str):
        if value not in ("coarse", "production"):
            raise InputError("expected 'coarse', 'production' or an element size in m")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise InputError("expected 'coarse', 'production' or a positive element size in m")
    return float(value)


def _body_spec(p: Mapping[str, Any]):
    from exudyn_study.bodies.reduction import ReductionSettings
    from exudyn_study.bodies.spec import BodySpec

    return BodySpec(
        kind=p["kind"],
        joint_model=p["joint_model"],
        component=p["component"] or None,
        mesh_size=p["mesh_size"],
        reduction=ReductionSettings(max_frequency_hz=p["max_frequency_hz"]),
        water_mass_per_tank_kg=p["water_mass_per_tank_kg"],
    )


def _build_body(spec, cache_dir: str) -> None:
    from exudyn_study.bodies.spec import flexible_body

    flexible_body(spec, cache_dir=cache_dir or None)


def _body_artefact(p: Mapping[str, Any]) -> tuple:
    spec = _body_spec(p)
    return (f"body:{spec!r}:{p['cache_dir']}", _build_body, (spec, p["cache_dir"]))


def body_frequencies(*, seed: int, kind: str = "chassis", joint_model: str = "simple",
                     component: str = "", mesh_size: Any = "production",
                     water_mass_per_tank_kg: float = 222.0, max_frequency_hz: float = 300.0,
                     n_modes: int = 10, cache_dir: str = "") -> dict[str, Any]:
    """Free-free frequencies of a reduced flexible body (orthogonalised Craig-Bampton).

    Calls :func:`exudyn_study.bodies.flexible_body`, which returns the cached body when
    its recipe is unchanged; the sweep engine builds each distinct body once before the
    points run.

    Parameters
    ----------
    seed : int
        Unused (the reduction is deterministic); recorded in the row.
    kind, joint_model, component, mesh_size, water_mass_per_tank_kg
        As :class:`exudyn_study.bodies.BodySpec` (``component=''`` is the whole body).
    max_frequency_hz : float
        Reduction cut-off (Hz).
    n_modes : int
        Number of lowest frequencies returned.
    cache_dir : str
        Cache directory ('' for the default).

    Returns
    -------
    dict
        ``f.01 .. f.NN`` in Hz (nan past the last mode), ``n_modes_total``,
        ``total_mass_kg``, ``from_cache``.
    """
    from exudyn_study.bodies.spec import flexible_body

    params = dict(kind=kind, joint_model=joint_model, component=component, mesh_size=mesh_size,
                  water_mass_per_tank_kg=water_mass_per_tank_kg, max_frequency_hz=max_frequency_hz)
    data = flexible_body(_body_spec(params), cache_dir=cache_dir or None)
    f = np.asarray(data.body.frequencies_hz, dtype=float)
    out: dict[str, Any] = {
        f"f.{i + 1:02d}": float(f[i]) if i < f.size else math.nan for i in range(n_modes)
    }
    out.update(n_modes_total=int(f.size), total_mass_kg=float(data.body.total_mass_kg),
               from_cache=bool(data.from_cache))
    return out


TASKS.register(
    Task(
        "body_frequencies",
        body_frequencies,
        (
            Parameter("kind", "str", choices=("chassis", "rear_foundation"), default="chassis"),
            Parameter("joint_model", "str", choices=("simple", "detailed"), default="simple"),
            Parameter("component", "str", default="",
                      choices=("", "frame", "tank_left", "tank_right", "bracket_left", "bracket_right")),
            Parameter("mesh_size", "any", "m", default="production", check=_mesh_size,
                      doc="'coarse', 'production' or element size"),
            Parameter("water_mass_per_tank_kg", "float", "kg", (0.0, 10_000.0), default=222.0),
            Parameter("max_frequency_hz", "float", "Hz", (1.0, 5000.0), default=300.0),
            Parameter("n_modes", "int", "", (1, 200), default=10),
            Parameter("cache_dir", "str", default=""),
        ),
        artefact=_body_artefact,
        plot_prefix="f.",
        plot_label="frequency (Hz)",
        summary=("f.01", "f.02", "f.03", "n_modes_total"),
    )
)


# ---------------------------------------------------------------------------------------
# damping_sensitivity: relative pseudo damage per z sensor (linear modal surrogate)
# ---------------------------------------------------------------------------------------

#: damping functions of :func:`damping_sensitivity`
DAMPING_CHOICES = ("adams-default", "step", "step-custom", "constant", "calibrated")
#: model paths: the linear modal surrogate, or a rig model variant against a virtual-rig recording
RIG_MODELS = ("rig-1", "rig-2", "rig-3")
MODELS = ("modal-table1",) + RIG_MODELS


def _damping_ratios(frequency_hz: np.ndarray, identified: np.ndarray, damping: str, ratio: float,
                    step: tuple[float, float, float, float]) -> np.ndarray:
    from exudyn_study.bodies import damping as dmp

    if damping == "adams-default":
        return dmp.adams_default(frequency_hz)
    if damping == "step":
        return dmp.step_reference(frequency_hz)
    if damping == "step-custom":
        x0, h0, x1, h1 = step
        return dmp.adams_step(frequency_hz, x0, h0, x1, h1)
    if damping == "constant":
        return dmp.constant(ratio)(frequency_hz)
    return dmp.PerModeTable(tuple(identified))(frequency_hz)  # calibrated


def damping_sensitivity(*, seed: int, model: str = "modal-table1", signal: str = "test",
                        damping: str = "adams-default", damping_scale: float = 1.0,
                        ratio: float = 0.02, step_x0_hz: float = 0.0, step_h0: float = 0.166,
                        step_x1_hz: float = 450.0, step_h1: float = 1.0, duration_s: float = 60.0,
                        sample_rate_hz: float = 1000.0, rms_m: float = 0.25e-3,
                        beta: float = 5.0, measured_scenario: str = "thesis") -> dict[str, Any]:
    r"""Relative pseudo damage per z sensor for a modal damping function.

    **Rig path** (``model='rig-1'|'rig-2'|'rig-3'``): the thesis's study itself. The
    "measured" recording is the virtual rig's ``measured_scenario`` (default ``'thesis'``)
    for ``signal`` and ``seed`` (generated once and cached in the body cache directory,
    ``virtual/``); the model variant with the damping function (times ``damping_scale``)
    applied to each flexible body's modes is simulated (linear path) with the recording's
    drive channel, and the relative pseudo damage of every z sensor is computed after the
    first second. ``'calibrated'`` means thesis Table 6 per body (Model 3 only).

    **Model path: the linear modal surrogate** (``model='modal-table1'``), not the Exudyn
    rig: the ten modes of thesis Table 1 on the thesis's response channels
    (:func:`exudyn_study.identify.synthetic.table1_system`), base-excited at the rig's
    drive point. The drive displacement :func:`exudyn_study.signals.drive_signal` is
    differentiated twice (in the frequency domain; the signals are periodic over their
    duration) and filtered by the exact transmissibility, giving the periodic steady
    state. The "measured" responses use the identified damping of Table 1; the
    "simulated" ones use the damping function applied to the same mode frequencies,
    times ``damping_scale``. Relative pseudo damage is ``D_sim / D_meas`` per z channel
    (:func:`exudyn_study.signals.fatigue.pseudo_damage`, rainflow + Basquin, ``beta``).

    The thesis applies the damping functions to the *flexible-body* modes; here they act
    on the *system* modes directly, which keeps the trend (Adams default: too little
    damping below 100 Hz -> damage overestimated; STEP: too much -> underestimated) but
    not the thesis's numbers. ``'calibrated'`` is the identified damping itself, so its
    relative pseudo damage is 1 by construction (a check of the pipeline). Per-body
    damping (Table 6) needs the Exudyn model variants and is not offered here.

    Parameters
    ----------
    seed : int
        Seed of the drive signal (same seed -> same drive for every damping function).
    model : {'modal-table1'}
    signal : {'white-noise', 'test', 'test-50'}
    damping : {'adams-default', 'step', 'step-custom', 'constant', 'calibrated'}
    damping_scale : float
        Factor on the ratios of the damping function (result clipped to 0.999).
    ratio : float
        Ratio of ``'constant'``.
    step_x0_hz, step_h0, step_x1_hz, step_h1 : float
        STEP of ``'step-custom'`` (Hz, -, Hz, -).
    duration_s, sample_rate_hz, rms_m
        Drive signal length (s), rate (Hz) and rms displacement (m).
    beta : float
        Basquin exponent.
    measured_scenario : str
        Virtual-rig scenario (:func:`exudyn_study.virtual_rig.scenarios.scenario`) whose
        recording is the "measured" one on the rig path (default ``'thesis'``); unused by
        ``'modal-table1'``.

    Returns
    -------
    dict
        ``rpd.<sensor>`` per z channel, ``rpd_mean`` (geometric mean), ``rpd_min``,
        ``rpd_max``, ``zeta_mean`` (mean applied ratio).
    """
    from exudyn_study.bodies.damping import MAX_RATIO
    from exudyn_study.identify.synthetic import BaseExcitedSystem, table1_system
    from exudyn_study.signals.drives import drive_signal
    from exudyn_study.signals.fatigue import pseudo_damage

    if model in RIG_MODELS:
        return _rig_damping_sensitivity(model, signal, damping, damping_scale, ratio,
                                        (step_x0_hz, step_h0, step_x1_hz, step_h1), duration_s, seed, beta,
                                        measured_scenario)
    if model != "modal-table1":
        raise InputError(f"model {model!r}; expected one of {list(MODELS)}")
    base = table1_system()
    zeta = _damping_ratios(base.frequency_hz, base.damping_ratio, damping, ratio,
                           (step_x0_hz, step_h0, step_x1_hz, step_h1))
    zeta = np.clip(np.asarray(zeta, dtype=float) * damping_scale, 1e-6, MAX_RATIO)
    sim = BaseExcitedSystem(base.frequency_hz, zeta, base.shapes, base.participation, base.rigid,
                            base.names, base.directions, base.positions_m, base.reference)
    x = drive_signal(signal, duration_s, sample_rate_hz, rms_m, seed)
    n = x.size
    f = np.fft.rfftfreq(n, 1.0 / sample_rate_hz)
    accel_spec = -((2 * np.pi * f) ** 2) * np.fft.rfft(x)  # base acceleration (m/s^2)
    z = np.array([d == "Z" for d in base.directions])
    names = [nm for nm, keep in zip(base.names, z, strict=True) if keep]

    def responses(system: BaseExcitedSystem) -> np.ndarray:
        t = system.transmissibility(f)[z, 0, :]
        return np.fft.irfft(t * accel_spec[None, :], n, axis=1)

    d_meas = pseudo_damage(responses(base), beta)
    d_sim = pseudo_damage(responses(sim), beta)
    rpd = d_sim / d_meas
    out: dict[str, Any] = {f"rpd.{nm}": float(v) for nm, v in zip(names, rpd, strict=True)}
    out.update(rpd_mean=float(np.exp(np.mean(np.log(rpd)))), rpd_min=float(rpd.min()),
               rpd_max=float(rpd.max()), zeta_mean=float(zeta.mean()))
    return out


def _virtual_measurement(scenario_name: str, signal: str, seed: int, duration_s: float):
    """Return the virtual rig's recording of ``scenario_name`` (cached on disk, written atomically)."""
    from exudyn_study.infra.cache import cache_dir
    from exudyn_study.recording.io import read_recording, write_recording
    from exudyn_study.virtual_rig import scenario
    from exudyn_study.virtual_rig.run import virtual_recording

    sc = scenario(scenario_name).with_seed(seed)
    folder = cache_dir() / "virtual"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{sc.name}_{signal}_s{seed}_{duration_s:g}s.h5"
    if path.exists():
        try:
            return read_recording(path)  # verified by the recording's checksum
        except InputError as exc:  # damaged (cut short, bytes changed): rebuilt, never used
            log.warning("cached virtual recording %s is damaged (%s); rebuilding it", path.name, exc)
            path.unlink(missing_ok=True)
    rec = virtual_recording(sc, signal, duration_s)
    write_recording(rec, path)
    return rec


def _rig_damping_sensitivity(model, signal, damping, damping_scale, ratio, step, duration_s, seed, beta,
                             measured_scenario):
    from exudyn_study.bodies.damping import MAX_RATIO, THESIS_TABLE6, PerBody
    from exudyn_study.model import build_model
    from exudyn_study.signals.fatigue import pseudo_damage
    from exudyn_study.simulate.run import simulate

    variant = int(model[-1])
    if damping == "calibrated":
        if variant != 3:
            raise InputError(f"damping 'calibrated' on {model!r}: the per-body Table 6 exists for model 3 "
                             "only; use rig-3 or another damping")
        chosen = PerBody({k: float(np.clip(v * damping_scale, 1e-6, MAX_RATIO))
                          for k, v in THESIS_TABLE6.ratios.items()}, default=THESIS_TABLE6.default)
    else:
        def chosen(frequency_hz):
            z = _damping_ratios(np.asarray(frequency_hz, dtype=float), np.zeros(0), damping, ratio, step)
            return np.clip(np.asarray(z, dtype=float) * damping_scale, 1e-6, MAX_RATIO)
    measured = _virtual_measurement(measured_scenario, signal, seed, duration_s)
    rig = build_model(variant, damping=chosen, exudyn_mesh="used")
    drive = measured.drive
    sim = simulate(rig, drive.data, method="linear", drive_rate_hz=drive.sample_rate_hz)
    k0 = 1000  # the first second (fade-in) is not compared
    out: dict[str, Any] = {}
    rpd = []
    for ch in sim:
        if ch.role != "response" or ch.direction != "Z" or ch.name not in measured.names:
            continue
        m = measured.channel(ch.name).data
        n = min(m.size, ch.data.size)
        value = float(np.sum(pseudo_damage(ch.data[k0:n], beta)) / np.sum(pseudo_damage(m[k0:n], beta)))
        out[f"rpd.{ch.name}"] = value
        rpd.append(value)
    rpd = np.array(rpd)
    zeta = np.concatenate([np.asarray(r, dtype=float).ravel() for r in rig.damping_ratios.values()])
    out.update(rpd_mean=float(np.exp(np.mean(np.log(rpd)))), rpd_min=float(rpd.min()),
               rpd_max=float(rpd.max()), zeta_mean=float(zeta.mean()))
    return out


def _signal_names() -> tuple[str, ...]:
    from exudyn_study.signals.drives import SIGNALS

    return tuple(SIGNALS)


TASKS.register(
    Task(
        "damping_sensitivity",
        damping_sensitivity,
        (
            Parameter("model", "str", choices=MODELS, default="modal-table1",
                      doc="model path: the linear modal surrogate, or rig-1/2/3 against the virtual rig"),
            Parameter("signal", "str", choices=_signal_names(), default="test"),
            Parameter("damping", "str", choices=DAMPING_CHOICES, default="adams-default"),
            Parameter("damping_scale", "float", "", (1e-3, 100.0), default=1.0),
            Parameter("ratio", "float", "", (0.0, 0.999), default=0.02),
            Parameter("step_x0_hz", "float", "Hz", (0.0, 10_000.0), default=0.0),
            Parameter("step_h0", "float", "", (0.0, 1.0), default=0.166),
            Parameter("step_x1_hz", "float", "Hz", (0.0, 10_000.0), default=450.0),
            Parameter("step_h1", "float", "", (0.0, 1.0), default=1.0),
            Parameter("duration_s", "float", "s", (1.0, 3600.0), default=60.0),
            Parameter("sample_rate_hz", "float", "Hz", (128.0, 100_000.0), default=1000.0),
            Parameter("rms_m", "float", "m", (1e-9, 0.1), default=0.25e-3),
            Parameter("beta", "float", "", (0.1, 50.0), default=5.0),
            Parameter("measured_scenario", "str", default="thesis",
                      doc="virtual-rig scenario of the 'measured' recording (rig paths)"),
        ),
        plot_prefix="rpd.",
        plot_label="relative pseudo damage D_sim / D_meas",
        summary=("rpd_mean", "rpd_min", "rpd_max", "zeta_mean"),
    )
)
