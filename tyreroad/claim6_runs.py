"""The measurements of claim 6's stage (rule ``claim6``, :mod:`tyreroad.claim6`): K*(f_c; d0) of the seed
variants and their frequency-domain controls about the reference's relaxed preload state, and K_sat of
dynamic contact runs computed exactly as the study does. Kept apart from :mod:`tyreroad.claim6` so that the
report (which reads claim 6's table) does not depend on the solver's code.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr

logger = logging.getLogger(__name__)

__all__ = ["seed_storage_stiffness", "seed_controls", "saturated_stiffness_of_runs"]


def seed_storage_stiffness(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, materials: Sequence,
                           frequency: float, preload: float, solver_settings, threads: int = 1,
                           same_relaxed_state: bool = True) -> dict[str, complex]:
    """K*(f_c; d0) about the reference's relaxed preload state, frequency domain only, per material [N/m].

    The relaxed state is the one of the greens file's static kernel and the springs given (the
    reference's); only the element FRF G(f_c) is each material's. Right for the reference and the seed's
    variants, whose relaxed modulus is the reference's (checked unless ``same_relaxed_state`` is False:
    the frequency-domain controls keep the reference's state on purpose and change G(f_c) only).
    """
    from .greens import ElementFRF
    from .kernel import LayerKernel
    from .springs import SpringTable
    from .stiffness import SpectrumSettings, stiffness_spectrum

    spectrum = SpectrumSettings(preloads=(float(preload),), f_min=float(frequency), n_frequencies=2,
                                report_frequencies=(float(frequency),), figure_preload=float(preload))
    z1 = surface["z1"].transpose("ex", "ey").values
    table = SpringTable.from_dataset(springs)
    e_static = float(greens.attrs.get("quasi_static_modulus", math.nan))
    out = {}
    for mat in materials:
        if same_relaxed_state and math.isfinite(e_static) and not math.isclose(mat.quasi_static_modulus, e_static,
                                                                                rel_tol=1e-9):
            raise ValueError(f"material {mat.name!r}: its quasi-static modulus {mat.quasi_static_modulus:.6g} Pa differs "
                             f"from the static kernel's ({e_static:.6g} Pa): its relaxed state is not the reference's")
        relaxed = LayerKernel.from_greens(greens, "quasistatic", mat)
        ds = stiffness_spectrum(z1, table, relaxed, ElementFRF(mat, relaxed.element_size), mat, relaxed.sample_rate,
                                spectrum, solver_settings, threads)
        sel = ds.sel(frequency=float(frequency), method="nearest").isel(preload=0)
        out[mat.name] = complex(float(sel["storage_stiffness"]), float(sel["loss_stiffness"]))
        logger.info("claim 6, K*(%g Hz; d0 = %g mm) of %s: K' = %.6g N/m, K'' = %.6g N/m", frequency, preload * 1e3,
                    mat.name, out[mat.name].real, out[mat.name].imag)
    return out


@dataclass(frozen=True)
class _ComplianceMix:
    """A frequency-axis modulus whose compliance 1/E has the real part of one model and the imaginary part
    of another (frequency-domain controls only: it is not causal and has no laplace_modulus)."""

    real_from: Any
    imag_from: Any

    def modulus(self, omega):
        c_re = (1.0 / self.real_from.modulus(omega)).real
        c_im = (1.0 / self.imag_from.modulus(omega)).imag
        return 1.0 / (c_re + 1j * c_im)


def seed_controls(reference, seed) -> dict[str, Any]:
    """The two frequency-domain controls of a seed variant, each changing one part of the layer's compliance.

    ``storage``: compliance 1/E with the seed's real part (storage compliance) and the reference's imaginary
    part (loss compliance); ``loss``: the other way round. At constant |E| a lower eta raises the storage
    compliance Re(1/E) = cos(phi)/|E| and lowers the loss compliance |Im(1/E)| = sin(phi)/|E|; K' of the
    contact (springs in series with the layer) falls with the first and rises as the second falls, so the
    two controls measure which one sets the sign.

    Returns
    -------
    dict
        ``{"storage": Material, "loss": Material}`` named ``<seed>-storage-control`` and ``<seed>-loss-control``.
    """
    import dataclasses

    return {
        kind: dataclasses.replace(reference, name=f"{seed.name}-{kind}-control", model=_ComplianceMix(*pair),
                                  loss_scale=1.0, loss_anchor=None, modulus_scale=1.0)
        for kind, pair in (("storage", (seed, reference)), ("loss", (reference, seed)))
    }


def saturated_stiffness_of_runs(contacts: Sequence, study_cfg: Mapping[str, Any], d_max: float) -> dict[str, float]:
    """K_sat [N/m] of dynamic contact runs (one per material), computed exactly as the study does."""
    from . import io
    from .study import StudySettings, case_on_grid, native_samples, saturated_stiffness

    datasets = [io.read_dataset(p) if not isinstance(p, xr.Dataset) else p for p in contacts]
    names = [str(ds.attrs["material"]) for ds in datasets]
    cfg = {k: v for k, v in study_cfg.items() if k not in ("claim6", "loadings")}
    cfg["materials"] = list(dict.fromkeys(names + [study_cfg["reference_material"]]))
    settings = StudySettings.from_config(cfg, d_max=d_max)
    out = {}
    for i, ds in enumerate(datasets):
        run = native_samples(ds, str(contacts[i]), settings)
        k = case_on_grid(run, settings)["stiffness"]
        out[names[i]] = saturated_stiffness(settings.grid, k, settings.saturation_range)
    return out
