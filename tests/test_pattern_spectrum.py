"""K*(f; d0) of a patterned tread (tyreroad.pattern_spectrum): the modal FE block FRF on the patch, checked
against a direct FE solve and a dense contact-set solve, the f -> 0 limit, passivity and the block's rocking mode."""

from __future__ import annotations

import math

import numpy as np
import pytest

from test_pattern import C, stage_datasets
from tyreroad import io, pipeline
from tyreroad.config import load_config
from tyreroad.fe_pattern import BlockCell, BlockMesh
from tyreroad.material import material_from_config
from tyreroad.pattern import kernel_from_pattern_greens
from tyreroad.pattern_spectrum import pattern_stiffness_spectrum
from tyreroad.pattern_stage import tread_pattern
from tyreroad.solver import SolverSettings

PRESET = {"block_length": 0.004, "block_width": 0.003, "groove_width": 0.001, "groove_depth": 0.01}
ORIGIN = (1e-3, 0.0)
FREQ = [10.0, 100.0, 1000.0, 3000.0, 5000.0]


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pattern_spectrum")
    cfg = load_config("config/config.yaml")
    nx, ny = 12, 9
    surface, springs, table = stage_datasets(nx, ny)
    greens = {}
    for name, preset in (("b4", PRESET), ("slick", None)):
        path = tmp / f"{name}.nc"
        pipeline.run_pattern_greens(name, preset, "fe", "tread", cfg["materials"]["tread"], C, [nx, ny], path)
        greens[name] = io.read_dataset(path)
    material = material_from_config("tread", cfg["materials"])
    settings = SolverSettings(d_max=2.5e-4, quasistatic_step=1e-5, method="dense")
    ds = pattern_stiffness_spectrum(surface, springs, greens["b4"], greens["slick"], material, [1e-4], FREQ,
                                    settings, 20, origin=ORIGIN)
    return ds, surface, table, greens, material, settings


def test_relaxed_limit_is_the_quasistatic_tangent_and_modal_form_is_checked(case):
    ds = case[0]
    np.testing.assert_allclose(ds["k_relaxed"].values, ds["tangent_stiffness"].values, rtol=1e-9)
    assert ds.attrs["modal_error"] < 2e-3  # measured 4.3e-4 at 5 kHz with 20 modes per class
    assert ds.attrs["modal_static_error"] < 1e-9


def test_passive_and_stiffening_with_frequency(case):
    ds = case[0]
    assert np.all(ds["k_loss"].values > 0)
    # the tread stiffens with frequency (E' rises): K'(1 kHz) above K'(10 Hz) on both treads
    k = ds["k_storage"].sel(preload=1e-4)
    assert np.all(k.sel(frequency=1000.0) > 1.2 * k.sel(frequency=10.0))
    # fewer elements touch on the blocks (grooves) and each block is softer: K' far below the slick tread's
    assert float(k.sel(case="b4", frequency=10.0)) < 0.6 * float(k.sel(case="slick", frequency=10.0))


def test_pattern_k_star_equals_a_dense_solve_with_the_direct_block_frf(case):
    """At 3 kHz: the patch's dense G_C from a direct FE solve of the block (no modes) and a plain numpy solve of
    K* = 1^T [G_C + diag(1/k)]^-1 1 over the contact set of the relaxed state."""
    from tyreroad.contact import preload_states
    from tyreroad.pattern import PatchInfluence, groove_springs

    ds, surface, table, greens, material, settings = case
    z1 = surface["z1"].values
    kernel = kernel_from_pattern_greens(greens["b4"], z1.shape, ORIGIN)
    layout = kernel.layout
    states = preload_states(z1, groove_springs(table, layout.grooved), kernel, [1e-4], settings)
    k = states.spring_stiffness[0].ravel()
    active = np.flatnonzero(k)
    f = 3000.0
    w = 2 * math.pi * f
    cell = BlockCell(tread_pattern(layout.geometry), material.thickness, material.poisson, material.density,
                     BlockMesh())
    g_block = cell.influence(complex(np.ravel(material.modulus(w))[0]), w)
    dense = PatchInfluence(layout, g_block).matrix()[np.ix_(active, active)]
    k_star = np.ones(active.size) @ np.linalg.solve(dense + np.diag(1 / k[active]), np.ones(active.size))
    got = complex(ds["k_storage"].sel(case="b4", frequency=f).item(), ds["k_loss"].sel(case="b4", frequency=f).item())
    assert got == pytest.approx(k_star, rel=2e-3)


def test_rocking_mode_of_the_small_block(case):
    """The 4 x 3 x 10 mm block's lowest mode rocks about its long axis (odd across y): 1.27 kHz measured, far
    below its vertical (even-even) mode; a block this slender rocks first."""
    ds = case[0]
    nat = ds["natural_frequency"]
    lowest = {str(c): float(nat.sel(symmetry_class=c).values[0]) for c in nat["symmetry_class"].values}
    assert min(lowest, key=lowest.get) == "even-x odd-y"
    assert lowest["even-x odd-y"] == pytest.approx(1265.0, rel=0.02)
    assert lowest["even-x even-y"] > 5 * lowest["even-x odd-y"]


def test_report_section_reads_the_spectrum(case, tmp_path):
    from tyreroad.report.pattern import spectrum_section

    ds = case[0]
    text = "\n".join(spectrum_section([ds]))
    k = float(ds["k_storage"].sel(case="b4", frequency=1000.0, preload=1e-4)) / 1e6
    eta = float((ds["k_loss"] / ds["k_storage"]).sel(case="b4", frequency=1000.0, preload=1e-4))
    assert f"| tread / b4 | 0.1 | b4 | {int(ds['contact_count'].sel(case='b4', preload=1e-4))} |" in text
    assert f"{k:.3f} | {eta:.3f}" in text
    assert "even-x odd-y 1265 Hz" in text and "limit 2%" in text
