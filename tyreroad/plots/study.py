"""Figures 5-8 of the study (SPEC section 7) from the study dataset.

* fig5_force: F(d) of the reference material, quasi-static and every acceleration.
* fig6_stiffness: K(d) for the same cases, with the contact fraction in a second panel.
* fig7_loss: K(d) of the loss-factor variants at the reference (highest) acceleration.
* fig8_density: K(d) of the density variants at the reference acceleration.

Which material is which variant is not read from material names: the caller passes the variant
groups ``{"loss": [[scale, name], ...], "density": [[scale, name], ...]}`` that
:func:`tyreroad.pipeline.material_variants` resolves from the material presets (``base:`` with
``loss_scale`` / ``density_scale``); :func:`tyreroad.study.variant_members` validates them.

Plots show d in mm, F in N, K in MN/m.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from . import save_png  # noqa: E402
from ..study import variant_members  # noqa: E402

logger = logging.getLogger(__name__)

__all__ = [
    "FIGURES",
    "plot_force",
    "plot_stiffness",
    "plot_variants",
    "plot_study_figures",
]

FIGURES = ("fig5_force", "fig6_stiffness", "fig7_loss", "fig8_density")

_MM = 1e3
_MN = 1e-6


def _reference(study: xr.Dataset, reference_material: str | None) -> str:
    ref = reference_material or study.attrs.get("reference_material")
    if not ref:
        raise ValueError("reference material not given and not in the study attributes")
    if ref not in set(study["material"].values.astype(str)):
        raise ValueError(f"reference material {ref!r} is not in the study")
    return str(ref)


def _accels(study: xr.Dataset, material: str) -> list[float]:
    sub = study.study.select(material=material, mode="dynamic")
    return sorted(float(a) for a in sub["accel"].values)


def _cases(study: xr.Dataset, material: str) -> list[tuple[str, xr.Dataset]]:
    """(legend label, case) for the quasi-static run and the dynamic runs by acceleration."""
    out = [("quasi-static", study.study.sel_case(material=material, mode="quasistatic"))]
    for a in _accels(study, material):
        out.append((f"dynamic, a = {a:g} m/s²", study.study.sel_case(material=material, mode="dynamic", accel=a)))
    return out


def _colors(n: int) -> list:
    return [plt.get_cmap("viridis")(x) for x in np.linspace(0.0, 0.85, n)]


def study_caption(study: xr.Dataset, source: str | Path | None = None) -> str:
    """One line naming the study a figure comes from: results file, surface and material set.

    Parameters
    ----------
    study : xarray.Dataset
        The study dataset (attributes ``surface`` and ``reference_material``).
    source : path-like, optional
        The study file (``{results_dir}/study.nc``); left out of the line when not given.
    """
    materials = list(dict.fromkeys(study["material"].values.astype(str)))
    ref = study.attrs.get("reference_material", "?")
    where = f"study {Path(source).as_posix()}, " if source is not None else ""
    shown = ", ".join(materials) if len(materials) <= 3 else f"{len(materials)} materials"
    return f"{where}surface {study.attrs.get('surface', '?')}, {shown} (reference {ref})"


def _caption(fig, caption: str | None) -> None:
    if caption:
        fig.suptitle(caption, fontsize=8, color="0.3")


def _save(fig, path) -> Path:
    return save_png(fig, path, logger)


def plot_force(study: xr.Dataset, path: str | Path, reference_material: str | None = None,
               caption: str | None = None) -> Path:
    """Figure 5: total contact force F(d) of the reference material (QS and every acceleration).

    ``caption`` (e.g. :func:`study_caption`) is printed above the title.
    """
    ref = _reference(study, reference_material)
    d = study["indentation"].values * _MM
    fig, ax = plt.subplots(figsize=(6.4, 4.6), layout="constrained")
    cases = _cases(study, ref)
    for (label, c), color in zip(cases, ["k"] + _colors(len(cases) - 1)):
        ax.plot(d, c["force"].values, color=color, ls="--" if label == "quasi-static" else "-", label=label)
    ax.set_xlabel("indentation d [mm]")
    ax.set_ylabel("contact force F [N]")
    ax.set_title(f"Contact force, material {ref}, surface {study.attrs.get('surface', '?')}")
    ax.set_xlim(0, d[-1])
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend()
    _caption(fig, caption)
    return _save(fig, path)


def plot_stiffness(study: xr.Dataset, path: str | Path, reference_material: str | None = None,
                   caption: str | None = None) -> Path:
    """Figure 6: contact stiffness K(d) (top) and fraction of elements in contact (bottom).

    ``caption`` (e.g. :func:`study_caption`) is printed above the title.
    """
    ref = _reference(study, reference_material)
    d = study["indentation"].values * _MM
    fig, (ax, ax2) = plt.subplots(
        2, 1, sharex=True, figsize=(6.4, 6.4), layout="constrained", gridspec_kw={"height_ratios": [2, 1]}
    )
    cases = _cases(study, ref)
    for (label, c), color in zip(cases, ["k"] + _colors(len(cases) - 1)):
        ls = "--" if label == "quasi-static" else "-"
        ax.plot(d, c["stiffness"].values * _MN, color=color, ls=ls, label=label)
        ax2.plot(d, c["contact_fraction"].values * 100, color=color, ls=ls, label=label)
    sat = study.attrs.get("saturation_range_m")
    if sat is not None:
        sat = np.atleast_1d(sat)
        ax.axvspan(sat[0] * _MM, sat[1] * _MM, color="0.9", zorder=0, label="K_sat range")
    ax.set_ylabel("contact stiffness K [MN/m]")
    ax.set_title(f"Contact stiffness, material {ref}, surface {study.attrs.get('surface', '?')}")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    dyn = np.array([c["contact_fraction"].values for label, c in cases if label != "quasi-static"])
    if len(dyn) > 1:
        spread = float(np.nanmax(np.nanmax(dyn, axis=0) - np.nanmin(dyn, axis=0))) * 100
        if spread < 2.0:  # the dynamic curves hide each other: say so
            ax2.text(0.02, 0.9, f"dynamic curves coincide (within {spread:.1f} percentage points)",
                     transform=ax2.transAxes, fontsize=8, va="top")
    ax2.legend(loc="lower right", fontsize=8, ncol=2, framealpha=0.85)
    ax2.set_xlabel("indentation d [mm]")
    ax2.set_ylabel("elements in contact [%]")
    ax2.set_xlim(0, d[-1])
    ax2.set_ylim(0, 100)
    ax2.grid(alpha=0.3)
    _caption(fig, caption)
    return _save(fig, path)


def plot_variants(
    study: xr.Dataset,
    members: Sequence[tuple[float, str]],
    kind: str,
    accel: float,
    path: str | Path,
    caption: str | None = None,
) -> Path:
    """Figures 7/8: K(d) of material variants at one acceleration, and their difference to the reference.

    The variants differ from the reference by a few percent at most, so in the top panel (K) the
    curves lie on top of each other; the bottom panel shows K − K_ref [kN/m], where they separate.

    Parameters
    ----------
    study : xarray.Dataset
        The study dataset.
    members : sequence of (float, str)
        (scale, material) of the variants, e.g. from :func:`tyreroad.study.variant_members`; the
        reference is the member with scale 1.
    kind : {"loss", "density"}
        Which property the scale multiplies (legend and title).
    accel : float
        Acceleration of the dynamic runs shown [m/s^2].
    path : path-like
        Output PNG.
    caption : str, optional
        A line above the title naming the study (e.g. :func:`study_caption`).
    """
    symbol = {"loss": "η", "density": "ρ"}[kind]
    what = {"loss": "loss factor", "density": "density"}[kind]
    d = study["indentation"].values * _MM
    fig, (ax, ax2) = plt.subplots(
        2, 1, sharex=True, figsize=(6.4, 6.4), layout="constrained", gridspec_kw={"height_ratios": [3, 2]}
    )
    styles = ["-", "-.", ":"]
    others = [m for m in members if m[0] != 1.0]
    colors = dict(zip(others, _colors(len(others))))
    ref = [m for s, m in members if s == 1.0]
    k_ref = study.study.sel_case(material=ref[0], mode="dynamic", accel=accel)["stiffness"].values if ref else None
    for i, (scale, material) in enumerate(members):
        c = study.study.sel_case(material=material, mode="dynamic", accel=accel)
        k = c["stiffness"].values
        # the reference (scale 1) is drawn like the quasi-static curve of fig 5-6: black dashed
        color, ls = ("k", "--") if scale == 1.0 else (colors[(scale, material)], styles[i % len(styles)])
        label = f"{symbol} ×{scale:g} ({material}), K_sat {float(c['saturated_stiffness']) * _MN:.3f} MN/m"
        ax.plot(d, k * _MN, color=color, ls=ls, lw=1.6, label=label)
        if k_ref is not None:
            ax2.plot(d, (k - k_ref) * 1e-3, color=color, ls=ls, lw=1.6)
    ax.set_ylabel("contact stiffness K [MN/m]")
    # the loss variants are causal (issue 24): the phase of E scaled, |E| kept at the default anchor
    what = "causal loss variants" if kind == "loss" else f"{what} variants"
    ax.set_title(f"Contact stiffness, {what}, dynamic a = {accel:g} m/s²")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    # the title only where the variants' curves do lie on top of each other (within 2 % of K's top)
    overlap = k_ref is not None and all(
        np.nanmax(np.abs(study.study.sel_case(material=m, mode="dynamic", accel=accel)["stiffness"].values - k_ref))
        < 0.02 * np.nanmax(np.abs(k_ref)) for _, m in members)
    ax.legend(loc="lower right", fontsize=8, title="curves overlap here: see K − K_ref below" if overlap else None,
              title_fontsize=7.5)
    ax2.set_xlabel("indentation d [mm]")
    ax2.set_ylabel("K − K_ref [kN/m]")
    ax2.set_xlim(0, d[-1])
    ax2.grid(alpha=0.3)
    sat = study.attrs.get("saturation_range_m")
    if sat is not None:
        sat = np.atleast_1d(sat)
        for a_ in (ax, ax2):
            a_.axvspan(sat[0] * _MM, sat[1] * _MM, color="0.92", zorder=0)
    _caption(fig, caption)
    return _save(fig, path)


def plot_study_figures(
    study: xr.Dataset,
    variants: Mapping[str, Any],
    outputs: Mapping[str, str | Path] | Sequence[str | Path],
    reference_material: str | None = None,
    accel: float | None = None,
    source: str | Path | None = None,
) -> list[Path]:
    """Write figures 5-8.

    Parameters
    ----------
    study : xarray.Dataset
        The study dataset.
    variants : mapping
        ``{"loss": [[scale, name], ...], "density": [[scale, name], ...]}``.
    outputs : mapping or sequence of path-like
        ``{figure name: path}`` with the names of :data:`FIGURES`, or four paths in that order.
    reference_material : str, optional
        Default: the study's ``reference_material`` attribute.
    accel : float, optional
        Acceleration of figures 7-8 [m/s^2]; default the highest dynamic acceleration.
    source : path-like, optional
        The study file, named in each figure's caption line with the surface and the materials.

    Returns
    -------
    list of pathlib.Path
        The written files, in the order of :data:`FIGURES`.
    """
    if isinstance(outputs, Mapping):
        missing = [n for n in FIGURES if n not in outputs]
        if missing:
            raise ValueError(f"outputs lack the figure(s) {missing}; expected keys {FIGURES}")
        paths = [outputs[n] for n in FIGURES]
    else:
        paths = list(outputs)
        if len(paths) != len(FIGURES):
            raise ValueError(f"expected {len(FIGURES)} output paths ({', '.join(FIGURES)}), got {len(paths)}")
    ref = _reference(study, reference_material)
    if accel is None:
        accel = _accels(study, ref)[-1]
    materials = list(dict.fromkeys(study["material"].values.astype(str)))
    caption = study_caption(study, source)
    return [
        plot_force(study, paths[0], ref, caption),
        plot_stiffness(study, paths[1], ref, caption),
        plot_variants(study, variant_members(variants, "loss", materials, ref), "loss", accel, paths[2], caption),
        plot_variants(study, variant_members(variants, "density", materials, ref), "density", accel, paths[3],
                      caption),
    ]
