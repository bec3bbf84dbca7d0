rule element_springs:
    input:
        surface="results/surface/{surface}.nc",
    output:
        nc="results/springs/{surface}/{material}.nc",
    log:
        "results/logs/element_springs/{surface}/{material}.log",
    benchmark:
        "results/benchmarks/element_springs/{surface}/{material}.tsv"
    params:
        # only what the springs depend on, so a density change does not re-run them
        material=lambda w: spring_material_inputs(w.material, config["materials"]),
        springs=config["springs"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the patch size and run length
        mem_mb=lambda w, attempt: cluster_resources("element_springs", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("element_springs", config, w, attempt)["runtime"],
    script:
        "../scripts/element_springs.py"


rule springs_figure:
    input:
        springs=f"results/springs/{{surface}}/{STUDY['reference_material']}.nc",
    output:
        png="results/figures/springs_{surface}.png",
    log:
        "results/logs/springs_figure/{surface}.log",
    threads: 1
    script:
        "../scripts/springs_figure.py"
