"""Report section "Viscoelastic contact springs" (issue 24): this study against an elastic-springs study.

Fed by the optional config key ``spring_comparison.elastic_results`` (config/springs-qlv.yaml): the
report of a study with ``springs.rheology: qlv`` compares its own files with the elastic study's
files of the same names in that results directory, where they exist. Nothing is run for it: the
elastic study is the default one (``snakemake -j2``), the QLV one its overlay; the rolling passes
are read where either study has run them (the rolling target is a named target).

What it shows: K_sat of every case, the claims' verdicts, K*(1 kHz) and its loss factor at every
preload (reference material) and at the figure preload (every material), the rolling-loss
coefficient of the passes both studies have, and the relaxation fit of the springs.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr

from .. import io

logger = logging.getLogger(__name__)

__all__ = ["spring_comparison_section"]

#: The frequency of the K* comparison [Hz].
COMPARISON_FREQUENCY = 1000.0


def _read(path: Path) -> xr.Dataset | None:
    if not path.is_file():
        return None
    try:
        return io.read_dataset(path)
    except Exception as exc:  # a file of the other study that cannot be read is reported, not fatal
        logger.warning("spring comparison: cannot read %s (%s)", path, exc)
        return None


def _k_at(ds: xr.Dataset, p: int, freq: float) -> complex | None:
    f = ds["frequency"].values
    j = int(np.argmin(np.abs(f - freq)))
    if abs(f[j] / freq - 1) > 1e-9:
        return None
    return complex(ds["storage_stiffness"].values[p, j], ds["loss_stiffness"].values[p, j])


def _claims(study, settings, variants):
    from .claims import evaluate_claims

    return {r.number: r for r in evaluate_claims(study, settings, variants)}


#: fs/2 alternation (relative to the force) above which a case is marked in the K_sat table.
ALTERNATION_FLAG = 1e-3


def _alternation(study: xr.Dataset) -> np.ndarray:
    if "fs2_alternation" not in study:
        return np.full(study.sizes["case"], np.nan)
    return np.asarray(study["fs2_alternation"].values, dtype=float)


def _fmt_alt(value) -> str:
    return "—" if value is None or not np.isfinite(value) else f"{value:.1e}"


def _fmt_eta(k: complex | None) -> str:
    return "—" if k is None else f"{k.imag / k.real:.3f}"


def spring_comparison_section(study: xr.Dataset, spectra: Sequence[xr.Dataset], settings, variants: Mapping[str, Any],
                              own_dir: str | Path, elastic_dir: str | Path, surface: str | None = None) -> list[str]:
    """Markdown lines of the section (module docstring).

    Parameters
    ----------
    study : xarray.Dataset
        This (QLV) study's study.nc.
    spectra : sequence of xarray.Dataset
        This study's stiffness-spectrum files.
    settings : tyreroad.study.StudySettings
        The study settings (claims).
    variants : mapping
        The variant groups (claims 6, 7).
    own_dir, elastic_dir : path
        results_dir of this study and of the elastic study.
    surface : str, optional
        The study surface (default: the study file's).
    """
    own_dir, elastic_dir = Path(own_dir), Path(elastic_dir)
    surface = surface or str(study.attrs.get("surface", ""))
    lines = ["## Viscoelastic contact springs (QLV) against elastic springs", ""]
    rheology = {str(ds.attrs.get("spring_rheology", "elastic")) for ds in spectra}
    lines.append(
        "The element springs are the tread's own rubber. Elastic springs (the seed's assumption) keep the "
        "modulus E_qs = E(0) at every frequency; with `springs.rheology: qlv` the spring force relaxes with "
        "the tread's modulus (quasi-linear viscoelasticity, F_e = ∫ R(t − τ) dF_el(ζ_e(τ)), R = E(t)/E_qs as a "
        "fitted Prony series run as a recursive filter per element; a spring never pulls: F is clipped at 0 on "
        "fast unloading), and K*(f) uses k_e(f) = k_e E(f)/E_qs. This study's springs: "
        f"{', '.join(sorted(rheology)) or 'unknown'}; the elastic study compared with: `{elastic_dir}`."
    )
    lines.append("")
    fits = []
    for ds in spectra:
        name = str(ds.attrs.get("material", ""))
        springs = _read(own_dir / "springs" / surface / f"{name}.nc")
        if springs is not None and "relaxation_fit_error" in springs.attrs:
            from ..qlv import RelaxationFunction

            rel = RelaxationFunction(float(springs.attrs["relaxed_ratio"]), springs["relaxation_weight"].values,
                                     springs["relaxation_time"].values)
            fs = float(ds.attrs.get("sample_rate", np.nan))
            a = a_n = np.nan
            if np.isfinite(fs):
                a, decay, gain = rel.step_coefficients(1.0 / fs)
                a_n = rel.relaxed + float(np.sum(gain * 2.0 / (1.0 + decay)))
            fits.append(f"{name}: {float(springs.attrs['relaxation_fit_error']):.1e} "
                        f"({springs.sizes['relaxation_term']} terms, R(0) = {rel.relaxation(0.0):.2f}, "
                        f"a = {a:.2f}, a_N = {a_n:.2f} at fs = {fs:g} Hz)")
    if fits:
        lines.append("Relaxation fit, largest relative error of E(f)/E_qs over 1e-7 Hz … 1 MHz (R(0): the "
                     "fitted short-time ratio; a: the spring's stiffness factor within one march step, "
                     "F = a F_el(ζ) + history; a_N = R_inf + Σ r_k β_k 2/(1 + e_k): its factor for a period-2 "
                     "(fs/2) oscillation): " + "; ".join(fits) + ". A material that is not causal (the seed's "
                     "constant-|E| loss variants, frequency domain only) would relax with its nearest causal "
                     "relaxation; the study's materials are causal.")
        lines.append("")

    reference_greens = _read(own_dir / "greens" / f"{study.attrs.get('reference_material', 'tread')}.nc")
    construction = "unknown" if reference_greens is None else str(reference_greens.attrs.get("construction", "unknown"))
    elastic_study = _read(elastic_dir / "study.nc")
    if elastic_study is None:
        lines += [f"The elastic study's `{elastic_dir / 'study.nc'}` is missing: run the default study "
                  "(`snakemake -j2`) for the comparison.", ""]
    else:
        lines += ["### K_sat of every case", "",
                  "The fs/2 alternation is the stability record of each run (fourth difference of the force / 16 "
                  "over the run's last fifth, relative to the force; `tyreroad.stability`). QLV springs are "
                  "stiffer at the march's time step (by a, and at fs/2 by a_N, both listed with the relaxation fit; "
                  "a_N is close to |E(fs/2)|/E(0), as a consistent discretization must be), so on a kernel with a "
                  "finite margin they pass its k_crit earlier and further; this study's kernel "
                  f"(`greens.construction: {construction}`"
                  f"{', stable for every spring equal at the stages of a step' if construction == 'radau' else ''}) "
                  "records each run's alternation. "
                  f"Cases marked † have an alternation above {ALTERNATION_FLAG:g} of the force: their K(d), K_sat and "
                  "the claims read from them carry the march's instability, not the springs' physics.", "",
                  "| case | K_sat elastic [MN/m] | K_sat QLV [MN/m] | change | fs/2 alternation elastic | "
                  "fs/2 alternation QLV |", "|---|---|---|---|---|---|"]
        cases_e = elastic_study["case"].values.tolist()
        el = dict(zip(cases_e, elastic_study["saturated_stiffness"].values))
        alt_e = dict(zip(cases_e, _alternation(elastic_study)))
        flagged = []
        for case, k, alt in zip(study["case"].values.tolist(), study["saturated_stiffness"].values,
                                _alternation(study)):
            ke = el.get(case)
            cell = "—" if ke is None else f"{ke / 1e6:.4f}"
            change = "—" if ke is None else f"{100 * (k / ke - 1):+.2f} %"
            mark = " †" if alt > ALTERNATION_FLAG else ""
            if mark:
                flagged.append(case)
            lines.append(f"| {case}{mark} | {cell} | {k / 1e6:.4f} | {change} | {_fmt_alt(alt_e.get(case))} | "
                         f"{_fmt_alt(alt)} |")
        lines.append("")
        if flagged:
            lines += [f"{len(flagged)} QLV case(s) past the alternation flag: {', '.join(flagged)}.", ""]
        try:
            own, other = _claims(study, settings, variants), _claims(elastic_study, settings, variants)
            lines += ["### The claims", "", "| # | verdict, elastic springs | verdict, QLV springs | measured, QLV |",
                      "|---|---|---|---|"]
            for n in sorted(own):
                lines.append(f"| {n} | {other[n].verdict if n in other else '—'} | **{own[n].verdict}** | "
                             f"{own[n].measured} |")
            lines.append("")
        except Exception as exc:  # the claims of either study cannot be evaluated: say so
            logger.warning("spring comparison: claims not evaluated (%s)", exc)
            lines += [f"The claims could not be compared: {exc}.", ""]

    f0 = COMPARISON_FREQUENCY
    rows, ref_rows = [], []
    for ds in spectra:
        name = str(ds.attrs.get("material", ""))
        other = _read(elastic_dir / "stiffness_spectrum" / surface / f"{name}.nc")
        if other is None:
            rows.append(f"| {name} | (elastic spectrum missing) | | | | |")
            continue
        pre = ds["preload"].values
        fig = float(ds.attrs.get("figure_preload", pre[len(pre) // 2]))
        for p, d0 in enumerate(pre):
            q = int(np.argmin(np.abs(other["preload"].values - d0)))
            k_q, k_e = _k_at(ds, p, f0), _k_at(other, q, f0)
            if k_q is None or k_e is None:
                continue
            row = (f"| {name} | {d0 * 1e3:.2f} | {k_e.real / 1e6:.3f} | {k_q.real / 1e6:.3f} | "
                   f"{k_q.real / k_e.real:.3f} | {_fmt_eta(k_e)} | {_fmt_eta(k_q)} |")
            if name == settings.reference_material:
                ref_rows.append(row)
            if np.isclose(d0, fig, rtol=1e-9):
                rows.append(row)
    header = [f"| material | d0 [mm] | K′ elastic [MN/m] | K′ QLV [MN/m] | ratio | η elastic | η QLV |",
              "|---|---|---|---|---|---|---|"]
    lines += [f"### K*({f0:g} Hz) about the relaxed preload state", ""]
    if ref_rows:
        lines += [f"Reference material, every preload (η = K″/K′):", ""] + header + ref_rows + [""]
    if rows:
        lines += ["Every material at the figure preload:", ""] + header + rows + [""]

    lines += ["### Rolling loss", ""]
    pairs = []
    for path in sorted((own_dir / "rolling").glob("*/*/dynamic_v*.nc")) if (own_dir / "rolling").is_dir() else []:
        if path.parent.parent.name == "greens":
            continue
        rel = path.relative_to(own_dir)
        own, other = _read(path), _read(elastic_dir / rel)
        if own is None:
            continue
        pairs.append((rel, own, other))
    if not pairs:
        lines += ["No rolling pass of this study (the rolling target is named: "
                  "`snakemake -j2 rolling --configfile config/config.yaml config/springs-qlv.yaml`, or one pass: its "
                  "file `results-qlv/rolling/<strip>/<material>/dynamic_v<speed>.nc`).", ""]
    else:
        lines += ["Coefficient = steady P/v over the steady mean force (as in rolling.md), at the wheel load; fs/2 "
                  "alternation of the pass as in the K_sat table († above "
                  f"{ALTERNATION_FLAG:g}: the pass chatters and its coefficient is the march's, not the springs').", "",
                  "| pass | coefficient elastic | coefficient QLV | ratio | steady force QLV [N] | "
                  "fs/2 alternation elastic | fs/2 alternation QLV |", "|---|---|---|---|---|---|---|"]

        def alt(ds):
            return float(ds["fs2_alternation"]) if ds is not None and "fs2_alternation" in ds else None

        for rel, own, other in pairs:
            c_q = float(own["steady_loss_force"]) / float(own["steady_force"])
            a_q = alt(own)
            mark = " †" if a_q is not None and a_q > ALTERNATION_FLAG else ""
            if other is None:
                lines.append(f"| {rel}{mark} | (missing) | {c_q:.3e} | — | {float(own['steady_force']):.1f} | — | "
                             f"{_fmt_alt(a_q)} |")
                continue
            c_e = float(other["steady_loss_force"]) / float(other["steady_force"])
            lines.append(f"| {rel}{mark} | {c_e:.3e} | {c_q:.3e} | {c_q / c_e:.2f} | {float(own['steady_force']):.1f} | "
                         f"{_fmt_alt(alt(other))} | {_fmt_alt(a_q)} |")
        lines.append("")
    return lines
