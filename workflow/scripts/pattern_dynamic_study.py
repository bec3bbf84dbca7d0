"""Snakemake adapter for rule pattern_dynamic_study."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])  # noqa: F821 (snakemake is injected)
pipeline.run_pattern_dynamic_study(
    contact_ncs=snakemake.input.runs,
    modes_ncs=snakemake.input.modes,
    study_cfg=snakemake.params.study,
    d_max=snakemake.params.d_max,
    out_nc=snakemake.output.nc,
)
