"""Snakemake adapter for rule report."""
import os

# BLAS threads = the job's threads, set before numpy loads: two jobs of -j2 each running a 2-thread
# OpenBLAS on 2 cores made a 400 x 400 Cholesky 100x slower (166 ms against 1.7 ms)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

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
    construction_ncs=snakemake.input.get("constructions", []),
    construction_greens_ncs=snakemake.input.get("construction_greens", []),
    spring_comparison=snakemake.params.get("spring_comparison"),
    claim6_nc=snakemake.input.claim6[0] if snakemake.input.get("claim6") else None,
    figure_pngs=snakemake.input.get("figures", []),
    belt_ncs=snakemake.input.get("belt", []),
    pattern_nc=snakemake.input.pattern[0] if snakemake.input.get("pattern") else None,
)
