"""Tests of tyreroad.contact (SPEC section 6) against analytic and dense references."""

from __future__ import annotations

import dataclasses
import logging
import math
import re
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.integrate import quad

from tyreroad import contact, newton
from tyreroad.contact import (
    ContactConvergenceError,
    SolverSettings,
    contact_dataset,
    solve_dynamic,
    solve_path,
    solve_quasistatic,
)
from tyreroad.history import DenseHistory
from tyreroad.kernel import LayerKernel
from tyreroad.layer import backing_force, backing_force_transfer
from tyreroad.reference import sdof
from tyreroad.reference.dense import dense_history_sum, lag_matrix
from tyreroad.springs import SpringTable, evaluate

E_STAR = 3.3e7  # Pa, plane-strain modulus of a ~25 MPa tread (nu = 0.49)
ELEMENT = 1e-3  # m


# --------------------------------------------------------------------------------------------
# Synthetic but realistic inputs
# --------------------------------------------------------------------------------------------
def linear_tables(k_c: float, n_zeta: int = 11, step: float = 1e-5):
    """Constant-stiffness spring table (one element)."""
    k = np.full((1, n_zeta), k_c)
    return k, k_c * step * np.arange(n_zeta)[None, :], step


def punch_tables(n_elem: int, rng, step: float = 1e-6, zeta_max: float = 1e-3):
    """Springs k = 2 E* a with a = sqrt(A/pi), A = max(sample area, pi R zeta) capped at c^2.

    For a paraboloid cap of radius R this is sqrt(2) x Hertz: k grows like sqrt(zeta).
    """
    zeta = np.arange(round(zeta_max / step) + 1) * step
    radius = rng.uniform(1e-3, 4e-3, size=n_elem)[:, None]
    area = np.minimum(np.maximum((ELEMENT / 26) ** 2, np.pi * radius * zeta[None, :]), ELEMENT**2)
    k = 2 * E_STAR * np.sqrt(area / np.pi)
    f = np.zeros_like(k)
    np.cumsum(0.5 * step * (k[:, 1:] + k[:, :-1]), axis=1, out=f[:, 1:])
    return k, f, step


def realistic_z1(nx: int, ny: int, rng, offset: float = 3e-3):
    """Element peaks with about half of them within 0.15 mm of the top."""
    z1 = -rng.exponential(0.15e-3 / math.log(2), size=(nx, ny))
    return z1 - z1.max() + offset


def realistic_kernel(nx: int, ny: int, n_lag: int, fs: float = 51200.0):
    """g[dx, dy, lag]: a Boussinesq-like static kernel spread over lags after a Rayleigh delay.

    Static part: self 1.12 / (E* c), neighbours 1 / (pi E* r) with a layer cut-off that turns
    slightly negative (surface bulge) beyond ~8 mm. Lags: exponential with 8-sample decay,
    starting at r / c_R (c_R = 87 m/s), normalised so that the lags hold the static value.
    """
    dx = np.arange(-(nx - 1), nx)[:, None] * ELEMENT
    dy = np.arange(-(ny - 1), ny)[None, :] * ELEMENT
    r = np.hypot(dx, dy)
    with np.errstate(divide="ignore"):
        g_static = np.where(r > 0, 1 / (np.pi * E_STAR * np.maximum(r, 1e-30)), 1.1222 / (E_STAR * ELEMENT))
    g_static = g_static * np.exp(-r / 0.01) * (1 - 0.1 * r / 0.008)
    arrival = r * fs / 87.0
    lag = np.arange(n_lag)[None, None, :]
    start = np.minimum(np.floor(arrival), n_lag - 1)
    shape = np.where(lag >= start[..., None], np.exp(-(lag - arrival[..., None]) / 8.0), 0.0)
    shape /= shape.sum(axis=2, keepdims=True)
    return g_static[..., None] * shape, g_static


def evaluate_springs(zeta, k_tab, f_tab, step):
    """The package's spring evaluation (numba kernel) for one zeta per table row."""
    return evaluate(zeta, step, k_tab, f_tab)


def layer_transfer_k0(omega, mat):
    """k = 0 transfer of a material object (tyreroad.layer.backing_force_transfer)."""
    return backing_force_transfer(omega, mat.modulus(omega), mat.poisson, mat.density, mat.thickness)


def spring_reference(zeta, k_tab, f_tab, step, rows=None):
    """Plain-numpy interpolation contract (written differently from the numba kernel).

    ``rows[i]`` is the table row of ``zeta[i]`` (default: row i).
    """
    zeta = np.asarray(zeta, dtype=float)
    rows = np.arange(zeta.size) if rows is None else np.asarray(rows)
    n_zeta = k_tab.shape[1]
    grid = step * np.arange(n_zeta)
    j = np.clip(np.floor(zeta / step), 0, n_zeta - 2).astype(int)
    # k as the weighted mean of the cell's end values; beyond the table it stays at the last value
    zc = np.clip(zeta, 0, grid[-1])
    k = ((grid[j + 1] - zc) * k_tab[rows, j] + (zc - grid[j]) * k_tab[rows, j + 1]) / step
    # trapezoid of the linear k on [z_j, zeta] is exact; beyond the table F grows linearly
    f = f_tab[rows, j] + 0.5 * (k_tab[rows, j] + k) * (zc - grid[j]) + k * (zeta - zc)
    off = zeta <= 0
    return np.where(off, 0.0, f), np.where(off, 0.0, k)


@dataclass(frozen=True)
class ConstantMaterial:
    """Frequency-independent complex modulus E (1 + i eta) (duck-types tyreroad Material)."""

    storage: float = 25e6
    eta: float = 0.05
    poisson: float = 0.49
    density: float = 1100.0
    thickness: float = 0.01

    def modulus(self, omega):
        return np.full(np.shape(omega), self.storage * (1 + 1j * self.eta))


@dataclass(frozen=True)
class FractionalMaterial:
    """Fractional Kelvin-Voigt tread E0 + E1 (i w / w1)^alpha (stiffening with frequency)."""

    poisson: float = 0.49
    density: float = 1100.0
    thickness: float = 0.01

    def modulus(self, omega):
        return 22e6 + 44e6 * (1j * np.asarray(omega) / (2 * np.pi * 1e3)) ** 0.24


@pytest.fixture(scope="module")
def realistic_run():
    rng = np.random.default_rng(7)
    nx = ny = 20
    z1 = realistic_z1(nx, ny, rng)
    k, f, step = punch_tables(nx * ny, rng)
    kernel, _ = realistic_kernel(nx, ny, 64)
    settings = SolverSettings()
    result = solve_dynamic(z1, k, f, step, kernel, 51200.0, 500.0, settings)
    return z1, k, f, step, kernel, settings, result


# --------------------------------------------------------------------------------------------
# Settings
# --------------------------------------------------------------------------------------------
def test_settings_defaults_and_errors():
    s = SolverSettings.from_config({})
    assert (s.tolerance, s.max_iterations, s.d_max, s.quasistatic_step) == (1e-12, 50, 2.5e-4, 1e-5)
    assert SolverSettings.from_config({"max_iterations": 7.0, "d_max": 1e-4}).max_iterations == 7
    for bad, key in [
        ({"tolerance": -1}, "solver.tolerance"),
        ({"max_iterations": 0}, "solver.max_iterations"),
        ({"d_max": "big"}, "solver.d_max"),
        ({"quasistatic_step": 1e-3}, "solver.quasistatic_step"),
        ({"tolerence": 1e-9}, "solver.tolerence"),
    ]:
        with pytest.raises(ValueError, match=re.escape(key)):
            SolverSettings.from_config(bad)


# --------------------------------------------------------------------------------------------
# 5. Springs: numba kernel vs. plain numpy contract
# --------------------------------------------------------------------------------------------
def test_spring_evaluation_matches_numpy_contract():
    rng = np.random.default_rng(1)
    k_tab, f_tab, step = punch_tables(50, rng, step=1e-5, zeta_max=2e-4)
    zmax = step * (k_tab.shape[1] - 1)
    zeta = np.concatenate([
        [-1e-4, 0.0, -0.0, 1e-300, step, 3 * step, zmax, zmax + 1e-5, 2 * zmax],
        rng.uniform(-0.2 * zmax, 1.5 * zmax, size=41),
    ])
    f, k = evaluate_springs(zeta, k_tab, f_tab, step)
    f_ref, k_ref = spring_reference(zeta, k_tab, f_tab, step)
    np.testing.assert_allclose(f, f_ref, rtol=1e-14, atol=1e-14 * f_tab.max())
    np.testing.assert_allclose(k, k_ref, rtol=1e-14, atol=0)
    assert np.all(f[zeta <= 0] == 0) and np.all(k[zeta <= 0] == 0)
    assert np.all(f[zeta > 0] > 0)
    # k is the derivative of F: central difference inside a cell
    z = np.full(50, 3.4 * step)
    fp, _ = evaluate_springs(z + 1e-9, k_tab, f_tab, step)
    fm, _ = evaluate_springs(z - 1e-9, k_tab, f_tab, step)
    _, kz = evaluate_springs(z, k_tab, f_tab, step)
    np.testing.assert_allclose((fp - fm) / 2e-9, kz, rtol=1e-6)


def test_spring_tables_must_be_consistent():
    k, f, step = linear_tables(1e4)
    with pytest.raises(ValueError, match="cumulative trapezoid"):
        SpringTable.checked(k, 1.5 * f, step, 1)
    with pytest.raises(ValueError, match="zeta_step"):
        SpringTable.checked(k, f, 0.0, 1)
    with pytest.raises(ValueError, match="zeta_step"):
        evaluate_springs([1e-5], k, f, 0.0)


# --------------------------------------------------------------------------------------------
# 1. One element, linear spring, static compliance
# --------------------------------------------------------------------------------------------
def test_one_element_linear_spring_static_compliance():
    k_c, g = 2.0e4, 3.0e-5
    k, f, step = linear_tables(k_c)  # table ends at 0.1 mm: beyond it k stays constant
    settings = SolverSettings(d_max=2.5e-4, quasistatic_step=1e-5)
    res = solve_quasistatic([[1e-3]], k, f, step, [[g]], settings)
    d = res.indentation
    assert d[-1] == pytest.approx(2.5e-4) and d.size == 26
    expected = d / (1 / k_c + g)
    np.testing.assert_allclose(res.force[1:], expected[1:], rtol=1e-12)
    assert res.force[0] == 0
    np.testing.assert_allclose(res.displacement[:, 0, 0], g * expected, rtol=1e-12, atol=1e-24)
    assert res.time is None and np.all(res.residual <= 1e-12)


def test_march_progress_lines_carry_elapsed_and_time_left(caplog):
    k, f, step = linear_tables(2.0e4)
    settings = SolverSettings(d_max=2.5e-4, quasistatic_step=1e-5)
    with caplog.at_level(logging.INFO, logger="tyreroad.contact"):
        solve_quasistatic([[1e-3]], k, f, step, [[3.0e-5]], settings)
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("step ")]
    assert lines[0].startswith("step 0/25:") and lines[-1].startswith("step 25/25:")
    assert all("; elapsed " in line for line in lines)
    assert "left" in lines[1] and "left" not in lines[-1]  # an estimate while steps remain, none at the end


# --------------------------------------------------------------------------------------------
# 2. One element on a one-degree-of-freedom kernel vs. ODE integration
# --------------------------------------------------------------------------------------------
def test_first_order_hold_kernel_sum_rule_and_shape():
    m, k_l, zd, fs = 2.5e-3, 1e5, 0.1, 51200.0
    g = sdof.first_order_hold_kernel(20000, fs, m, k_l, zd)
    assert g.sum() == pytest.approx(1 / k_l, rel=1e-10)
    # the closed form equals the defining hat-function integrals (adaptive quadrature)
    dt = 1 / fs
    for lag in (0, 1, 2, 17, 40):
        def integrand(u, lag=lag):
            return sdof.impulse_response(u, m, k_l, zd) * max(0.0, 1 - abs(u - lag * dt) / dt)
        lo = max(0.0, (lag - 1) * dt)
        ref = quad(integrand, lo, (lag + 1) * dt, points=[lag * dt], epsabs=0, epsrel=1e-13)[0]
        assert g[lag] == pytest.approx(ref, rel=1e-9)
    # interior lags approach g(t_l) dt (error ~ (w dt)^2 / 12); lag 0 ~ dt^2 / (6 m)
    t = np.arange(1, 50) / fs
    g_t = sdof.impulse_response(t, m, k_l, zd) / fs
    np.testing.assert_allclose(g[1:50], g_t, rtol=0, atol=2e-3 * np.abs(g_t).max())
    assert g[0] == pytest.approx(1 / (6 * m * fs**2), rel=2e-2)


@pytest.mark.parametrize("damping_ratio", [0.05, 0.3])
def test_one_element_sdof_matches_ode(damping_ratio):
    m, k_l, k_c, a = 2.5e-3, 1e5, 1.5e5, 500.0  # f0 = 1 kHz, coupled ~ 1.6 kHz
    fs = 51200.0
    settings = SolverSettings(d_max=2.5e-4)
    n_steps = math.ceil(fs * math.sqrt(2 * settings.d_max / a)) + 1
    kernel = sdof.first_order_hold_kernel(n_steps, fs, m, k_l, damping_ratio)[None, None, :]
    k, f, step = linear_tables(k_c)
    res = solve_dynamic([[0.0]], k, f, step, kernel, fs, a, settings)
    ode = sdof.contact_force_ode(res.time, m, k_l, damping_ratio, k_c, a)
    peak_error = abs(res.force.max() - ode.max()) / ode.max()
    series_error = np.max(np.abs(res.force - ode)) / ode.max()
    assert peak_error < 1e-3 and series_error < 1e-3  # measured 2e-4 at most
    # the response is genuinely dynamic: it differs from the quasi-static spring series by > 5 %
    static = res.indentation / (1 / k_c + 1 / k_l)
    assert np.max(np.abs(static - ode)) / ode.max() > 0.05
    # second-order discretisation: doubling fs cuts the error about fourfold
    kernel2 = sdof.first_order_hold_kernel(2 * n_steps, 2 * fs, m, k_l, damping_ratio)[None, None, :]
    res2 = solve_dynamic([[0.0]], k, f, step, kernel2, 2 * fs, a, settings)
    ode2 = sdof.contact_force_ode(res2.time, m, k_l, damping_ratio, k_c, a)
    series_error2 = np.max(np.abs(res2.force - ode2)) / ode2.max()
    assert 3.0 < series_error / series_error2 < 5.0


# --------------------------------------------------------------------------------------------
# 3. One-lag dynamic == quasi-static; fast history == dense history
# --------------------------------------------------------------------------------------------
def test_one_lag_dynamic_equals_quasistatic():
    rng = np.random.default_rng(3)
    nx, ny = 6, 5
    z1 = realistic_z1(nx, ny, rng)
    k, f, step = punch_tables(nx * ny, rng)
    _, g_static = realistic_kernel(nx, ny, 1)
    settings = SolverSettings(d_max=2.5e-4, quasistatic_step=1e-6)
    dyn = solve_dynamic(z1, k, f, step, g_static[:, :, None], 51200.0, 500.0, settings)
    qs = solve_quasistatic(z1, k, f, step, g_static, settings, indentation=dyn.indentation)
    np.testing.assert_allclose(dyn.force, qs.force, rtol=1e-12, atol=0)
    np.testing.assert_allclose(dyn.element_force, qs.element_force, rtol=1e-12, atol=1e-12 * qs.force.max())
    # the uniform-grid quasi-static run agrees where the grids meet (d = 0 and near d_max) and
    # every point of it satisfies the static equations independently
    qs_grid = solve_quasistatic(z1, k, f, step, g_static, settings)
    assert qs_grid.indentation.size == 251
    last = qs_grid.indentation[-1]
    np.testing.assert_allclose(qs_grid.force[-1], np.interp(last, dyn.indentation, dyn.force), rtol=2e-2)
    _check_equations(z1, k, f, step, g_static[:, :, None], qs_grid, tol=1e-12)


def test_fast_history_equals_dense_sum():
    """DenseHistory (ring of L - 1 steps, loaded elements only) against dense matrices and a loop."""
    rng = np.random.default_rng(11)
    nx = ny = 8
    n_lag, n_steps = 32, 40
    kernel = rng.normal(size=(2 * nx - 1, 2 * ny - 1, n_lag)) * 1e-6
    forces = rng.uniform(0, 5, size=(n_steps, nx * ny)) * (rng.random((n_steps, nx * ny)) < 0.5)
    history = DenseHistory(kernel, (nx, ny))
    for n in range(n_steps):
        out = history.displacement(n)
        history.record(n, forces[n])
        if n not in (0, 1, 5, 31, 32, 39):
            continue
        ref = dense_history_sum(kernel, forces.reshape(n_steps, nx, ny), n).ravel()
        # explicit loop over (lag, m): an independent reference for the dense helper too
        loop = np.zeros(nx * ny)
        for lag in range(1, min(n_lag - 1, n) + 1):
            for m in range(nx * ny):
                mx, my = divmod(m, ny)
                for e in range(nx * ny):
                    ex, ey = divmod(e, ny)
                    loop[e] += kernel[ex - mx + nx - 1, ey - my + ny - 1, lag] * forces[n - lag, m]
        scale = max(np.max(np.abs(ref)), 1e-300)
        np.testing.assert_allclose(out, ref, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(loop, ref, rtol=0, atol=1e-12 * scale)
    with pytest.raises(ValueError, match="next step"):
        history.displacement(n_steps + 3)


# --------------------------------------------------------------------------------------------
# 4. Realistic 20 x 20 run: invariants, convergence, failure
# --------------------------------------------------------------------------------------------
def _check_equations(z1, k, f, step, kernel, res, tol):
    """Every step satisfies zeta = z1 - z2 - w with w from dense lag matrices (independent check)."""
    z1 = np.asarray(z1)
    nx, ny = z1.shape
    n_steps = res.indentation.size
    forces = res.element_force.reshape(n_steps, nx * ny)
    rows = np.tile(np.arange(nx * ny), n_steps)
    f_ref, _ = spring_reference(res.compression.ravel(), k.reshape(nx * ny, -1), f.reshape(nx * ny, -1), step, rows)
    np.testing.assert_allclose(forces.ravel(), f_ref, rtol=1e-13, atol=1e-13 * max(f_ref.max(), 1))
    w = np.zeros((n_steps, nx * ny))
    for lag in range(min(kernel.shape[2], n_steps)):
        w[lag:] += forces[: n_steps - lag] @ lag_matrix(np.asarray(kernel), lag).T
    resid = res.compression.reshape(n_steps, -1) - ((z1.ravel() - z1.max())[None, :] + res.indentation[:, None] - w)
    assert np.max(np.abs(resid)) <= tol * 1.001
    np.testing.assert_allclose(res.displacement.reshape(n_steps, -1), w, rtol=0, atol=1e-15)


def test_realistic_run_invariants(realistic_run):
    z1, k, f, step, kernel, settings, res = realistic_run
    n = res.indentation.size
    assert n == 53 and res.indentation[-1] >= 2.5e-4 > res.indentation[-2]
    np.testing.assert_allclose(res.time, np.arange(n) / 51200.0)
    assert np.all(res.residual <= settings.tolerance)
    assert np.all(res.newton_iterations <= 10)
    ef, zeta = res.element_force, res.compression
    assert np.all(ef[zeta <= 0] == 0) and np.all(ef[zeta > 0] > 0)
    np.testing.assert_allclose(res.force, ef.sum(axis=(1, 2)), rtol=1e-14)
    np.testing.assert_array_equal(res.contact_count, (zeta > 0).sum(axis=(1, 2)))
    assert res.force[0] == 0 and np.all(np.diff(res.force) > 0)
    # realistic scale: a few N at 0.25 mm, 30-70 % of the elements in contact at 0.15 mm
    i15 = np.searchsorted(res.indentation, 1.5e-4)
    assert 0.3 < res.contact_count[i15] / 400 < 0.8
    _check_equations(z1, k, f, step, kernel, res, settings.tolerance)


def test_nonconvergence_raises_with_step_d_and_residual(realistic_run):
    z1, k, f, step, kernel, _, _ = realistic_run
    settings = SolverSettings(max_iterations=1)
    with pytest.raises(ContactConvergenceError) as err:
        solve_dynamic(z1, k, f, step, kernel, 51200.0, 500.0, settings)
    msg = str(err.value)
    assert re.search(r"step \d+", msg) and re.search(r"d = \d\.\d+e-0\d m", msg) and "residual" in msg
    step_no = int(re.search(r"step (\d+)", msg).group(1))
    assert step_no >= 1


def test_kernel_and_table_validation():
    k, f, step = linear_tables(1e4)
    with pytest.raises(ValueError, match="offset axis"):
        solve_path([[0.0, 0.0]], np.vstack([k, k]), np.vstack([f, f]), step, LayerKernel.dynamic(np.ones((1, 2, 3)), 51200.0), [0.0],
                   SolverSettings())
    with pytest.raises(ValueError, match="spring tables"):
        solve_path([[0.0]], np.vstack([k, k]), np.vstack([f, f]), step, LayerKernel.dynamic(np.ones((1, 1, 3)), 51200.0), [0.0],
                   SolverSettings())
    # a larger centred table is cropped to the patch
    big = np.zeros((5, 5, 1))
    big[2, 2, 0] = 3e-5
    res = solve_path([[0.0]], k, f, step, LayerKernel.quasistatic(big[:, :, 0]), [1e-4], SolverSettings())
    assert res.force[0] == pytest.approx(1e-4 / (1 / 1e4 + 3e-5), rel=1e-12)


# --------------------------------------------------------------------------------------------
# 6. Backing force
# --------------------------------------------------------------------------------------------
def test_transfer_peaks_at_quarter_wave():
    mat = ConstantMaterial()
    nu = mat.poisson
    p_modulus = mat.storage * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    c_p = math.sqrt(p_modulus / mat.density)
    f_quarter = c_p / (4 * mat.thickness)
    freq = np.linspace(1.0, 3 * f_quarter, 60001)
    t = layer_transfer_k0(2 * np.pi * freq, mat)
    assert layer_transfer_k0(np.array([0.0]), mat)[0] == 1.0
    assert freq[np.argmax(np.abs(t))] == pytest.approx(f_quarter, rel=5e-3)
    # peak height of the damped quarter-wave resonance ~ 4 / (pi eta)
    assert np.abs(t).max() == pytest.approx(4 / (np.pi * mat.eta), rel=0.05)


def _steady_state_amplitude(series, j, n_period):
    """Complex amplitude (T for a unit sine input) of sin/cos(2 pi j n / N) fitted to a series."""
    n = np.arange(series.size)
    basis = np.stack([np.sin(2 * np.pi * j * n / n_period), np.cos(2 * np.pi * j * n / n_period)], axis=1)
    (s, c), *_ = np.linalg.lstsq(basis, series, rcond=None)
    return complex(s, c)  # response Im(T exp(i w t)) = Re T sin + Im T cos


def test_backing_force_static_limit_and_sinusoid():
    fs, n_period = 51200.0, 2048
    mat = FractionalMaterial()
    n = np.arange(3 * n_period)
    slow = (n / fs) ** 2 * 1e3  # a slowly growing, ramp-like force
    back = backing_force(slow, mat, fs)
    np.testing.assert_allclose(back[400:], slow[400:], rtol=1e-4)
    assert abs(back[-1] / slow[-1] - 1) < 1e-6
    # steady state of a low-frequency sinusoid (periodic on n_period samples) is T(omega) F
    j = 60  # 1.5 kHz
    back = backing_force(np.sin(2 * np.pi * j * n / n_period), mat, fs)[-n_period:]
    t = layer_transfer_k0(np.array([2 * np.pi * j * fs / n_period]), mat)[0]
    assert _steady_state_amplitude(back, j, n_period) == pytest.approx(complex(t), rel=1e-2)
    # near the resonance (9 kHz, 5.7 samples per period) the discrete result is that of the
    # piecewise-linear force: compare with a 16x oversampled periodic FFT convolution
    j, over = 360, 16
    back = backing_force(np.sin(2 * np.pi * j * n / n_period), mat, fs)[-n_period:]
    fine_t = np.arange(n_period * over) / over
    fine_f = np.interp(fine_t, np.arange(n_period + 1), np.sin(2 * np.pi * j * np.arange(n_period + 1) / n_period))
    omega = 2 * np.pi * np.fft.rfftfreq(n_period * over, 1 / (fs * over))
    ref = np.fft.irfft(np.fft.rfft(fine_f) * layer_transfer_k0(omega, mat), n_period * over)[::over]
    np.testing.assert_allclose(back, ref, rtol=0, atol=3e-3)
    t = layer_transfer_k0(np.array([2 * np.pi * j * fs / n_period]), mat)[0]
    assert abs(t) > 1.1  # amplified near the quarter-wave resonance


# --------------------------------------------------------------------------------------------
# Dataset
# --------------------------------------------------------------------------------------------
def test_contact_dataset(realistic_run, tmp_path):
    from tyreroad import io

    *_, res = realistic_run
    with pytest.raises(ValueError, match="backing_force"):
        contact_dataset(res, "dynamic", 500.0, "iso10844", "tread")
    mat = FractionalMaterial()
    res_b = contact.dataclasses.replace(res, backing_force=backing_force(res.force, mat, 51200.0))
    ds = contact_dataset(res_b, "dynamic", 500.0, "iso10844", "tread")
    io.check_metadata(ds)
    assert ds.sizes == {"step": 53, "ex": 20, "ey": 20}
    assert ds.attrs["mode"] == "dynamic" and ds.attrs["acceleration"] == 500.0
    np.testing.assert_array_equal(ds["element_force"].values, res.element_force)
    assert "time" in ds.coords
    path = io.write_dataset(ds, tmp_path / "dynamic_500.nc", {"solver": {}})
    back = io.read_dataset(path)
    np.testing.assert_array_equal(back["compression"].values, res.compression)
    with pytest.raises(ValueError, match="acceleration"):
        contact_dataset(res, "quasistatic", 500.0, "iso10844", "tread")


def test_jacobian_block_solve_matches_numpy():
    rng = np.random.default_rng(5)
    _, g_static = realistic_kernel(6, 6, 1)
    g0 = lag_matrix(g_static[:, :, None], 0)
    active = np.sort(rng.choice(36, size=20, replace=False))
    ka = rng.uniform(1e3, 4e4, size=20)
    rhs = rng.normal(size=20) * 1e-6
    x, ok = newton._jacobian_block_solve(g0, active, ka, rhs)
    jac = np.eye(20) + g0[np.ix_(active, active)] * ka[None, :]
    assert ok
    np.testing.assert_allclose(x, np.linalg.solve(jac, rhs), rtol=1e-12, atol=1e-12 * np.abs(x).max())
    # an exactly singular block (I + G K = [[.5, -.5], [-.5, .5]]) is reported, not divided by 0
    _, ok = newton._jacobian_block_solve(np.full((2, 2), -0.5), np.array([0, 1]), np.array([1.0, 1.0]),
                                          np.ones(2))
    assert not ok


def test_solve_run_from_stage_datasets():
    import xarray as xr

    rng = np.random.default_rng(9)
    nx, ny = 4, 3
    z1 = realistic_z1(nx, ny, rng)
    k, f, step = punch_tables(nx * ny, rng, step=1e-5)
    kernel, g_static = realistic_kernel(nx, ny, 40)
    n_zeta = k.shape[1]
    surface = xr.Dataset({"z1": (("ex", "ey"), z1)}, attrs={"element_size": ELEMENT})
    springs = xr.Dataset(
        {"stiffness": (("ex", "ey", "zeta"), k.reshape(nx, ny, n_zeta)),
         "force": (("ex", "ey", "zeta"), f.reshape(nx, ny, n_zeta))},
        coords={"zeta": step * np.arange(n_zeta)},
    )
    # greens tables stored with a different dimension order must still be read as g[dx, dy, lag]
    greens = xr.Dataset(
        {"g": (("lag", "dx", "dy"), np.moveaxis(kernel, 2, 0)), "g_static": (("dx", "dy"), g_static)},
        attrs={"sample_rate": 51200.0, "n_fft": 4096, "element_size": ELEMENT},
    )
    settings = SolverSettings(d_max=1e-4, quasistatic_step=1e-5)
    mat = FractionalMaterial()
    dyn = contact.solve_run(surface, springs, greens, mat, "dynamic", 500.0, settings)
    ref = solve_dynamic(z1, k, f, step, kernel, 51200.0, 500.0, settings)
    np.testing.assert_array_equal(dyn.force, ref.force)
    np.testing.assert_allclose(dyn.backing_force, backing_force(ref.force, mat, 51200.0), rtol=1e-14)
    qs = contact.solve_run(surface, springs, greens, mat, "quasistatic", 0.0, settings)
    np.testing.assert_array_equal(qs.force, solve_quasistatic(z1, k, f, step, g_static, settings).force)
    np.testing.assert_array_equal(qs.backing_force, qs.force)
    ds = contact_dataset(qs, "quasistatic", 0.0, "s", "m")
    assert "time" not in ds.coords and ds.sizes["step"] == 11
    with pytest.raises(ValueError, match="acceleration"):
        contact.solve_run(surface, springs, greens, mat, "quasistatic", 50.0, settings)
    # a run longer than the kept lags, from a greens file without a tail: an error, not a truncation
    short = greens.isel(lag=slice(0, 16))
    with pytest.raises(ValueError, match=r"needs 34 steps .* greens.n_lags = 16 lags"):
        contact.solve_run(surface, springs, short, mat, "dynamic", 500.0, settings)
    with pytest.raises(ValueError, match="mode"):
        contact.solve_run(surface, springs, greens, mat, "static", 0.0, settings)


# --------------------------------------------------------------------------------------------
# FFT / Newton-Krylov path (issue 7) against the dense reference path
# --------------------------------------------------------------------------------------------
def test_fft_path_equals_dense_path(realistic_run):
    z1, k, f, step, kernel, settings, dense = realistic_run
    fft_settings = dataclasses.replace(settings, method="fft")
    fft = solve_dynamic(z1, k, f, step, kernel, 51200.0, 500.0, fft_settings)
    assert fft.force.shape == dense.force.shape
    scale = dense.force.max()
    np.testing.assert_allclose(fft.force, dense.force, rtol=1e-10, atol=1e-10 * scale)
    np.testing.assert_allclose(fft.element_force, dense.element_force, rtol=0, atol=1e-10 * scale)
    np.testing.assert_array_equal(fft.contact_count, dense.contact_count)
    assert fft.residual.max() <= settings.tolerance
    # quasi-static (one-lag kernel) as well
    g_static = kernel.sum(axis=2)
    qs_dense = solve_quasistatic(z1, k, f, step, g_static, settings)
    qs_fft = solve_quasistatic(z1, k, f, step, g_static, fft_settings)
    np.testing.assert_allclose(qs_fft.force, qs_dense.force, rtol=1e-10, atol=1e-10 * qs_dense.force.max())


def test_method_selection_and_validation():
    assert SolverSettings().resolved_method(400) == "dense"
    assert SolverSettings().resolved_method(401) == "fft"
    assert SolverSettings(method="dense").resolved_method(30000) == "dense"
    with pytest.raises(ValueError, match="solver.method"):
        SolverSettings.from_config({"method": "magic"})
    with pytest.raises(ValueError, match="solver.preconditioner_block"):
        SolverSettings.from_config({"preconditioner_block": 0})


# --------------------------------------------------------------------------------------------
# The time-marching protocol: new loadings and histories plug in without touching the loop
# --------------------------------------------------------------------------------------------
class ConstantOffsetHistory:
    """A history that pushes every element into the layer by a fixed offset (a trivial extra term)."""

    def __init__(self, offset):
        self.offset = np.asarray(offset, dtype=float)
        self.recorded = []

    def displacement(self, n):
        return self.offset.copy()

    def record(self, n, force):
        self.recorded.append(n)


class StaircaseLoading:
    """A per-element prescribed free compression (not a single d): element e sees d[n] + tilt_e."""

    def __init__(self, z1, d, tilt):
        self.gap0 = (np.asarray(z1) - np.max(z1)).ravel()
        self.d = np.asarray(d, dtype=float)
        self.tilt = np.asarray(tilt, dtype=float).ravel()
        self.n_steps = self.d.size
        self.time = np.arange(self.n_steps) / 51200.0

    def free_compression(self, n):
        return self.gap0 + self.d[n] + self.tilt

    def rest_compression(self):
        return self.gap0.copy()

    def describe(self, n):
        return f"stair {n}"

    def done(self, n, force):
        return False

    def unfinished(self, n):
        return None

    def prescribed(self):
        field = self.gap0[None, :] + self.d[:, None] + self.tilt[None, :]
        return {"free_compression": (field.reshape(self.n_steps, 4, 3), "m", "prescribed z1 - z2 per element")}


def test_extra_history_and_new_loading_plug_into_the_march():
    """A constant-offset history equals the same run with the offset removed from the indentation,
    and a per-element loading runs through the unchanged march and Newton driver."""
    from tyreroad.contact import RunRecorder, march
    from tyreroad.history import HistorySum
    from tyreroad.loading import IndentationPath

    rng = np.random.default_rng(21)
    nx, ny = 4, 3
    z1 = realistic_z1(nx, ny, rng)
    k, f, step = punch_tables(nx * ny, rng)
    kernel, _ = realistic_kernel(nx, ny, 48)
    settings = SolverSettings(d_max=2e-4)
    table = SpringTable.checked(k, f, step, nx * ny)
    d = 0.5 * 500.0 * (np.arange(40) / 51200.0) ** 2 + 1e-5
    offset = 4e-6  # m, every element pushed 4 um into the layer by the extra history
    for method in ("dense", "fft"):
        s = dataclasses.replace(settings, method=method)
        substrate, kept = LayerKernel.dynamic(kernel, 51200.0).collaborators((nx, ny), s)
        extra = ConstantOffsetHistory(np.full(nx * ny, offset))
        loading = IndentationPath(z1, d, time=np.arange(d.size) / 51200.0)
        res = march(loading, table, substrate, HistorySum([kept, extra]), s, RunRecorder(d.size, (nx, ny)))
        ref = solve_path(z1, k, f, step, LayerKernel.dynamic(kernel, 51200.0), d - offset, s,
                         time=np.arange(d.size) / 51200.0)
        np.testing.assert_allclose(res.force, ref.force, rtol=1e-10, atol=1e-10 * ref.force.max())
        # the offset is part of the displacement w, not of the spring compression
        np.testing.assert_allclose(res.displacement - offset, ref.displacement, rtol=0, atol=1e-14)
        assert extra.recorded == list(range(d.size))
        assert ref.force[-1] > 0.5 and res.force[0] < ref.force.max()

    # a per-element loading: the tilt makes the elements meet the road at different times
    tilt = np.linspace(-2e-5, 2e-5, nx * ny)
    substrate, kept = LayerKernel.dynamic(kernel, 51200.0).collaborators((nx, ny), settings)
    stairs = StaircaseLoading(z1, d, tilt)
    res = march(stairs, table, substrate, kept, settings, RunRecorder(d.size, (nx, ny)))
    n_steps = d.size
    forces = res.element_force.reshape(n_steps, -1)
    w = np.zeros((n_steps, nx * ny))
    for lag in range(min(kernel.shape[2], n_steps)):
        w[lag:] += forces[: n_steps - lag] @ lag_matrix(kernel, lag).T
    free = np.stack([stairs.free_compression(n) for n in range(n_steps)])
    assert np.max(np.abs(res.compression.reshape(n_steps, -1) - (free - w))) <= settings.tolerance * 1.001
    f_ref, _ = spring_reference(res.compression.ravel(), k, f, step, np.tile(np.arange(nx * ny), n_steps))
    np.testing.assert_allclose(forces.ravel(), f_ref, rtol=1e-13, atol=1e-13 * f_ref.max())
    first_contact = np.argmax(forces > 0, axis=0)[forces.max(axis=0) > 0]
    assert np.unique(first_contact).size > 2  # the tilt staggers the elements' first contact
    ds = contact_dataset(dataclasses.replace(res, backing_force=res.force), "dynamic", 500.0, "s", "m")
    assert ds["free_compression"].dims == ("step", "ex", "ey") and "indentation" not in ds
    with pytest.raises(ContactConvergenceError, match=r"contact step (\d+) \(stair \1\): Newton did not converge"):
        march(stairs, table, substrate, DenseHistory(kernel, (nx, ny)), SolverSettings(max_iterations=1),
              RunRecorder(d.size, (nx, ny)))
