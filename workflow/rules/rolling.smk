# Rolling contact (SPEC 12; tyreroad.rolling). A named target, not part of the default one:
#   snakemake -j2 rolling  ->  {results_dir}/rolling/..., rolling.nc, rolling.md, figures 11-14.
# The strips (rolling.surfaces) use the generic surface and springs rules, and their own Green's
# functions sized for the largest strip: the study's greens files stay as they are.
from tyreroad.rolling import RollingSettings

ROLLING_PASS_CFG = {k: v for k, v in ROLLING.items() if k not in ("surfaces", "materials", "speeds",
                                                                   "quasistatic_speeds", "reference_material")}


rule rolling_greens:
    output:
        nc=f"{R}/rolling/greens/{{material}}.nc",
    log:
        f"{R}/logs/rolling/greens/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/rolling/greens/{{material}}.tsv"
    params:
        material=resolved_material,
        greens=config["greens"],
        n_elements=rolling_greens_elements if ROLLING_SURFACES else [1, 1],
        # the correction and the margin on the contact's window of the strip (rolling.contact_window elements
        # along x): every contact set inside it is covered, and each pass checks that its contact stays inside
        margin_window=[RollingSettings.from_config(ROLLING_PASS_CFG).contact_window,
                       max_patch_elements(rolling=True)[1]] if ROLLING_SURFACES else None,
        element_size=study_element_size(),
        code=SOURCE["greens"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the largest strip and the kept lags
        mem_mb=lambda w, attempt: cluster_resources("rolling_greens", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("rolling_greens", config, w, attempt)["runtime"],
    script:
        "../scripts/greens.py"


rule rolling_run:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/rolling/greens/{{material}}.nc",
    output:
        nc=f"{R}/rolling/{{surface}}/{{material}}/{{mode}}_v{{speed}}.nc",
    log:
        f"{R}/logs/rolling/{{surface}}/{{material}}/{{mode}}_v{{speed}}.log",
    benchmark:
        f"{R}/benchmarks/rolling/{{surface}}/{{material}}/{{mode}}_v{{speed}}.tsv"
    params:
        check=checked,
        rolling=ROLLING_PASS_CFG,
        solver=config["solver"],
        code=SOURCE["rolling"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the strip size and the pass length in steps
        mem_mb=lambda w, attempt: cluster_resources("rolling_run", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("rolling_run", config, w, attempt)["runtime"],
    script:
        "../scripts/rolling_run.py"


rule rolling_study:
    input:
        runs=rolling_runs(),
    output:
        nc=f"{R}/rolling.nc",
    log:
        f"{R}/logs/rolling_study.log",
    params:
        rolling=ROLLING_PASS_CFG,
        code=SOURCE["rolling_study"],
    threads: 1
    script:
        "../scripts/rolling_study.py"


rule rolling_figures:
    input:
        study=f"{R}/rolling.nc",
        maps=rolling_map_runs() if ROLLING_SURFACES else [],
    output:
        [report(f"{R}/figures/{name}.png", caption=f"../report/{name}.rst", category="Rolling")
         for name in ROLLING_FIGURES],
    log:
        f"{R}/logs/rolling_figures.log",
    params:
        code=SOURCE["rolling_figures"],
    threads: 1
    script:
        "../scripts/rolling_figures.py"


rule rolling_report:
    input:
        study=f"{R}/rolling.nc",
        figures=[f"{R}/figures/{name}.png" for name in ROLLING_FIGURES],  # embedded with their captions
    output:
        md=f"{R}/rolling.md",
    log:
        f"{R}/logs/rolling_report.log",
    params:
        code=SOURCE["rolling_report"],
        spring_comparison=config.get("spring_comparison"),  # optional (issue 24): QLV vs elastic springs
    threads: 1
    script:
        "../scripts/rolling_report.py"


rule rolling:
    input:
        rolling_targets() if ROLLING_SURFACES else [],
