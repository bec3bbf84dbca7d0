"""Snakemake adapter for rule greens."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_greens(
    material_name=snakemake.wildcards.material,
    material_cfg=snakemake.params.material,
    greens_cfg=snakemake.params.greens,
    n_elements=snakemake.params.n_elements,
    element_size=snakemake.params.element_size,
    out_nc=snakemake.output.nc,
)
