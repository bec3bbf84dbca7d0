"""The file of one rolling pass and the rolling study ``results/rolling.nc``."""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
import xarray as xr

from ..io import level_attrs
from .analysis import band_levels, belt_power, pass_work, steady_mask, third_octave_centres
from .recorder import RollingResult
from .settings import RollingSettings

__all__ = ["rolling_dataset", "aggregate_rolling"]


def rolling_dataset(result: RollingResult, info: Mapping[str, float], mode: str, speed: float,
                    settings: RollingSettings, surface: xr.Dataset | None, surface_name: str,
                    material_name: str) -> xr.Dataset:
    """The file of one rolling pass (docs/data_contracts.md "Rolling run dataset").

    Step series (t, x_c, force, contact count, pressure centre, belt power, Newton counts), the
    element forces at the snapshot steps, and the pass's scalars: d0, the work W and its positive
    part, the rolled distance (strip length), the rolling-loss force W / dx, the steady part's mean
    force and mean power / v.
    """
    n = result.force.size
    nx, ny = result.snapshot_force.shape[1:] if result.snapshot_force.size else (0, 0)
    power = belt_power(result, speed, settings.radius)
    w, w_in = pass_work(result, speed, settings.radius)
    steady = steady_mask(result.x_c, info, settings.steady_margin, settings.steady_entry)
    dx_roll = info["strip_length"]
    mean_force = float(result.force[steady].mean()) if steady.any() else float("nan")
    steady_loss = float(power[steady].mean() / speed) if steady.any() else float("nan")

    def a(units, long_name, **extra):
        return {"units": units, "long_name": long_name, **extra}

    coords = {
        "step": ("step", np.arange(n), a("1", "step index")),
        "time": ("step", result.time, a("s", "time since the start of the pass")),
        "x_c": ("step", result.x_c, a("m", "contact centre x_c (the belt's lowest point) from the strip start")),
        "snapshot": ("snapshot", np.arange(result.snapshot_step.size), a("1", "snapshot index")),
        "ex": ("ex", np.arange(nx), a("1", "element index along x")),
        "ey": ("ey", np.arange(ny), a("1", "element index along y")),
    }
    data = {
        "force": ("step", result.force, a("N", "total contact force")),
        "contact_count": ("step", result.contact_count, a("1", "number of elements in contact")),
        "pressure_centre": ("step", result.pressure_centre, a("m", "pressure centre sum F_e x_e / F (NaN without contact)")),
        "belt_power": ("step", power, a("W", "power the belt puts into the tread, sum F_e (-dz2_e/dt)")),
        "steady": ("step", steady.astype(np.int8), a("1", "1 where the contact lies fully on the strip (steady part)")),
        "newton_iterations": ("step", result.newton_iterations, a("1", "Newton iterations")),
        "krylov_iterations": ("step", result.krylov_iterations, a("1", "Krylov products (0: direct solve)")),
        "residual": ("step", result.residual, a("m", "final max-norm Newton residual")),
        **({} if result.contact_extent is None else {
            "contact_extent_x": ("step", result.contact_extent[:, 0], a(
                "1", "span of the contact along x [elements]: of the elements with a positive force or spring "
                "stiffness (a kernel's margin_window must cover it)")),
            "contact_extent_y": ("step", result.contact_extent[:, 1], a("1", "span of the contact along y [elements]")),
        }),
        "snapshot_step": ("snapshot", result.snapshot_step, a("1", "step of the element force map")),
        "snapshot_x_c": ("snapshot", result.x_c[result.snapshot_step], a("m", "x_c of the element force map")),
        "element_force": (("snapshot", "ex", "ey"), result.snapshot_force, a("N", "contact spring force per element")),
        "d0": ((), info["d0"], a("m", "indentation of the belt below the highest road peak")),
        "work": ((), w, a("J", "work of the belt on the tread over the pass, W = int sum F_e (-dz2_e/dt) dt")),
        "work_in": ((), w_in, a("J", "positive part of the belt's work (while the belt power is positive)")),
        "rolled_distance": ((), dx_roll, a("m", "rolled distance of the loss force: the strip length")),
        "rolling_loss_force": ((), w / dx_roll, a("N", "rolling-loss force W / dx")),
        "steady_force": ((), mean_force, a("N", "mean total force over the steady part")),
        "steady_loss_force": ((), steady_loss, a("N", "mean belt power over v in the steady part")),
    }
    if result.stability is not None:
        data.update(result.stability.variables())
    if surface is not None and "element_x" in surface:
        data["element_x"] = ("ex", surface["element_x"].values, a("m", "x of element centres"))
        data["element_y"] = ("ey", surface["element_y"].values, a("m", "y of element centres"))
        data["z1"] = (("ex", "ey"), surface["z1"].transpose("ex", "ey").values, a("m", "element matching height"))
    attrs = {"mode": mode, "speed": float(speed), "radius": settings.radius, "material": material_name,
             "surface": surface_name, "x_start": info["x_start"], "x_end": info["x_end"],
             "half_length": info["half_length"], "element_size": info["element_size"],
             "load": float("nan") if settings.load is None else float(settings.load),
             "static_d0": float(info.get("static_d0", float("nan"))), "load_passes": int(info.get("load_passes", 0)),
             "load_error": float(info.get("load_error", float("nan"))),
             "steady_margin": settings.steady_margin, "steady_entry": settings.steady_entry}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def fs2_band_amplitude(force, fraction: float = 0.9) -> tuple[float, float]:
    """The force's largest spectral component in the top band [fraction, 1] x fs/2, over its mean, and how
    the fourth difference grows along the record (rms over its last third / over its first third).

    The fourth-difference measure (:func:`tyreroad.stability.fs2_alternation`) also sees real content well
    below fs/2 (on a rolling pass, the ripple of elements entering the contact at v / element size). A
    march instability sits in the top band or grows; a ripple sits at the element rate and stays. Hann
    window, cubic trend removed; (NaN, NaN) for fewer than 32 samples.
    """
    f = np.asarray(force, dtype=float)
    if f.size < 32 or not np.mean(f) > 0:
        return float("nan"), float("nan")
    n = np.arange(f.size)
    x = f - np.polyval(np.polyfit(n, f, 3), n)
    spectrum = np.abs(np.fft.rfft(x * np.hanning(f.size))) * 4.0 / f.size  # Hann: amplitude of a pure tone
    top = np.fft.rfftfreq(f.size) >= 0.5 * fraction
    d4 = np.diff(f, 4)
    third = d4.size // 3
    first, last = np.sqrt(np.mean(d4[:third] ** 2)), np.sqrt(np.mean(d4[-third:] ** 2))
    return float(spectrum[top].max() / np.mean(f)), float(last / first) if first > 0 else float("nan")


#: Harmonics of the element rate that :func:`alternation_without_input_lines` removes.
INPUT_HARMONICS = 5

#: Lower edge of the top band, as a fraction of fs/2 (:func:`fs2_band_amplitude`).
TOP_BAND = 0.9


def input_line_frequencies(element_rate: float, sample_rate: float, harmonics: int = INPUT_HARMONICS) -> np.ndarray:
    """The road input's lines k v / element size, k = 1 ... ``harmonics``, aliased into [0, fs/2] [Hz]."""
    fs = float(sample_rate)
    lines = (np.arange(1, int(harmonics) + 1) * float(element_rate)) % fs
    return np.minimum(lines, fs - lines)


def alternation_without_input_lines(force, element_rate: float, sample_rate: float,
                                    harmonics: int = INPUT_HARMONICS, fraction: float = TOP_BAND) -> float:
    """:func:`tyreroad.stability.fs2_alternation` of a steady force after the road's input lines are removed [1].

    Elements enter the contact at v / element size, so a rolling pass's force carries lines at k v / element
    size (aliased into [0, fs/2]); on a flat road they are its only fluctuation, and the fourth difference
    reads their harmonics near fs/2 as alternation. Their amplitudes and phases (k = 1 ... ``harmonics``)
    are fitted to its fourth difference by least squares and removed; a line whose aliased frequency falls in the top band
    [``fraction``, 1] x fs/2 is kept (it cannot be told from a march instability there). What remains is the
    alternation the march itself adds. NaN for fewer than 32 samples or a force without a positive mean.

    Parameters
    ----------
    force : array_like
        Total force over the steady part [N].
    element_rate, sample_rate : float
        v / element size and the time-step rate [Hz].
    """
    f = np.asarray(force, dtype=float)
    if f.size < 32 or not np.mean(f) > 0:
        return float("nan")
    # fitted to the fourth difference itself, whose lines are the force's (same frequencies): a fit to the force
    # would leak its large low-frequency content (a rough road's texture) into the lines near fs/2, and least
    # squares on the fourth difference can only lower its rms
    d4 = np.diff(f, 4) / 16.0
    n = np.arange(d4.size, dtype=float)
    columns = []
    for alias in input_line_frequencies(element_rate, sample_rate, harmonics):
        if alias <= 0.0 or alias >= 0.5 * fraction * float(sample_rate):
            continue
        phase = 2.0 * np.pi * alias / float(sample_rate) * n
        columns += [np.cos(phase), np.sin(phase)]
    if columns:
        basis = np.stack(columns, axis=1)
        coefficients, *_ = np.linalg.lstsq(basis, d4, rcond=None)
        d4 = d4 - basis @ coefficients
    return float(np.sqrt(np.mean(d4 ** 2))) / float(np.mean(np.abs(f)))


def contact_holes(run: xr.Dataset) -> int:
    """The most elements without force inside a row's contact, over the pass's steady snapshots.

    Per snapshot (``element_force``) and per row of elements along the rolling direction, the elements
    between the row's first and last element in contact that carry no force; the maximum over rows and
    the snapshots taken on the steady part. On a flat road the contact is one convex region and any hole
    is numerical (a time march alternating at fs/2 opens a gap across the contact); on a rough road holes
    are the texture's own. 0 without snapshots.
    """
    if "element_force" not in run or run.sizes.get("snapshot", 0) == 0:
        return 0
    steady_steps = set(np.flatnonzero(run["steady"].values.astype(bool)).tolist())
    worst = 0
    for k in range(run.sizes["snapshot"]):
        if int(run["snapshot_step"].values[k]) not in steady_steps:
            continue
        loaded = run["element_force"].values[k] > 0.0  # (ex, ey)
        for row in loaded.T:  # one row of elements along x
            on = np.flatnonzero(row)
            if on.size:
                worst = max(worst, int(on[-1] - on[0] + 1 - on.size))
    return worst


def aggregate_rolling(runs: Sequence[xr.Dataset], band_limits=(100.0, 5000.0)) -> xr.Dataset:
    """Per case (material, mode, speed): steady force, rolling-loss force and coefficient, band levels.

    F(x_c) of every run is interpolated onto one x_c grid (that of the first quasi-static run,
    else the first run) for the figures.
    """
    if not runs:
        raise ValueError("aggregate_rolling: no rolling runs")
    centres = third_octave_centres(*band_limits)
    ref = next((r for r in runs if r.attrs["mode"] == "quasistatic"), runs[0])
    x_grid = ref["x_c"].values
    rows = []
    for r in runs:
        steady = r["steady"].values.astype(bool)
        f = r["force"].values
        t = r["time"].values
        dt = float(np.median(np.diff(t))) if t.size > 1 else float("nan")
        fluct = f[steady]
        levels = band_levels(fluct, dt, centres) if steady.sum() > 8 else np.full(centres.size, np.nan)
        finite = np.isfinite(levels)
        strongest = float(centres[finite][np.argmax(levels[finite])]) if finite.any() else float("nan")
        # fs/2 chatter of the time march (a period-2 alternation, amplitude = |second difference| / 4):
        # a numerical instability of the discrete kernel with stiff springs, never physics
        chatter = (float(np.sqrt(np.mean((0.25 * np.diff(fluct, 2)) ** 2))) / max(float(np.std(fluct)), 1e-300)
                   if r.attrs["mode"] == "dynamic" and fluct.size > 2 else 0.0)
        mean_f = float(r["steady_force"])
        loss = float(r["rolling_loss_force"])
        band, growth = fs2_band_amplitude(fluct) if r.attrs["mode"] == "dynamic" else (float("nan"), float("nan"))
        rows.append({
            "material": r.attrs["material"], "mode": r.attrs["mode"], "speed": float(r.attrs["speed"]),
            "steady_force": mean_f, "rolling_loss_force": loss, "steady_loss_force": float(r["steady_loss_force"]),
            "rolling_loss_coefficient": float(r["steady_loss_force"]) / mean_f if mean_f > 0 else float("nan"),
            "work": float(r["work"]), "work_in": float(r["work_in"]), "d0": float(r["d0"]),
            "fluctuation_rms": float(np.std(fluct)) if fluct.size else float("nan"),
            "band_level": levels, "strongest_band": strongest, "chatter": chatter,
            "fs2_alternation": float(r["fs2_alternation"]) if "fs2_alternation" in r else float("nan"),
            "margin_critical_stiffness": float(r["margin_critical_stiffness"]) if "margin_critical_stiffness" in r
            else float("nan"),
            "max_spring_stiffness": float(np.max(r["max_spring_stiffness"].values, initial=0.0))
            if "max_spring_stiffness" in r and r.attrs["mode"] == "dynamic" else float("nan"),
            "contact_holes": contact_holes(r),
            "fs2_band_amplitude": band, "alternation_growth": growth,
            "alternation_input_removed": alternation_without_input_lines(
                fluct, float(r.attrs["speed"]) / float(r.attrs["element_size"]), 1.0 / dt)
            if r.attrs["mode"] == "dynamic" else float("nan"),
            "element_rate": float(r.attrs["speed"]) / float(r.attrs["element_size"]),
            "sample_rate": 1.0 / dt,
            "flat_road": int("z1" in r and float(np.ptp(r["z1"].values)) == 0.0),
            "curve": np.interp(x_grid, r["x_c"].values, f, left=0.0, right=0.0),
            "centre_offset": float(np.nanmean(r["pressure_centre"].values[steady] - r["x_c"].values[steady]))
            if steady.any() else float("nan"),
        })

    def a(units, long_name):
        return {"units": units, "long_name": long_name}

    scal = {
        "steady_force": ("N", "mean total force over the steady part"),
        "rolling_loss_force": ("N", "rolling-loss force W / dx (dx = strip length)"),
        "steady_loss_force": ("N", "mean belt power / v over the steady part"),
        "rolling_loss_coefficient": ("1", "steady rolling-loss force (mean belt power / v over the steady part) over "
                                          "the steady mean force"),
        "work": ("J", "work of the belt over the pass"),
        "work_in": ("J", "positive part of the belt's work"),
        "d0": ("m", "belt indentation below the highest road peak"),
        "fluctuation_rms": ("N", "rms of the force fluctuation over the steady part"),
        "strongest_band": ("Hz", "centre of the 1/3-octave band with the highest force level"),
        "centre_offset": ("m", "mean pressure centre minus x_c over the steady part (> 0: ahead)"),
        "chatter": ("1", "rms of the fs/2 alternation of the force over the rms fluctuation (> 0.05: the time "
                         "march chattered, the case is not trustworthy)"),
        "fs2_alternation": ("1", "rms of the fs/2 alternation of the force over the steady part, over the steady "
                                 "mean force (NaN: quasi-static, or a pass file without a stability record)"),
        "margin_critical_stiffness": ("N/m", "the pass's kernel's stability margin over the unit circle (the greens "
                                             "file's critical_stiffness; NaN: quasi-static or not known)"),
        "max_spring_stiffness": ("N/m", "stiffest tangent contact spring of the pass (NaN: quasi-static)"),
        "contact_holes": ("1", "most elements without force between a row's first and last element in contact, "
                               "over the steady snapshots (tyreroad.rolling.dataset.contact_holes)"),
        "flat_road": ("1", "1 where the strip is flat (all matching heights equal): contact holes are numerical"),
        "fs2_band_amplitude": ("1", "largest component of the steady force in 0.9-1 x fs/2, over the steady mean "
                                    "force (tyreroad.rolling.dataset.fs2_band_amplitude; NaN: quasi-static)"),
        "alternation_growth": ("1", "rms fourth difference of the steady force over its last third, over its first "
                                    "third (> 1: growing; NaN: quasi-static)"),
        "alternation_input_removed": ("1", "fs2_alternation after the road's input lines at k v / element size "
                                           "(k = 1 ... 5, aliased, outside the top band) are fitted and removed "
                                           "(tyreroad.rolling.dataset.alternation_without_input_lines; NaN: "
                                           "quasi-static)"),
        "element_rate": ("Hz", "elements passed per second, v / element size: the road texture's input reaches "
                               "about this frequency"),
        "sample_rate": ("Hz", "the pass's time-step rate"),
    }
    data = {k: ("case", np.array([row[k] for row in rows]), a(*v)) for k, v in scal.items()}
    data["band_level"] = (("case", "band"), np.array([row["band_level"] for row in rows]),
                          level_attrs("1/3-octave level of the force fluctuation over the steady part", 1.0, "N"))
    data["force_curve"] = (("case", "position"), np.array([row["curve"] for row in rows]),
                           a("N", "total force against x_c"))
    coords = {
        "case": ("case", np.arange(len(rows)), a("1", "case index")),
        "material": ("case", [row["material"] for row in rows], {"units": "1", "long_name": "material preset"}),
        "mode": ("case", [row["mode"] for row in rows], {"units": "1", "long_name": "run mode"}),
        "speed": ("case", np.array([row["speed"] for row in rows]), a("m/s", "rolling speed")),
        "band": ("band", centres, a("Hz", "1/3-octave band centre frequency")),
        "position": ("position", x_grid, a("m", "contact centre x_c")),
    }
    attrs = {"radius": float(ref.attrs["radius"]), "surface": str(ref.attrs["surface"]),
             "strip_length": float(ref["rolled_distance"])}
    for key in ("spring_rheology", "kernel_construction"):  # what the passes ran on, when they all agree
        values = {str(r.attrs[key]) for r in runs if key in r.attrs}
        if values:
            attrs[key] = values.pop() if len(values) == 1 else "mixed: " + ", ".join(sorted(values))
    return xr.Dataset(data, coords=coords, attrs=attrs)
