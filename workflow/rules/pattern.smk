# Patterned treads (issue 27; config section `pattern`, named target `pattern`, part of rule all with
# pattern.study: true): the block influence table per pattern and material (results/greens/pattern/, the slick
# tread's static offset table of the same patch beside them), the quasi-static runs of every pattern material on
# every pattern and on the slick tread, K(d) and K_sat per case (results/pattern/study.nc) and pattern.md.

rule pattern_greens:
    output:
        nc=f"{R}/greens/pattern/{{pattern}}/{{material}}.nc",
    log:
        f"{R}/logs/greens/pattern/{{pattern}}/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/greens/pattern/{{pattern}}/{{material}}.tsv"
    params:
        pattern=pattern_preset,
        influence=PATTERN.get("influence", "fe"),
        material=resolved_material,
        element_size=lambda w: pattern_surface_spec().get("element_size", 1.0e-3),
        patch_elements=lambda w: pattern_surface_spec()["patch_elements"] if w.pattern == "slick" else None,
        code=SOURCE["pattern_greens"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("pattern_greens", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("pattern_greens", config, w, attempt)["runtime"],
    script:
        "../scripts/pattern_greens.py"


rule pattern_contact:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/greens/pattern/{{pattern}}/{{material}}.nc",
    output:
        nc=f"{R}/pattern/contact/{{surface}}/{{material}}/{{pattern}}/quasistatic_0.nc",
    log:
        f"{R}/logs/pattern/contact/{{surface}}/{{material}}/{{pattern}}/quasistatic_0.log",
    benchmark:
        f"{R}/benchmarks/pattern/contact/{{surface}}/{{material}}/{{pattern}}/quasistatic_0.tsv"
    params:
        check=pattern_preset,
        origin=lambda w: [0.0, 0.0] if w.pattern == "slick" else PATTERN.get("patch_origin", [0.0, 0.0]),
        solver=config["solver"],
        code=SOURCE["pattern_contact"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("pattern_contact", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("pattern_contact", config, w, attempt)["runtime"],
    script:
        "../scripts/pattern_contact.py"


rule pattern_grooves_only:  # the slick layer with the pattern's grooved springs off: what the grooves alone change
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/greens/pattern/slick/{{material}}.nc",
        grooves=f"{R}/greens/pattern/{{pattern}}/{{material}}.nc",
    output:
        nc=f"{R}/pattern/contact/{{surface}}/{{material}}/{{pattern}}/grooves-only_0.nc",
    log:
        f"{R}/logs/pattern/contact/{{surface}}/{{material}}/{{pattern}}/grooves-only_0.log",
    benchmark:
        f"{R}/benchmarks/pattern/contact/{{surface}}/{{material}}/{{pattern}}/grooves-only_0.tsv"
    params:
        check=pattern_preset,
        origin=PATTERN.get("patch_origin", [0.0, 0.0]),
        solver=config["solver"],
        code=SOURCE["pattern_contact"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("pattern_grooves_only", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("pattern_grooves_only", config, w, attempt)["runtime"],
    script:
        "../scripts/pattern_contact.py"


rule pattern_study:
    input:
        runs=pattern_runs(),
        greens=pattern_greens_files(),
    output:
        nc=f"{R}/pattern/study.nc",
    log:
        f"{R}/logs/pattern/study.log",
    params:
        study=STUDY,
        d_max=config["solver"]["d_max"],
        code=SOURCE["pattern_study"],
    threads: 1
    script:
        "../scripts/pattern_study.py"


rule pattern_stiffness_spectrum:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/greens/pattern/{{pattern}}/{{material}}.nc",
        slick=f"{R}/greens/pattern/slick/{{material}}.nc",
    output:
        nc=f"{R}/pattern/stiffness_spectrum/{{surface}}/{{material}}/{{pattern}}.nc",
    log:
        f"{R}/logs/pattern/stiffness_spectrum/{{surface}}/{{material}}/{{pattern}}.log",
    benchmark:
        f"{R}/benchmarks/pattern/stiffness_spectrum/{{surface}}/{{material}}/{{pattern}}.tsv"
    params:
        check=pattern_preset,
        material=resolved_material,
        origin=PATTERN.get("patch_origin", [0.0, 0.0]),
        solver=config["solver"],
        spectrum=PATTERN.get("stiffness_spectrum", {}),
        code=SOURCE["pattern_stiffness_spectrum"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("pattern_stiffness_spectrum", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("pattern_stiffness_spectrum", config, w, attempt)["runtime"],
    script:
        "../scripts/pattern_stiffness_spectrum.py"


rule pattern_modes:  # the block's modal form for dynamic runs: one eigen-decomposition per pattern
    output:
        nc=f"{R}/greens/pattern-modes/{{pattern}}.nc",
    log:
        f"{R}/logs/greens/pattern-modes/{{pattern}}.log",
    benchmark:
        f"{R}/benchmarks/greens/pattern-modes/{{pattern}}.tsv"
    params:
        pattern=pattern_preset,
        material_name=pattern_modes_material(),
        material=lambda w: _resolved_material_config(pattern_modes_material(), config["materials"]),
        element_size=lambda w: pattern_surface_spec().get("element_size", 1.0e-3),
        dynamic=PATTERN.get("dynamic", {}),
        code=SOURCE["pattern_modes"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("pattern_modes", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("pattern_modes", config, w, attempt)["runtime"],
    script:
        "../scripts/pattern_modes.py"


rule pattern_dynamic:  # a dynamic run on the block's modal form, or (quasistatic_0) the same form's relaxed table
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        modes=f"{R}/greens/pattern-modes/{{pattern}}.nc",
    output:
        nc=f"{R}/pattern/modal/{{surface}}/{{material}}/{{pattern}}/{{mode}}_{{accel}}.nc",
    log:
        f"{R}/logs/pattern/modal/{{surface}}/{{material}}/{{pattern}}/{{mode}}_{{accel}}.log",
    benchmark:
        f"{R}/benchmarks/pattern/modal/{{surface}}/{{material}}/{{pattern}}/{{mode}}_{{accel}}.tsv"
    params:
        check=pattern_preset,
        material=resolved_material,
        origin=PATTERN.get("patch_origin", [0.0, 0.0]),
        solver=config["solver"],
        greens=config["greens"],
        code=SOURCE["pattern_dynamic"],
    threads: 1
    resources:
        mem_mb=lambda w, attempt: cluster_resources("pattern_dynamic", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("pattern_dynamic", config, w, attempt)["runtime"],
    script:
        "../scripts/pattern_dynamic.py"


rule pattern_dynamic_study:
    input:
        runs=pattern_dynamic_runs(),
        modes=pattern_modes_files(),
    output:
        nc=f"{R}/pattern/dynamic.nc",
    log:
        f"{R}/logs/pattern/dynamic_study.log",
    params:
        study=STUDY,
        d_max=config["solver"]["d_max"],
        code=SOURCE["pattern_dynamic_study"],
    threads: 1
    script:
        "../scripts/pattern_dynamic_study.py"


rule pattern_report:
    input:
        study=f"{R}/pattern/study.nc",
        spectra=pattern_spectra(),
        dynamic=[f"{R}/pattern/dynamic.nc"] if pattern_dynamic_on() else [],
        figures=pattern_figure_files(),  # linked from pattern.md (rule pattern_figures)
    output:
        md=f"{R}/pattern.md",
    log:
        f"{R}/logs/pattern/report.log",
    params:
        code=SOURCE["pattern_report"],
    threads: 1
    script:
        "../scripts/pattern_report.py"


rule pattern:
    input:
        pattern_targets(),


rule pattern_figures:  # the blocks' edge softening; K*(f; d0) on the patterns beside slick (with a spectrum)
    input:
        greens=pattern_block_greens(),
        spectra=pattern_spectra(),
    output:
        compliance=report(f"{R}/figures/pattern/compliance_map.png", caption="../report/pattern_compliance_map.rst",
                          category="Patterned treads"),
        **({"spectrum": report(f"{R}/figures/pattern/stiffness_spectrum.png",
                               caption="../report/pattern_stiffness_spectrum.rst", category="Patterned treads")}
           if pattern_spectra() else {}),
    log:
        f"{R}/logs/pattern/figures.log",
    params:
        code=SOURCE["pattern_figures"],
    threads: 1
    script:
        "../scripts/pattern_figures.py"
