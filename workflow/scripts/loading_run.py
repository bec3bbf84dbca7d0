"""Snakemake adapter for rule loading_run."""
import os

# BLAS threads = the job's threads, set before numpy loads: two jobs of -j2 each running a 2-thread
# OpenBLAS on 2 cores made a 400 x 400 Cholesky 100x slower (166 ms against 1.7 ms)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_loading(
    surface_nc=snakemake.input.surface,
    springs_nc=snakemake.input.springs,
    greens_nc=snakemake.input.greens,
    surface_name=snakemake.wildcards.surface,
    material_name=snakemake.wildcards.material,
    material_cfg=snakemake.params.material,
    mode=snakemake.wildcards.mode,
    loading_name=snakemake.wildcards.loading,
    loading_cfg=snakemake.params.loading,
    solver_cfg=snakemake.params.solver,
    out_nc=snakemake.output.nc,
    threads=snakemake.threads,
)
