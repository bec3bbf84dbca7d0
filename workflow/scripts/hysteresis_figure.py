"""Snakemake adapter for rule hysteresis_figure."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_hysteresis_figure(loading_nc=snakemake.input.loading, out_png=snakemake.output.png)
