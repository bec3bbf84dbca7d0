"""The greens stage's checks of its kernel (issue 23): the stability margin over the unit circle (circulant
bound, patch certification) against the slow eigen-solve reference of tyreroad.cq and against a march that
chatters past it; the fidelity to the FRF; the refusal of springs past the margin."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pytest

from tyreroad import cq
from tyreroad.config import load_config
from tyreroad.contact import SolverSettings, solve_path
from tyreroad.fidelity import kernel_fidelity
from tyreroad.greens import greens_dataset
from tyreroad.influence import offset_matrix
from tyreroad.kernel import LayerKernel
from tyreroad.margin import patch_margin
from tyreroad.material import material_from_config
from tyreroad.springs import linear_tables
from tyreroad.stability import circulant_margin, fs2_alternation, nyquist_critical_stiffness

ROOT = Path(__file__).resolve().parents[1]

FS = 51200.0
SHAPE = (6, 6)


@pytest.fixture(scope="module")
def tread():
    return material_from_config("tread", load_config(ROOT / "config" / "config.yaml")["materials"])


@pytest.fixture(scope="module")
def fold_kernel(tread):
    ds = greens_dataset(tread, SHAPE, 1e-3, FS, 256, 4096, construction="fold")
    return LayerKernel.from_greens(ds, "dynamic")


def test_circulant_bound_is_below_the_patch_eigenvalue_everywhere(fold_kernel):
    """The bound's claim, checked: for random theta and phi, lambda_min Herm(e^{i phi} G_d) of the patch
    (dense eigen-solve) >= min over the circulant's eigenvalues; and it is not vacuous (within a factor
    of the truth at theta = pi)."""
    bound = circulant_margin(fold_kernel, SHAPE, n_theta=257, n_phi=1)  # phi = 0 only: the bound at phi = 0
    rng = np.random.default_rng(7)
    for i in rng.choice(bound.theta.size, 12, replace=False):
        a = offset_matrix(fold_kernel.own_frequency_response(np.array([bound.theta[i] * FS / (2 * np.pi)]),
                                                             SHAPE)[0])
        lam = np.linalg.eigvalsh(a.real)[0]
        assert lam >= bound.p_bound[i] - 1e-12 * np.abs(a).max()
    lam_pi = nyquist_critical_stiffness(fold_kernel, SHAPE)[1]
    assert lam_pi < 0
    assert bound.p_bound[-1] <= lam_pi and bound.p_bound[-1] > 3 * lam_pi


@pytest.mark.parametrize("name", ["tread-rho0.5", "tread-rho2"])
def test_rounding_does_not_certify_the_real_symbol_at_fs2(name):
    """At theta = pi the kernel's symbol G_d(-1) is real: its imaginary part is rounding (~1e-20 m/N), and the
    circulant bound at phi = +-pi/2 read a positive rounding as p > 0 (these fold kernels on 6 x 6, and tread-rho2
    on 20 x 20, were stored stable for every spring). With G_d(-1) indefinite, uniform springs of
    -1 / lambda_min(G_d(-1)) put a root at z = -1: the circulant bound must not certify theta = pi, and the
    margin there must be that spring (1e-6)."""
    material = material_from_config(name, load_config(ROOT / "config" / "config.yaml")["materials"])
    kernel = LayerKernel.from_greens(greens_dataset(material, SHAPE, 1e-3, FS, 256, 4096, construction="fold"),
                                     "dynamic")
    k_pi, lam_pi = nyquist_critical_stiffness(kernel, SHAPE)
    assert lam_pi < 0 and math.isfinite(k_pi)
    bound = circulant_margin(kernel, SHAPE, n_theta=1025)
    assert bound.theta[-1] == math.pi
    assert bound.k_bound[-1] <= k_pi * (1 + 1e-9)
    margin = patch_margin(kernel, SHAPE)
    assert margin.k_safe[-1] == pytest.approx(k_pi, rel=1e-6)
    assert margin.k_crit <= k_pi * (1 + 1e-6)


def test_patch_margin_equals_the_eigen_solve_reference(fold_kernel):
    """patch_margin (bound + Cholesky certification + full solves where needed) against
    tyreroad.cq.stability_margin (eigen-solves everywhere, phase optimised): the same k_crit, at the
    same theta, on the 6 x 6 patch of today's kernel (it fails only at fs/2: k_crit = -1/lambda_min G_d(-1))."""
    fast = patch_margin(fold_kernel, SHAPE, n_theta=1025)
    slow = cq.kernel_margin(fold_kernel, SHAPE, n_theta=1025)
    assert fast.method == "patch"
    assert fast.k_crit == pytest.approx(slow.k_crit, rel=1e-6)
    assert fast.theta_k == pytest.approx(np.pi)
    k_nyq, _ = nyquist_critical_stiffness(fold_kernel, SHAPE)
    assert fast.k_crit == pytest.approx(k_nyq, rel=1e-7)  # the phase search lands within 1e-5 rad of 0
    # every grid point the slow reference proves stable is not failing in the fast one, and vice versa
    slow_bad = np.isfinite(np.interp(fast.theta, slow.theta, np.where(np.isfinite(slow.k_safe), 1.0, np.inf)))
    assert np.array_equal(np.isfinite(fast.k_safe), slow_bad)


def test_march_chatters_past_the_stored_margin_and_not_below(fold_kernel):
    """The margin means what it says: a 6 x 6 patch on linear springs held at constant indentation for
    600 steps (a step at t = 0 excites every frequency): 0.8 k_crit decays, 1.25 k_crit alternates at fs/2 and grows."""
    k_crit = patch_margin(fold_kernel, SHAPE, n_theta=513).k_crit
    z1 = np.zeros(SHAPE)
    d = np.full(600, 2e-5)
    alternation = {}
    for factor in (0.8, 1.25):
        stiffness, force = linear_tables(36, factor * k_crit)
        run = solve_path(z1, stiffness, force, 1e-6, fold_kernel, d, SolverSettings(method="dense"))
        f = run.force
        alternation[factor] = (fs2_alternation(f[50:150], fraction=1.0), fs2_alternation(f[-100:], fraction=1.0))
    assert alternation[0.8][1] < 0.5 * alternation[0.8][0]
    # past the limit the alternation grows until the springs open (force >= 0 bounds it)
    assert alternation[1.25][1] > 0.1 and alternation[1.25][1] > 100 * alternation[0.8][1]


def test_springs_past_the_margin_are_refused_before_the_first_step(fold_kernel, caplog):
    kernel = LayerKernel(fold_kernel.lags, False, FS, fold_kernel.memory, 1e-3, name="tread",
                         critical_stiffness=1.0e4, construction="fold")
    stiffness, force = linear_tables(36, 2.0e4)
    step = 1e-6
    d = np.linspace(0, 1e-5, 20)
    with pytest.raises(ValueError, match=r"2e\+04 N/m.*k_crit = 1e\+04 N/m.*greens.construction.*solver.stability"):
        solve_path(np.zeros(SHAPE), stiffness, force, step, kernel, d, SolverSettings(method="dense"))
    with caplog.at_level(logging.WARNING):
        run = solve_path(np.zeros(SHAPE), stiffness, force, step, kernel, d,
                         SolverSettings(method="dense", stability="warn"))
    assert run.force.size == 20 and "running anyway" in caplog.text
    soft, force = linear_tables(36, 0.9e4)
    solve_path(np.zeros(SHAPE), soft, force, step, kernel, d, SolverSettings(method="dense"))


def test_fidelity_of_todays_kernel_and_of_a_wrong_one(tread, fold_kernel):
    """Today's kernel meets the FRF (0.3-0.5 % of |G_0|); the same kernel with its lags scaled by 1.02 misses
    it by 2 % (a factor the check must catch)."""
    ok = kernel_fidelity(fold_kernel, tread, SHAPE)
    assert ok.faithful and 0.001 < ok.magnitude < 0.006 and ok.phase < 0.006
    wrong = LayerKernel(1.02 * fold_kernel.lags, False, FS, fold_kernel.memory, 1e-3, name="scaled")
    bad = kernel_fidelity(wrong, tread, SHAPE)
    assert not bad.faithful and 0.015 < bad.magnitude < 0.03


def test_greens_stage_stores_margin_and_fidelity_and_refuses_an_unfaithful_kernel(tmp_path, monkeypatch, tread):
    import xarray as xr

    from tyreroad import greens as greens_module
    from tyreroad import pipeline

    cfg = load_config(ROOT / "config" / "config.yaml")
    out = tmp_path / "g.nc"
    pipeline.run_greens("tread", cfg["materials"]["tread"], {"construction": "fold"}, [6, 6], 1e-3, out)
    ds = xr.open_dataset(out)
    assert float(ds["critical_stiffness"]) == pytest.approx(
        nyquist_critical_stiffness(LayerKernel.from_greens(ds, "dynamic"), SHAPE)[0], rel=1e-7)
    assert ds["margin_spring"].sizes["theta"] == 1025 and ds.attrs["construction"] == "fold"
    assert float(ds["fidelity_magnitude"]) < 0.01
    assert LayerKernel.from_greens(ds, "dynamic").critical_stiffness == float(ds["critical_stiffness"])
    ds.close()
    # a construction that scales the FRF by 3 % is refused, and leaves no file
    real = greens_module.greens_dataset

    def scaled(*args, **kwargs):
        return real(*args, frf_map=lambda frf, omega, offsets: 1.03 * frf, **kwargs)

    monkeypatch.setattr(greens_module, "greens_dataset", scaled)
    bad = tmp_path / "bad.nc"
    with pytest.raises(ValueError, match=r"greens tread: the 'fold' kernel misses the element FRF by 3\.0"):
        pipeline.run_greens("tread", cfg["materials"]["tread"], {"construction": "fold"}, [6, 6], 1e-3, bad)
    assert not bad.exists()
    assert math.isfinite(float(xr.open_dataset(out)["critical_stiffness"]))


@pytest.fixture(scope="module")
def passive_greens(tmp_path_factory):
    import xarray as xr

    from tyreroad import pipeline

    cfg = load_config(ROOT / "config" / "config.yaml")
    out = tmp_path_factory.mktemp("passive") / "tread.nc"
    pipeline.run_greens("tread", cfg["materials"]["tread"], {"construction": "passive"}, list(SHAPE), 1e-3, out)
    return xr.open_dataset(out)


def test_default_kernel_holds_the_stiffest_default_spring_and_refuses_stiffer(passive_greens, tread):
    """Issue 23 must-show 1, scaled to 6 x 6 (benchmarks/hold_stability.py runs the 20 x 20, 100 ms case):
    the default (passive) kernel's stored k_crit is >= 1.5 x the stiffest default spring (3.96e4 N/m, the flat
    punch's plateau); a hold at 0.2 mm on springs of that stiffness stays free of fs/2 alternation (<= 1e-6 of
    the force over the hold's last fifth), where today's construction alternates; springs of 1e6 N/m are
    refused before the first step, naming the margin and the key."""
    ds = passive_greens
    assert ds.attrs["construction"] == "passive"
    kernel = LayerKernel.from_greens(ds, "dynamic", material=tread)
    assert kernel.critical_stiffness >= 1.5 * 3.96e4
    assert float(ds["fidelity_magnitude"]) <= 0.01 and float(ds["fidelity_phase"]) <= 0.01
    fold = LayerKernel.from_greens(greens_dataset(tread, SHAPE, 1e-3, FS, 256, 4096, construction="fold"),
                                   "dynamic", material=tread)
    n_load, n_hold = 102, 1500
    d = np.concatenate([np.linspace(0, 2e-4, n_load), np.full(n_hold, 2e-4)])
    z1 = np.zeros(SHAPE)
    stiffness, force = linear_tables(36, 4.0e4)
    held = solve_path(z1, stiffness, force, 1e-6, kernel, d, SolverSettings(method="dense"))
    assert fs2_alternation(held.force[n_load:]) <= 1e-6
    today = solve_path(z1, stiffness, force, 1e-6, fold, d, SolverSettings(method="dense"))
    assert fs2_alternation(today.force[n_load:]) > 1e-3
    stiff, force = linear_tables(36, 1.0e6)
    with pytest.raises(ValueError, match=r"1e\+06 N/m.*'passive' kernel, k_crit = .*greens.construction"):
        solve_path(z1, stiff, force, 1e-6, kernel, d[:20], SolverSettings(method="dense"))


# ----------------------------------------------------------------------------------------------
# the reflection blocks (tyreroad.symmetry): the same spectrum, margin and design as the whole patch matrices


def _even_table(rng, nx, ny):
    t = rng.normal(size=(nx, ny)) + 1j * rng.normal(size=(nx, ny))
    dx, dy = np.abs(np.arange(-(nx - 1), nx)), np.abs(np.arange(-(ny - 1), ny))
    return t[dx[:, None], dy[None, :]]


@pytest.mark.parametrize("shape", [(6, 6), (7, 5), (1, 4), (3, 1), (9, 8)])
def test_reflection_blocks_carry_the_whole_spectrum(shape):
    """For an offset table even in dx and dy, the blocks' spectra together are the patch matrix's, at every
    phase (odd and even sizes, a one-element axis), and the blocks' sizes add up to the patch."""
    from tyreroad.symmetry import ReflectionBlocks, is_reflection_even

    table = _even_table(np.random.default_rng(3), *shape)
    assert is_reflection_even(table)
    blocks = ReflectionBlocks(shape)
    assert sum(blocks.sizes) == shape[0] * shape[1]
    a = offset_matrix(table)
    re, im = blocks.blocks(table.real), blocks.blocks(table.imag)
    for phi in (0.0, 0.7, -np.pi / 2):
        whole = np.linalg.eigvalsh(math.cos(phi) * a.real - math.sin(phi) * a.imag)
        parts = np.sort(np.concatenate([np.linalg.eigvalsh(math.cos(phi) * b - math.sin(phi) * c)
                                        for b, c in zip(re, im)]))
        np.testing.assert_allclose(parts, whole, rtol=0, atol=1e-12 * np.abs(whole).max())


@pytest.mark.parametrize("n", [2, 5, 6])
def test_swap_blocks_hold_the_smallest_eigenvalue(n):
    """A square patch whose table is also symmetric under dx <-> dy: the swap-split blocks (the odd-even one
    left out, its spectrum is the even-odd one's) hold only eigenvalues of the patch matrix, among them the
    smallest, at every phase."""
    from tyreroad.symmetry import is_swap_symmetric, patch_blocks

    table = _even_table(np.random.default_rng(5), n, n)
    table = table + table.T
    blocks = patch_blocks(table, (n, n))
    assert blocks.swap and is_swap_symmetric(table)
    a = offset_matrix(table)
    re, im = blocks.blocks(table.real), blocks.blocks(table.imag)
    for phi in (0.0, 0.4, np.pi / 2):
        whole = np.linalg.eigvalsh(math.cos(phi) * a.real - math.sin(phi) * a.imag)
        parts = np.concatenate([np.linalg.eigvalsh(math.cos(phi) * b - math.sin(phi) * c) for b, c in zip(re, im)])
        tol = 1e-12 * np.abs(whole).max()
        assert abs(parts.min() - whole[0]) <= tol
        assert np.abs(parts[:, None] - whole[None, :]).min(axis=1).max() <= tol


@pytest.mark.parametrize("shape", [(10, 10), (11, 9)])
def test_blocks_smallest_eigenvalue_by_cholesky_equals_every_blocks_eigen_solve(shape):
    """patch_support's path for blocks above the batched size (one block eigen-solved per phase, the others
    proven above it by a shifted Cholesky factorisation): the same lambda_min as the whole patch matrix's
    eigen-solve, on a stack of tables whose smallest block changes from table to table (a guess that is wrong
    must be caught by the factorisation that fails)."""
    from tyreroad import construction
    from tyreroad.symmetry import patch_blocks

    rng = np.random.default_rng(11)
    tables = np.stack([_even_table(rng, *shape) for _ in range(12)])
    if shape[0] == shape[1]:
        tables = tables + np.swapaxes(tables, 1, 2)
    blocks = patch_blocks(tables, shape)
    assert max(blocks.sizes) > construction._BATCHED_BLOCK and len(blocks.sizes) > 1
    phi = np.linspace(-np.pi / 12, np.pi / 2, 8)
    fast = construction.patch_support(tables, shape, phi)
    whole = construction.patch_support(tables, shape, phi, symmetry=False)
    np.testing.assert_allclose(fast, whole, rtol=0, atol=1e-12 * np.abs(tables).max())
    # which block is smallest really changes along the stack, so the guess is wrong somewhere
    smallest = set()
    for k in range(tables.shape[0]):
        re, im = blocks.blocks(tables[k].real), blocks.blocks(tables[k].imag)
        smallest.add(int(np.argmin([np.linalg.eigvalsh(b)[0] for b in re])))
    assert len(smallest) > 1


def test_warm_started_lp_equals_a_cold_solve_of_every_row():
    """The design's cutting-plane LP (one HiGHS model, warm starts, fidelity rows added once violated) against
    scipy.optimize.linprog of the whole LP, round by round: rows added, phases re-picked, right-hand sides moved
    (a new target). The same optimum value (1e-9) and taps (1e-6 of their size), and every fidelity row held."""
    import scipy.optimize

    from tyreroad import construction

    rng = np.random.default_rng(2)
    n_taps, fs = 24, FS
    theta = np.linspace(2 * np.pi * 5000 / fs, np.pi, 90)
    band = np.linspace(0.0, 2 * np.pi * 5000 / fs, 60)
    e, ef = construction._fir(n_taps, theta), construction._fir(n_taps, band)
    radius = 0.02 * (1.0 + band)
    phi = np.linspace(-np.pi / 12, np.pi / 2, 8)
    h = rng.normal(-0.3, 0.3, (theta.size, phi.size))
    lp = construction._CuttingPlaneLP(e, ef, radius)

    def cold(rows_on, j, rhs):
        stab = (np.exp(1j * phi[j])[:, None] * e[rows_on]).real
        eye, zero = np.eye(n_taps), np.zeros((n_taps, 1))
        fid = [np.hstack([(np.exp(1j * psi) * ef).real, np.zeros((band.size, n_taps + 1))])
               for psi in np.arange(8) * np.pi / 4]
        a = np.vstack([np.hstack([-stab, np.zeros((rows_on.size, n_taps)), np.ones((rows_on.size, 1))])] + fid
                      + [np.hstack([eye, -eye, zero]), np.hstack([-eye, -eye, zero])])
        b = np.concatenate([rhs] + [radius] * 8 + [np.zeros(2 * n_taps)])
        cost = np.r_[np.zeros(n_taps), 1e-3 * np.ones(n_taps), -1.0]
        res = scipy.optimize.linprog(cost, A_ub=a, b_ub=b, A_eq=np.r_[np.ones(n_taps), np.zeros(n_taps + 1)][None],
                                     b_eq=[0.0], bounds=[(None, None)] * n_taps + [(0, None)] * n_taps + [(None, 1.0)],
                                     method="highs")
        assert res.status == 0
        return res

    rows_on = np.arange(0, theta.size, 6)
    j = rng.integers(0, phi.size, theta.size)
    for step in range(4):
        allowance = 0.1 * np.cos(phi) * (1.0 + step // 2)  # the third round: a softer target (larger allowance)
        rhs = h[rows_on, j[rows_on]] + allowance[j[rows_on]]
        status, _, x = lp.solve(rows_on, j[rows_on], phi, rhs)
        ref = cold(rows_on, j[rows_on], rhs)
        assert status == 0
        cost = np.r_[np.zeros(n_taps), 1e-3 * np.ones(n_taps), -1.0]
        assert cost @ x == pytest.approx(ref.fun, rel=1e-9, abs=1e-9)
        np.testing.assert_allclose(x[:n_taps], ref.x[:n_taps], rtol=0, atol=1e-6 * np.abs(ref.x[:n_taps]).max())
        delta = ef @ x[:n_taps]
        assert np.all(np.abs(delta) <= radius / math.cos(math.pi / 8) * (1 + 1e-6))
        rows_on = np.union1d(rows_on, rng.choice(theta.size, 8, replace=False))  # cutting planes
        j[rng.choice(theta.size, 10, replace=False)] = rng.integers(0, phi.size, 10)  # phases re-picked
    assert lp.solves > 4  # the fidelity rows were not all passed at first: some joined on violation


@pytest.fixture(scope="module")
def odd_kernel(tread):
    """The 7 x 5 fold kernel (stable at fs/2 on this patch) with an excitation-element FIR that makes it fail
    over a band inside the circle (0.54-0.97 pi): Delta(theta) = g_00[0] (e^{-2 i theta} - 1) (real part <= 0)."""
    fold = LayerKernel.from_greens(greens_dataset(tread, (7, 5), 1e-3, FS, 256, 4096, construction="fold"), "dynamic")
    lags = fold.lags.copy()
    cx, cy = (lags.shape[0] - 1) // 2, (lags.shape[1] - 1) // 2
    g0 = lags[cx, cy, 0]
    lags[cx, cy, 0] -= g0
    lags[cx, cy, 2] += g0
    return LayerKernel(lags, False, FS, fold.memory, 1e-3, name="fold 7 x 5, perturbed")


@pytest.mark.parametrize("which", ["fold-6x6", "fold-7x5", "passive-6x6"])
def test_block_margin_equals_the_whole_matrix_margin(which, fold_kernel, odd_kernel, passive_greens, tread):
    """patch_margin on the reflection blocks against the same algorithm on the whole patch matrices (the
    reference): the same k_crit (1e-9), at the same theta, failing on the same grid points; the passive
    kernel fails in a band inside the circle, not only at fs/2."""
    kernel, shape = {"fold-6x6": (fold_kernel, SHAPE), "fold-7x5": (odd_kernel, (7, 5)),
                     "passive-6x6": (LayerKernel.from_greens(passive_greens, "dynamic"), SHAPE)}[which]
    fast = patch_margin(kernel, shape, n_theta=513)
    slow = patch_margin(kernel, shape, n_theta=513, symmetry=False)
    assert fast.method == slow.method == "patch"
    assert math.isfinite(slow.k_crit)
    assert fast.k_crit == pytest.approx(slow.k_crit, rel=1e-9)
    assert fast.theta_k == slow.theta_k
    assert np.array_equal(np.isfinite(fast.k_safe), np.isfinite(slow.k_safe))


def test_design_on_blocks_equals_the_design_on_the_patch_matrices(fold_kernel):
    """design_correction's eigen-solves on the blocks: the same lambda_min table (to round-off) and the same
    LP outcome (slack, grid min p, sum |c|, Delta(-1)) as on the whole 6 x 6 matrices."""
    from tyreroad import construction

    mem = fold_kernel.memory
    args = (fold_kernel.lags, mem.residual_compliance, mem.weights, mem.decays)
    theta, tables = construction.transfer_tables(*args, 64)
    phi = np.linspace(-np.pi / 12, np.pi / 2, 8)
    h_blocks = construction.patch_support(tables, SHAPE, phi)
    h_whole = construction.patch_support(tables, SHAPE, phi, symmetry=False)
    np.testing.assert_allclose(h_blocks, h_whole, rtol=0, atol=1e-12 * np.abs(tables).max())
    opts = dict(shape=SHAPE, sample_rate=FS, n_theta=64, n_phi=8, k_target=1.2e5)
    fast = construction.design_correction(*args, **opts)
    slow = construction.design_correction(*args, symmetry=False, **opts)
    assert fast.slack == pytest.approx(slow.slack, rel=1e-6, abs=1e-12)
    assert fast.min_p == pytest.approx(slow.min_p, rel=1e-6)
    # the LP's optimum is not unique (degenerate vertices: round-off picks among equal-cost taps), its value is
    assert fast.sum_abs == pytest.approx(slow.sum_abs, rel=1e-6)
    assert fast.at_nyquist == pytest.approx(slow.at_nyquist, rel=1e-3)


def test_margin_from_the_designs_eigenvalues_equals_the_margin_from_its_own(tread, caplog):
    """The greens stage's margin reuses the design's lambda_min table (support + Re(e^{i phi} Delta)): on a
    6 x 6 design checked on the margin's grid, the same k_crit (1e-9) at the same theta as patch_margin without
    it (and the support used), the design's spring met, and a support that does not belong to the kernel
    (scaled by 2) refused."""
    from tyreroad import construction

    base = greens_dataset(tread, SHAPE, 1e-3, FS, 256, 4096, construction="passive")
    ds, corr = construction.correct_greens(base, shape=SHAPE, n_theta=64, n_phi=8, k_target=1.2e5, n_dense=1024,
                                           max_rounds=30)
    kernel = LayerKernel.from_greens(ds, "dynamic")
    support = corr.margin_support()
    # rows a Cholesky certified instead of an eigen-solve hold lower bounds of the kernel's own eigenvalues
    theta_s, phi_s, h_s, exact, scale_s = support
    assert exact.any() and (~exact).any()
    # the corrected tables' entry scale, which spares the margin those points' own tables
    own_tables = kernel.own_frequency_response(theta_s * FS / (2 * np.pi), SHAPE)
    own_scale = np.maximum(np.abs(own_tables.real).max(axis=(1, 2)), np.abs(own_tables.imag).max(axis=(1, 2)))
    np.testing.assert_allclose(scale_s, own_scale, rtol=1e-12)
    tables = kernel.own_frequency_response(theta_s[~exact] * FS / (2 * np.pi), SHAPE)
    own_h = construction.patch_support(tables, SHAPE, phi_s)
    assert np.all(h_s[~exact] <= own_h + 1e-12 * np.abs(own_h).max())
    assert np.all(np.isclose(h_s[~exact], own_h, rtol=1e-9, atol=0).any(axis=1) == False)  # noqa: E712 (bounds)
    with caplog.at_level(logging.INFO, logger="tyreroad.margin"):
        reused = patch_margin(kernel, SHAPE, support=support)
    used = [r.getMessage() for r in caplog.records if "from the design's eigenvalues" in r.getMessage()]
    assert used and " 0 theta from the design's eigenvalues" not in used[-1]
    own = patch_margin(kernel, SHAPE)
    assert math.isfinite(own.k_crit)
    assert reused.k_crit == pytest.approx(own.k_crit, rel=1e-9) and reused.theta_k == own.theta_k
    if corr.slack >= 0:
        assert reused.k_crit >= corr.k_target
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="tyreroad.margin"):
        wrong = patch_margin(kernel, SHAPE, support=(support[0], support[1], 2.0 * support[2]))
    assert "differs from the kernel's own matrices" in caplog.text
    assert wrong.k_crit == pytest.approx(own.k_crit, rel=1e-9)
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="tyreroad.margin"):
        wrong = patch_margin(kernel, SHAPE, support=support[:4] + (1.5 * scale_s,))
    assert "table scale differs" in caplog.text
    assert wrong.k_crit == pytest.approx(own.k_crit, rel=1e-9)


@pytest.mark.parametrize("symmetry, strip, shape", [(True, False, (6, 6)), (False, False, (5, 3)),
                                                    (True, True, (6, 3))])
def test_cholesky_certificate_agrees_with_the_eigenvalues(fold_kernel, symmetry, strip, shape):
    """patch_certify proves lambda_min > -shift exactly when the eigen-solve (patch_support) says so: a shift
    1e-6 of |lambda| above -lambda_min certifies, 1e-6 below does not (every table, three phases; a NaN pair
    is skipped and the index of the pair that succeeded is returned)."""
    from tyreroad import construction

    theta = np.linspace(0.1, 1.0, 7) * np.pi
    tables = fold_kernel.own_frequency_response(theta * FS / (2 * np.pi), shape)
    for phi in (-np.pi / 3, 0.0, 0.4 * np.pi):
        lam = construction.patch_support(tables, shape, np.array([phi]), symmetry=symmetry, strip=strip)[:, 0]
        phases = np.full((theta.size, 3), phi)
        eps = 1e-6 * np.abs(lam)
        shifts = np.stack([-lam - eps, np.full(theta.size, np.nan), -lam + eps], axis=1)
        got = construction.patch_certify(tables, shape, phases, shifts, symmetry=symmetry, strip=strip)
        assert np.all(got == 2)
        assert np.all(construction.patch_certify(tables, shape, phases[:, :1], shifts[:, :1], symmetry=symmetry,
                                                 strip=strip) == -1)


# ----------------------------------------------------------------------------------------------
# the strip bound (tyreroad.margin.strip_symbol_blocks): long patches, wrapped along, exact across


def _wrapped_matrix(table, shape):
    """The reference: the patch's offset table on a block circulant of 2 n - 1 along the long axis (dense)."""
    nx, ny = shape
    if ny > nx:
        table, nx, ny = table.T, ny, nx
    px = 2 * nx - 1
    i, j = np.divmod(np.arange(px * ny), ny)
    dx = (i[:, None] - i[None, :] + nx - 1) % px - (nx - 1)  # wrapped into -(nx - 1) ... nx - 1
    return table[dx + nx - 1, j[:, None] - j[None, :] + ny - 1]


@pytest.mark.parametrize("shape", [(9, 4), (4, 9), (8, 5), (7, 1)])
def test_strip_blocks_carry_the_wrapped_patch_spectrum(shape):
    """strip_symbol_blocks against a dense block circulant (wrapped along the long axis): the blocks' spectra,
    each wave number but 0 counted twice, are the circulant's at every phase; the patch matrix is its principal
    submatrix, so the blocks' smallest eigenvalue is below the patch's and above the two-axis circulant bound's."""
    from tyreroad.construction import circulant_lower_bound
    from tyreroad.symmetry import strip_symbol_blocks

    table = _even_table(np.random.default_rng(11), *shape)
    blocks = strip_symbol_blocks(table[None], shape)
    nx = max(shape)
    assert [b.shape[:2] for b, _ in blocks] == [(1, nx)] * len(blocks)
    wrapped = _wrapped_matrix(table, shape)
    patch = offset_matrix(table)
    for phi in (0.0, 0.9, -np.pi / 2):
        cp, sp = math.cos(phi), math.sin(phi)
        whole = np.linalg.eigvalsh(cp * wrapped.real - sp * wrapped.imag)
        eig = [np.linalg.eigvalsh(cp * b[0] - sp * c[0]) for b, c in blocks]  # (nx, m) per block type
        parts = np.sort(np.concatenate([np.concatenate([e[0], e[1:].ravel(), e[1:].ravel()]) for e in eig]))
        np.testing.assert_allclose(parts, whole, rtol=0, atol=1e-12 * np.abs(whole).max())
        lam_patch = np.linalg.eigvalsh(cp * patch.real - sp * patch.imag)[0]
        assert parts[0] <= lam_patch + 1e-12 * np.abs(whole).max()
        two_axis = circulant_lower_bound(table[None], shape, np.array([phi]), pads=[(2 * shape[0] - 1,
                                                                                  2 * shape[1] - 1)])[0, 0]
        assert two_axis <= parts[0] + 1e-12 * np.abs(whole).max()


@pytest.fixture(scope="module")
def long_kernel(tread):
    """Today's fold kernel on a long, narrow patch (30 x 6): fails at fs/2 on its patch matrices."""
    return LayerKernel.from_greens(greens_dataset(tread, (30, 6), 1e-3, FS, 256, 4096, construction="fold"),
                                   "dynamic")


def test_strip_margin_is_a_tight_lower_bound_of_the_patch_margin(long_kernel):
    """patch_margin on the strip bound (forced by a dense limit below the 30 x 6 patch's blocks of 45) against
    the patch matrices: never above (k_safe finite wherever the patch's is, k_crit not larger), and tight on a
    long strip (k_crit within 5 %; measured 2.45e4 against 2.52e4 N/m), where the two-axis circulant bound is
    not (2.00e4: below 0.9 of it)."""
    shape = (30, 6)
    patch = patch_margin(long_kernel, shape, n_theta=257)
    strip = patch_margin(long_kernel, shape, n_theta=257, max_dense=20)
    assert patch.method == "patch" and strip.method == "strip"
    assert math.isfinite(patch.k_crit)
    assert strip.k_crit <= patch.k_crit * (1 + 1e-9)
    assert strip.k_crit >= 0.95 * patch.k_crit
    assert not np.any(np.isinf(strip.k_safe) & np.isfinite(patch.k_safe))
    circ = circulant_margin(long_kernel, shape, n_theta=257)
    assert circ.k_crit < 0.9 * patch.k_crit


def test_correction_designed_on_the_strip_bound_holds_on_the_patch(long_kernel, caplog):
    """design_correction(strip=True) on the 30 x 6 fold kernel (k_crit 2.5e4 N/m on its patch matrices): the
    target met on the strip bound is met by the strip margin of the corrected kernel (which reuses the design's
    eigenvalues after checking them) and by its patch matrices, which are never below the strip bound (measured:
    k_crit 6.11e4 on the strip bound, 6.58e4 on the patch matrices)."""
    from tyreroad import construction

    shape = (30, 6)
    mem = long_kernel.memory
    corr = construction.design_correction(long_kernel.lags, mem.residual_compliance, mem.weights, mem.decays,
                                          shape=shape, sample_rate=FS, n_theta=128, n_phi=8, k_target=6e4,
                                          n_dense=256, max_rounds=30, strip=True)
    assert corr.slack >= 0
    kernel = LayerKernel(construction.apply_correction(long_kernel.lags, corr), False, FS, mem, 1e-3, name="strip")
    with caplog.at_level(logging.INFO, logger="tyreroad.margin"):
        strip = patch_margin(kernel, shape, n_theta=257, max_dense=20, support=corr.margin_support())
    assert "differs from the kernel's own" not in caplog.text
    assert " 0 theta from the design's eigenvalues" not in caplog.text
    assert "from the design's eigenvalues" in caplog.text
    own = patch_margin(kernel, shape, n_theta=257, max_dense=20)
    patch = patch_margin(kernel, shape, n_theta=257)
    assert strip.method == own.method == "strip" and patch.method == "patch"
    assert strip.k_crit == pytest.approx(own.k_crit, rel=1e-6)
    assert 6e4 <= strip.k_crit <= patch.k_crit * (1 + 1e-9)


def test_strip_support_refuses_tables_that_are_not_even():
    """The strip bound's folds assume tables even in dx and dy: others are refused, not folded wrongly."""
    from tyreroad.construction import patch_support

    table = _even_table(np.random.default_rng(2), 9, 4)
    table[0, 0] += 1.0  # dx = -8, dy = -3 only
    with pytest.raises(ValueError, match="even in dx and dy"):
        patch_support(table[None], (9, 4), np.zeros(1), strip=True)


def test_which_patches_get_the_strip_bound():
    """The default rolling strip (150 x 20, either way round) gets the strip bound; the narrow one (150 x 10,
    blocks of 375), the study's 20 x 20 and a 40 x 40 (blocks of 400) keep the patch matrices, and a footprint
    (150 x 200) is too wide for it."""
    from tyreroad.margin import uses_strip_bound

    assert uses_strip_bound((150, 20)) and uses_strip_bound((20, 150))
    assert not any(uses_strip_bound(s) for s in ((150, 10), (20, 20), (40, 40), (150, 200)))


def test_a_missed_target_hands_its_rows_to_the_next_and_the_met_one_holds(tread):
    """Targets in turn with a tight fidelity budget (1e-3): every spring (inf) is missed with 64 taps, 1e6 N/m is
    met starting from the missed target's rows, then the longer FIR (128 taps) tried once more at inf, from
    the rows both found, meets it; the margin of the corrected kernel, computed without the design's
    eigenvalues, certifies at least the softer target (and the design's own grid p > 0)."""
    from tyreroad import construction

    base = greens_dataset(tread, SHAPE, 1e-3, FS, 256, 4096, construction="passive")
    ds, corr = construction.correct_greens(base, shape=SHAPE, n_theta=64, n_phi=8, k_target=(math.inf, 1e6),
                                           fidelity_budget=1e-3, n_dense=1024, max_rounds=30, n_taps=64,
                                           longer_taps=128)
    assert any("k_target inf N/m not met" in note for note in corr.notes)
    assert corr.k_target == math.inf and corr.taps.size == 128 and corr.slack >= 0 and corr.min_p > 0
    assert corr.in_band <= 1e-3 * 1.01
    margin = patch_margin(LayerKernel.from_greens(ds, "dynamic"), SHAPE)
    assert margin.k_crit >= 1e6


def test_margin_window_covers_every_contact_inside_it_and_a_run_is_held_to_it(tread):
    """A rolling strip's kernel: the correction and the margin on a window of the strip (12 x 4 strip, 6 x 4
    window). The stored k_crit is the window's own margin (recomputed from scratch), the whole strip's margin is
    no higher (interlacing), a sub-window's no lower; a pass whose contact spans more than the window is refused
    (or, with warn, logged), one inside it is not."""
    from tyreroad.pipeline import build_greens
    from tyreroad.greens import GreensSettings

    settings = GreensSettings.from_config({"construction": "passive"})
    ds = build_greens(tread, (12, 4), 1e-3, settings, margin_window=(6, 10**6))
    assert list(ds.attrs["margin_window"]) == [6, 4]
    kernel = LayerKernel.from_greens(ds, "dynamic")
    assert kernel.margin_window == (6, 4)
    stored = float(ds["critical_stiffness"])
    window = patch_margin(kernel, (6, 4), n_theta=1025).k_crit
    # both certified lower bounds of the same k_crit (from the design's eigenvalues, or the Cholesky ladder)
    assert stored == pytest.approx(window, rel=1e-3)
    assert stored >= float(ds.attrs["spring_correction_k_target"])  # the design's target holds where it was designed
    assert patch_margin(kernel, (12, 4), n_theta=1025).k_crit <= window * (1 + 1e-3)
    assert patch_margin(kernel, (4, 4), n_theta=1025).k_crit >= window * (1 - 1e-3)
    kernel.check_contact_extent((6, 4), "refuse")  # inside: nothing
    with pytest.raises(ValueError, match=r"the contact spans 7 x 4 elements at step 9, beyond the 6 x 4 window.*"
                                         r"raise rolling.contact_window"):
        kernel.check_contact_extent((7, 4), "refuse", " at step 9")
    kernel.check_contact_extent((7, 4), "warn")  # logged, not raised
    LayerKernel.from_greens(build_greens(tread, (6, 4), 1e-3, settings), "dynamic").check_contact_extent((99, 99))


def test_a_dense_patch_wider_than_20_is_designed_on_itself():
    """The correction is designed on the matrices the margin evaluates: on a 24 x 12 patch of tread-eta0.5
    (blocks of 72, within the dense limit) the stored k_crit meets the design's target. Designed on its centre
    20 x 12, as before, the design met 1.2e5 N/m there and the patch's k_crit was 1.04e5."""
    from tyreroad.pipeline import build_greens
    from tyreroad.greens import GreensSettings

    material = material_from_config("tread-eta0.5", load_config(ROOT / "config" / "config.yaml")["materials"])
    ds = build_greens(material, (24, 12), 1e-3, GreensSettings.from_config({"construction": "passive"}))
    assert "margin_window" not in ds.attrs
    assert float(ds["critical_stiffness"]) >= float(ds.attrs["spring_correction_k_target"])
