# The study repeated with a flexible belt behind the tread (issue 26; config section `belt`, rules active with
# belt.study: true): greens files of tread + belt (tyreroad.belt_stage), every study run (quasi-static and
# dynamic: the belt changes the static kernel too), the belt study (results/belt/study.nc: the same case labels
# as study.nc) and K*(f; d0) of the reference material with the belt. The report sets them beside the rigid belt.

rule belt_greens:
    output:
        nc=f"{R}/belt/greens/{{material}}.nc",
    log:
        f"{R}/logs/belt/greens/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/belt/greens/{{material}}.tsv"
    params:
        material=resolved_material,
        greens=config["greens"],
        belt=BELT,
        n_elements=max_patch_elements(),
        element_size=study_element_size(),
        code=SOURCE["greens"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("belt_greens", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("belt_greens", config, w, attempt)["runtime"],
    script:
        "../scripts/greens.py"


rule belt_contact:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/belt/greens/{{material}}.nc",
    output:
        nc=f"{R}/belt/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.nc",
    log:
        f"{R}/logs/belt/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.log",
    benchmark:
        f"{R}/benchmarks/belt/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.tsv"
    params:
        material=resolved_material,
        # as the construction comparisons: a run past its belt kernel's margin is recorded (fs/2 alternation,
        # fs2_limit_indentation) and marked in the report's belt section, not refused
        solver=dict(config["solver"], stability="warn"),
        code=SOURCE["contact"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("belt_contact", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("belt_contact", config, w, attempt)["runtime"],
    script:
        "../scripts/contact.py"


rule belt_study:
    input:
        runs=belt_runs(),
    output:
        nc=f"{R}/belt/study.nc",
    log:
        f"{R}/logs/belt/study.log",
    params:
        study=STUDY,
        d_max=config["solver"]["d_max"],
        compounds=STUDY_COMPOUNDS,
        code=SOURCE["study"],
    threads: 1
    script:
        "../scripts/study.py"


rule belt_stiffness_spectrum:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/belt/greens/{{material}}.nc",
    output:
        nc=f"{R}/belt/stiffness_spectrum/{{surface}}/{{material}}.nc",
    log:
        f"{R}/logs/belt/stiffness_spectrum/{{surface}}/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/belt/stiffness_spectrum/{{surface}}/{{material}}.tsv"
    params:
        material=resolved_material,
        solver=config["solver"],
        spectrum=config.get("stiffness_spectrum", {}),
        code=SOURCE["stiffness_spectrum"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("belt_stiffness_spectrum", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("belt_stiffness_spectrum", config, w, attempt)["runtime"],
    script:
        "../scripts/stiffness_spectrum.py"


rule belt_mobility:
    output:
        nc=f"{R}/belt/mobility.nc",
        png=report(f"{R}/figures/belt_mobility.png", caption="../report/belt_mobility.rst", category="Belt"),
    log:
        f"{R}/logs/belt/mobility.log",
    params:
        material=lambda w: _resolved_material_config(STUDY["reference_material"], config["materials"]),
        name=STUDY["reference_material"],
        belt=BELT.get("properties"),
        code=SOURCE["belt_mobility"],
    threads: 1
    script:
        "../scripts/belt_mobility.py"

