rule greens:
    output:
        nc="results/greens/{material}.nc",
    log:
        "results/logs/greens/{material}.log",
    benchmark:
        "results/benchmarks/greens/{material}.tsv"
    params:
        material=lambda w: resolved_material(w.material),
        greens=config["greens"],
        n_elements=max_patch_elements(),
        element_size=study_element_size(),
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the patch size and run length
        mem_mb=lambda w, attempt: cluster_resources("greens", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("greens", config, w, attempt)["runtime"],
    script:
        "../scripts/greens.py"


rule greens_figures:
    input:
        greens=study_greens(),
    output:
        material="results/figures/fig2_material.png",
        frf="results/figures/fig3_frf.png",
    log:
        "results/logs/greens_figures.log",
    threads: 1
    script:
        "../scripts/greens_figures.py"
