"""Snakemake adapter for rule stiffness_figure."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_stiffness_figure(
    snakemake.input.spectra,
    reference=snakemake.params.reference,
    variants=snakemake.params.variants,
    spectrum_cfg=snakemake.params.spectrum,
    out_png=snakemake.output.png,
)
