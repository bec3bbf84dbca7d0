"""Snakemake adapter for rule rolling_figures."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_rolling_figures(rolling_nc=snakemake.input.study, map_ncs=snakemake.input.maps,
                             outputs=list(snakemake.output))
