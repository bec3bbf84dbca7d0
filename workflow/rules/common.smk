# Config validation (before any rule), wildcard constraints and small target helpers.
from snakemake.utils import min_version, validate

min_version("8.10")


validate(config, "../schemas/config.schema.yaml")

from tyreroad.config import check_references

check_references(config)


wildcard_constraints:
    surface=r"[A-Za-z0-9.\-]+",
    material=r"[A-Za-z0-9.\-]+",
    mode=r"dynamic|quasistatic",
    accel=r"[0-9][0-9.e+\-]*",


# Cheap aggregation and plotting jobs run on the submitting host, never as cluster jobs.
localrules:
    all,
    springs_figure,
    greens_figures,
    study,
    study_figures,
    report,


STUDY = config["study"]
STUDY_SURFACE = STUDY["surface"]


def fmt_accel(accel):
    """Acceleration as it appears in file names: '{:g}' of the value in m/s^2."""
    return f"{float(accel):g}"


def contact_runs(material):
    """Contact result files of one material: one quasi-static run (acceleration-free) and one per acceleration."""
    runs = [f"results/contact/{STUDY_SURFACE}/{material}/quasistatic_0.nc"]
    runs += [
        f"results/contact/{STUDY_SURFACE}/{material}/dynamic_{fmt_accel(a)}.nc"
        for a in STUDY["accelerations"]
    ]
    return runs


def all_contact_runs():
    return [run for material in STUDY["materials"] for run in contact_runs(material)]


def study_greens():
    return [f"results/greens/{material}.nc" for material in STUDY["materials"]]


def stiffness_spectra():
    """K*(f; d0) files of the study materials on the study surface (rule stiffness_spectrum)."""
    return [f"results/stiffness_spectrum/{STUDY_SURFACE}/{m}.nc" for m in STUDY["materials"]]


def max_patch_elements():
    """Largest patch (elements in x and y) over the configured surfaces: the Green's tables cover it."""
    sizes = [tuple(s["patch_elements"]) for s in config["surfaces"].values()]
    return [max(s[0] for s in sizes), max(s[1] for s in sizes)]


def study_element_size():
    return config["surfaces"][STUDY_SURFACE]["element_size"]


def all_targets():
    return [
        f"results/surface/{STUDY_SURFACE}.nc",
        f"results/figures/fig4_surface_{STUDY_SURFACE}.png",
        f"results/figures/springs_{STUDY_SURFACE}.png",
        "results/figures/fig2_material.png",
        "results/figures/fig3_frf.png",
        *all_contact_runs(),
        "results/study.nc",
        "results/report.md",
        *[f"results/figures/{name}.png" for name in STUDY_FIGURES],
        *stiffness_spectra(),
        "results/figures/fig9_stiffness_spectrum.png",
    ]


STUDY_FIGURES = ["fig5_force", "fig6_stiffness", "fig7_loss", "fig8_density"]


# Material helpers come from the package so that the rules and the code resolve presets identically.
from tyreroad.pipeline import material_variants as _material_variants
from tyreroad.pipeline import resolved_material_config as _resolved_material_config
from tyreroad.pipeline import spring_material_inputs


def resolved_material(material):
    """The material preset with its `base:` resolved: a change in the base re-runs every variant."""
    return _resolved_material_config(material, config["materials"])


def material_variants():
    """Which study materials are the loss-factor and density variants of the reference material."""
    return _material_variants(STUDY["reference_material"], STUDY["materials"], config["materials"])
