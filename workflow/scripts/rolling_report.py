"""Snakemake adapter for rule rolling_report."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_rolling_report(rolling_nc=snakemake.input.study, out_md=snakemake.output.md)
