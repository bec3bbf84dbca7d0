"""Snakemake adapter for rule pattern_modes."""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_pattern_modes(
    pattern_name=snakemake.wildcards.pattern,
    pattern_cfg=snakemake.params.pattern,
    material_name=snakemake.params.material_name,
    material_cfg=snakemake.params.material,
    element_size=snakemake.params.element_size,
    dynamic_cfg=snakemake.params.dynamic,
    out_nc=snakemake.output.nc,
)
