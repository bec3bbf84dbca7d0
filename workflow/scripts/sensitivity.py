"""Snakemake adapter for rule sensitivity."""
from tyreroad import log, sensitivity

log.configure(snakemake.log[0])
sensitivity.run_sensitivity_stage(
    snakemake.input.points, snakemake.params.sensitivity, snakemake.output.nc, snakemake.output.png, snakemake.output.md
)
