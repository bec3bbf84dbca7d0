# Dynamic contact stiffness K*(f; d0) (SPEC 11, tyreroad.stiffness): per study material the complex
# contact spring about the relaxed preload state, all materials in one file (stiffness_spectrum.nc,
# a material dimension), figure 9, and (rule report) a report section.
# The section and its frequencies against the kernel's sample rate are checked at planning time by
# tyreroad.config.check_config (common.smk).
STIFFNESS_SPECTRUM = config.get("stiffness_spectrum", {})


rule stiffness_spectrum:
    input:
        surface=f"{R}/surface/{{surface}}.nc",
        springs=f"{R}/springs/{{surface}}/{{material}}.nc",
        greens=f"{R}/greens/{{material}}.nc",
    output:
        nc=f"{R}/stiffness_spectrum/{{surface}}/{{material}}.nc",
    log:
        f"{R}/logs/stiffness_spectrum/{{surface}}/{{material}}.log",
    benchmark:
        f"{R}/benchmarks/stiffness_spectrum/{{surface}}/{{material}}.tsv"
    params:
        material=resolved_material,
        solver=config["solver"],
        spectrum=STIFFNESS_SPECTRUM,
        code=SOURCE["stiffness_spectrum"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster): a contact-sized job
        mem_mb=lambda w, attempt: cluster_resources("stiffness_spectrum", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("stiffness_spectrum", config, w, attempt)["runtime"],
    script:
        "../scripts/stiffness_spectrum.py"


rule stiffness_figure:
    input:
        spectra=stiffness_spectra(),
    output:
        png=report(f"{R}/figures/fig9_stiffness_spectrum.png", caption="../report/fig9_stiffness_spectrum.rst",
                   category="Stiffness spectrum"),
    log:
        f"{R}/logs/stiffness_figure.log",
    params:
        reference=STUDY["reference_material"],
        variants=lambda w: material_variants(),
        spectrum=STIFFNESS_SPECTRUM,
        code=SOURCE["stiffness_figure"],
    threads: 1
    script:
        "../scripts/stiffness_figure.py"


rule stiffness_combined:
    input:
        spectra=stiffness_spectra(),
    output:
        nc=f"{R}/stiffness_spectrum.nc",
    log:
        f"{R}/logs/stiffness_combined.log",
    params:
        compounds=STUDY_COMPOUNDS,
        code=SOURCE["stiffness_combined"],
    threads: 1
    script:
        "../scripts/stiffness_combined.py"
