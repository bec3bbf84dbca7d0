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
from matplotlib.lines import Line2D  # noqa: E402

from ..io import atomic_path  # noqa: E402

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


def plot_materials(datasets: list, path) -> Path:
    """SPEC fig 2: storage and loss modulus, and loss factor, against frequency per material.

    Materials with the same E(f) (e.g. the density variants of a material) would draw the same
    curve on top of each other: they are drawn once, labelled ``a = b = c (same curve)``.

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
    fig, (ax_e, ax_eta) = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    handles = []
    for n, group in enumerate(_groups(datasets, _same_material_curve)):
        ds = datasets[group[0]]
        f = ds["frequency"].values
        keep = f > 0
        e1 = ds["storage_modulus"].values[keep]
        eta = ds["loss_factor"].values[keep]
        colour = f"C{n}"
        label = _group_label(datasets, group)
        ax_e.loglog(f[keep], e1 / 1e6, color=colour)
        ax_e.loglog(f[keep], e1 * eta / 1e6, color=colour, ls="--")
        (h,) = ax_eta.semilogx(f[keep], eta, color=colour, label=label)
        handles.append(h)
    ax_e.set_xlabel("frequency [Hz]")
    ax_e.set_ylabel("modulus [MPa]")
    ax_e.set_title("storage E' (solid) and loss E'' (dashed) modulus")
    ax_e.grid(True, which="both", alpha=0.3)
    style = [Line2D([], [], color="0.3", label="E' (storage)"), Line2D([], [], color="0.3", ls="--", label="E'' (loss)")]
    ax_e.legend(handles=style + handles, labels=[h.get_label() for h in style + handles], fontsize=7)
    ax_eta.set_xlabel("frequency [Hz]")
    ax_eta.set_ylabel("loss factor η [-]")
    ax_eta.set_ylim(bottom=0)
    ax_eta.set_title("loss factor")
    ax_eta.grid(True, which="both", alpha=0.3)
    ax_eta.legend(fontsize=7)
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

    The quasi-static g (g(omega = 0) with the quasi-static modulus) is a horizontal line, drawn once
    per distinct value in black (dotted) and labelled with the materials it belongs to. A note says
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
    fig, ax = plt.subplots(figsize=(7.5, 5.0), constrained_layout=True)
    mags, freqs = [], None
    for i, ds in enumerate(datasets):
        f = ds["frequency"].values
        keep = f > 0
        mag = np.hypot(ds["frf_real"].values, ds["frf_imag"].values)[keep]
        ax.loglog(f[keep], mag, color=f"C{i}", label=_label(ds, i))
        if freqs is None or (freqs.shape == f[keep].shape and np.allclose(freqs, f[keep])):
            freqs = f[keep]
            mags.append(mag)
    statics = [float(ds["g_static"].sel(dx=0, dy=0)) for ds in datasets]
    styles = [":", "-.", (0, (1, 3))]
    for n, group in enumerate(_groups(list(range(len(datasets))), lambda a, b: np.isclose(statics[a], statics[b], rtol=1e-9))):
        names = [_label(datasets[i], i) for i in group]
        who = "all materials" if len(group) == len(datasets) and len(group) > 1 else ", ".join(names)
        ax.axhline(statics[group[0]], color="k", ls=styles[n % len(styles)], lw=1.2, label=f"quasi-static g ({who})")
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
    ax.legend(fontsize=7.5, loc="lower left", bbox_to_anchor=(0.0, 0.17))
    return _save(fig, path)
