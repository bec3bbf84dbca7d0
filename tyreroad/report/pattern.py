"""The pattern study's report (issue 27): ``results/pattern.md`` from ``results/pattern/study.nc``.

K_sat of every material on every pattern beside the slick tread of the same patch, the change against slick,
the grooved fraction of the patch, the seed's quasi-static claims re-checked on the pattern with the report's
thresholds (:data:`tyreroad.report.claims.THRESHOLDS`), the memory of the influence tables and the cost of the
greens and contact stages.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import xarray as xr

from .claims import THRESHOLDS, count_growth_peak, saturation_change
from .document import write_report
from .figures import figure_caption

__all__ = ["pattern_section", "spectrum_section", "figures_section", "build_pattern_report", "write_pattern_report"]

_SLICK = "slick"  # tyreroad.pattern.SLICK (not imported: the report does not run the contact code)


def _mb(n_bytes: float) -> str:
    return f"{n_bytes / 1e6:.3g}"


def _claims(ds: xr.Dataset, i: int, slick: int) -> list[str]:
    """Claims 3, 4 and 5 of the seed on case i (quasi-static), with the report's thresholds."""
    t = THRESHOLDS
    d = ds["indentation"].values
    k = ds["stiffness"].values[i]
    sat = tuple(float(v) for v in ds.attrs["saturation_range_m"])
    ksat = float(ds["saturated_stiffness"].values[i])
    blocks = 1.0 - float(ds["grooved_fraction"].values[i])
    frac = ds["contact_fraction"].values[i] / blocks  # of the elements on blocks (grooves never touch)
    f = ds["force"].values[i]
    fs = ds["force"].values[slick]
    ok = np.isfinite(f) & np.isfinite(fs) & (d > 0)
    shape_rms = float(np.sqrt(np.mean((f[ok] / f[ok][-1] - fs[ok] / fs[ok][-1]) ** 2)))
    d_peak = count_growth_peak(d, frac, t["c4_window"])
    at = float(np.interp(t["c5_d"], d, frac))
    change = saturation_change(d, k, sat, ksat)

    def verdict(ok_):
        return "holds" if ok_ else "fails"

    return [
        f"claim 3 (F(d) of similar shape as slick): rms of F/F(d_max) against slick {shape_rms:.3f} "
        f"(<= {t['c3_rms_max']:g}: {verdict(shape_rms <= t['c3_rms_max'])})",
        f"claim 4 (count grows fastest up to 0.05 mm): fastest at d = {1e3 * d_peak:.3f} mm "
        f"({verdict(d_peak <= t['c4_d_peak_max'])})",
        f"claim 5 (about half the block elements in contact at 0.15 mm, K saturated): {100 * at:.1f} % "
        f"(in [{100 * t['c5_fraction_lo']:.0f}, {100 * t['c5_fraction_hi']:.0f}] %: "
        f"{verdict(t['c5_fraction_lo'] <= at <= t['c5_fraction_hi'])}), line-fit change of K over the saturation "
        f"range {100 * change:.1f} % (<= {100 * t['c5_change_max']:.0f} %: {verdict(change <= t['c5_change_max'])})",
    ]


def pattern_section(ds: xr.Dataset) -> list[str]:
    """The pattern study as markdown lines (one table of cases, K(d) samples, claims, memory and cost)."""
    cases = [str(c) for c in ds["case"].values]
    materials = [str(m) for m in ds["material"].values]
    patterns = [str(p) for p in ds["pattern"].values]
    variants = [str(v) for v in ds["variant"].values] if "variant" in ds.coords else [""] * len(cases)
    sat = tuple(1e3 * float(v) for v in ds.attrs["saturation_range_m"])
    lines = [
        "## Patterned treads (issue 27)",
        "",
        f"Quasi-static runs on a patch placed on each tread pattern, beside the slick tread of the same patch, "
        f"surface and springs. K(d) and K_sat as in the study (tangent dF/dd, K_sat = median K over "
        f"d in [{sat[0]:g}, {sat[1]:g}] mm). Elements over a groove are never in contact (springs inactive). "
        f"Block influence: {ds.attrs.get('influence_note', 'see the greens files')}. A grooves-only case is the "
        f"slick layer with that pattern's grooved springs off: its change against slick is what removing the grooved "
        f"elements does; the rest of the pattern's change comes from its block influence (the cut coupling between "
        f"blocks, and with FE tables the blocks' edges).",
        "",
        "| case | K_sat [MN/m] | change against slick | grooved fraction | influence table [MB] | dense patch "
        "matrix [MB] | greens stage [s] | contact run [s] | substrate |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for i, case in enumerate(cases):
        lines.append(
            f"| {case} | {1e-6 * float(ds['saturated_stiffness'][i]):.4g} | "
            f"{100 * float(ds['slick_change'][i]):+.2f} % | {100 * float(ds['grooved_fraction'][i]):.1f} % | "
            f"{_mb(float(ds['influence_bytes'][i]))} | {_mb(float(ds['dense_patch_bytes'][i]))} | "
            f"{float(ds['greens_time'][i]):.3g} | {float(ds['contact_time'][i]):.3g} | {ds['solver_path'].values[i]} |")
    d = ds["indentation"].values
    marks = [m for m in (0.05e-3, 0.10e-3, 0.15e-3, 0.20e-3, 0.25e-3) if m <= d[-1] * (1 + 1e-9)]
    lines += ["", "K(d) [MN/m]:", "", "| case | " + " | ".join(f"d = {1e3 * m:g} mm" for m in marks) + " |",
              "|---|" + "---|" * len(marks)]
    for i, case in enumerate(cases):
        k = ds["stiffness"].values[i]
        lines.append(f"| {case} | " + " | ".join(f"{1e-6 * float(np.interp(m, d, k)):.4g}" for m in marks) + " |")
    lines += ["", "Claims of the seed on the pattern (quasi-static; the report's thresholds):", ""]
    for i, case in enumerate(cases):
        if patterns[i] == _SLICK or variants[i]:
            continue
        slick = next(j for j in range(len(cases))
                     if materials[j] == materials[i] and patterns[j] == _SLICK and not variants[j])
        lines.append(f"- {case}:")
        lines += [f"  - {c}" for c in _claims(ds, i, slick)]
    lines += ["", "Memory: a pattern stores one N x N block table (N = the block's elements) for every block of the "
              "patch, independent of the number of blocks; the slick tread stores its translation-invariant offset "
              "table. The dense patch matrix (M x M, M = the patch's elements) is what a non-Toeplitz kernel would "
              "need without the block structure. Times are wall times inside the stage (table build; the "
              "quasi-static march with its tangents), on one thread.", ""]
    return lines


def spectrum_section(spectra: Sequence[xr.Dataset], frequencies=(100.0, 1000.0, 5000.0)) -> list[str]:
    """K*(f; d0) on the patterned treads beside the slick tread (:mod:`tyreroad.pattern_spectrum`)."""
    if not spectra:
        return []
    lines = ["## K*(f; d0) on the patterned tread", "",
             "The contact stiffness about the relaxed preload state, K* = 1^T [G_C(f) + diag(1/k_e)]^-1 1, with the "
             "block's FE frequency response in modal form (checked against a direct complex solve at the highest "
             "frequency) beside the slick tread's element FRF on the same patch and springs.", "",
             "| material / pattern | d0 [mm] | case | contact | " + " | ".join(
                 f"K'({f:g} Hz) [MN/m] | eta({f:g} Hz)" for f in frequencies) + " |",
             "|---|---|---|---|" + "---|---|" * len(frequencies)]
    notes = []
    for ds in spectra:
        avail = ds["frequency"].values
        use = [f for f in frequencies if np.any(np.isclose(avail, f))]
        for d0 in ds["preload"].values:
            for case in ds["case"].values:
                k1 = ds["k_storage"].sel(case=case, preload=d0)
                k2 = ds["k_loss"].sel(case=case, preload=d0)
                cells = []
                for f in frequencies:
                    if f in use:
                        i = int(np.argmin(np.abs(avail - f)))
                        cells.append(f"{float(k1[i]) / 1e6:.3f} | {float(k2[i] / k1[i]):.3f}")
                    else:
                        cells.append("- | -")
                count = int(ds["contact_count"].sel(case=case, preload=d0))
                lines.append(f"| {ds.attrs['material']} / {ds.attrs['pattern']} | {d0 * 1e3:.3g} | {case} | {count} | "
                             + " | ".join(cells) + " |")
        nat = ds["natural_frequency"]
        lowest = ", ".join(f"{c} {float(nat.sel(symmetry_class=c).values[0]):.0f} Hz"
                           for c in nat["symmetry_class"].values)
        notes.append(f"- {ds.attrs['pattern']} ({ds.attrs['material']}): lowest block modes per symmetry class (undamped, "
                     f"Re E(f)): {lowest}. Modal form ({int(ds.attrs['n_modes'])} modes per class) against a direct "
                     f"solve at {float(ds.attrs['modal_check_frequency']):g} Hz: {float(ds.attrs['modal_error']):.2%} "
                     f"(limit {float(ds.attrs['modal_tolerance']):.0%}); eigen-decomposition "
                     f"{float(ds.attrs['modes_time_s']):.0f} s, job {float(ds.attrs['compute_time_s']):.0f} s.")
    return lines + [""] + notes + [""]


def figures_section(figures: Sequence[str]) -> list[str]:
    """The pattern study's figures (rule ``pattern_figures``) embedded with their captions.

    Parameters
    ----------
    figures : sequence of str
        Paths of the figures relative to ``pattern.md``'s folder (``figures/pattern/compliance_map.png``), in the
        order shown; their captions come from :data:`tyreroad.report.figures.FIGURE_CAPTIONS` (by file stem).

    Returns
    -------
    list of str
        Markdown lines; none without figures.
    """
    if not figures:
        return []
    lines = ["## Figures of the pattern study", ""]
    for rel in (str(f).replace("\\", "/") for f in figures):
        lines += [f"![{Path(rel).stem}]({rel})", "", f"*{figure_caption(rel)}* (`{rel}`)", ""]
    return lines


def build_pattern_report(ds: xr.Dataset, source: str = "", spectra: Sequence[xr.Dataset] = (),
                         figures: Sequence[str] = (), extra: Sequence[str] = ()) -> str:
    """``pattern.md``: the title, the source, :func:`pattern_section`, :func:`spectrum_section`, ``extra`` lines (the
    dynamic runs, :func:`tyreroad.report.pattern_dynamic.dynamic_section`) and :func:`figures_section`
    (``figures``: paths relative to ``pattern.md``'s folder)."""
    head = ["# tyreroad: patterned treads", ""] + ([f"Source: `{source}`", ""] if source else [])
    return "\n".join(head + pattern_section(ds) + spectrum_section(spectra) + list(extra)
                     + figures_section(figures)) + "\n"


def write_pattern_report(ds: xr.Dataset, path: str | Path, source: str = "", spectra: Sequence[xr.Dataset] = (),
                         figures: Sequence[str] = (), extra: Sequence[str] = ()) -> Path:
    """Write ``pattern.md`` atomically."""
    return write_report(build_pattern_report(ds, source, spectra, figures, extra), path)
