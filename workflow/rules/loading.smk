rule loading_run:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/greens/{{material}}.nc",
    output:
        nc=f"{R}/loading/{{surface}}/{{material}}/{{mode}}_{{loading}}.nc",
    log:
        f"{R}/logs/loading/{{surface}}/{{material}}/{{mode}}_{{loading}}.log",
    benchmark:
        f"{R}/benchmarks/loading/{{surface}}/{{material}}/{{mode}}_{{loading}}.tsv"
    params:
        material=resolved_material,
        loading=loading_spec,
        solver=config["solver"],
        code=SOURCE["loading"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the patch size and the path's length
        mem_mb=lambda w, attempt: cluster_resources("loading_run", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("loading_run", config, w, attempt)["runtime"],
    script:
        "../scripts/loading_run.py"


rule loading_study:
    input:
        runs=all_loading_runs(),
    output:
        nc=f"{R}/loading.nc",
    log:
        f"{R}/logs/loading_study.log",
    params:
        code=SOURCE["loading_study"],
    threads: 1
    script:
        "../scripts/loading_study.py"


rule hysteresis_figure:
    input:
        loading=f"{R}/loading.nc",
    output:
        png=report(f"{R}/figures/fig10_hysteresis.png", caption="../report/fig10_hysteresis.rst",
                   category="Load-unload cycles"),
    log:
        f"{R}/logs/hysteresis_figure.log",
    params:
        code=SOURCE["hysteresis_figure"],
    threads: 1
    script:
        "../scripts/hysteresis_figure.py"
