"""Snakemake adapter for rule study."""
import os

# BLAS threads = the job's threads, set before numpy loads: two jobs of -j2 each running a 2-thread
# OpenBLAS on 2 cores made a 400 x 400 Cholesky 100x slower (166 ms against 1.7 ms)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_study(snakemake.input.runs, snakemake.params.study, snakemake.params.d_max, snakemake.output.nc,
                   compounds=snakemake.params.compounds)
