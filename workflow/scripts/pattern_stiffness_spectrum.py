"""Snakemake adapter for rule pattern_stiffness_spectrum."""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_pattern_stiffness_spectrum(
    surface_nc=snakemake.input.surface,
    springs_nc=snakemake.input.springs,
    greens_nc=snakemake.input.greens,
    slick_nc=snakemake.input.slick,
    surface_name=snakemake.wildcards.surface,
    material_name=snakemake.wildcards.material,
    material_cfg=snakemake.params.material,
    patch_origin=snakemake.params.origin,
    solver_cfg=snakemake.params.solver,
    spectrum_cfg=snakemake.params.spectrum,
    out_nc=snakemake.output.nc,
    threads=snakemake.threads,
)
