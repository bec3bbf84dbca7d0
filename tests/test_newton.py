"""Tests of tyreroad.newton: stiff (hard-contact) springs on both paths, the line search, the forcing."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from tyreroad import contact, greens
from tyreroad.contact import ContactConvergenceError, SolverSettings, solve_quasistatic
from tyreroad.history import DenseHistory
from tyreroad.loading import IndentationPath
from tyreroad.influence import offset_matrix
from tyreroad.newton import DenseSubstrate, StepConvergenceError, solve_step
from tyreroad.springs import SpringTable, linear_tables

E, NU, H, C = 25e6, 0.49, 0.01, 1e-3  # the study's layer: Pa, -, m, m
N = 20


@pytest.fixture(scope="module")
def layer_kernel():
    """Static element kernel of the 10 mm layer for a 20 x 20 patch of 1 mm elements."""
    uniq = greens.unique_offsets((N, N))
    g = greens.static_element_kernel(uniq * C, C, E, NU, H)
    return g[greens.offset_table_index((N, N))[2]]


def rough_z1(rng):
    """Element peaks, about half within 0.15 mm of the top."""
    z1 = -rng.exponential(0.15e-3 / math.log(2), size=(N, N))
    return z1 - z1.max()


@pytest.mark.parametrize("stiffness", [1e6, 1e8, 1e10])
def test_stiff_linear_springs_converge_and_paths_agree(layer_kernel, stiffness):
    z1 = rough_z1(np.random.default_rng(3))
    k, f = linear_tables(N * N, stiffness)
    settings = SolverSettings(quasistatic_step=5e-5)  # default tolerance, forcing and iteration limit
    runs = {m: solve_quasistatic(z1, k, f, 1e-6, layer_kernel, SolverSettings(quasistatic_step=5e-5, method=m))
            for m in ("dense", "fft")}
    for res in runs.values():
        assert res.residual.max() <= settings.tolerance
        assert res.newton_iterations.max() <= 12
    scale = runs["dense"].force.max()
    np.testing.assert_allclose(runs["fft"].force, runs["dense"].force, rtol=1e-9, atol=1e-9 * scale)
    np.testing.assert_allclose(runs["fft"].element_force, runs["dense"].element_force, rtol=0, atol=1e-9 * scale)
    # every step solves R = 0 with the analytic springs F = k max(zeta, 0)
    g0 = offset_matrix(layer_kernel)
    res = runs["dense"]
    for n, d in enumerate(res.indentation):
        zeta = res.compression[n].ravel()
        free = z1.ravel() - (z1.max() - d)
        r = zeta - free + g0 @ (stiffness * np.maximum(zeta, 0.0))
        assert np.abs(r).max() <= 1e-11


def test_stiff_limit_approaches_hard_contact(layer_kernel):
    z1 = rough_z1(np.random.default_rng(3))
    forces = []
    for stiffness in (1e6, 1e8, 1e10):
        k, f = linear_tables(N * N, stiffness)
        forces.append(solve_quasistatic(z1, k, f, 1e-6, layer_kernel, SolverSettings(quasistatic_step=5e-5)).force[-1])
    # stiffer springs, larger force; 1e8 is within 1e-3 of 1e10 (spring compliance 1/k << g_00 ~ 3e-5 m/N)
    assert forces[0] < forces[1] < forces[2]
    assert forces[1] / forces[2] == pytest.approx(1.0, abs=1e-3)
    assert forces[0] / forces[2] < 0.995


@pytest.mark.parametrize("method", ["dense", "fft"])
def test_rigid_square_punch_on_both_paths(layer_kernel, method):
    """SPEC 8: a rigid 20 x 20 mm square on the 10 mm layer (nu = 0.49) has K/E = 0.117 m."""
    k, f = linear_tables(N * N, 1e10)
    d = 1e-4
    res = solve_quasistatic(np.zeros((N, N)), k, f, 1e-6, layer_kernel, SolverSettings(method=method), indentation=[d])
    stiffness = res.force[0] / d
    assert stiffness / E == pytest.approx(0.117, rel=5e-3)
    # exactly the punch on the layer through the 400 springs, F = 1^T (G0 + I / k)^-1 1 d (their
    # compliance moves K by ~1e-6; the residual tolerance 1e-12 m moves F by ~1e-8 of F at d = 0.1 mm)
    g0 = offset_matrix(layer_kernel)
    exact = np.linalg.solve(g0 + np.eye(N * N) / 1e10, np.ones(N * N)).sum()
    assert stiffness == pytest.approx(exact, rel=2e-8)
    assert stiffness != pytest.approx(np.linalg.solve(g0, np.ones(N * N)).sum(), rel=2e-7)


class _WrongWay(DenseSubstrate):
    """A substrate whose corrections point uphill: no step length can decrease the residual."""

    def correction(self, stiffness, residual, polish):
        delta, products = super().correction(stiffness, residual, polish)
        return -delta, products


def test_line_search_never_accepts_a_growing_residual(layer_kernel):
    k, f = linear_tables(N * N, 1e8)
    springs = SpringTable.checked(k, f, 1e-6, N * N)
    b = np.full(N * N, 1e-5)
    with pytest.raises(StepConvergenceError) as err:
        solve_step(b, b.copy(), springs, _WrongWay(layer_kernel), 1e-12, 50)
    msg = str(err.value)
    assert "line search" in msg and "max|R| = " in msg
    assert "spring stiffness k = 1.000e+08 ... 1.000e+08 N/m over 400 loaded springs" in msg
    assert err.value.iterations == 0
    # through the march: the step and d are named too, and no result is returned
    z1 = np.zeros((N, N))
    loading = IndentationPath(z1, [1e-5, 2e-5])
    recorder = contact.RunRecorder(loading.n_steps, (N, N))
    with pytest.raises(ContactConvergenceError) as err:
        contact.march(loading, springs, _WrongWay(layer_kernel), DenseHistory(layer_kernel[:, :, None], (N, N)),
                      SolverSettings(), recorder)
    assert re.search(r"contact step 0 \(d = 1\.0+e-05 m\): line search", str(err.value))


def test_linear_tables_are_kept_as_two_points():
    k, f = linear_tables(3, [1e5, 2e5, 1e10], zeta_step=1e-6)
    assert k.shape == f.shape == (3, 2)
    # the same springs as a full 1 mm table: the solver keeps two points, with equal F and k
    grid = np.arange(1001)
    k_full = np.repeat(k[:, :1], 1001, axis=1)
    f_full = k[:, :1] * 1e-6 * grid[None, :]
    full = SpringTable.checked(k_full, f_full, 1e-6, 3)
    assert full.stiffness.shape == (3, 2)
    zeta = np.array([-1e-6, 0.0, 3.3e-7, 4.2e-4, 2e-3])
    for table in (full, SpringTable.checked(k, f, 1e-6, 3)):
        for row in range(3):
            # spring `row` at zeta, the other two 0.7 mm further in: each spring must read its own
            # compression and its own table row (an evaluation that mixed springs would see the shift)
            z = zeta[:, None] + np.where(np.arange(3) == row, 0.0, 7e-4)
            force, stiff = table.evaluate(z)
            np.testing.assert_allclose(force[:, row], k[row, 0] * np.maximum(zeta, 0), rtol=1e-13, atol=0)
            np.testing.assert_array_equal(stiff[:, row], np.where(zeta > 0, k[row, 0], 0.0))
            np.testing.assert_allclose(force, k[:, 0] * np.maximum(z, 0), rtol=1e-13, atol=0)
            np.testing.assert_array_equal(stiff, np.where(z > 0, k[:, 0], 0.0))
    # a table whose k varies keeps its grid
    k_var = k_full.copy()
    k_var[0, 500:] *= 2
    f_var = np.zeros_like(k_var)
    np.cumsum(0.5e-6 * (k_var[:, 1:] + k_var[:, :-1]), axis=1, out=f_var[:, 1:])
    assert SpringTable.checked(k_var, f_var, 1e-6, 3).stiffness.shape == (3, 1001)


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda k, f: k.__setitem__((1, 3), np.nan), "NaN or infinite"),
        (lambda k, f: f.__setitem__((0, 2), np.inf), "NaN or infinite"),
        (lambda k, f: k.__setitem__((2, 0), -1.0), "must be >= 0"),
        (lambda k, f: f.__setitem__((2, 5), f[2, 5] * (1 + 1e-6)), "cumulative trapezoid"),
    ],
)
def test_table_checks_name_the_fault(mutate, message):
    k = np.repeat(np.array([[1e5], [2e5], [3e5]]), 11, axis=1)
    f = k * 1e-6 * np.arange(11)[None, :]
    mutate(k, f)
    with pytest.raises(ValueError, match=message):
        SpringTable.checked(k, f, 1e-6, 3)


def test_linear_tables_validation():
    with pytest.raises(ValueError, match="stiffness must be finite and > 0"):
        linear_tables(2, [1e5, 0.0])
    with pytest.raises(ValueError, match="zeta_step"):
        linear_tables(2, 1e5, zeta_step=0.0)


def test_krylov_forcing_setting():
    assert SolverSettings().krylov_forcing == 1e-6
    assert SolverSettings.from_config({"krylov_forcing": 1e-3}).krylov_forcing == 1e-3
    for bad in (0.0, 1.0, "small"):
        with pytest.raises(ValueError, match="solver.krylov_forcing"):
            SolverSettings.from_config({"krylov_forcing": bad})
