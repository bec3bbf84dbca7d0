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

__all__ = ["plot_hysteresis"]

_STYLE = {"quasistatic": dict(color="0.2", ls="--", lw=1.4), "dynamic": dict(color="C3", ls="-", lw=1.2)}


def plot_hysteresis(loading: xr.Dataset, path) -> None:
    """Write figure 10 (PNG) of the loading study ``loading`` to ``path``."""
    materials = list(dict.fromkeys(str(m) for m in loading["material"].values))
    ncol = min(3, len(materials))
    nrow = math.ceil(len(materials) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.4 * nrow), squeeze=False, sharex=True, sharey=True)
    for ax, material in zip(axes.flat, materials):
        cases = np.flatnonzero(loading["material"].values.astype(str) == material)
        for i in cases:
            c = loading.isel(case=i)
            mode = str(c["mode"].item())
            d = c["loop_indentation"].values
            f = c["loop_force"].values
            keep = np.isfinite(d)
            label = f"{mode} ({c['loading'].item()}): W = {1e3 * float(c['dissipated_energy']):.3g} mJ"
            ax.plot(1e3 * d[keep], f[keep], label=label, **_STYLE.get(mode, {}))
        ax.set_title(material)
        ax.axhline(0.0, color="0.8", lw=0.6)
        ax.legend(fontsize=7, loc="upper left")
        ax.grid(alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("total contact force F [N]")
    for i, ax in enumerate(axes.flat):
        if i >= len(materials):
            ax.set_visible(False)
        elif i + ncol >= len(materials):  # nothing drawn below this panel: it carries the x axis
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel("indentation d [mm]")
    fig.suptitle("Fig. 10: load-unload cycles (quasi-static loops close on themselves: W = 0)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130, format="png")
    plt.close(fig)
