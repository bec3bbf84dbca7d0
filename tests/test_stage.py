"""The Radau IIA-3 stage kernel (issue 23): its histories against plain sums, and the must-show: a load-and-hold
on springs of 1e6, 1e8 and 1e10 N/m runs without fs/2 alternation, where today's kernel alternates or fails;
hard contact held long reaches the quasi-static rigid-punch state."""

from __future__ import annotations

import numpy as np
import pytest

from tyreroad import radau
from tyreroad.contact import ContactConvergenceError, SolverSettings, solve_path
from tyreroad.cq import exact_frf, unique_entries
from tyreroad.greens import greens_dataset
from tyreroad.influence import offset_matrix
from tyreroad.kernel import LayerKernel
from tyreroad.material import material_from_config
from tyreroad.memory import fit_retardation_spectrum
from tyreroad.springs import linear_tables
from tyreroad.stability import fs2_alternation, nyquist_critical_stiffness
from tyreroad.stage import StageFFTHistory, StageKernel, StageTail, StageTailHistory

FS = 51200.0
C = 1e-3
SHAPE = (6, 6)
TREAD = material_from_config("tread", {"tread": {
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}})
# a tread that relaxes within a millisecond: a long hold reaches its relaxed state in a short test
FAST = material_from_config("fast", {"fast": {
    "model": "generalized_maxwell", "E_inf": 2.5e7, "moduli": [2.5e7], "relaxation_times": [2e-4],
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}})
D_HOLD = 2e-4
N_RAMP = 256


def hold_path(n_hold):
    """A raised-cosine ramp to 0.2 mm over 5 ms, then a hold."""
    ramp = D_HOLD * 0.5 * (1 - np.cos(np.pi * np.arange(1, N_RAMP + 1) / N_RAMP))
    d = np.concatenate([ramp, np.full(n_hold, D_HOLD)])
    return d, np.arange(d.size) / FS


@pytest.fixture(scope="module")
def road():
    return np.random.default_rng(3).uniform(-4e-5, 0.0, SHAPE)


@pytest.fixture(scope="module")
def stage_kernel():
    return StageKernel.from_material(TREAD, SHAPE, C, FS, 256)


def _even_tables(rng, shape, extra):
    nx, ny = shape
    t = rng.standard_normal((2 * nx - 1, 2 * ny - 1) + extra)
    return t + t[::-1] + t[:, ::-1] + t[::-1, ::-1]


def test_fft_history_equals_the_plain_stage_sum():
    rng = np.random.default_rng(0)
    shape, n_lags, steps = (3, 4), 7, 12
    m = shape[0] * shape[1]
    table = _even_tables(rng, shape, (n_lags, 3, 3))
    blocks = [np.block([[offset_matrix(table[:, :, l, i, j]) for j in range(3)] for i in range(3)])
              for l in range(n_lags)]
    hist = StageFFTHistory(table, shape)
    forces = rng.standard_normal((steps, 3 * m)) * (rng.random((steps, 3 * m)) > 0.3)
    for n in range(steps):
        expected = sum(blocks[l] @ forces[n - l] for l in range(1, min(n, n_lags - 1) + 1)) if n else np.zeros(3 * m)
        np.testing.assert_allclose(hist.displacement(n), expected, atol=1e-12 * np.abs(table).max() * 10)
        hist.record(n, forces[n])


def test_tail_is_the_radau_image_of_the_creep_terms():
    """Block weights of the tail = the CQ weights of Q sum_k J_k / (1 + s tau_k) at lags >= L, and its history is
    their plain convolution."""
    spectrum = fit_retardation_spectrum(TREAD, FS / 2)
    shape, n_lags = (2, 3), 5
    q = _even_tables(np.random.default_rng(1), shape, ())
    tail = StageTail.from_spectrum(q, spectrum, FS, n_lags)
    assert 0 < tail.r.size <= spectrum.times.size
    w = radau.radau_weights(lambda s: np.sum(tail.amplitude / (s[:, None] + tail.rates), axis=1), 40, 1 / FS)
    np.testing.assert_allclose(tail.block_weights(np.arange(n_lags, 40)), w[n_lags:],
                               atol=1e-9 * np.abs(w[n_lags]).max())
    hist = StageTailHistory(tail, shape)
    m = shape[0] * shape[1]
    bigq = offset_matrix(q)
    forces = np.random.default_rng(2).standard_normal((30, 3 * m))
    weights = tail.block_weights(np.arange(1, 30))
    for n in range(30):
        expected = np.zeros(3 * m)
        for l in range(n_lags, n + 1):
            expected += np.kron(weights[l - 1], bigq) @ forces[n - l]
        np.testing.assert_allclose(hist.displacement(n), expected, atol=1e-9 * max(np.abs(expected).max(), 1e-30))
        hist.record(n, forces[n])


def test_kernel_summary_and_truncation(stage_kernel):
    k = stage_kernel
    assert not k.static and k.n_lags == 256 and k.stage_lags.shape == (11, 11, 256, 3, 3)
    np.testing.assert_array_equal(k.lags, k.stage_lags[:, :, :, 2, :].sum(axis=-1))
    # the kept weights plus the tail's images miss little of the layer's memory
    cut = k.truncation(TREAD, (2, 2), factor=3)
    assert cut["excitation"] < 1e-5 and cut["worst"] < 1e-5
    # own transfer function (kept lags + tail) follows the exact FRF
    freq = np.geomspace(10.0, 5000.0, 30)
    own = k.own_frequency_response(freq, (3, 3))
    ratio = unique_entries(own, (3, 3)) / exact_frf(TREAD, (3, 3), C, freq)
    assert np.abs(np.abs(ratio) - 1).max() < 1e-3 and np.abs(np.angle(ratio)).max() < 1e-3
    assert k.relaxed().static
    # the stage march has no fs/2 limit for springs equal at the stages (the run's stability record says so)
    assert nyquist_critical_stiffness(k, SHAPE)[0] == np.inf


@pytest.mark.parametrize("stiffness", [1e6, 1e8, 1e10])
def test_hold_without_fs2_alternation(stage_kernel, road, stiffness):
    """The must-show of issue 23 (scaled to 6 x 6, 1500-step hold): springs far past today's k_crit hold steady."""
    d, time = hold_path(1500)
    k, f = linear_tables(road.size, stiffness)
    res = solve_path(road, k, f, 1e-6, stage_kernel, d, SolverSettings(), time=time)
    hold = res.force[N_RAMP:]
    assert fs2_alternation(hold) <= 1e-6
    assert np.all(hold > 0) and hold[-1] < hold[0]  # the tread creeps: the force relaxes at fixed d
    assert res.element_force.shape == (d.size,) + SHAPE and np.all(res.residual <= 1e-12)


@pytest.fixture(scope="module")
def today_kernel():
    return LayerKernel.from_greens(greens_dataset(TREAD, SHAPE, C, FS, 256, 4096), "dynamic")


def test_agrees_with_todays_kernel_where_that_is_stable(stage_kernel, today_kernel):
    """Springs of 1e4 N/m (below today's k_crit ~ 2.4e4 N/m), partial road contact, ramp, hold and unload: both
    kernels give the same force history to 1e-4 of its peak (measured 4e-5)."""
    road = np.random.default_rng(5).uniform(-1e-4, 0.0, SHAPE)
    d, _ = hold_path(800)
    d = np.concatenate([d, D_HOLD * 0.5 * (1 + np.cos(np.pi * np.arange(1, N_RAMP + 1) / N_RAMP))])
    time = np.arange(d.size) / FS
    k, f = linear_tables(road.size, 1e4)
    stage = solve_path(road, k, f, 1e-6, stage_kernel, d, SolverSettings(), time=time)
    today = solve_path(road, k, f, 1e-6, today_kernel, d, SolverSettings(method="dense"), time=time)
    assert np.abs(stage.force - today.force).max() < 1e-4 * today.force.max()
    assert stage.force[-1] == 0.0


def test_todays_kernel_alternates_on_the_same_case(road, today_kernel):
    """Today's kernel (256 lags + creep tail) on the same hold: an fs/2 alternation at 1e6 N/m, no
    convergence at 1e8 N/m (so the must-show above can fail)."""
    kernel = today_kernel
    d, time = hold_path(300)
    k, f = linear_tables(road.size, 1e6)
    res = solve_path(road, k, f, 1e-6, kernel, d, SolverSettings(method="dense"), time=time)
    assert fs2_alternation(res.force[N_RAMP:]) > 1e-2
    k, f = linear_tables(road.size, 1e8)
    with pytest.raises(ContactConvergenceError):
        solve_path(road, k, f, 1e-6, kernel, d, SolverSettings(method="dense"), time=time)


def test_hard_contact_reaches_the_rigid_punch_state():
    """Springs of 1e10 N/m (hard contact) on a tread that relaxes in ~0.4 ms: held 40 ms, the dynamic state is the
    quasi-static rigid-punch state of the relaxed layer (no penetration beyond F / k, no force where open)."""
    road = np.random.default_rng(5).uniform(-3e-4, 0.0, SHAPE)  # rough: a partial contact at 0.2 mm
    kernel = StageKernel.from_material(FAST, SHAPE, C, FS, 128)
    d, time = hold_path(2048)
    k, f = linear_tables(road.size, 1e10)
    res = solve_path(road, k, f, 1e-6, kernel, d, SolverSettings(), time=time)
    static = solve_path(road, k, f, 1e-6, kernel.relaxed(), [D_HOLD], SolverSettings())
    f_dyn, f_qs = res.element_force[-1], static.element_force[0]
    assert abs(res.force[-1] - static.force[0]) < 1e-6 * static.force[0]
    assert np.max(np.abs(f_dyn - f_qs)) < 1e-6 * f_qs.max()
    assert 0 < res.contact_count[-1] == static.contact_count[0] < road.size
    zeta = res.compression[-1]
    assert np.all(zeta[f_dyn > 0] <= f_dyn[f_dyn > 0] / 1e10 * (1 + 1e-9))
    assert np.all(f_dyn[zeta <= 0] == 0)
    assert fs2_alternation(res.force[N_RAMP:]) <= 1e-6


def test_nonlinear_springs_load_hold_unload(stage_kernel):
    """Stiffening springs k = 1e6 (1 + zeta / 0.1 um) N/m (1e6 ... 1e9 N/m on the table), so the stages of a step see
    different stiffnesses: a ramp-hold-unload on a partial contact converges every step, holds without fs/2
    alternation, and leaves the road."""
    road = np.random.default_rng(5).uniform(-1e-4, 0.0, SHAPE)
    step = 1e-7
    zeta = np.arange(1001) * step
    k_tab = np.broadcast_to(1e6 * (1 + zeta / 1e-7), (road.size, zeta.size)).copy()
    f_tab = np.concatenate([np.zeros((road.size, 1)), np.cumsum(0.5 * (k_tab[:, 1:] + k_tab[:, :-1]) * step,
                                                                axis=1)], axis=1)
    d, _ = hold_path(600)
    d = np.concatenate([d, D_HOLD * 0.5 * (1 + np.cos(np.pi * np.arange(1, N_RAMP + 1) / N_RAMP))])
    res = solve_path(road, k_tab, f_tab, step, stage_kernel, d, SolverSettings(), time=np.arange(d.size) / FS)
    hold = res.force[N_RAMP:N_RAMP + 600]
    assert fs2_alternation(hold) <= 1e-6
    assert 0 < res.contact_count[N_RAMP] < road.size and res.max_spring_stiffness.max() > 1e7
    assert res.force[-1] == 0.0 and np.all(res.residual <= 1e-12)


def test_dense_substrate_products():
    """The substrate's FFT product is its dense W_0; a correction solves (I + W_0 diag(k)) delta = -r exactly."""
    from tyreroad.stage import StageDenseSubstrate

    rng = np.random.default_rng(4)
    shape = (3, 4)
    table = _even_tables(rng, shape, (3, 3)) * 1e-6
    sub = StageDenseSubstrate.from_table(table, shape)
    f = rng.standard_normal(3 * 12)
    np.testing.assert_allclose(sub.instant(f), sub.g0 @ f, atol=1e-12 * np.abs(sub.g0 @ f).max())
    k = rng.uniform(0, 1e6, f.size) * (rng.random(f.size) > 0.4)
    r = rng.standard_normal(f.size) * 1e-6
    delta, _ = sub.correction(k, r, polish=False)
    np.testing.assert_allclose(delta + sub.g0 @ (k * delta), -r, atol=1e-12 * np.abs(r).max())


def test_dense_substrate_refines_changed_stiffnesses_on_its_factors():
    """Nonlinear springs and a changing contact: every polishing correction solves J(k) delta = -r to 1e-11 of r
    on one factorisation while it can: a small change of every tangent by refinement, springs changed x10,
    loaded or unloaded as Woodbury columns on the kept factors; past MAX_UPDATES columns the factors are renewed.
    A correction before the polish stops at the inexact-Newton forcing (1e-6 of ||r||_2), not before."""
    from tyreroad.stage import StageDenseSubstrate

    rng = np.random.default_rng(5)
    shape = (3, 4)
    sub = StageDenseSubstrate.from_table(_even_tables(rng, shape, (3, 3)) * 1e-6, shape)
    n = 3 * 12
    k = rng.uniform(1e5, 1e6, n) * (rng.random(n) > 0.3)
    r = rng.standard_normal(n) * 1e-6

    def exact(delta, k):
        return np.abs(delta + sub.g0 @ (k * delta) + r).max() <= 1e-11 * np.abs(r).max()

    assert exact(sub.correction(k, r, polish=True)[0], k) and sub.factorisations == 1
    k2 = k * (1 + 0.01 * rng.standard_normal(n))  # a Newton iteration's change of tangent
    loose = sub.correction(k2, r, polish=False)[0]
    misfit = np.linalg.norm(loose + sub.g0 @ (k2 * loose) + r) / np.linalg.norm(r)
    assert misfit <= sub.REFINE_FORCING and sub.factorisations == 1
    assert exact(sub.correction(k2, r, polish=True)[0], k2)
    assert (sub.factorisations, sub.refinements, sub.updates) == (1, 2, 0)
    k3 = k2.copy()
    k3[np.flatnonzero(k3)[:4]] *= 10.0
    assert exact(sub.correction(k3, r, polish=True)[0], k3)
    assert (sub.factorisations, sub.updates) == (1, 4)
    k4 = k3.copy()
    k4[np.flatnonzero(k3 == 0)[0]] = 3e5  # one more spring loaded
    k4[np.flatnonzero(k3)[-2:]] = 0.0  # two unloaded
    assert exact(sub.correction(k4, r, polish=True)[0], k4)
    assert (sub.factorisations, sub.updates) == (1, 7)
    sub.MAX_UPDATES = 8
    k5 = k4.copy()
    k5[np.flatnonzero(k4 == 0)[:2]] = 2e5  # two more: 9 columns > 8
    assert exact(sub.correction(k5, r, polish=True)[0], k5) and sub.factorisations == 2
    assert exact(sub.correction(k5, r, polish=True)[0], k5) and sub.factorisations == 2  # its own factors


def test_stage_margin_equals_a_dense_eigen_solve():
    """p(theta) of :func:`tyreroad.stage.stage_margin` (reflection blocks) against plain numpy on the 5 x 4 patch
    matrix of the exact G(s) at the three Radau eigenvalues, and positive on the whole circle (tread)."""
    from tyreroad.config import load_config
    from tyreroad.greens import element_laplace, offset_table_index, unique_offsets
    from tyreroad.influence import offset_matrix
    from tyreroad.material import material_from_config
    from tyreroad.radau import radau_delta
    from tyreroad.stage import stage_margin

    material = material_from_config("tread", load_config("config/config.yaml")["materials"])
    shape, c, fs = (5, 4), 1e-3, 51200.0
    theta, p = stage_margin(material, shape, c, fs, n_theta=8)
    assert np.all(p > 0)
    offsets = unique_offsets(shape) * c
    _, _, index = offset_table_index(shape)

    def matrix(s):
        v = element_laplace(offsets, c, np.array([s]), material.laplace_modulus(np.array([s])), material.poisson,
                            material.density, material.thickness)[0]
        return offset_matrix(v[index])

    g0 = matrix(1e-9 + 0j).real
    top = np.linalg.eigvalsh(0.5 * (g0 + g0.T))[-1]
    for k in (1, 4, 7):  # theta = pi (k + 1) / 8
        d = np.linalg.eigvals(radau_delta(np.exp(-1j * theta[k])))
        worst = min(np.linalg.eigvalsh((np.exp(1j * np.angle(s)) * matrix(s)).real)[0]
                    for s in d * fs) / top
        assert p[k] == pytest.approx(worst, rel=1e-9)
