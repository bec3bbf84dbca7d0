"""Settings of every test session.

One BLAS/OpenMP thread per process: pytest runs on two workers (``-n 2`` in pyproject's addopts) on machines of
about two cores, and the scripts' Snakemake jobs already set the same (workflow/scripts/*.py). With OpenBLAS's
own thread pool per worker, a sparse complex factorisation of the FE block model (tyreroad.fe_pattern) took 41 s
instead of 0.9 s while the other worker was busy. Set before numpy is imported by any test module; a value the
caller exported is kept.
"""

import os
import sys
import warnings

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
if "numpy" in sys.modules:  # a plugin imported it first: its BLAS pool is already sized
    warnings.warn("numpy was imported before tests/conftest.py: the BLAS thread limit does not apply", stacklevel=1)
