"""Snakemake adapter for rule claim6."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_claim6(
    surface_nc=snakemake.input.surface,
    springs_nc=snakemake.input.springs,
    greens_nc=snakemake.input.greens,
    contact_ncs=list(snakemake.input.runs),
    materials_cfg=snakemake.params.materials,
    study_cfg=snakemake.params.study,
    variants=snakemake.params.variants,
    solver_cfg=snakemake.params.solver,
    out_nc=snakemake.output.nc,
    threads=snakemake.threads,
)
