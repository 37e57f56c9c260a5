"""Identification tests: single-threaded BLAS.

The fits make thousands of small LAPACK/BLAS calls; on a few cores OpenBLAS's
threads only add overhead (this suite takes ~100 s with them on two cores, ~35 s
without). The variable takes effect only if NumPy is not imported yet, i.e. when
this directory is collected first (``pytest tests/identify``).
"""

import os
import sys

if "numpy" not in sys.modules:
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
