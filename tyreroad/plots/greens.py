"""Figures 2 and 3: material curves and the element FRF at the excitation element.

Both take the Green's function datasets of :func:`tyreroad.greens.greens_dataset` (one per material;
the legend uses the dataset's ``material`` attribute).
"""

from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tyreroad.io import atomic_path  # noqa: E402

logger = logging.getLogger(__name__)

__all__ = ["plot_materials", "plot_frf"]

_REQUIRED_MATERIAL = ("storage_modulus", "loss_factor")
_REQUIRED_FRF = ("frf_real", "frf_imag", "g_static")


def _check(datasets, required, what):
    if not datasets:
        raise ValueError(f"{what}: no datasets given")
    for i, ds in enumerate(datasets):
        missing = [v for v in required if v not in ds]
        if missing:
            name = ds.attrs.get("material", f"#{i}")
            raise ValueError(f"{what}: dataset {name} lacks variable(s) {missing}")


def _label(ds, i):
    return str(ds.attrs.get("material", f"material {i}"))


def _save(fig, path):
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=150, format="png")
    plt.close(fig)
    logger.info("wrote %s", path)
    return path


def plot_materials(datasets: list, path) -> Path:
    """SPEC fig 2: storage and loss modulus, and loss factor, against frequency per material.

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Green's function datasets with ``storage_modulus`` [Pa] and ``loss_factor`` [1] over
        ``frequency`` [Hz].
    path : path-like
        PNG file to write.

    Returns
    -------
    pathlib.Path
    """
    _check(datasets, _REQUIRED_MATERIAL, "plot_materials")
    fig, (ax_e, ax_eta) = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    for i, ds in enumerate(datasets):
        f = ds["frequency"].values
        keep = f > 0
        e1 = ds["storage_modulus"].values[keep]
        eta = ds["loss_factor"].values[keep]
        colour = f"C{i}"
        label = _label(ds, i)
        ax_e.loglog(f[keep], e1 / 1e6, color=colour, label=f"{label}: E'")
        ax_e.loglog(f[keep], e1 * eta / 1e6, color=colour, ls="--", label=f"{label}: E''")
        ax_eta.semilogx(f[keep], eta, color=colour, label=label)
    ax_e.set_xlabel("frequency [Hz]")
    ax_e.set_ylabel("modulus [MPa]")
    ax_e.set_title("storage E' (solid) and loss E'' (dashed) modulus")
    ax_e.grid(True, which="both", alpha=0.3)
    ax_e.legend(fontsize=7, ncol=2)
    ax_eta.set_xlabel("frequency [Hz]")
    ax_eta.set_ylabel("loss factor η [-]")
    ax_eta.set_ylim(bottom=0)
    ax_eta.set_title("loss factor")
    ax_eta.grid(True, which="both", alpha=0.3)
    ax_eta.legend(fontsize=8)
    return _save(fig, path)


def plot_frf(datasets: list, path) -> Path:
    """SPEC fig 3: |g| at the excitation element against frequency, with the quasi-static value.

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Green's function datasets with ``frf_real``, ``frf_imag`` [m/N] over ``frequency`` [Hz]
        and ``g_static[dx, dy]`` [m/N].
    path : path-like
        PNG file to write.

    Returns
    -------
    pathlib.Path
    """
    _check(datasets, _REQUIRED_FRF, "plot_frf")
    fig, ax = plt.subplots(figsize=(6.5, 4.5), constrained_layout=True)
    for i, ds in enumerate(datasets):
        f = ds["frequency"].values
        keep = f > 0
        mag = np.hypot(ds["frf_real"].values, ds["frf_imag"].values)[keep]
        colour = f"C{i}"
        ax.loglog(f[keep], mag, color=colour, label=_label(ds, i))
        static = float(ds["g_static"].sel(dx=0, dy=0))
        ax.axhline(static, color=colour, ls=":", lw=1.2, label="quasi-static" if i == 0 else None)
        ax.plot(f[keep][0], static, marker="<", color=colour, ms=7, clip_on=False)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|g| at the excitation element [m/N]")
    ax.set_title("element receptance (dotted: quasi-static g)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)
