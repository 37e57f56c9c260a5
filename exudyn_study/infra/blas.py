"""One BLAS thread for the small dense algebra of the studies.

The calibration, the drive iteration/grid and the diagnosis solve thousands of small
(~100-200) eigen/linear problems; on a loaded 2-core machine OpenBLAS's threads made one
124 x 124 ``eig`` take 1.5-2.5 s instead of 0.02-0.04 s (measured). ``threadpoolctl`` is a
dependency; without it (a stripped install) these are no-ops.
"""

from __future__ import annotations

import contextlib
import functools

__all__ = ["single_threaded_blas", "one_blas_thread"]


def single_threaded_blas():
    """Return a context manager limiting BLAS/LAPACK to one thread (no-op without threadpoolctl)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # optional: without it the small solves may be slower under load
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def one_blas_thread(function):
    """Decorate ``function`` to run inside :func:`single_threaded_blas`.

    Parameters
    ----------
    function : callable
        Function to wrap.

    Returns
    -------
    callable
        Wrapper with the same signature that calls ``function`` with BLAS limited to one thread.
    """

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with single_threaded_blas():
            return function(*args, **kwargs)

    return wrapper
