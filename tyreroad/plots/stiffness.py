"""Figure 9: the dynamic contact stiffness K*(f; d0) (SPEC 11) from the stiffness-spectrum files.

Separate panels for the storage stiffness K′ = Re K* (top row; the report tabulates K′) and the loss
stiffness K″ = Im K* (bottom row), in MN/m against a log frequency axis. Left column: the reference
material, one colour per preload, the relaxed state solid and (when the files carry it) the
transient state dashed, the quasi-static tangent K_qs (the f -> 0 limit about the relaxed state) as
a marker at the left edge. Right column: every study material at one preload, relaxed state.

The model's validity limit is marked: above :data:`tyreroad.fidelity.FIDELITY_BAND`'s upper end
(5 kHz) the march kernel that the time-domain runs use is not checked against the element FRF from
which K* is computed, so there K* describes the layer model but not what the time-domain contact
runs feel; that band is shaded. The axis ends at the kernel's Nyquist frequency fs/2 (the grid's last
point), beyond which the time-domain model has no content at all.
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

from ..fidelity import FIDELITY_BAND  # noqa: E402

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
    transient = "storage_stiffness_transient" in ref
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5), sharex=True)
    f = ref["frequency"].values
    colors = plt.cm.viridis(np.linspace(0.0, 0.85, ref.sizes["preload"]))
    for p, d0 in enumerate(ref["preload"].values):
        sel = ref.isel(preload=p)
        label = f"d0 = {d0 * _MM:.3g} mm ({100 * float(sel['contact_fraction']):.0f} % in contact)"
        axes[0, 0].plot(f, sel["storage_stiffness"] * _MN, color=colors[p], label=label)
        axes[0, 0].plot(f[0], float(sel["tangent_stiffness_qs"]) * _MN, "<", color=colors[p], ms=7)
        axes[1, 0].plot(f, sel["loss_stiffness"] * _MN, color=colors[p], label=label)
        if transient:
            axes[0, 0].plot(f, sel["storage_stiffness_transient"] * _MN, "--", color=colors[p], lw=1.2)
            axes[1, 0].plot(f, sel["loss_stiffness_transient"] * _MN, "--", color=colors[p], lw=1.2)
    speed = ref.attrs.get("transient_speed")
    state_note = (f"solid: relaxed state; dashed: transient state (loaded to d0 at {float(speed):g} m/s)"
                  if transient else "relaxed state")
    axes[0, 0].set_title(f"{reference}: one colour per preload\n{state_note}", fontsize=10)
    order = [reference] + sorted(m for m in by if m != reference)
    styles = ["-", "--", ":", "-.", (0, (5, 1, 1, 1))]
    for i, material in enumerate(order):
        ds = by[material]
        sel = ds.isel(preload=_preload_index(ds, figure_preload))
        label = _variant_label(material, reference, variants)
        ls = styles[i % len(styles)]
        axes[0, 1].plot(ds["frequency"], sel["storage_stiffness"] * _MN, ls=ls, label=label)
        axes[1, 1].plot(ds["frequency"], sel["loss_stiffness"] * _MN, ls=ls, label=label)
    axes[0, 1].set_title(f"all materials at d0 = {figure_preload * _MM:.3g} mm, relaxed state", fontsize=10)
    for ax in axes[0]:
        ax.set_ylabel("storage stiffness K' = Re K* [MN/m]")
    for ax in axes[1]:
        ax.set_ylabel("loss stiffness K'' = Im K* [MN/m]")
        ax.set_xlabel("frequency [Hz]")
    f_check = FIDELITY_BAND[1]
    nyquist = 0.5 * float(ref.attrs.get("sample_rate", 2 * f[-1]))
    for ax in axes.ravel():
        ax.set_xscale("log")
        ax.set_xlim(f[0] / 1.2, max(f[-1], nyquist))
        ax.grid(True, which="both", alpha=0.3)
        ax.axvspan(f_check, max(f[-1], nyquist), color="0.85", alpha=0.5, lw=0, zorder=0)
        ax.axvline(f_check, color="0.3", lw=1.0, ls="-.")
    axes[0, 0].legend(fontsize=8, title="◀ quasi-static tangent K_qs", title_fontsize=8, loc="upper left")
    axes[1, 1].legend(fontsize=8, loc="upper left")
    fig.suptitle("Dynamic contact stiffness K*(f; d0) = K' + i K'' (exp(+iωt))")
    fig.text(0.5, 0.005, f"Shaded, right of the dash-dotted line: above {f_check / 1e3:g} kHz the time-domain kernel's "
             f"fidelity to the layer FRF (from which K* is computed) is not checked;\n"
             f"the axis ends at the kernel's Nyquist frequency fs/2 = {nyquist / 1e3:g} kHz.",
             ha="center", va="bottom", fontsize=8.5, color="0.2")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    fig.savefig(out_png, dpi=120)
    plt.close(fig)
    logger.info("wrote %s", out_png)
    return Path(out_png)
