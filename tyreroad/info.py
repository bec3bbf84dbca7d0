"""A short human summary of a tyreroad result file (``tyreroad info FILE``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from .io import is_text

__all__ = ["describe"]


def _range(values: np.ndarray, units: str) -> str:
    if values.size == 0:
        return "empty"
    if values.dtype.kind in "US O":
        shown = ", ".join(map(str, values[:6])) + (", ..." if values.size > 6 else "")
        return shown
    lo, hi = np.nanmin(values), np.nanmax(values)
    u = f" {units}" if units and units != "1" else ""
    return f"{lo:.4g}{u}" if values.size == 1 else f"{lo:.4g} .. {hi:.4g}{u} ({values.size} values)"


def describe(path: str | Path) -> str:
    """The file's stage, surface, material, code version, config hash and variables with units.

    Parameters
    ----------
    path : path-like
        A netCDF file written by the pipeline (:func:`tyreroad.io.write_dataset`).

    Returns
    -------
    str
        Several lines of text.

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    with xr.open_dataset(path) as ds:
        a = ds.attrs
        lines = [f"{path}"]
        for key, label in (("stage", "stage"), ("surface", "surface"), ("material", "material"),
                           ("materials", "materials"), ("tyreroad_version", "code version"),
                           ("created", "created")):
            if key in a:
                lines.append(f"  {label + ':':14s}{a[key]}")
        if "config_sha256" in a:
            lines.append(f"  {'config hash:':14s}{str(a['config_sha256'])[:16]} (SHA-256 of the config stored "
                         "in the attribute 'config')")
        if not any(k in a for k in ("stage", "tyreroad_version")):
            lines.append("  (no tyreroad provenance attributes: not written by the pipeline?)")
        lines.append("  dimensions:   " + ", ".join(f"{d} = {n}" for d, n in ds.sizes.items()))
        lines.append("  coordinates:")
        for name, var in ds.coords.items():
            units = str(var.attrs.get("units", ""))
            lines.append(f"    {name:28s} [{units}]  {_range(np.asarray(var.values), units)}")
        lines.append("  variables:")
        for name, var in ds.data_vars.items():
            units = str(var.attrs.get("units", "" if is_text(var) else "?"))  # labels: no units
            dims = ", ".join(var.dims)
            lines.append(f"    {name:28s} [{units}]  ({dims})  {var.attrs.get('long_name', '')}")
    return "\n".join(lines)
