"""Snakemake adapter for rule sensitivity_point."""
from tyreroad import log, sensitivity

log.configure(snakemake.log[0])
sensitivity.run_point_stage(
    name=snakemake.wildcards.point,
    point=snakemake.params.point,
    reference_material=snakemake.params.reference_material,
    surface_spec=snakemake.params.surface,
    springs_cfg=snakemake.params.springs,
    greens_cfg=snakemake.params.greens,
    solver_cfg=snakemake.params.solver,
    study_cfg=snakemake.params.study,
    sensitivity_cfg=snakemake.params.sensitivity,
    out_nc=snakemake.output.nc,
    threads=snakemake.threads,
)
