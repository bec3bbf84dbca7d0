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
    script:
        "../scripts/contact.py"
