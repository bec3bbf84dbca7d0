"""Synthetic contact runs following the contact-dataset contract, for the study and report tests.

The force F(d) and the contact fraction are prescribed functions of the indentation, so K(d),
K_sat and every claim's measured number are known in closed form.
"""

from __future__ import annotations

import math

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
