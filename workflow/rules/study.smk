rule study:
    input:
        runs=all_contact_runs(),
    output:
        nc=f"{R}/study.nc",
    log:
        f"{R}/logs/study.log",
    params:
        study=STUDY,
        d_max=config["solver"]["d_max"],
        compounds=STUDY_COMPOUNDS,
        code=SOURCE["study"],
    threads: 1
    script:
        "../scripts/study.py"


rule study_figures:
    input:
        study=f"{R}/study.nc",
    output:
        [report(f"{R}/figures/{name}.png", caption=f"../report/{name}.rst", category="Study")
         for name in STUDY_FIGURES],
    log:
        f"{R}/logs/study_figures.log",
    params:
        study=STUDY,
        variants=lambda w: material_variants(),
        code=SOURCE["study_figures"],
    threads: 1
    script:
        "../scripts/study_figures.py"


rule report:
    input:
        study=f"{R}/study.nc",
        surface=f"{R}/surface/{STUDY_SURFACE}.nc",
        greens=study_greens(),
        loading=loading_outputs()[:1],
        spectra=stiffness_spectra(),
        constructions=construction_outputs(),
        construction_greens=construction_greens(),
        claim6=claim6_outputs(),
        belt=belt_outputs(),  # the study on a flexible belt (belt.study): study.nc, greens, K* of the reference
        pattern=pattern_targets()[:1] if PATTERN_STUDY else [],  # the pattern study (pattern.study, issue 27)
        figures=report_figures(),  # embedded in report.md with their captions
    output:
        md=f"{R}/report.md",
    log:
        f"{R}/logs/report.log",
    params:
        study=STUDY,
        variants=lambda w: material_variants(),
        spring_comparison=config.get("spring_comparison"),  # optional (issue 24): QLV vs elastic springs
        code=SOURCE["report"],
    threads: 1
    script:
        "../scripts/report.py"
