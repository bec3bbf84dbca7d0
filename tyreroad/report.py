"""The claims report ``results/report.md`` (SPEC section 7).

Each of the ten claims of the seed paper is turned into a test with an explicit threshold, evaluated
on the study dataset (:mod:`tyreroad.study`), and listed in a markdown table with the measured numbers
and PASS/FAIL. Unless stated, a claim is tested on the reference material; "the reference case" is
the reference material, dynamic, at the highest study acceleration (500 m/s^2 in the paper's study).

The thresholds (module constants below) and why they were chosen:

1. Dynamic stiffer than quasi-static at every d > 0.05 mm: K_a(d) / K_QS(d) > 1 at every common-grid
   point with d > 0.05 mm, for every acceleration a (strict, as stated).
2. K_500 > K_250 > K_50 > K_QS when saturated: strict ordering of K_sat by acceleration (QS lowest).
3. F(d) curves of similar shape: RMS over the common grid of F_a/F_a(d_end) - F_QS/F_QS(d_end) <= 0.05
   for every a. (0.05 separates power laws whose exponents differ by about 0.25: d^1.5 vs d^1.25 gives
   0.049, d^2 vs d^1.5 gives 0.075.)
4. Contact count grows fastest up to d ~ 0.05 mm: the growth rate of the contact fraction (slope over a
   0.02 mm window, to average the unit steps of the count) is largest at some d <= 0.05 mm, for every
   run of the reference material.
5. ~50 % of the elements in contact at 0.15 mm and K saturates beyond it (reference case): contact
   fraction at 0.15 mm in [0.40, 0.60], and the change of K across the saturation range from a
   least-squares line, |slope| (d_hi - d_lo) / K_sat <= 0.10 (a line fit is insensitive to ripples;
   K ~ d^0.5 would give about 0.16).
6. Loss factor +-50 % changes K_sat by a few percent (~3 %): at the reference acceleration,
   Delta = K_sat(variant)/K_sat(reference) - 1 for every loss variant; pass if all |Delta| <= 10 % and
   the largest |Delta| >= 0.5 % (the effect exists but is small).
7. Density x2 and x0.5 change K_sat by <~ 2 % while adding ripples at small d: all |Delta| <= 3 %,
   and the ripple of the heaviest variant is >= 1.2 x the reference's. Ripple = RMS over 0 < d <= 0.1 mm
   of K minus its Savitzky-Golay smoothing (quadratic, 0.03 mm window), divided by the reference K_sat.
   (Heavier layer -> lower wave speeds -> more inertia oscillation at early times.)
8. K_sat ~ 2.75 MN/m at 500 m/s^2: reference-case K_sat within +-15 % of 2.75 MN/m. The material's
   modulus scale was calibrated to this (SPEC 5), so this checks the calibration, not a prediction.
9. QS stiffness independent of acceleration: the quasi-static solver has no time, so a quasi-static
   run does not depend on the acceleration by construction (one run per material). What can depend on
   the acceleration is the stiffness *estimate*, through the sampling of d: the QS force is resampled at
   each acceleration's native indentations d_n = a (n dt)^2 / 2, differentiated the same way as the
   dynamic runs and compared with the uniform-grid estimate: pass if |K_sat change| <= 1 % and the
   pointwise difference for d >= 0.05 mm is <= 5 % of K_sat.
10. Backing force gives equivalent results: for every case, |K_sat(backing)/K_sat(surface) - 1| <= 2 %.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr
import yaml
from scipy.signal import savgol_filter

from . import io
from .study import (
    StudySettings,
    case_label,
    contact_stiffness,
    saturated_stiffness,
    variant_members,
)

logger = logging.getLogger(__name__)

__all__ = [
    "THRESHOLDS",
    "ClaimResult",
    "evaluate_claims",
    "ripple",
    "count_growth_peak",
    "quasistatic_resampling_check",
    "build_report",
    "write_report",
]

#: Thresholds of the claim tests (SI units); see the module docstring for the reasoning.
THRESHOLDS: dict[str, float] = {
    "c1_d_min": 0.05e-3,  # m
    "c3_rms_max": 0.05,  # 1
    "c4_window": 0.02e-3,  # m
    "c4_d_peak_max": 0.05e-3,  # m
    "c5_d": 0.15e-3,  # m
    "c5_fraction_lo": 0.40,
    "c5_fraction_hi": 0.60,
    "c5_change_max": 0.10,
    "c6_delta_max": 0.10,
    "c6_delta_min": 0.005,
    "c7_delta_max": 0.03,
    "c7_ripple_d_max": 0.1e-3,  # m
    "c7_ripple_window": 0.03e-3,  # m
    "c7_ripple_ratio_min": 1.2,
    "c8_target": 2.75e6,  # N/m
    "c8_rel_tol": 0.15,
    "c9_ksat_rel_max": 0.01,
    "c9_pointwise_rel_max": 0.05,
    "c9_d_min": 0.05e-3,  # m
    "c10_rel_max": 0.02,
}

_MN = 1e-6  # N/m -> MN/m
_MM = 1e3  # m -> mm


@dataclass(frozen=True)
class ClaimResult:
    """One row of the claims table.

    Attributes
    ----------
    number : int
        Claim number (1-10, SPEC section 7).
    claim : str
        The seed's claim.
    test : str
        The test and its threshold, in words.
    measured : str
        The measured numbers.
    passed : bool or None
        Outcome; None when the study lacks what the test needs (e.g. no loss variants).
    values : dict
        The measured numbers in SI units, for programmatic use.
    """

    number: int
    claim: str
    test: str
    measured: str
    passed: bool | None
    values: dict

    @property
    def verdict(self) -> str:
        return {True: "PASS", False: "FAIL", None: "not evaluated"}[self.passed]


# --------------------------------------------------------------------------------------------------
# measurements
# --------------------------------------------------------------------------------------------------
def ripple(indentation: np.ndarray, stiffness: np.ndarray, d_max: float, window: float, k_ref: float) -> float:
    """Small-d ripple of a stiffness curve [1].

    RMS over 0 < d <= ``d_max`` of K minus its Savitzky-Golay smoothing (quadratic, ``window`` wide,
    polynomial end treatment), divided by ``k_ref``. The smoothing is applied on a range extended by
    one window beyond ``d_max`` so that the upper end of the evaluated range is not an edge.

    Parameters
    ----------
    indentation : array_like
        Uniform indentation grid starting at 0 [m].
    stiffness : array_like
        K on that grid [N/m]; NaN samples are not allowed inside the used range.
    d_max : float
        Upper end of the evaluated range [m].
    window : float
        Smoothing window [m]; must span at least 5 samples.
    k_ref : float
        Normalising stiffness [N/m].
    """
    d = np.asarray(indentation, dtype=float)
    k = np.asarray(stiffness, dtype=float)
    step = d[1] - d[0]
    n_win = int(round(window / step)) | 1  # odd
    if n_win < 5:
        raise ValueError(f"ripple window {window:g} m spans {n_win} samples of {step:g} m; need >= 5")
    use = d <= d_max + window + 1e-9 * d_max
    ku = k[use]
    if not np.all(np.isfinite(ku)):
        raise ValueError(f"stiffness has NaN samples below d = {d_max + window:g} m; cannot measure ripple")
    if ku.size < n_win:
        raise ValueError(f"only {ku.size} samples below d = {d_max + window:g} m, fewer than the ripple window")
    resid = ku - savgol_filter(ku, n_win, 2, mode="interp")
    sel = (d[use] > 0) & (d[use] <= d_max * (1 + 1e-9))
    return float(np.sqrt(np.mean(resid[sel] ** 2)) / k_ref)


def count_growth_peak(indentation: np.ndarray, fraction: np.ndarray, window: float) -> float:
    """Indentation at which the contact fraction grows fastest [m].

    The growth rate at d is the slope of the fraction between d - window/2 and d + window/2
    (truncated at the ends of the finite data), which averages over the unit steps of the
    element count. Returns the first d of the maximum.
    """
    d = np.asarray(indentation, dtype=float)
    f = np.asarray(fraction, dtype=float)
    ok = np.isfinite(f)
    d, f = d[ok], f[ok]
    lo = np.clip(d - window / 2, d[0], d[-1])
    hi = np.clip(d + window / 2, d[0], d[-1])
    rate = (np.interp(hi, d, f) - np.interp(lo, d, f)) / (hi - lo)
    return float(d[int(np.argmax(rate))])


def quasistatic_resampling_check(
    qs_indentation: np.ndarray,
    qs_force: np.ndarray,
    dyn_indentation: np.ndarray,
    grid: np.ndarray,
    saturation_range: Sequence[float],
    d_min: float,
) -> tuple[float, float]:
    """Stiffness of a quasi-static run estimated on another (dynamic) indentation sampling.

    The QS force is linearly interpolated at the dynamic run's native indentations (those within the
    QS range), differentiated with :func:`tyreroad.study.contact_stiffness`, interpolated onto the
    common grid, and compared with the estimate from the QS run's own samples.

    Returns
    -------
    (float, float)
        K_sat(resampled)/K_sat(native) - 1, and max over grid d >= ``d_min`` of
        |K_resampled - K_native| / K_sat(native) [1].
    """
    dq = np.asarray(qs_indentation, dtype=float)
    fq = np.asarray(qs_force, dtype=float)
    da = np.asarray(dyn_indentation, dtype=float)
    da = da[np.isfinite(da) & (da <= dq[-1] * (1 + 1e-12))]
    k_native = _on_grid(grid, dq, contact_stiffness(dq, fq))
    k_resampled = _on_grid(grid, da, contact_stiffness(da, np.interp(da, dq, fq)))
    ks_native = saturated_stiffness(grid, k_native, saturation_range)
    ks_resampled = saturated_stiffness(grid, k_resampled, saturation_range)
    sel = (grid >= d_min) & np.isfinite(k_native) & np.isfinite(k_resampled)
    pointwise = float(np.max(np.abs(k_resampled[sel] - k_native[sel])) / ks_native)
    return ks_resampled / ks_native - 1.0, pointwise


def _on_grid(grid: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    out = np.interp(grid, x, y)
    tol = 1e-9 * abs(x[-1])
    out[(grid < x[0] - tol) | (grid > x[-1] + tol)] = np.nan
    return out


# --------------------------------------------------------------------------------------------------
# the claims
# --------------------------------------------------------------------------------------------------
def _mn(x: float) -> str:
    return f"{x * _MN:.3f} MN/m"


def _pct(x: float) -> str:
    return f"{100 * x:+.2f} %"


def evaluate_claims(study: xr.Dataset, settings: StudySettings, variants: Mapping[str, Any]) -> list[ClaimResult]:
    """Evaluate the ten seed claims on a study dataset (see the module docstring for the tests).

    Parameters
    ----------
    study : xarray.Dataset
        From :func:`tyreroad.study.aggregate` / :func:`tyreroad.study.open_study`.
    settings : StudySettings
        The study settings (reference material, accelerations, saturation range).
    variants : mapping
        ``{"loss": [[scale, name], ...], "density": [[scale, name], ...]}`` (see
        :func:`tyreroad.study.variant_members`).

    Returns
    -------
    list of ClaimResult
        Ten results, claims 1-10 in order.
    """
    t = THRESHOLDS
    ref = settings.reference_material
    accels = sorted(settings.accelerations)
    a_ref = accels[-1]
    d = study["indentation"].values
    sat = settings.saturation_range
    materials = [str(m) for m in dict.fromkeys(study["material"].values.astype(str))]

    def case(material: str, mode: str, accel: float) -> xr.Dataset:
        return study.study.sel_case(material=material, mode=mode, accel=accel)

    def k(material, mode, accel):
        return case(material, mode, accel)["stiffness"].values

    def ksat(material, mode, accel):
        return float(case(material, mode, accel)["saturated_stiffness"])

    qs_k = k(ref, "quasistatic", 0)
    results: list[ClaimResult] = []

    # 1 -----------------------------------------------------------------------------------------
    ratios = {}
    for a in accels:
        ka = k(ref, "dynamic", a)
        sel = (d > t["c1_d_min"]) & np.isfinite(ka) & np.isfinite(qs_k)
        ratios[a] = float(np.min(ka[sel] / qs_k[sel]))
    results.append(
        ClaimResult(
            1,
            "dynamic stiffer than quasi-static at every d > 0.05 mm",
            f"K_a(d)/K_QS(d) > 1 at every grid d > {t['c1_d_min'] * _MM:g} mm, every a",
            "min K_a/K_QS: " + ", ".join(f"a={a:g}: {r:.3f}" for a, r in ratios.items()),
            all(r > 1.0 for r in ratios.values()),
            {"min_ratio": ratios},
        )
    )

    # 2 -----------------------------------------------------------------------------------------
    seq = [("QS", ksat(ref, "quasistatic", 0))] + [(f"{a:g}", ksat(ref, "dynamic", a)) for a in accels]
    ordered = all(seq[i + 1][1] > seq[i][1] for i in range(len(seq) - 1))
    results.append(
        ClaimResult(
            2,
            "K_500 > K_250 > K_50 > K_QS when saturated",
            "K_sat strictly increasing: QS < " + " < ".join(f"a={a:g}" for a in accels),
            "K_sat: " + ", ".join(f"{name}: {_mn(v)}" for name, v in seq),
            ordered,
            {"saturated_stiffness": dict(seq)},
        )
    )

    # 3 -----------------------------------------------------------------------------------------
    qs_f = case(ref, "quasistatic", 0)["force"].values
    rms = {}
    for a in accels:
        fa = case(ref, "dynamic", a)["force"].values
        ok = np.isfinite(fa) & np.isfinite(qs_f)
        last = np.flatnonzero(ok)[-1]
        diff = fa[ok] / fa[last] - qs_f[ok] / qs_f[last]
        rms[a] = float(np.sqrt(np.mean(diff**2)))
    results.append(
        ClaimResult(
            3,
            "F(d) curves of similar shape",
            f"RMS of F_a/F_a(d_end) − F_QS/F_QS(d_end) ≤ {t['c3_rms_max']:g}, every a",
            "RMS: " + ", ".join(f"a={a:g}: {r:.4f}" for a, r in rms.items()),
            all(r <= t["c3_rms_max"] for r in rms.values()),
            {"rms": rms},
        )
    )

    # 4 -----------------------------------------------------------------------------------------
    peaks, reached = {}, {}
    for mode, a in [("quasistatic", 0.0)] + [("dynamic", a) for a in accels]:
        frac = case(ref, mode, a)["contact_fraction"].values
        label = "QS" if mode == "quasistatic" else f"{a:g}"
        peaks[label] = count_growth_peak(d, frac, t["c4_window"])
        ok = np.isfinite(frac)
        reached[label] = float(np.interp(t["c4_d_peak_max"], d[ok], frac[ok]) / frac[ok][-1])
    results.append(
        ClaimResult(
            4,
            "contact count grows fastest up to d ≈ 0.05 mm",
            f"d of max growth rate of the contact fraction ({t['c4_window'] * _MM:g} mm window) "
            f"≤ {t['c4_d_peak_max'] * _MM:g} mm, every run",
            "d_peak [mm]: " + ", ".join(f"{k_}: {v * _MM:.3f}" for k_, v in peaks.items())
            + f"; share of final count reached at {t['c4_d_peak_max'] * _MM:g} mm: "
            + ", ".join(f"{k_}: {v:.2f}" for k_, v in reached.items()),
            all(v <= t["c4_d_peak_max"] * (1 + 1e-9) for v in peaks.values()),
            {"d_peak": peaks, "share_at_limit": reached},
        )
    )

    # 5 -----------------------------------------------------------------------------------------
    rc = case(ref, "dynamic", a_ref)
    frac = rc["contact_fraction"].values
    ok = np.isfinite(frac)
    frac_at = float(np.interp(t["c5_d"], d[ok], frac[ok]))
    kref = rc["stiffness"].values
    ksat_ref = float(rc["saturated_stiffness"])
    in_sat = (d >= sat[0] - 1e-12) & (d <= sat[1] + 1e-12) & np.isfinite(kref)
    slope = float(np.polyfit(d[in_sat], kref[in_sat], 1)[0])
    change = abs(slope) * (sat[1] - sat[0]) / ksat_ref
    qs_frac = case(ref, "quasistatic", 0)["contact_fraction"].values
    okq = np.isfinite(qs_frac)
    qs_frac_at = float(np.interp(t["c5_d"], d[okq], qs_frac[okq]))
    results.append(
        ClaimResult(
            5,
            "≈50 % of elements in contact at d = 0.15 mm and K saturates beyond it",
            f"reference case: contact fraction at {t['c5_d'] * _MM:g} mm in [{t['c5_fraction_lo']:g}, "
            f"{t['c5_fraction_hi']:g}] and line-fit change of K over [{sat[0] * _MM:g}, {sat[1] * _MM:g}] mm "
            f"≤ {100 * t['c5_change_max']:g} % of K_sat",
            f"fraction {frac_at:.3f} (QS: {qs_frac_at:.3f}); K change {100 * change:.2f} %",
            bool(t["c5_fraction_lo"] <= frac_at <= t["c5_fraction_hi"] and change <= t["c5_change_max"]),
            {"fraction": frac_at, "fraction_qs": qs_frac_at, "change": change},
        )
    )

    # 6 -----------------------------------------------------------------------------------------
    loss = [(s, m) for s, m in variant_members(variants, "loss", materials, ref) if m != ref]
    if loss:
        deltas = {s: ksat(m, "dynamic", a_ref) / ksat_ref - 1.0 for s, m in loss}
        mags = [abs(v) for v in deltas.values()]
        passed6: bool | None = bool(max(mags) <= t["c6_delta_max"] and max(mags) >= t["c6_delta_min"])
        measured6 = "ΔK_sat: " + ", ".join(f"η×{s:g}: {_pct(v)}" for s, v in deltas.items())
    else:
        deltas, passed6, measured6 = {}, None, "no loss-factor variants in the study"
    results.append(
        ClaimResult(
            6,
            "loss factor ±50 % changes K_sat by a few percent (≈3 %)",
            f"at a={a_ref:g}: every \\|ΔK_sat\\| ≤ {100 * t['c6_delta_max']:g} % and the largest "
            f"≥ {100 * t['c6_delta_min']:g} %",
            measured6,
            passed6,
            {"delta": deltas},
        )
    )

    # 7 -----------------------------------------------------------------------------------------
    dens = [(s, m) for s, m in variant_members(variants, "density", materials, ref) if m != ref]
    if dens:
        deltas7 = {s: ksat(m, "dynamic", a_ref) / ksat_ref - 1.0 for s, m in dens}
        rip = {1.0: ripple(d, kref, t["c7_ripple_d_max"], t["c7_ripple_window"], ksat_ref)}
        for s, m in dens:
            rip[s] = ripple(d, k(m, "dynamic", a_ref), t["c7_ripple_d_max"], t["c7_ripple_window"], ksat_ref)
        heavy = max(s for s, _ in dens)
        ratio = rip[heavy] / rip[1.0] if rip[1.0] > 0 else math.inf
        ok_delta = all(abs(v) <= t["c7_delta_max"] for v in deltas7.values())
        passed7: bool | None = bool(ok_delta and heavy > 1.0 and ratio >= t["c7_ripple_ratio_min"])
        measured7 = (
            "ΔK_sat: " + ", ".join(f"ρ×{s:g}: {_pct(v)}" for s, v in deltas7.items())
            + "; ripple/K_sat: " + ", ".join(f"ρ×{s:g}: {v:.2e}" for s, v in sorted(rip.items()))
            + f"; ripple ratio ρ×{heavy:g}/ref: {ratio:.2f}"
        )
    else:
        deltas7, rip, ratio, passed7, measured7 = {}, {}, math.nan, None, "no density variants in the study"
    results.append(
        ClaimResult(
            7,
            "density ×2 and ×0.5 change K_sat by ≲ 2 % while adding ripples at small d",
            f"at a={a_ref:g}: every \\|ΔK_sat\\| ≤ {100 * t['c7_delta_max']:g} % and ripple (RMS of K − "
            f"smoothed K for d ≤ {t['c7_ripple_d_max'] * _MM:g} mm) of the heaviest variant ≥ "
            f"{t['c7_ripple_ratio_min']:g} × reference",
            measured7,
            passed7,
            {"delta": deltas7, "ripple": rip, "ripple_ratio": ratio},
        )
    )

    # 8 -----------------------------------------------------------------------------------------
    rel8 = ksat_ref / t["c8_target"] - 1.0
    results.append(
        ClaimResult(
            8,
            "K_sat ≈ 2.75 MN/m at 500 m/s²",
            f"reference case (a={a_ref:g}) K_sat within ±{100 * t['c8_rel_tol']:g} % of "
            f"{t['c8_target'] * _MN:g} MN/m (calibration target of the material, SPEC 5)",
            f"K_sat = {_mn(ksat_ref)} ({_pct(rel8)})",
            abs(rel8) <= t["c8_rel_tol"],
            {"saturated_stiffness": ksat_ref, "relative_error": rel8},
        )
    )

    # 9 -----------------------------------------------------------------------------------------
    qsc = case(ref, "quasistatic", 0)
    nq = int(qsc["native_samples"])
    dq = qsc["native_indentation"].values[:nq]
    fq = qsc["native_force"].values[:nq]
    ks9, pw9 = {}, {}
    for a in accels:
        dc = case(ref, "dynamic", a)
        da = dc["native_indentation"].values[: int(dc["native_samples"])]
        ks9[a], pw9[a] = quasistatic_resampling_check(dq, fq, da, d, sat, t["c9_d_min"])
    results.append(
        ClaimResult(
            9,
            "QS stiffness independent of acceleration",
            "holds by construction (QS solver has no time); test: QS force resampled at each a's d_n, "
            f"\\|ΔK_sat\\| ≤ {100 * t['c9_ksat_rel_max']:g} % and pointwise \\|ΔK\\| ≤ "
            f"{100 * t['c9_pointwise_rel_max']:g} % K_sat for d ≥ {t['c9_d_min'] * _MM:g} mm",
            "ΔK_sat: " + ", ".join(f"a={a:g}: {_pct(v)}" for a, v in ks9.items())
            + "; max pointwise: " + ", ".join(f"a={a:g}: {100 * v:.2f} %" for a, v in pw9.items()),
            all(abs(ks9[a]) <= t["c9_ksat_rel_max"] and pw9[a] <= t["c9_pointwise_rel_max"] for a in accels),
            {"ksat_change": ks9, "pointwise": pw9},
        )
    )

    # 10 ----------------------------------------------------------------------------------------
    rel10 = study["saturated_backing_stiffness"].values / study["saturated_stiffness"].values - 1.0
    worst = int(np.argmax(np.abs(rel10)))
    ref_idx = list(study["case"].values.astype(str)).index(case_label(ref, "dynamic", a_ref))
    results.append(
        ClaimResult(
            10,
            "backing force gives equivalent results",
            f"every case: \\|K_sat(backing)/K_sat(surface) − 1\\| ≤ {100 * t['c10_rel_max']:g} %",
            f"reference case {_pct(float(rel10[ref_idx]))}; worst {study['case'].values[worst]}: "
            f"{_pct(float(rel10[worst]))}",
            bool(np.max(np.abs(rel10)) <= t["c10_rel_max"]),
            {"relative_difference": dict(zip(study["case"].values.astype(str), rel10.tolist()))},
        )
    )
    for r in results:
        logger.info("claim %d: %s (%s)", r.number, r.verdict, r.measured)
    return results


# --------------------------------------------------------------------------------------------------
# markdown
# --------------------------------------------------------------------------------------------------
def _greens_by_material(greens: Mapping[str, xr.Dataset] | Sequence[xr.Dataset] | None) -> dict[str, xr.Dataset]:
    if greens is None:
        return {}
    if isinstance(greens, Mapping):
        return dict(greens)
    out = {}
    for i, ds in enumerate(greens):
        if "material" not in ds.attrs:
            raise ValueError(f"Green's dataset #{i} has no 'material' attribute; pass a mapping material -> dataset")
        out[str(ds.attrs["material"])] = ds
    return out


def _material_config(ds: xr.Dataset, name: str) -> dict:
    """The resolved material preset recorded in a Green's file's provenance (empty if absent)."""
    try:
        cfg = yaml.safe_load(ds.attrs.get("config", "")) or {}
        return dict(cfg.get("material", {}).get(name, {}))
    except (yaml.YAMLError, AttributeError, TypeError):
        return {}


def _surface_section(surface: xr.Dataset) -> list[str]:
    need = ("mpd", "rms_height", "skewness", "peak_fraction_within", "z1")
    missing = [n for n in need if n not in surface.variables]
    if missing:
        raise ValueError(f"surface dataset lacks {', '.join(missing)} (docs/data_contracts.md 'Surface dataset')")
    lines = [
        f"## Road surface `{surface.attrs.get('surface', '?')}`",
        "",
        "| quantity | value |",
        "|---|---|",
        f"| MPD (whole field, ISO 13473-1) | {float(surface['mpd']) * _MM:.3f} mm |",
        f"| rms height | {float(surface['rms_height']) * 1e6:.1f} µm |",
        f"| skewness | {float(surface['skewness']):+.3f} |",
        f"| patch elements | {surface.sizes['ex']} × {surface.sizes['ey']} |",
    ]
    if "element_size" in surface.attrs:
        lines.append(f"| element size | {float(surface.attrs['element_size']) * _MM:g} mm |")
    depth_dim = surface["peak_fraction_within"].dims[0]
    for depth, frac in zip(surface[depth_dim].values, surface["peak_fraction_within"].values):
        lines.append(f"| element peaks within {float(depth) * _MM:.2f} mm of the top | {100 * float(frac):.1f} % |")
    return lines + [""]


def _material_section(greens: dict[str, xr.Dataset], materials: Sequence[str], variants: Mapping[str, Any], ref: str) -> list[str]:
    scale = {m: ("", "") for m in materials}
    for kind, col in (("loss", 0), ("density", 1)):
        for s, m in variant_members(variants, kind, materials, ref):
            cur = list(scale[m])
            cur[col] = f"{s:g}"
            scale[m] = tuple(cur)
    freqs = (100.0, 1000.0, 10000.0)
    lines = [
        "## Materials",
        "",
        "| material | η scale | ρ scale | ρ [kg/m³] | ν | h [mm] | "
        + " | ".join(f"E′ / η at {f:g} Hz" for f in freqs)
        + " | kept g(0) fraction | precursor energy |",
        "|---|---|---|---|---|---|" + "---|" * len(freqs) + "---|---|",
    ]
    for m in materials:
        ds = greens.get(m)
        cells = [m, scale[m][0] or "—", scale[m][1] or "—"]
        if ds is None:
            cells += ["—"] * (3 + len(freqs) + 2)
        else:
            cfg = _material_config(ds, m)
            cells += [
                f"{float(cfg['density']):g}" if "density" in cfg else "—",
                f"{float(cfg['poisson_ratio']):g}" if "poisson_ratio" in cfg else "—",
                f"{float(cfg['thickness']) * _MM:g}" if "thickness" in cfg else "—",
            ]
            f = ds["frequency"].values
            for fr in freqs:
                if f[0] <= fr <= f[-1]:
                    e = np.interp(fr, f, ds["storage_modulus"].values)
                    eta = np.interp(fr, f, ds["loss_factor"].values)
                    cells.append(f"{e * 1e-6:.1f} MPa / {eta:.3f}")
                else:
                    cells.append("outside band")
            cells.append(f"{float(ds['kept_fraction']):.4f}" if "kept_fraction" in ds else "—")
            cells.append(f"{float(ds['precursor_energy_fraction']):.2e}" if "precursor_energy_fraction" in ds else "—")
        lines.append("| " + " | ".join(cells) + " |")
    return lines + [""]


def _cases_section(study: xr.Dataset) -> list[str]:
    d = study["indentation"].values
    lines = [
        "## Cases",
        "",
        "| case | K_sat [MN/m] | K_sat from backing force [MN/m] | contact fraction at 0.15 mm | F at d_max [N] |",
        "|---|---|---|---|---|",
    ]
    for i, label in enumerate(study["case"].values.astype(str)):
        c = study.isel(case=i)
        frac = c["contact_fraction"].values
        ok = np.isfinite(frac)
        f = c["force"].values
        lines.append(
            f"| {label} | {float(c['saturated_stiffness']) * _MN:.4f} | "
            f"{float(c['saturated_backing_stiffness']) * _MN:.4f} | "
            f"{np.interp(0.15e-3, d[ok], frac[ok]):.3f} | {f[np.isfinite(f)][-1]:.2f} |"
        )
    return lines + [""]


def build_report(
    study: xr.Dataset,
    surface: xr.Dataset | None,
    greens: Mapping[str, xr.Dataset] | Sequence[xr.Dataset] | None,
    settings: StudySettings,
    variants: Mapping[str, Any],
    config: Mapping[str, Any] | None = None,
) -> str:
    """The markdown text of ``results/report.md``.

    Parameters
    ----------
    study : xarray.Dataset
        The study dataset.
    surface : xarray.Dataset or None
        The study's surface dataset (texture statistics section); None omits the section.
    greens : mapping or sequence of xarray.Dataset, or None
        Green's datasets per material (material summary); a sequence is keyed by each dataset's
        ``material`` attribute.
    settings : StudySettings
        The study settings.
    variants : mapping
        Loss and density variant groups (:func:`tyreroad.study.variant_members`).
    config : mapping, optional
        The config that made the report (its hash is printed); default: the study settings and
        the variants.

    Returns
    -------
    str
        Markdown.
    """
    claims = evaluate_claims(study, settings, variants)
    if config is None:
        config = {
            "study": {
                "surface": settings.surface,
                "reference_material": settings.reference_material,
                "materials": list(settings.materials),
                "accelerations": list(settings.accelerations),
                "indentation_step": settings.indentation_step,
                "saturation_range": list(settings.saturation_range),
            },
            "d_max": settings.d_max,
            "variants": {k: [list(m) for m in v] for k, v in variants.items()},
        }
    n_pass = sum(c.passed is True for c in claims)
    n_eval = sum(c.passed is not None for c in claims)
    a_ref = max(settings.accelerations)
    lines = [
        "# tyreroad: claims of Winroth, Andersson & Kropp (JSV 2014) checked",
        "",
        f"- tyreroad version: {io.code_version()} (study file made by "
        f"{study.attrs.get('tyreroad_version', 'unknown')})",
        f"- report config SHA-256: `{io.config_hash(config)}`",
        f"- study file config SHA-256: `{study.attrs.get('config_sha256', 'not recorded')}`",
        f"- surface `{settings.surface}`, reference material `{settings.reference_material}`, "
        f"reference case: dynamic at a = {a_ref:g} m/s², d_max = {settings.d_max * _MM:g} mm",
        f"- K = dF/dd by second-order differences on each run's native samples, then linear interpolation "
        f"onto a {settings.indentation_step * 1e6:g} µm grid; K_sat = median K over "
        f"[{settings.saturation_range[0] * _MM:g}, {settings.saturation_range[1] * _MM:g}] mm",
        "",
        f"## Seed claims: {n_pass} of {n_eval} evaluated pass",
        "",
        "| # | claim (seed) | test and threshold | measured | result |",
        "|---|---|---|---|---|",
    ]
    for c in claims:
        lines.append(f"| {c.number} | {c.claim} | {c.test} | {c.measured} | **{c.verdict}** |")
    lines.append("")
    lines += _cases_section(study)
    if surface is not None:
        lines += _surface_section(surface)
    materials = [str(m) for m in dict.fromkeys(study["material"].values.astype(str))]
    lines += _material_section(_greens_by_material(greens), materials, variants, settings.reference_material)
    lines += ["## Config", "", "```yaml", io.config_yaml(config).rstrip(), "```", ""]
    return "\n".join(lines)


def write_report(text: str, path: str | Path) -> Path:
    """Write the report atomically (no partial file on failure)."""
    with io.atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    logger.info("wrote %s", path)
    return Path(path)
