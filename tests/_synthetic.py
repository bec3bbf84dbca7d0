"""Synthetic contact runs following the contact-dataset contract, for the study and report tests.

The force F(d) and the contact fraction are prescribed functions of the indentation, so K(d),
K_sat and every claim's measured number are known in closed form.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import xarray as xr

DT = 1.0 / 51200.0  # s, the study's time step


def synthetic_run(material, mode, accel, force_fn, fraction_fn=None, backing_scale=1.0, surface="synth",
                  d_max=2.5e-4, qs_step=1e-6, overshoot=True, shape=(4, 5)):
    """A contact dataset (docs/data_contracts.md 'Contact dataset') with a prescribed F(d) and contact fraction.

    Dynamic runs sample d = a t^2/2 at t_n = n DT up to the first step with d >= d_max
    (``overshoot=False``: the last step below d_max); quasi-static runs step d uniformly by
    ``qs_step``. The total force is spread evenly over the ``shape`` elements.
    """
    n_ex, n_ey = shape
    if mode == "quasistatic":
        d = np.arange(round(d_max / qs_step) + 1) * qs_step
        time = None
    else:
        n_t = math.sqrt(2 * d_max / accel) / DT
        n = math.ceil(n_t) if overshoot else math.floor(n_t)
        time = np.arange(n + 1) * DT
        d = 0.5 * accel * time**2
    n_el = n_ex * n_ey
    if fraction_fn is None:
        fraction_fn = lambda x: 1.0 - np.exp(-x / 5e-5)  # noqa: E731
    force = force_fn(d)
    count = np.round(fraction_fn(d) * n_el)
    coords = {
        "step": ("step", np.arange(d.size), {"units": "1", "long_name": "step"}),
        "indentation": ("step", d, {"units": "m", "long_name": "indentation"}),
        "ex": ("ex", np.arange(n_ex), {"units": "1", "long_name": "element x index"}),
        "ey": ("ey", np.arange(n_ey), {"units": "1", "long_name": "element y index"}),
    }
    if time is not None:
        coords["time"] = ("step", time, {"units": "s", "long_name": "time"})
    per_el = np.broadcast_to((force / n_el)[:, None, None], (d.size, n_ex, n_ey)).copy()
    data = {
        "force": ("step", force, {"units": "N", "long_name": "total force"}),
        "backing_force": ("step", backing_scale * force, {"units": "N", "long_name": "backing force"}),
        "contact_count": ("step", count, {"units": "1", "long_name": "contact count"}),
        "element_force": (("step", "ex", "ey"), per_el, {"units": "N", "long_name": "element force"}),
        "compression": (("step", "ex", "ey"), np.zeros_like(per_el), {"units": "m", "long_name": "zeta"}),
        "displacement": (("step", "ex", "ey"), np.zeros_like(per_el), {"units": "m", "long_name": "w"}),
        "newton_iterations": ("step", np.full(d.size, 3), {"units": "1", "long_name": "iterations"}),
        "residual": ("step", np.full(d.size, 1e-14), {"units": "m", "long_name": "residual"}),
    }
    attrs = {"mode": mode, "acceleration": float(accel), "material": material, "surface": surface}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def append_unloading(run, hold_steps=5, unload_steps=40, recovery=0.6):
    """A copy of ``run`` continued by a hold at its last indentation and an unloading back to d = 0.

    The continuation is a load-unload cycle as a cycle path would write it (SPEC 10): the force
    relaxes during the hold and follows a lower unloading curve (``recovery`` times the loading
    force at the same d), so F is not a function of d on the whole path. The time axis (dynamic
    runs) continues with the run's step.
    """
    d = run["indentation"].values
    f = run["force"].values
    d_top = d[-1]
    d_new = np.concatenate([np.full(hold_steps, d_top), np.linspace(d_top, 0.0, unload_steps + 1)[1:]])
    f_new = recovery * np.interp(d_new, d, f)
    n_old, n_add = d.size, d_new.size
    out = {}
    for name, var in run.data_vars.items():
        v = var.values
        if name == "force" or name == "backing_force":
            scale = v[-1] / f[-1] if f[-1] else 1.0
            add = scale * f_new
        elif name == "contact_count":
            add = np.round(np.interp(d_new, d, v) * recovery)
        else:
            add = np.repeat(v[-1:], n_add, axis=0)
        out[name] = (var.dims, np.concatenate([v, add], axis=0), var.attrs)
    coords = {
        "step": ("step", np.arange(n_old + n_add), run["step"].attrs),
        "indentation": ("step", np.concatenate([d, d_new]), run["indentation"].attrs),
        "ex": run["ex"],
        "ey": run["ey"],
    }
    if "time" in run.coords:
        t = run["time"].values
        coords["time"] = ("step", np.concatenate([t, t[-1] + (t[1] - t[0]) * np.arange(1, n_add + 1)]), run["time"].attrs)
    return xr.Dataset(out, coords=coords, attrs=dict(run.attrs))


REPO = Path(__file__).resolve().parents[1]


def copy_workflow(dest, items=("Snakefile", "workflow", "config")) -> Path:
    """Copy the repository's workflow pieces ``items`` into ``dest`` (created) for a Snakemake run there."""
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    for item in items:
        src = REPO / item
        (shutil.copytree if src.is_dir() else shutil.copy)(src, dest / item)
    return dest


def capture_figures(monkeypatch, *modules) -> list:
    """Replace the figure modules' ``_save`` by one that keeps the figure and writes nothing; the kept figures."""
    figs = []

    def keep(fig, path):
        figs.append(fig)
        return path

    for module in modules:
        monkeypatch.setattr(module, "_save", keep)
    return figs
