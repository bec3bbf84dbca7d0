"""Snakemake adapter for rule loading_study."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_loading_study(loading_ncs=snakemake.input.runs, out_nc=snakemake.output.nc)
