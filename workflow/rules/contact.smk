rule contact:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/greens/{{material}}.nc",
    output:
        nc=f"{R}/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.nc",
    log:
        f"{R}/logs/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.log",
    benchmark:
        f"{R}/benchmarks/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.tsv"
    params:
        material=resolved_material,
        solver=config["solver"],
        code=SOURCE["contact"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the patch size and run length
        mem_mb=lambda w, attempt: cluster_resources("contact", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("contact", config, w, attempt)["runtime"],
    script:
        "../scripts/contact.py"
