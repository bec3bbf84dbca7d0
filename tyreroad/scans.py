"""Reading measured road scans (SPEC section 3, generator ``file``).

A scan is a 2-D grid of heights, indexed ``[x, y]``, with a uniform step in x and y. After reading,
heights are converted to metres (config ``height_unit``; m, mm, um, nm or pm), optionally cropped
to a window (``crop: {origin: [x0, y0], size: [sx, sy]}`` in m, before gap filling), checked (no
NaN or missing samples unless ``fill_gaps: true``, a plausible step), plane-detrended by least
squares (``detrend: plane``), checked for a plausible peak-to-valley height range
(:data:`PV_RANGE`: a flat scan or heights in the wrong unit are errors that name the suspected
unit), and finally resampled by bilinear interpolation onto the element grid of
``element_size / samples_per_element`` (see :func:`to_element_grid`).

:func:`check_scan_header` is the cheap check of the planning step (``snakemake -n``): the file
exists, is not empty, and its header (shape, step, unit) is readable and consistent with the
preset, without reading the heights.

Supported formats (``format``, or inferred from the file suffix):

``npy`` (``.npy``)
    A 2-D array ``[x, y]`` of heights. ``step`` [m] from config (scalar or ``[dx, dy]``).
``netcdf`` (``.nc``, ``.nc4``, ``.cdf``)
    The 2-D data variable named by ``variable`` (default: the only 2-D variable). The first
    dimension is x unless the dimensions are called ``x`` and ``y``. The step comes from 1-D
    coordinates of the two dimensions (which must be uniform; their ``units`` attribute, or the
    ``unit`` attribute SurfaceTopography writes, else ``lateral_unit``) or, without coordinates,
    from ``step``. If the variable has a ``units`` (or ``unit``) attribute, it must agree with
    ``height_unit``.
``text`` (``.csv``, ``.txt``, ``.asc``, ``.dat``)
    A plain grid: one line per y (first line y = 0), one column per x, delimiter detected
    (comma, semicolon, tab or white space), ``#`` starts a comment, an empty field is a missing
    sample. ``step`` from config. ESRI ASCII grids (``ncols ... cellsize ... NODATA_value``
    header) are recognised: the step is ``cellsize`` (in ``lateral_unit``), NODATA samples are
    missing, and the first line is the largest y (north-up).
``xyz`` (``.xyz``)
    Three columns x, y, z (delimiter detected; coordinates in ``lateral_unit``) of points on a
    regular grid, in any order. The grid is checked: uniform spacing in x and in y, every (x, y)
    at most once; grid nodes without a point are missing samples.
``instrument`` (``.x3p``, ``.sdf``, ``.sur``, ``.plu``, ``.datx``, ``.opd``, ``.al3d``, ...)
    Read through SurfaceTopography (optional extra ``tyreroad[scans]``); heights and sizes in the
    file's own unit, converted to m. A file that states no unit needs ``height_unit`` and
    ``lateral_unit`` in the preset; a unit tyreroad does not know is an error.
"""

from __future__ import annotations

import csv
import logging
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import xarray as xr
from scipy import ndimage
from scipy.interpolate import LinearNDInterpolator, RegularGridInterpolator

logger = logging.getLogger(__name__)

__all__ = [
    "FILE_KEYS",
    "UNIT_SCALE",
    "ScanSpec",
    "Scan",
    "ScanError",
    "scan_spec_from_config",
    "read_scan",
    "read_raw",
    "check_scan_header",
    "crop_window",
    "largest_valid_window",
    "plane_detrend",
    "fill_gaps",
    "to_element_grid",
]

#: Metres per unit for ``height_unit`` and ``lateral_unit``.
UNIT_SCALE = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "nm": 1e-9, "pm": 1e-12}
_UNIT_ALIASES = {
    "m": "m", "meter": "m", "metre": "m", "meters": "m", "metres": "m",
    "mm": "mm", "millimeter": "mm", "millimetre": "mm", "millimeters": "mm", "millimetres": "mm",
    "um": "um", "µm": "um", "μm": "um", "micrometer": "um", "micrometre": "um", "micron": "um",
    "micrometers": "um", "micrometres": "um", "microns": "um",
    "nm": "nm", "nanometer": "nm", "nanometre": "nm", "nanometers": "nm", "nanometres": "nm",
    "pm": "pm", "picometer": "pm", "picometre": "pm", "picometers": "pm", "picometres": "pm",
}
#: Plausible peak-to-valley range of the (detrended) heights of a road scan [m]: below 20 um the
#: scan is flat or in too small a unit, above 50 mm it is in too large a unit (or not a road).
PV_RANGE = (20e-6, 50e-3)
#: Plausible range of the scan step after unit conversion [m].
STEP_RANGE = (1e-7, 5e-3)
#: Relative tolerance for a step to count as uniform / equal to another step.
STEP_RTOL = 1e-6

#: Keys of a ``generator: file`` preset with their defaults (None: required or optional).
FILE_KEYS: dict[str, Any] = {
    "path": None,
    "format": None,
    "step": None,
    "height_unit": "m",
    "lateral_unit": "m",
    "variable": None,
    "fill_gaps": False,
    "detrend": "plane",
    "crop": None,
}

_SUFFIX_FORMAT = {
    ".npy": "npy",
    ".nc": "netcdf", ".nc4": "netcdf", ".cdf": "netcdf", ".netcdf": "netcdf",
    ".csv": "text", ".txt": "text", ".asc": "text", ".dat": "text",
    ".xyz": "xyz",
}
_INSTRUMENT_SUFFIXES = {".x3p", ".sdf", ".sur", ".plu", ".datx", ".opd", ".al3d", ".di", ".ibw", ".mi",
                        ".gwy", ".frt", ".ezd", ".zon", ".plux", ".lext", ".vk4", ".vk6", ".os3d", ".wsxm"}


class ScanError(ValueError):
    """Bad scan file or settings; the message names the file and the problem."""


@dataclass(frozen=True)
class ScanSpec:
    """Validated settings of a ``generator: file`` preset.

    Attributes
    ----------
    path : pathlib.Path
        Scan file (relative paths resolved against the preset's base directory).
    format : str or None
        ``npy``, ``netcdf``, ``text``, ``xyz`` or ``instrument``; None: from the suffix.
    step : tuple of float or None
        Sample step ``(dx, dy)`` [m] for formats that do not carry it.
    height_unit : str
        Unit of the heights in the file: ``m``, ``mm`` or ``um``.
    lateral_unit : str
        Unit of coordinates stored in the file (xyz, ESRI cellsize, netCDF coords without units).
    variable : str or None
        netCDF variable name.
    fill_gaps : bool
        Fill missing samples by linear interpolation (with a warning) instead of failing.
    detrend : str
        ``plane`` (least-squares plane removed) or ``none``.
    crop : tuple or None
        ``((x0, y0), (sx, sy))`` [m]: window of the scan kept before gap filling; the first kept
        sample is the one nearest ``(x0, y0)`` from the scan's first sample, and the window holds
        ``round(sx / dx) x round(sy / dy)`` samples. None: the whole scan.
    units_given : bool
        Whether ``height_unit``/``lateral_unit`` were set in the preset (used for instrument
        files that state no unit).
    """

    path: Path
    format: str | None = None
    step: tuple[float, float] | None = None
    height_unit: str = "m"
    lateral_unit: str = "m"
    variable: str | None = None
    fill_gaps: bool = False
    detrend: str = "plane"
    crop: tuple[tuple[float, float], tuple[float, float]] | None = None
    units_given: bool = False

    def __post_init__(self) -> None:
        if self.format is not None and self.format not in ("npy", "netcdf", "text", "xyz", "instrument"):
            raise ValueError(f"format must be npy|netcdf|text|xyz|instrument, got {self.format!r}")
        if self.height_unit not in UNIT_SCALE:
            raise ValueError(f"height_unit must be one of {sorted(UNIT_SCALE)}, got {self.height_unit!r}")
        if self.lateral_unit not in UNIT_SCALE:
            raise ValueError(f"lateral_unit must be one of {sorted(UNIT_SCALE)}, got {self.lateral_unit!r}")
        if self.step is not None and (len(self.step) != 2 or not all(np.isfinite(s) and s > 0 for s in self.step)):
            raise ValueError(f"step must be a positive length in m or [dx, dy], got {self.step!r}")
        if self.detrend not in ("plane", "none"):
            raise ValueError(f"detrend must be 'plane' or 'none', got {self.detrend!r}")
        if not isinstance(self.fill_gaps, bool):
            raise ValueError(f"fill_gaps must be true or false, got {self.fill_gaps!r}")
        if self.crop is not None:
            (x0, y0), (sx, sy) = self.crop
            if not (min(x0, y0) >= 0 and min(sx, sy) > 0 and all(map(math.isfinite, (x0, y0, sx, sy)))):
                raise ValueError(
                    f"crop must be {{origin: [x0, y0], size: [sx, sy]}} with origin >= 0 and size > 0 [m], "
                    f"got origin {[x0, y0]}, size {[sx, sy]}"
                )


@dataclass(frozen=True)
class Scan:
    """A scan after reading, unit conversion, checks, gap filling and detrending.

    Attributes
    ----------
    path : pathlib.Path
        Source file.
    height : numpy.ndarray
        Heights [m], ``[x, y]``; sample ``(i, j)`` at ``(i dx, j dy)``.
    step : tuple of float
        ``(dx, dy)`` [m].
    filled : int
        Number of missing samples filled by interpolation.
    """

    path: Path
    height: np.ndarray
    step: tuple[float, float]
    filled: int = 0

    @property
    def extent(self) -> tuple[float, float]:
        """Distance from the first to the last sample in x and y [m]."""
        return ((self.height.shape[0] - 1) * self.step[0], (self.height.shape[1] - 1) * self.step[1])


def _unit(value: Any, where: str) -> str:
    key = str(value).strip()
    unit = _UNIT_ALIASES.get(key, _UNIT_ALIASES.get(key.lower()))
    if unit is None:
        raise ScanError(f"{where}: unknown length unit {value!r} (expected one of {', '.join(UNIT_SCALE)})")
    return unit


def scan_spec_from_config(name: str, spec: Mapping, common_keys: Mapping = ()) -> ScanSpec:
    """Validate a ``generator: file`` preset and build its :class:`ScanSpec`.

    Parameters
    ----------
    name : str
        Preset name, for error messages (``surfaces.<name>.<key>``).
    spec : mapping
        The preset.
    common_keys : iterable of str
        Keys shared by all generators (ignored here).

    Returns
    -------
    ScanSpec
    """
    for key in spec:
        if key not in FILE_KEYS and key not in common_keys:
            raise ValueError(
                f"surfaces.{name}.{key}: unknown key for generator 'file' "
                f"(allowed: {sorted(set(common_keys) | set(FILE_KEYS))})"
            )
    path = spec.get("path")
    if not isinstance(path, str) or not path:
        raise ValueError(f"surfaces.{name}.path: expected the scan file path, got {path!r}")
    step = spec.get("step")
    if step is not None:
        if isinstance(step, (int, float)) and not isinstance(step, bool):
            step = (float(step), float(step))
        elif isinstance(step, (list, tuple)) and len(step) == 2:
            step = (float(step[0]), float(step[1]))
        else:
            raise ValueError(f"surfaces.{name}.step: expected a length in m or [dx, dy], got {step!r}")
    crop = spec.get("crop")
    if crop is not None:
        ok = isinstance(crop, Mapping) and set(crop) == {"origin", "size"}
        ok = ok and all(isinstance(crop[k], (list, tuple)) and len(crop[k]) == 2 for k in ("origin", "size"))
        if not ok:
            raise ValueError(f"surfaces.{name}.crop: expected {{origin: [x0, y0], size: [sx, sy]}} in m, got {crop!r}")
        crop = (tuple(float(v) for v in crop["origin"]), tuple(float(v) for v in crop["size"]))
    kwargs = {k: spec.get(k, v) for k, v in FILE_KEYS.items() if k not in ("path", "step", "crop")}
    units_given = "height_unit" in spec or "lateral_unit" in spec
    try:
        return ScanSpec(path=Path(path), step=step, crop=crop, units_given=units_given, **kwargs)
    except ValueError as exc:
        key = next((k for k in FILE_KEYS if str(exc).startswith(k)), None)
        raise ValueError(f"surfaces.{name}.{key or ''}: {exc}".replace(f"{name}.:", f"{name}:")) from None


# ---------------------------------------------------------------------------------------------
# Format readers: return (raw heights [x, y] in the file's height unit, step (dx, dy) in m or None)
# ---------------------------------------------------------------------------------------------
def _npy_header(path: Path) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype from the header of a .npy file (the data are not read)."""
    try:
        with path.open("rb") as fh:
            version = np.lib.format.read_magic(fh)
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, _, dtype = read(fh)
    except Exception as exc:  # ValueError for a bad magic string, EOFError/OSError for a short file
        raise ScanError(f"{path}: not a readable .npy array ({type(exc).__name__}: {exc})") from None
    if len(shape) != 2:
        raise ScanError(f"{path}: expected a 2-D height array [x, y], got shape {shape}")
    if dtype.kind not in "fiu":
        raise ScanError(f"{path}: expected numeric heights, got dtype {dtype}")
    return shape, dtype


def _read_npy(path: Path, spec: ScanSpec):
    _npy_header(path)
    try:
        arr = np.load(path, allow_pickle=False)
    except Exception as exc:  # a truncated file
        raise ScanError(f"{path}: not a readable .npy array ({type(exc).__name__}: {exc})") from None
    return arr.astype(float), None


def _uniform_step(coord: np.ndarray, path: Path, axis: str) -> float:
    c = np.asarray(coord, dtype=float)
    if c.size < 2:
        raise ScanError(f"{path}: fewer than two samples along {axis}")
    d = np.diff(c)
    step = float(np.mean(d))
    if step <= 0 or np.max(np.abs(d - step)) > STEP_RTOL * abs(step) + 1e-15:
        raise ScanError(
            f"{path}: non-uniform step along {axis} (steps from {d.min():.9g} to {d.max():.9g}; "
            f"expected a regular grid)"
        )
    return step


def _attr_unit(attrs: Mapping) -> Any:
    """The ``units`` attribute, or ``unit`` as SurfaceTopography writes it; None if neither."""
    return attrs.get("units", attrs.get("unit"))


def _read_netcdf(path: Path, spec: ScanSpec, header_only: bool = False):
    try:
        ds = xr.open_dataset(path)
    except Exception as exc:  # netCDF4 raises various types for a corrupt file
        raise ScanError(f"{path}: cannot read as netCDF ({exc})") from None
    with ds:
        if spec.variable is not None:
            if spec.variable not in ds.data_vars:
                raise ScanError(f"{path}: no variable {spec.variable!r} (has {sorted(ds.data_vars)})")
            var = ds[spec.variable]
        else:
            cands = [v for v in ds.data_vars if ds[v].ndim == 2]
            if len(cands) != 1:
                raise ScanError(f"{path}: set 'variable'; 2-D variables found: {cands}")
            var = ds[cands[0]]
        if var.ndim != 2:
            raise ScanError(f"{path}: variable {var.name!r} is not 2-D (dims {var.dims})")
        if set(var.dims) == {"x", "y"}:
            var = var.transpose("x", "y")
        units = _attr_unit(var.attrs)
        if units is not None:
            file_unit = _unit(units, f"{path}: variable {var.name!r} units")
            if file_unit != spec.height_unit:
                raise ScanError(
                    f"{path}: variable {var.name!r} has units {units!r} but height_unit is "
                    f"{spec.height_unit!r}; make them agree"
                )
        steps = []
        for dim, axis in zip(var.dims, ("x", "y")):
            if dim in var.coords and var.coords[dim].ndim == 1:
                coord = var.coords[dim]
                cu = _attr_unit(coord.attrs)
                unit = _unit(cu, f"{path}: coordinate {dim!r} units") if cu else spec.lateral_unit
                scale = UNIT_SCALE[unit]
                steps.append(_uniform_step(coord.values, path, axis) * scale)
            else:
                steps.append(None)
        heights = tuple(var.shape) if header_only else np.asarray(var.values, dtype=float)
    if None in steps:
        if steps != [None, None]:
            raise ScanError(f"{path}: only one of the dimensions {var.dims} has a coordinate")
        return heights, None
    if spec.step is not None and not np.allclose(steps, spec.step, rtol=STEP_RTOL):
        raise ScanError(f"{path}: step {steps} m from the coordinates disagrees with config step {list(spec.step)} m")
    return heights, tuple(steps)


_ESRI_KEYS = {"ncols", "nrows", "xllcorner", "yllcorner", "xllcenter", "yllcenter", "cellsize", "nodata_value",
              "dx", "dy"}


def _sniff_delimiter(lines: list[str]) -> str | None:
    sample = "\n".join(lines[:20])
    for delim in (",", ";", "\t"):
        if delim in sample:
            return delim
    return None  # white space


def _data_lines(path: Path) -> list[str]:
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise ScanError(f"{path}: not a text file") from None
    return [ln.split("#", 1)[0].rstrip() for ln in text.splitlines()]


def _parse_rows(rows: list[str], delim: str | None, path: Path, first_line: int) -> np.ndarray:
    """Parse numeric rows; empty fields become NaN; rows must all have the same length."""
    try:  # fast path (C parser) for complete grids
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            return np.atleast_2d(np.loadtxt(rows, delimiter=delim, dtype=float, ndmin=2))
    except (ValueError, UserWarning):
        pass
    out = []
    for k, line in enumerate(rows):
        fields = next(csv.reader([line], delimiter=delim)) if delim else line.split()
        try:
            out.append([float(f) if f.strip() else np.nan for f in fields])
        except ValueError as exc:
            raise ScanError(f"{path}: line {first_line + k + 1}: {exc}") from None
    lengths = {len(r) for r in out}
    if len(lengths) != 1:
        raise ScanError(f"{path}: rows have different numbers of values {sorted(lengths)} (missing samples?)")
    return np.asarray(out, dtype=float)


def _read_text(path: Path, spec: ScanSpec):
    lines = _data_lines(path)
    header: dict[str, float] = {}
    start = 0
    for start, line in enumerate(lines):
        if not line.strip():
            continue
        parts = line.split()
        if len(parts) == 2 and parts[0].lower() in _ESRI_KEYS:
            header[parts[0].lower()] = float(parts[1])
            continue
        break
    else:
        start = len(lines)
    rows = [ln for ln in lines[start:] if ln.strip()]
    if not rows:
        raise ScanError(f"{path}: no data rows")
    grid = _parse_rows(rows, _sniff_delimiter(rows), path, start)
    step = None
    if header:
        if "ncols" not in header or "nrows" not in header:
            raise ScanError(f"{path}: ESRI ASCII header lacks ncols/nrows")
        if grid.shape != (int(header["nrows"]), int(header["ncols"])):
            raise ScanError(
                f"{path}: header says {int(header['nrows'])} x {int(header['ncols'])} (rows x cols), "
                f"data have {grid.shape[0]} x {grid.shape[1]} (missing samples?)"
            )
        if "nodata_value" in header:
            grid[grid == header["nodata_value"]] = np.nan
        grid = grid[::-1]  # ESRI grids are north-up: first line is the largest y
        scale = UNIT_SCALE[spec.lateral_unit]
        if "cellsize" in header:
            step = (header["cellsize"] * scale,) * 2
        elif "dx" in header and "dy" in header:
            step = (header["dx"] * scale, header["dy"] * scale)
        if step is not None and spec.step is not None and not np.allclose(step, spec.step, rtol=STEP_RTOL):
            raise ScanError(f"{path}: cell size {list(step)} m disagrees with config step {list(spec.step)} m")
    return grid.T.copy(), step


def _lattice(values: np.ndarray, path: Path, axis: str) -> tuple[float, np.ndarray]:
    """Step and integer index of coordinates that must lie on a regular lattice (rows may be absent)."""
    vals = np.unique(values)
    if vals.size < 2:
        raise ScanError(f"{path}: fewer than two distinct {axis} values")
    d = np.diff(vals)
    k = np.round((vals - vals[0]) / d.min())
    step = (vals[-1] - vals[0]) / k[-1]
    # Coordinates written with a few digits are off the lattice by rounding only; a real
    # non-uniform grid is off by a sizeable part of a step.
    off = np.abs(vals - vals[0] - k * step)
    if off.max() > 1e-3 * step:
        raise ScanError(
            f"{path}: non-uniform {axis} step (spacings from {d.min():.9g} to {d.max():.9g}, "
            f"a point lies {off.max() / step:.3g} steps off the regular grid); expected points on a regular grid"
        )
    return float(step), np.round((values - vals[0]) / step).astype(np.int64)


def _read_xyz(path: Path, spec: ScanSpec):
    lines = [ln for ln in _data_lines(path) if ln.strip()]
    if not lines:
        raise ScanError(f"{path}: no data rows")
    delim = _sniff_delimiter(lines[1:] or lines)
    first = next(csv.reader([lines[0]], delimiter=delim)) if delim else lines[0].split()
    try:
        [float(f) for f in first]
    except ValueError:
        lines = lines[1:]  # a column header
    pts = _parse_rows(lines, delim, path, 0)
    if pts.shape[1] != 3:
        raise ScanError(f"{path}: expected 3 columns x, y, z, got {pts.shape[1]}")
    if not np.all(np.isfinite(pts[:, :2])):
        raise ScanError(f"{path}: NaN or missing x/y coordinates")
    scale = UNIT_SCALE[spec.lateral_unit]
    (sx, ix), (sy, iy) = _lattice(pts[:, 0], path, "x"), _lattice(pts[:, 1], path, "y")
    steps = (sx * scale, sy * scale)
    nx, ny = int(ix.max()) + 1, int(iy.max()) + 1
    flat = ix * ny + iy
    if np.unique(flat).size != flat.size:
        raise ScanError(f"{path}: some (x, y) points occur more than once")
    grid = np.full((nx, ny), np.nan)
    grid.ravel()[flat] = pts[:, 2]
    if spec.step is not None and not np.allclose(steps, spec.step, rtol=1e-3):
        raise ScanError(
            f"{path}: step {list(steps)} m from the coordinates disagrees with config step {list(spec.step)} m"
        )
    return grid, steps


def _surface_topography():
    try:
        import SurfaceTopography
    except ImportError:
        return None
    return SurfaceTopography


def _instrument_units(path: Path, unit: Any, spec: ScanSpec) -> tuple[float, float]:
    """(height scale, lateral scale) in m per file unit for an instrument file stating ``unit``."""
    if unit is None:
        if not spec.units_given:
            raise ScanError(
                f"{path}: the file states no length unit; set height_unit and lateral_unit in the preset"
            )
        return UNIT_SCALE[spec.height_unit], UNIT_SCALE[spec.lateral_unit]
    scale = UNIT_SCALE[_unit(unit, f"{path}: file unit")]
    return scale, scale


def _read_instrument(path: Path, spec: ScanSpec, header_only: bool = False):
    st = _surface_topography()
    if st is None:
        raise ImportError(
            f"{path}: instrument formats need SurfaceTopography; install it with: pip install \"tyreroad[scans]\""
        )
    try:
        reader = st.open_topography(str(path))
        channel = reader.default_channel
        nb, sizes, unit = channel.nb_grid_pts, channel.physical_sizes, channel.unit
        topo = None if header_only else reader.topography()
    except Exception as exc:  # the readers raise many exception types
        raise ScanError(f"{path}: SurfaceTopography could not read the file ({type(exc).__name__}: {exc})") from None
    if topo is not None:
        nb, sizes, unit = topo.nb_grid_pts, topo.physical_sizes, topo.unit
        if topo.dim != 2 or not topo.is_uniform:
            raise ScanError(f"{path}: expected a uniform 2-D topography, got dim={topo.dim}, uniform={topo.is_uniform}")
    if nb is None or len(nb) != 2 or sizes is None:
        raise ScanError(f"{path}: expected a 2-D topography with physical sizes, got grid {nb}, sizes {sizes}")
    h_scale, l_scale = _instrument_units(path, unit, spec)
    (nx, ny), (sx, sy) = nb, sizes
    step = (float(sx) / nx * l_scale, float(sy) / ny * l_scale)
    if header_only:
        return (int(nx), int(ny)), step
    h = np.ma.filled(np.ma.asarray(topo.heights(), dtype=float), np.nan)
    # read_scan multiplies by height_unit's scale; the file's own unit decides here.
    return h * h_scale / UNIT_SCALE[spec.height_unit], step


_READERS = {"npy": _read_npy, "netcdf": _read_netcdf, "text": _read_text, "xyz": _read_xyz,
            "instrument": _read_instrument}


def _format_of(path: Path, spec: ScanSpec) -> str:
    if spec.format is not None:
        return spec.format
    suffix = path.suffix.lower()
    if suffix in _SUFFIX_FORMAT:
        return _SUFFIX_FORMAT[suffix]
    if suffix in _INSTRUMENT_SUFFIXES:
        return "instrument"
    raise ScanError(f"{path}: cannot infer the scan format from the suffix {suffix!r}; set 'format'")


def _resolve(spec: ScanSpec, base_dir: str | Path) -> tuple[Path, str]:
    """The file's path (checked to exist and not to be empty) and its format."""
    path = spec.path if spec.path.is_absolute() else Path(base_dir) / spec.path
    if not path.is_file():
        raise FileNotFoundError(f"{path}: scan file not found")
    if path.stat().st_size == 0:
        raise ScanError(f"{path}: the scan file is empty (0 bytes)")
    return path, _format_of(path, spec)


def _check_step(path: Path, step) -> None:
    for s, axis in zip(step, "xy"):
        if not STEP_RANGE[0] <= s <= STEP_RANGE[1]:
            raise ScanError(
                f"{path}: step {s:.6g} m along {axis} is implausible for a road scan "
                f"(expected {STEP_RANGE[0]:g}..{STEP_RANGE[1]:g} m; wrong units?)"
            )


def check_scan_header(spec: ScanSpec, base_dir: str | Path = ".") -> dict[str, Any]:
    """Cheap planning-time check of a scan file: exists, not empty, header readable and consistent.

    Reads only the header where the format has one (npy, netCDF, instrument formats); for text
    and xyz files it checks that the file is text with numeric data in its first lines.

    Returns
    -------
    dict
        ``path`` (resolved), ``format``, ``shape`` (samples in x and y, or None when only a full
        read would tell), ``step`` ((dx, dy) [m], or None when unknown before a full read).

    Raises
    ------
    FileNotFoundError, ScanError, ImportError
        Naming the file.
    """
    path, fmt = _resolve(spec, base_dir)
    shape = step = None
    try:
        if fmt == "npy":
            shape = _npy_header(path)[0]
        elif fmt == "netcdf":
            shape, step = _read_netcdf(path, spec, header_only=True)
        elif fmt == "instrument":
            shape, step = _read_instrument(path, spec, header_only=True)
        else:
            with path.open("rb") as fh:
                head = fh.read(65536)
            try:
                text = head.decode()
            except UnicodeDecodeError as exc:
                if exc.start < len(head) - 4:  # not just a multi-byte character cut at the end
                    raise ScanError(f"{path}: not a text file") from None
                text = head[: exc.start].decode()
            lines = [ln.split("#", 1)[0].strip() for ln in text.splitlines()[:-1] or text.splitlines()]
            rows = [ln for ln in lines if ln and ln.split()[0].lower() not in _ESRI_KEYS]
            if not rows:
                raise ScanError(f"{path}: no data rows")
            fields = [f for f in re.split(r"[,;\s]+", rows[-1]) if f]
            try:
                [float(f) for f in fields]
            except ValueError:
                raise ScanError(f"{path}: line {rows[-1][:60]!r} is not numeric data") from None
    except (ScanError, ImportError):
        raise
    except Exception as exc:
        raise ScanError(f"{path}: cannot read as a {fmt} scan ({type(exc).__name__}: {exc})") from None
    if step is None:
        step = spec.step
    if step is not None:
        _check_step(path, step)
    if shape is not None and min(shape) < 2:
        raise ScanError(f"{path}: scan of shape {tuple(shape)} has fewer than two samples along an axis")
    if shape is not None and step is not None and spec.crop is not None:
        crop_window(shape, step, spec.crop, path)
    return {"path": path, "format": fmt, "shape": None if shape is None else tuple(int(v) for v in shape),
            "step": None if step is None else (float(step[0]), float(step[1]))}


def read_raw(spec: ScanSpec, base_dir: str | Path = ".") -> tuple[Path, np.ndarray, tuple[float, float]]:
    """Read a scan file as it is: heights in the file's ``height_unit`` and the step in m.

    Returns
    -------
    path : pathlib.Path
        Resolved file path.
    height : numpy.ndarray
        Raw heights ``[x, y]`` (may contain NaN for missing samples).
    step : tuple of float
        ``(dx, dy)`` [m].
    """
    path, fmt = _resolve(spec, base_dir)
    logger.info("reading %s scan %s", fmt, path)
    try:
        height, step = _READERS[fmt](path, spec)
    except (ScanError, ImportError):
        raise
    except Exception as exc:  # any other failure of a reader: name the file
        raise ScanError(f"{path}: cannot read as a {fmt} scan ({type(exc).__name__}: {exc})") from None
    if step is None:
        if spec.step is None:
            raise ScanError(f"{path}: the {fmt} file does not carry the sample step; set 'step' [m] in the config")
        step = spec.step
    _check_step(path, step)
    if min(height.shape) < 2:
        raise ScanError(f"{path}: scan of shape {height.shape} has fewer than two samples along an axis")
    return path, height, (float(step[0]), float(step[1]))


def read_scan(spec: ScanSpec, base_dir: str | Path = ".") -> Scan:
    """Read, convert to m, crop, check, optionally fill gaps, and detrend a scan.

    Parameters
    ----------
    spec : ScanSpec
        File and settings.
    base_dir : path-like
        Directory for relative paths.

    Returns
    -------
    Scan

    Raises
    ------
    FileNotFoundError
        The file does not exist (message names the path).
    ScanError
        An empty or unreadable file, NaN or missing samples (without ``fill_gaps``; at the border
        the message suggests the largest NaN-free crop window), infinite values, non-uniform
        step, a crop window outside the scan, a flat scan or a height range implausible for a
        road in the given unit (the message names the suspected unit); the message names the file.
    ImportError
        Instrument format without SurfaceTopography installed.
    """
    path, raw, step = read_raw(spec, base_dir)
    h = raw * UNIT_SCALE[spec.height_unit]
    if spec.crop is not None:
        (i0, j0), (ni, nj) = crop_window(h.shape, step, spec.crop, path)
        logger.info("%s: cropped to samples [%d:%d, %d:%d] of %s", path, i0, i0 + ni, j0, j0 + nj, list(h.shape))
        h = h[i0 : i0 + ni, j0 : j0 + nj]
    if np.any(np.isinf(h)):
        raise ScanError(f"{path}: {int(np.isinf(h).sum())} infinite height values")
    missing = np.isnan(h)
    n_missing = int(missing.sum())
    if n_missing == h.size:
        raise ScanError(f"{path}: all samples are missing")
    if n_missing:
        if not spec.fill_gaps:
            raise ScanError(
                f"{path}: {n_missing} NaN or missing samples of {h.size}; set 'fill_gaps: true' to fill "
                f"them by linear interpolation{_crop_hint(missing, step, spec)}"
            )
        try:
            h = fill_gaps(h, path)
        except ScanError as exc:
            raise ScanError(f"{exc}{_crop_hint(missing, step, spec)}") from None
        logger.warning("%s: filled %d missing samples (%.2f %%) by linear interpolation", path, n_missing,
                       100.0 * n_missing / h.size)
    magnitude = float(np.max(np.abs(h)))
    if spec.detrend == "plane":
        h = plane_detrend(h)
    _check_height_range(path, h, spec.height_unit, magnitude)
    return Scan(path=path, height=h, step=step, filled=n_missing)


def _check_height_range(path: Path, h: np.ndarray, height_unit: str, magnitude: float = 0.0) -> None:
    """Peak-to-valley range of the heights [m] against :data:`PV_RANGE`; names the suspected unit.

    ``magnitude`` is the largest absolute height before detrending: a range within round-off of
    it (1e-9 relative) means a flat (or exactly planar) scan.
    """
    pv = float(np.max(h) - np.min(h))
    lo, hi = PV_RANGE
    if pv <= 1e-9 * magnitude or pv == 0.0:
        raise ScanError(
            f"{path}: the scan is flat (all heights equal, or on one plane, to round-off); expected a road texture"
        )
    if lo <= pv <= hi:
        return
    declared = UNIT_SCALE[height_unit]
    # the unit u that would bring the range closest to 1 mm (the middle of the plausible range, in log)
    fits = {u: pv * scale / declared for u, scale in UNIT_SCALE.items() if u != height_unit}
    fits = {u: v for u, v in fits.items() if lo <= v <= hi}
    hint = ""
    if fits:
        best = min(fits, key=lambda u: abs(math.log10(fits[u] / 1e-3)))
        hint = f"; the file's heights look like {best} (set height_unit: {best}, giving {fits[best] * 1e3:.3g} mm)"
    raise ScanError(
        f"{path}: heights span {pv:.3g} m peak to valley with height_unit {height_unit!r}; a road patch "
        f"spans {lo * 1e6:g} um to {hi * 1e3:g} mm{hint}"
    )


def crop_window(shape, step, crop, path: str | Path = "scan") -> tuple[tuple[int, int], tuple[int, int]]:
    """Sample window of a crop ``((x0, y0), (sx, sy))`` [m] in a scan of ``shape`` at ``step``.

    The first kept sample is the one nearest ``(x0, y0)`` (measured from the scan's first
    sample); the window holds ``round(sx / dx) x round(sy / dy)`` samples.

    Returns
    -------
    (i0, j0), (ni, nj) : tuple of int
        First sample and number of samples in x and y.

    Raises
    ------
    ScanError
        The window is empty or extends beyond the scan.
    """
    (x0, y0), (sx, sy) = crop
    dx, dy = step
    i0, j0 = int(round(x0 / dx)), int(round(y0 / dy))
    ni, nj = int(round(sx / dx)), int(round(sy / dy))
    nx, ny = int(shape[0]), int(shape[1])
    if ni < 2 or nj < 2 or i0 + ni > nx or j0 + nj > ny:
        raise ScanError(
            f"{path}: crop window origin [{x0:g}, {y0:g}] m, size [{sx:g}, {sy:g}] m (samples [{i0}:{i0 + ni}, "
            f"{j0}:{j0 + nj}]) does not lie inside the scan of {nx} x {ny} samples "
            f"({nx * dx:.6g} x {ny * dy:.6g} m at step [{dx:.6g}, {dy:.6g}] m)"
        )
    return (i0, j0), (ni, nj)


def largest_valid_window(valid: np.ndarray) -> tuple[tuple[int, int], tuple[int, int]]:
    """Largest axis-parallel window (most samples) in which every sample is valid.

    The maximal-rectangle algorithm on column histograms, O(nx ny). Grids above 4 million
    samples are first reduced by blocks (a block is valid only if all its samples are), so the
    window found is valid but may be a little smaller than the largest one.

    Parameters
    ----------
    valid : numpy.ndarray of bool
        ``[x, y]`` mask of valid samples.

    Returns
    -------
    (i0, j0), (ni, nj) : tuple of int
        First sample and size of the window (``(0, 0), (0, 0)`` if no sample is valid).
    """
    v = np.asarray(valid, dtype=bool)
    b = max(1, math.ceil(math.sqrt(v.size / 4e6)))
    if b > 1:
        nx, ny = (v.shape[0] // b) * b, (v.shape[1] // b) * b
        v = v[:nx, :ny].reshape(nx // b, b, ny // b, b).all(axis=(1, 3))
    nx, ny = v.shape
    height = np.zeros(ny + 1, dtype=np.int64)  # sentinel column of height 0
    best = (0, 0, 0, 0, 0)  # area, i0, j0, ni, nj
    for i in range(nx):
        height[:ny] = np.where(v[i], height[:ny] + 1, 0)
        stack: list[int] = []
        hs = height.tolist()
        for j in range(ny + 1):
            while stack and hs[stack[-1]] >= hs[j]:
                top = stack.pop()
                width = j - (stack[-1] + 1 if stack else 0)
                area = hs[top] * width
                if area > best[0]:
                    best = (area, i - hs[top] + 1, (stack[-1] + 1 if stack else 0), hs[top], width)
            stack.append(j)
    _, i0, j0, ni, nj = best
    return (i0 * b, j0 * b), (ni * b, nj * b)


def _crop_hint(missing: np.ndarray, step, spec: ScanSpec) -> str:
    """Suggest the largest NaN-free crop window when missing samples touch the border."""
    border = missing[0].any() or missing[-1].any() or missing[:, 0].any() or missing[:, -1].any()
    if not border:
        return ""
    (i0, j0), (ni, nj) = largest_valid_window(~missing)
    if ni < 2 or nj < 2:
        return ""
    off = (0, 0) if spec.crop is None else crop_window(
        (10**12, 10**12), step, spec.crop)[0]  # offset of the current crop in the file
    dx, dy = step
    x0, y0 = (off[0] + i0) * dx, (off[1] + j0) * dy
    return (
        f". Missing samples lie on the scan border; the largest NaN-free window is "
        f"crop: {{origin: [{x0:.6g}, {y0:.6g}], size: [{ni * dx:.6g}, {nj * dy:.6g}]}} "
        f"({ni} x {nj} samples)"
    )


def plane_detrend(height: np.ndarray) -> np.ndarray:
    """Subtract the least-squares plane ``a + b i + c j`` from a full grid.

    On a complete rectangular grid the centred index coordinates are orthogonal, so the
    least-squares coefficients are the separate projections; the result has zero mean and zero
    correlation with either coordinate. (The step does not matter for the residual.)

    Parameters
    ----------
    height : numpy.ndarray
        Heights ``[x, y]`` without NaN.

    Returns
    -------
    numpy.ndarray
        Detrended heights (a new array).
    """
    h = np.asarray(height, dtype=float)
    if h.ndim != 2 or np.isnan(h).any():
        raise ValueError("plane_detrend: need a complete 2-D grid without NaN")
    nx, ny = h.shape
    ti = np.arange(nx) - 0.5 * (nx - 1)
    tj = np.arange(ny) - 0.5 * (ny - 1)
    a = h.mean()
    b = (ti @ h.sum(axis=1)) / (ny * (ti @ ti)) if nx > 1 else 0.0
    c = (h.sum(axis=0) @ tj) / (nx * (tj @ tj)) if ny > 1 else 0.0
    return h - a - b * ti[:, None] - c * tj[None, :]


def fill_gaps(height: np.ndarray, path: str | Path = "scan") -> np.ndarray:
    """Fill NaN samples by linear (Delaunay) interpolation from the valid samples around each gap.

    Each connected gap is filled from the valid samples in its bounding box widened by two
    samples, which keeps the triangulation small for large scans. A gap that is not enclosed by
    valid samples (at the scan border) cannot be interpolated and raises.

    Parameters
    ----------
    height : numpy.ndarray
        Heights ``[x, y]`` with NaN for missing samples.
    path : path-like
        File name for error messages.

    Returns
    -------
    numpy.ndarray
        Filled heights (a new array).
    """
    h = np.array(height, dtype=float)
    missing = np.isnan(h)
    labels, count = ndimage.label(missing)
    for k, sl in enumerate(ndimage.find_objects(labels), start=1):
        box = tuple(slice(max(0, s.start - 2), min(n, s.stop + 2)) for s, n in zip(sl, h.shape))
        sub = h[box]
        valid = ~np.isnan(sub)
        gi, gj = np.nonzero(valid)
        hole = labels[box] == k
        hi, hj = np.nonzero(hole)
        if gi.size < 3:
            raise ScanError(f"{path}: a gap of {hi.size} samples has too few valid neighbours to interpolate")
        try:
            interp = LinearNDInterpolator(np.c_[gi, gj], sub[valid])
        except Exception as exc:  # Qhull fails for collinear neighbours
            raise ScanError(f"{path}: cannot interpolate a gap of {hi.size} samples ({exc})") from None
        vals = interp(np.c_[hi, hj])
        if np.isnan(vals).any():
            raise ScanError(
                f"{path}: {int(np.isnan(vals).sum())} missing samples lie at the scan border and cannot be "
                f"interpolated; crop the scan"
            )
        sub[hole] = vals
    return h


def element_grid_shape(shape, scan_step, step: float) -> tuple[int, int]:
    """Samples of the element grid (step ``step``) that fit in a scan of ``shape`` at ``scan_step``.

    An axis already at ``step`` keeps its samples; otherwise the grid ``k step`` from the first
    sample is cut where it passes the last sample (``(n - 1) scan_step``).
    """
    out = []
    for n, s in zip(shape, scan_step):
        if abs(s - step) <= STEP_RTOL * step:
            out.append(int(n))
        else:
            out.append(math.floor((n - 1) * s / step * (1 + 1e-12) + 1e-9) + 1)
    return out[0], out[1]


def to_element_grid(
    scan: Scan, step: float, patch_elements, samples_per_element: int
) -> np.ndarray:
    """Resample a scan onto the element grid (step ``element_size / samples_per_element``).

    The target samples are ``k step`` from the scan's first sample, as many as fit inside the
    scan. A scan already at the target step is used unchanged (no interpolation); otherwise
    heights are interpolated bilinearly (:class:`scipy.interpolate.RegularGridInterpolator`,
    ``method="linear"``). A scan coarser than the target step is upsampled with a warning:
    interpolation cannot create the peaks that the coarse scan missed.

    Parameters
    ----------
    scan : Scan
        The scan.
    step : float
        Target step [m].
    patch_elements : sequence of int
        Patch size in elements, checked against the scan's size.
    samples_per_element : int
        Samples per element edge.

    Returns
    -------
    numpy.ndarray
        Heights [m] ``[x, y]`` at ``step``.

    Raises
    ------
    ScanError
        The patch is larger than the scan.
    """
    n = int(samples_per_element)
    need = [int(p) * n for p in patch_elements]
    ext = scan.extent
    size = list(element_grid_shape(scan.height.shape, scan.step, step))
    same = [abs(s - step) <= STEP_RTOL * step for s in scan.step]
    if size[0] < need[0] or size[1] < need[1]:
        raise ScanError(
            f"{scan.path}: patch of {patch_elements[0]} x {patch_elements[1]} elements is larger than the scan: "
            f"it needs {need[0]} x {need[1]} samples at the element grid step {step * 1e6:.4g} um, i.e. a scan "
            f"spanning at least {(need[0] - 1) * step * 1e3:.4f} x {(need[1] - 1) * step * 1e3:.4f} mm from its "
            f"first to its last sample; the scan ({scan.height.shape[0]} x {scan.height.shape[1]} samples at "
            f"{scan.step[0] * 1e6:.4g} x {scan.step[1] * 1e6:.4g} um) spans {ext[0] * 1e3:.4f} x {ext[1] * 1e3:.4f} mm "
            f"and gives {size[0]} x {size[1]} samples"
        )
    if all(same):
        return np.ascontiguousarray(scan.height)
    if max(scan.step) > step * (1 + STEP_RTOL):
        logger.warning("%s: scan step %s m is coarser than the element grid step %.4g m; upsampling "
                       "cannot recover missed peaks", scan.path, list(scan.step), step)
    logger.info("%s: resampling %s samples at %s m onto %s samples at %.4g m", scan.path,
                list(scan.height.shape), list(scan.step), size, step)
    xs = np.arange(scan.height.shape[0]) * scan.step[0]
    ys = np.arange(scan.height.shape[1]) * scan.step[1]
    interp = RegularGridInterpolator((xs, ys), scan.height, method="linear", bounds_error=True)
    tx = np.minimum(np.arange(size[0]) * step, xs[-1])  # clip round-off at the far edge
    ty = np.minimum(np.arange(size[1]) * step, ys[-1])
    out = np.empty(size)
    rows = max(1, 1_000_000 // size[1])  # chunks keep the point arrays small for large scans
    for i in range(0, size[0], rows):
        gx, gy = np.meshgrid(tx[i : i + rows], ty, indexing="ij")
        out[i : i + rows] = interp(np.stack([gx.ravel(), gy.ravel()], axis=-1)).reshape(gx.shape)
    return out
