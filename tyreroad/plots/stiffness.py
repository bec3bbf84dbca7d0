"""Figure 9: the dynamic contact stiffness K*(f; d0) (SPEC 11) from the stiffness-spectrum files.

Left column: the reference material, one curve per preload; right column: every study material
(the reference and its loss and density variants) at one preload. Top row |K*| [MN/m] with the
quasi-static tangent K_qs (the f -> 0 limit about the relaxed state) as a marker at the left
edge; bottom row the loss factor K''/K' of the contact. Log frequency axis.
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

logger = logging.getLogger(__name__)

__all__ = ["plot_stiffness_spectrum"]

_MN = 1e-6
_MM = 1e3


def _by_material(spectra: Sequence[xr.Dataset]) -> dict[str, xr.Dataset]:
    out = {}
    for i, ds in enumerate(spectra):
        if "material" not in ds.attrs:
            raise ValueError(f"stiffness spectrum #{i} has no 'material' attribute")
        out[str(ds.attrs["material"])] = ds
    return out


def _preload_index(ds: xr.Dataset, preload: float) -> int:
    pre = ds["preload"].values
    i = int(np.argmin(np.abs(pre - preload)))
    if not np.isclose(pre[i], preload, rtol=1e-9, atol=0):
        raise ValueError(f"{ds.attrs.get('material')}: no preload {preload:g} m in the file ({pre.tolist()})")
    return i


def _variant_label(material: str, reference: str, variants: Mapping[str, Any]) -> str:
    if material == reference:
        return f"{material} (reference)"
    for kind, symbol in (("loss", "η"), ("density", "ρ")):
        for scale, name in variants.get(kind, []):
            if name == material:
                return f"{symbol} ×{float(scale):g} ({material})"
    return material


def plot_stiffness_spectrum(spectra: Sequence[xr.Dataset], reference: str, variants: Mapping[str, Any],
                            figure_preload: float, out_png: str | Path) -> Path:
    """Draw figure 9.

    Parameters
    ----------
    spectra : sequence of xarray.Dataset
        Stiffness-spectrum datasets (docs/data_contracts.md), one per material.
    reference : str
        The reference material (left column).
    variants : mapping
        ``{"loss": [[scale, name], ...], "density": [[scale, name], ...]}`` (labels of the right column).
    figure_preload : float
        Preload of the right column [m].
    out_png : path-like
        Output file.

    Returns
    -------
    pathlib.Path
    """
    by = _by_material(spectra)
    if reference not in by:
        raise ValueError(f"reference material {reference!r} has no stiffness spectrum (have {sorted(by)})")
    ref = by[reference]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True)
    f = ref["frequency"].values
    colors = plt.cm.viridis(np.linspace(0.0, 0.85, ref.sizes["preload"]))
    for p, d0 in enumerate(ref["preload"].values):
        sel = ref.isel(preload=p)
        label = f"d0 = {d0 * _MM:.3g} mm ({100 * float(sel['contact_fraction']):.0f} % in contact)"
        axes[0, 0].plot(f, sel["stiffness_magnitude"] * _MN, color=colors[p], label=label)
        axes[0, 0].plot(f[0], float(sel["tangent_stiffness_qs"]) * _MN, "<", color=colors[p], ms=7)
        axes[1, 0].plot(f, sel["loss_factor"], color=colors[p], label=label)
    axes[0, 0].set_title(f"{reference}: one curve per preload")
    order = [reference] + sorted(m for m in by if m != reference)
    styles = ["-", "--", ":", "-.", (0, (5, 1, 1, 1))]
    for i, material in enumerate(order):
        ds = by[material]
        sel = ds.isel(preload=_preload_index(ds, figure_preload))
        label = _variant_label(material, reference, variants)
        ls = styles[i % len(styles)]
        axes[0, 1].plot(ds["frequency"], sel["stiffness_magnitude"] * _MN, ls=ls, label=label)
        axes[1, 1].plot(ds["frequency"], sel["loss_factor"], ls=ls, label=label)
    axes[0, 1].set_title(f"all materials at d0 = {figure_preload * _MM:.3g} mm")
    for ax in axes[0]:
        ax.set_ylabel("|K*| [MN/m]")
    for ax in axes[1]:
        ax.set_ylabel("loss factor K''/K' [1]")
        ax.set_xlabel("frequency [Hz]")
    for ax in axes.ravel():
        ax.set_xscale("log")
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize=8, title="◀ quasi-static tangent K_qs", title_fontsize=8)
    axes[1, 1].legend(fontsize=8)
    fig.suptitle("Dynamic contact stiffness K*(f; d0) about the relaxed preload state (exp(+iωt))")
    fig.tight_layout()
    fig.savefig(out_png, dpi=120)
    plt.close(fig)
    logger.info("wrote %s", out_png)
    return Path(out_png)
