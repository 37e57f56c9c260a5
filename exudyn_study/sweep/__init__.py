"""Parameter sweeps: a TOML study, run on a local process pool or a Dask cluster.

- :mod:`.config`: parse and validate the TOML file, expand grid/random points;
- :mod:`.tasks`: the task registry and the built-in tasks;
- :mod:`.engine`: run the points (process pool or ``dask.distributed``), write results
  incrementally and atomically, resume;
- :mod:`.plots`: sensitivity plot of a task's output family against a swept parameter;
- :mod:`.cli`: the ``exudyn-study sweep`` subcommand.
"""

from exudyn_study.sweep.config import Point, SweepConfig, expand_points, load_config, parse_config
from exudyn_study.sweep.engine import SweepResult, run_sweep
from exudyn_study.sweep.tasks import TASKS, Parameter, Task, get_task, register_task

__all__ = [
    "Point",
    "SweepConfig",
    "expand_points",
    "load_config",
    "parse_config",
    "SweepResult",
    "run_sweep",
    "TASKS",
    "Parameter",
    "Task",
    "get_task",
    "register_task",
]
