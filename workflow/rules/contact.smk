rule contact:
    input:
        surface="results/surface/{surface}.nc",
        springs="results/springs/{surface}/{material}.nc",
        greens="results/greens/{material}.nc",
    output:
        nc="results/contact/{surface}/{material}/{mode}_{accel}.nc",
    log:
        "results/logs/contact/{surface}/{material}/{mode}_{accel}.log",
    benchmark:
        "results/benchmarks/contact/{surface}/{material}/{mode}_{accel}.tsv"
    params:
        material=lambda w: resolved_material(w.material),
        solver=config["solver"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the patch size and run length
        mem_mb=lambda w, attempt: cluster_resources("contact", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("contact", config, w, attempt)["runtime"],
    script:
        "../scripts/contact.py"
