"""Snakemake adapter for rule rolling_run."""
import os

# BLAS threads = the job's threads, set before numpy loads: two jobs of -j2 each running a 2-thread
# OpenBLAS on 2 cores made a 400 x 400 Cholesky 100x slower (166 ms against 1.7 ms)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_rolling(
    surface_nc=snakemake.input.surface,
    springs_nc=snakemake.input.springs,
    greens_nc=snakemake.input.greens,
    surface_name=snakemake.wildcards.surface,
    material_name=snakemake.wildcards.material,
    mode=snakemake.wildcards.mode,
    speed=float(snakemake.wildcards.speed),
    rolling_cfg=snakemake.params.rolling,
    solver_cfg=snakemake.params.solver,
    out_nc=snakemake.output.nc,
    threads=snakemake.threads,
    material_cfg=getattr(snakemake.params, "material", None),  # rule belt_rolling_run: the belt's vibration
)
