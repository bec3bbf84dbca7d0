rule element_springs:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
    output:
        nc=f"{R}/springs/{{surface}}/{{material}}.nc",
    log:
        f"{R}/logs/element_springs/{{surface}}/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/element_springs/{{surface}}/{{material}}.tsv"
    params:
        # only what the springs depend on, so a density change does not re-run them
        material=spring_material_inputs,
        springs=config["springs"],
        code=SOURCE["element_springs"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the patch size and run length
        mem_mb=lambda w, attempt: cluster_resources("element_springs", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("element_springs", config, w, attempt)["runtime"],
    script:
        "../scripts/element_springs.py"


rule springs_figure:
    input:
        springs=f"{R}/springs/{{surface}}/{STUDY['reference_material']}.nc",
    output:
        png=report(f"{R}/figures/springs_{{surface}}.png", caption="../report/springs.rst",
                   category="Surface", subcategory="{surface}"),
    log:
        f"{R}/logs/springs_figure/{{surface}}.log",
    params:
        code=SOURCE["springs_figure"],
    threads: 1
    script:
        "../scripts/springs_figure.py"
