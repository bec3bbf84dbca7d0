"""Snakemake adapter for rule springs_figure."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_springs_figure(snakemake.input.springs, snakemake.output.png)
