r"""A compound from a DMA master curve: fit, check and a preset block for the config (``tyreroad material``).

The table (f, E', eta) at the reference temperature T_ref becomes a ``table`` material preset
(:mod:`tyreroad.material`): a causal generalised Maxwell fit, shifted to each study temperature T by
E(f; T) = E_ref(f a_T). :func:`check_compound` builds that preset exactly as a pipeline run would
(:func:`tyreroad.material.material_from_config`, so that a table the config would refuse is refused here with
the same message) and reports:

* the fit: max and rms relative error |E_fit - E| / |E| of the joint E', E'' fit (the config's
  ``fit_tolerance`` bounds the max);
* causality, by Kramers-Kronig (:func:`kramers_kronig_storage`): the storage modulus the table's own loss
  implies, E'_KK(f) = E_r + sum_k E_k (w tau_k)^2 / (1 + (w tau_k)^2) from a generalised Maxwell model fitted
  to E'' alone, against the table's E'. Kramers-Kronig fixes E' from E'' up to one constant (the relaxed
  modulus E_r, fitted as the least-squares offset), so the deviation measures how far the table's E' and
  eta are from one causal material -- unlike the joint fit's residual, which a non-causal table can keep
  small by trading E' against E''. The loss outside the table's range is the fit's extrapolation (its
  relaxation times reach a decade beyond the data), which leaves a deviation of order 1e-3 at the ends
  for a causal table;
* the shift factor a_T and E', eta at 1 kHz at each study temperature.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

from .material import (
    expand_temperatures,
    fit_generalized_maxwell,
    material_from_config,
    path_safe,
    read_dma_table,
    relaxation_time_grid,
    scaled_nnls,
    temperature_variant_name,
)

__all__ = ["CompoundCheck", "kramers_kronig_storage", "check_compound", "preset_block", "default_name"]

#: Frequency [Hz] at which the summary states E' and eta per temperature.
SUMMARY_FREQUENCY = 1000.0


def kramers_kronig_storage(frequency, storage_modulus, loss_factor, terms_per_decade: int = 10):
    """E'(f) [Pa] that the table's loss modulus E'' implies through Kramers-Kronig, and its deviation.

    A generalised Maxwell model is fitted to E'' = eta E' alone (non-negative least squares, relative
    weights, relaxation times log-spaced as in :func:`tyreroad.material.fit_generalized_maxwell`); its
    storage modulus E'_KK = E_r + sum_k E_k (w tau_k)^2 / (1 + (w tau_k)^2) is the causal partner of that
    loss. The constant E_r (the relaxed modulus, which Kramers-Kronig leaves free) is the least-squares
    offset against the table's E' in relative terms.

    Parameters
    ----------
    frequency : array_like
        f [Hz], strictly increasing.
    storage_modulus : array_like
        E'(f) [Pa].
    loss_factor : array_like
        eta(f) [-].
    terms_per_decade : int
        Relaxation times per decade.

    Returns
    -------
    storage_kk : numpy.ndarray
        E'_KK(f) [Pa] at the table's frequencies.
    max_deviation : float
        max |E'_KK - E'| / E' [-].
    relaxed_modulus : float
        E_r [Pa] (negative: no causal material has this loss and this storage modulus).
    """
    f = np.asarray(frequency, dtype=float)
    e1 = np.asarray(storage_modulus, dtype=float)
    e2 = e1 * np.asarray(loss_factor, dtype=float)
    tau = relaxation_time_grid(f, terms_per_decade)
    wt = 2.0 * np.pi * f[:, None] * tau[None, :]
    weight = 1.0 / np.hypot(e1, e2)
    coef = scaled_nnls(wt / (1.0 + wt**2) * weight[:, None], e2 * weight)
    rise = (wt**2 / (1.0 + wt**2)) @ coef
    w_rel = 1.0 / e1**2
    relaxed = float(np.sum((e1 - rise) * w_rel) / np.sum(w_rel))
    storage_kk = relaxed + rise
    return storage_kk, float(np.max(np.abs(storage_kk - e1) / e1)), relaxed


@dataclass(frozen=True)
class CompoundCheck:
    """What :func:`check_compound` found.

    Attributes
    ----------
    name : str
        Preset name.
    preset : dict
        The ``materials.<name>`` block (data by ``table_file``).
    n_points : int
        Table rows.
    frequency_range : tuple of float
        Lowest and highest frequency of the table [Hz].
    fit_max_error, fit_rms_error : float
        Relative error of the causal fit, max and rms [-].
    n_terms : int
        Maxwell terms of the fit.
    kk_max_deviation : float
        max |E'_KK - E'| / E' [-] (:func:`kramers_kronig_storage`).
    kk_inner_deviation : float
        The same without the outermost decade at each end of the table [-] (nan for a table of less
        than two decades): the ends see the unknown loss beyond the data.
    kk_relaxed_modulus : float
        E_r of the Kramers-Kronig reconstruction [Pa].
    relaxed_modulus : float
        The relaxed (quasi-static) modulus the pipeline will use [Pa].
    temperatures : list of dict
        Per study temperature (the reference first): ``name``, ``temperature`` [degC], ``shift_factor``
        a_T [-], ``storage_modulus`` E'(1 kHz) [Pa], ``loss_factor`` eta(1 kHz) [-].
    """

    name: str
    preset: dict
    n_points: int
    frequency_range: tuple
    fit_max_error: float
    fit_rms_error: float
    n_terms: int
    kk_max_deviation: float
    kk_inner_deviation: float
    kk_relaxed_modulus: float
    relaxed_modulus: float
    temperatures: list

    def summary(self) -> str:
        """The check as YAML comment lines (``# ...``), to sit above :func:`preset_block` in a config."""
        lines = [
            f"material {self.name}: {self.n_points} points, {self.frequency_range[0]:.4g} - "
            f"{self.frequency_range[1]:.4g} Hz"
            + (f" at {self.preset['reference_temperature']:g} degC" if "reference_temperature" in self.preset
               else " (no reference temperature: not shifted)"),
            f"causal fit (generalised Maxwell, {self.n_terms} terms): relative error max {self.fit_max_error:.3g}, "
            f"rms {self.fit_rms_error:.3g} (fit_tolerance {self.preset.get('fit_tolerance', 0.02):g})",
            f"Kramers-Kronig: E' implied by the table's loss deviates from its E' by at most "
            f"{self.kk_max_deviation:.3g}, {self.kk_inner_deviation:.3g} a decade inside the ends "
            f"(relaxed modulus {self.kk_relaxed_modulus:.4g} Pa; a causal table: ~1e-4 inside)",
            f"relaxed (quasi-static) modulus: {self.relaxed_modulus:.4g} Pa"
            + (" (given)" if self.preset.get("quasi_static_modulus", "zero_frequency") != "zero_frequency"
               else " (extrapolated below the table: give quasi_static_modulus from data)"),
        ]
        for t in self.temperatures:
            lines.append(
                f"{t['name']}: T = {t['temperature']:g} degC, a_T = {t['shift_factor']:.6g}, "
                f"E'({SUMMARY_FREQUENCY:g} Hz) = {t['storage_modulus']:.4g} Pa, eta = {t['loss_factor']:.4g}"
            )
        return "\n".join("# " + line for line in lines)


def default_name(path) -> str:
    """A path-safe preset name from a table file's stem ('_' and other characters -> '-')."""
    stem = "".join(c if c.isalnum() or c in ".-" else "-" for c in Path(path).stem).strip("-.") or "compound"
    return stem if path_safe(stem) else "compound-" + stem


def check_compound(
    table_file: str | Path,
    *,
    name: str | None = None,
    reference_temperature: float | None = None,
    shift: Mapping[str, Any] | None = None,
    temperatures: Sequence[float] = (),
    quasi_static_modulus: float | None = None,
    fit_tolerance: float | None = None,
    poisson_ratio: float = 0.49,
    density: float = 1100.0,
    thickness: float = 0.01,
) -> CompoundCheck:
    """Fit and check a compound given as a DMA master curve in a CSV file.

    Parameters
    ----------
    table_file : path-like
        CSV file (:func:`tyreroad.material.read_dma_table`), as it will be named in the config (relative
        to the working directory).
    name : str, optional
        Preset name; default :func:`default_name` of the file.
    reference_temperature : float, optional
        T_ref [degC] of the master curve; needed with ``shift``.
    shift : Mapping, optional
        ``{model: wlf, C1, C2}`` or ``{model: arrhenius, activation_energy}`` (:func:`tyreroad.material.shift_factor`).
    temperatures : sequence of float
        Study temperatures [degC] (each becomes the variant ``<name>-T<T>``).
    quasi_static_modulus : float, optional
        Relaxed modulus from data [Pa]; default: the fit's extrapolation (with the pipeline's warning).
    fit_tolerance : float, optional
        Largest allowed relative fit error [-] (default the pipeline's, 0.02).
    poisson_ratio, density, thickness : float
        nu [-], rho [kg/m^3], h [m] of the tread layer.

    Returns
    -------
    CompoundCheck

    Raises
    ------
    ValueError, FileNotFoundError
        As the config would: naming ``materials.<name>.<key>`` (a poor fit, a singular WLF shift, a
        temperature without a shift, a missing file, ...).
    """
    name = name or default_name(table_file)
    preset: dict[str, Any] = {"model": "table", "table_file": str(table_file)}
    if reference_temperature is not None:
        preset["reference_temperature"] = float(reference_temperature)
    if shift is not None:
        preset["shift"] = dict(shift)
    temps = [float(t) for t in temperatures]
    if temps:
        preset["temperatures"] = temps
    if fit_tolerance is not None:
        preset["fit_tolerance"] = float(fit_tolerance)
    preset["quasi_static_modulus"] = "zero_frequency" if quasi_static_modulus is None else float(quasi_static_modulus)
    preset.update(poisson_ratio=float(poisson_ratio), density=float(density), thickness=float(thickness))

    section = expand_temperatures({name: preset})
    reference = material_from_config(name, section)  # the pipeline's checks and fit
    f, e1, eta = read_dma_table(table_file)
    _, err_max, err_rms = fit_generalized_maxwell(f, e1, eta)
    kk, kk_dev, kk_relaxed = kramers_kronig_storage(f, e1, eta)
    fa, e1a = np.asarray(f), np.asarray(e1)
    inner = (fa >= 10.0 * fa[0]) & (fa <= fa[-1] / 10.0)  # the loss beyond the ends is unknown to Kramers-Kronig
    kk_inner = float(np.max(np.abs(kk[inner] - e1a[inner]) / e1a[inner])) if inner.any() else math.nan
    w = 2.0 * np.pi * SUMMARY_FREQUENCY
    rows = []
    for variant in [name] + [temperature_variant_name(name, t) for t in temps]:
        m = reference if variant == name else material_from_config(variant, section)
        e = complex(m.modulus(w))
        rows.append({
            "name": variant,
            "temperature": m.temperature if m.temperature is not None else math.nan,
            "shift_factor": m.shift_factor,
            "storage_modulus": e.real,
            "loss_factor": e.imag / e.real,
        })
    return CompoundCheck(
        name=name,
        preset=preset,
        n_points=len(f),
        frequency_range=(f[0], f[-1]),
        fit_max_error=err_max,
        fit_rms_error=err_rms,
        n_terms=len(reference.model.moduli),
        kk_max_deviation=kk_dev,
        kk_inner_deviation=kk_inner,
        kk_relaxed_modulus=kk_relaxed,
        relaxed_modulus=reference.quasi_static_modulus,
        temperatures=rows,
    )


def preset_block(check: CompoundCheck) -> str:
    """The ``materials:`` block of the compound, ready to paste into a config overlay (YAML text)."""
    body = yaml.safe_dump({"materials": {check.name: check.preset}}, sort_keys=False, default_flow_style=None)
    names = [t["name"] for t in check.temperatures]
    study = f"# list in study.materials: [{', '.join(names)}]\n"
    return check.summary() + "\n" + study + body
