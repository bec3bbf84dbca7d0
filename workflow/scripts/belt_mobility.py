"""Snakemake adapter for rule belt_mobility."""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_belt_mobility(
    material_name=snakemake.params.name,
    material_cfg=snakemake.params.material,
    belt_cfg_or_None=snakemake.params.belt,
    out_nc=snakemake.output.nc,
    out_png=snakemake.output.png,
)
