"""Snakemake adapter for rule rolling_study."""
from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_rolling_study(rolling_ncs=snakemake.input.runs, rolling_cfg=snakemake.params.rolling,
                           out_nc=snakemake.output.nc)
