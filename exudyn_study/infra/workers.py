"""Process-pool workers that end with the process that started them."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator

__all__ = ["THREAD_VARS", "die_with_parent", "single_threaded_workers"]

#: environment variables that set the thread count of the BLAS and OpenMP libraries
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS")


@contextlib.contextmanager
def single_threaded_workers() -> Iterator[None]:
    """Set :data:`THREAD_VARS` to 1 (where unset) while worker processes are started; restore them.

    Workers spawned inside inherit one BLAS thread each, so a pool of one worker per core does not
    oversubscribe the cores; the calling process keeps its own setting.
    """
    saved = {v: os.environ.get(v) for v in THREAD_VARS}
    for v in THREAD_VARS:
        os.environ.setdefault(v, "1")
    try:
        yield
    finally:
        for v, old in saved.items():
            if old is None:
                os.environ.pop(v, None)
            else:
                os.environ[v] = old


def die_with_parent(parent_pid: int) -> None:
    """Pool-worker initializer: end this worker when the process that started it is gone.

    A killed parent (SIGKILL, out of memory) cannot shut its pool down; without this its workers
    would finish their queue and the resource tracker would wait for them. On Linux the kernel
    sends SIGKILL at the parent's death (``PR_SET_PDEATHSIG``); everywhere a daemon thread also
    checks once a second that the parent is still the same process.

    Parameters
    ----------
    parent_pid : int
        Process id of the parent (``os.getpid()`` in the process that creates the pool).
    """
    if sys.platform.startswith("linux"):
        import ctypes

        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # 1: PR_SET_PDEATHSIG
    if os.getppid() != parent_pid:  # the parent died before the call above
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(1.0)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="exudyn-study-parent-watch", daemon=True).start()
