"""Writing and reading tyreroad's netCDF files with provenance.

Every file the pipeline writes goes through :func:`write_dataset`, which

* checks that every data variable and coordinate carries ``units`` and ``long_name`` (text
  variables, such as material or case labels, only ``long_name``: CF gives labels no units, and
  the writer drops a ``units`` attribute from them),
* adds the global provenance attributes required by the specification (tyreroad version,
  the config section that made the file as YAML text and its SHA-256 hash, creation time),
* compresses the variables, and
* writes atomically: the data go to a temporary file in the target directory which is renamed
  onto the target only after a complete, successful write. A failed job therefore never leaves a
  partial or stale-looking result file behind.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import logging
import math
import os
import tempfile
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import numpy as np
import xarray as xr
import yaml

logger = logging.getLogger(__name__)

__all__ = [
    "code_version",
    "config_yaml",
    "config_hash",
    "provenance_attrs",
    "check_metadata",
    "is_text",
    "level_attrs",
    "assign_compound_coords",
    "unstack_compounds",
    "write_dataset",
    "read_dataset",
    "atomic_path",
]


def code_version() -> str:
    """Return the installed tyreroad version (``"unknown"`` when not installed)."""
    try:
        return version("tyreroad")
    except PackageNotFoundError:  # pragma: no cover - only when run from a bare source tree
        return "unknown"


def _plain(obj: Any) -> Any:
    """Convert numpy scalars/arrays and tuples into plain YAML-safe Python objects."""
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def config_yaml(section: Mapping[str, Any] | None) -> str:
    """Serialise a config section as canonical YAML text (sorted keys)."""
    return yaml.safe_dump(_plain(section or {}), sort_keys=True, default_flow_style=False)


def config_hash(section: Mapping[str, Any] | None) -> str:
    """SHA-256 hex digest of the canonical YAML text of a config section."""
    return hashlib.sha256(config_yaml(section).encode()).hexdigest()


def provenance_attrs(section: Mapping[str, Any] | None, **extra: Any) -> dict[str, str]:
    """Global attributes recording which code and which config made a file.

    Parameters
    ----------
    section : mapping
        The config section(s) that determined the file's content.
    **extra
        Further attributes (e.g. ``stage="greens"``); values are stored as strings.
    """
    attrs = {
        "tyreroad_version": code_version(),
        "config": config_yaml(section),
        "config_sha256": config_hash(section),
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "Conventions": "CF-1.8",
    }
    attrs.update({k: str(v) for k, v in extra.items()})
    return attrs


def is_text(var: xr.DataArray | xr.Variable) -> bool:
    """True for a variable of strings (labels): CF gives such variables no ``units``."""
    kind = var.dtype.kind
    if kind in "US":
        return True
    if kind == "O":
        values = np.asarray(var.values).ravel()
        return values.size > 0 and all(isinstance(v, (str, bytes)) for v in values)
    return False


def level_attrs(long_name: str, reference: float, reference_units: str) -> dict[str, Any]:
    """CF-valid attributes of a level in decibels, 10 log10(P / P_ref) or 20 log10(a / a_ref).

    UDUNITS-2 (which CF-1.8 units must parse in) knows no ``dB``, and "dB re 1e-6 m" is no unit:
    a level is dimensionless, so ``units="1"``; the long name says "dB re <reference>", and the
    attributes ``level_units="dB"``, ``reference_value`` and ``reference_value_units`` state the
    reference in a form a program can read.

    Parameters
    ----------
    long_name : str
        What the level is of.
    reference : float
        The reference value of the level (e.g. 1e-6 for a texture level re 1 um).
    reference_units : str
        UDUNITS units of the reference (e.g. "m").
    """
    ref = f"{reference:g}"
    if "e" in ref:  # 1e-06 -> 1e-6
        mantissa, exponent = ref.split("e")
        ref = f"{mantissa}e{int(exponent)}"
    return {"units": "1", "long_name": f"{long_name} [dB re {ref} {reference_units}]",
            "level_units": "dB", "reference_value": float(reference), "reference_value_units": reference_units}


def assign_compound_coords(ds: xr.Dataset, compounds: Mapping[str, Sequence[Any]], dim: str) -> xr.Dataset:
    """``ds`` with the coordinates ``compound`` and ``temperature`` along ``dim``, from its ``material``.

    They make temperature a dimension of the study: :func:`unstack_compounds` gives compound x temperature
    arrays. ``ds.set_index(material=["compound", "temperature"]).unstack("material")`` does the same for
    materials that all have a temperature; with a NaN temperature among them it silently puts values in the
    wrong cells (xarray 2026.9 / pandas 3.1: a NaN index level), which :func:`unstack_compounds` avoids.

    Parameters
    ----------
    ds : xarray.Dataset
        A dataset with a ``material`` coordinate along ``dim`` (material preset names).
    compounds : mapping
        Material preset name -> ``(compound, temperature)``: the base compound's name and the
        temperature [degC] the material runs at, None or NaN for a material without one
        (:func:`tyreroad.material.compound_and_temperature`).
    dim : str
        The dimension the ``material`` coordinate lies along (``material`` or ``case``).

    Returns
    -------
    xarray.Dataset
        A new dataset; ``temperature`` [degC] (CF ``units: degC``) is NaN where a material has none.

    Raises
    ------
    ValueError
        A material of ``ds`` missing from ``compounds`` (named).
    """
    names = [str(m) for m in np.atleast_1d(ds["material"].values)]
    missing = sorted(set(names) - set(compounds))
    if missing:
        raise ValueError(f"no compound and temperature for the material(s) {', '.join(missing)} "
                         f"(known: {', '.join(sorted(compounds))})")
    compound = [str(compounds[m][0]) for m in names]
    temperature = np.array([math.nan if compounds[m][1] is None else float(compounds[m][1]) for m in names])
    return ds.assign_coords(
        compound=(dim, compound, {"long_name": "tread compound: the material preset, or for a temperature "
                                               "variant <name>-T<T> the preset <name>"}),
        temperature=(dim, temperature, {"units": "degC",
                                        "long_name": "temperature the compound is run at (NaN: no temperature, "
                                                     "the material has no master-curve reference)"}),
    )


def unstack_compounds(ds: xr.Dataset, dim: str = "material", extra: Sequence[str] = ()) -> xr.Dataset:
    """Unstack ``dim`` into the dimensions ``compound`` and ``temperature`` [degC] (and ``extra``).

    Materials without a temperature sit at ``temperature`` NaN (the first label); select them with
    ``isel(temperature=0)`` or ``isnull()``, not ``sel(temperature=nan)``. Equivalent to
    ``ds.set_index({dim: ["compound", "temperature", *extra]}).unstack(dim)``, which misplaces the values
    of NaN-temperature materials (the NaN is replaced by -inf for the unstacking and restored after).

    Parameters
    ----------
    ds : xarray.Dataset
        A study file (``dim = "case"``, usually with ``extra = ("mode", "accel")`` or one mode selected)
        or a combined K* file (``dim = "material"``), with the coordinates of :func:`assign_compound_coords`.
    dim : str
        The dimension to unstack.
    extra : sequence of str
        Further coordinates along ``dim`` that become dimensions.

    Returns
    -------
    xarray.Dataset
        Missing combinations are NaN.
    """
    t = np.asarray(ds["temperature"].values, dtype=float)
    attrs = dict(ds["temperature"].attrs)
    marked = ds.assign_coords(temperature=(dim, np.where(np.isnan(t), -np.inf, t), attrs))
    out = marked.set_index({dim: ["compound", "temperature", *extra]}).unstack(dim)
    labels = np.asarray(out["temperature"].values, dtype=float)
    return out.assign_coords(temperature=("temperature", np.where(np.isneginf(labels), np.nan, labels), attrs))


def check_metadata(ds: xr.Dataset) -> None:
    """Raise ``ValueError`` naming every variable that lacks ``units`` or ``long_name``.

    Dimensionless quantities must say so with ``units="1"``; text (label) variables need only a
    ``long_name``.
    """
    missing = []
    for name, var in {**ds.data_vars, **ds.coords}.items():
        for key in ("long_name",) if is_text(var) else ("units", "long_name"):
            if key not in var.attrs:
                missing.append(f"{name}.{key}")
    if missing:
        raise ValueError("dataset variables lack required metadata: " + ", ".join(sorted(missing)))


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; rename it onto ``path`` only on success.

    The temporary name keeps the suffix of ``path`` (writers such as matplotlib infer the format
    from it).

    On any exception the temporary file is removed and ``path`` is left untouched
    (an existing file is neither overwritten nor deleted).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes the file private (0600); give the result the permissions of a normally
        # created file (0666 minus the umask) so colleagues on a shared file system can read it.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp_path, 0o666 & ~umask)
        os.replace(tmp_path, path)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def _encoding(ds: xr.Dataset) -> dict[str, dict[str, Any]]:
    enc: dict[str, dict[str, Any]] = {}
    for name, var in ds.data_vars.items():
        if var.dtype.kind in "fiub" and var.ndim > 0:
            enc[name] = {"zlib": True, "complevel": 4}
    return enc


def write_dataset(
    ds: xr.Dataset,
    path: str | os.PathLike,
    config_section: Mapping[str, Any] | None,
    **extra_attrs: Any,
) -> Path:
    """Write ``ds`` to netCDF at ``path`` with provenance, compression and an atomic rename.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset whose variables and coordinates all carry ``units`` and ``long_name``.
    path : path-like
        Target file (``.nc``). Parent directories are created.
    config_section : mapping
        Config that made the file; stored as YAML text with its SHA-256 hash.
    **extra_attrs
        Further global attributes.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    check_metadata(ds)
    ds = ds.copy()
    for name in [*ds.data_vars, *ds.coords]:
        if is_text(ds[name].variable) and "units" in ds[name].attrs:  # CF: labels carry no units
            ds[name].attrs = {k: v for k, v in ds[name].attrs.items() if k != "units"}
    ds.attrs.update(provenance_attrs(config_section, **extra_attrs))
    # complex variables are not representable in classic netCDF: callers store re/im parts.
    for name, var in ds.data_vars.items():
        if np.iscomplexobj(var.values):
            raise TypeError(f"variable {name!r} is complex; store real and imaginary parts separately")
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", encoding=_encoding(ds))
    logger.info("wrote %s", path)
    return Path(path)


def read_dataset(path: str | os.PathLike, variables: Sequence[str] | None = None) -> xr.Dataset:
    """Load a tyreroad netCDF file fully into memory and close it.

    Parameters
    ----------
    path : path-like
        The file.
    variables : sequence of str, optional
        Load only these data variables (with their coordinates and the file's attributes); the
        default loads all. A 150 x 200 springs file's ``area`` table alone is 229 MiB, which the
        contact solver never reads.

    Raises
    ------
    FileNotFoundError
        With the path in the message when the file does not exist.
    KeyError
        Naming the file and the variables it lacks.
    """
    path = Path(path)
    if isinstance(variables, str):
        raise TypeError(f"read_dataset({path}): variables must be a sequence of names, got the string {variables!r}")
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such tyreroad result file")
    with xr.open_dataset(path, engine="netcdf4") as ds:
        if variables is None:
            return ds.load()
        missing = [v for v in variables if v not in ds.data_vars]
        if missing:
            raise KeyError(f"{path}: no variable(s) {', '.join(missing)} (has {', '.join(map(str, ds.data_vars))})")
        return ds[list(variables)].load()
