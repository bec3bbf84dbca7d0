rule greens:
    output:
        nc=f"{R}/greens/{{material}}.nc",
    log:
        f"{R}/logs/greens/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/greens/{{material}}.tsv"
    params:
        material=resolved_material,
        greens=config["greens"],
        n_elements=max_patch_elements(),
        element_size=study_element_size(),
        code=SOURCE["greens"],
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
        material=report(f"{R}/figures/fig2_material.png", caption="../report/fig2_material.rst", category="Materials"),
        frf=report(f"{R}/figures/fig3_frf.png", caption="../report/fig3_frf.rst", category="Materials"),
    log:
        f"{R}/logs/greens_figures.log",
    params:
        code=SOURCE["greens_figures"],
    threads: 1
    script:
        "../scripts/greens_figures.py"
