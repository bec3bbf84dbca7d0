rule prepare_surface:
    input:
        scan=scan_files,
    output:
        nc=f"{R}/surface/{{surface}}.nc",
        png=report(f"{R}/figures/fig4_surface_{{surface}}.png", caption="../report/fig4_surface.rst",
                   category="Surface", subcategory="{surface}"),
    log:
        f"{R}/logs/prepare_surface/{{surface}}.log",
    benchmark:
        f"{R}/benchmarks/prepare_surface/{{surface}}.tsv"
    params:
        spec=surface_spec,
        code=SOURCE["prepare_surface"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the patch size and run length
        mem_mb=lambda w, attempt: cluster_resources("prepare_surface", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("prepare_surface", config, w, attempt)["runtime"],
    script:
        "../scripts/prepare_surface.py"
