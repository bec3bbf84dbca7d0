"""The reports assembled: ``results/report.md`` and ``results/rolling.md``.

The one place that decides what a report holds and in which order (:data:`REPORT_SECTIONS`,
:data:`ROLLING_REPORT_SECTIONS`); each section is a function of one
:class:`~tyreroad.report.sections.ReportContext` and is empty when the context lacks its data.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import xarray as xr

from .. import io
from ..study import StudySettings
from .claims import THRESHOLDS, ClaimContext, evaluate_context
from .sections import (
    ReportContext,
    cases_section,
    claims_section,
    construction_section,
    belt_section,
    config_section,
    claim6_section,
    decides_section,
    equivalent_section,
    figures_section,
    greens_by_material,
    header_section,
    hysteresis_section,
    material_section,
    rolling_header_section,
    rolling_section,
    rolling_spring_comparison_section,
    stability_section,
    stiffness_spectrum_section,
    surface_section,
)

logger = logging.getLogger(__name__)

__all__ = ["REPORT_SECTIONS", "ROLLING_REPORT_SECTIONS", "build_report", "build_rolling_report", "write_report"]

Section = Callable[[ReportContext], list[str]]

#: The sections of ``results/report.md``, in order.
REPORT_SECTIONS: tuple[Section, ...] = (
    header_section,
    claims_section,
    decides_section,
    claim6_section,
    equivalent_section,
    cases_section,
    stability_section,
    construction_section,
    belt_section,
    stiffness_spectrum_section,
    surface_section,
    material_section,
    hysteresis_section,
    figures_section,
    config_section,
)

#: The sections of ``results/rolling.md``, in order.
ROLLING_REPORT_SECTIONS: tuple[Section, ...] = (rolling_header_section, rolling_section,
                                                rolling_spring_comparison_section, figures_section, config_section)


def _assemble(sections: Sequence[Section], ctx: ReportContext) -> str:
    lines: list[str] = []
    for section in sections:
        lines += section(ctx)
    return "\n".join(lines)


def build_report(
    study: xr.Dataset,
    surface: xr.Dataset | None,
    greens: Mapping[str, xr.Dataset] | Sequence[xr.Dataset] | None,
    settings: StudySettings,
    variants: Mapping[str, Any],
    config: Mapping[str, Any] | None = None,
    spectra: Sequence[xr.Dataset] | None = None,
    loading: xr.Dataset | None = None,
    thresholds: Mapping[str, float] | None = None,
    constructions: Mapping[str, tuple] | None = None,
    claim6: xr.Dataset | None = None,
    figures: Sequence[str] = (),
    belt: tuple | None = None,
) -> str:
    """The markdown text of ``results/report.md``.

    Parameters
    ----------
    study : xarray.Dataset
        The study dataset.
    surface : xarray.Dataset or None
        The study's surface dataset (texture statistics section); None omits the section.
    greens : mapping or sequence of xarray.Dataset, or None
        Green's datasets per material (material summary); a sequence is keyed by each dataset's
        ``material`` attribute.
    settings : StudySettings
        The study settings.
    variants : mapping
        Loss and density variant groups (:func:`tyreroad.study.variant_members`).
    config : mapping, optional
        The config that made the report (its hash is printed); default: the study settings and
        the variants.
    spectra : sequence of xarray.Dataset, optional
        Stiffness-spectrum datasets of the study materials (:mod:`tyreroad.stiffness`): the section
        on K*(f; d0); None omits it.
    loading : xarray.Dataset, optional
        ``results/loading.nc`` (:func:`tyreroad.hysteresis.aggregate_loading`): the section on the
        load-unload cycles; None omits it.
    thresholds : mapping, optional
        Overrides of :data:`tyreroad.report.claims.THRESHOLDS`, used by the claims and the prose.
    constructions : mapping, optional
        {construction: (study dataset, greens datasets)} of the same study run with other kernel
        constructions (``study.compare_constructions``): the section that sets them beside this one.
    claim6 : xarray.Dataset, optional
        ``results/claim6.nc`` (:mod:`tyreroad.claim6`): the claim-6 table by loss-variant definition;
        None omits it.
    figures : sequence of str, optional
        Figure files as paths relative to the report's folder (``figures/fig5_force.png``): the
        section that shows each with its caption; empty omits it.
    belt : tuple, optional
        (study dataset, greens datasets, K* datasets) of the study repeated with the flexible belt
        (``belt.study``, results/belt/): the section that sets it beside this one; None omits it.

    Returns
    -------
    str
        Markdown.
    """
    claims = ClaimContext(study, settings, variants, thresholds)
    results = evaluate_context(claims)
    if config is None:
        config = {
            "study": {
                "surface": settings.surface,
                "reference_material": settings.reference_material,
                "materials": list(settings.materials),
                "accelerations": list(settings.accelerations),
                "indentation_step": settings.indentation_step,
                "saturation_range": list(settings.saturation_range),
            },
            "d_max": settings.d_max,
            "variants": {k: [list(m) for m in v] for k, v in variants.items()},
        }
    ctx = ReportContext(
        thresholds=claims.t,
        claims=claims,
        results={c.number: c for c in results},
        config=config,
        config_text=io.config_yaml(config),
        surface=surface,
        greens=greens_by_material(greens),
        spectra=list(spectra or ()),
        loading=loading,
        constructions={name: (study_ds, greens_by_material(g), evaluate_context(
            ClaimContext(study_ds, settings, variants, thresholds)))
            for name, (study_ds, g) in (constructions or {}).items()},
        claim6=claim6,
        figures=tuple(figures),
        belt=None if belt is None else (belt[0], greens_by_material(belt[1]), evaluate_context(
            ClaimContext(belt[0], settings, variants, thresholds)), list(belt[2])),
    )
    return _assemble(REPORT_SECTIONS, ctx)


def build_rolling_report(rolling: xr.Dataset, thresholds: Mapping[str, float] | None = None,
                         figures: Sequence[str] = (), reference: xr.Dataset | None = None,
                         reference_label: str = "") -> str:
    """The markdown text of ``results/rolling.md`` from ``results/rolling.nc``.

    Parameters
    ----------
    rolling : xarray.Dataset
        The rolling study (:func:`tyreroad.rolling.aggregate_rolling`) as written, with its
        provenance (the ``config`` attribute is printed as the config section).
    thresholds : mapping, optional
        Overrides of :data:`tyreroad.report.claims.THRESHOLDS`.
    figures : sequence of str, optional
        Figures 11-14 as paths relative to the report's folder: shown with their captions.
    reference, reference_label : xarray.Dataset or None, str
        The elastic-springs rolling study this one is compared with and its results folder
        (``spring_comparison.elastic_results``); a label with ``reference`` None: the section says it is missing.
    """
    ctx = ReportContext(thresholds={**THRESHOLDS, **dict(thresholds or {})},
                        config_text=str(rolling.attrs.get("config", "")), rolling=rolling, figures=tuple(figures),
                        rolling_reference=reference, rolling_reference_label=reference_label)
    return _assemble(ROLLING_REPORT_SECTIONS, ctx)


def write_report(text: str, path: str | Path) -> Path:
    """Write the report atomically (no partial file on failure)."""
    with io.atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    logger.info("wrote %s", path)
    return Path(path)
