"""The pattern greens stage (issue 27): the block influence table of a pattern and material, and the slick
tread's static offset table over the same patch (``results/greens/pattern/{pattern}/{material}.nc``).

Kept apart from :mod:`tyreroad.pattern` so that the pattern contact runs, which read these files, do not depend
on the greens code (a change of the element Green's functions re-runs this stage, and the runs through its
files). ``pattern.influence`` picks the block table: ``fe`` (default), the FE cell model
(:func:`tyreroad.fe_pattern.block_static_influence`), or ``standin``, the flat layer's kernel restricted to the block
(no edge effect: what the FE table changes against it is the edge softening).
"""

from __future__ import annotations

import logging
import time

import numpy as np
import xarray as xr

from .pattern import PATTERN_INFLUENCES, SLICK, PatternGeometry

logger = logging.getLogger(__name__)

__all__ = ["tread_pattern", "fe_block_influence", "standin_block_influence", "pattern_greens_dataset", "slick_greens_dataset"]


def _static_offset_table(shape, element_size: float, material) -> np.ndarray:
    """g_static[dx, dy] [m/N] of the flat layer for offsets -(nx-1) ... nx-1, -(ny-1) ... ny-1."""
    from .greens import offset_table_index, static_element_kernel, unique_offsets

    uniq = unique_offsets(shape)
    values = static_element_kernel(uniq * element_size, element_size, material.quasi_static_modulus,
                                   material.poisson, material.thickness)
    _, _, index = offset_table_index(shape)
    return values[index]


def standin_block_influence(pattern: PatternGeometry, material) -> tuple[np.ndarray, np.ndarray]:
    """The stand-in for ``tyreroad.fe_pattern.block_static_influence``: the flat layer's static element kernel
    restricted to one block's elements (a block with no edge effect), same call shape and return.

    Parameters
    ----------
    pattern : PatternGeometry
        The pattern (its block size and element size).
    material : tyreroad.material.Material
        The tread (quasi-static modulus, Poisson's ratio, thickness).

    Returns
    -------
    element_centres_xy : numpy.ndarray
        Centres [m] of the block's N elements, row-major over x then y, shape (N, 2).
    G : numpy.ndarray
        G[i, j] = g_static(x_i - x_j, y_i - y_j) [m/N], shape (N, N).
    """
    from .influence import offset_matrix

    table = _static_offset_table(pattern.block_elements, pattern.element_size, material)
    return pattern.element_centres(), offset_matrix(table)


def tread_pattern(geometry: PatternGeometry):
    """The FE cell model's geometry (:class:`tyreroad.fe_pattern.TreadPattern`) of a pattern preset.

    Kept here, not as a method of :class:`~tyreroad.pattern.PatternGeometry`: the contact runs import
    :mod:`tyreroad.pattern`, and must not depend on the FE code (a change there would re-run them).
    """
    from .fe_pattern import TreadPattern

    return TreadPattern(geometry.block_length, geometry.block_width, geometry.groove_width, geometry.groove_depth,
                        geometry.element_size)


def fe_block_influence(pattern: PatternGeometry, material) -> tuple[np.ndarray, np.ndarray, str]:
    """The block's static influence from the FE cell model (:func:`tyreroad.fe_pattern.block_static_influence`,
    its default mesh), with a note on the model for the file.

    Returns
    -------
    element_centres_xy : numpy.ndarray
        Centres [m] of the block's N elements, row-major over x then y, shape (N, 2).
    G : numpy.ndarray
        G[i, j] [m/N]: displacement at the centre of element i per unit force spread over element j, shape (N, N).
    note : str
        What the table is (model, mesh, boundary conditions).
    """
    from .fe_pattern import BlockMesh, block_static_influence

    mesh = BlockMesh()
    geometry = tread_pattern(pattern)
    xy, g = block_static_influence(geometry, material, mesh)
    asym = float(np.max(np.abs(g - g.T)) / np.max(np.abs(g)))
    note = (f"FE cell model (tyreroad.fe_pattern): one block on the rigid belt, {mesh.per_element} x {mesh.per_element} "
            f"{mesh.element} hexahedra per surface element, grooves {'to the belt' if not geometry.has_undertread(material.thickness) else 'over an undertread, periodic cell'}; "
            f"displacement at element centres (greens' convention), so G is reciprocal only to {asym:.1e} of max|G|")
    return xy, g, note


def pattern_greens_dataset(pattern: PatternGeometry, material, influence: str = "standin") -> xr.Dataset:
    """The block influence table of one pattern and material (``results/greens/pattern/{pattern}/{material}.nc``).

    Variables ``influence`` (element, source) [m/N], coordinates ``x``, ``y`` of the element centres [m]; the
    geometry, the memory of the table (``influence_bytes``) and the compute time (``compute_time_s``) as
    attributes.
    """
    if influence not in PATTERN_INFLUENCES:
        raise ValueError(f"pattern.influence = {influence!r}: expected one of {PATTERN_INFLUENCES}")
    start = time.perf_counter()
    if influence == "fe":
        xy, g, note = fe_block_influence(pattern, material)
    else:
        xy, g = standin_block_influence(pattern, material)
        note = ("stand-in: the flat layer's static element kernel restricted to the block's elements (no edge "
                "effect, the coupling between blocks cut); for comparison with the FE cell model")
    elapsed = time.perf_counter() - start
    n = g.shape[0]
    logger.info("pattern %s, material %s: block of %d x %d elements, influence table %d x %d (%.3g MB) in %.3g s",
                pattern.name, material.name, *pattern.block_elements, n, n, 8e-6 * n * n, elapsed)
    el = {"units": "1", "long_name": "element index in the block (row-major over x then y)"}
    ds = xr.Dataset(
        {"influence": (("element", "source"), g, {"units": "m/N", "long_name": "static displacement at the element "
                       "centre per unit force spread over the source element (block influence G_b)"})},
        coords={"element": ("element", np.arange(n), el), "source": ("source", np.arange(n), dict(el)),
                "x": ("element", xy[:, 0], {"units": "m", "long_name": "element centre x from the block corner"}),
                "y": ("element", xy[:, 1], {"units": "m", "long_name": "element centre y from the block corner"})},
        attrs={"pattern": pattern.name, "kind": "pattern", "influence_model": influence,
               "influence_note": note,
               "material": material.name, "element_size": pattern.element_size,
               "block_elements": np.asarray(pattern.block_elements, dtype=np.int64),
               "block_length": pattern.block_length, "block_width": pattern.block_width,
               "groove_width": pattern.groove_width, "groove_depth": pattern.groove_depth,
               "influence_bytes": np.int64(8 * n * n),
               "memory_note": "one N x N table for every block of the patch (block diagonal): memory independent of "
                              "the number of blocks",
               "compute_time_s": elapsed},
    )
    return ds


def slick_greens_dataset(shape, element_size: float, material) -> xr.Dataset:
    """The slick tread's static offset table g_static[dx, dy] [m/N] over a patch of ``shape`` (the reference of the
    pattern study; translation invariant: (2 nx - 1)(2 ny - 1) values)."""
    start = time.perf_counter()
    table = _static_offset_table(tuple(shape), float(element_size), material)
    elapsed = time.perf_counter() - start
    nx, ny = (table.shape[0] + 1) // 2, (table.shape[1] + 1) // 2
    return xr.Dataset(
        {"g_static": (("dx", "dy"), table, {"units": "m/N", "long_name": "quasi-static element Green's function"})},
        coords={"dx": ("dx", np.arange(-(nx - 1), nx), {"units": "1", "long_name": "element offset along x"}),
                "dy": ("dy", np.arange(-(ny - 1), ny), {"units": "1", "long_name": "element offset along y"})},
        attrs={"pattern": SLICK, "kind": "slick", "material": material.name, "element_size": float(element_size),
               "influence_bytes": np.int64(table.nbytes), "compute_time_s": elapsed},
    )


def pattern_modes_dataset(pattern: PatternGeometry, material, n_modes: int, check_frequency: float,
                          tolerance: float = 0.02) -> xr.Dataset:
    """The block's modal form for dynamic runs (``results/greens/pattern/{pattern}/modes.nc``).

    :class:`tyreroad.pattern_dynamic.BlockModalForm` of the FE cell model (its default mesh, the element-mean
    field) with ``n_modes`` modes per symmetry class, for the material's thickness, Poisson's ratio and density
    (the density only scales the eigenvalues: :meth:`~tyreroad.pattern_dynamic.BlockModalForm.with_density`
    serves every material of the same thickness and Poisson's ratio). Checked against a direct complex FE solve at
    ``check_frequency`` [Hz] for the block's centre, edge-centre and corner elements; refused above ``tolerance``.
    """
    from .fe_pattern import BlockCell, BlockMesh, BlockModes
    from .pattern_dynamic import DYNAMIC_FIELD, BlockModalForm
    from .pattern_spectrum import block_check_sources, modal_check

    start = time.perf_counter()
    cell = BlockCell(tread_pattern(pattern), material.thickness, material.poisson, material.density, BlockMesh())
    modes = BlockModes(cell, int(n_modes), field=DYNAMIC_FIELD)
    form = BlockModalForm.from_modes(modes)
    t_modes = time.perf_counter() - start
    logger.info("pattern %s: %d modes in %.1f s; direct complex solve at %.4g Hz for the check ...", pattern.name,
                form.n_modes, t_modes, check_frequency)
    # the K* stage's check of the same modal truncation (the form is the modes unfolded, to 1e-12)
    error = modal_check(modes, cell, material, float(check_frequency), list(block_check_sources(pattern).values()))
    natural = form.natural_frequencies(material)
    elapsed = time.perf_counter() - start
    logger.info("pattern %s: modal form against the direct solve at %.4g Hz: %.2e (limit %.0e); lowest natural "
                "frequencies %s Hz; %.1f s", pattern.name, check_frequency, error, tolerance,
                ", ".join(f"{f:.0f}" for f in natural[:4]), elapsed)
    if not error <= tolerance:
        raise ValueError(f"pattern {pattern.name!r}: the modal form with {n_modes} modes per class misses the direct "
                         f"solve at {check_frequency:g} Hz by {error:.2%} (limit {tolerance:.0%}); raise "
                         "pattern.dynamic.n_modes or lower pattern.dynamic.check_frequency")
    ds = form.to_dataset()
    ds = ds.assign_coords(natural_frequency=("mode", np.sort(natural)))
    ds["natural_frequency"].attrs.update({"units": "Hz", "long_name": "undamped natural frequency at Re E(f), ascending"})
    ds.attrs.update({"pattern": pattern.name, "kind": "pattern-modes", "material": material.name,
                     "thickness": float(material.thickness), "poisson": float(material.poisson),
                     "element_size": pattern.element_size,
                     "block_length": pattern.block_length, "block_width": pattern.block_width,
                     "groove_width": pattern.groove_width, "groove_depth": pattern.groove_depth,
                     "modes_per_class": int(n_modes), "check_frequency": float(check_frequency),
                     "modal_error": error, "modal_tolerance": float(tolerance), "modes_time_s": t_modes,
                     "compute_time_s": elapsed,
                     "modal_bytes": np.int64(8 * (form.psi.size + 2 * form.static.size))})
    return ds
