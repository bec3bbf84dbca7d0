"""The claims of ``results/report.md`` (SPEC section 7): thresholds, measurements and the registry.

Each of the ten claims of the seed paper is turned into a test with an explicit threshold: one small
function per claim, registered by number in :data:`CLAIMS`, takes a :class:`ClaimContext` (the study
dataset of :mod:`tyreroad.study`, its settings and the variant groups) and returns a
:class:`ClaimResult` with the measured numbers and a verdict: "holds", "fails", or for claim 6
"size holds, direction opposite" (:data:`VERDICTS`). The report lists them in a markdown table,
explains what decides claims 5-7, and gives the equivalent quasi-static stiffness s(a) of the study
file (:func:`tyreroad.study.equivalent_modulus_scale`). Unless stated, a claim is tested on the reference material; "the reference case" is
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
6. Loss factor +-50 % changes K_sat by a few percent (~3 %), a higher loss factor giving a stiffer
   saturated contact: at the reference acceleration, Delta = K_sat(variant)/K_sat(reference) - 1 for
   every loss variant. Size: all |Delta| <= 10 % and the largest |Delta| >= 0.5 % (the effect exists
   but is small). Direction: Delta has the sign of (scale - 1) for every variant. Both: "holds"; size
   with every sign opposite: "size holds, direction opposite"; otherwise "fails"
   (:func:`loss_direction_verdict`).
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
   pointwise difference for d >= 0.05 mm is <= 5 % of K_sat. A QS run with a stored tangent (coarse
   QS grid) is resampled through the cubic Hermite interpolant of (d, F, dF/dd), as the study does.
10. Backing force gives equivalent results: for every case, |K_sat(backing)/K_sat(surface) - 1| <= 2 %.

The registry is the one place a verdict is decided: the report's table and the sensitivity sweep
(:mod:`tyreroad.sensitivity`) both call the functions of :data:`CLAIMS`.

:data:`THRESHOLDS` also holds the limits of the rolling section (:func:`tyreroad.report.rolling_section`):
a dynamic rolling case whose fs/2 chatter measure exceeds ``rolling_chatter_max`` is flagged as not
trustworthy (the force alternates from step to step: a numerical instability of the time march, not
physics), as is one whose fs/2 alternation relative to the steady mean force exceeds
``rolling_alternation_max`` (1e-4: the chatter measure divides by the force fluctuation, which a flat road
does not have) or whose flat-road contact has a hole (an element without force inside a row's contact),
and the dynamic rolling-loss coefficients are called sensible inside
[``rolling_coefficient_lo``, ``rolling_coefficient_hi``], a decade around either end of the expected
tread-hysteresis range of 1e-3 to 1e-2 (a check for gross errors, not a claim).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import xarray as xr

from ..study import (
    StudySettings,
    case_label,
    contact_stiffness,
    hermite_on_grid,
    interp_on_grid,
    saturated_stiffness,
    variant_members,
)

logger = logging.getLogger(__name__)

__all__ = [
    "THRESHOLDS",
    "HOLDS",
    "DIRECTION_OPPOSITE",
    "FAILS",
    "NOT_EVALUATED",
    "VERDICTS",
    "ClaimResult",
    "ClaimContext",
    "CLAIMS",
    "evaluate_claims",
    "evaluate_context",
    "loss_direction_verdict",
    "saturation_change",
    "ripple",
    "count_growth_peak",
    "quasistatic_resampling_check",
]

#: Thresholds of the claim tests and of the rolling section (SI units); see the module docstring for the reasoning.
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
    "rolling_chatter_max": 0.05,  # 1
    "rolling_alternation_max": 1e-4,  # 1, of the steady mean force
    "rolling_coefficient_lo": 1e-4,  # 1
    "rolling_coefficient_hi": 5e-2,  # 1
}

_MN = 1e-6  # N/m -> MN/m
_MM = 1e3  # m -> mm


#: Verdict words of a claim (``ClaimResult.verdict``).
HOLDS = "holds"
DIRECTION_OPPOSITE = "size holds, direction opposite"
FAILS = "fails"
NOT_EVALUATED = "not evaluated"
VERDICTS = (HOLDS, DIRECTION_OPPOSITE, FAILS, NOT_EVALUATED)


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
    verdict : str
        One of :data:`VERDICTS`: "holds", "size holds, direction opposite" (claim 6: the size of the
        effect is as the seed says, its sign is not), "fails", or "not evaluated" when the study lacks
        what the test needs (e.g. no loss variants).
    values : dict
        The measured numbers in SI units, for programmatic use.
    """

    number: int
    claim: str
    test: str
    measured: str
    verdict: str
    values: dict

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"claim {self.number}: verdict must be one of {VERDICTS}, got {self.verdict!r}")

    @property
    def passed(self) -> bool | None:
        """True when the claim holds, None when not evaluated, False otherwise (also for "direction opposite")."""
        return {HOLDS: True, NOT_EVALUATED: None}.get(self.verdict, False)


def _verdict(ok: bool | None) -> str:
    return {True: HOLDS, False: FAILS, None: NOT_EVALUATED}[None if ok is None else bool(ok)]


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
    from scipy.signal import savgol_filter  # here, not at the top: scipy.signal costs ~0.5 s of every Snakemake start

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
    qs_stiffness: np.ndarray | None = None,
) -> tuple[float, float]:
    """Stiffness of a quasi-static run estimated on another (dynamic) indentation sampling.

    The QS force is interpolated at the dynamic run's native indentations (those within the QS
    range), differentiated with :func:`tyreroad.study.contact_stiffness`, interpolated onto the
    common grid, and compared with the estimate from the QS run's own samples. Without
    ``qs_stiffness`` the interpolation is linear and the native estimate is the second-order
    difference of the QS force; with it (the run's tangent dF/dd at its samples, coarse QS grids)
    the force is the cubic Hermite interpolant and the native estimate its derivative, as the study
    computes them (:func:`tyreroad.study.hermite_on_grid`).

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
    if qs_stiffness is None:
        k_native = interp_on_grid(grid, dq, contact_stiffness(dq, fq))
        fa = np.interp(da, dq, fq)
    else:
        kq = np.asarray(qs_stiffness, dtype=float)
        k_native = hermite_on_grid(grid, dq, fq, kq)[1]
        fa = hermite_on_grid(da, dq, fq, kq)[0]
    k_resampled = interp_on_grid(grid, da, contact_stiffness(da, fa))
    ks_native = saturated_stiffness(grid, k_native, saturation_range)
    ks_resampled = saturated_stiffness(grid, k_resampled, saturation_range)
    sel = (grid >= d_min) & np.isfinite(k_native) & np.isfinite(k_resampled)
    pointwise = float(np.max(np.abs(k_resampled[sel] - k_native[sel])) / ks_native)
    return ks_resampled / ks_native - 1.0, pointwise


# --------------------------------------------------------------------------------------------------
# the claims: one function per claim, registered in CLAIMS
# --------------------------------------------------------------------------------------------------
def _mn(x: float) -> str:
    return f"{x * _MN:.3f} MN/m"


def _pct(x: float) -> str:
    return f"{100 * x:+.2f} %"


class ClaimContext:
    """What every claim function needs: the study, its settings, the variant groups, and shortcuts.

    Parameters
    ----------
    study : xarray.Dataset
        From :func:`tyreroad.study.aggregate` / :func:`tyreroad.study.open_study`.
    settings : StudySettings
        The study settings (reference material, accelerations, saturation range).
    variants : mapping
        ``{"loss": [[scale, name], ...], "density": [[scale, name], ...]}`` (see
        :func:`tyreroad.study.variant_members`).
    thresholds : mapping, optional
        Thresholds of the claim tests: overrides of :data:`THRESHOLDS` (the keys not given keep
        their default).
    """

    def __init__(self, study: xr.Dataset, settings: StudySettings, variants: Mapping[str, Any],
                 thresholds: Mapping[str, float] | None = None) -> None:
        self.study = study
        self.settings = settings
        self.variants = variants
        self.t = {**THRESHOLDS, **dict(thresholds or {})}
        self.ref = settings.reference_material
        self.accels = sorted(settings.accelerations)
        self.a_ref = self.accels[-1]
        self.d = study["indentation"].values
        self.sat = settings.saturation_range
        self.materials = [str(m) for m in dict.fromkeys(study["material"].values.astype(str))]

    def case(self, material: str, mode: str, accel: float) -> xr.Dataset:
        return self.study.study.sel_case(material=material, mode=mode, accel=accel)

    def k(self, material: str, mode: str, accel: float) -> np.ndarray:
        """K(d) on the common grid [N/m]."""
        return self.case(material, mode, accel)["stiffness"].values

    def ksat(self, material: str, mode: str, accel: float) -> float:
        """K_sat [N/m]."""
        return float(self.case(material, mode, accel)["saturated_stiffness"])

    @property
    def ksat_ref(self) -> float:
        """K_sat of the reference case (reference material, dynamic, highest acceleration) [N/m]."""
        return self.ksat(self.ref, "dynamic", self.a_ref)

    def members(self, kind: str) -> list[tuple[float, str]]:
        """(scale, material) of the loss or density variants, the reference excluded."""
        return [(s, m) for s, m in variant_members(self.variants, kind, self.materials, self.ref) if m != self.ref]


#: The claim functions by number: each takes a :class:`ClaimContext` and returns a :class:`ClaimResult`.
CLAIMS: dict[int, Callable[[ClaimContext], ClaimResult]] = {}


def _register(number: int):
    def wrap(fn: Callable[[ClaimContext], ClaimResult]) -> Callable[[ClaimContext], ClaimResult]:
        if number in CLAIMS:
            raise RuntimeError(f"claim {number} registered twice")
        CLAIMS[number] = fn
        return fn

    return wrap


@_register(1)
def claim_dynamic_stiffer(c: ClaimContext) -> ClaimResult:
    """Claim 1: K_a(d) / K_QS(d) > 1 at every grid d > 0.05 mm, every acceleration."""
    t = c.t
    qs_k = c.k(c.ref, "quasistatic", 0)
    ratios = {}
    for a in c.accels:
        ka = c.k(c.ref, "dynamic", a)
        sel = (c.d > t["c1_d_min"]) & np.isfinite(ka) & np.isfinite(qs_k)
        ratios[a] = float(np.min(ka[sel] / qs_k[sel]))
    return ClaimResult(
        1,
        "dynamic stiffer than quasi-static at every d > 0.05 mm",
        f"K_a(d)/K_QS(d) > 1 at every grid d > {t['c1_d_min'] * _MM:g} mm, every a",
        "min K_a/K_QS: " + ", ".join(f"a={a:g}: {r:.3f}" for a, r in ratios.items()),
        _verdict(all(r > 1.0 for r in ratios.values())),
        {"min_ratio": ratios},
    )


@_register(2)
def claim_ordering(c: ClaimContext) -> ClaimResult:
    """Claim 2: K_sat strictly increasing with the acceleration, quasi-static lowest."""
    seq = [("QS", c.ksat(c.ref, "quasistatic", 0))] + [(f"{a:g}", c.ksat(c.ref, "dynamic", a)) for a in c.accels]
    ordered = all(seq[i + 1][1] > seq[i][1] for i in range(len(seq) - 1))
    return ClaimResult(
        2,
        "K_500 > K_250 > K_50 > K_QS when saturated",
        "K_sat strictly increasing: QS < " + " < ".join(f"a={a:g}" for a in c.accels),
        "K_sat: " + ", ".join(f"{name}: {_mn(v)}" for name, v in seq),
        _verdict(ordered),
        {"saturated_stiffness": dict(seq)},
    )


@_register(3)
def claim_force_shape(c: ClaimContext) -> ClaimResult:
    """Claim 3: RMS of the end-normalised F(d) differences to the quasi-static curve <= 0.05."""
    t = c.t
    qs_f = c.case(c.ref, "quasistatic", 0)["force"].values
    rms = {}
    for a in c.accels:
        fa = c.case(c.ref, "dynamic", a)["force"].values
        ok = np.isfinite(fa) & np.isfinite(qs_f)
        last = np.flatnonzero(ok)[-1]
        diff = fa[ok] / fa[last] - qs_f[ok] / qs_f[last]
        rms[a] = float(np.sqrt(np.mean(diff**2)))
    return ClaimResult(
        3,
        "F(d) curves of similar shape",
        f"RMS of F_a/F_a(d_end) − F_QS/F_QS(d_end) ≤ {t['c3_rms_max']:g}, every a",
        "RMS: " + ", ".join(f"a={a:g}: {r:.4f}" for a, r in rms.items()),
        _verdict(all(r <= t["c3_rms_max"] for r in rms.values())),
        {"rms": rms},
    )


@_register(4)
def claim_count_growth(c: ClaimContext) -> ClaimResult:
    """Claim 4: the contact fraction grows fastest at some d <= 0.05 mm, every run of the reference."""
    t, d = c.t, c.d
    peaks, reached = {}, {}
    for mode, a in [("quasistatic", 0.0)] + [("dynamic", a) for a in c.accels]:
        frac = c.case(c.ref, mode, a)["contact_fraction"].values
        label = "QS" if mode == "quasistatic" else f"{a:g}"
        peaks[label] = count_growth_peak(d, frac, t["c4_window"])
        ok = np.isfinite(frac)
        reached[label] = float(np.interp(t["c4_d_peak_max"], d[ok], frac[ok]) / frac[ok][-1])
    return ClaimResult(
        4,
        "contact count grows fastest up to d ≈ 0.05 mm",
        f"d of max growth rate of the contact fraction ({t['c4_window'] * _MM:g} mm window) "
        f"≤ {t['c4_d_peak_max'] * _MM:g} mm, every run",
        "d_peak [mm]: " + ", ".join(f"{k_}: {v * _MM:.3f}" for k_, v in peaks.items())
        + f"; share of final count reached at {t['c4_d_peak_max'] * _MM:g} mm: "
        + ", ".join(f"{k_}: {v:.2f}" for k_, v in reached.items()),
        _verdict(all(v <= t["c4_d_peak_max"] * (1 + 1e-9) for v in peaks.values())),
        {"d_peak": peaks, "share_at_limit": reached},
    )


def saturation_change(indentation: np.ndarray, stiffness: np.ndarray, saturation_range: Sequence[float], k_sat: float) -> float:
    """Claim 5's saturation measure: |slope| (d_hi - d_lo) / K_sat of a least-squares line of K(d) [1].

    The line is fitted over the saturation range (inclusive, finite samples only); a line fit is
    insensitive to ripples. K ~ d^0.5 would give about 0.16.
    """
    d = np.asarray(indentation, dtype=float)
    k = np.asarray(stiffness, dtype=float)
    lo, hi = float(saturation_range[0]), float(saturation_range[1])
    sel = (d >= lo - 1e-12) & (d <= hi + 1e-12) & np.isfinite(k)
    if np.count_nonzero(sel) < 2:
        raise ValueError(f"fewer than 2 finite stiffness samples in the saturation range [{lo:g}, {hi:g}] m")
    slope = float(np.polyfit(d[sel], k[sel], 1)[0])
    return abs(slope) * (hi - lo) / k_sat


@_register(5)
def claim_saturation(c: ClaimContext) -> ClaimResult:
    """Claim 5: contact fraction at 0.15 mm in [0.4, 0.6] and line-fit change of K over the saturation range <= 10 %."""
    t, d, sat = c.t, c.d, c.sat
    rc = c.case(c.ref, "dynamic", c.a_ref)
    frac = rc["contact_fraction"].values
    ok = np.isfinite(frac)
    frac_at = float(np.interp(t["c5_d"], d[ok], frac[ok]))
    change = saturation_change(d, rc["stiffness"].values, sat, c.ksat_ref)
    qs_frac = c.case(c.ref, "quasistatic", 0)["contact_fraction"].values
    okq = np.isfinite(qs_frac)
    qs_frac_at = float(np.interp(t["c5_d"], d[okq], qs_frac[okq]))
    frac_sat = [float(np.interp(x, d[ok], frac[ok])) for x in sat]
    return ClaimResult(
        5,
        "≈50 % of elements in contact at d = 0.15 mm and K saturates beyond it",
        f"reference case: contact fraction at {t['c5_d'] * _MM:g} mm in [{t['c5_fraction_lo']:g}, "
        f"{t['c5_fraction_hi']:g}] and line-fit change of K over [{sat[0] * _MM:g}, {sat[1] * _MM:g}] mm "
        f"≤ {100 * t['c5_change_max']:g} % of K_sat",
        f"fraction {frac_at:.3f} (QS: {qs_frac_at:.3f}); K change {100 * change:.2f} %; "
        f"fraction still grows {frac_sat[0]:.3f} → {frac_sat[1]:.3f} over the saturation range",
        _verdict(t["c5_fraction_lo"] <= frac_at <= t["c5_fraction_hi"] and change <= t["c5_change_max"]),
        {"fraction": frac_at, "fraction_qs": qs_frac_at, "change": change, "fraction_saturation_range": frac_sat},
    )


def loss_direction_verdict(deltas: Mapping[float, float], delta_max: float, delta_min: float) -> str:
    """Verdict of claim 6 from the K_sat changes of the loss-factor variants.

    The seed: a *higher* loss factor gives a *stiffer* saturated contact, by a few percent. Size:
    every |Delta| <= ``delta_max`` and the largest >= ``delta_min``. Direction: sign(Delta) =
    sign(scale - 1) for every variant (seed's direction) or the opposite sign for every variant.

    Parameters
    ----------
    deltas : mapping
        Loss scale [1] -> K_sat(variant) / K_sat(reference) - 1 [1]; the reference (scale 1) excluded.
    delta_max, delta_min : float
        Size limits [1].

    Returns
    -------
    str
        "holds" (size and direction), "size holds, direction opposite" (size as the seed, every sign
        opposite), or "fails" (size outside the limits, or the signs do not follow the scale
        one way or the other).
    """
    if not deltas:
        return NOT_EVALUATED
    mags = [abs(v) for v in deltas.values()]
    if not (max(mags) <= delta_max and max(mags) >= delta_min):
        return FAILS
    seed = [np.sign(v) == np.sign(s - 1.0) and v != 0 for s, v in deltas.items()]
    opposite = [np.sign(v) == -np.sign(s - 1.0) and v != 0 for s, v in deltas.items()]
    if all(seed):
        return HOLDS
    if all(opposite):
        return DIRECTION_OPPOSITE
    return FAILS


@_register(6)
def claim_loss_factor(c: ClaimContext) -> ClaimResult:
    """Claim 6: loss factor x0.5 / x1.5 changes K_sat by a few percent, a higher loss factor stiffer."""
    t = c.t
    loss = c.members("loss")
    if loss:
        deltas = {s: c.ksat(m, "dynamic", c.a_ref) / c.ksat_ref - 1.0 for s, m in loss}
        verdict = loss_direction_verdict(deltas, t["c6_delta_max"], t["c6_delta_min"])
        higher = [v for s, v in deltas.items() if s > 1.0]
        direction = ""
        if higher:
            direction = "; here higher η → " + ("stiffer" if all(v > 0 for v in higher) else
                                                 "softer" if all(v < 0 for v in higher) else "mixed")
        measured = "ΔK_sat: " + ", ".join(f"η×{s:g}: {_pct(v)}" for s, v in deltas.items()) + direction
    else:
        deltas, verdict, measured = {}, NOT_EVALUATED, "no loss-factor variants in the study"
    return ClaimResult(
        6,
        "loss factor ±50 % changes K_sat by a few percent (≈3 %); higher loss factor → stiffer",
        f"at a={c.a_ref:g}: size: every \\|ΔK_sat\\| ≤ {100 * t['c6_delta_max']:g} % and the largest "
        f"≥ {100 * t['c6_delta_min']:g} %; direction: ΔK_sat has the sign of (η scale − 1)",
        measured,
        verdict,
        {"delta": deltas},
    )


@_register(7)
def claim_density(c: ClaimContext) -> ClaimResult:
    """Claim 7: density x2 / x0.5 change K_sat by <= 3 % and the heaviest variant ripples >= 1.2 x the reference."""
    t, d = c.t, c.d
    dens = c.members("density")
    if dens:
        ksat_ref = c.ksat_ref
        deltas = {s: c.ksat(m, "dynamic", c.a_ref) / ksat_ref - 1.0 for s, m in dens}
        rip = {1.0: ripple(d, c.k(c.ref, "dynamic", c.a_ref), t["c7_ripple_d_max"], t["c7_ripple_window"], ksat_ref)}
        for s, m in dens:
            rip[s] = ripple(d, c.k(m, "dynamic", c.a_ref), t["c7_ripple_d_max"], t["c7_ripple_window"], ksat_ref)
        heavy = max(s for s, _ in dens)
        ratio = rip[heavy] / rip[1.0] if rip[1.0] > 0 else math.inf
        # the quasi-static run has no inertia: its ripple is what elements entering contact make
        rip_qs = ripple(d, c.k(c.ref, "quasistatic", 0), t["c7_ripple_d_max"], t["c7_ripple_window"], ksat_ref)
        ok_delta = all(abs(v) <= t["c7_delta_max"] for v in deltas.values())
        verdict = _verdict(ok_delta and heavy > 1.0 and ratio >= t["c7_ripple_ratio_min"])
        measured = (
            "ΔK_sat: " + ", ".join(f"ρ×{s:g}: {_pct(v)}" for s, v in deltas.items())
            + "; ripple/K_sat: " + ", ".join(f"ρ×{s:g}: {v:.2e}" for s, v in sorted(rip.items()))
            + f"; ripple ratio ρ×{heavy:g}/ref: {ratio:.2f}"
        )
    else:
        deltas, rip, ratio, rip_qs, verdict, measured = {}, {}, math.nan, math.nan, NOT_EVALUATED, "no density variants in the study"
    return ClaimResult(
        7,
        "density ×2 and ×0.5 change K_sat by ≲ 2 % while adding ripples at small d",
        f"at a={c.a_ref:g}: every \\|ΔK_sat\\| ≤ {100 * t['c7_delta_max']:g} % and ripple (RMS of K − "
        f"smoothed K for d ≤ {t['c7_ripple_d_max'] * _MM:g} mm) of the heaviest variant ≥ "
        f"{t['c7_ripple_ratio_min']:g} × reference",
        measured,
        verdict,
        {"delta": deltas, "ripple": rip, "ripple_ratio": ratio, "ripple_quasistatic": rip_qs},
    )


@_register(8)
def claim_level(c: ClaimContext) -> ClaimResult:
    """Claim 8: reference-case K_sat within +-15 % of 2.75 MN/m (the calibration target)."""
    t = c.t
    ksat_ref = c.ksat_ref
    rel = ksat_ref / t["c8_target"] - 1.0
    return ClaimResult(
        8,
        "K_sat ≈ 2.75 MN/m at 500 m/s²",
        f"reference case (a={c.a_ref:g}) K_sat within ±{100 * t['c8_rel_tol']:g} % of "
        f"{t['c8_target'] * _MN:g} MN/m (calibration target of the material, SPEC 5)",
        f"K_sat = {_mn(ksat_ref)} ({_pct(rel)})",
        _verdict(abs(rel) <= t["c8_rel_tol"]),
        {"saturated_stiffness": ksat_ref, "relative_error": rel},
    )


@_register(9)
def claim_qs_independent(c: ClaimContext) -> ClaimResult:
    """Claim 9: the QS stiffness estimate does not depend on the acceleration's sampling of d."""
    t = c.t
    qsc = c.case(c.ref, "quasistatic", 0)
    nq = int(qsc["native_samples"])
    dq = qsc["native_indentation"].values[:nq]
    fq = qsc["native_force"].values[:nq]
    tangent = "stiffness_from_tangent" in qsc and int(qsc["stiffness_from_tangent"]) > 0
    kq = qsc["native_stiffness"].values[:nq] if tangent else None
    ks, pw = {}, {}
    for a in c.accels:
        dc = c.case(c.ref, "dynamic", a)
        da = dc["native_indentation"].values[: int(dc["native_samples"])]
        ks[a], pw[a] = quasistatic_resampling_check(dq, fq, da, c.d, c.sat, t["c9_d_min"], kq)
    return ClaimResult(
        9,
        "QS stiffness independent of acceleration",
        "holds by construction (QS solver has no time); test: QS force resampled at each a's d_n, "
        f"\\|ΔK_sat\\| ≤ {100 * t['c9_ksat_rel_max']:g} % and pointwise \\|ΔK\\| ≤ "
        f"{100 * t['c9_pointwise_rel_max']:g} % K_sat for d ≥ {t['c9_d_min'] * _MM:g} mm",
        "ΔK_sat: " + ", ".join(f"a={a:g}: {_pct(v)}" for a, v in ks.items())
        + "; max pointwise: " + ", ".join(f"a={a:g}: {100 * v:.2f} %" for a, v in pw.items()),
        _verdict(all(abs(ks[a]) <= t["c9_ksat_rel_max"] and pw[a] <= t["c9_pointwise_rel_max"] for a in c.accels)),
        {"ksat_change": ks, "pointwise": pw},
    )


@_register(10)
def claim_backing(c: ClaimContext) -> ClaimResult:
    """Claim 10: |K_sat(backing) / K_sat(surface) - 1| <= 2 % for every case."""
    study = c.study
    rel = study["saturated_backing_stiffness"].values / study["saturated_stiffness"].values - 1.0
    worst = int(np.argmax(np.abs(rel)))
    ref_idx = list(study["case"].values.astype(str)).index(case_label(c.ref, "dynamic", c.a_ref))
    return ClaimResult(
        10,
        "backing force gives equivalent results",
        f"every case: \\|K_sat(backing)/K_sat(surface) − 1\\| ≤ {100 * c.t['c10_rel_max']:g} %",
        f"reference case {_pct(float(rel[ref_idx]))}; worst {study['case'].values[worst]}: "
        f"{_pct(float(rel[worst]))}",
        _verdict(np.max(np.abs(rel)) <= c.t["c10_rel_max"]),
        {"relative_difference": dict(zip(study["case"].values.astype(str), rel.tolist()))},
    )


def evaluate_claims(study: xr.Dataset, settings: StudySettings, variants: Mapping[str, Any],
                    thresholds: Mapping[str, float] | None = None) -> list[ClaimResult]:
    """Evaluate the seed claims of :data:`CLAIMS` on a study dataset (tests: see the module docstring).

    Parameters
    ----------
    study : xarray.Dataset
        From :func:`tyreroad.study.aggregate` / :func:`tyreroad.study.open_study`.
    settings : StudySettings
        The study settings (reference material, accelerations, saturation range).
    variants : mapping
        ``{"loss": [[scale, name], ...], "density": [[scale, name], ...]}`` (see
        :func:`tyreroad.study.variant_members`).
    thresholds : mapping, optional
        Overrides of :data:`THRESHOLDS`.

    Returns
    -------
    list of ClaimResult
        One per registered claim, by number (claims 1-10).
    """
    return evaluate_context(ClaimContext(study, settings, variants, thresholds))


def evaluate_context(ctx: ClaimContext) -> list[ClaimResult]:
    """Every claim of :data:`CLAIMS` on one :class:`ClaimContext`, by number (logged)."""
    results = [CLAIMS[n](ctx) for n in sorted(CLAIMS)]
    for r in results:
        logger.info("claim %d: %s (%s)", r.number, r.verdict, r.measured)
    return results
