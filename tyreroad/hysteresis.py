"""Hysteresis of load-unload cycles: dissipated energy, loading work and the study of loading runs (SPEC 10).

A cycle loads the tread to d_max, holds, and unloads until every element has separated; the
delayed recovery of the visco-elastic layer makes the unloading force lower than the loading
force at the same indentation. The energy the tread dissipates over the closed path is

    W = closed integral of F dd = sum_n (F[n] + F[n-1]) / 2 (d[n] - d[n-1])   [J]

(trapezoid on the native steps; the path starts and ends without contact, so it closes). W >= 0
for a passive tread; a quasi-static run has no rate dependence and gives W = 0 to round-off.

The report's section on the cycles is :func:`tyreroad.report.hysteresis_section`.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Iterable

import numpy as np
import xarray as xr

from . import io

logger = logging.getLogger(__name__)

__all__ = ["dissipated_energy", "loading_work", "aggregate_loading"]


def dissipated_energy(indentation, force) -> float:
    """W = closed integral of F dd over the whole path [J] (trapezoid on the samples).

    Parameters
    ----------
    indentation : array_like
        d[n] [m] along the path.
    force : array_like
        Total force F[n] [N].
    """
    d = np.asarray(indentation, dtype=float)
    f = np.asarray(force, dtype=float)
    if d.shape != f.shape or d.ndim != 1 or d.size < 2:
        raise ValueError(f"dissipated_energy: expected two 1-D series of equal length >= 2, got {d.shape} and {f.shape}")
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(d)))


def loading_work(indentation, force) -> float:
    """Work done on the tread while the indentation increases, sum over steps with d[n] > d[n-1] [J]."""
    d = np.asarray(indentation, dtype=float)
    f = np.asarray(force, dtype=float)
    dd = np.diff(d)
    return float(np.sum(np.where(dd > 0, 0.5 * (f[1:] + f[:-1]) * dd, 0.0)))


def aggregate_loading(runs: Iterable[xr.Dataset | str | Path]) -> xr.Dataset:
    """``results/loading.nc``: per loading run (case) W, loading work, peak force and the loop itself.

    Returns
    -------
    xarray.Dataset
        dims (case, sample); coords material, mode, loading per case; variables
        dissipated_energy, loading_work, loss_ratio (W over loading work), peak_force, and the
        native loop ``loop_indentation``/``loop_force`` [case, sample] (NaN-padded).
    """
    datasets = [io.read_dataset(r) if not isinstance(r, xr.Dataset) else r for r in runs]
    if not datasets:
        raise ValueError("aggregate_loading: no loading runs given")
    labels, cols = [], {k: [] for k in ("material", "mode", "loading", "kind")}
    w, work, peak, loops = [], [], [], []
    for ds in datasets:
        for key in ("material", "mode", "loading"):
            if key not in ds.attrs:
                raise ValueError(f"aggregate_loading: a loading run lacks the attribute {key!r}")
        cols["material"].append(ds.attrs["material"])
        cols["mode"].append(ds.attrs["mode"])
        cols["loading"].append(ds.attrs["loading"])
        cols["kind"].append(ds.attrs.get("loading_kind", ""))
        labels.append(f"{ds.attrs['material']}/{ds.attrs['mode']}/{ds.attrs['loading']}")
        d = ds["indentation"].values
        f = ds["force"].values
        w.append(float(ds["dissipated_energy"]) if "dissipated_energy" in ds else dissipated_energy(d, f))
        work.append(float(ds["loading_work"]) if "loading_work" in ds else loading_work(d, f))
        peak.append(float(np.max(f)))
        loops.append((d, f))
    n = max(d.size for d, _ in loops)
    loop_d = np.full((len(loops), n), np.nan)
    loop_f = np.full((len(loops), n), np.nan)
    for i, (d, f) in enumerate(loops):
        loop_d[i, : d.size] = d
        loop_f[i, : f.size] = f
    w, work = np.asarray(w), np.asarray(work)
    ratio = np.divide(w, work, out=np.full_like(w, np.nan), where=work > 0)
    for label, wi, ri in zip(labels, w, ratio):
        logger.info("%s: W = %.4e J (%.4f of the loading work)", label, wi, ri)
    return xr.Dataset(
        {
            "dissipated_energy": ("case", w, {"units": "J", "long_name": "dissipated energy W over the cycle"}),
            "loading_work": ("case", work, {"units": "J", "long_name": "work done while loading"}),
            "loss_ratio": ("case", ratio, {"units": "1", "long_name": "W over the loading work"}),
            "peak_force": ("case", np.asarray(peak), {"units": "N", "long_name": "largest total contact force"}),
            "loop_indentation": (("case", "sample"), loop_d, {"units": "m", "long_name": "indentation d along the path"}),
            "loop_force": (("case", "sample"), loop_f, {"units": "N", "long_name": "total contact force along the path"}),
        },
        coords={
            "case": ("case", labels, {"units": "1", "long_name": "material/mode/loading"}),
            **{k: ("case", v, {"units": "1", "long_name": f"{k} of the run"}) for k, v in cols.items()},
        },
    )

