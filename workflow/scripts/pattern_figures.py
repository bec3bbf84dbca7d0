"""Snakemake adapter for rule pattern_figures."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])  # noqa: F821 (snakemake is injected)
pipeline.run_pattern_figures(
    greens_ncs=snakemake.input.greens,
    spectrum_ncs=snakemake.input.spectra,
    out_compliance_png=snakemake.output.compliance,
    out_spectrum_png=snakemake.output.get("spectrum"),
)
