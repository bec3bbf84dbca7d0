r"""Dynamic contact stiffness K*(f; d0) of a patterned tread, beside the slick tread's (issue 27).

The contact stiffness of SPEC 11, K* = 1^T [G_C(f) + diag(1/k_e)]^-1 1 over the contact set C of the relaxed
preload state (:mod:`tyreroad.stiffness`), with G(f) the patterned tread's frequency response:

* **the block's FRF** from the FE cell model in modal form (:class:`tyreroad.fe_pattern.BlockModes`: one
  generalised eigen-decomposition K_1 phi = lambda M phi per symmetry class serves every frequency,
  G(omega) = sum_k P phi_k phi_k^T F / (E(omega) lambda_k - omega^2) + the static residual of the modes left
  out / E(omega)), placed on the patch block by block (:class:`tyreroad.pattern.PatchInfluence`, complex);
* the relaxed preload state on the pattern greens file's static FE table (the pattern's quasi-static runs'
  kernel), with the grooved elements' springs off;
* the slick tread on the same patch and springs: the layer's exact element FRF
  (:class:`tyreroad.greens.ElementFRF`), its relaxed state on the slick static table.

The modal form is checked, not assumed, in every job: against a direct complex solve of the cell at the highest
frequency for three source elements (block centre, edge centre, corner), and at f = 0 against the file's static
table. Both errors are stored; a modal error above :data:`MODAL_TOLERANCE` stops the job, naming the key that
adds modes (``pattern.stiffness_spectrum.n_modes``).
"""

from __future__ import annotations

import logging
import math
import time
from typing import Sequence

import numpy as np
import xarray as xr

from .pattern import (PatchInfluence, PatchLayout, PatternGeometry, groove_springs, kernel_from_pattern_greens,
                      run_inputs)

logger = logging.getLogger(__name__)

__all__ = ["MODAL_TOLERANCE", "BlockResponse", "block_check_sources", "modal_check", "pattern_stiffness_spectrum"]

#: Largest relative error of the modal form against a direct solve at the highest frequency [-].
MODAL_TOLERANCE = 0.02


class BlockResponse:
    """The patterned tread's frequency response as patch influence operators.

    Parameters
    ----------
    layout : tyreroad.pattern.PatchLayout
        The patch on the pattern.
    modes : tyreroad.fe_pattern.BlockModes
        The block's modal form (its cell's density and Poisson's ratio are the material's).
    material : tyreroad.material.Material
        E(omega) [Pa] and the quasi-static modulus [Pa] (f = 0).
    """

    def __init__(self, layout: PatchLayout, modes, material):
        self.layout, self.modes, self.material = layout, modes, material

    def block_table(self, frequency: float) -> np.ndarray:
        """G_b(f) [m/N], shape (N, N): complex, real at f = 0 (the quasi-static modulus)."""
        f = float(frequency)
        if f == 0.0:
            return self.modes.influence(complex(self.material.quasi_static_modulus), 0.0).real
        w = 2.0 * math.pi * f
        return self.modes.influence(self.material.modulus_at(f), w)

    def frequency_influences(self, frequencies, shape, workers: int = 1) -> list[PatchInfluence]:
        """One :class:`~tyreroad.pattern.PatchInfluence` per frequency [Hz] (``shape`` must be the layout's)."""
        if tuple(shape) != tuple(self.layout.shape):
            raise ValueError(f"patch {tuple(shape)} differs from the patch placed on the pattern {self.layout.shape}")
        return [PatchInfluence(self.layout, self.block_table(f)) for f in np.atleast_1d(frequencies)]


def block_check_sources(geometry: PatternGeometry) -> dict[str, int]:
    """The block's centre, edge-centre and corner elements (row-major index i n_y + j)."""
    n_x, n_y = geometry.block_elements
    return {"centre": (n_x // 2) * n_y + n_y // 2, "edge": (n_x // 2) * n_y, "corner": 0}


def modal_check(modes, cell, material, frequency: float, sources: Sequence[int]) -> float:
    """max over the sources' columns of |G_modal - G_direct| / max |G_direct| at ``frequency`` [Hz]."""
    w = 2.0 * math.pi * frequency
    e = material.modulus_at(frequency)
    direct = cell.influence(e, w, np.asarray(sources), modes.field)
    modal = modes.influence(e, w, np.asarray(sources))
    return float(np.max(np.abs(modal - direct)) / np.max(np.abs(direct)))


def pattern_stiffness_spectrum(surface: xr.Dataset, springs: xr.Dataset, pattern_greens: xr.Dataset,
                               slick_greens: xr.Dataset, material, preloads: Sequence[float],
                               frequencies: Sequence[float], settings, n_modes: int, origin=(0.0, 0.0),
                               threads: int = 1) -> xr.Dataset:
    """K*(f; d0) on the patterned tread and on the slick tread of the same patch and springs.

    Parameters
    ----------
    surface, springs : xarray.Dataset
        The pattern study's surface and its element springs for ``material``.
    pattern_greens : xarray.Dataset
        The pattern's greens file (``results/greens/pattern/{pattern}/{material}.nc``, FE static table).
    slick_greens : xarray.Dataset
        The slick tread's static offset table of the same patch (``results/greens/pattern/slick/...``).
    material : tyreroad.material.Material
        The tread.
    preloads : sequence of float
        d0 [m], increasing.
    frequencies : sequence of float
        f > 0 [Hz].
    settings : tyreroad.solver.SolverSettings
        The preload solve (indentation step, tolerance).
    n_modes : int
        Modes per symmetry class of the block's modal form.
    origin : (float, float)
        The patch corner in pattern coordinates [m].
    threads : int
        Workers of the slick FRF.

    Returns
    -------
    xarray.Dataset
        ``k_storage``, ``k_loss`` (case, preload, frequency) [N/m], ``k_relaxed`` and ``contact_count``
        (case, preload), the block's lowest natural frequencies per symmetry class, the modal check's errors.

    Raises
    ------
    ValueError
        When the modal form misses the direct solve by more than :data:`MODAL_TOLERANCE`.
    """
    from .contact import preload_states
    from .fe_pattern import BlockCell, BlockMesh, BlockModes
    from .greens import ElementFRF
    from .pattern_stage import tread_pattern
    from .stiffness import _contact_set_spectrum

    t0 = time.perf_counter()
    if str(pattern_greens.attrs.get("influence_model")) != "fe":
        raise ValueError(f"pattern {pattern_greens.attrs.get('pattern')!r}: K*(f) needs the FE block table "
                         f"(pattern.influence: fe), got {pattern_greens.attrs.get('influence_model')!r}")
    freq = np.asarray(frequencies, dtype=float)
    if freq.ndim != 1 or freq.size == 0 or np.any(freq <= 0) or np.any(np.diff(freq) <= 0):
        raise ValueError(f"frequencies: expected increasing values > 0 [Hz], got {freq}")
    z1, pattern_kernel, table = run_inputs(surface, springs, pattern_greens, origin)
    shape = z1.shape
    slick_kernel = kernel_from_pattern_greens(slick_greens, shape)
    layout = pattern_kernel.layout
    geometry = layout.geometry
    grooved_table = groove_springs(table, layout.grooved)

    cell = BlockCell(tread_pattern(geometry), material.thickness, material.poisson, material.density, BlockMesh())
    modes = BlockModes(cell, int(n_modes))
    t_modes = time.perf_counter() - t0
    sources = block_check_sources(geometry)
    modal_error = modal_check(modes, cell, material, float(freq[-1]), list(sources.values()))
    static_file = pattern_greens["influence"].transpose("element", "source").values
    static_modal = modes.influence(complex(material.quasi_static_modulus), 0.0).real
    static_error = float(np.max(np.abs(static_modal - static_file)) / np.max(np.abs(static_file)))
    natural = modes.frequencies(material)
    logger.info("pattern %s: %d modes per class in %.1f s; modal form against a direct solve at %.4g Hz: %.2e "
                "(limit %.0e); static: %.1e; lowest natural frequencies %s Hz", geometry.name, n_modes, t_modes,
                freq[-1], modal_error, MODAL_TOLERANCE, static_error,
                ", ".join(f"{c}: {v[0]:.0f}" for c, v in natural.items()))
    if not modal_error <= MODAL_TOLERANCE:
        raise ValueError(f"pattern {geometry.name!r}: the modal form with {n_modes} modes per class misses the direct "
                         f"solve at {freq[-1]:g} Hz by {modal_error:.2%} (limit {MODAL_TOLERANCE:.0%}); raise "
                         "pattern.stiffness_spectrum.n_modes or lower f_max")

    all_f = np.concatenate([[0.0], freq])
    cases = {}
    pattern_states = preload_states(z1, grooved_table, pattern_kernel, preloads, settings, threads)
    response = BlockResponse(layout, modes, material)
    values = np.array([[op.stiffness(pattern_states.spring_stiffness[p].ravel()) for op in
                        response.frequency_influences(all_f, shape)] for p in range(len(preloads))])
    cases[geometry.name] = (pattern_states, values)
    slick_states = preload_states(z1, table, slick_kernel, preloads, settings, threads)
    frf = ElementFRF(material, float(slick_greens.attrs["element_size"]))
    slick_values, _ = _contact_set_spectrum(slick_states, frf.frequency_influences(all_f, shape, threads), "dense",
                                            None)
    cases["slick"] = (slick_states, slick_values)
    names = list(cases)
    k = np.array([cases[c][1] for c in names])  # (case, preload, 1 + frequency)
    elapsed = time.perf_counter() - t0
    for c in names:
        states = cases[c][0]
        logger.info("%s: d0 %s mm, contact %s, K*(f -> 0) / K_qs - 1 = %s", c,
                    ", ".join(f"{d * 1e3:.3g}" for d in states.preload), [int(n) for n in states.contact_count],
                    ", ".join(f"{v:.1e}" for v in cases[c][1][:, 0].real / states.tangent_stiffness - 1))

    # class (a, b): the mode's parity about the block's x and y mid-planes (+1 even, -1 odd)
    classes = [f"{'even' if a > 0 else 'odd'}-x {'even' if b > 0 else 'odd'}-y" for a, b in natural]
    n_nat = min(len(v) for v in natural.values())
    n_keep = min(n_nat, 8)

    def var(dims, values, units, long_name):
        return dims, values, {"units": units, "long_name": long_name}

    ds = xr.Dataset(
        {
            "k_storage": var(("case", "preload", "frequency"), k[:, :, 1:].real, "N/m", "storage stiffness K' = Re K*"),
            "k_loss": var(("case", "preload", "frequency"), k[:, :, 1:].imag, "N/m", "loss stiffness K'' = Im K*"),
            "k_relaxed": var(("case", "preload"), k[:, :, 0].real, "N/m", "K*(f -> 0) (quasi-static modulus)"),
            "tangent_stiffness": var(("case", "preload"), np.array([cases[c][0].tangent_stiffness for c in names]),
                                     "N/m", "quasi-static tangent dF/dd of the relaxed preload state"),
            "contact_count": var(("case", "preload"), np.array([cases[c][0].contact_count for c in names]), "1",
                                 "elements in contact in the relaxed preload state"),
            "natural_frequency": var(("symmetry_class", "mode"), np.array([natural[c][:n_keep] for c in natural]),
                                     "Hz", "block natural frequencies sqrt(Re E(f) lambda) / 2 pi (undamped)"),
        },
        coords={
            "case": ("case", names, {"long_name": "pattern preset, or slick"}),
            "preload": ("preload", np.asarray(preloads, dtype=float), {"units": "m", "long_name": "preload d0"}),
            "frequency": ("frequency", freq, {"units": "Hz", "long_name": "frequency"}),
            "symmetry_class": ("symmetry_class", classes, {"long_name": "symmetry of the block mode about its "
                                                                         "mid-planes"}),
            "mode": ("mode", np.arange(n_keep), {"units": "1", "long_name": "mode number within the class"}),
        },
        attrs={
            "material": material.name, "pattern": geometry.name, "element_size": geometry.element_size,
            "n_modes": int(n_modes), "modal_error": modal_error, "modal_check_frequency": float(freq[-1]),
            "modal_check_sources": ", ".join(f"{k} {v}" for k, v in sources.items()),
            "modal_tolerance": MODAL_TOLERANCE, "modal_static_error": static_error,
            "modes_time_s": t_modes, "compute_time_s": elapsed,
            "method": ("K* = 1^T [G_C(f) + diag(1/k_e)]^-1 1 about the relaxed preload state; pattern: the block's FE "
                       "FRF in modal form on the patch, block by block; slick: the layer's element FRF"),
        },
    )
    return ds
