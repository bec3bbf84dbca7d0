"""Figures of the patterned-tread study (issue 27): the block's edge softening and K*(f; d0) on the pattern.

:func:`compliance_map_figure` draws the static self-compliance g_ii (the diagonal of a pattern greens file's
block table ``influence``, :func:`tyreroad.pattern_stage.pattern_greens_dataset`) of every element of a block,
normalised by the block centre's, as a map per pattern, and its cut through the block's middle row
(:func:`edge_profile`). :func:`pattern_spectrum_figure` draws K′(f) and the loss factor η(f) = K″/K′ of each
pattern's K* file (:func:`tyreroad.pattern_spectrum.pattern_stiffness_spectrum`) beside the slick tread's, which
every such file carries as its ``slick`` case, with the block's lowest natural frequencies marked.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from . import save_png  # noqa: E402

logger = logging.getLogger(__name__)

__all__ = ["compliance_grid", "edge_profile", "softening_ratios", "compliance_map_figure", "lowest_modes",
           "pattern_spectrum_figure"]

_MM = 1e3
_MN = 1e-6
_SLICK = "slick"  # tyreroad.pattern.SLICK (not imported: the figures do not run the contact code)
_REQUIRED_GREENS = ("influence", "x", "y")
_REQUIRED_SPECTRUM = ("k_storage", "k_loss", "case", "frequency", "preload")
#: What the lowest mode of each symmetry class of a block is (tyreroad.fe_pattern's classes; docs/pattern.md).
#: The names of matplotlib's default colours C0 ... C9 (for the text that refers to a line).
_COLOUR_NAMES = ["blue", "orange", "green", "red", "purple", "brown", "pink", "grey", "olive", "cyan"]
_MODE_KIND = {"even-x even-y": "vertical", "odd-x even-y": "rocking", "even-x odd-y": "rocking",
              "odd-x odd-y": "twist"}


def _name(ds: xr.Dataset, i: int) -> str:
    return str(ds.attrs.get("pattern", f"#{i}"))


def _check(ds: xr.Dataset, required: Sequence[str], what: str, i: int) -> None:
    missing = [v for v in required if v not in ds.variables]
    if missing:
        raise ValueError(f"{what}: dataset {_name(ds, i)} (#{i}) lacks variable(s) {missing}"
                         + (" (a slick greens file has only g_static, no block table)"
                            if "influence" in missing and "g_static" in ds else ""))


def _save(fig, path) -> Path:
    return save_png(fig, path, logger)


def compliance_grid(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The block's static self-compliance g_ii on its element grid.

    Parameters
    ----------
    ds : xarray.Dataset
        A pattern greens file: ``influence`` (element, source) [m/N] with the element centres ``x``, ``y`` [m]
        (row-major over x then y, :func:`tyreroad.pattern_stage.pattern_greens_dataset`).

    Returns
    -------
    x, y : numpy.ndarray
        Element centres along x (n_x) and y (n_y) [m], from the block's corner.
    g : numpy.ndarray
        g_ii [m/N], shape (n_x, n_y): ``g[i, j]`` belongs to the element at (x[i], y[j]).

    Raises
    ------
    ValueError
        A dataset without ``influence``, ``x`` or ``y``, or whose element centres are not a full grid.
    """
    _check(ds, _REQUIRED_GREENS, "compliance_grid", 0)
    xs, ys = ds["x"].values, ds["y"].values
    ux, uy = np.unique(xs), np.unique(ys)
    n = ds.sizes["element"]
    if ux.size * uy.size != n:
        raise ValueError(f"greens {_name(ds, 0)}: element centres x, y are not a full grid "
                         f"({ux.size} x {uy.size} != {n} elements)")
    diag = np.diagonal(ds["influence"].values)
    g = np.full((ux.size, uy.size), np.nan)
    g[np.searchsorted(ux, xs), np.searchsorted(uy, ys)] = diag
    return ux, uy, g


def _middle(n: int) -> list[int]:
    """Index (odd n) or the two indices (even n) of the middle of n elements."""
    return [n // 2] if n % 2 else [n // 2 - 1, n // 2]


def _centre_value(g: np.ndarray) -> float:
    """Mean g_ii of the block's central element(s) (1, 2 or 4 of them) [m/N]."""
    ix, iy = _middle(g.shape[0]), _middle(g.shape[1])
    return float(g[np.ix_(ix, iy)].mean())


def edge_profile(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """g_ii / g_centre along x through the block's middle row (the edge-softening cut).

    The middle row is the row of elements at the block's middle in y (the mean of the two middle rows when the
    block has an even number of elements across y; they are mirror images). g_centre is the mean g_ii of the
    block's central element(s).

    Parameters
    ----------
    ds : xarray.Dataset
        A pattern greens file (``influence`` [m/N], ``x``, ``y`` [m]).

    Returns
    -------
    position : numpy.ndarray
        Element centres along x from the block's centre [m].
    ratio : numpy.ndarray
        g_ii / g_centre [-] of those elements (1 at the centre; > 1 towards the free sides of an FE block).
    """
    x, _, g = compliance_grid(ds)
    row = g[:, _middle(g.shape[1])].mean(axis=1)
    return x - 0.5 * (x[0] + x[-1]), row / _centre_value(g)


def softening_ratios(ds: xr.Dataset) -> dict[str, float]:
    """The block's centre compliance and its edge and corner softening.

    Parameters
    ----------
    ds : xarray.Dataset
        A pattern greens file (``influence`` [m/N], ``x``, ``y`` [m]).

    Returns
    -------
    dict
        ``centre``: g_ii of the central element(s) [m/N]; ``edge``: g_ii / g_centre at the ends of the middle row
        along x (mean of both ends; the edge-centre elements) [-]; ``corner``: g_ii / g_centre of the four corner
        elements (mean) [-]. On the 20 mm FE block: 1.676 and 2.680 (docs/pattern.md).
    """
    _, _, g = compliance_grid(ds)
    centre = _centre_value(g)
    row = g[:, _middle(g.shape[1])].mean(axis=1)
    corners = g[np.ix_([0, -1], [0, -1])]
    return {"centre": centre, "edge": float(0.5 * (row[0] + row[-1]) / centre),
            "corner": float(corners.mean() / centre)}


def compliance_map_figure(greens_datasets: Sequence[xr.Dataset], path) -> Path:
    """The blocks' static self-compliance g_ii: a map per pattern and the cut through the middle row.

    Left: g_ii / g_centre of every element of the block, one panel per greens file on one colour scale, with
    g_centre [1e-5 m/N] and the edge and corner ratios in the panel's title. Right: g_ii / g_centre along x through
    the block's middle row against the position from the block centre [mm], one line per greens file
    (:func:`edge_profile`).

    Parameters
    ----------
    greens_datasets : sequence of xarray.Dataset
        Pattern greens files (``influence`` (element, source) [m/N], element centres ``x``, ``y`` [m]; attributes
        ``pattern``, ``material`` and ``influence_model`` label the panels when present).
    path : path-like
        PNG file to write.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        No datasets, or a dataset without ``influence``, ``x`` or ``y`` (e.g. the slick tread's greens file).
    """
    if not greens_datasets:
        raise ValueError("compliance_map_figure: no greens datasets given")
    for i, ds in enumerate(greens_datasets):
        _check(ds, _REQUIRED_GREENS, "compliance_map_figure", i)
    grids = [compliance_grid(ds) for ds in greens_datasets]
    ratios = [g / _centre_value(g) for _, _, g in grids]
    vmin = min(1.0, min(float(np.nanmin(r)) for r in ratios))
    vmax = max(vmin + 0.01, max(float(np.nanmax(r)) for r in ratios))  # a stand-in block is uniform: 1 everywhere
    materials = {str(ds.attrs.get("material", "")) for ds in greens_datasets}
    n = len(greens_datasets)
    fig, all_axes = plt.subplots(1, n + 1, figsize=(4.3 * n + 6.5, 4.9), layout="constrained",
                                 width_ratios=[1.0] * n + [1.45])
    axes, ax_cut = all_axes[:n], all_axes[n]
    image = None
    for i, (ds, (x, y, g), r) in enumerate(zip(greens_datasets, grids, ratios)):
        label = _name(ds, i) + (f" ({ds.attrs['material']})" if len(materials) > 1 and "material" in ds.attrs else "")
        s = softening_ratios(ds)
        h = float(ds.attrs.get("element_size", x[1] - x[0] if x.size > 1 else 1e-3))
        ax = axes[i]
        image = ax.imshow(r.T, origin="lower", cmap="viridis", vmin=vmin, vmax=vmax, interpolation="nearest",
                          extent=(_MM * (x[0] - h / 2), _MM * (x[-1] + h / 2), _MM * (y[0] - h / 2),
                                  _MM * (y[-1] + h / 2)))
        model = ds.attrs.get("influence_model")
        ax.set_title(f"{label}{f', {model}' if model else ''}\ng_centre = {s['centre'] * 1e5:.3f}e-5 m/N; "
                     f"edge {s['edge']:.3f}×, corner {s['corner']:.3f}×", fontsize=9.5)
        ax.set_xlabel("x from the block corner [mm]")
        ax.set_ylabel("y [mm]")
        pos, prof = edge_profile(ds)
        ax_cut.plot(_MM * pos, prof, "o-", ms=3.5, lw=1.4, color=f"C{i % 10}",
                    label=f"{label}: edge {s['edge']:.3f}×, centre {s['centre'] * 1e5:.3f}e-5 m/N")
    fig.colorbar(image, ax=list(axes), label="g_ii / g_centre [-]", shrink=0.8, location="left")
    fig.suptitle("Static self-compliance g_ii of the block's elements, normalised by the block centre's: "
                 "the edge softening of a block with free sides")
    ax_cut.axhline(1.0, color="0.4", lw=0.8, ls=":")
    ax_cut.set_xlabel("x from the block centre along its middle row [mm]")
    ax_cut.set_ylabel("g_ii / g_centre [-]")
    ax_cut.set_title("cut through the block's middle row (its free sides at the line ends)", fontsize=9.5)
    ax_cut.grid(True, alpha=0.3)
    # headroom for the legend (a line per pattern) above the highest point: a small block's edges lie mid-axis
    top = max(float(np.nanmax(edge_profile(ds)[1])) for ds in greens_datasets)
    ax_cut.set_ylim(min(0.98, vmin - 0.02), 1 + (top - 1) / (1 - min(0.5, 0.06 + 0.07 * n)) + 0.02)
    ax_cut.legend(fontsize=9, loc="upper center")
    return _save(fig, path)


def lowest_modes(ds: xr.Dataset) -> list[tuple[float, str]]:
    """The block's lowest natural frequency per symmetry class, equal ones merged (the rocking pair).

    Parameters
    ----------
    ds : xarray.Dataset
        A pattern K* file with ``natural_frequency`` (symmetry_class, mode) [Hz]; without it, [].

    Returns
    -------
    list of (float, str)
        (frequency [Hz], label) in ascending frequency, the label naming the mode kind and its classes.
    """
    if "natural_frequency" not in ds:
        return []
    nat = ds["natural_frequency"]
    found: list[tuple[float, list[str]]] = []
    for c in nat["symmetry_class"].values:
        f = float(np.nanmin(nat.sel(symmetry_class=c).values))
        for item in found:
            if np.isclose(item[0], f, rtol=1e-9):
                item[1].append(str(c))
                break
        else:
            found.append((f, [str(c)]))
    out = []
    for f, classes in sorted(found):
        kinds = {_MODE_KIND.get(c, "") for c in classes} - {""}
        kind = kinds.pop() if len(kinds) == 1 else ""
        out.append((f, (f"{kind} " if kind else "") + ("pair " if len(classes) > 1 else "")
                    + f"({' / '.join(classes)})"))
    return out


def pattern_spectrum_figure(spectra: Sequence[xr.Dataset], path) -> Path:
    """K′(f) and the loss factor η(f) of the contact on each pattern beside the slick tread's.

    Left: the storage stiffness K′ = Re K* [MN/m]; right: η = K″/K′ [-]; both against a log frequency axis, every
    preload of every file. Each pattern is a colour (solid); the slick tread of the same material and patch (the
    ``slick`` case every K* file carries) is black, dashed, drawn once per material. The block's lowest natural
    frequency of each symmetry class (``natural_frequency``, when the file stores it; undamped, at Re E(f)) is a
    dotted vertical line in the pattern's colour where it lies on the axis, and listed below the panels.

    Parameters
    ----------
    spectra : sequence of xarray.Dataset
        Pattern K* files (:func:`tyreroad.pattern_spectrum.pattern_stiffness_spectrum`): ``k_storage``,
        ``k_loss`` (case, preload, frequency) [N/m] with the cases ``<pattern>`` and ``slick``; attributes
        ``pattern`` and ``material``.
    path : path-like
        PNG file to write.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        No datasets, or one without ``k_storage``, ``k_loss``, ``case``, ``frequency`` or ``preload``, or without
        a ``slick`` case.
    """
    if not spectra:
        raise ValueError("pattern_spectrum_figure: no K* datasets given")
    for i, ds in enumerate(spectra):
        _check(ds, _REQUIRED_SPECTRUM, "pattern_spectrum_figure", i)
        if _SLICK not in [str(c) for c in ds["case"].values]:
            raise ValueError(f"pattern_spectrum_figure: dataset {_name(ds, i)} (#{i}) has no case 'slick' in "
                             f"'case' ({[str(c) for c in ds['case'].values]})")
    materials = [str(ds.attrs.get("material", "")) for ds in spectra]
    several_materials = len(set(materials)) > 1
    preloads = sorted({float(p) for ds in spectra for p in ds["preload"].values})
    fig, (ax_k, ax_eta) = plt.subplots(1, 2, figsize=(13, 5.6), layout="constrained")
    f_lo = min(float(ds["frequency"].values[0]) for ds in spectra)
    f_hi = max(float(ds["frequency"].values[-1]) for ds in spectra)
    slick_drawn: dict[tuple[str, float], tuple[np.ndarray, np.ndarray]] = {}
    notes = []
    p_styles = ["-", "-.", (0, (5, 1, 1, 1)), (0, (8, 2))]
    for i, ds in enumerate(spectra):
        name, material = _name(ds, i), materials[i]
        colour = f"C{i % 10}"
        cases = [str(c) for c in ds["case"].values]
        f = ds["frequency"].values
        for p, d0 in enumerate(ds["preload"].values):
            d0_label = f", d0 = {float(d0) * _MM:g} mm" if len(preloads) > 1 else ""
            for case in cases:
                is_slick = case == _SLICK
                k1 = ds["k_storage"].sel(case=case).isel(preload=p).values
                k2 = ds["k_loss"].sel(case=case).isel(preload=p).values
                who = f"{case} ({material})" if several_materials else case
                if is_slick:
                    # every K* file of a material carries the same slick case: drawn once, unless they differ
                    key = (material, float(d0))
                    seen = slick_drawn.get(key)
                    if seen is not None and seen[0].shape == f.shape and np.allclose(seen[0], f, rtol=1e-12) \
                            and np.allclose(seen[1], k1 + 1j * k2, rtol=1e-9, atol=0):
                        continue
                    if seen is not None:
                        who += f" (of the {name} file, differs)"
                    slick_drawn.setdefault(key, (f, k1 + 1j * k2))
                count = (f" ({int(ds['contact_count'].sel(case=case).isel(preload=p))} elements in contact)"
                         if "contact_count" in ds else "")
                style = ({"color": "k", "ls": "--"} if is_slick
                         else {"color": colour, "ls": p_styles[p % len(p_styles)]})
                ax_k.plot(f, k1 * _MN, lw=1.6, label=f"{who}{d0_label}{count}", **style)
                ax_eta.plot(f, k2 / k1, lw=1.6, **style)
        modes = lowest_modes(ds)
        for f_n, _ in modes:  # labelled below the panels: the modes of a block lie too close for labels here
            if f_lo <= f_n <= f_hi:
                for ax in (ax_k, ax_eta):
                    ax.axvline(f_n, color=colour, ls=":", lw=1.2)
        if modes:
            listed = ", ".join(f"{lab} {f_n / 1e3:.2f} kHz" + ("" if f_lo <= f_n <= f_hi else " (off the axis)")
                               for f_n, lab in modes)
            who = f"{name} ({material})" if several_materials else name
            notes.append(f"{who} ({_COLOUR_NAMES[i % 10]} dotted): lowest block modes {listed}")
    for ax in (ax_k, ax_eta):
        ax.set_xscale("log")
        ax.set_xlim(f_lo, f_hi)
        ax.set_xlabel("frequency [Hz]")
        ax.grid(True, which="both", alpha=0.3)
    ax_k.set_ylabel("storage stiffness K′ = Re K* [MN/m]")
    ax_k.set_ylim(bottom=0)
    ax_eta.set_ylabel("loss factor η = K″/K′ [-]")
    ax_eta.set_ylim(bottom=0)
    ax_k.set_title("contact storage stiffness", fontsize=10)
    ax_eta.set_title("contact loss factor", fontsize=10)
    ax_k.legend(fontsize=8.5, loc="upper left")
    d0_title = f" at d0 = {preloads[0] * _MM:g} mm" if len(preloads) == 1 else ""
    fig.suptitle(f"K*(f; d0) on the patterned tread (solid) beside the slick tread of the same patch (dashed){d0_title}"
                 "\nrelaxed preload state; dotted: the block's lowest natural frequencies (undamped, at Re E(f))",
                 fontsize=10.5)
    if notes:
        fig.supxlabel("\n".join(notes), fontsize=8, color="0.2")
    return _save(fig, path)
