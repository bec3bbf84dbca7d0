"""Snakemake adapter for rule belt_rolling_spectra."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])  # noqa: F821 (snakemake is injected)
pipeline.run_belt_rolling_spectra(
    belt_ncs=snakemake.input.belt,
    rigid_ncs=snakemake.input.rigid,
    out_nc=snakemake.output.nc,
    out_png=snakemake.output.png,
)
