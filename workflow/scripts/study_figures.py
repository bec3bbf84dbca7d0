"""Snakemake adapter for rule study_figures."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_study_figures(snakemake.input.study, snakemake.params.study, snakemake.params.variants, snakemake.output)
