"""Snakemake adapter for rule loading_run."""
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
