"""The figures' captions: one line each, for ``results/report.md`` and Snakemake's HTML report.

:data:`FIGURE_CAPTIONS` is the one place a figure's caption is written. The report section
(:func:`figures_section`) embeds each figure the report was given with its caption; the workflow
marks each figure output with ``report(..., caption="../report/<stem>.rst")`` and those .rst
files hold the same line (``tests/test_figure_captions.py`` checks that every figure output of the
rules is so marked and that its caption file says what :data:`FIGURE_CAPTIONS` says).
"""

from __future__ import annotations

import fnmatch
from pathlib import Path, PurePosixPath
from typing import Sequence

__all__ = ["FIGURE_CAPTIONS", "figure_caption", "figures_section_lines"]

#: {file stem pattern: caption}, in the order the report shows them (``*`` stands for the surface).
FIGURE_CAPTIONS: dict[str, str] = {
    "fig2_material": "Fig. 2 — Tread materials: storage modulus E′, loss modulus E″ and loss factor η against "
                     "frequency, a colour and line style per material (identical curves drawn once).",
    "fig3_frf": "Fig. 3 — Magnitude of the layer's receptance g(f) at the excitation element per material, with "
                "each material's quasi-static g (dotted).",
    "fig4_surface_*": "Fig. 4 — Road patch heights with the element grid; the colour scale spans the top 0.3 mm, "
                      "and filled matching points and the white contour lie within 0.15 mm of the highest peak.",
    "springs_*": "Element contact springs k_e(ζ) of three elements up to where they turn flat (the flat-punch "
                 "stiffness of the whole element top), and the patch sum at a common compression.",
    "fig5_force": "Fig. 5 — Total contact force F(d) of the reference material, quasi-static and at each loading "
                  "acceleration.",
    "fig6_stiffness": "Fig. 6 — Contact stiffness K(d) = dF/dd of the reference material (K_sat range shaded) and "
                      "the share of elements in contact.",
    "fig7_loss": "Fig. 7 — Contact stiffness K(d) of the causal loss-factor variants at the highest acceleration, "
                 "and their difference to the reference.",
    "fig8_density": "Fig. 8 — Contact stiffness K(d) of the density variants at the highest acceleration, and "
                    "their difference to the reference.",
    "fig9_stiffness_spectrum": "Fig. 9 — Dynamic contact stiffness K′ and K″ against frequency at the study's "
                               "preloads; above the shaded limit the time-domain kernel is not checked.",
    "fig10_hysteresis": "Fig. 10 — Load–unload cycles F(d) per material with the work W each loop dissipates "
                        "(quasi-static loops close: W = 0).",
    "fig11_rolling_force": "Fig. 11 — Total force against the contact centre x_c of the rolling passes, "
                           "quasi-static and at each speed, per material.",
    "fig12_rolling_spectra": "Fig. 12 — 1/3-octave spectra of the rolling force fluctuation over the steady part "
                             "of each pass.",
    "fig13_rolling_loss": "Fig. 13 — Rolling-loss coefficient (dissipated work per distance over the steady mean "
                          "force) against speed, per material.",
    "fig14_contact_map": "Fig. 14 — Element forces at one instant of a quasi-static and a dynamic rolling pass, "
                         "with x_c and the geometric contact half-length marked.",
    "belt_mobility": "Point and transfer mobility of the tread surface on the flexible belt, beside the tread on a "
                     "rigid belt, the bare belt and the infinite plate, with the published statements on measured "
                     "car-tyre mobilities as frequency bands.",
    "belt_rolling_spectra": "Rolling on the flexible belt beside the rigid belt: 1/3-octave levels of the total "
                            "contact force, and of the belt's normal velocity just ahead of and behind the contact.",
    "sensitivity": "Sensitivity sweep: what decides claims 5–7 at each sweep point (loss factor, K_sat change of "
                   "the loss variants, density ripple, K change over the saturation range).",
    # the pattern study's figures (results/figures/pattern/, rule pattern_figures, linked from pattern.md)
    "compliance_map": "Patterned tread — static self-compliance g_ii of every block element normalised by the block "
                      "centre's (a map per pattern, g_centre in its title) and the cut through the block's middle "
                      "row: the edge softening of the blocks' free sides.",
    "stiffness_spectrum": "Patterned tread — contact storage stiffness K′ and loss factor η = K″/K′ against frequency "
                          "on each pattern beside the slick tread of the same patch (dashed), with the blocks' "
                          "lowest natural frequencies (dotted).",
}


def figure_caption(path: str | Path) -> str:
    """The caption of a figure file, from its stem (``results/figures/fig4_surface_iso10844.png``).

    Raises
    ------
    KeyError
        For a figure without a caption in :data:`FIGURE_CAPTIONS`.
    """
    stem = PurePosixPath(str(path).replace("\\", "/")).stem
    for pattern, caption in FIGURE_CAPTIONS.items():
        if fnmatch.fnmatchcase(stem, pattern):
            return caption
    raise KeyError(f"figure {stem!r} has no caption in tyreroad.report.figures.FIGURE_CAPTIONS")


def _order(path: str) -> int:
    stem = PurePosixPath(path).stem
    for i, pattern in enumerate(FIGURE_CAPTIONS):
        if fnmatch.fnmatchcase(stem, pattern):
            return i
    return len(FIGURE_CAPTIONS)


def figures_section_lines(figures: Sequence[str]) -> list[str]:
    """A markdown "Figures" section: each figure embedded (link relative to the report) and captioned.

    Parameters
    ----------
    figures : sequence of str
        Paths of the figures relative to the report's folder (``figures/fig2_material.png``),
        in any order; shown in the order of :data:`FIGURE_CAPTIONS`.
    """
    if not figures:
        return []
    lines = ["## Figures", ""]
    for rel in sorted((str(f).replace("\\", "/") for f in figures), key=_order):
        caption = figure_caption(rel)
        lines += [f"![{PurePosixPath(rel).stem}]({rel})", "", f"*{caption}* (`{rel}`)", ""]
    return lines
