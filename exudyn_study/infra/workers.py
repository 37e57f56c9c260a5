"""Process-pool workers that end with the process that started them."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time

__all__ = ["die_with_parent"]


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
