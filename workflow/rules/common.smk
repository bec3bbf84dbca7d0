# Config checks (before any rule), wildcard constraints and small target helpers.
# Every check that needs no computed result runs here, at planning time (snakemake -n included):
# tyreroad.config names the key path, the value and what is expected. See docs/pipeline.md "Configuration".
from pathlib import Path

from snakemake.utils import min_version, validate

min_version("8.10")

from tyreroad.cluster import job_resources as cluster_resources
from tyreroad.config import (
    ConfigError,
    check_config,
    check_config_files,
    check_job,
    check_rolling_kernel,
    config_file_order,
    expand_material_temperatures,
    naming_config_files,
    rolling_materials,
    sensitivity_points,
    validate_schema,
)
from tyreroad.pipeline import material_compounds as _material_compounds
from tyreroad.pipeline import material_variants as _material_variants
from tyreroad.pipeline import resolved_material_config as _resolved_material_config
from tyreroad.pipeline import spring_material_inputs as _spring_material_inputs
from tyreroad.pattern import check_pattern_springs as _check_pattern_springs
from tyreroad.provenance import STAGE_MODULES, source_hash

SCHEMA = Path(workflow.current_basedir) / "../schemas/config.schema.yaml"
# the config files in the order their keys apply: an error about a key names the file that set it
CONFIG_FILES = config_file_order(workflow.configfiles, workflow.overwrite_configfiles)
check_config_files(workflow.configfiles)  # duplicate keys are errors (YAML keeps the last silently)
with naming_config_files(CONFIG_FILES):
    validate_schema(config, SCHEMA)
    # a table preset's `temperatures: [T, ...]` become the base: variants <name>-T<T> (tyreroad.config)
    config["materials"] = expand_material_temperatures(config)["materials"]
    validate(config, "../schemas/config.schema.yaml")  # inserts the schema's defaults
    check_config(config)


wildcard_constraints:
    surface=r"[A-Za-z0-9][A-Za-z0-9.\-]*",
    material=r"[A-Za-z0-9][A-Za-z0-9.\-]*",
    mode=r"dynamic|quasistatic",
    accel=r"[0-9][0-9.e+\-]*",
    loading=r"[A-Za-z0-9][A-Za-z0-9.\-]*",
    speed=r"[0-9][0-9.e+\-]*",
    pattern=r"[A-Za-z0-9][A-Za-z0-9.\-]*",


# Cheap aggregation and plotting jobs run on the submitting host, never as cluster jobs. The one
# list of local rules: all but tyreroad.cluster.CLUSTER_RULES (which carry resources) and the
# sweep points (sensitivity_point), which run a whole small study each.
localrules:
    all,
    springs_figure,
    greens_figures,
    study,
    study_figures,
    construction_study,
    belt_study,
    belt_mobility,
    belt_rolling_spectra,
    belt_rolling,
    pattern_study,
    pattern_report,
    pattern_figures,
    pattern,
    claim6,
    report,
    loading_study,
    hysteresis_figure,
    stiffness_figure,
    stiffness_combined,
    sensitivity,
    rolling,
    rolling_study,
    rolling_figures,
    rolling_report,


# Every result, log and benchmark of this study lives under R (config key results_dir).
R = config["results_dir"]
STUDY = config["study"]
STUDY_SURFACE = STUDY["surface"]
# compound and temperature [degC] of each study material: coordinates of study.nc and stiffness_spectrum.nc
STUDY_COMPOUNDS = _material_compounds(STUDY["materials"], config["materials"])

# Hash of the tyreroad source each stage runs (tyreroad.provenance.STAGE_MODULES): a rule's params
# carry it, so a change in the package re-plans exactly the stages whose code changed.
SOURCE = {stage: source_hash(stage) for stage in STAGE_MODULES}


# The job output named in messages, by the set of wildcards of the rule.
_TARGET_OF = {
    ("surface",): f"{R}/surface/{{surface}}.nc",
    ("material",): f"{R}/greens/{{material}}.nc",
    ("material", "surface"): f"{R}/springs/{{surface}}/{{material}}.nc",
    ("accel", "material", "mode", "surface"): f"{R}/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.nc",
    ("loading", "material", "mode", "surface"): f"{R}/loading/{{surface}}/{{material}}/{{mode}}_{{loading}}.nc",
    ("material", "mode", "speed", "surface"): f"{R}/rolling/{{surface}}/{{material}}/{{mode}}_v{{speed}}.nc",
    ("construction", "material"): f"{R}/constructions/{{construction}}/greens/{{material}}.nc",
    ("material", "pattern"): f"{R}/greens/pattern/{{pattern}}/{{material}}.nc",
    ("material", "pattern", "surface"): f"{R}/pattern/contact/{{surface}}/{{material}}/{{pattern}}/quasistatic_0.nc",
    ("pattern",): f"{R}/greens/pattern-modes/{{pattern}}.nc",
    ("accel", "material", "mode", "pattern", "surface"):
        f"{R}/pattern/modal/{{surface}}/{{material}}/{{pattern}}/{{mode}}_{{accel}}.nc",
    ("accel", "construction", "material", "mode", "surface"):
        f"{R}/constructions/{{construction}}/contact/{{surface}}/{{material}}/{{mode}}_{{accel}}.nc",
}


def checked(wildcards):
    """Check the presets named by a job's wildcards (e.g. a requested target); see tyreroad.config.check_job.

    Called from the params functions. They take the wildcards only: Snakemake does not record
    (nor compare) params of functions that take input or output.
    """
    w = dict(wildcards)
    with naming_config_files(CONFIG_FILES):
        check_job(config, _TARGET_OF[tuple(sorted(w))].format(**w), w)


def fmt_accel(accel):
    """Acceleration as it appears in file names: '{:g}' of the value in m/s^2."""
    return f"{float(accel):g}"


def contact_runs(material):
    """Contact result files of one material: one quasi-static run (acceleration-free) and one per acceleration."""
    runs = [f"{R}/contact/{STUDY_SURFACE}/{material}/quasistatic_0.nc"]
    runs += [
        f"{R}/contact/{STUDY_SURFACE}/{material}/dynamic_{fmt_accel(a)}.nc"
        for a in STUDY["accelerations"]
    ]
    return runs


def all_contact_runs():
    return [run for material in STUDY["materials"] for run in contact_runs(material)]


def all_loading_runs():
    """Loading-preset runs of the study: every preset named in study.loadings, for its materials, both modes."""
    return [
        f"{R}/loading/{STUDY_SURFACE}/{material}/{mode}_{loading}.nc"
        for loading, materials in STUDY.get("loadings", {}).items()
        for material in materials
        for mode in ("quasistatic", "dynamic")
    ]


def loading_outputs():
    """The loading study and its figure, when the study runs any loading presets."""
    if not all_loading_runs():
        return []
    return [f"{R}/loading.nc", f"{R}/figures/fig10_hysteresis.png"]


def study_greens():
    return [f"{R}/greens/{material}.nc" for material in STUDY["materials"]]


def stiffness_spectra():
    """K*(f; d0) files of the study materials on the study surface (rule stiffness_spectrum)."""
    return [f"{R}/stiffness_spectrum/{STUDY_SURFACE}/{m}.nc" for m in STUDY["materials"]]


# The rolling section with the schema's defaults (speeds, quasistatic_speeds, surfaces), inserted by
# validate() above; the pass settings' defaults are tyreroad.rolling.RollingSettings', and the
# materials' tyreroad.config.rolling_materials'.
ROLLING = config.get("rolling", {})
ROLLING_SURFACES = ROLLING.get("surfaces", [])
ROLLING_MATERIALS, ROLLING_REFERENCE = rolling_materials(config) if ROLLING_SURFACES else ([], None)


def max_patch_elements(rolling=False):
    """Largest patch (elements in x and y) over the configured surfaces: the Green's tables cover it.

    The rolling strips (rolling.surfaces) have their own Green's functions (rolling=True), so that
    a 150 x 20 strip does not change the study's greens files."""
    sizes = [tuple(s["patch_elements"]) for name, s in config["surfaces"].items()
             if (name in ROLLING_SURFACES) == rolling and name not in PATTERN_OWN_SURFACES]
    return [max(s[0] for s in sizes), max(s[1] for s in sizes)]


def rolling_greens_elements(wildcards):
    """The rolling greens' table size (the largest strip), after checking that the kernel can take it: called
    while the rolling jobs are planned, so a strip too large for the Radau kernel stops `snakemake -n rolling`."""
    checked(wildcards)
    with naming_config_files(CONFIG_FILES):
        check_rolling_kernel(config)
    return max_patch_elements(rolling=True)


def study_element_size():
    return config["surfaces"][STUDY_SURFACE]["element_size"]


def surface_spec(wildcards):
    checked(wildcards)
    return config["surfaces"][wildcards.surface]


def scan_files(wildcards):
    """The scan file of a 'file' surface preset: an input, so a changed scan re-plans its surface."""
    spec = config["surfaces"].get(wildcards.surface, {})
    return [spec["path"]] if spec.get("generator") == "file" else []


def all_targets():
    return [
        f"{R}/surface/{STUDY_SURFACE}.nc",
        f"{R}/figures/fig4_surface_{STUDY_SURFACE}.png",
        f"{R}/figures/springs_{STUDY_SURFACE}.png",
        f"{R}/figures/fig2_material.png",
        f"{R}/figures/fig3_frf.png",
        *all_contact_runs(),
        f"{R}/study.nc",
        f"{R}/report.md",
        *[f"{R}/figures/{name}.png" for name in STUDY_FIGURES],
        *stiffness_spectra(),
        f"{R}/stiffness_spectrum.nc",
        f"{R}/figures/fig9_stiffness_spectrum.png",
        *loading_outputs(),
        *construction_outputs(),
        *claim6_outputs(),
        *belt_outputs(),
        *(pattern_targets() if PATTERN_STUDY else []),
    ]


STUDY_FIGURES = ["fig5_force", "fig6_stiffness", "fig7_loss", "fig8_density"]


def report_figures():
    """The default study's figures, which report.md shows with their captions."""
    return [p for p in all_targets() if p.endswith(".png")]


def fmt_speed(speed):
    """Speed as it appears in file names: '{:g}' of the value in m/s."""
    return f"{float(speed):g}"


def rolling_runs():
    """Rolling passes of the named target `rolling`: every strip and material, dynamic at each speed,
    quasi-static at each of rolling.quasistatic_speeds."""
    runs = []
    for surface in ROLLING_SURFACES:
        for material in ROLLING_MATERIALS:
            runs += [f"{R}/rolling/{surface}/{material}/quasistatic_v{fmt_speed(v)}.nc"
                     for v in ROLLING["quasistatic_speeds"]]
            runs += [f"{R}/rolling/{surface}/{material}/dynamic_v{fmt_speed(v)}.nc" for v in ROLLING["speeds"]]
    return runs


def rolling_map_runs():
    """The two passes of the contact map (figure 14): the reference material, quasi-static and dynamic
    at the middle speed, on the first strip."""
    material, surface = ROLLING_REFERENCE, ROLLING_SURFACES[0]
    speeds = sorted(ROLLING["speeds"])
    return [f"{R}/rolling/{surface}/{material}/quasistatic_v{fmt_speed(ROLLING['quasistatic_speeds'][0])}.nc",
            f"{R}/rolling/{surface}/{material}/dynamic_v{fmt_speed(speeds[len(speeds) // 2])}.nc"]


ROLLING_FIGURES = ["fig11_rolling_force", "fig12_rolling_spectra", "fig13_rolling_loss", "fig14_contact_map"]


def rolling_targets():
    return [*rolling_runs(), f"{R}/rolling.nc", f"{R}/rolling.md",
            *[f"{R}/figures/{name}.png" for name in ROLLING_FIGURES]]


# Material helpers come from the package (imported above) so that the rules and the code resolve
# presets identically.
def resolved_material(wildcards):
    """The material preset with its `base:` resolved: a change in the base re-runs every variant."""
    checked(wildcards)
    return _resolved_material_config(wildcards.material, config["materials"])


def spring_material_inputs(wildcards):
    """Only what the springs depend on, so that a density change does not re-run them."""
    checked(wildcards)
    return _spring_material_inputs(wildcards.material, config["materials"], config["springs"])


def loading_spec(wildcards):
    """The loading preset of a loading run (checked with the run's other presets)."""
    checked(wildcards)
    return config["loadings"][wildcards.loading]


def material_variants():
    """Which study materials are the loss-factor and density variants of the reference material."""
    return _material_variants(STUDY["reference_material"], STUDY["materials"], config["materials"])


# Claim 6 by loss-variant definition (rule claim6, workflow/rules/claim6.smk; issue 24).
from tyreroad.claim6 import Claim6Settings as _Claim6Settings

CLAIM6 = _Claim6Settings.from_config(STUDY.get("claim6"))


def claim6_outputs():
    """results/claim6.nc when the study has a claim6 section."""
    return [f"{R}/claim6.nc"] if STUDY.get("claim6") is not None else []


def claim6_runs():
    """Dynamic runs at the highest study acceleration: the reference, the study's loss variants, the anchor
    variants and the checks (the first two are also study runs)."""
    ref = STUDY["reference_material"]
    loss = [name for _, name in material_variants()["loss"] if name != ref]
    a = fmt_accel(max(STUDY["accelerations"]))
    return [f"{R}/contact/{STUDY_SURFACE}/{m}/dynamic_{a}.nc" for m in [ref, *loss, *CLAIM6.time_domain]]


# The study repeated with other kernel constructions (study.compare_constructions; rules in constructions.smk).
COMPARE_CONSTRUCTIONS = STUDY.get("compare_constructions", [])


def construction_runs(construction):
    runs = []
    for material in STUDY["materials"]:
        runs.append(f"{R}/contact/{STUDY_SURFACE}/{material}/quasistatic_0.nc")
        runs += [f"{R}/constructions/{construction}/contact/{STUDY_SURFACE}/{material}/dynamic_{fmt_accel(a)}.nc"
                 for a in STUDY["accelerations"]]
    return runs


def construction_outputs():
    """The comparison studies and their greens files (report inputs), one per compared construction."""
    return [f"{R}/constructions/{c}/study.nc" for c in COMPARE_CONSTRUCTIONS]


# The study repeated with a flexible belt behind the tread (config section `belt`; rules in belt.smk).
BELT = config.get("belt", {}) or {}
BELT_STUDY = bool(BELT.get("study", False))


def belt_runs():
    """Every study run (both modes) on the greens files of tread + belt."""
    return [run.replace(f"{R}/contact/", f"{R}/belt/contact/", 1) for run in all_contact_runs()]


def belt_outputs():
    """The belt study, its greens files and the reference material's K* with the belt (report inputs)."""
    if not BELT_STUDY:
        return []
    ref = STUDY["reference_material"]
    spectra = ([f"{R}/belt/stiffness_spectrum/{STUDY_SURFACE}/{ref}.nc"]
               if config.get("stiffness_spectrum") else [])
    return [f"{R}/belt/study.nc", *[f"{R}/belt/greens/{m}.nc" for m in STUDY["materials"]], *spectra,
            f"{R}/belt/mobility.nc", f"{R}/figures/belt_mobility.png"]


# Rolling on the belt (named target belt_rolling; rules in belt_rolling.smk): the reference material's dynamic passes
# on the first rolling strip at belt.rolling_speeds, on the belt and on the rigid belt.
BELT_ROLLING_SPEEDS = BELT.get("rolling_speeds", [20.0])


def belt_rolling_runs():
    if not ROLLING_SURFACES:
        return []
    strip = ROLLING_SURFACES[0]
    return [(f"{R}/belt/rolling/{strip}/{ROLLING_REFERENCE}/dynamic_v{fmt_speed(v)}.nc",
             f"{R}/rolling/{strip}/{ROLLING_REFERENCE}/dynamic_v{fmt_speed(v)}.nc") for v in BELT_ROLLING_SPEEDS]



def construction_greens():
    return [f"{R}/constructions/{c}/greens/{m}.nc" for c in COMPARE_CONSTRUCTIONS for m in STUDY["materials"]]


# Patterned treads (config section `pattern`, issue 27; rules in pattern.smk, named target `pattern`): every
# pattern.materials on every pattern preset and on the slick tread of the pattern surface's patch (quasi-static).
PATTERN = config.get("pattern", {}) or {}
PATTERN_STUDY = bool(PATTERN.get("study", False))
PATTERN_SURFACE = PATTERN.get("surface")
# the pattern's patch has its own static tables (pattern_greens jobs), so it does not size the study's greens files
PATTERN_OWN_SURFACES = {PATTERN_SURFACE} - set(ROLLING_SURFACES) - {STUDY_SURFACE} if PATTERN.get("presets") else set()


def pattern_surface_spec():
    return config["surfaces"][PATTERN_SURFACE]


def pattern_preset(wildcards):
    """The pattern preset of a job (None for the slick tread), after checking its presets (planning time)."""
    checked(wildcards)
    with naming_config_files(CONFIG_FILES):
        try:
            _check_pattern_springs(config)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
    presets = PATTERN.get("presets", {}) or {}
    if wildcards.pattern != "slick" and wildcards.pattern not in presets:
        raise ConfigError(f"pattern {wildcards.pattern!r} is not a preset in pattern.presets; expected one of: "
                          f"{', '.join(['slick', *sorted(presets)])}")
    return presets.get(wildcards.pattern)


def pattern_cases():
    return [(m, p) for m in PATTERN.get("materials", []) for p in ["slick", *(PATTERN.get("presets", {}) or {})]]


def pattern_runs():
    """Every pattern case's run, and per pattern preset the grooves-only run (slick layer, grooved springs off)."""
    runs = [f"{R}/pattern/contact/{PATTERN_SURFACE}/{m}/{p}/quasistatic_0.nc" for m, p in pattern_cases()]
    return runs + [f"{R}/pattern/contact/{PATTERN_SURFACE}/{m}/{p}/grooves-only_0.nc" for m, p in pattern_cases()
                   if p != "slick"]


def pattern_greens_files():
    return [f"{R}/greens/pattern/{p}/{m}.nc" for m, p in pattern_cases()]


def pattern_spectra():
    """K*(f; d0) of every pattern.materials on every pattern.stiffness_spectrum.patterns."""
    names = (PATTERN.get("stiffness_spectrum") or {}).get("patterns", [])
    return [f"{R}/pattern/stiffness_spectrum/{PATTERN_SURFACE}/{m}/{p}.nc" for m in PATTERN.get("materials", [])
            for p in names]


def pattern_dynamic_on():
    return "dynamic" in PATTERN.get("modes", ["quasistatic"]) and bool(PATTERN.get("presets"))


def pattern_modes_material(wildcards=None):
    """The material whose thickness, Poisson's ratio and density the modal forms are computed with (the first
    pattern material; every pattern material shares the first two, checked at planning time)."""
    return PATTERN.get("materials", ["tread"])[0]


def pattern_dynamic_runs():
    """Per pattern material and preset: the dynamic runs at pattern.dynamic.accelerations and the quasi-static run
    on the same modal form's relaxed table."""
    if not pattern_dynamic_on():
        return []
    accels = [float(a) for a in (PATTERN.get("dynamic") or {}).get("accelerations", [50.0, 250.0, 500.0])]
    runs = []
    for m, p in pattern_cases():
        if p == "slick":
            continue
        runs.append(f"{R}/pattern/modal/{PATTERN_SURFACE}/{m}/{p}/quasistatic_0.nc")
        runs += [f"{R}/pattern/modal/{PATTERN_SURFACE}/{m}/{p}/dynamic_{a:g}.nc" for a in accels]
    # the loss and density variants at the highest acceleration (the seed's claims 6 and 7 on the blocks)
    for v in (PATTERN.get("dynamic") or {}).get("variants", []):
        runs += [f"{R}/pattern/modal/{PATTERN_SURFACE}/{v}/{p}/dynamic_{max(accels):g}.nc"
                 for p in (PATTERN.get("presets") or {})]
    return runs


def pattern_modes_files():
    return [f"{R}/greens/pattern-modes/{p}.nc" for p in (PATTERN.get("presets") or {})] if pattern_dynamic_on() else []


def pattern_block_greens():
    """The block tables of every pattern.materials on every preset (the edge-softening figure; not the slick ones)."""
    return [f"{R}/greens/pattern/{p}/{m}.nc" for m, p in pattern_cases() if p != "slick"]


def pattern_figure_files():
    """The pattern study's figures (made by the pattern_figures job): the blocks' edge softening, and K*(f; d0) on
    the patterns beside slick when pattern.stiffness_spectrum.patterns names any."""
    if not pattern_block_greens():  # no preset or no pattern material: no block to draw
        return []
    return [f"{R}/figures/pattern/compliance_map.png"] + ([f"{R}/figures/pattern/stiffness_spectrum.png"]
                                                          if pattern_spectra() else [])


def pattern_targets():
    if not PATTERN.get("presets"):
        return []
    return [f"{R}/pattern/study.nc", f"{R}/pattern.md", *pattern_figure_files()] + (
        [f"{R}/pattern/dynamic.nc"] if pattern_dynamic_on() else [])
