"""Snakemake adapter for rule pattern_greens."""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_pattern_greens(
    pattern_name=snakemake.wildcards.pattern,
    pattern_cfg=snakemake.params.pattern,
    influence=snakemake.params.influence,
    material_name=snakemake.wildcards.material,
    material_cfg=snakemake.params.material,
    element_size=snakemake.params.element_size,
    patch_elements=snakemake.params.patch_elements or [1, 1],
    out_nc=snakemake.output.nc,
)
