# Rolling on the belt (named target `belt_rolling`): the reference material's dynamic passes on the first rolling
# strip at belt.rolling_speeds, with the indentation from the rim (the wheel load is carried by tread + belt), the
# belt's velocity just ahead of and behind the contact, and the rigid-belt pass beside it.
rule belt_rolling_greens:
    output:
        nc=f"{R}/belt/rolling/greens/{{material}}.nc",
    log:
        f"{R}/logs/belt/rolling/greens/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/belt/rolling/greens/{{material}}.tsv"
    params:
        material=resolved_material,
        greens=config["greens"],
        belt=dict(BELT, reference="rim"),
        n_elements=rolling_greens_elements if ROLLING_SURFACES else [1, 1],
        element_size=study_element_size(),
        code=SOURCE["greens"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("belt_rolling_greens", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("belt_rolling_greens", config, w, attempt)["runtime"],
    script:
        "../scripts/greens.py"


rule belt_rolling_run:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/belt/rolling/greens/{{material}}.nc",
    output:
        nc=f"{R}/belt/rolling/{{surface}}/{{material}}/{{mode}}_v{{speed}}.nc",
    log:
        f"{R}/logs/belt/rolling/{{surface}}/{{material}}/{{mode}}_v{{speed}}.log",
    benchmark:
        f"{R}/benchmarks/belt/rolling/{{surface}}/{{material}}/{{mode}}_v{{speed}}.tsv"
    params:
        check=checked,
        rolling=ROLLING_PASS_CFG,
        material=resolved_material,
        solver=dict(config["solver"], stability="warn"),
        code=SOURCE["rolling"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("belt_rolling_run", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("belt_rolling_run", config, w, attempt)["runtime"],
    script:
        "../scripts/rolling_run.py"


rule belt_rolling_spectra:
    input:
        belt=[b for b, _ in belt_rolling_runs()],
        rigid=[r for _, r in belt_rolling_runs()],
    output:
        nc=f"{R}/belt/rolling_spectra.nc",
        png=report(f"{R}/figures/belt_rolling_spectra.png", caption="../report/belt_rolling_spectra.rst",
                   category="Belt"),
    log:
        f"{R}/logs/belt/rolling_spectra.log",
    params:
        code=SOURCE["belt_rolling_spectra"],
    threads: 1
    script:
        "../scripts/belt_rolling_spectra.py"


rule belt_rolling:
    input:
        f"{R}/belt/rolling_spectra.nc",
        f"{R}/figures/belt_rolling_spectra.png",
