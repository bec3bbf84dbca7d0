"""Snakemake adapter for rule prepare_surface."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_prepare_surface(
    snakemake.wildcards.surface, snakemake.params.spec, snakemake.output.nc, snakemake.output.png
)
