"""Snakemake adapter for rule rolling_run."""
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
)
