r"""Claim 6 by loss-variant definition: the seed's (frequency domain) and causal anchors (time domain), issue 24.

The seed's claim 6 says that a loss factor x0.5 / x1.5 changes the saturated contact stiffness by a few
percent, a higher loss giving a stiffer contact. What a "loss variant" is decides the answer:

* **seed** (``{base: tread, loss_scale: s}``): eta scaled at constant |E|. Not causal (it breaks
  Kramers-Kronig), so no time-domain run of it is meaningful and the workflow refuses one at planning
  time (:func:`tyreroad.material.causality_error`). It is measured in the frequency domain: the storage
  contact stiffness K'(f_c; d0) = Re K* about the relaxed preload state d0 (:mod:`tyreroad.stiffness`),
  relative to the reference's. The seed variant's relaxed modulus is the reference's (eta(0) = 0), so
  the relaxed state, the springs and the static kernel are the reference's; only the element FRF
  G(f_c) differs. d0 (default 0.2 mm) lies in the saturation range and f_c (default 1 kHz) is the centre
  of the band the reference loading excites: at 500 m/s^2 the tread reaches 0.25 mm in
  sqrt(2 d_max / a) = 1 ms, the saturation range in 0.85-1 ms.
* **causal** (``loss_anchor: f_a``): E_s = |E(f_a)|^(1-s) E^s, the phase scaled and |E| kept at f_a.
  Measured in the time domain: Delta K_sat at the reference acceleration, from contact runs. The study's
  own loss variants (study.materials, figure 7) carry the default anchor; ``study.claim6.anchor_variants``
  adds the variants of another anchor (dynamic runs at the reference acceleration only).
What decides the sign is checked by runs that change one quantity of a variant at a time:

* **storage check** (``modulus_scale: k``, time domain): the reference with every modulus scaled by k, its
  loss factor unchanged, k the E'(f_c) ratio of one causal variant: E' in the loading's band alone.
* **springs check** (a variant's ``quasi_static_modulus``, time domain): the reference with the relaxed
  modulus of one causal variant, which sets the element springs (``springs.modulus: quasi_static``) and the
  quasi-static kernel; E(w) and the dynamic kernel stay the reference's. A phase-scaled variant anchored at
  f_a > 0 moves its relaxed modulus a lot (|E(f_a)|^(1-s) E0^s: +72 % / -42 % for x0.5 / x1.5 at 1 kHz).
* **layer check** (a causal variant with the reference's ``quasi_static_modulus``, time domain): the variant's
  layer with the reference's springs and quasi-static kernel: the complement of the springs check.
* for the seed rows (frequency domain, in the same job): K' of the reference with E scaled so that either
  its E'(f_c) or its storage compliance Re(1/E)(f_c) matches the seed variant's. At constant |E| these two
  move in opposite directions (E' = |E| cos phi, Re 1/E = cos phi / |E|), so the runs tell which one K' follows.

A control *accounts for* a variant's Delta when it has its sign and lies within :data:`ACCOUNTS` (relative)
of it; for a causal variant the sum of the two controls is compared as well.

:func:`claim6_dataset` collects every row (results/claim6.nc, rule ``claim6``, whose measurements live in
:mod:`tyreroad.claim6_runs`, so that the report does not import the solver); :func:`claim6_rows`
turns it into the report's table, with the verdict of :func:`tyreroad.report.claims.loss_direction_verdict`
per definition and the sign's explanation as the controls measured it.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr

logger = logging.getLogger(__name__)

__all__ = [
    "Claim6Settings",
    "storage_change",
    "claim6_dataset",
    "claim6_rows",
]

_KEYS = {"frequency", "preload", "seed_variants", "anchor_variants", "storage_checks", "springs_checks", "layer_checks"}

#: A control accounts for a variant's Delta when it has its sign and |control - Delta| <= ACCOUNTS |Delta|.
ACCOUNTS = 0.5
#: Two controls together account for it when their sum has its sign and |sum - Delta| <= ACCOUNTS_SUM (|a| + |b|)
#: (the parts may nearly cancel, so the residual is measured against their size).
ACCOUNTS_SUM = 0.25


@dataclass(frozen=True)
class Claim6Settings:
    """Config section ``study.claim6``.

    Attributes
    ----------
    frequency : float
        f_c [Hz]: where the seed definition's K' and every variant's E' change are read (default 1 kHz).
    preload : float
        d0 [m] of the seed definition's K* (default 0.2 mm, in the saturation range).
    seed_variants, anchor_variants, storage_checks, springs_checks, layer_checks : tuple of str
        Material presets (see the module docstring); each may be empty.
    """

    frequency: float = 1000.0
    preload: float = 2.0e-4
    seed_variants: tuple = ()
    anchor_variants: tuple = ()
    storage_checks: tuple = ()
    springs_checks: tuple = ()
    layer_checks: tuple = ()

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "Claim6Settings":
        section = dict(section or {})
        unknown = sorted(set(section) - _KEYS)
        if unknown:
            raise ValueError(f"study.claim6.{unknown[0]}: unknown key (expected one of {', '.join(sorted(_KEYS))})")
        out = {}
        for key in ("frequency", "preload"):
            if key in section:
                v = section[key]
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                    raise ValueError(f"study.claim6.{key} = {v!r}: expected a number > 0")
                out[key] = float(v)
        for key in ("seed_variants", "anchor_variants", "storage_checks", "springs_checks", "layer_checks"):
            names = section.get(key) or []
            if isinstance(names, str) or not all(isinstance(n, str) for n in names):
                raise ValueError(f"study.claim6.{key} = {names!r}: expected a list of material presets")
            out[key] = tuple(names)
        return cls(**out)

    @property
    def time_domain(self) -> tuple:
        """The materials of the section that get contact runs (anchor variants and the checks)."""
        return self.anchor_variants + self.storage_checks + self.springs_checks + self.layer_checks


def storage_change(material, reference, frequency: float) -> float:
    """E'(f) of ``material`` over E'(f) of ``reference``, minus 1 [1]."""
    w = 2.0 * np.pi * float(frequency)
    return float(material.storage_modulus(w) / reference.storage_modulus(w) - 1.0)


def _matching(candidates, value, rel):
    """The first (name, delta) of ``candidates`` [(name, key value, delta)] whose key matches ``value``."""
    for name, key, delta in candidates:
        if math.isclose(key, value, rel_tol=rel, abs_tol=rel):
            return name, delta
    return "", math.nan


def claim6_dataset(materials: Mapping[str, Any], reference: str, ksat: Mapping[str, float],
                   k_star: Mapping[str, complex], settings: Claim6Settings, acceleration: float,
                   study_loss_variants: Sequence[str]) -> xr.Dataset:
    """The rows of the claim-6 table (results/claim6.nc), dim ``variant``.

    Parameters
    ----------
    materials : mapping
        Material name -> :class:`tyreroad.material.Material` (the reference and every variant and check).
    reference : str
        The reference material.
    ksat : mapping
        K_sat [N/m] at the reference acceleration of the reference and of every time-domain material.
    k_star : mapping
        K*(f_c; d0) [N/m] of the reference, every seed variant and its two controls
        (``<seed>-storage-control``, ``<seed>-loss-control``, :func:`seed_controls`).
    settings : Claim6Settings
    acceleration : float
        The reference acceleration [m/s^2].
    study_loss_variants : sequence of str
        The study's loss variants (the default anchor, figure 7).

    Returns
    -------
    xarray.Dataset
        Per variant: ``definition`` (seed, causal, storage-check, springs-check), ``delta`` (K' change
        for seed rows, K_sat change otherwise), ``loss_scale``, ``loss_anchor`` (NaN: seed),
        ``storage_change`` (E'(f_c)), ``quasi_static_change``, and the controls that change one quantity of it:
        ``storage_control`` / ``springs_control`` (causal rows, the matching check's Delta K_sat) or
        ``storage_control`` / ``compliance_control`` (seed rows, Delta K' of the controls with the seed's
        storage compliance / loss compliance alone); NaN where there is none.
    """
    ref = materials[reference]
    w_c = 2.0 * np.pi * settings.frequency

    def qs_change(m):
        return m.quasi_static_modulus / ref.quasi_static_modulus - 1.0

    storage_checks = [(n, storage_change(materials[n], ref, settings.frequency), ksat[n] / ksat[reference] - 1.0)
                      for n in settings.storage_checks]
    springs_checks = [(n, qs_change(materials[n]), ksat[n] / ksat[reference] - 1.0) for n in settings.springs_checks]
    layer_checks = [(n, (float(materials[n].loss_scale), materials[n].loss_anchor), ksat[n] / ksat[reference] - 1.0)
                    for n in settings.layer_checks if abs(qs_change(materials[n])) < 1e-9]
    rows = []
    for group, names in (("causal", list(study_loss_variants)), ("causal", list(settings.anchor_variants)),
                         ("seed", list(settings.seed_variants)), ("storage-check", list(settings.storage_checks)),
                         ("springs-check", list(settings.springs_checks)),
                         ("layer-check", list(settings.layer_checks))):
        for name in names:
            m = materials[name]
            row = {"variant": name, "definition": group, "loss_scale": float(m.loss_scale),
                   "loss_anchor": math.nan if m.loss_anchor is None else float(m.loss_anchor),
                   "modulus_scale": float(m.modulus_scale),
                   "storage_change": storage_change(m, ref, settings.frequency),
                   "compliance_change": float((1.0 / complex(m.modulus(w_c))).real / (1.0 / complex(ref.modulus(w_c))).real
                                              - 1.0),
                   "loss_compliance_change": float((1.0 / complex(m.modulus(w_c))).imag
                                                   / (1.0 / complex(ref.modulus(w_c))).imag - 1.0),
                   "quasi_static_change": qs_change(m), "default": name in study_loss_variants,
                   "storage_control": math.nan, "springs_control": math.nan, "compliance_control": math.nan,
                   "layer_control": math.nan,
                   "storage_control_name": "", "springs_control_name": "", "layer_control_name": ""}
            if group == "seed":
                kr = k_star[reference].real
                row["quantity"] = "storage contact stiffness K'(f_c; d0)"
                row["delta"] = k_star[name].real / kr - 1.0
                row["storage_control"] = k_star[f"{name}-storage-control"].real / kr - 1.0
                row["compliance_control"] = k_star[f"{name}-loss-control"].real / kr - 1.0
            else:
                row["quantity"] = "K_sat"
                row["delta"] = ksat[name] / ksat[reference] - 1.0
                if group == "causal":
                    row["storage_control_name"], row["storage_control"] = _matching(
                        storage_checks, row["storage_change"], 1e-3)
                    row["springs_control_name"], row["springs_control"] = _matching(
                        springs_checks, row["quasi_static_change"], 1e-4)
                    key = (float(m.loss_scale), m.loss_anchor)
                    row["layer_control_name"], row["layer_control"] = next(
                        ((n, dl) for n, k, dl in layer_checks if k == key), ("", math.nan))
            rows.append(row)
    dim = "variant"
    meta = {
        "definition": ("1", "seed (constant |E|, frequency domain), causal (phase scaled, time domain), "
                            "storage-check or springs-check"),
        "quantity": ("1", "what delta compares"),
        "delta": ("1", "variant / reference - 1 of the quantity (K' at f_c and d0 for seed rows, else K_sat)"),
        "loss_scale": ("1", "loss scale s"),
        "loss_anchor": ("Hz", "frequency whose |E| the causal variant keeps (NaN: the seed's constant |E|)"),
        "modulus_scale": ("1", "modulus scale k (storage checks)"),
        "storage_change": ("1", "E'(f_c) / E'_reference(f_c) - 1"),
        "compliance_change": ("1", "Re(1/E)(f_c) / Re(1/E_reference)(f_c) - 1 (storage compliance)"),
        "loss_compliance_change": ("1", "Im(1/E)(f_c) / Im(1/E_reference)(f_c) - 1 (loss compliance)"),
        "quasi_static_change": ("1", "quasi-static (relaxed) modulus / the reference's - 1: the springs"),
        "default": ("1", "1: a study loss variant (the default anchor, figure 7)"),
        "storage_control": ("1", "delta of the control with the variant's E'(f_c) alone (seed rows: its storage "
                                 "compliance Re(1/E) alone, at every frequency; NaN: none)"),
        "springs_control": ("1", "delta of the control with the variant's quasi-static modulus alone (NaN: none)"),
        "compliance_control": ("1", "seed rows: delta of the control with the variant's loss compliance Im(1/E) alone"),
        "storage_control_name": ("1", "material of the storage control (time domain; '' for none)"),
        "springs_control_name": ("1", "material of the springs control ('' for none)"),
        "layer_control": ("1", "delta of the variant run with the reference's springs (the layer alone; NaN: none)"),
        "layer_control_name": ("1", "material of the layer control ('' for none)"),
    }
    text = {"definition", "quantity", "storage_control_name", "springs_control_name", "layer_control_name"}
    values = {k: np.array([r[k] for r in rows], dtype=object) if k in text else
              np.array([r[k] for r in rows], dtype=np.int8 if k == "default" else float) for k in meta}
    ds = xr.Dataset(
        {k: (dim, values[k], {"units": u, "long_name": n}) for k, (u, n) in meta.items()},
        coords={dim: (dim, np.array([r["variant"] for r in rows], dtype=object),
                      {"units": "1", "long_name": "material preset"})},
        attrs={"reference_material": reference, "frequency": settings.frequency, "preload": settings.preload,
               "acceleration": float(acceleration), "accounts_within": ACCOUNTS,
               "reference_saturated_stiffness": float(ksat.get(reference, math.nan)),
               "reference_storage_stiffness": float(k_star[reference].real) if reference in k_star else math.nan},
    )
    return ds


def _pct(x: float) -> str:
    return f"{100 * x:+.2f} %"


def _accounts(control: float, delta: float, within: float = ACCOUNTS) -> bool:
    """A control accounts for ``delta``: the same sign and |control - delta| <= within |delta|."""
    return (math.isfinite(control) and delta != 0 and np.sign(control) == np.sign(delta)
            and abs(control - delta) <= within * abs(delta))


def _accounts_sum(a: float, b: float, delta: float) -> bool:
    """Two controls together account for ``delta``: their sum has its sign and misses it by at most
    :data:`ACCOUNTS_SUM` of their sizes |a| + |b|."""
    return (math.isfinite(a) and math.isfinite(b) and delta != 0 and np.sign(a + b) == np.sign(delta)
            and abs(a + b - delta) <= ACCOUNTS_SUM * (abs(a) + abs(b)))


def _sign_sentence(r: Mapping[str, Any], f_c: float) -> tuple[str, bool]:
    """What decides the sign of one variant's Delta, as its control runs measured it; and whether the
    controls account for it (one alone, or two together)."""
    s, d = r["loss_scale"], r["delta"]
    head = f"η×{s:g} ({_pct(d)})"
    if r["definition"] == "seed":
        st, lo = r["storage_control"], r["compliance_control"]
        parts = [f"its storage compliance Re(1/E) ({_pct(r['compliance_change'])} at {f_c:g} Hz) alone gives {_pct(st)}",
                 f"its loss compliance Im(1/E) ({_pct(r['loss_compliance_change'])}) alone gives {_pct(lo)}"]
        found = [name for name, c in (("the storage compliance", st), ("the loss compliance", lo)) if _accounts(c, d)]
        if len(found) == 1:
            verdict, ok = f"{found[0]} decides", True
        elif len(found) == 2:
            verdict, ok = "either alone accounts for it", True
        elif _accounts_sum(st, lo, d):
            verdict, ok = (f"the two nearly cancel and together ({_pct(st + lo)}) account for it; the sign is that of "
                           + ("the storage compliance" if abs(st) > abs(lo) else "the loss compliance")), True
        else:
            verdict, ok = "the controls do not account for it", False
        return f"{head}: {'; '.join(parts)}: {verdict}", ok
    st, sp, la = r["storage_control"], r["springs_control"], r["layer_control"]
    qs_fixed = abs(r["quasi_static_change"]) <= 1e-9
    parts = []
    if not qs_fixed:
        parts.append(f"its relaxed modulus ({_pct(r['quasi_static_change'])}: the element springs) alone gives "
                     + (_pct(sp) if math.isfinite(sp) else "– (no control run)"))
        parts.append("its layer with the reference's springs gives " + (_pct(la) if math.isfinite(la) else
                                                                       "– (no control run)"))
    parts.append(f"E′({f_c:g} Hz) {_pct(r['storage_change'])} alone gives "
                 + (_pct(st) if math.isfinite(st) else "– (no control run)"))
    if qs_fixed:
        ok = bool(np.sign(d) == np.sign(r["storage_change"]))
        text = ("its springs and relaxed modulus are the reference's, only the layer's dynamic modulus differs: "
                + (f"ΔK_sat has the sign of E′({f_c:g} Hz)" if ok else f"yet ΔK_sat has the sign opposite to E′({f_c:g} Hz)"))
        if math.isfinite(st):
            ok = ok and _accounts(st, d)
        return f"{head}: {'; '.join(parts[-1:] if math.isfinite(st) else [])}{'; ' if math.isfinite(st) else ''}{text}", ok
    found = [name for name, c in (("the springs' (relaxed) modulus", sp), ("the layer", la)) if _accounts(c, d)]
    if len(found) == 1:
        text, ok = f"{found[0]} decides", True
    elif len(found) == 2:
        text, ok = "either alone accounts for it", True
    elif _accounts_sum(sp, la, d):
        text, ok = (f"springs and layer together ({_pct(sp + la)}) account for it; the sign is that of "
                    + ("the springs" if abs(sp) > abs(la) else "the layer")), True
    else:
        text, ok = "the controls do not account for it", False
    if math.isfinite(la) and math.isfinite(st):
        text += ("; the layer's own part follows E′ in the band" if _accounts(st, la) else
                 "; the layer's own part is not E′ in the band alone")
    return f"{head}: {'; '.join(parts)}: {text}", bool(ok)


def claim6_rows(ds: xr.Dataset, delta_max: float, delta_min: float) -> list[dict[str, Any]]:
    """The claim-6 table: one row per definition (the seed's; each causal anchor), with its controls.

    Each row: ``definition`` (words), ``quantity``, ``deltas`` {scale: delta}, ``verdict``
    (:func:`tyreroad.report.claims.loss_direction_verdict`), ``checked`` (every variant's Delta is
    accounted for by its controls, :func:`_sign_sentence`), ``default``, ``anchor`` (None: seed) and
    ``sign``: the sentence on what decides the sign, with the control runs' numbers.
    Seed first, then the default anchor, then the others by anchor.
    """
    from .report.claims import loss_direction_verdict

    f_c = float(ds.attrs["frequency"])
    d0 = float(ds.attrs["preload"])
    a = float(ds.attrs["acceleration"])
    records = [{k: (ds[k].values[i].item() if hasattr(ds[k].values[i], "item") else ds[k].values[i])
                for k in ds.data_vars} for i in range(ds.sizes["variant"])]
    groups: dict[Any, list[dict]] = {}
    for r in records:
        if r["definition"] == "seed":
            groups.setdefault("seed", []).append(r)
        elif r["definition"] == "causal":
            groups.setdefault(float(r["loss_anchor"]), []).append(r)
    rows = []
    for key, members in groups.items():
        members = sorted(members, key=lambda r: r["loss_scale"])
        deltas = {float(r["loss_scale"]): float(r["delta"]) for r in members}
        default = any(int(r["default"]) for r in members)
        if key == "seed":
            name = "seed: η scaled at constant \\|E\\| (not causal; frequency domain)"
            quantity = f"ΔK′({f_c:g} Hz; d0 = {d0 * 1e3:g} mm)"
        else:
            kept = "the relaxed modulus (0 Hz)" if key == 0 else f"\\|E({key:g} Hz)\\|"
            name = f"causal: phase scaled, {kept} kept" + (" (default, figure 7)" if default else "")
            quantity = f"ΔK_sat(a = {a:g} m/s²)"
        sentences = [_sign_sentence(r, f_c) for r in members]
        checked = all(ok for _, ok in sentences)
        sign = "; ".join(t for t, _ in sentences) + ". " + ("Checked by run." if checked else "NOT accounted for by the control runs.")
        rows.append({"definition": name, "quantity": quantity, "deltas": deltas,
                     "verdict": loss_direction_verdict(deltas, delta_max, delta_min),
                     "checked": checked, "default": default, "anchor": None if key == "seed" else key, "sign": sign})
    rows.sort(key=lambda r: (r["anchor"] is not None, not r["default"], r["anchor"] or 0.0))
    return rows
