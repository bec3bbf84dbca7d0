"""Figure 4 of the paper: the road patch with its element grid and matching points."""

from __future__ import annotations

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

logger = logging.getLogger(__name__)

__all__ = ["plot_patch"]


def _outline():
    import matplotlib.patheffects as pe

    return pe.withStroke(linewidth=2.2, foreground="0.3")


#: Colour range of the height map below the highest sample [m]: the contact happens in the top
#: tenths of a millimetre, so a scale over the whole patch depth (1.4 mm on ISO 10844) paints
#: every stone top the same colour.
COLOUR_RANGE = 0.3e-3


def plot_patch(ds: xr.Dataset, path: str | Path, depth: float = 0.15e-3,
               colour_range: float = COLOUR_RANGE) -> Path:
    """Plot the contact patch: heights (mm colour map), 1 mm element grid and matching points.

    The colour scale spans only the top ``colour_range`` below the highest sample (lower ground
    is drawn in the scale's darkest colour, marked by the colourbar's arrow), and a white contour
    marks the height ``depth`` below the highest matching point, so the stone tops that carry the
    load are told apart.

    Matching points (each element's highest sample) within ``depth`` of the patch's highest peak
    are drawn filled, the others hollow, so the figure also shows which elements are in contact
    at an indentation of ``depth``.

    Parameters
    ----------
    ds : xarray.Dataset
        Surface dataset (variables height, z1, peak_x, peak_y; attrs element_size, surface).
    path : path-like
        Output PNG file; parent directories are created.
    depth : float
        Depth below the top used to mark matching points and draw the contour [m].
    colour_range : float
        Height range of the colour scale below the highest sample [m].

    Returns
    -------
    pathlib.Path
        The written file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    x_mm = ds["x"].values * 1e3
    y_mm = ds["y"].values * 1e3
    c_mm = float(ds.attrs["element_size"]) * 1e3
    step_mm = float(ds.attrs["scan_step"]) * 1e3
    h_mm = ds["height"].values * 1e3
    z1 = ds["z1"].values
    top = z1.max()
    near = z1 >= top - depth
    ex, ey = z1.shape

    # Edges of the cell-centred samples.
    xe = np.concatenate([x_mm - 0.5 * step_mm, [x_mm[-1] + 0.5 * step_mm]])
    ye = np.concatenate([y_mm - 0.5 * step_mm, [y_mm[-1] + 0.5 * step_mm]])
    # a long strip (a rolling patch, 150 x 20 elements) is drawn wide, with the colour bar and the
    # legend below it, instead of a thin band in a square figure
    wide = (xe[-1] - xe[0]) > 2.5 * (ye[-1] - ye[0])
    if wide:
        map_h = 13.0 * (ye[-1] - ye[0]) / (xe[-1] - xe[0])
        fig, ax = plt.subplots(figsize=(14.0, map_h + 2.5), layout="constrained")
    else:
        fig, ax = plt.subplots(figsize=(7.2, 6.0), layout="constrained")
    marker = 14 if ex * ey <= 900 else 5
    h_top = float(np.nanmax(h_mm))
    span_mm = colour_range * 1e3
    mesh = ax.pcolormesh(xe, ye, h_mm.T, cmap="cividis", shading="flat", rasterized=True,
                         vmin=h_top - span_mm, vmax=h_top)
    cbar = fig.colorbar(mesh, ax=ax, extend="min", **({"location": "bottom", "shrink": 0.5} if wide else {}))
    cbar.set_label(f"road height z [mm]: scale clipped to the top {span_mm:g} mm" + (" " if wide else "\n")
                   + f"(the patch spans {h_top - float(np.nanmin(h_mm)):.2f} mm; lower ground: darkest colour)")
    level = (top - depth) * 1e3
    ax.contour(x_mm, y_mm, h_mm.T, levels=[level], colors="white", linewidths=0.9,
               linestyles="solid")
    (cbar.ax.axvline if wide else cbar.ax.axhline)(level, color="white", lw=1.5)
    for i in range(ex + 1):
        ax.axvline(i * c_mm, color="0.15", lw=0.35, alpha=0.5)
    for j in range(ey + 1):
        ax.axhline(j * c_mm, color="0.15", lw=0.35, alpha=0.5)
    px = ds["peak_x"].values * 1e3
    py = ds["peak_y"].values * 1e3
    ax.scatter(px[near], py[near], s=marker, c="red", edgecolors="black", linewidths=0.4,
               label=f"matching point within {depth * 1e3:g} mm of the top ({near.mean():.0%})")
    ax.scatter(px[~near], py[~near], s=marker, facecolors="none", edgecolors="red", linewidths=0.8,
               label="other matching points")
    ax.plot([], [], color="white", lw=0.9, path_effects=[_outline()],
            label=f"contour {depth * 1e3:g} mm below the highest matching point")
    ax.set_xlim(xe[0], xe[-1])
    ax.set_ylim(ye[0], ye[-1])
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    name = ds.attrs.get("surface", "")
    ax.set_title(f"Road patch {name}: {ex} x {ey} elements of {c_mm:g} mm")
    if wide:
        fig.legend(loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    else:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=1, fontsize=9, frameon=False)
    fig.savefig(path, dpi=150)
    plt.close(fig)
    logger.info("wrote %s", path)
    return path
