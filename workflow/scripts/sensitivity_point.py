"""Snakemake adapter for rule sensitivity_point."""
import os

# BLAS threads = the job's threads, set before numpy loads: two jobs of -j2 each running a 2-thread
# OpenBLAS on 2 cores made a 400 x 400 Cholesky 100x slower (166 ms against 1.7 ms)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, sensitivity

log.configure(snakemake.log[0])
sensitivity.run_point_stage(
    name=snakemake.wildcards.point,
    point=snakemake.params.point,
    reference_material=snakemake.params.reference_material,
    surface_spec=snakemake.params.surface,
    springs_cfg=snakemake.params.springs,
    greens_cfg=snakemake.params.greens,
    solver_cfg=snakemake.params.solver,
    study_cfg=snakemake.params.study,
    sensitivity_cfg=snakemake.params.sensitivity,
    out_nc=snakemake.output.nc,
    threads=snakemake.threads,
)
