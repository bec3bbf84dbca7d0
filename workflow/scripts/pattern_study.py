"""Snakemake adapter for rule pattern_study."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])  # noqa: F821 (snakemake is injected)
pipeline.run_pattern_study(
    contact_ncs=snakemake.input.runs,
    greens_ncs=snakemake.input.greens,
    study_cfg=snakemake.params.study,
    d_max=snakemake.params.d_max,
    out_nc=snakemake.output.nc,
)
