"""The dynamic runs on the patterned treads in ``results/pattern.md`` (issue 27), from ``results/pattern/dynamic.nc``.

Per material and pattern: K_sat of the quasi-static run on the block's modal form (its relaxed table, element-mean
field) and of the dynamic runs at every acceleration, the seed's inertia claims 1 and 2 re-checked on the blocks
with the report's thresholds (:data:`tyreroad.report.claims.THRESHOLDS`), the inertia effect K_sat(a) / K_sat(QS)
- 1, each run's fs/2 alternation and wall time, and each pattern's modal check and cost. With the pattern study
beside it, the quasi-static K_sat of the FE table (element-centre field) of the same pattern, so that the change
of field is stated, not hidden.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .claims import THRESHOLDS, loss_direction_verdict

__all__ = ["dynamic_section"]


def _mn(x: float) -> str:
    return f"{x / 1e6:.3f}"


def dynamic_section(ds: xr.Dataset, study: xr.Dataset | None = None) -> list[str]:
    """The markdown lines of the dynamic pattern runs (see the module docstring)."""
    t = THRESHOLDS
    d = ds["indentation"].values
    lines = ["## Dynamic runs on the blocks", "",
             "The block's FE modal form (element-mean field) as a Radau IIA-3 stage kernel "
             "(`tyreroad.pattern_dynamic`): stable for every spring by construction, history in modal coordinates. "
             "The quasi-static reference (QS) is the same form's relaxed table, so that the dynamic/QS ratios compare "
             "one model; the pattern study's quasi-static runs above use the FE table's element-centre field.", ""]
    lines += ["| material / pattern | QS K_sat [MN/m] | " + " | ".join(
        f"a = {a:g}: K_sat [MN/m] (vs QS)" for a in sorted(set(ds["acceleration"].values[ds["mode"].values == "dynamic"])))
        + " | claim 1: min K_a/K_QS, d > 0.05 mm | claim 2: QS < K_50 < ... | max fs/2 alternation | march [s] |",
        "|---|---|" + "---|" * (len(set(ds["acceleration"].values[ds["mode"].values == "dynamic"])) + 4)]
    mats, pats = ds["material"].values.astype(str), ds["pattern"].values.astype(str)
    for m, p in dict.fromkeys(zip(mats, pats)):
        sel = np.flatnonzero((mats == m) & (pats == p))
        qs = [i for i in sel if ds["mode"].values[i] == "quasistatic"]
        if not qs:  # a variant run only at the highest acceleration: in the claims 6 and 7 table below
            continue
        dyn = sorted((i for i in sel if ds["mode"].values[i] == "dynamic"), key=lambda i: ds["acceleration"].values[i])
        if not qs or not dyn:
            continue
        q = qs[0]
        k_qs = ds["stiffness"].values[q]
        ks_qs = float(ds["saturated_stiffness"].values[q])
        cells, ratios = [], []
        for i in dyn:
            ks = float(ds["saturated_stiffness"].values[i])
            cells.append(f"{_mn(ks)} ({100 * (ks / ks_qs - 1):+.1f} %)")
            ka = ds["stiffness"].values[i]
            ok = (d > t["c1_d_min"]) & np.isfinite(ka) & np.isfinite(k_qs)
            ratios.append(float(np.min(ka[ok] / k_qs[ok])))
        seq = [ks_qs] + [float(ds["saturated_stiffness"].values[i]) for i in dyn]
        c1 = "holds" if all(r > 1.0 for r in ratios) else "fails"
        c2 = "holds" if all(b > a for a, b in zip(seq, seq[1:])) else "fails"
        alt = np.nanmax(ds["fs2_alternation"].values[dyn])
        march = ", ".join(f"{ds['contact_time'].values[i]:.0f}" for i in [q] + dyn)
        lines.append(f"| {m} / {p} | {_mn(ks_qs)} | " + " | ".join(cells)
                     + f" | {', '.join(f'{r:.3f}' for r in ratios)}: {c1} | {c2} | {alt:.1e} | {march} |")
    lines.append("")
    lines += _variant_lines(ds)
    if study is not None:
        notes = []
        for m, p in dict.fromkeys(zip(mats, pats)):
            q = [i for i in np.flatnonzero((mats == m) & (pats == p)) if ds["mode"].values[i] == "quasistatic"]
            case = f"{m}/{p}"
            if q and case in list(study["case"].values):
                centre = float(study["saturated_stiffness"].sel(case=case))
                mean = float(ds["saturated_stiffness"].values[q[0]])
                notes.append(f"{case}: {_mn(mean)} MN/m (element mean) against {_mn(centre)} MN/m (element centre, "
                             f"the pattern study's FE table), {100 * (mean / centre - 1):+.1f} %")
        if notes:
            lines += ["Quasi-static K_sat by the field of the block table: " + "; ".join(notes) + ".", ""]
    rows = []
    for j, p in enumerate(ds["modal_pattern"].values.astype(str)):
        rows.append(f"| {p} | {ds['lowest_natural_frequency'].values[j]:.0f} | {100 * ds['modal_error'].values[j]:.2f} % "
                    f"at {ds['check_frequency'].values[j]:g} Hz | {ds['modes_time_s'].values[j]:.0f} / "
                    f"{ds['compute_time_s'].values[j]:.0f} | {ds['modal_bytes'].values[j] / 1e6:.3g} |")
    lines += ["| pattern | lowest mode [Hz] | modal form vs direct FE solve | modes / stage [s] | modal form [MB] |",
              "|---|---|---|---|---|"] + rows + [""]
    return lines


def _variant_lines(ds: xr.Dataset) -> list[str]:
    """Claims 6 (loss factor) and 7 (density, its K_sat part) on each pattern at the highest acceleration: the
    variants' K_sat against the reference material's (the one with a quasi-static run)."""
    t = THRESHOLDS
    mats, pats, modes = (ds[k].values.astype(str) for k in ("material", "pattern", "mode"))
    acc = ds["acceleration"].values
    out = []
    for p in dict.fromkeys(pats):
        refs = {m for m, pp, mo in zip(mats, pats, modes) if pp == p and mo == "quasistatic"}
        if len(refs) != 1:
            continue
        ref = refs.pop()
        a_ref = float(acc[(pats == p) & (modes == "dynamic")].max())
        at = {m: i for i, (m, pp, mo, a) in enumerate(zip(mats, pats, modes, acc)) if pp == p and mo == "dynamic"
              and a == a_ref}
        if ref not in at or len(at) < 2:
            continue
        k_ref = float(ds["saturated_stiffness"].values[at[ref]])
        rho_ref = float(ds["density"].values[at[ref]])
        loss, dens = {}, {}
        for m, i in at.items():
            if m == ref:
                continue
            delta = float(ds["saturated_stiffness"].values[i]) / k_ref - 1.0
            if float(ds["loss_scale"].values[i]) != 1.0:
                loss[(float(ds["loss_scale"].values[i]), m)] = delta
            elif abs(float(ds["density"].values[i]) / rho_ref - 1.0) > 1e-12:
                dens[(float(ds["density"].values[i]) / rho_ref, m)] = delta
        if loss:
            verdict = loss_direction_verdict({s: v for (s, _), v in loss.items()}, t["c6_delta_max"], t["c6_delta_min"])
            out.append(f"- {p}, claim 6 (loss factor ±50 % changes K_sat by a few percent, higher loss stiffer; a = "
                       f"{a_ref:g}): " + ", ".join(f"η×{s:g} ({m}): {100 * v:+.2f} %" for (s, m), v in
                                                  sorted(loss.items())) + f": **{verdict}**")
        if dens:
            ok = all(abs(v) <= t["c7_delta_max"] for v in dens.values())
            out.append(f"- {p}, claim 7, its K_sat part (density ×2 and ×0.5 change K_sat by ≤ "
                       f"{100 * t['c7_delta_max']:g} %; a = {a_ref:g}): " + ", ".join(
                           f"ρ×{s:g} ({m}): {100 * v:+.2f} %" for (s, m), v in sorted(dens.items()))
                       + f": **{'holds' if ok else 'fails'}** (the ripple part is not evaluated on the blocks)")
    return (["Loss and density variants on the blocks (K_sat against the reference material's at the highest "
             "acceleration):", ""] + out + [""]) if out else []
