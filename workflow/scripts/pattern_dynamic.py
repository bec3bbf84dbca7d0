"""Snakemake adapter for rule pattern_dynamic."""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_pattern_dynamic(
    surface_nc=snakemake.input.surface,
    springs_nc=snakemake.input.springs,
    modes_nc=snakemake.input.modes,
    surface_name=snakemake.wildcards.surface,
    material_name=snakemake.wildcards.material,
    material_cfg=snakemake.params.material,
    pattern_name=snakemake.wildcards.pattern,
    mode=snakemake.wildcards.mode,
    acceleration=float(snakemake.wildcards.accel),
    patch_origin=snakemake.params.origin,
    solver_cfg=snakemake.params.solver,
    greens_cfg=snakemake.params.greens,
    out_nc=snakemake.output.nc,
    threads=snakemake.threads,
)
