r"""K*(f; d0) as a deliverable for a tyre model: one combined file, any preload, CSV and 1/3-octave bands.

The stiffness-spectrum stage (:mod:`tyreroad.stiffness`) writes one file per material with K* at
the configured preloads only. This module turns those files into what a tyre/road model reads:

* :func:`combine_spectra` — one dataset with a ``material`` dimension (``results/stiffness_spectrum.nc``).
* :func:`open_material` — one material's K* from the combined file, or from its per-material file when
  the combined file is absent (saying which file it read).
* :func:`at_preload` — K′, K″, |K*| and the loss factor at any preload d0 inside the computed range.
  **Interpolation:** K′ and K″ are each interpolated *linearly in d0* between the two neighbouring
  computed preloads, frequency by frequency; |K*| and the loss factor are then formed from the
  interpolated K′ and K″ (so |K*|² = K′² + K″² holds exactly). At a computed preload the values are
  the file's. Outside the computed range it refuses: K*(d0) is not extrapolated.
* :func:`third_octave_bands` — the same in 1/3-octave bands of IEC 61260-1 (base 10):
  exact centres f_m = 1000 · 10^(n/10) Hz, edges f_m · 10^(∓1/20). **Band value:** the mean of K′
  (and of K″) over the band on a logarithmic frequency axis,

      K_band = 1 / ln(f_2 / f_1) · ∫_{f_1}^{f_2} K(f) d(ln f),

  with K(f) taken piecewise linear in ln f between the computed frequencies (the integral is then
  exact by the trapezoidal rule on the computed points inside the band plus the two edges); |K*| and
  the loss factor of a band are those of the band-mean complex K′ + i K″. Only bands that lie wholly
  inside the computed frequency range are given.

Both relaxed (``storage_stiffness``, ``loss_stiffness``) and, when the files carry them, transient
(``*_transient``) states are handled; see docs/data_contracts.md "Stiffness spectrum dataset".
"""

from __future__ import annotations

import io as _io
import math
import re
from pathlib import Path
from typing import Sequence

import numpy as np
import xarray as xr

__all__ = [
    "parse_length",
    "combine_spectra",
    "open_material",
    "at_preload",
    "third_octave_bands",
    "nominal_third_octave",
    "to_csv",
]

#: The two states a stiffness-spectrum file may carry: (suffix of the variables, name in outputs).
STATES = (("", "relaxed"), ("_transient", "transient"))
#: Per-preload-and-frequency variables of a combined file (besides the state variables).
_PF_VARIABLES = ("storage_stiffness", "loss_stiffness", "loss_factor", "stiffness_magnitude",
                 "storage_stiffness_transient", "loss_stiffness_transient", "loss_factor_transient")
_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "nm": 1e-9}
#: IEC 61260-1 nominal mid-band frequencies of one decade (the mantissas, 1/3-octave bands).
_NOMINAL = (1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0)


def parse_length(text: str | float) -> float:
    """A length with an optional unit, in metres: ``"0.12mm"``, ``"120um"``, ``"1.2e-4"`` (bare number: m).

    Units: m, cm, mm, um (µm), nm.

    Raises
    ------
    ValueError
        For an unknown unit, a non-number or a length <= 0.
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value, unit = float(text), "m"
    else:
        match = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-zµμ]*)\s*", str(text))
        if not match:
            raise ValueError(f"length {text!r}: expected a number with an optional unit (m, cm, mm, um, nm), "
                             "e.g. 0.12mm, 120um or 1.2e-4 (metres)")
        value, unit = float(match.group(1)), match.group(2) or "m"
        if unit not in _UNITS:
            raise ValueError(f"length {text!r}: unknown unit {unit!r} (expected one of m, cm, mm, um, nm)")
    metres = value * _UNITS[unit]
    if not (math.isfinite(metres) and metres > 0):
        raise ValueError(f"length {text!r}: expected a length > 0")
    return metres


# --------------------------------------------------------------------------------------------
# the combined file
# --------------------------------------------------------------------------------------------
def combine_spectra(spectra: Sequence[xr.Dataset]) -> xr.Dataset:
    """One K*(f; d0) dataset with a ``material`` dimension from the per-material stiffness-spectrum files.

    Parameters
    ----------
    spectra : sequence of xarray.Dataset
        Stiffness-spectrum datasets (one per material, attribute ``material``), all on the same
        preloads [m] and frequencies [Hz] (one study).

    Returns
    -------
    xarray.Dataset
        Dims (material, preload, frequency): K′, K″ [N/m], |K*| [N/m], loss factor [1] of the relaxed
        state (and of the transient state when every file has it); per (material, preload) the
        relaxed stiffness K*(f -> 0) and the quasi-static tangent [N/m], the preload force [N] and the
        contact fraction [1]; per material the quasi-static and zero-frequency moduli [Pa]. Attributes
        common to all files (surface, sample rate, conventions) are kept.

    Raises
    ------
    ValueError
        For no input, a file without ``material``, a material twice, or differing grids.
    """
    if not spectra:
        raise ValueError("combine_spectra: no stiffness-spectrum datasets given")
    names = []
    for i, ds in enumerate(spectra):
        if "material" not in ds.attrs:
            raise ValueError(f"stiffness spectrum #{i}: no 'material' attribute")
        names.append(str(ds.attrs["material"]))
    if len(set(names)) != len(names):
        raise ValueError(f"combine_spectra: a material given twice ({names})")
    first = spectra[0]
    for name, ds in zip(names[1:], spectra[1:]):
        for dim in ("preload", "frequency"):
            a, b = first[dim].values, ds[dim].values
            if a.shape != b.shape or not np.allclose(a, b, rtol=1e-12, atol=0):
                raise ValueError(f"combine_spectra: {name} has other {dim} values than {names[0]} "
                                 f"({b.size} against {a.size}); combine the files of one study only")
    transient = all("storage_stiffness_transient" in ds for ds in spectra)
    keep = [v for v in (*_PF_VARIABLES, "relaxed_stiffness", "tangent_stiffness_qs", "preload_force",
                        "contact_fraction", "transient_force", "transient_contact_fraction")
            if v in first and (transient or not v.endswith("transient") and not v.startswith("transient"))]
    parts = [ds[keep].assign_coords(preload=first["preload"], frequency=first["frequency"]) for ds in spectra]
    out = xr.concat(parts, dim=xr.DataArray(names, dims="material", name="material"),
                    combine_attrs="drop", coords="minimal", compat="override")
    for v in keep:
        out[v].attrs = dict(first[v].attrs)
    for c in ("preload", "frequency"):
        out[c].attrs = dict(first[c].attrs)
    out["material"].attrs = {"units": "1", "long_name": "tread material (study name)"}
    for key, long_name in (("quasi_static_modulus", "modulus of the relaxed state E_qs"),
                           ("zero_frequency_modulus", "E(omega -> 0) of the material")):
        out[key] = ("material", [float(ds.attrs.get(key, np.nan)) for ds in spectra],
                    {"units": "Pa", "long_name": long_name})
    common = {k: v for k, v in first.attrs.items()
              if k not in ("material", "config", "config_sha256", "created", "stage", "tyreroad_version")
              and all(k in ds.attrs and np.array_equal(np.asarray(ds.attrs[k]), np.asarray(v)) for ds in spectra)}
    out.attrs = common
    out.attrs["materials"] = ", ".join(names)
    return out


def open_material(results: str | Path, material: str, surface: str = "iso10844") -> tuple[xr.Dataset, str]:
    """One material's stiffness spectrum, from the combined file ``<results>/stiffness_spectrum.nc``.

    The combined file (rule ``stiffness_combined``: the study's materials with a ``material``
    dimension) is read when it exists; only when it does not is the per-material file
    ``<results>/stiffness_spectrum/<surface>/<material>.nc`` read. The returned note says which file
    was read, and why, for the caller to show; there is no silent fallback: a combined file without
    the material (or of another surface) is an error that names the file, its materials and the
    per-material file if there is one.

    Parameters
    ----------
    results : path-like
        The results folder.
    material : str
        Material preset name.
    surface : str
        The study surface (the per-material files' folder; checked against the combined file's
        ``surface`` attribute).

    Returns
    -------
    dataset : xarray.Dataset
        Dims (preload [m], frequency [Hz]); attributes ``material``, ``surface`` and ``source_file`` (the
        file read).
    note : str
        ``read K* of <material> from <file> (...)``; it also says when a per-material file is newer than
        the combined one (the combined file is then stale).

    Raises
    ------
    FileNotFoundError
        Neither file exists (with the command that makes the combined file).
    ValueError
        The combined file lacks the material or is of another surface.
    """
    from . import io

    combined = Path(results) / "stiffness_spectrum.nc"
    single = Path(results) / "stiffness_spectrum" / surface / f"{material}.nc"
    if not combined.is_file():
        if not single.is_file():
            raise FileNotFoundError(
                f"{combined}: no combined K* file, and {single}: no K* file for material {material!r} on surface "
                f"{surface!r}; make them with: tyreroad run {combined.as_posix()} (the study's materials) or "
                f"tyreroad run {single.as_posix()}")
        ds = io.read_dataset(single)
        ds.attrs["source_file"] = str(single)
        return ds, f"read K* of {material} from the per-material file {single} ({combined} is absent)"
    ds = io.read_dataset(combined)
    names = [str(m) for m in np.atleast_1d(ds["material"].values)]
    there = f"; {single} exists: read it with --file {single.as_posix()}" if single.is_file() else ""
    have = str(ds.attrs.get("surface", ""))
    if have and have != surface:
        raise ValueError(f"{combined}: the combined K* file is of surface {have!r}, not {surface!r}{there}")
    if material not in names:
        raise ValueError(f"{combined}: material {material!r} is not in the combined K* file (materials: "
                         f"{', '.join(names)}); it holds the study's materials (study.materials){there}")
    one = ds.sel(material=material)
    one = one.drop_vars([c for c in ("material", "compound", "temperature") if c in one.coords])
    one.attrs = {**ds.attrs, "material": material, "surface": have or surface, "source_file": str(combined)}
    note = f"read K* of {material} from the combined file {combined}"
    if single.is_file() and single.stat().st_mtime > combined.stat().st_mtime:
        note += (f"; note: {single} is newer than the combined file, which may be stale: "
                 f"tyreroad run {combined.as_posix()} updates it")
    return one, note


# --------------------------------------------------------------------------------------------
# any preload
# --------------------------------------------------------------------------------------------
def _states(ds: xr.Dataset) -> list[tuple[str, str]]:
    return [(suffix, name) for suffix, name in STATES if f"storage_stiffness{suffix}" in ds]


def at_preload(ds: xr.Dataset, preload: float) -> xr.Dataset:
    """K′, K″, |K*| and the loss factor against frequency at preload ``preload``, interpolated linearly in d0.

    Parameters
    ----------
    ds : xarray.Dataset
        A stiffness-spectrum dataset of one material (dims preload, frequency), or one material of
        a combined file (``combined.sel(material=...)``).
    preload : float
        d0 [m], inside the computed preloads' range.

    Returns
    -------
    xarray.Dataset
        Dim frequency [Hz]; for each state the file carries (``relaxed``, ``transient``) the variables
        ``storage_<state>``, ``loss_<state>``, ``magnitude_<state>`` [N/m] and ``loss_factor_<state>`` [1];
        attributes ``preload`` [m], ``interpolation`` (how the value was formed), ``material``, ``surface``
        and ``source`` (the file read, from ``ds.attrs["source_file"]`` when :func:`open_material` set it).

    Raises
    ------
    ValueError
        Naming the computed range [mm] when ``preload`` lies outside it.
    """
    pre = np.asarray(ds["preload"].values, dtype=float)
    d0 = float(preload)
    lo, hi = float(pre.min()), float(pre.max())
    tol = 1e-9 * hi
    if not lo - tol <= d0 <= hi + tol:
        raise ValueError(f"preload {d0 * 1e3:.6g} mm lies outside the computed preloads "
                         f"{lo * 1e3:.6g}-{hi * 1e3:.6g} mm ({', '.join(f'{p * 1e3:g}' for p in pre)} mm); "
                         "K*(d0) is interpolated, not extrapolated: add the preload to "
                         "stiffness_spectrum.preloads and re-run")
    exact = np.flatnonzero(np.isclose(pre, d0, rtol=1e-9, atol=0))
    if exact.size:
        i = j = int(exact[0])
        w = 0.0
        how = f"computed preload d0 = {pre[i] * 1e3:g} mm (no interpolation)"
    else:
        j = int(np.searchsorted(pre, d0))
        i = j - 1
        w = (d0 - pre[i]) / (pre[j] - pre[i])
        how = (f"K' and K'' linear in d0 between the computed preloads {pre[i] * 1e3:g} and {pre[j] * 1e3:g} mm "
               f"(weight {w:.6g} on the upper); |K*| and the loss factor from the interpolated K' and K''")
    out = xr.Dataset(coords={"frequency": ds["frequency"]})
    for suffix, state in _states(ds):
        k1 = ds[f"storage_stiffness{suffix}"].transpose("preload", "frequency").values
        k2 = ds[f"loss_stiffness{suffix}"].transpose("preload", "frequency").values
        s = (1 - w) * k1[i] + w * k1[j]
        l = (1 - w) * k2[i] + w * k2[j]
        _put_state(out, state, s, l, "frequency")
    out.attrs = {"preload": d0, "interpolation": how, "material": str(ds.attrs.get("material", "")),
                 "surface": str(ds.attrs.get("surface", "")), "source": str(ds.attrs.get("source_file", ""))}
    return out


def _put_state(out: xr.Dataset, state: str, storage, loss, dim: str) -> None:
    storage = np.asarray(storage, dtype=float)
    loss = np.asarray(loss, dtype=float)
    out[f"storage_{state}"] = (dim, storage, {"units": "N/m", "long_name": f"storage stiffness K' ({state} state)"})
    out[f"loss_{state}"] = (dim, loss, {"units": "N/m", "long_name": f"loss stiffness K'' ({state} state)"})
    out[f"magnitude_{state}"] = (dim, np.hypot(storage, loss), {"units": "N/m", "long_name": f"|K*| ({state} state)"})
    out[f"loss_factor_{state}"] = (dim, loss / storage,
                                   {"units": "1", "long_name": f"loss factor K''/K' ({state} state)"})


# --------------------------------------------------------------------------------------------
# 1/3-octave bands
# --------------------------------------------------------------------------------------------
def nominal_third_octave(centre: float) -> float:
    """The IEC 61260-1 nominal mid-band frequency [Hz] of an exact 1/3-octave centre ``centre`` [Hz]."""
    exponent = math.floor(math.log10(centre) + 1e-9)
    mantissa = centre / 10.0 ** exponent
    nearest = min(_NOMINAL + (10.0,), key=lambda m: abs(math.log10(m / mantissa)))
    return float(round(nearest * 10.0 ** exponent, 6))


def _band_mean_log(freq: np.ndarray, values: np.ndarray, f1: float, f2: float) -> float:
    """Mean of the piecewise-linear-in-ln f interpolant of values(freq) over [f1, f2] on ln f (exact)."""
    x = np.log(freq)
    inner = (freq > f1) & (freq < f2)
    xs = np.concatenate([[math.log(f1)], x[inner], [math.log(f2)]])
    ys = np.interp(xs, x, values)
    return float(np.sum(0.5 * (ys[1:] + ys[:-1]) * np.diff(xs)) / (xs[-1] - xs[0]))


def third_octave_bands(spectrum: xr.Dataset) -> xr.Dataset:
    """1/3-octave band values (IEC 61260-1, base 10) of a K* spectrum from :func:`at_preload`.

    Parameters
    ----------
    spectrum : xarray.Dataset
        Output of :func:`at_preload` (dim frequency [Hz]).

    Returns
    -------
    xarray.Dataset
        Dim ``band`` with coordinates ``centre`` (exact f_m = 1000 · 10^(n/10) Hz), ``nominal`` (IEC
        nominal [Hz]), ``lower`` and ``upper`` edges [Hz]; the same variables as the input, each the
        log-frequency mean over the band of K′ and K″ (|K*| and the loss factor from the band means).

    Raises
    ------
    ValueError
        When no whole band lies inside the computed frequencies.
    """
    freq = np.asarray(spectrum["frequency"].values, dtype=float)
    f_lo, f_hi = float(freq.min()), float(freq.max())
    n_first = math.ceil(10 * math.log10(f_lo / 1000.0) + 0.5 - 1e-9)
    n_last = math.floor(10 * math.log10(f_hi / 1000.0) - 0.5 + 1e-9)
    bands = np.arange(n_first, n_last + 1)
    if bands.size == 0:
        raise ValueError(f"no whole 1/3-octave band inside the computed frequencies {f_lo:g}-{f_hi:g} Hz")
    centre = 1000.0 * 10.0 ** (bands / 10.0)
    lower, upper = centre * 10.0 ** (-1 / 20), centre * 10.0 ** (1 / 20)
    out = xr.Dataset(coords={
        "centre": ("band", centre, {"units": "Hz", "long_name": "exact 1/3-octave mid-band frequency 1000*10^(n/10)"}),
        "nominal": ("band", [nominal_third_octave(c) for c in centre],
                    {"units": "Hz", "long_name": "IEC 61260-1 nominal mid-band frequency"}),
        "lower": ("band", lower, {"units": "Hz", "long_name": "lower band edge f_m*10^(-1/20)"}),
        "upper": ("band", upper, {"units": "Hz", "long_name": "upper band edge f_m*10^(1/20)"}),
    })
    for state in [name for _, name in STATES if f"storage_{name}" in spectrum]:
        mean = {}
        for part in ("storage", "loss"):
            v = np.asarray(spectrum[f"{part}_{state}"].values, dtype=float)
            mean[part] = [_band_mean_log(freq, v, a, b) for a, b in zip(lower, upper)]
        _put_state(out, state, mean["storage"], mean["loss"], "band")
    out.attrs = dict(spectrum.attrs)
    out.attrs["band_value"] = ("mean of K' and of K'' over the band on a log-frequency axis, K piecewise linear "
                               "in ln f between the computed frequencies; |K*| and loss factor of the band means")
    return out


def to_csv(table: xr.Dataset) -> str:
    """CSV text of an :func:`at_preload` or :func:`third_octave_bands` result, with '#' comment lines first.

    Columns: the coordinates (``frequency_Hz``, or ``centre_Hz, nominal_Hz, lower_Hz, upper_Hz``), then
    per state ``storage_<state>_N_per_m, loss_<state>_N_per_m, magnitude_<state>_N_per_m,
    loss_factor_<state>`` (``pandas.read_csv(path, comment="#")`` reads it).
    """
    dim = next(iter(table.dims))
    coords = [c for c in table.coords if table[c].dims == (dim,)]
    variables = list(table.data_vars)
    suffix = {"Hz": "_Hz", "N/m": "_N_per_m", "1": ""}
    header = [f"{c}{suffix.get(table[c].attrs.get('units'), '')}" for c in coords]
    header += [f"{v}{suffix.get(table[v].attrs.get('units'), '')}" for v in variables]
    buf = _io.StringIO()
    for key in ("material", "surface", "source", "preload", "interpolation", "band_value"):
        if key in table.attrs and str(table.attrs[key]):
            value = table.attrs[key]
            text = f"{float(value):.6g} m" if key == "preload" else str(value)
            buf.write(f"# {key}: {text}\n")
    buf.write(",".join(header) + "\n")
    columns = [np.asarray(table[c].values, dtype=float) for c in coords + variables]
    for row in zip(*columns):
        buf.write(",".join(f"{x:.12g}" for x in row) + "\n")
    return buf.getvalue()
