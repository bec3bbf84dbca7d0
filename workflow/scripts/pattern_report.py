"""Snakemake adapter for rule pattern_report."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])  # noqa: F821 (snakemake is injected)
pipeline.run_pattern_report(study_nc=snakemake.input.study, out_md=snakemake.output.md,
                            spectrum_ncs=snakemake.input.spectra, figure_pngs=snakemake.input.get("figures", []),
                            dynamic_ncs=snakemake.input.get("dynamic", []))
