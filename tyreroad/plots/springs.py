"""Figure of the element contact springs: k(zeta) of a few elements and of the whole patch."""

from __future__ import annotations

import logging
import math
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


def _plateau(ds: xr.Dataset, full_area: float) -> tuple[float | None, str]:
    """The stiffness of an element with its whole top in contact, and how it comes about.

    For ``single_punch`` springs: the flat rigid punch of the element's whole area A_e (radius
    a = sqrt(A_e / pi)) on the layer, 2 E* kappa(a / h, nu) a (:func:`tyreroad.springs.punch_factor`);
    for the other models the largest tabulated stiffness, without a formula.
    """
    k_max = float(np.nanmax(ds["stiffness"].values))
    if ds.attrs.get("model") != "single_punch" or "spring_modulus" not in ds.attrs:
        return k_max, "largest tabulated k"
    from ..springs import punch_factor

    nu = float(ds.attrs["poisson"])
    e_star = float(ds.attrs["spring_modulus"]) / (1.0 - nu**2)
    a = math.sqrt(full_area / math.pi)
    h = float(ds.attrs.get("thickness", math.inf))
    kappa = float(punch_factor(a / h if math.isfinite(h) else 0.0, nu))
    k = 2.0 * e_star * kappa * a
    return k, (f"whole {full_area * 1e6:.3g} mm² top in contact,\nflat punch 2E*κa, a = {a * 1e3:.3f} mm, "
               f"κ = {kappa:.3f}")


def plot_springs(ds: xr.Dataset, path: str | Path) -> None:
    """Plot k(zeta) for representative elements and the patch sum sum_e k_e(zeta).

    Left panel: stiffness [kN/m] against compression [um] for the stiffest, the median and a
    soft (10th percentile) element, ranked by k at zeta = 50 um (or the grid end if shorter),
    up to a little past the compression where the last of them has its whole top in contact:
    from there on k is flat. The plateau is marked and named: for ``single_punch`` springs it is
    the flat-punch stiffness 2 E* kappa(a/h) a of the whole element top, a = sqrt(A_e / pi).
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

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    flat_area = area.reshape(n_ex * n_ey, -1)
    full_at = []  # first compression with the element's whole top in contact
    styles = ["-", "--", "-."]
    for (label, idx), ls in zip(picks.items(), styles):
        i, j = divmod(int(idx), n_ey)
        ax1.plot(zeta_um, flat[idx] * 1e-3, ls=ls, label=f"{label}: element ({i}, {j})")
        full_at.append(zeta_um[int(np.argmax(flat_area[idx] >= flat_area[idx, -1]))])
    plateau, note = _plateau(ds, float(flat_area.max()))
    if plateau is not None:
        ax1.axhline(plateau * 1e-3, color="0.5", lw=5, alpha=0.35, zorder=0,
                    label=f"plateau {plateau * 1e-3:.1f} kN/m: {note}")
    x_end = min(float(zeta_um[-1]), 1.3 * max(full_at) if max(full_at) > 0 else float(zeta_um[-1]))
    ax1.set_xlim(0, x_end)
    ax1.set_xlabel(r"spring compression $\zeta$ [µm]")
    ax1.set_ylabel(r"element stiffness $k_e(\zeta)$ [kN/m]")
    ax1.set_title(f"Element springs ({ds.attrs.get('model', '?')}), shown to {x_end:.0f} µm\n"
                  f"(all three flat there; the table runs to {zeta_um[-1]:.0f} µm)", fontsize=10)
    ax1.grid(True, alpha=0.3)
    ax1.legend(loc="lower right", fontsize=8, framealpha=0.9)

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
    ax2.set_title(f"{n_ex} x {n_ey} elements, all compressed by the same ζ\n"
                  "(grows until the lowest element tops are in full contact)", fontsize=10)
    fig.savefig(path, format="png", dpi=120)
    plt.close(fig)
    logger.info("springs figure written to %s", path)
