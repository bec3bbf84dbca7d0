"""The sections of the reports, each a function of one :class:`ReportContext`.

A section returns its markdown lines (ending with an empty line), or nothing when the context
lacks what it reports on. Numbers that decide or qualify a statement come from the context: the
thresholds (:data:`tyreroad.report.claims.THRESHOLDS` or the overrides given), the study's settings
and the datasets; the assembling order is :data:`tyreroad.report.document.REPORT_SECTIONS`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr
import yaml

from .. import io
from ..study import variant_members
from ..rolling.dataset import INPUT_HARMONICS, TOP_BAND, input_line_frequencies
from .claims import _MM, _MN, DIRECTION_OPPOSITE, HOLDS, NOT_EVALUATED, THRESHOLDS, ClaimContext, ClaimResult, _pct

__all__ = [
    "ReportContext",
    "header_section",
    "claims_section",
    "decides_section",
    "claim6_section",
    "equivalent_section",
    "cases_section",
    "stability_section",
    "stiffness_spectrum_section",
    "surface_section",
    "material_section",
    "hysteresis_section",
    "figures_section",
    "rolling_header_section",
    "rolling_section",
    "config_section",
]


@dataclass(frozen=True)
class ReportContext:
    """What the report sections read.

    Attributes
    ----------
    thresholds : mapping
        Thresholds of the claims and of the rolling section (:data:`THRESHOLDS` with any overrides).
    claims : ClaimContext or None
        The study dataset, its settings and variant groups (None for a report without a study,
        e.g. ``results/rolling.md``).
    results : mapping
        Claim number -> :class:`ClaimResult` of the evaluated claims.
    config : mapping or None
        The config the report is made from (its hash is printed in the header).
    config_text : str
        The YAML printed in the config section.
    surface : xarray.Dataset or None
        The study's surface dataset.
    greens : dict
        Green's datasets by material.
    spectra : sequence of xarray.Dataset
        Stiffness-spectrum datasets (K*(f; d0)).
    loading : xarray.Dataset or None
        ``results/loading.nc`` (load-unload cycles).
    rolling : xarray.Dataset or None
        ``results/rolling.nc`` (rolling study).
    constructions : mapping
        {construction: (study dataset, greens by material, claim results)} of the study repeated with
        other kernel constructions (``study.compare_constructions``).
    claim6 : xarray.Dataset or None
        ``results/claim6.nc`` (claim 6 by loss-variant definition, :mod:`tyreroad.claim6`).
    figures : sequence of str
        The report's figures, as paths relative to the report's folder (``figures/fig5_force.png``):
        embedded with their captions (:mod:`tyreroad.report.figures`).
    belt : tuple or None
        (study dataset, greens by material, claim results, K* datasets) of the study repeated with the flexible
        belt behind the tread (``belt.study``, results/belt/).
    rolling_reference : xarray.Dataset or None
        The rolling study with elastic contact springs that this (QLV) one is compared with
        (``spring_comparison.elastic_results``/rolling.nc); ``rolling_reference_label`` names its folder, and a
        label without a dataset says the file is missing.
    """

    thresholds: Mapping[str, float] = field(default_factory=lambda: dict(THRESHOLDS))
    claims: ClaimContext | None = None
    results: Mapping[int, ClaimResult] = field(default_factory=dict)
    config: Mapping[str, Any] | None = None
    config_text: str = ""
    surface: xr.Dataset | None = None
    greens: Mapping[str, xr.Dataset] = field(default_factory=dict)
    spectra: Sequence[xr.Dataset] = ()
    loading: xr.Dataset | None = None
    rolling: xr.Dataset | None = None
    constructions: Mapping[str, tuple] = field(default_factory=dict)
    claim6: xr.Dataset | None = None
    figures: Sequence[str] = ()
    rolling_reference: xr.Dataset | None = None
    rolling_reference_label: str = ""
    belt: tuple | None = None


def figures_section(ctx: ReportContext) -> list[str]:
    """Each figure of the study embedded (relative link) with its one-line caption."""
    from .figures import figures_section_lines

    return figures_section_lines(ctx.figures)


def greens_by_material(greens: Mapping[str, xr.Dataset] | Sequence[xr.Dataset] | None) -> dict[str, xr.Dataset]:
    """Green's datasets keyed by material: a mapping as it is, a sequence by each dataset's ``material`` attribute."""
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


# --------------------------------------------------------------------------------------------------
# the claims report results/report.md
# --------------------------------------------------------------------------------------------------
def header_section(ctx: ReportContext) -> list[str]:
    """Title, versions, config hashes, the reference case and how K and K_sat are computed."""
    study, settings = ctx.claims.study, ctx.claims.settings
    a_ref = max(settings.accelerations)
    return [
        "# tyreroad: claims of Winroth, Andersson & Kropp (JSV 2014) checked",
        "",
        f"- tyreroad version: {io.code_version()} (study file made by "
        f"{study.attrs.get('tyreroad_version', 'unknown')})",
        f"- report config SHA-256: `{io.config_hash(ctx.config)}` — hash of the config this report was made "
        "from (the `study` section and the variant groups, printed at the end)",
        f"- study file config SHA-256: `{study.attrs.get('config_sha256', 'not recorded')}` — hash recorded "
        "in results/study.nc of the config that made it (`study` section and `d_max`); the two hash "
        "different sections, so they differ; each changes when its own config changes",
        f"- surface `{settings.surface}`, reference material `{settings.reference_material}`, "
        f"reference case: dynamic at a = {a_ref:g} m/s², d_max = {settings.d_max * _MM:g} mm",
        f"- K = dF/dd by second-order differences on each run's native samples, then linear interpolation "
        f"onto a {settings.indentation_step * 1e6:g} µm grid"
        + ("; quasi-static runs: the tangent dF/dd of each solved state, F and K by cubic Hermite "
           "interpolation" if "stiffness_from_tangent" in study and int(study["stiffness_from_tangent"].sum()) else "")
        + "; K_sat = median K over "
        f"[{settings.saturation_range[0] * _MM:g}, {settings.saturation_range[1] * _MM:g}] mm",
        "",
    ]


def claims_section(ctx: ReportContext) -> list[str]:
    """The claims table: one row per claim of the registry, with the count of claims that hold."""
    claims = [ctx.results[n] for n in sorted(ctx.results)]
    n_hold = sum(c.verdict == HOLDS for c in claims)
    n_eval = sum(c.verdict != NOT_EVALUATED for c in claims)
    n_opposite = sum(c.verdict == DIRECTION_OPPOSITE for c in claims)
    summary = f"{n_hold} of {n_eval} evaluated hold"
    if n_opposite:
        summary += f", {n_opposite} hold{'s' if n_opposite == 1 else ''} in size with the opposite direction"
    lines = [
        f"## Seed claims: {summary}",
        "",
        "Verdicts: **holds** (as the seed says), **size holds, direction opposite** (the size of the effect "
        "is the seed's, its sign is not), **fails**.",
        "",
        "| # | claim (seed) | test and threshold | measured | verdict |",
        "|---|---|---|---|---|",
    ]
    for c in claims:
        lines.append(f"| {c.number} | {c.claim} | {c.test} | {c.measured} | **{c.verdict}** |")
    return lines + [""]




def surface_section(ctx: ReportContext) -> list[str]:
    """Texture statistics of the study's road surface (none without a surface dataset)."""
    surface = ctx.surface
    if surface is None:
        return []
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


def material_section(ctx: ReportContext) -> list[str]:
    """Per study material: variant scales, density, nu, h, E' / eta at three frequencies, kernel summary."""
    greens, variants = ctx.greens, ctx.claims.variants
    ref = ctx.claims.settings.reference_material
    materials = ctx.claims.materials
    run_note = _run_note(ctx)
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
    lines += [
        "",
        "- *kept g(0) fraction*: share of the static compliance g(ω = 0) at the excitation element that the "
        "kept time lags of the kernel hold (the rest is slow creep beyond the kernel's memory)"
        + (f"; {run_note}." if run_note else "."),
        "- *precursor energy*: energy of the discarded non-causal part of the inverse FFT (samples at "
        "negative time) over the kernel's total energy; small means the time-domain kernel is causal.",
    ]
    return lines + [""]


def _stiffness_at(ds: xr.Dataset, preload_index: int, freq: float) -> tuple[float, float] | None:
    """(K' [N/m], loss factor [1]) of a stiffness spectrum at ``freq`` [Hz]: the grid value when the
    frequency is on the grid, else None (the stage inserts the report frequencies into its grid)."""
    f = ds["frequency"].values
    j = int(np.argmin(np.abs(f - freq)))
    if not np.isclose(f[j], freq, rtol=1e-9, atol=0):
        return None
    sel = ds.isel(preload=preload_index, frequency=j)
    return float(sel["storage_stiffness"]), float(sel["loss_factor"])


def _spectrum_row(ds: xr.Dataset, p: int, freqs: Sequence[float]) -> list[str]:
    k_qs = float(ds["tangent_stiffness_qs"][p])
    cells = []
    for fr in freqs:
        v = _stiffness_at(ds, p, fr)
        cells.append("—" if v is None else f"{v[0] * _MN:.3f} / {v[1]:.3f}")
    at_1k = _stiffness_at(ds, p, 1000.0)
    cells.append("—" if at_1k is None else f"{at_1k[0] / k_qs:.3f}")
    return cells


def stiffness_spectrum_section(ctx: ReportContext) -> list[str]:
    """Report section on K*(f; d0): K' and the loss factor at the report frequencies per preload
    (none without stiffness-spectrum datasets or without one of the reference material)."""
    if not ctx.spectra:
        return []
    settings = ctx.claims.settings
    return _stiffness_spectrum_section(ctx.spectra, settings.reference_material, ctx.claims.variants,
                                       list(settings.materials))


def _stiffness_spectrum_section(spectra: Sequence[xr.Dataset], reference: str, variants: Mapping[str, Any],
                                materials: Sequence[str]) -> list[str]:
    """:func:`stiffness_spectrum_section` from its datasets (``variants`` is not used; the signature is
    kept for tests/test_stiffness.py, which calls it directly)."""
    by = {str(ds.attrs.get("material")): ds for ds in spectra}
    if reference not in by:
        return []
    ref = by[reference]
    freqs = [float(f) for f in np.atleast_1d(ref.attrs.get("report_frequencies", (100.0, 1000.0, 5000.0)))]
    head = " | ".join(f"K′ [MN/m] / η at {f:g} Hz" for f in freqs)
    f_lo = float(ref["frequency"].values[0])
    lines = [
        "## Dynamic contact stiffness K*(f; d0)",
        "",
        "The contact spring a tyre/road model needs, per preload d0: the complex contact stiffness "
        "K* = 1ᵀ[G_C(f) + diag(1/k_e)]⁻¹1 of the contact linearised about the **relaxed preload state** (the "
        "quasi-static solution at d0 with the quasi-static modulus: a tread held at d0 until it has relaxed, "
        "which takes seconds and more for the default fractional tread), with the element FRF g(f) of the layer "
        "over the contact set C and the tangent spring stiffnesses k_e (SPEC 11; exp(+iωt), F̂ = K* δ̂). "
        f"Files: `results/stiffness_spectrum/{{surface}}/{{material}}.nc` ({ref.sizes['frequency']} frequencies "
        f"from {f_lo:g} Hz to {float(ref['frequency'].values[-1]):g} Hz), all materials in one file "
        "`results/stiffness_spectrum.nc` (a material dimension), K′ and K″ in figure "
        "`results/figures/fig9_stiffness_spectrum.png`; `tyreroad kstar MATERIAL --preload 0.12mm [--third-octave]` "
        "exports CSV at any preload between the computed ones (K′, K″ linear in d0). K′ = Re K*, η = Im K*/Re K*, K_qs = dF/dd of the "
        "quasi-static curve at d0.",
        "",
        f"Reference material `{reference}`:",
        "",
        f"| d0 [mm] | in contact | F(d0) [N] | K_qs [MN/m] | K*(f→0)/K_qs − 1 | K′({f_lo:g} Hz)/K_qs | {head} "
        "| K′(1 kHz)/K_qs |",
        "|---|---|---|---|---|---|" + "---|" * len(freqs) + "---|",
    ]
    for p, d0 in enumerate(ref["preload"].values):
        k_qs = float(ref["tangent_stiffness_qs"][p])
        lines.append(
            f"| {d0 * _MM:.3g} | {100 * float(ref['contact_fraction'][p]):.1f} % | {float(ref['preload_force'][p]):.1f} "
            f"| {k_qs * _MN:.3f} | {float(ref['relaxed_stiffness'][p]) / k_qs - 1:+.1e} "
            f"| {float(ref['storage_stiffness'][p, 0]) / k_qs:.3f} | " + " | ".join(_spectrum_row(ref, p, freqs)) + " |"
        )
    fig_preload = float(ref.attrs.get("figure_preload", ref["preload"].values[(ref.sizes["preload"] - 1) // 2]))
    lines += _transient_lines(ref, fig_preload, freqs)
    others = [m for m in materials if m in by]
    lines += [
        "",
        f"All materials at d0 = {fig_preload * _MM:g} mm:",
        "",
        f"| material | K_qs [MN/m] | {head} | K′(1 kHz)/K_qs |",
        "|---|---|" + "---|" * len(freqs) + "---|",
    ]
    for m in others:
        ds = by[m]
        pre = ds["preload"].values
        p = int(np.argmin(np.abs(pre - fig_preload)))
        if not np.isclose(pre[p], fig_preload, rtol=1e-9, atol=0):
            continue
        lines.append(f"| {m} | {float(ds['tangent_stiffness_qs'][p]) * _MN:.3f} | "
                     + " | ".join(_spectrum_row(ds, p, freqs)) + " |")
    loss_min = min(float(by[m]["loss_stiffness"].min()) for m in others)
    limit = max(abs(float(by[m]["relaxed_stiffness"][p] / by[m]["tangent_stiffness_qs"][p] - 1))
                for m in others for p in range(by[m].sizes["preload"]))
    lines += [
        "",
        f"- f → 0: K*(f → 0) (element FRF at f = 0, modulus E(ω → 0)) equals K_qs to {limit:.1e} at every preload "
        f"and material. At {f_lo:g} Hz the contact is still stiffer than that: the tread's modulus keeps relaxing "
        "well below 10 Hz.",
        f"- Passivity: the smallest loss stiffness K″ over every material, preload and frequency is "
        f"{loss_min * _MN:.4f} MN/m ({'≥ 0' if loss_min >= 0 else 'NEGATIVE'}).",
        "- Reading it: `xarray.open_dataset(path).storage_stiffness.sel(preload=1e-4, frequency=1000)`; "
        "`tyreroad kstar` exports it (README, recipe \"K* for your tyre model\"; docs/results.md).",
        "",
    ]
    return lines


def _transient_lines(ref: xr.Dataset, d0: float, freqs: Sequence[float]) -> list[str]:
    """The reference's K* about the transient preload state beside the relaxed one, at one preload."""
    if "storage_stiffness_transient" not in ref:
        return []
    p = int(np.argmin(np.abs(ref["preload"].values - d0)))
    speed = float(ref.attrs.get("transient_speed", float("nan")))
    f = ref["frequency"].values
    cells = []
    for freq in freqs:
        j = int(np.argmin(np.abs(f - freq)))
        if not np.isclose(f[j], freq, rtol=1e-9):
            continue
        k_r, k_t = float(ref["storage_stiffness"][p, j]), float(ref["storage_stiffness_transient"][p, j])
        cells.append(f"| {freq:g} Hz | {k_r * _MN:.3f} / {float(ref['loss_factor'][p, j]):.3f} | "
                     f"{k_t * _MN:.3f} / {float(ref['loss_factor_transient'][p, j]):.3f} | {k_t / k_r:.3f} |")
    return [
        "",
        f"Transient preload state: the contact loaded from first contact to d0 = {ref['preload'].values[p] * _MM:g} mm "
        f"at {speed:g} m/s (the working point of a rolling contact, where the tread has had no time to relax) "
        f"carries F = {float(ref['transient_force'][p]):.1f} N with "
        f"{100 * float(ref['transient_contact_fraction'][p]):.1f} % of the elements in contact, against "
        f"{float(ref['preload_force'][p]):.1f} N and {100 * float(ref['contact_fraction'][p]):.1f} % relaxed; "
        "K* about each state (K′ [MN/m] / η):",
        "",
        "| f | relaxed | transient | K′ transient / relaxed |",
        "|---|---|---|---|",
        *cells,
    ]


def _storage_change(greens: dict[str, xr.Dataset], material: str, reference: str, freq: float) -> float | None:
    """E'(material) / E'(reference) - 1 at ``freq`` [Hz] from the Green's datasets (None if unavailable)."""
    if material not in greens or reference not in greens:
        return None
    out = []
    for name in (material, reference):
        ds = greens[name]
        f = ds["frequency"].values
        if not (f[0] <= freq <= f[-1]):
            return None
        out.append(float(np.interp(freq, f, ds["storage_modulus"].values)))
    return out[0] / out[1] - 1.0


def _loss_factor_at(greens: dict[str, xr.Dataset], material: str, freq: float) -> float | None:
    ds = greens.get(material)
    if ds is None:
        return None
    f = ds["frequency"].values
    return float(np.interp(freq, f, ds["loss_factor"].values)) if f[0] <= freq <= f[-1] else None


def decides_section(ctx: ReportContext) -> list[str]:
    """"What decides claims 5-7": the mechanism behind each verdict, from the study's own numbers
    and the context's thresholds."""
    claims, greens, t = ctx.results, ctx.greens, ctx.thresholds
    settings, variants = ctx.claims.settings, ctx.claims.variants
    ref = settings.reference_material
    lo, hi = settings.saturation_range
    lines = ["## What decides claims 5–7", ""]
    c5 = claims.get(5)
    if c5 is not None:
        v = c5.values
        fr = v["fraction_saturation_range"]
        limit = t["c5_change_max"]
        text = (
            f"- **Claim 5 ({c5.verdict}).** {100 * v['fraction']:.0f} % of the elements are in contact at "
            f"{t['c5_d'] * _MM:g} mm (seed ≈ 50 %). K changes by {100 * v['change']:.1f} % over the saturation range "
            f"(limit {100 * limit:g} %); the contact fraction goes {fr[0]:.3f} → {fr[1]:.3f} between "
            f"{lo * _MM:g} and {hi * _MM:g} mm. "
        )
        if v["change"] > limit:
            text += ("K keeps rising because elements still come into contact there, each adding a spring in "
                     f"parallel: a flatter K needs a surface whose element peaks lie within about {t['c5_d'] * _MM:g} mm "
                     "of the top (few new contacts beyond it).")
        else:
            text += f"Few new contacts beyond {lo * _MM:g} mm: K saturates."
        lines.append(text)
    c6 = claims.get(6)
    if c6 is not None and c6.values.get("delta"):
        parts = []
        agree = []
        names = dict(variant_members(variants, "loss", settings.materials, ref))
        for scale, delta in c6.values["delta"].items():
            name = names.get(scale)
            e1 = _storage_change(greens, name, ref, 1000.0) if name else None
            e10 = _storage_change(greens, name, ref, 10000.0) if name else None
            if e1 is not None and e10 is not None:
                parts.append(f"η×{scale:g}: E′ {_pct(e1)} at 1 kHz, {_pct(e10)} at 10 kHz, K_sat {_pct(delta)}")
                agree.append(np.sign(delta) == np.sign(e1))
        text = (
            f"- **Claim 6 ({c6.verdict}).** The study's loss variants are causal (issue 24): the phase of E is "
            "scaled, E_s = C E^s, so η and E′ change together as Kramers–Kronig demands; what C keeps fixed (the "
            "anchor) decides how E′ moves in the loading's band (table *Claim 6 by loss-variant definition* below)."
        )
        if parts:
            text += " Here: " + "; ".join(parts) + "."
        text += (" A phase-scaled variant also moves its relaxed modulus (unless anchored at 0 Hz), and with it the "
                 "element springs (`springs.modulus: quasi_static`) and the quasi-static runs; which of these decides "
                 "the sign is measured by control runs in the table below, not argued.")
        lines.append(text)
    c7 = claims.get(7)
    if c7 is not None and c7.values.get("ripple"):
        rip = c7.values["ripple"]
        eta10 = _loss_factor_at(greens, ref, 10000.0)
        text = (
            f"- **Claim 7 ({c7.verdict}).** The ripple of K for d ≤ {t['c7_ripple_d_max'] * _MM:g} mm is "
            + ", ".join(f"ρ×{s:g}: {v:.1e} K_sat" for s, v in sorted(rip.items()))
            + f" (ratio {c7.values['ripple_ratio']:.2f}; the test asks ≥ {t['c7_ripple_ratio_min']:g}). "
            "Inertia ripples are layer oscillations excited as elements come into contact."
        )
        rip_qs = c7.values.get("ripple_quasistatic", math.nan)
        if math.isfinite(rip_qs) and rip.get(1.0, 0) > 0:
            text += (f" The quasi-static run, which has no inertia at all, has a ripple of {rip_qs:.1e} K_sat "
                     f"({rip_qs / rip[1.0]:.2f} × the dynamic reference's): ")
            text += ("most of the measured ripple comes from elements entering contact one by one (the surface), "
                     "which the density does not change." if rip_qs / rip[1.0] >= 0.5 else
                     "the dynamic ripple is mostly the layer's inertia.")
        if eta10 is not None:
            text += (f" With η = {eta10:.2f} at 10 kHz an oscillation keeps a factor e^(−πη) = "
                     f"{math.exp(-math.pi * eta10):.2f} of its amplitude per period, whatever the density.")
        if c7.values["ripple_ratio"] < t["c7_ripple_ratio_min"]:
            text += " Whether another stand-in material or surface gives ripples that grow with the density is what the sensitivity sweep measures."
        lines.append(text)
    lines += [
        "",
        "Which stand-in material or surface would change these verdicts is the question of the sensitivity "
        "sweep: `snakemake -j2 sensitivity` writes `results/sensitivity.md` (table and conclusion), "
        "`results/sensitivity.nc` and `results/figures/sensitivity.png`.",
        "",
    ]
    return lines


def claim6_section(ctx: ReportContext) -> list[str]:
    """Claim 6 by loss-variant definition: the seed's (K*, frequency domain) and the causal anchors
    (K_sat, time domain), each with its numbers, verdict and what decides its sign, checked against the
    storage-check runs (:func:`tyreroad.claim6.claim6_rows`). Empty without ``results/claim6.nc``."""
    from ..claim6 import claim6_rows

    if ctx.claim6 is None:
        return []
    t = ctx.thresholds
    rows = claim6_rows(ctx.claim6, t["c6_delta_max"], t["c6_delta_min"])
    scales = sorted({s for r in rows for s in r["deltas"]})
    ds = ctx.claim6
    lines = [
        "## Claim 6 by loss-variant definition",
        "",
        "The seed's loss variants scale η at constant \\|E\\|, which breaks Kramers–Kronig: they are not "
        "materials, and a time-domain run of one depends on how its negative-time response is cut off. They are "
        "measured here in the frequency domain only, by the storage contact stiffness K′ = Re K* about the "
        f"relaxed preload state d0 = {float(ds.attrs['preload']) * _MM:g} mm at f_c = {float(ds.attrs['frequency']):g} Hz "
        f"(the centre of the band the a = {float(ds.attrs['acceleration']):g} m/s² loading excites: d_max is reached "
        "in about 1 ms). The causal variants (E_s = \\|E(f_a)\\|^(1−s) E^s, passive while s·arg E < π/2 at every "
        "frequency) run in the time domain; the default anchor's are the study's loss variants (figure 7). "
        f"Verdict as claim 6: size \\|Δ\\| ≤ {100 * t['c6_delta_max']:g} % with the largest ≥ "
        f"{100 * t['c6_delta_min']:g} %, direction: Δ has the sign of (η scale − 1).",
        "",
        "| definition | quantity | " + " | ".join(f"η×{s:g}" for s in scales) + " | verdict | what decides the sign |",
        "|---|---|" + "---|" * len(scales) + "---|---|",
    ]
    for r in rows:
        cells = " | ".join(_pct(r["deltas"][s]) if s in r["deltas"] else "–" for s in scales)
        lines.append(f"| {r['definition']} | {r['quantity']} | {cells} | **{r['verdict']}** | {r['sign']} |")
    lines.append("")
    return lines


def equivalent_section(ctx: ReportContext) -> list[str]:
    """Equivalent quasi-static stiffness s(a) per material and its misfit (from ``study.nc``)."""
    study, settings = ctx.claims.study, ctx.claims.settings
    if "equivalent_modulus_scale" not in study:
        return []
    rng = np.atleast_1d(study.attrs.get("equivalent_range_m", [np.nan, np.nan]))
    ref = settings.reference_material
    accels = sorted(settings.accelerations)
    materials = [str(m) for m in dict.fromkeys(study["material"].values.astype(str))]

    def cell(material, a):
        c = study.study.sel_case(material=material, mode="dynamic", accel=a)
        return float(c["equivalent_modulus_scale"]), float(c["equivalent_misfit"])

    ref_vals = [cell(ref, a) for a in accels]
    worst = max(m for _, m in ref_vals)
    lines = [
        "## Equivalent quasi-static stiffness",
        "",
        "The seed's practical conclusion: inertia and damping can be approximated by a stiffer quasi-static "
        "model tuned per acceleration. The quasi-static force scales exactly with a common modulus factor s "
        f"of layer and springs, so s(a) is the least-squares fit of K_dyn(d) by s·K_QS(d) over "
        f"{rng[0] * _MM:g}–{rng[-1] * _MM:g} mm; the misfit is RMS(K_dyn − s·K_QS) / RMS(K_dyn) "
        "(`equivalent_modulus_scale`, `equivalent_misfit` in results/study.nc).",
        "",
        f"Reference material `{ref}`: "
        + ", ".join(f"s({a:g} m/s²) = {s_:.3f} (misfit {100 * m:.2f} %)" for a, (s_, m) in zip(accels, ref_vals))
        + f". The approximation reproduces K(d) to within {100 * worst:.1f} % RMS; what it leaves is the "
        "shape: K_dyn/K_QS is not constant in d.",
        "",
        "| material | " + " | ".join(f"s({a:g}) / misfit" for a in accels) + " |",
        "|---|" + "---|" * len(accels),
    ]
    for m in materials:
        lines.append(f"| {m} | " + " | ".join(f"{s_:.3f} / {100 * mf:.2f} %" for s_, mf in (cell(m, a) for a in accels)) + " |")
    return lines + [""]


def cases_section(ctx: ReportContext) -> list[str]:
    """One row per study case: K_sat, K_sat of the backing force, contact fraction at claim 5's d, final F."""
    study, d_c5 = ctx.claims.study, ctx.thresholds["c5_d"]
    d = study["indentation"].values
    lines = [
        "## Cases",
        "",
        f"| case | K_sat [MN/m] | K_sat from backing force [MN/m] | contact fraction at {d_c5 * _MM:g} mm | F at d_max [N] |",
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
            f"{np.interp(d_c5, d[ok], frac[ok]):.3f} | {f[np.isfinite(f)][-1]:.2f} |"
        )
    return lines + [""]


def stability_section(ctx: ReportContext) -> list[str]:
    """Which dynamic cases pass the time march's fs/2 stability limit, and from which indentation on."""
    if ctx.claims is None or "fs2_limit_indentation" not in ctx.claims.study:
        return []
    study = ctx.claims.study
    dynamic = study["mode"].values.astype(str) == "dynamic"
    labels = study["case"].values.astype(str)[dynamic]
    limit = study["fs2_limit_indentation"].values[dynamic]
    alternation = (study["fs2_alternation"].values[dynamic] if "fs2_alternation" in study
                   else np.full(limit.size, np.nan))
    past = np.isfinite(limit)
    lines = ["## Stability of the time march at fs/2", ""]
    if not past.any():
        return lines + [f"No dynamic case's contact springs reach the fs/2 stability limit of its kernel "
                        f"({int(dynamic.sum())} cases).", ""]
    lines += [
        f"{int(past.sum())} of {int(dynamic.sum())} dynamic cases reach contact springs stiffer than the fs/2 "
        "stability limit k_crit = -1/lambda_min(G_d(-1)) of the march's kernel (`tyreroad.stability`): from there "
        "on the march admits a growing period-2 alternation of the forces. Each contact file records k_crit, the "
        "stiffest spring of every step and the alternation (fourth difference / 16) over the run's last fifth, "
        f"here at most {np.nanmax(alternation[past]):.1e} of the force: these runs end before it has grown, but "
        "the march does not guarantee their K(d) past that indentation, and a long hold past it can chatter.",
        "",
        "| case | first d past k_crit [mm] | fs/2 alternation, last fifth [1] |",
        "|---|---|---|",
    ]
    lines += [f"| {label} | {d * _MM:.3f} | {a:.1e} |" for label, d, a in zip(labels[past], limit[past], alternation[past])]
    return lines + [""]


def _construction_of(greens: Mapping[str, xr.Dataset]) -> str:
    names = {str(ds.attrs.get("construction", "fold")) for ds in greens.values()}
    return ", ".join(sorted(names)) or "?"


def _kernel_rows(name: str, greens: Mapping[str, xr.Dataset], materials: Sequence[str]) -> list[str]:
    rows = []
    for m in materials:
        ds = greens.get(m)
        if ds is None or "critical_stiffness" not in ds:
            continue
        k = float(ds["critical_stiffness"])
        rows.append(
            f"| {name} | {m} | {'every spring' if not math.isfinite(k) else f'{k:.3g}'} | "
            f"{float(ds['fidelity_magnitude']):.2%} / {float(ds['fidelity_phase']):.4f} | "
            f"{'yes' if int(ds.attrs.get('causal_material', 1)) else 'no (not causal)'} |")
    return rows


def construction_section(ctx: ReportContext) -> list[str]:
    """The study beside the same study run with other kernel constructions: each kernel's stability margin and
    fidelity, K_sat per dynamic case and the claims."""
    if ctx.claims is None or not ctx.constructions:
        return []
    study = ctx.claims.study
    own = _construction_of(ctx.greens)
    materials = [str(m) for m in ctx.claims.settings.materials]
    lines = [
        "## Kernel construction: the study beside " + ", ".join(f"`{n}`" for n in ctx.constructions),
        "",
        f"The study's kernels are built by `{own}` (greens.construction); the same dynamic runs were repeated "
        f"with {', '.join(f'`{n}`' for n in ctx.constructions)} (quasi-static runs do not depend on it). "
        "`seed` is the paper's construction: the band-limited inverse FFT of the element FRF with its negative-time "
        "part discarded. The greens stage measures each kernel: k_crit, the stiffest element spring for which the "
        "time march is stable on every contact set of the patch (the margin over the whole unit circle, "
        "`tyreroad.margin`), and the largest error of the kernel's own transfer function against the element "
        "FRF over 10 Hz - 5 kHz (relative to the excitation element's |G_0|; phase where |G| >= 0.1 |G_0|). The "
        "stiffest default spring is the flat punch's plateau.",
        "",
        "| construction | material | k_crit [N/m] | fidelity (magnitude / phase [rad]) | causal material |",
        "|---|---|---|---|---|",
    ]
    lines += _kernel_rows(own, ctx.greens, materials)
    for name, (_, greens, _) in ctx.constructions.items():
        lines += _kernel_rows(name, greens, materials)
    lines += ["", "| case | K_sat, " + own + " [MN/m] | "
              + " | ".join(f"K_sat, {n} [MN/m] | change" for n in ctx.constructions) + " |",
              "|---|---|" + "---|---|" * len(ctx.constructions)]
    labels = study["case"].values.astype(str)
    dynamic = study["mode"].values.astype(str) == "dynamic"
    for i in np.flatnonzero(dynamic):
        k_own = float(study["saturated_stiffness"].values[i])
        cells = [f"{k_own * _MN:.4f}"]
        for other, _, _ in ctx.constructions.values():
            j = np.flatnonzero(other["case"].values.astype(str) == labels[i])
            if j.size == 0:
                cells += ["-", "-"]
                continue
            k_other = float(other["saturated_stiffness"].values[j[0]])
            past = ""
            if "fs2_limit_indentation" in other and np.isfinite(other["fs2_limit_indentation"].values[j[0]]):
                past = f" (past k_crit from {other['fs2_limit_indentation'].values[j[0]] * _MM:.3f} mm)"
            cells += [f"{k_other * _MN:.4f}{past}", _pct(k_other / k_own - 1.0)]
        lines.append(f"| {labels[i]} | " + " | ".join(cells) + " |")
    lines += ["", "| # | claim | " + own + " | " + " | ".join(ctx.constructions) + " |",
              "|---|---|---|" + "---|" * len(ctx.constructions)]
    for n in sorted(ctx.results):
        c = ctx.results[n]
        others = [f"{res[n].verdict} ({res[n].measured})" if n in res else "-"
                  for _, _, res in ({k: (a, b, {r.number: r for r in c_})
                                     for k, (a, b, c_) in ctx.constructions.items()}).values()]
        lines.append(f"| {n} | {c.claim} | {c.verdict} ({c.measured}) | " + " | ".join(others) + " |")
    return lines + [""]


#: What the belt section says of each ``belt.reference`` (tyreroad.belt_stage).
_BELT_REFERENCE_TEXT = {
    "footprint": "`belt.reference: footprint` (`tyreroad.belt_stage`): the patch is taken for what the paper takes "
                 "it, a sample of a tyre footprint whose 20 mm cells carry similar loads, so the belt sees the patch's "
                 "forces repeated over the footprint. The belt's response to the footprint's mean pressure is the "
                 "tyre's global deflection, which a tyre model computes itself and which is not contact compliance; "
                 "its response to the pressure's variation at the patch scale (and its dynamics there) stays in the "
                 "kernel.",
    "patch_mean": "`belt.reference: patch_mean` (`tyreroad.belt_stage`): the patch alone on the belt, the indentation "
                  "measured from the belt's mean position under it. An isolated loaded patch bends the belt into a "
                  "bowl, and contacts at the patch's edges then count as stiffer than its mean: read the change as an "
                  "upper bound of the belt's local effect, not as the tyre's.",
    "rim": "`belt.reference: rim` (`tyreroad.belt_stage`): the indentation is measured from the rim, so the tyre's "
           "structural compliance is in series with the contact.",
}

#: Frequencies [Hz] at which the belt section compares K* (the stiffness spectrum's default report frequencies).
_BELT_SPECTRUM_FREQUENCIES = (100.0, 1000.0, 5000.0)


def belt_section(ctx: ReportContext) -> list[str]:
    """The study beside the same study on a flexible belt (issue 26): the seed's first limitation answered with
    K_sat per case, the claims, the belt kernels' fit, margin and fidelity, and K* of the reference."""
    if ctx.claims is None or ctx.belt is None:
        return []
    belt_study, belt_greens, belt_results, belt_spectra = ctx.belt
    study = ctx.claims.study
    materials = [str(m) for m in ctx.claims.settings.materials]
    any_greens = next(iter(belt_greens.values()), None)
    reference = "?" if any_greens is None else str(any_greens.attrs.get("belt_reference", "?"))
    from dataclasses import fields

    from ..belt import BeltProperties

    props = "" if any_greens is None else ", ".join(
        f"{f.name} {v}" if isinstance(v, str) else f"{f.name} {float(v):.4g}" for f in fields(BeltProperties)
        for v in (any_greens.attrs.get(f"belt_{f.name}"),)
        if f"belt_{f.name}" in any_greens.attrs)
    lines = [
        "## The flexible belt: the seed's first limitation",
        "",
        "The paper keeps the tread on a rigid belt and says that with a flexible belt, with its waves and modes, "
        "\"the results may be slightly affected but this is not further investigated\". Here every run of the "
        "study was repeated on the kernel of tread + belt (`tyreroad.belt`: a pre-tensioned orthotropic plate on an "
        "elastic bed, coupled exactly through the tread layer as a two-port; ring-and-strip mode sum; its memory "
        "as recursive filters, `tyreroad.belt_kernel`). Belt: " + props + " (SI units).",
        "",
        _BELT_REFERENCE_TEXT.get(reference, f"`belt.reference: {reference}`."),
        "",
        "| material | belt poles | fit error [relative to the magnitude of G_0] | k_crit [N/m] | fidelity (magnitude / phase [rad]) |",
        "|---|---|---|---|---|",
    ]
    for m in materials:
        ds = belt_greens.get(m)
        if ds is None:
            continue
        k = float(ds["critical_stiffness"]) if "critical_stiffness" in ds else float("nan")
        fit = float(ds.attrs.get("belt_fit_error", float("nan")))
        lines.append(f"| {m} | {int(ds.sizes.get('belt_pole', 0))} | {fit:.2e} | "
                     f"{'every spring' if math.isinf(k) else f'{k:.3g}'} | "
                     + (f"{float(ds['fidelity_magnitude']):.2%} / {float(ds['fidelity_phase']):.4f} |"
                        if "fidelity_magnitude" in ds else "- |"))
    lines += ["", "| case | K_sat, rigid belt [MN/m] | K_sat, flexible belt [MN/m] | change |", "|---|---|---|---|"]
    labels = study["case"].values.astype(str)
    other_labels = belt_study["case"].values.astype(str)
    changes, n_past = [], 0
    for i, label in enumerate(labels):
        j = np.flatnonzero(other_labels == label)
        k_own = float(study["saturated_stiffness"].values[i])
        if j.size == 0:
            lines.append(f"| {label} | {k_own * _MN:.4f} | - | - |")
            continue
        k_belt = float(belt_study["saturated_stiffness"].values[j[0]])
        changes.append(k_belt / k_own - 1.0)
        past = ""
        if "fs2_limit_indentation" in belt_study and np.isfinite(belt_study["fs2_limit_indentation"].values[j[0]]):
            past = f" (past k_crit from {belt_study['fs2_limit_indentation'].values[j[0]] * _MM:.3f} mm)"
            n_past += 1
        lines.append(f"| {label} | {k_own * _MN:.4f} | {k_belt * _MN:.4f}{past} | {_pct(k_belt / k_own - 1.0)} |")
    if changes:
        lines += ["", f"Over the {len(changes)} cases the belt changes K_sat by {_pct(min(changes))} to "
                  f"{_pct(max(changes))} (median {_pct(float(np.median(changes)))})."]
    if n_past:
        lines += ["", f"{n_past} belt run(s) reached springs stiffer than their belt kernel's k_crit (marked): they ran "
                  "with `solver.stability: warn`, their fs/2 alternation is recorded in results/belt/contact/ "
                  "(`fs2_alternation`); read those K_sat with it."]
    lines += ["", "| # | claim | rigid belt | flexible belt |", "|---|---|---|---|"]
    by_number = {r.number: r for r in belt_results}
    for n in sorted(ctx.results):
        c = ctx.results[n]
        b = by_number.get(n)
        lines.append(f"| {n} | {c.claim} | {c.verdict} ({c.measured}) | "
                     + ("-" if b is None else f"{b.verdict} ({b.measured})") + " |")
    ref = next((ds for ds in belt_spectra), None)
    rigid = next((ds for ds in ctx.spectra if str(ds.attrs.get("material")) == str(ref.attrs.get("material"))),
                 None) if ref is not None else None
    if ref is not None and rigid is not None:
        lines += ["", f"K*(f; d0) of `{ref.attrs.get('material')}` (relaxed state), rigid against flexible belt:", "",
                  "| d0 [mm] | f [Hz] | K', rigid [MN/m] | K', belt [MN/m] | eta_K, rigid | eta_K, belt |",
                  "|---|---|---|---|---|---|"]
        for p in range(ref.sizes["preload"]):
            for f in _BELT_SPECTRUM_FREQUENCIES:
                sel_b = ref.isel(preload=p).sel(frequency=f, method="nearest")
                sel_r = rigid.isel(preload=p).sel(frequency=f, method="nearest")
                lines.append(f"| {float(ref['preload'][p]) * _MM:.3f} | {float(sel_b['frequency']):.0f} | "
                             f"{float(sel_r['storage_stiffness']) * _MN:.3f} | {float(sel_b['storage_stiffness']) * _MN:.3f} | "
                             f"{float(sel_r['loss_factor']):.3f} | {float(sel_b['loss_factor']):.3f} |")
    return lines + ["", "Reading it: `xarray.open_dataset('results/belt/study.nc')` has the study's case labels; "
                    "`results/belt/greens/<material>.nc` the belt kernels (poles, residues, fit error).", ""]


def _run_note(ctx: ReportContext) -> str:
    """Whether the longest dynamic run reaches beyond the kernel's kept lags ("" without lag counts)."""
    study = ctx.claims.study
    lags = {int(float(ds.attrs["n_lags"])) for ds in ctx.greens.values() if "n_lags" in ds.attrs}
    if not lags or "native_samples" not in study:
        return ""
    longest = int(study.study.select(mode="dynamic")["native_samples"].max())
    return (f"the longest dynamic run has {longest} steps, the kernel keeps {min(lags)} lags: "
            + ("the runs never reach beyond the kept memory" if longest <= min(lags) else
               "longer runs need the kernel's long-memory tail"))


# --------------------------------------------------------------------------------------------------
# sections on the further studies: load-unload cycles, rolling
# --------------------------------------------------------------------------------------------------
def hysteresis_section(ctx: ReportContext) -> list[str]:
    """The load-unload cycles of ``results/loading.nc``: W per case (none without it)."""
    loading = ctx.loading
    if loading is None:
        return []
    lines = [
        "## Load-unload cycles: hysteresis",
        "",
        "Each cycle loads at constant speed, holds, and unloads until every element has separated "
        "(SPEC 10). W is the closed integral of F dd; a quasi-static run has no rate dependence, so its "
        "W is round-off.",
        "",
        "| material | mode | loading | W [mJ] | loading work [mJ] | W / loading work | peak force [N] |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    for i in range(loading.sizes["case"]):
        c = loading.isel(case=i)
        lines.append(
            f"| {c['material'].item()} | {c['mode'].item()} | {c['loading'].item()} | "
            f"{1e3 * float(c['dissipated_energy']):.4g} | {1e3 * float(c['loading_work']):.4g} | "
            f"{float(c['loss_ratio']):.3g} | {float(c['peak_force']):.4g} |"
        )
    return lines + [""]


def rolling_header_section(ctx: ReportContext) -> list[str]:
    """Title of ``results/rolling.md``."""
    return ["# tyreroad: rolling contact", ""]


def rolling_section(ctx: ReportContext) -> list[str]:
    """The rolling study of ``results/rolling.nc``: the table per material and speed, and what it means
    (none without it). Dynamic cases whose fs/2 chatter measure exceeds the threshold
    ``rolling_chatter_max`` are flagged and left out of the coefficient range, which is checked
    against [``rolling_coefficient_lo``, ``rolling_coefficient_hi``]."""
    study, t = ctx.rolling, ctx.thresholds
    if study is None:
        return []
    chatter_max = t["rolling_chatter_max"]
    lines = ["## Rolling contact (SPEC 12)", "",
             f"A slick tyre of radius {study.attrs['radius']:g} m rolls over the road strip {study.attrs['surface']} "
             f"({study.attrs['strip_length'] * 1e3:.0f} mm long) at a fixed axle height: with a wheel load, d0 is "
             "set pass by pass until the mean force over the steady part is the load (rolling.load_tolerance). "
             "Rolling-loss force W/dx over the whole pass (dx = strip length, the strip's ends included); "
             "coefficient = steady P/v (the belt's mean power over the steady part / v) over the steady mean force. "
             "Band levels of the force fluctuation over the steady part (dB re 1 N).", "",
             "| material | mode | v [m/s] | d0 [mm] | mean F [N] | W/dx [N] | coefficient | steady P/v [N] | "
             "centre - x_c [mm] | rms dF [N] | strongest band [Hz] | level [dB] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for i in range(study.sizes["case"]):
        s = study.isel(case=i)
        lv = s["band_level"].values
        top = float(np.nanmax(lv)) if np.isfinite(lv).any() else float("nan")
        flag = " (fs/2 chatter)" if i in _untrustworthy_rolling_cases(study, t) else ""
        lines.append(
            f"| {s['material'].item()}{flag} | {s['mode'].item()} | {float(s['speed']):g} | {1e3 * float(s['d0']):.4f} | "
            f"{float(s['steady_force']):.1f} | {float(s['rolling_loss_force']):.4g} | "
            f"{float(s['rolling_loss_coefficient']):.3e} | {float(s['steady_loss_force']):.4g} | "
            f"{1e3 * float(s['centre_offset']):.3f} | {float(s['fluctuation_rms']):.3g} | "
            f"{float(s['strongest_band']):.0f} | {top:.1f} |")
    bad = _untrustworthy_rolling_cases(study, t)
    lines += _rolling_stability_lines(study, t)
    if bad:
        names = ", ".join(f"{study['material'].values[i]} at {float(study['speed'][i]):g} m/s" for i in bad)
        lines += ["", f"**Not trustworthy: {names}.** Each fails a stability limit (fs/2 alternation without "
                  f"the road's input lines past {t['rolling_alternation_max']:.0e} of the steady force, chatter past "
                  f"{chatter_max:g} of the "
                  "fluctuation, or a hole in a flat road's contact) and is left out of the range below, whatever "
                  "the cause; what the record says about the cause:", ""]
        lines += [f"- {study['material'].values[i]} at {float(study['speed'][i]):g} m/s: {_rolling_failure_cause(study, i, t)}"
                  for i in bad]
    keep = np.ones(study.sizes["case"], bool)
    keep[bad] = False
    dyn = study.isel(case=np.flatnonzero(keep & (study["mode"].values.astype(str) == "dynamic")))
    if dyn.sizes.get("case", 0):
        coef = dyn["rolling_loss_coefficient"].values
        sensible = np.all((coef > t["rolling_coefficient_lo"]) & (coef < t["rolling_coefficient_hi"]))
        strongest = sorted({float(v) for v in dyn["strongest_band"].values if np.isfinite(v)})
        lines += ["", f"Strongest 1/3-octave bands of the dynamic force: {', '.join(f'{v:.0f}' for v in strongest)} Hz "
                  f"(v / f = {', '.join(f'{1e3 * float(sp) / float(fb):.0f}' for sp, fb in zip(dyn['speed'].values, dyn['strongest_band'].values))} mm: "
                  "a band that moves with the speed at a fixed wavelength is excited by the road texture, or, at the element size, by the elements entering the contact)."]
        lines += ["", f"Dynamic rolling-loss coefficients span {np.nanmin(coef):.2e} to {np.nanmax(coef):.2e}; "
                  f"tread hysteresis is expected of the order of 1e-3 to 1e-2: "
                  f"{'in that range' if sensible else 'OUTSIDE that range (check the material and d0)'}."]
    qs = study.where(study["mode"] == "quasistatic", drop=True)
    for material in dict.fromkeys(qs["material"].values.astype(str)) if qs.sizes.get("case", 0) else []:
        curves = qs["force_curve"].values[qs["material"].values.astype(str) == material]
        if len(curves) > 1:
            diff = np.max(np.abs(curves - curves[0])) / np.max(np.abs(curves[0]))
            lines += ["", f"Quasi-static passes of {material} at {len(curves)} speeds: F(x_c) differs by at most "
                      f"{diff:.1e} of its peak (no rate effect)."]
    return lines + [""]


def _judged_alternation(study, i) -> float:
    """The fs/2 alternation case ``i`` is judged by: the fourth difference once the road's input lines (k v /
    element size, aliased, outside the top band) are fitted out (``alternation_input_removed``), where the
    record has it; else the raw fourth difference (``fs2_alternation``).

    The raw fourth difference also reads those lines near fs/2 (0.79 of a 20 kHz line): on the flat road at
    10 m/s they are the model's own response to rows of elements entering the contact, the same with the
    every-spring Radau kernel as with the default one (20 kHz line 2.81e-4 against 2.79e-4 of the mean force,
    150 x 8 strip, tread), so they do not measure the march. A line in the top band is never removed."""
    for name in ("alternation_input_removed", "fs2_alternation"):
        if name in study and np.isfinite(float(study[name].values[i])):
            return float(study[name].values[i])
    return float("nan")


def _untrustworthy_rolling_cases(study, t) -> list[int]:
    """Dynamic rolling cases whose force alternates at fs/2 (chatter over the fluctuation, or alternation over
    the steady mean force without the road's input lines, :func:`_judged_alternation`, past their thresholds) or
    whose flat-road contact has a hole."""
    def value(name, i, default=0.0):
        return float(study[name].values[i]) if name in study else default

    bad = []
    for i in range(study.sizes["case"]):
        alternation = _judged_alternation(study, i)
        flat = bool(value("flat_road", i))  # no texture: the chatter's fluctuation is only the element ripple
        if ((not flat and value("chatter", i) > t["rolling_chatter_max"])
                or (np.isfinite(alternation) and alternation > t["rolling_alternation_max"]
                    and _alternation_is_judged(study, i))
                or (flat and value("contact_holes", i) > 0)):
            bad.append(i)
    return bad


#: Growth of the fourth difference over the steady part (last third / first third) above which a failing pass
#: reads as a growing mode rather than a steady ripple.
_GROWING = 1.1


def _rolling_failure_cause(study, i, t) -> str:
    """Why case ``i`` of :func:`_untrustworthy_rolling_cases` fails, from its stability record: a march
    instability (force in the top band 0.9-1 x fs/2 past the limit, or a growing fourth difference, or chatter),
    or a steady ripple at the road's input (elements entering the contact at v / element size) that the fourth
    difference also reads; holes are named."""
    def value(name, default=float("nan")):
        return float(study[name].values[i]) if name in study else default

    limit = t["rolling_alternation_max"]
    alternation, band, growth = value("fs2_alternation"), value("fs2_band_amplitude"), value("alternation_growth")
    parts = []
    flat = bool(value("flat_road", 0.0))
    if not flat and value("chatter", 0.0) > t["rolling_chatter_max"]:
        parts.append(f"chatter {value('chatter'):.3g} of the fluctuation (limit {t['rolling_chatter_max']:g}): "
                     "the force alternates step by step, a march instability")
    judged = _judged_alternation(study, i)
    if np.isfinite(judged) and judged > limit and _alternation_is_judged(study, i):
        removed = value("alternation_input_removed")
        what = (f"fs/2 alternation {alternation:.2e}"
                + (f", {removed:.2e} without the road's input lines" if np.isfinite(removed) else "")
                + f" (limit {limit:.0e})")
        rate, fs = value("element_rate"), value("sample_rate")
        in_top = ([] if not (np.isfinite(rate) and np.isfinite(fs)) else
                  [k + 1 for k, line in enumerate(input_line_frequencies(rate, fs)) if line >= 0.5 * TOP_BAND * fs])
        if growth <= _GROWING and band > limit and in_top:
            k = in_top[0]
            parts.append(f"{what}, top band {band:.2g}, growth {growth:.2f}: either a march instability or the road "
                         f"input's line {k} x v / element size = {k * rate / 1e3:.3g} kHz, which aliases into the top "
                         "band, where the record cannot tell them apart")
        elif band > limit or growth > _GROWING:
            parts.append(f"{what}, top band {band:.2g}, growth {growth:.2f}: a march instability")
        elif np.isfinite(removed):
            parts.append(f"{what}, but its top band is {band:.2g} and it does not grow ({growth:.2f}): a steady "
                         "alternation the record does not explain (the road's input lines k = 1 ... "
                         f"{INPUT_HARMONICS} are out of it; higher harmonics of v / element size = "
                         f"{rate / 1e3:.3g} kHz would read so)")
        else:
            parts.append(f"{what}, but its top band is {band:.2g} and it does not grow ({growth:.2f}): the fourth "
                         f"difference reads the steady ripple of element rows entering the contact at v / element "
                         f"size = {rate / 1e3:.3g} kHz and its harmonics (the 1 mm discretisation of the road's "
                         "input; this record has no alternation without those lines); not a march instability")
    if flat and value("contact_holes", 0.0) > 0:
        parts.append(f"{int(value('contact_holes'))} force-free elements inside a row of the flat road's contact")
    return "; ".join(parts) if parts else "see the stability table"


def _alternation_is_judged(study, i) -> bool:
    """Whether case ``i``'s fs/2 alternation can only be numerical: the road's input (v / element size: the
    texture, and on any road the elements entering the contact) stays below a quarter of the sample rate.
    Faster passes drive the force near fs/2 themselves, so their fourth difference is partly physics and
    only reported."""
    if "element_rate" not in study or "sample_rate" not in study:
        return True
    return float(study["element_rate"].values[i]) <= 0.25 * float(study["sample_rate"].values[i])


def _rolling_stability_lines(study, t) -> list[str]:
    """The dynamic passes' stability record: the kernel's margin, the stiffest spring, the fs/2 alternation
    against ``rolling_alternation_max`` and, on a flat road, the contact's holes."""
    dynamic = [i for i in range(study.sizes["case"]) if str(study["mode"].values[i]) == "dynamic"]
    if not dynamic or "fs2_alternation" not in study:
        return []
    limit = t["rolling_alternation_max"]
    lines = ["", f"Stability of the dynamic passes (tyreroad.stability): the kernel's margin k_crit over the unit "
             f"circle, the stiffest contact spring of the pass (marked where it exceeds k_crit: stability is then not "
             f"certified, only measured), and the fs/2 alternation of the force over the "
             f"steady part relative to the steady mean force (limit {limit:.0e}, judged where the road's input v / "
             f"element size stays below fs/4: faster passes put real force content near fs/2); beside it, the "
             f"largest component in the top band 0.9-1 x fs/2 over the mean force and the growth of the fourth "
             f"difference from the first to the last third of the steady part (a march instability sits in the "
             f"top band or grows; the ripple of elements entering the contact sits at v / element size and stays). "
             f"The verdict reads the alternation once those input lines (k v / element size, k = 1 ... "
             f"{INPUT_HARMONICS}, aliased; a line in the top band is kept) are fitted and removed: the raw fourth "
             f"difference counts them too (0.79 of a 20 kHz line), and on the flat road at 10 m/s they are the "
             f"model's response to the elements entering, the same with the every-spring Radau kernel as with the "
             f"default one, not the march's"
             + (", and the most force-free elements inside a row of the flat road's contact (limit 0)"
                if "flat_road" in study and study["flat_road"].values.any() else "") + ".", "",
             "| material | v [m/s] | k_crit [N/m] | stiffest spring [N/m] | fs/2 alternation (raw) | without input lines (judged) | "
             "top-band amplitude | growth | holes | verdict |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    bad = set(_untrustworthy_rolling_cases(study, t))
    for i in dynamic:
        margin = float(study["margin_critical_stiffness"].values[i]) if "margin_critical_stiffness" in study else np.nan
        stiff = float(study["max_spring_stiffness"].values[i]) if "max_spring_stiffness" in study else np.nan
        holes = (str(int(study["contact_holes"].values[i])) if "flat_road" in study and study["flat_road"].values[i]
                 else "(rough road)")
        verdict = "fails" if i in bad else "holds" if _alternation_is_judged(study, i) else "not judged (input near fs/2)"
        band = float(study["fs2_band_amplitude"].values[i]) if "fs2_band_amplitude" in study else np.nan
        growth = float(study["alternation_growth"].values[i]) if "alternation_growth" in study else np.nan
        past = " (past k_crit)" if stiff > margin else ""  # NaN compares False: no mark without a margin
        removed = (float(study["alternation_input_removed"].values[i]) if "alternation_input_removed" in study
                   else np.nan)
        lines.append(f"| {study['material'].values[i]} | {float(study['speed'].values[i]):g} | {margin:.3g} | "
                     f"{stiff:.3g}{past} | {float(study['fs2_alternation'].values[i]):.2e} | {removed:.2e} | {band:.1e} | "
                     f"{growth:.2f} | {holes} | {verdict} |")
    if "flat_road" in study:
        for material in dict.fromkeys(study["material"].values.astype(str)):
            rows = [i for i in dynamic if str(study["material"].values[i]) == material and study["flat_road"].values[i]]
            rows.sort(key=lambda i: float(study["speed"].values[i]))
            if len(rows) < 3:
                continue
            speeds = [float(study["speed"].values[i]) for i in rows]
            centre = np.array([float(study["centre_offset"].values[i]) for i in rows])
            loss = np.array([float(study["steady_loss_force"].values[i]) for i in rows])

            def monotone(v):
                return bool(np.all(np.diff(v) > 0) or np.all(np.diff(v) < 0))

            lines += ["", f"Flat road, {material}, against speed ({', '.join(f'{v:g}' for v in speeds)} m/s): "
                      f"pressure centre - x_c {', '.join(f'{1e3 * v:.3f}' for v in centre)} mm "
                      f"({'monotone' if monotone(centre) else 'NOT monotone'}), steady loss force "
                      f"{', '.join(f'{v:.4g}' for v in loss)} N ({'monotone' if monotone(loss) else 'NOT monotone'})."]
    return lines


def config_section(ctx: ReportContext) -> list[str]:
    """The config the report was made from, as YAML."""
    return ["## Config", "", "```yaml", ctx.config_text.rstrip(), "```", ""]


def _springs_rheology(study: xr.Dataset) -> str:
    """The contact springs' rheology a rolling study's passes ran with (its ``spring_rheology`` attribute, from
    the springs files; a study written before the attribute existed: ``elastic (not recorded)``)."""
    return str(study.attrs.get("spring_rheology", "elastic (not recorded)"))


def rolling_spring_comparison_section(ctx: ReportContext) -> list[str]:
    """Rolling loss with viscoelastic (QLV) contact springs against elastic ones (issue 24), pass by pass: the
    cases of this study matched by material, mode and speed with those of ``ctx.rolling_reference`` (none
    without ``spring_comparison``). Both must be on the same strip; the table states each one's springs."""
    study, ref, label = ctx.rolling, ctx.rolling_reference, ctx.rolling_reference_label
    if study is None or not label:
        return []
    lines = ["## Rolling loss with viscoelastic contact springs", ""]
    if ref is None:
        return lines + [f"The elastic-springs rolling study `{label}/rolling.nc` is missing: run it first (same "
                        "config without `springs.rheology: qlv`); nothing is compared.", ""]
    same = {k: (study.attrs.get(k), ref.attrs.get(k)) for k in ("surface", "strip_length", "radius")}
    differ = {k: v for k, v in same.items() if v[0] != v[1]}
    if differ:
        return lines + ["Not compared: the two rolling studies are not on the same strip ("
                        + ", ".join(f"{k} {a} here, {b} in `{label}`" for k, (a, b) in differ.items()) + ").", ""]
    mine, theirs = _springs_rheology(study), _springs_rheology(ref)
    lines += [f"This study's contact springs are `{mine}`, those of `{label}` `{theirs}`; strip {study.attrs['surface']} "
              f"({study.attrs['strip_length'] * 1e3:.0f} mm), both at the wheel load (d0 set pass by pass). "
              "Steady P/v: the belt's mean power over the steady part / v; coefficient: that over the steady mean "
              "force.", "",
              f"| material | mode | v [m/s] | d0 {theirs} / {mine} [mm] | mean F {theirs} / {mine} [N] | "
              f"steady P/v {theirs} / {mine} [N] | ratio | coefficient {theirs} / {mine} | fs/2 alternation {mine} |",
              "|---|---|---|---|---|---|---|---|---|"]
    key = lambda d, i: (str(d["material"].values[i]), str(d["mode"].values[i]), float(d["speed"].values[i]))
    ref_cases = {key(ref, i): i for i in range(ref.sizes["case"])}
    ratios = []
    for i in range(study.sizes["case"]):
        j = ref_cases.get(key(study, i))
        if j is None:
            continue
        a, b = ref.isel(case=j), study.isel(case=i)
        ratio = float(b["steady_loss_force"]) / float(a["steady_loss_force"])
        if str(b["mode"].item()) == "dynamic":
            ratios.append(ratio)
        alt = float(b["fs2_alternation"]) if "fs2_alternation" in b else float("nan")
        lines.append(f"| {b['material'].item()} | {b['mode'].item()} | {float(b['speed']):g} | "
                     f"{1e3 * float(a['d0']):.4f} / {1e3 * float(b['d0']):.4f} | {float(a['steady_force']):.1f} / "
                     f"{float(b['steady_force']):.1f} | {float(a['steady_loss_force']):.4g} / "
                     f"{float(b['steady_loss_force']):.4g} | {ratio:.3f} | {float(a['rolling_loss_coefficient']):.3e} / "
                     f"{float(b['rolling_loss_coefficient']):.3e} | {alt:.1e} |")
    if ratios:
        lines += ["", f"Dynamic passes: the steady rolling-loss force with `{mine}` springs is "
                  f"{min(ratios):.3f}-{max(ratios):.3f} times that with `{theirs}` springs. The contact springs' own "
                  "hysteresis (they relax with the tread's modulus) adds to the layer's; quasi-static passes "
                  "hold relaxed states, where both spring laws give the same force."]
    return lines + [""]
