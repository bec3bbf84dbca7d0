"""Snakemake adapter for rule greens_figures."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_greens_figures(snakemake.input.greens, snakemake.output.material, snakemake.output.frf)
