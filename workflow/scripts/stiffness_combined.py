"""Snakemake adapter for rule stiffness_combined."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])  # noqa: F821 (snakemake is injected)
pipeline.run_stiffness_combined(snakemake.input.spectra, out_nc=snakemake.output.nc,  # noqa: F821
                                compounds=snakemake.params.compounds)  # noqa: F821
