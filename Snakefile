# tyreroad — tyre tread / rough road contact study (Winroth, Andersson & Kropp, JSV 2014).
# Table of contents only: the logic lives in the tyreroad package, the rules in workflow/rules/.

configfile: "config/config.yaml"

report: "workflow/report/workflow.rst"  # `snakemake --report results/report.html`: every figure captioned


include: "workflow/rules/common.smk"
include: "workflow/rules/surface.smk"
include: "workflow/rules/springs.smk"
include: "workflow/rules/greens.smk"
include: "workflow/rules/contact.smk"
include: "workflow/rules/constructions.smk"
include: "workflow/rules/belt.smk"
include: "workflow/rules/claim6.smk"
include: "workflow/rules/study.smk"
include: "workflow/rules/loading.smk"
include: "workflow/rules/sensitivity.smk"
include: "workflow/rules/stiffness.smk"
include: "workflow/rules/rolling.smk"
include: "workflow/rules/belt_rolling.smk"
include: "workflow/rules/pattern.smk"


rule all:
    default_target: True
    input:
        all_targets(),
