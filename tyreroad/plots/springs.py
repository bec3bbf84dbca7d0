"""Figure of the element contact springs: k(zeta) of a few elements and of the whole patch."""

from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

logger = logging.getLogger(__name__)

__all__ = ["plot_springs"]

#: Compression at which elements are ranked for the figure [m].
RANK_COMPRESSION = 50e-6


def plot_springs(ds: xr.Dataset, path: str | Path) -> None:
    """Plot k(zeta) for representative elements and the patch sum sum_e k_e(zeta).

    Left panel: stiffness [kN/m] against compression [um] for the stiffest, the median and a
    soft (10th percentile) element, ranked by k at zeta = 50 um (or the grid end if shorter).
    Right panel: the sum over all elements at a common compression (every element compressed by
    the same zeta, an upper bound of the patch stiffness since the elements' heights differ) in
    MN/m, and the contact area sum in mm^2 on a second axis.

    Parameters
    ----------
    ds : xarray.Dataset
        Springs dataset of :func:`tyreroad.springs.element_springs`.
    path : str or pathlib.Path
        Output file; written as PNG whatever its suffix (the workflow passes a temporary name).
    """
    for name in ("stiffness", "area"):
        if name not in ds:
            raise KeyError(f"plot_springs: dataset has no variable '{name}'")
    zeta_um = ds["zeta"].values * 1e6
    k = ds["stiffness"].transpose("ex", "ey", "zeta").values
    area = ds["area"].transpose("ex", "ey", "zeta").values
    n_ex, n_ey, _ = k.shape
    flat = k.reshape(n_ex * n_ey, -1)
    j_rank = int(np.argmin(np.abs(ds["zeta"].values - RANK_COMPRESSION)))
    rank = np.argsort(flat[:, j_rank], kind="stable")
    picks = {
        "stiffest": rank[-1],
        "median": rank[len(rank) // 2],
        "10th percentile": rank[int(0.1 * (len(rank) - 1))],
    }

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    for label, idx in picks.items():
        i, j = divmod(int(idx), n_ey)
        ax1.plot(zeta_um, flat[idx] * 1e-3, label=f"{label}: element ({i}, {j})")
    ax1.set_xlabel(r"spring compression $\zeta$ [µm]")
    ax1.set_ylabel(r"element stiffness $k_e(\zeta)$ [kN/m]")
    ax1.set_title(f"Element springs ({ds.attrs.get('model', '?')})")
    ax1.grid(True, alpha=0.3)
    ax1.legend(loc="lower right", fontsize=8)

    k_sum = k.sum(axis=(0, 1))
    line1 = ax2.plot(zeta_um, k_sum * 1e-6, color="C3", label=r"$\Sigma_e\, k_e(\zeta)$")
    ax2.set_xlabel(r"common compression $\zeta$ [µm]")
    ax2.set_ylabel(r"patch sum of stiffness [MN/m]")
    ax2.grid(True, alpha=0.3)
    ax2b = ax2.twinx()
    line2 = ax2b.plot(
        zeta_um, area.sum(axis=(0, 1)) * 1e6, color="C0", linestyle="--", label=r"$\Sigma_e\, A_e(\zeta)$"
    )
    ax2b.set_ylabel(r"patch sum of overlap area [mm$^2$]")
    lines = line1 + line2
    ax2.legend(lines, [ln.get_label() for ln in lines], loc="lower right", fontsize=8)
    ax2.set_title(f"{n_ex} x {n_ey} elements, all compressed by the same ζ")
    fig.savefig(path, format="png", dpi=120)
    plt.close(fig)
    logger.info("springs figure written to %s", path)
