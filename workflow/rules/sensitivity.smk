# Sensitivity sweep: what decides claims 5-7 (tyreroad.sensitivity). A named target, not part of
# the default one:  snakemake -j2 sensitivity  ->  {results_dir}/sensitivity.nc, sensitivity.md,
# figures/sensitivity.png.  One job per sweep point (config: sensitivity.points).
from tyreroad.sensitivity import point_files as _point_files

# planning-time checks (tyreroad.config.sensitivity_points): the section, every point's material and surface preset
with naming_config_files(CONFIG_FILES):
    SENSITIVITY_POINTS = sensitivity_points(config, SCHEMA)
# the section without its points: changing one point re-runs that point only
SENSITIVITY_GLOBALS = {k: v for k, v in config.get("sensitivity", {}).items() if k != "points"}


rule sensitivity_point:
    output:
        nc=f"{R}/sensitivity/{{point}}.nc",
    log:
        f"{R}/logs/sensitivity/{{point}}.log",
    benchmark:
        f"{R}/benchmarks/sensitivity/{{point}}.tsv"
    wildcard_constraints:
        point=r"[A-Za-z0-9.\-]+",
    params:
        point=lambda w: SENSITIVITY_POINTS[w.point],
        sensitivity=SENSITIVITY_GLOBALS,
        reference_material=_resolved_material_config(STUDY["reference_material"], config["materials"]),
        surface=config["surfaces"][STUDY_SURFACE],
        springs=config["springs"],
        greens=config["greens"],
        solver=config["solver"],
        study=STUDY,
        code=SOURCE["sensitivity"],
    threads: 1
    resources:  # cluster requests (tyreroad.cluster), from the study patch
        mem_mb=lambda w, attempt: cluster_resources("sensitivity_point", config, w, attempt)["mem_mb"],
        runtime=lambda w, attempt: cluster_resources("sensitivity_point", config, w, attempt)["runtime"],
    script:
        "../scripts/sensitivity_point.py"


rule sensitivity:
    input:
        points=lambda w: _point_files(SENSITIVITY_POINTS, R),
    output:
        nc=f"{R}/sensitivity.nc",
        png=report(f"{R}/figures/sensitivity.png", caption="../report/sensitivity.rst", category="Sensitivity"),
        md=f"{R}/sensitivity.md",
    log:
        f"{R}/logs/sensitivity.log",
    params:
        sensitivity=SENSITIVITY_GLOBALS,
        code=SOURCE["sensitivity"],
    threads: 1
    script:
        "../scripts/sensitivity.py"
