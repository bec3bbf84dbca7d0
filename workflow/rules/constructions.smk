# The study's dynamic runs repeated with other kernel constructions (study.compare_constructions), so
# that the report can show the seed's construction beside the default. Quasi-static runs do not depend
# on the construction: each comparison study takes the study's own.

wildcard_constraints:
    construction="|".join(COMPARE_CONSTRUCTIONS) or "no-construction",


rule construction_greens:
    output:
        nc=f"{R}/constructions/{{construction}}/greens/{{material}}.nc",
    log:
        f"{R}/logs/constructions/{{construction}}/greens/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/constructions/{{construction}}/greens/{{material}}.tsv"
    params:
        material=resolved_material,
        greens=lambda w: dict(config["greens"], construction=w.construction),
        n_elements=max_patch_elements(),
        element_size=study_element_size(),
        code=SOURCE["greens"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("construction_greens", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("construction_greens", config, w, attempt)["runtime"],
    script:
        "../scripts/greens.py"


rule construction_contact:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/constructions/{{construction}}/greens/{{material}}.nc",
    output:
        nc=f"{R}/constructions/{{construction}}/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.nc",
    log:
        f"{R}/logs/constructions/{{construction}}/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.log",
    benchmark:
        f"{R}/benchmarks/constructions/{{construction}}/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.tsv"
    wildcard_constraints:
        mode="dynamic",
    params:
        material=resolved_material,
        # these runs show what a construction gives: past its margin they are recorded, not refused
        solver=dict(config["solver"], stability="warn"),
        code=SOURCE["contact"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("construction_contact", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("construction_contact", config, w, attempt)["runtime"],
    script:
        "../scripts/contact.py"


rule construction_study:
    input:
        runs=lambda w: construction_runs(w.construction),
    output:
        nc=f"{R}/constructions/{{construction}}/study.nc",
    log:
        f"{R}/logs/constructions/{{construction}}/study.log",
    params:
        study=STUDY,
        d_max=config["solver"]["d_max"],
        compounds=STUDY_COMPOUNDS,  # the same coordinates as the study's own study.nc
        code=SOURCE["study"],
    threads: 1
    script:
        "../scripts/study.py"
