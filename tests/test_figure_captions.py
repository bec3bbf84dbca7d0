"""Every figure the workflow makes is captioned, in Snakemake's HTML report and in report.md.

The workflow is parsed with Snakemake's API (no job runs): each rule output ending in .png must be
wrapped in ``report(..., caption=...)``, its caption file must exist and hold the caption that
:data:`tyreroad.report.figures.FIGURE_CAPTIONS` gives the figure, and every caption there must
belong to a figure the rules make.
"""

from __future__ import annotations

import fnmatch
import re
from pathlib import Path, PurePosixPath

import pytest

from tyreroad.report.figures import FIGURE_CAPTIONS, figure_caption, figures_section_lines

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def figure_outputs():
    """{output path pattern: report flag or None} of every .png output of the rules."""
    from snakemake.api import SnakemakeApi
    from snakemake.settings.types import ConfigSettings, OutputSettings, ResourceSettings, StorageSettings

    out = {}
    with SnakemakeApi(OutputSettings(quiet={"all"})) as api:
        wf = api.workflow(resource_settings=ResourceSettings(), config_settings=ConfigSettings(),
                          storage_settings=StorageSettings(), snakefile=ROOT / "Snakefile", workdir=ROOT)
        wf.dag()  # parses the rule files
        for rule in wf._workflow.rules:
            for f in rule.output:
                if str(f).endswith(".png"):
                    out[f"{rule.name}: {f}"] = getattr(f, "flags", {}).get("report")
    return out


def _stem(name: str) -> str:
    """'rule: results/figures/fig4_surface_{surface,[A-Z]*}.png' -> 'fig4_surface_x' (a wildcard as x)."""
    return PurePosixPath(re.sub(r"\{[^{}]*\}", "x", name.split(": ", 1)[1])).stem


def test_every_figure_output_is_in_the_html_report_with_its_caption(figure_outputs):
    assert len(figure_outputs) >= 15  # figs 2-14, the springs and the sensitivity figure
    problems = []
    for name, flag in figure_outputs.items():
        if flag is None or flag.caption is None:
            problems.append(f"{name}: not wrapped in report(..., caption=...)")
            continue
        path = Path(flag.caption.get_path_or_uri(secret_free=True))
        if not path.is_file():
            problems.append(f"{name}: caption file {path} missing")
            continue
        text = path.read_text(encoding="utf-8").strip()
        if text != figure_caption(_stem(name)):
            problems.append(f"{name}: caption file {path.name} differs from FIGURE_CAPTIONS")
    assert problems == []


def test_every_caption_belongs_to_a_figure(figure_outputs):
    stems = [_stem(n) for n in figure_outputs]
    for pattern in FIGURE_CAPTIONS:
        assert any(fnmatch.fnmatchcase(s, pattern) for s in stems), pattern


def test_report_section_embeds_each_figure_relative_to_the_report():
    lines = figures_section_lines(["figures/fig5_force.png", "figures/fig4_surface_iso10844.png",
                                   "figures/fig2_material.png"])
    images = [ln for ln in lines if ln.startswith("![")]
    assert [ln.rsplit("(", 1)[1] for ln in images] == [
        "figures/fig2_material.png)", "figures/fig4_surface_iso10844.png)", "figures/fig5_force.png)"]
    assert f"*{FIGURE_CAPTIONS['fig4_surface_*']}* (`figures/fig4_surface_iso10844.png`)" in lines
    assert figures_section_lines([]) == []
    with pytest.raises(KeyError, match="fig99_new"):
        figure_caption("results/figures/fig99_new.png")
