"""Figures 11-14 of the rolling study (SPEC 12), from ``results/rolling.nc`` and two rolling runs.

* fig 11: total force against the contact centre x_c, quasi-static and each speed, per material;
* fig 12: 1/3-octave spectra of the force fluctuation over the steady part, per material;
* fig 13: rolling-loss coefficient (W / dx over the steady mean force) against speed, per material;
* fig 14: element forces at one instant (the middle snapshot) of a quasi-static and a dynamic
  pass: the contact patch, x_c and the geometric contact half-length a = sqrt(2 R d0) marked.
"""

from __future__ import annotations

import math
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from .. import io  # noqa: E402
from ..report.claims import THRESHOLDS  # noqa: E402

__all__ = ["plot_rolling_figures", "ROLLING_FIGURES"]

#: File stems of the rolling figures, in the order of ``outputs``.
ROLLING_FIGURES = ["fig11_rolling_force", "fig12_rolling_spectra", "fig13_rolling_loss", "fig14_contact_map"]


def _materials(study: xr.Dataset) -> list[str]:
    return list(dict.fromkeys(str(m) for m in study["material"].values))


def _panels(n: int):
    ncol = min(3, n)
    nrow = math.ceil(n / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.4 * ncol, 3.4 * nrow), squeeze=False, sharex=True, sharey=True)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    return fig, axes


def _cases(study, material):
    return [i for i in range(study.sizes["case"]) if str(study["material"].values[i]) == material]


def plot_force(study: xr.Dataset, path) -> None:
    """Fig. 11: F(x_c) of each material, quasi-static (dashed) and each speed."""
    mats = _materials(study)
    fig, axes = _panels(len(mats))
    x = 1e3 * study["position"].values
    for ax, material in zip(axes.flat, mats):
        qs_done = False
        for i in _cases(study, material):
            c = study.isel(case=i)
            mode, v = str(c["mode"].item()), float(c["speed"])
            if mode == "quasistatic":
                if qs_done:
                    continue  # every quasi-static pass gives the same F(x_c)
                qs_done = True
                ax.plot(x, c["force_curve"].values, color="0.2", ls="--", lw=1.3, label="quasi-static")
            else:
                ax.plot(x, c["force_curve"].values, lw=1.0, label=f"{v:g} m/s")
        ax.set_title(material)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("contact centre x_c [mm]")
    for ax in axes[:, 0]:
        ax.set_ylabel("total contact force F [N]")
    fig.suptitle(f"Fig. 11: rolling over the {study.attrs['surface']} strip (R = {study.attrs['radius']:g} m, axle "
                 "height fixed)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130, format="png")
    plt.close(fig)


def plot_spectra(study: xr.Dataset, path) -> None:
    """Fig. 12: 1/3-octave levels of the force fluctuation over the steady part."""
    mats = _materials(study)
    fig, axes = _panels(len(mats))
    f = study["band"].values
    for ax, material in zip(axes.flat, mats):
        for i in _cases(study, material):
            c = study.isel(case=i)
            mode, v = str(c["mode"].item()), float(c["speed"])
            style = dict(ls="--", color="0.5", lw=0.9) if mode == "quasistatic" else dict(lw=1.1, marker="o", ms=2.5)
            ax.semilogx(f, c["band_level"].values, label=f"{'QS' if mode == 'quasistatic' else 'dyn'} {v:g} m/s",
                        **style)
        ax.set_title(material)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=6, ncol=2)
    for ax in axes[-1]:
        ax.set_xlabel("1/3-octave band centre [Hz]")
    for ax in axes[:, 0]:
        ax.set_ylabel("force fluctuation level [dB re 1 N]")
    fig.suptitle("Fig. 12: spectra of the total force over the steady part (bands below 2/T not resolved)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130, format="png")
    plt.close(fig)


def plot_loss(study: xr.Dataset, path) -> None:
    """Fig. 13: rolling-loss coefficient against speed, one line per material (dynamic passes)."""
    fig, ax = plt.subplots(figsize=(5.6, 3.8))
    for material in _materials(study):
        idx = [i for i in _cases(study, material) if str(study["mode"].values[i]) == "dynamic"]
        v = study["speed"].values[idx]
        order = np.argsort(v)
        coef = study["rolling_loss_coefficient"].values[idx][order]
        line, = ax.plot(v[order], coef, marker="o", label=material)
        if "chatter" in study:  # cases whose time march chattered at fs/2 (not trustworthy): crossed out
            bad = study["chatter"].values[idx][order] > THRESHOLDS["rolling_chatter_max"]
            ax.plot(v[order][bad], coef[bad], ls="none", marker="x", ms=12, color="k",
                    label=f"{material}: fs/2 chatter, not trustworthy" if bad.any() else None)
    ax.axhspan(1e-3, 1e-2, color="0.9", zorder=0, label="tread hysteresis, typical")
    ax.set_xlabel("speed v [m/s]")
    ax.set_ylabel("rolling-loss coefficient (P/v) / F, steady part [-]")
    ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    ax.set_title("Fig. 13: rolling loss of the tread", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130, format="png")
    plt.close(fig)


def plot_contact_map(runs: Sequence[xr.Dataset], path) -> None:
    """Fig. 14: element forces at the middle snapshot of each run, x_c and +-a marked."""
    fig, axes = plt.subplots(len(runs), 1, figsize=(10, 1.0 + 1.9 * len(runs)), squeeze=False)
    vmax = max(float(r["element_force"].max()) for r in runs) or 1.0
    for ax, run in zip(axes[:, 0], runs):
        k = run.sizes["snapshot"] // 2
        f = run["element_force"].isel(snapshot=k).values
        c = float(run.attrs["element_size"])
        nx, ny = f.shape
        im = ax.imshow(f.T, origin="lower", extent=(0, 1e3 * nx * c, 0, 1e3 * ny * c), cmap="viridis",
                       vmin=0, vmax=vmax, aspect="equal", interpolation="nearest")
        xc = float(run["snapshot_x_c"].values[k])
        a = float(run.attrs["half_length"])
        step = int(run["snapshot_step"].values[k])
        ax.axvline(1e3 * xc, color="w", lw=1.2, label="x_c")
        for s in (-1, 1):
            ax.axvline(1e3 * (xc + s * a), color="w", lw=0.8, ls=":")
        centre = float(run["pressure_centre"].values[step])
        ax.plot([1e3 * centre], [1e3 * ny * c / 2], marker="x", color="r", ms=8, label="pressure centre")
        count = int(run["contact_count"].values[step])
        ax.set_title(f"{run.attrs['material']}, {run.attrs['mode']} {float(run.attrs['speed']):g} m/s: x_c = "
                     f"{1e3 * xc:.1f} mm, F = {float(run['force'].values[step]):.0f} N, {count} elements in contact "
                     f"(dotted: x_c +- a, a = {1e3 * a:.1f} mm)", fontsize=8)
        ax.set_xlim(1e3 * (xc - 2 * a), 1e3 * (xc + 2 * a))
        ax.set_ylabel("y [mm]")
        ax.legend(fontsize=7, loc="upper right")
        fig.colorbar(im, ax=ax, label="F_e [N]", fraction=0.03)
    axes[-1, 0].set_xlabel("x [mm] (rolling direction +x)")
    fig.suptitle("Fig. 14: contact map at one instant", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130, format="png")
    plt.close(fig)


def plot_rolling_figures(study: xr.Dataset, map_runs: Sequence[xr.Dataset], outputs: Sequence[str]) -> None:
    """Write figures 11-14 to ``outputs`` (in the order of :data:`ROLLING_FIGURES`)."""
    writers = [lambda p: plot_force(study, p), lambda p: plot_spectra(study, p), lambda p: plot_loss(study, p),
               lambda p: plot_contact_map(map_runs, p)]
    for write, out in zip(writers, outputs):
        with io.atomic_path(out) as tmp:
            write(tmp)
