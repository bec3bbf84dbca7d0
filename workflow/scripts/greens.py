"""Snakemake adapter for rule greens."""
import os

# BLAS threads = the job's threads, set before numpy loads: two jobs of -j2 each running a 2-thread
# OpenBLAS on 2 cores made a 400 x 400 Cholesky 100x slower (166 ms against 1.7 ms)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, str(snakemake.threads))  # noqa: F821 (snakemake is injected)

from tyreroad import log, pipeline

log.configure(snakemake.log[0])
pipeline.run_greens(
    material_name=snakemake.wildcards.material,
    material_cfg=snakemake.params.material,
    greens_cfg=snakemake.params.greens,
    n_elements=snakemake.params.n_elements,
    element_size=snakemake.params.element_size,
    out_nc=snakemake.output.nc,
    belt_cfg=getattr(snakemake.params, "belt", None),  # rule belt_greens: tread + flexible belt
    margin_window=getattr(snakemake.params, "margin_window", None),  # rule rolling_greens: the contact's window
)
