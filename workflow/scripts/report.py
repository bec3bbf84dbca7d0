"""Snakemake adapter for rule report."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_report(
    study_nc=snakemake.input.study,
    surface_nc=snakemake.input.surface,
    greens_ncs=snakemake.input.greens,
    study_cfg=snakemake.params.study,
    variants=snakemake.params.variants,
    out_md=snakemake.output.md,
    loading_nc=snakemake.input.loading[0] if snakemake.input.loading else None,
    spectra_ncs=snakemake.input.get("spectra", []),
    claim6_nc=snakemake.input.claim6[0] if snakemake.input.get("claim6") else None,
)
