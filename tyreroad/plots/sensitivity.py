"""Figure of the sensitivity sweep (:mod:`tyreroad.sensitivity`): what decides claims 5-7.

Four panels, one entry per sweep point: (a) the loss factor of each point's material against
frequency, (b) the K_sat change of the two loss-factor variants (claim 6: the seed's direction is
"high η stiffer, low η softer"), (c) the ripple ratio of the density variant (claim 7, threshold
line), (d) the change of K over the saturation range (claim 5, threshold line) with the contact
fraction at 0.15 mm written on each bar.
"""

from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..report.claims import THRESHOLDS  # noqa: E402

logger = logging.getLogger(__name__)

__all__ = ["plot_sensitivity"]

_LINESTYLES = ["-", "--", "-.", ":"]


def plot_sensitivity(ds: xr.Dataset, path: str | Path) -> Path:
    """Write the sweep figure.

    Parameters
    ----------
    ds : xarray.Dataset
        The sweep dataset (:func:`tyreroad.sensitivity.combine_points`).
    path : path-like
        Output PNG.

    Returns
    -------
    pathlib.Path
    """
    names = [str(p) for p in ds["point"].values]
    x = np.arange(len(names))
    fig, axes = plt.subplots(2, 2, figsize=(12, 8.5), layout="constrained")
    ax_eta, ax6, ax7, ax5 = axes.ravel()

    # (a) material loss factor; points sharing the same eta(f) are drawn once and named together
    f = ds["frequency"].values
    groups: list[list[int]] = []
    for i in range(len(names)):
        eta = ds["loss_factor_curve"].values[i]
        for g in groups:
            if np.allclose(ds["loss_factor_curve"].values[g[0]], eta, rtol=1e-6):
                g.append(i)
                break
        else:
            groups.append([i])
    for n, g in enumerate(groups):
        label = " = ".join(names[i] for i in g)
        ax_eta.semilogx(f, ds["loss_factor_curve"].values[g[0]], color=f"C{n}", ls=_LINESTYLES[n % 4], lw=1.6,
                        label=label if len(g) == 1 else f"{label} (same η(f))")
    ax_eta.axvspan(1e3, 1e4, color="0.93", zorder=0, label="1–10 kHz")
    ax_eta.set_xlabel("frequency [Hz]")
    ax_eta.set_ylabel("loss factor η [-]")
    ax_eta.set_ylim(bottom=0)
    ax_eta.grid(True, which="both", alpha=0.3)
    ax_eta.legend(fontsize=7)
    ax_eta.set_title("(a) material of each point (calibrated)")

    # (b) claim 6
    delta = ds["loss_delta"].values * 100
    scales = ds["loss_scale"].values
    w = 0.38
    for j, (s, color) in enumerate(zip(scales, ("tab:blue", "tab:red"))):
        ax6.bar(x + (j - 0.5) * w, delta[:, j], w, color=color, label=f"η ×{s:g}")
    ax6.axhline(0, color="k", lw=0.8)
    ax6.set_ylabel("ΔK_sat [%]")
    ax6.set_title(f"(b) claim 6: seed says η ×{scales[1]:g} > 0 > η ×{scales[0]:g}")
    verdicts = ds["claim6_verdict"].values.astype(str)
    short = {"holds": "holds", "size holds, direction opposite": "opposite", "fails": "fails"}
    top = np.nanmax(np.abs(delta)) * 1.25
    for i, v in enumerate(verdicts):
        ax6.text(x[i], top * 0.92, short.get(v, v), ha="center", va="top", fontsize=7, rotation=0)
    ax6.set_ylim(-top, top)
    ax6.legend(fontsize=8, loc="lower right")

    # (c) claim 7
    ratio = ds["ripple_ratio"].values
    ax7.bar(x, ratio, 0.6, color="tab:green")
    thr7 = THRESHOLDS["c7_ripple_ratio_min"]
    ax7.axhline(thr7, color="k", ls="--", lw=1, label=f"claim 7 needs ≥ {thr7:g}")
    ax7.axhline(1.0, color="0.5", lw=0.8)
    ax7.set_ylabel("ripple(ρ ×2) / ripple(reference)")
    ax7.set_title("(c) claim 7: density ripples at small d")
    ax7.set_ylim(0, max(np.nanmax(ratio), thr7) * 1.25)
    ax7.legend(fontsize=8, loc="upper left")

    # (d) claim 5
    change = ds["saturation_change"].values * 100
    ax5.bar(x, change, 0.6, color="tab:orange")
    thr5 = THRESHOLDS["c5_change_max"] * 100
    ax5.axhline(thr5, color="k", ls="--", lw=1, label=f"claim 5 needs ≤ {thr5:g} %")
    for i, fr in enumerate(ds["fraction_at_c5"].values):
        ax5.text(x[i], change[i], f"{100 * fr:.0f} %", ha="center", va="bottom", fontsize=7)
    ax5.set_ylabel("change of K over the saturation range [%]")
    ax5.set_title("(d) claim 5: saturation (label: elements in contact at 0.15 mm)")
    ax5.legend(fontsize=8)
    ax5.set_ylim(0, max(np.nanmax(change), thr5) * 1.2)

    for ax in (ax6, ax7, ax5):
        ax.set_xticks(x, names, rotation=30, ha="right", fontsize=8)
        ax.grid(axis="y", alpha=0.3)
    a = float(ds.attrs.get("acceleration_m_s2", 500.0))
    fig.suptitle(f"What decides claims 5–7: sweep at a = {a:g} m/s², every point calibrated to "
                 f"K_sat ≈ {float(ds.attrs.get('target_stiffness_N_m', 2.75e6)) * 1e-6:g} MN/m")
    path = Path(path)
    fig.savefig(path, format="png", dpi=130)
    plt.close(fig)
    logger.info("wrote %s", path)
    return path
