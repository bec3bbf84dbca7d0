"""Snakemake adapter for rule element_springs."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_element_springs(
    surface_nc=snakemake.input.surface,
    surface_name=snakemake.wildcards.surface,
    material_name=snakemake.wildcards.material,
    material_inputs=snakemake.params.material,
    springs_cfg=snakemake.params.springs,
    out_nc=snakemake.output.nc,
)
