rule prepare_surface:
    output:
        nc="results/surface/{surface}.nc",
        png="results/figures/fig4_surface_{surface}.png",
    log:
        "results/logs/prepare_surface/{surface}.log",
    benchmark:
        "results/benchmarks/prepare_surface/{surface}.tsv"
    params:
        spec=lambda w: config["surfaces"][w.surface],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the patch size and run length
        mem_mb=lambda w, attempt: cluster_resources("prepare_surface", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("prepare_surface", config, w, attempt)["runtime"],
    script:
        "../scripts/prepare_surface.py"
