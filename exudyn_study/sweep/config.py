"""Sweep configuration: a TOML file parsed into frozen dataclasses and validated.

Layout of a configuration file::

    [study]
    name = "damping-comparison"     # optional, default: the file name
    task = "damping_sensitivity"    # a registered task (exudyn_study.sweep.tasks)
    mode = "grid"                   # 'grid' (Cartesian product) or 'random'
    samples = 20                    # random mode: number of points
    seed = 1                        # seed of the points (and of random sampling)
    imports = ["mypackage.tasks"]   # optional: modules that register user tasks (imported
                                    # only with allow_imports / ``--allow-imports``)

    [study.settings]                # fixed task parameters (model, signal, outputs...)
    model = "modal-table1"
    duration_s = 60.0

    [parameters]                    # swept task parameters, one table each
    damping = { values = ["adams-default", "step", "calibrated"] }
    damping_scale = { logspace = [-1, 1, 5] }    # 10**-1 .. 10**1, 5 values
    step_h0 = { linspace = [0.05, 0.3, 6] }      # start, stop (inclusive), number
    n_modes = { range = [4, 12, 2] }             # integers start..stop inclusive, step
    seed = { range = [0, 4] }                    # replicates: 'seed' may be swept

In ``random`` mode each parameter is sampled ``samples`` times with the study seed:
``values`` uniformly among the values, ``linspace`` uniformly in [start, stop],
``logspace`` log-uniformly in [10**start, 10**stop], ``range`` uniformly among its
integers.

Everything is checked before any task runs (:func:`load_config`): unknown task,
unknown or repeated parameter names, empty ranges, more than :data:`MAX_POINTS` points,
a ``study.name`` that is not a plain folder name (it names the output folder, so a path
such as ``../../x`` is refused), ``study.imports`` without the explicit opt-in (importing a
module runs its code: a configuration from someone else must not do that unasked), and
every expanded value against the task's declared type, bounds and choices (e.g. an unknown
model). Errors are one-line
:class:`~exudyn_study.errors.InputError` messages naming the key and the fix.
"""

from __future__ import annotations

import hashlib
import importlib
import itertools
import json
import math
import os
import re
import socket
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any
from urllib.parse import urlsplit

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.sweep.tasks import TASKS, Task, TaskRegistry

__all__ = [
    "ParameterRange",
    "SweepConfig",
    "Point",
    "load_config",
    "parse_config",
    "expand_points",
    "point_key",
    "check_scheduler",
    "RANGE_KINDS",
]

RANGE_KINDS = ("values", "linspace", "logspace", "range")
MODES = ("grid", "random")
#: most points of one sweep: each point is one task run (seconds to minutes), so 100 000
#: points are days of work on a cluster; a larger count is a typo in a range
MAX_POINTS = 100_000
#: largest |exponent| of a logspace range: 10**308 is the largest double
MAX_LOG_EXPONENT = 300
#: largest seed: stored as a 64-bit integer in the results
SEED_MAX = 2**63 - 1
#: a study name is a folder name: letters, digits, '.', '_', '-' (not starting with '.')
_NAME_PATTERN = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]{0,99}")
_STUDY_KEYS = ("name", "task", "mode", "samples", "seed", "settings", "imports")


@dataclass(frozen=True)
class ParameterRange:
    """The values of one swept parameter.

    Parameters
    ----------
    name : str
        Task parameter name (or 'seed').
    kind : {'values', 'linspace', 'logspace', 'range'}
    args : tuple
        The values (``values``), ``(start, stop, num)`` (``linspace``/``logspace``, stop
        inclusive, exponents of 10 for ``logspace``), ``(start, stop[, step])``
        (``range``, integers, stop inclusive).
    """

    name: str
    kind: str
    args: tuple

    def __post_init__(self) -> None:
        where = f"parameters.{self.name}.{self.kind}"
        if self.kind not in RANGE_KINDS:
            raise InputError(f"parameters.{self.name}: {self.kind!r}; expected one of {list(RANGE_KINDS)}")
        object.__setattr__(self, "args", tuple(self.args))
        a = self.args
        if self.kind == "values":
            if not a:
                raise InputError(f"{where} = []: empty list; give at least one value")
            return
        if self.kind in ("linspace", "logspace"):
            if len(a) != 3 or not all(_is_number(v) for v in a[:2]) or not _is_int(a[2]):
                raise InputError(f"{where} = {list(a)}: expected [start, stop, num] with an integer num")
            if a[2] < 1:
                raise InputError(f"{where} = {list(a)}: empty range (num = {a[2]}); use num >= 1")
            if a[2] > MAX_POINTS:
                raise InputError(f"{where} = {list(a)}: {a[2]} values; at most {MAX_POINTS} points per sweep")
            if self.kind == "logspace" and max(abs(a[0]), abs(a[1])) > MAX_LOG_EXPONENT:
                raise InputError(f"{where} = {list(a)}: exponents beyond +-{MAX_LOG_EXPONENT} overflow a "
                                 "double; give the exponents of 10")
            return
        if len(a) not in (2, 3) or not all(_is_int(v) for v in a):
            raise InputError(f"{where} = {list(a)}: expected integers [start, stop] or [start, stop, step]")
        step = a[2] if len(a) == 3 else 1
        if step == 0:
            raise InputError(f"{where} = {list(a)}: step 0; use a non-zero step")
        if len(range(a[0], a[1] + (1 if step > 0 else -1), step)) > MAX_POINTS:
            raise InputError(f"{where} = {list(a)}: more than {MAX_POINTS} values; at most {MAX_POINTS} "
                             "points per sweep")
        if not self.grid_values():
            raise InputError(
                f"{where} = {list(a)}: empty range (stop is inclusive; start <= stop for a positive step)"
            )

    def n_values(self) -> int:
        """Return the number of grid values (without listing them)."""
        a = self.args
        if self.kind == "values":
            return len(a)
        if self.kind in ("linspace", "logspace"):
            return int(a[2])
        step = a[2] if len(a) == 3 else 1
        return len(range(a[0], a[1] + (1 if step > 0 else -1), step))

    def grid_values(self) -> list:
        """Return the values of a grid sweep, in order."""
        a = self.args
        if self.kind == "values":
            return list(a)
        if self.kind == "linspace":
            return [float(v) for v in np.linspace(a[0], a[1], int(a[2]))]
        if self.kind == "logspace":
            return [float(v) for v in np.logspace(a[0], a[1], int(a[2]))]
        step = a[2] if len(a) == 3 else 1
        return list(range(a[0], a[1] + (1 if step > 0 else -1), step))

    def sample(self, rng: np.random.Generator, n: int) -> list:
        """``n`` random values (see the module notes).

        Parameters
        ----------
        rng : numpy.random.Generator
            Random generator to draw from.
        n : int
            Number of values to draw.

        Returns
        -------
        list
            ``n`` values: drawn with replacement from the grid values for ``values`` and ``range``,
            uniform between the two bounds for ``linspace``, log-uniform between ``10**lo`` and
            ``10**hi`` for ``logspace``.
        """
        a = self.args
        if self.kind in ("values", "range"):
            pool = self.grid_values()
            return [pool[int(i)] for i in rng.integers(0, len(pool), n)]
        lo, hi = float(a[0]), float(a[1])
        u = rng.uniform(0.0, 1.0, n)
        v = lo + (hi - lo) * u
        return [float(x) for x in (10.0**v if self.kind == "logspace" else v)]


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


@dataclass(frozen=True)
class Point:
    """One sweep point.

    Parameters
    ----------
    index : int
        Position in the sweep.
    key : str
        Identity of the point: hash of task, parameters and seed (:func:`point_key`).
    params : mapping
        Every task parameter (settings, swept values and defaults).
    seed : int
    """

    index: int
    key: str
    params: Mapping[str, Any]
    seed: int


@dataclass(frozen=True)
class SweepConfig:
    """A validated sweep configuration.

    Parameters
    ----------
    name : str
    task : str
        Registered task name.
    settings : mapping
        Fixed task parameters (validated).
    parameters : tuple of ParameterRange
        Swept parameters, in file order.
    mode : {'grid', 'random'}
    samples : int
        Number of points in random mode (0 in grid mode).
    seed : int
        Study seed (the point seed unless 'seed' is swept; random sampling seed).
    imports : tuple of str
        Modules imported to register user tasks.
    source : str
        Where the configuration came from (file path), for messages.
    """

    name: str
    task: str
    settings: Mapping[str, Any]
    parameters: tuple[ParameterRange, ...]
    mode: str = "grid"
    samples: int = 0
    seed: int = 0
    imports: tuple[str, ...] = ()
    source: str = "<config>"

    def __post_init__(self) -> None:
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))
        object.__setattr__(self, "parameters", tuple(self.parameters))
        if self.mode not in MODES:
            raise InputError(f"study.mode = {self.mode!r}; expected one of {list(MODES)}")
        if self.mode == "random" and self.samples < 1:
            raise InputError(f"study.samples = {self.samples!r}; random mode needs samples >= 1")

    @property
    def swept(self) -> tuple[str, ...]:
        """Names of the swept parameters."""
        return tuple(p.name for p in self.parameters)

    def as_dict(self) -> dict:
        """JSON-ready description (for the results manifest)."""
        return {
            "name": self.name,
            "task": self.task,
            "mode": self.mode,
            "samples": self.samples,
            "seed": self.seed,
            "settings": dict(self.settings),
            "parameters": {p.name: {p.kind: list(p.args)} for p in self.parameters},
            "imports": list(self.imports),
        }


def load_config(path: str | os.PathLike, registry: TaskRegistry | None = None,
                allow_imports: bool = False) -> SweepConfig:
    """Read and validate a sweep configuration file.

    Parameters
    ----------
    path : path
        TOML file.
    registry : TaskRegistry, optional
        Task registry (default :data:`~exudyn_study.sweep.tasks.TASKS`).
    allow_imports : bool
        Import the modules listed in ``study.imports`` (they run code); without it a
        configuration that lists any is refused.

    Returns
    -------
    SweepConfig
        Validated; :func:`expand_points` gives its points.

    Raises
    ------
    InputError
        Unreadable or non-UTF-8 file, TOML syntax error, or any of the checks of
        :func:`parse_config`.
    """
    from exudyn_study.infra.files import load_toml_input

    p = Path(path)
    data = load_toml_input(p, "sweep configuration")
    default_name = re.sub(r"[^A-Za-z0-9._-]", "_", p.stem).lstrip(".")[:100] or "sweep"
    try:
        return parse_config(data, source=str(p), default_name=default_name, registry=registry,
                            allow_imports=allow_imports)
    except InputError as exc:  # name the file as well as the key
        text = str(exc)
        where = f"sweep configuration {str(p)!r}"
        raise InputError(text if text.startswith(str(p)) else f"{where}: {text}") from None


def parse_config(data: Mapping[str, Any], source: str = "<config>", default_name: str = "sweep",
                 registry: TaskRegistry | None = None, allow_imports: bool = False) -> SweepConfig:
    """Validate the parsed TOML ``data`` (see the module notes) into a :class:`SweepConfig`.

    Every point is expanded and each value checked against the task's declarations, so a
    bad value is reported here, before any task runs.

    Parameters
    ----------
    data : Mapping[str, Any]
        Parsed TOML document with the tables ``[study]`` and ``[parameters]``.
    source : str, default "<config>"
        Name of the configuration (for example its file path), used in error messages and
        stored in the result.
    default_name : str, default "sweep"
        Study name used when ``study.name`` is absent; it names the output folder.
    registry : TaskRegistry, optional
        Registry in which the task is looked up (default :data:`TASKS`).
    allow_imports : bool, default False
        Whether the modules listed in ``study.imports`` may be imported (importing runs their
        code); without it a non-empty list is an error.

    Returns
    -------
    SweepConfig
        The validated configuration.

    Raises
    ------
    InputError
        Naming the offending key: unknown section or key, unknown task, unknown or
        repeated parameter, empty range, wrong type, out of bounds, unknown choice
        (e.g. ``study.settings.model``), missing required parameter.
    """
    registry = registry or TASKS
    unknown = sorted(set(data) - {"study", "parameters"})
    if unknown:
        raise InputError(f"{source}: unknown section(s) {unknown}; expected [study] and [parameters]")
    study = data.get("study")
    if not isinstance(study, Mapping):
        raise InputError(f"{source}: missing [study] table; it needs at least task = '<name>'")
    bad = sorted(set(study) - set(_STUDY_KEYS))
    if bad:
        raise InputError(f"study.{bad[0]}: unknown key; [study] accepts {list(_STUDY_KEYS)}")
    study_name = study.get("name", default_name)
    if not isinstance(study_name, str) or not _NAME_PATTERN.fullmatch(study_name):
        raise InputError(f"study.name = {study_name!r}: expected a folder name of letters, digits, '.', "
                         "'_' or '-' (not a path; it names the output folder sweep-results/<name>)")
    imports = study.get("imports", [])
    if not isinstance(imports, list) or not all(isinstance(m, str) for m in imports):
        raise InputError(f"study.imports = {imports!r}: expected a list of module names")
    if imports and not allow_imports:
        raise InputError(f"study.imports = {imports!r}: importing a module runs its code; pass "
                         "--allow-imports if you trust this configuration")
    for module in imports:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise InputError(f"study.imports: cannot import {module!r} ({exc}); is it installed?") from None
    if "task" not in study:
        raise InputError(f"study.task: missing; registered tasks: {list(registry.names())}")
    task = registry.get(study["task"])
    mode = study.get("mode", "grid")
    if mode not in MODES:
        raise InputError(f"study.mode = {mode!r}; expected one of {list(MODES)}")
    samples = study.get("samples", 0)
    if not _is_int(samples) or samples < 0:
        raise InputError(f"study.samples = {samples!r}: expected a positive integer")
    if samples > MAX_POINTS:
        raise InputError(f"study.samples = {samples!r}: at most {MAX_POINTS} points per sweep")
    if mode == "random" and samples < 1:
        raise InputError("study.samples: random mode needs samples = N >= 1")
    if mode == "grid" and samples:
        raise InputError("study.samples is only used with mode = 'random'; remove it or set the mode")
    seed = study.get("seed", 0)
    if not _is_int(seed) or not 0 <= seed <= SEED_MAX:
        raise InputError(f"study.seed = {seed!r}: expected an integer in [0, 2**63 - 1] (stored as a 64-bit "
                         "integer)")
    settings_raw = study.get("settings", {})
    if not isinstance(settings_raw, Mapping):
        raise InputError("study.settings: expected a table of task parameters")
    declared = task.parameter_map
    settings: dict[str, Any] = {}
    for key, value in settings_raw.items():
        if key == "seed":
            raise InputError("study.settings.seed: set the seed as study.seed (or sweep it in [parameters])")
        _known(task, key, "study.settings")
        settings[key] = declared[key].coerce(value, f"study.settings.{key}")
    params_raw = data.get("parameters", {})
    if not isinstance(params_raw, Mapping):
        raise InputError("parameters: expected a table with one entry per swept parameter")
    ranges = []
    for name, spec in params_raw.items():
        if name != "seed":
            _known(task, name, "parameters")
        if name in settings:
            raise InputError(f"parameters.{name}: also set in study.settings; keep one of the two")
        if not isinstance(spec, Mapping) or len(spec) != 1:
            raise InputError(
                f"parameters.{name} = {spec!r}: expected exactly one of "
                f"{', '.join(k + ' = [...]' for k in RANGE_KINDS)}"
            )
        (kind, args), = spec.items()
        if kind not in RANGE_KINDS:
            raise InputError(
                f"parameters.{name}.{kind}: unknown range kind; expected one of {list(RANGE_KINDS)}"
            )
        if not isinstance(args, list):
            raise InputError(f"parameters.{name}.{kind} = {args!r}: expected a list")
        r = ParameterRange(name, kind, tuple(args))
        seen = set()
        for v in r.grid_values() if kind in ("values", "range") else list(r.args[:2]):
            where = f"parameters.{name}.{kind}"
            if name == "seed":
                if not _is_int(v) or not 0 <= v <= SEED_MAX:
                    raise InputError(f"{where}: seed {v!r}; expected integers in [0, 2**63 - 1]")
            else:
                _check_range_value(declared[name], r, v, where)
            if kind == "values":
                marker = json.dumps(v, sort_keys=True, default=str)
                if marker in seen:
                    raise InputError(f"{where}: value {v!r} repeats; list each value once")
                seen.add(marker)
        ranges.append(r)
    given = set(settings) | set(params_raw)
    missing = [p.name for p in task.parameters if p.required and p.name not in given]
    if missing:
        raise InputError(
            f"study.settings: task {task.name!r} needs {', '.join(declared[m].describe() for m in missing)}"
        )
    if mode == "grid":
        n_points = math.prod(r.n_values() for r in ranges)
        if n_points > MAX_POINTS:
            raise InputError(f"[parameters]: the grid has {n_points} points; at most {MAX_POINTS} per sweep "
                             "(use mode = 'random' with samples = N, or fewer values)")
    config = SweepConfig(
        name=study_name, task=task.name, settings=settings,
        parameters=tuple(ranges), mode=mode, samples=samples, seed=seed,
        imports=tuple(imports), source=source,
    )
    expand_points(config, registry)  # checks every value of every point
    return config


def _known(task: Task, name: str, section: str) -> None:
    if name not in task.parameter_map:
        import difflib

        close = difflib.get_close_matches(name, list(task.parameter_map), n=3, cutoff=0.6)
        hint = f"did you mean {', '.join(close)}? " if close else ""
        raise InputError(
            f"{section}.{name}: unknown parameter of task {task.name!r}; {hint}"
            f"it accepts {', '.join(task.parameter_map) or 'no parameters'} (and 'seed' in [parameters])"
        )


def _check_range_value(param, r: ParameterRange, v: Any, where: str) -> None:
    if r.kind in ("linspace", "logspace"):
        if param.type not in ("float", "any"):
            raise InputError(f"{where}: {param.name} is {param.type}; use values = [...] or range = [...]")
        v = 10.0**v if r.kind == "logspace" else v
    param.coerce(v, where)


def point_key(task: str, params: Mapping[str, Any], seed: int) -> str:
    """Identity of a point: the first 16 hex digits of SHA-256 of its canonical JSON.

    Parameters
    ----------
    task : str
        Name of the task.
    params : Mapping[str, Any]
        Parameter values of the point, by name.
    seed : int
        Seed of the point.

    Returns
    -------
    str
        16 hex digits identifying the point.
    """
    text = json.dumps({"task": task, "params": dict(params), "seed": int(seed)}, sort_keys=True,
                      separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def expand_points(config: SweepConfig, registry: TaskRegistry | None = None) -> tuple[Point, ...]:
    """Return the points of ``config``: grid (Cartesian product, last parameter fastest) or random.

    Every value is checked against the task's declaration; duplicate points (possible in
    random mode with discrete values) are kept once.

    Parameters
    ----------
    config : SweepConfig
        Validated sweep configuration (see :func:`parse_config`).
    registry : TaskRegistry, optional
        Registry in which ``config.task`` is looked up (default :data:`TASKS`).

    Returns
    -------
    tuple of Point
    """
    task = (registry or TASKS).get(config.task)
    if config.mode == "grid":
        axes = [r.grid_values() for r in config.parameters]
        combos = list(itertools.product(*axes)) if axes else [()]
    else:
        rng = np.random.default_rng(config.seed)
        cols = [r.sample(rng, config.samples) for r in config.parameters]
        combos = list(zip(*cols, strict=True)) if cols else [()] * config.samples
    defaults = {p.name: p.default for p in task.parameters if not p.required}
    points, seen = [], set()
    for combo in combos:
        params = dict(defaults)
        params.update(config.settings)
        seed = config.seed
        for r, value in zip(config.parameters, combo, strict=True):
            if r.name == "seed":
                seed = int(value)
            else:
                params[r.name] = task.parameter_map[r.name].coerce(value, f"parameters.{r.name}")
        params = {p.name: params[p.name] for p in task.parameters}  # declaration order
        key = point_key(task.name, params, seed)
        if key in seen:
            continue
        seen.add(key)
        points.append(Point(len(points), key, MappingProxyType(params), seed))
    return tuple(points)


def check_scheduler(address: str, timeout_s: float = 2.0) -> str:
    """Check that a Dask scheduler listens at ``address``; return the normalised address.

    Parameters
    ----------
    address : str
        ``tcp://host:port``, ``host:port`` (default port 8786 when omitted).
    timeout_s : float
        Connection timeout (s).

    Raises
    ------
    InputError
        Malformed address, or nothing accepting connections there within the timeout.
    """
    text = address if "://" in address else f"tcp://{address}"
    parts = urlsplit(text)
    if parts.scheme not in ("tcp", "tls") or not parts.hostname:
        raise InputError(f"--scheduler {address!r}: expected tcp://HOST:PORT (e.g. tcp://127.0.0.1:8786)")
    try:
        port = parts.port or 8786
    except ValueError:
        raise InputError(f"--scheduler {address!r}: bad port; expected tcp://HOST:PORT") from None
    try:
        with socket.create_connection((parts.hostname, port), timeout=timeout_s):
            pass
    except OSError as exc:
        reason = "timed out" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc))
        raise InputError(
            f"--scheduler {address!r}: no scheduler reachable at {parts.hostname}:{port} ({reason} "
            f"within {timeout_s:g} s); start one with 'dask scheduler' or omit --scheduler "
            "for the local process pool"
        ) from None
    return f"{parts.scheme}://{parts.hostname}:{port}"
