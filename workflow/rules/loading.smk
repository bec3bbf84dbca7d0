rule loading_run:
    input:
        surface="results/surface/{surface}.nc",
        springs="results/springs/{surface}/{material}.nc",
        greens="results/greens/{material}.nc",
    output:
        nc="results/loading/{surface}/{material}/{mode}_{loading}.nc",
    log:
        "results/logs/loading/{surface}/{material}/{mode}_{loading}.log",
    benchmark:
        "results/benchmarks/loading/{surface}/{material}/{mode}_{loading}.tsv"
    params:
        material=lambda w: resolved_material(w.material),
        loading=lambda w: config["loadings"][w.loading],
        solver=config["solver"],
    threads: 1
    script:
        "../scripts/loading_run.py"


rule loading_study:
    input:
        runs=all_loading_runs(),
    output:
        nc="results/loading.nc",
    log:
        "results/logs/loading_study.log",
    threads: 1
    script:
        "../scripts/loading_study.py"


rule hysteresis_figure:
    input:
        loading="results/loading.nc",
    output:
        png="results/figures/fig10_hysteresis.png",
    log:
        "results/logs/hysteresis_figure.log",
    threads: 1
    script:
        "../scripts/hysteresis_figure.py"
