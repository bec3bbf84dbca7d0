"""Snakemake adapter for rule study."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_study(snakemake.input.runs, snakemake.params.study, snakemake.params.d_max, snakemake.output.nc)
