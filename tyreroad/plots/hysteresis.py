"""Figure 10: hysteresis loops F(d) of the load-unload cycles (SPEC 10), from ``results/loading.nc``.

One panel per material: the quasi-static cycle (no rate dependence: loading and unloading coincide)
and the dynamic cycle (delayed recovery: the unloading branch lies below the loading branch and
the force reaches zero before d does). The legend gives W per loop.
"""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

__all__ = ["plot_hysteresis", "work_label"]

#: |W| below this fraction of the loop's input work is printed as zero (round-off of a closed loop).
ZERO_WORK = 1e-6

_STYLE = {"quasistatic": dict(color="0.2", ls="--", lw=1.4), "dynamic": dict(color="C3", ls="-", lw=1.2)}


def _sci(x: float) -> str:
    """1e-06 -> '1e-6'."""
    mantissa, exponent = f"{x:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def _decimals(input_works) -> int:
    """Decimals of W in mJ: a resolution of 0.1 % of the largest input work, between 0 and 6."""
    top = max((abs(w) for w in input_works if np.isfinite(w)), default=0.0) * 1e3
    if top <= 0.0:
        return 3
    return int(min(6, max(0, -math.floor(math.log10(1e-3 * top)))))


def work_label(dissipated: float, input_work: float, decimals: int) -> str:
    """Legend text of one loop: W in mJ at a fixed precision, with its share of the input work.

    Parameters
    ----------
    dissipated : float
        Work dissipated over the cycle W [J].
    input_work : float
        Work done on the loading branch [J].
    decimals : int
        Decimals of the mJ figures (the same for every loop of the figure).
    """
    if not np.isfinite(dissipated):
        return "W not computed"
    if input_work > 0 and abs(dissipated) < ZERO_WORK * input_work:
        return f"W = 0 (|W| < {_sci(ZERO_WORK)} of {1e3 * input_work:.{decimals}f} mJ input)"
    share = f", {dissipated / input_work:.1%} of {1e3 * input_work:.{decimals}f} mJ input" if input_work > 0 else ""
    return f"W = {1e3 * dissipated:.{decimals}f} mJ{share}"


def plot_hysteresis(loading: xr.Dataset, path) -> None:
    """Write figure 10 (PNG) of the loading study ``loading`` to ``path``.

    The legend prints each loop's dissipated work W at one fixed precision (0.1 % of the largest
    input work) and as a share of its input work; a loop with |W| below :data:`ZERO_WORK` of its
    input work reads ``W = 0``.
    """
    materials = list(dict.fromkeys(str(m) for m in loading["material"].values))
    ncol = min(3, len(materials))
    nrow = math.ceil(len(materials) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.0 * ncol, 3.9 * nrow), squeeze=False, sharex=True, sharey=True)
    decimals = _decimals(loading["loading_work"].values)
    for ax, material in zip(axes.flat, materials):
        cases = np.flatnonzero(loading["material"].values.astype(str) == material)
        for i in cases:
            c = loading.isel(case=i)
            mode = str(c["mode"].item())
            d = c["loop_indentation"].values
            f = c["loop_force"].values
            keep = np.isfinite(d)
            work = work_label(float(c["dissipated_energy"]), float(c["loading_work"]), decimals)
            label = f"{mode} ({c['loading'].item()}):\n{work}"
            ax.plot(1e3 * d[keep], f[keep], label=label, **_STYLE.get(mode, {}))
        ax.set_title(material)
        ax.axhline(0.0, color="0.8", lw=0.6)
        ax.legend(fontsize=9, loc="upper left", framealpha=0.9)
        ax.grid(alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("total contact force F [N]")
    for i, ax in enumerate(axes.flat):
        if i >= len(materials):
            ax.set_visible(False)
        elif i + ncol >= len(materials):  # nothing drawn below this panel: it carries the x axis
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel("indentation d [mm]")
    fig.suptitle(f"Fig. 10: load-unload cycles; W = dissipated work per cycle (quasi-static loops close on "
                 f"themselves: |W| < {_sci(ZERO_WORK)} of the input work)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130, format="png")
    plt.close(fig)
