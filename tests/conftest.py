"""Whole suite: single-threaded BLAS.

The library's numerical work in tests is thousands of small (~100x100) dense problems; on
a shared 2-core machine OpenBLAS's threads make each several times slower (a 124x124
eigen-solve: 1.5-2.4 s with two threads under load, 0.02-0.04 s with one). The
environment variables reach subprocesses (CLI tests, process pools); ``threadpoolctl``
limits the already loaded libraries of this process.
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import pytest  # noqa: E402


@pytest.fixture(scope="session", autouse=True)
def _single_threaded_blas():
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        yield
