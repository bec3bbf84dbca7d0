"""Snakemake adapter for rule stiffness_spectrum."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_stiffness_spectrum(
    surface_nc=snakemake.input.surface,
    springs_nc=snakemake.input.springs,
    greens_nc=snakemake.input.greens,
    surface_name=snakemake.wildcards.surface,
    material_name=snakemake.wildcards.material,
    material_cfg=snakemake.params.material,
    solver_cfg=snakemake.params.solver,
    spectrum_cfg=snakemake.params.spectrum,
    out_nc=snakemake.output.nc,
    threads=snakemake.threads,
)
