# Claim 6 by loss-variant definition (issue 24, tyreroad.claim6): the seed's constant-|E| variants in the
# frequency domain (K* about the reference's relaxed state, no time-domain job of theirs), the causal anchors
# in the time domain (the study's loss variants and study.claim6.anchor_variants), and the storage checks.
# The section is checked at planning time (tyreroad.config.check_config); results/claim6.nc feeds the report.
# Its helpers (CLAIM6, claim6_outputs, claim6_runs) live in common.smk.
rule claim6:
    input:
        surface=f"{R}/surface/{STUDY_SURFACE}.nc",
        springs=f"{R}/springs/{STUDY_SURFACE}/{STUDY['reference_material']}.nc",
        greens=f"{R}/greens/{STUDY['reference_material']}.nc",
        runs=claim6_runs(),
    output:
        nc=f"{R}/claim6.nc",
    log:
        f"{R}/logs/claim6.log",
    benchmark:
        f"{R}/benchmarks/claim6.tsv"
    params:
        materials={m: _resolved_material_config(m, config["materials"])
                   for m in [STUDY["reference_material"], *STUDY["materials"], *CLAIM6.seed_variants, *CLAIM6.time_domain]},
        study=STUDY,
        variants=lambda w: material_variants(),
        solver=config["solver"],
        code=SOURCE["claim6"],
    threads: 1
    script:
        "../scripts/claim6.py"
