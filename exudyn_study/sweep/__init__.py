"""Parameter sweeps: a TOML study, run on a local process pool or a Dask cluster.

- :mod:`.config`: parse and validate the TOML file, expand grid/random points;
- :mod:`.tasks`: the task registry and the built-in tasks;
- :mod:`.engine`: run the points (process pool or ``dask.distributed``), write results
  incrementally and atomically, resume;
- :mod:`.plots`: sensitivity plot of a task's output family against a swept parameter;
- :mod:`.cli`: the ``exudyn-study sweep`` subcommand.
"""

from .config import Point, SweepConfig, expand_points, load_config, parse_config
from .engine import SweepResult, run_sweep
from .tasks import TASKS, Parameter, Task, get_task, register_task

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
