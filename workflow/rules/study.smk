rule study:
    input:
        runs=all_contact_runs(),
    output:
        nc="results/study.nc",
    log:
        "results/logs/study.log",
    params:
        study=STUDY,
        d_max=config["solver"]["d_max"],
    threads: 1
    script:
        "../scripts/study.py"


rule study_figures:
    input:
        study="results/study.nc",
    output:
        [f"results/figures/{name}.png" for name in STUDY_FIGURES],
    log:
        "results/logs/study_figures.log",
    params:
        study=STUDY,
        variants=lambda w: material_variants(),
    threads: 1
    script:
        "../scripts/study_figures.py"


rule report:
    input:
        study="results/study.nc",
        surface=f"results/surface/{STUDY_SURFACE}.nc",
        greens=study_greens(),
        spectra=stiffness_spectra(),
    output:
        md="results/report.md",
    log:
        "results/logs/report.log",
    params:
        study=STUDY,
        variants=lambda w: material_variants(),
    threads: 1
    script:
        "../scripts/report.py"
