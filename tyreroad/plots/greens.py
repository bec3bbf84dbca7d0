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
from matplotlib.ticker import FormatStrFormatter  # noqa: E402

from . import save_png  # noqa: E402

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


def _save(fig, path) -> Path:
    return save_png(fig, path, logger)


def _groups(datasets, same) -> list[list[int]]:
    """Indices of the datasets grouped by ``same(a, b)`` (first member first), in input order."""
    groups: list[list[int]] = []
    for i, ds in enumerate(datasets):
        for g in groups:
            if same(datasets[g[0]], ds):
                g.append(i)
                break
        else:
            groups.append([i])
    return groups


def _same_material_curve(a, b) -> bool:
    """Equal E'(f) and eta(f) (to round-off): the curves would hide each other."""
    if a["frequency"].shape != b["frequency"].shape or not np.allclose(a["frequency"], b["frequency"]):
        return False
    return bool(np.allclose(a["storage_modulus"], b["storage_modulus"], rtol=1e-9, atol=0)
                and np.allclose(a["loss_factor"], b["loss_factor"], rtol=1e-9, atol=0))


def _group_label(datasets, group) -> str:
    names = [_label(datasets[i], i) for i in group]
    if len(names) == 1:
        return names[0]
    return " = ".join(names) + " (same curve)"


#: Line styles cycled per material (with the colour), so that crossing or close curves stay apart.
_LINESTYLES = ["-", "--", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (8, 2))]


def _material_style(n: int) -> dict:
    """Colour and line style of the n-th material (or group of identical materials)."""
    return {"color": f"C{n % 10}", "ls": _LINESTYLES[n % len(_LINESTYLES)]}


def plot_materials(datasets: list, path) -> Path:
    """SPEC fig 2: storage modulus, loss modulus and loss factor against frequency per material.

    One panel each for E', E'' and eta; every material has its own colour and line style, and the
    legend sits below the panels (outside the axes), so that added compounds neither hide each
    other nor disappear behind the legend. Materials with the same E(f) (e.g. the density
    variants of a material) would draw the same curve on top of each other: they are drawn once,
    labelled ``a = b = c (same curve)``.

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
    fig, (ax_e1, ax_e2, ax_eta) = plt.subplots(1, 3, figsize=(13, 4.8), layout="constrained")
    handles = []
    for n, group in enumerate(_groups(datasets, _same_material_curve)):
        ds = datasets[group[0]]
        f = ds["frequency"].values
        keep = f > 0
        e1 = ds["storage_modulus"].values[keep]
        eta = ds["loss_factor"].values[keep]
        style = _material_style(n)
        label = _group_label(datasets, group)
        ax_e1.loglog(f[keep], e1 / 1e6, lw=1.6, **style)
        ax_e2.loglog(f[keep], e1 * eta / 1e6, lw=1.6, **style)
        (h,) = ax_eta.semilogx(f[keep], eta, lw=1.6, label=label, **style)
        handles.append(h)
    for ax, title, ylabel in ((ax_e1, "storage modulus E'", "E' [MPa]"), (ax_e2, "loss modulus E''", "E'' [MPa]"),
                              (ax_eta, "loss factor η = E''/E'", "η [-]")):
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    for ax in (ax_e1, ax_e2):  # plain numbers (40, 60, 100), not 4 x 10^1, on the log modulus axes
        ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
        ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
    ax_eta.set_ylim(bottom=0)
    fig.legend(handles=handles, labels=[h.get_label() for h in handles], loc="outside lower center",
               ncol=min(3, len(handles)), fontsize=9, frameon=False)
    return _save(fig, path)


def _coincide_below(freqs, mags, rel=0.01) -> float | None:
    """Highest frequency below which all |g| curves agree within ``rel`` (None if they never do)."""
    mags = np.asarray(mags)
    spread = (mags.max(axis=0) - mags.min(axis=0)) / mags.max(axis=0)
    bad = np.flatnonzero(spread > rel)
    if bad.size == 0:
        return float(freqs[-1])
    return float(freqs[bad[0] - 1]) if bad[0] > 0 else None


def plot_frf(datasets: list, path) -> Path:
    """SPEC fig 3: |g| at the excitation element against frequency, with the quasi-static value.

    Every material has its own colour and line style; the legend sits outside the axes (right).
    The quasi-static g (g(omega = 0) with the quasi-static modulus) is a horizontal dotted line,
    drawn once per distinct value in the colour of its first material (black when one value
    stands for all) and labelled with the materials it belongs to. A note says
    below which frequency the material curves coincide, and why the quasi-static level lies above
    the lowest FRF sample: with the default quasi-static modulus E(omega -> 0) the material is
    still creeping below the first frequency sample (fractional model), so |g(f_1)| < g_static.

    Parameters
    ----------
    datasets : list of xarray.Dataset
        Green's function datasets with ``frf_real``, ``frf_imag`` [m/N] over ``frequency`` [Hz]
        and ``g_static[dx, dy]`` [m/N]; optional attribute ``quasi_static_modulus`` [Pa].
    path : path-like
        PNG file to write.

    Returns
    -------
    pathlib.Path
    """
    _check(datasets, _REQUIRED_FRF, "plot_frf")
    fig, ax = plt.subplots(figsize=(11, 5.2), layout="constrained")
    mags, freqs = [], None
    for i, ds in enumerate(datasets):
        f = ds["frequency"].values
        keep = f > 0
        mag = np.hypot(ds["frf_real"].values, ds["frf_imag"].values)[keep]
        ax.loglog(f[keep], mag, lw=1.5, label=_label(ds, i), **_material_style(i))
        if freqs is None or (freqs.shape == f[keep].shape and np.allclose(freqs, f[keep])):
            freqs = f[keep]
            mags.append(mag)
    statics = [float(ds["g_static"].sel(dx=0, dy=0)) for ds in datasets]
    static_groups = _groups(list(range(len(datasets))), lambda a, b: np.isclose(statics[a], statics[b], rtol=1e-9))
    for group in static_groups:
        names = [_label(datasets[i], i) for i in group]
        who = "all materials" if len(group) == len(datasets) and len(group) > 1 else ", ".join(names)
        # dotted, in the colour of its (first) material; black when it stands for all of them
        colour = "k" if len(static_groups) == 1 else _material_style(group[0])["color"]
        ax.axhline(statics[group[0]], color=colour, ls=":", lw=1.4, label=f"quasi-static g ({who})")
    notes = []
    if len(mags) == len(datasets) and len(datasets) > 1:
        below = _coincide_below(freqs, mags)
        if below is not None:
            notes.append(f"material curves coincide (within 1 %) below {below:.0f} Hz")
    ds0 = datasets[0]
    f0 = freqs[0]
    ratio = mags[0][0] / statics[0]
    if ratio < 1:
        e_qs = ds0.attrs.get("quasi_static_modulus")
        e1 = np.interp(f0, ds0["frequency"].values, ds0["storage_modulus"].values) if "storage_modulus" in ds0 else None
        text = f"at {f0:g} Hz |g| = {ratio:.2f} × quasi-static g"
        if e_qs is not None and e1 is not None:
            text += (f": the quasi-static modulus is E(ω→0) = {float(e_qs) / 1e6:.0f} MPa,\n"
                     f"E' at {f0:g} Hz is already {e1 / 1e6:.0f} MPa (the material still creeps below {f0:g} Hz)")
        notes.append(text)
    if notes:
        ax.text(0.02, 0.03, "\n".join(notes), transform=ax.transAxes, fontsize=7.5, va="bottom",
                bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "0.7"})
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|g| at the excitation element [m/N]")
    ax.set_title("element receptance |g(f)| and quasi-static g")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_ylim(top=1.2 * max(statics))
    ax.legend(fontsize=9, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    return _save(fig, path)
