"""FFT offset convolution, FFT history ring and the Newton-Krylov step (FFT substrate) against dense references."""

import numpy as np
import pytest

from tyreroad import springs
import scipy.fft

from tyreroad.convolution import (
    BlockJacobiPreconditioner,
    ComplianceBlockPreconditioner,
    OffsetConvolution,
    _cg_curvature,
    _cg_direction,
    _cg_update,
    _combine,
    _orthogonalize,
    _tile_block,
    compliance_cg,
    padded_shape,
    pivoted_solve,
)
from tyreroad.history import FFTHistory, _accumulate_complex, _accumulate_real
from tyreroad.newton import FFTSubstrate, StepConvergenceError, solve_step


def solve_step_newton_krylov(rhs, zeta0, table, conv, tol=1e-12, max_iter=50, block=4, krylov="auto"):
    """One matrix-free Newton step on (nx, ny) fields through the package's driver."""
    substrate = FFTSubstrate(conv, tol, block=block, krylov=krylov)
    return solve_step(np.ravel(rhs).astype(float), np.ravel(zeta0).astype(float), table, substrate, tol, max_iter)


def _dense_matrices(g, nx, ny):
    """G[lag, e, m] = g[e - m, lag] by an explicit double loop over element pairs (reference)."""
    n_lag = g.shape[2]
    mat = np.zeros((n_lag, nx * ny, nx * ny))
    for ex in range(nx):
        for ey in range(ny):
            for mx in range(nx):
                for my in range(ny):
                    mat[:, ex * ny + ey, mx * ny + my] = g[ex - mx + nx - 1, ey - my + ny - 1, :]
    return mat


def _rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize("nx, ny, n_lag, even", [(8, 8, 32, False), (7, 11, 32, False), (7, 11, 32, True)])
def test_apply_lag_equals_dense_sum(nx, ny, n_lag, even):
    rng = np.random.default_rng(1)
    # no symmetry: a transposed offset (e - m vs m - e) or swapped axes would show
    g = rng.standard_normal((2 * nx - 1, 2 * ny - 1, n_lag)) * 1e-6
    if even:  # real-spectrum path of layer-like tables
        g = g + g[::-1] + g[:, ::-1] + g[::-1, ::-1]
    forces = rng.uniform(0, 10, (nx, ny))
    conv = OffsetConvolution(g, (nx, ny), workers=2)
    assert conv.symmetric == even
    dense = _dense_matrices(g, nx, ny)
    for lag in (0, 1, 17, n_lag - 1):
        ref = (dense[lag] @ forces.ravel()).reshape(nx, ny)
        assert _rel(conv.apply_lag(forces, lag), ref) < 1e-12
    # the smallest grid that avoids wrap-around is used: 2n - 1 rounded up to a fast length
    px, py = conv.padded
    assert 2 * nx - 1 <= px < 2 * (2 * nx - 1) and 2 * ny - 1 <= py < 2 * (2 * ny - 1)


def test_padding_is_minimal_but_sufficient():
    assert padded_shape((150, 200)) == (300, 400)
    assert padded_shape((1, 1)) == (1, 1)
    # a single isolated offset at the extreme corner must not wrap onto any other element
    nx, ny = 5, 6
    g = np.zeros((2 * nx - 1, 2 * ny - 1, 1))
    g[-1, -1, 0] = 1.0  # dx = nx - 1, dy = ny - 1: only element (nx-1, ny-1) sees source (0, 0)
    f = np.zeros((nx, ny))
    f[0, 0] = 1.0
    w = OffsetConvolution(g, (nx, ny)).apply_lag(f, 0)
    expected = np.zeros((nx, ny))
    expected[-1, -1] = 1.0
    assert np.max(np.abs(w - expected)) < 1e-15


def test_larger_centred_kernel_is_cropped():
    rng = np.random.default_rng(2)
    nx, ny = 4, 5
    big = rng.standard_normal((2 * nx + 3, 2 * ny + 1, 3))
    crop = big[2:-2, 1:-1]
    f = rng.standard_normal((nx, ny))
    a = OffsetConvolution(big, (nx, ny)).apply_lag(f, 2)
    b = OffsetConvolution(crop, (nx, ny)).apply_lag(f, 2)
    assert np.max(np.abs(a - b)) < 1e-14


@pytest.mark.parametrize(
    "nx, ny, n_lag, kind", [(8, 8, 32, "random"), (7, 11, 32, "random"), (7, 11, 32, "even"), (8, 8, 32, "nearly_even")]
)
def test_history_equals_dense_sum(nx, ny, n_lag, kind):
    rng = np.random.default_rng(3)
    g = rng.standard_normal((2 * nx - 1, 2 * ny - 1, n_lag)) * 1e-6
    if kind != "random":  # even in dx and dy (to round-off), as the layer kernel
        g = g + g[::-1] + g[:, ::-1] + g[::-1, ::-1]
    if kind == "nearly_even":  # an odd part above round-off must keep the complex path
        g[0, 3, 5] += 1e-10 * np.max(np.abs(g))
    conv = OffsetConvolution(g, (nx, ny), workers=2)
    assert conv.symmetric == (kind == "even")
    acc = FFTHistory(conv)
    assert np.all(acc.displacement(0) == 0.0)
    n_steps = 45  # more than L - 1: the ring wraps around
    f_hist = rng.uniform(0, 5, (n_steps, nx, ny))
    dense = _dense_matrices(g, nx, ny)
    worst = 0.0
    for n in range(1, n_steps + 1):
        acc.record(n - 1, f_hist[n - 1])
        ref = np.zeros(nx * ny)
        for lag in range(1, min(n_lag - 1, n) + 1):
            ref += dense[lag] @ f_hist[n - lag].ravel()
        worst = max(worst, _rel(acc.displacement(n), ref))
    assert worst < 1e-12


def test_history_single_lag_is_zero():
    rng = np.random.default_rng(4)
    conv = OffsetConvolution(rng.standard_normal((5, 5, 1)), (3, 3))
    acc = FFTHistory(conv)
    acc.record(0, np.ones((3, 3)))
    acc.record(1, np.ones(9))
    assert np.all(acc.displacement(2) == 0.0)
    with pytest.raises(ValueError, match="next step to record is 2"):
        acc.record(5, np.ones(9))


def _accumulate_numpy(spectra, ring, newest, n_terms):
    depth = spectra.shape[1]
    out = np.zeros(spectra.shape[0], dtype=complex)
    for j in range(n_terms):
        out += spectra[:, j] * ring[:, (newest + j) % depth]
    return out


@pytest.mark.parametrize("newest, n_terms", [(0, 9), (3, 9), (8, 9), (5, 4), (7, 0)])
def test_accumulate_kernels_equal_numpy(newest, n_terms):
    rng = np.random.default_rng(5)
    shape = (37, 9)
    spectra = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    ring = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    out_re, out_im = np.empty(shape[0]), np.empty(shape[0])
    _accumulate_complex(spectra.real.copy(), spectra.imag.copy(), ring.real.copy(), ring.imag.copy(),
                        newest, n_terms, out_re, out_im)
    ref = _accumulate_numpy(spectra, ring, newest, n_terms)
    assert np.max(np.abs(out_re + 1j * out_im - ref)) <= 1e-13 * max(1.0, np.max(np.abs(ref)))
    _accumulate_real(spectra.real.copy(), ring.real.copy(), ring.imag.copy(), newest, n_terms, out_re, out_im)
    ref = _accumulate_numpy(spectra.real.astype(complex), ring, newest, n_terms)
    assert np.max(np.abs(out_re + 1j * out_im - ref)) <= 1e-13 * max(1.0, np.max(np.abs(ref)))


def test_gram_schmidt_kernels_equal_numpy():
    rng = np.random.default_rng(9)
    basis, _ = np.linalg.qr(rng.standard_normal((50, 6)))
    basis = np.ascontiguousarray(basis.T)  # 6 orthonormal rows
    w0 = rng.standard_normal(50)
    w = w0.copy()
    coef = np.empty(6)
    _orthogonalize(basis, w, coef)
    c1 = basis @ w0
    w_ref = w0 - c1 @ basis
    c2 = basis @ w_ref
    w_ref -= c2 @ basis
    assert np.max(np.abs(coef - (c1 + c2))) < 1e-14 and np.max(np.abs(w - w_ref)) < 1e-14
    assert np.max(np.abs(basis @ w)) < 1e-14
    out = np.empty(50)
    _combine(c1, basis, out)
    assert np.max(np.abs(out - c1 @ basis)) < 1e-14


def test_pivoted_solve_matches_numpy_and_flags_a_singular_pivot():
    rng = np.random.default_rng(12)
    a = rng.standard_normal((7, 7))
    a[[0, 3]] = a[[3, 0]] * 1e-3  # a small leading pivot: the rows must be swapped
    b = rng.standard_normal((7, 3))
    x = b.copy()
    assert pivoted_solve(a.copy(), x)
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-12, atol=1e-12)
    assert not pivoted_solve(np.zeros((2, 2)), np.ones((2, 1)))


def test_block_preconditioner_inverts_tiles():
    rng = np.random.default_rng(6)
    nx, ny, b = 7, 11, 4
    g = rng.standard_normal((2 * nx - 1, 2 * ny - 1, 1)) * 1e-5
    k = rng.uniform(0, 2e5, (nx, ny))
    k[rng.random((nx, ny)) < 0.3] = 0.0
    pre = BlockJacobiPreconditioner(OffsetConvolution(g, (nx, ny)), b)
    pre.update(k)
    r = rng.standard_normal((nx, ny))
    z = pre.solve(r)
    jac = np.eye(nx * ny) + _dense_matrices(g, nx, ny)[0] * k.ravel()[None, :]
    # dense block of J on every (clipped) tile, solved independently
    ref = np.zeros((nx, ny))
    for tx in range(0, nx, b):
        for ty in range(0, ny, b):
            ix, iy = np.meshgrid(np.arange(tx, min(tx + b, nx)), np.arange(ty, min(ty + b, ny)), indexing="ij")
            idx = (ix * ny + iy).ravel()
            ref.ravel()[idx] = np.linalg.solve(jac[np.ix_(idx, idx)], r.ravel()[idx])
    assert _rel(z, ref) < 1e-12
    pre1 = BlockJacobiPreconditioner(OffsetConvolution(g, (nx, ny)), 1)
    pre1.update(k)
    assert _rel(pre1.solve(r), r / (1.0 + g[nx - 1, ny - 1, 0] * k)) < 1e-14


@pytest.mark.parametrize("nx, ny, b", [(7, 11, 4), (5, 3, 2), (3, 4, 8), (4, 4, 1)])
def test_tile_block_is_the_lag0_matrix_of_one_tile(nx, ny, b):
    """Both block preconditioners use one tile block, G_tile[p, q] = g[x_p - x_q, y_p - y_q, 0]
    (element p of a tile at (p // by, p % by)), and the same tiling; b is clipped to the patch."""
    rng = np.random.default_rng(16)
    g = rng.standard_normal((2 * nx - 1, 2 * ny - 1, 2))  # not even: a transposed offset would show
    conv = OffsetConvolution(g, (nx, ny))
    bx, by = min(b, nx), min(b, ny)
    # the top-left tile's rows and columns of the dense lag-0 matrix (explicit double loop)
    corner = [x * ny + y for x in range(bx) for y in range(by)]
    ref = _dense_matrices(g, nx, ny)[0][np.ix_(corner, corner)]
    np.testing.assert_array_equal(_tile_block(conv.lag0, bx, by), ref)
    for cls in (BlockJacobiPreconditioner, ComplianceBlockPreconditioner):
        pre = cls(conv, b)
        assert (pre.block, pre.bx, pre.by, pre.shape) == (b, bx, by, (nx, ny))
        assert pre.tiles == (-(-nx // bx), -(-ny // by)) and pre.n_tiles == pre.tiles[0] * pre.tiles[1]
        np.testing.assert_array_equal(pre._g_tile, ref)
        with pytest.raises(RuntimeError, match=f"{cls.__name__}.solve called before update"):
            pre.solve(np.zeros((nx, ny)))
        with pytest.raises(ValueError, match="block: expected an integer >= 1, got 0"):
            cls(conv, 0)


# --- Newton-Krylov against a dense Newton solve ----------------------------------------------
def _problem(nx=12, ny=12, seed=7):
    """Rough patch on an exponentially coupled lag-0 kernel with nonlinear table springs."""
    rng = np.random.default_rng(seed)
    dx = np.arange(-(nx - 1), nx)[:, None]
    dy = np.arange(-(ny - 1), ny)[None, :]
    r = np.hypot(dx, dy)
    # exp(-r/l) is positive definite in 2-D; the amplitude makes g0 k ~ 0.3 ... 3 (strong coupling)
    g0 = 2e-5 * np.exp(-r / 2.5)
    g = np.stack([g0, 0.3 * g0], axis=-1)
    step = 1e-6
    zeta_grid = np.arange(200) * step
    k0 = rng.uniform(1e4, 5e4, (nx, ny, 1))
    k_tab = k0 * (1.0 + 3.0 * np.sqrt(zeta_grid / zeta_grid[-1]))  # kinks on every grid point
    f_tab = np.concatenate([np.zeros((nx, ny, 1)), np.cumsum(0.5 * step * (k_tab[..., 1:] + k_tab[..., :-1]), axis=-1)], -1)

    def spring_eval(z):
        return springs.evaluate(np.reshape(z, (nx, ny)), step, k_tab, f_tab)

    z1 = -rng.uniform(0, 2e-4, (nx, ny))
    rhs = z1 + 2e-4  # indentation 0.2 mm: about a third of the elements in contact
    return g, spring_eval, rhs, springs.SpringTable.checked(k_tab, f_tab, step, nx * ny)


def _dense_newton(g0mat, spring_eval, rhs):
    zeta = rhs.ravel().copy()
    b = rhs.ravel()
    for _ in range(100):
        f, k = (a.ravel() for a in spring_eval(zeta))
        r = zeta - b + g0mat @ f
        if np.max(np.abs(r)) < 1e-19:
            break
        delta = np.linalg.solve(np.eye(b.size) + g0mat * k[None, :], -r)
        lam = 1.0
        while lam > 1e-6:
            f2, _ = spring_eval(zeta + lam * delta)
            if np.linalg.norm(zeta + lam * delta - b + g0mat @ f2.ravel()) < np.linalg.norm(r):
                break
            lam *= 0.5
        zeta = zeta + lam * delta
    return zeta.reshape(rhs.shape), np.max(np.abs(r))


@pytest.mark.parametrize("block, krylov", [(1, "auto"), (4, "auto"), (4, "gmres")])
def test_newton_krylov_equals_dense_newton(block, krylov):
    nx = ny = 12
    g, spring_eval, rhs, table = _problem(nx, ny)
    conv = OffsetConvolution(g, (nx, ny))
    g0mat = _dense_matrices(g, nx, ny)[0]
    ref, ref_res = _dense_newton(g0mat, spring_eval, rhs)
    assert ref_res < 1e-18
    active = np.mean(ref > 0)
    assert 0.25 < active < 0.9  # a genuine contact problem, not all-in or all-out

    sol = solve_step_newton_krylov(rhs, rhs, table, conv, tol=1e-12, max_iter=50, block=block, krylov=krylov)
    f, _ = spring_eval(sol.zeta)
    true_res = np.max(np.abs(sol.zeta.ravel() - rhs.ravel() + g0mat @ f.ravel()))
    assert sol.residual <= 1e-12 and true_res <= 1e-12
    assert abs(true_res - sol.residual) < 1e-15
    assert _rel(sol.zeta, ref.ravel()) < 1e-8  # |R| <= 1e-12 m on zeta ~ 1e-4 m
    assert sol.newton_iterations >= 2 and sol.krylov_iterations >= sol.newton_iterations
    assert _rel(sol.force, spring_eval(sol.zeta)[0].ravel()) == 0.0

    tight = solve_step_newton_krylov(rhs, rhs, table, conv, tol=1e-15, max_iter=50, block=block, krylov=krylov)
    assert _rel(tight.zeta, ref.ravel()) < 1e-10


def test_cg_kernels_equal_numpy():
    rng = np.random.default_rng(11)
    n = 57
    p, gp, res, pre = (rng.standard_normal(n) for _ in range(4))
    k = rng.uniform(1e4, 1e6, n)
    k[rng.random(n) < 0.4] = 0.0
    kinv = np.where(k > 0, 1.0 / np.where(k > 0, k, 1.0), 0.0)
    q = np.empty(n)
    pq = _cg_curvature(p, gp, kinv, q)
    q_ref = np.where(k > 0, gp + kinv * p, 0.0)
    assert np.max(np.abs(q - q_ref)) < 1e-15 * np.max(np.abs(q_ref)) and abs(pq - p @ q_ref) < 1e-13 * abs(p @ q_ref)
    u, gu, r = rng.standard_normal(n), rng.standard_normal(n), res.copy()
    u0, gu0 = u.copy(), gu.copy()
    rr = _cg_update(0.7, p, gp, q, u, gu, r)
    assert np.max(np.abs(u - (u0 + 0.7 * p))) < 1e-15 and np.max(np.abs(gu - (gu0 + 0.7 * gp))) < 1e-15
    assert np.max(np.abs(r - (res - 0.7 * q))) < 1e-15 and abs(rr - np.sum((res - 0.7 * q) ** 2)) < 1e-12 * rr
    p2 = p.copy()
    _cg_direction(0.3, pre, p2)
    assert np.max(np.abs(p2 - (pre + 0.3 * p))) < 1e-15


@pytest.mark.parametrize("nx, ny, b", [(7, 11, 4), (9, 10, 3), (5, 6, 1)])
def test_compliance_preconditioner_solves_the_loaded_tile_blocks(nx, ny, b):
    """blockdiag((G_t[L, L] + diag(1/k_L))^-1) by Cholesky over the loaded elements, against numpy per tile."""
    g, _, _, _ = _problem(nx, ny)
    conv = OffsetConvolution(g, (nx, ny))
    rng = np.random.default_rng(15)
    k = rng.uniform(1e4, 1e10, (nx, ny))
    k[rng.random((nx, ny)) < 0.4] = 0.0
    k[:b, :b] = 0.0  # a tile without contact
    r = rng.standard_normal((nx, ny)) * (k > 0)
    pre = ComplianceBlockPreconditioner(conv, b)
    with pytest.raises(RuntimeError, match="before update"):
        pre.solve(r)
    pre.update(k)
    z = pre.solve(r)
    g0 = _dense_matrices(g, nx, ny)[0]
    ref = np.zeros((nx, ny))
    for tx in range(0, nx, b):
        for ty in range(0, ny, b):
            ix, iy = np.meshgrid(np.arange(tx, min(tx + b, nx)), np.arange(ty, min(ty + b, ny)), indexing="ij")
            idx = (ix * ny + iy).ravel()
            idx = idx[k.ravel()[idx] > 0]
            if idx.size:
                block = g0[np.ix_(idx, idx)] + np.diag(1.0 / k.ravel()[idx])
                ref.ravel()[idx] = np.linalg.solve(block, r.ravel()[idx])
    assert _rel(z, ref) < 1e-12 and np.all(z[k == 0] == 0.0)
    # the same as k (I + G_t k)^-1 of the Jacobian's tile inverses
    bj = BlockJacobiPreconditioner(conv, b)
    bj.update(k)
    assert _rel(z, k * bj.solve(r)) < 1e-10
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        ComplianceBlockPreconditioner(OffsetConvolution(-g, (nx, ny)), b).update(np.full((nx, ny), 1e12))


@pytest.mark.parametrize("block", [1, 3])
def test_compliance_cg_solves_the_jacobian(block):
    """J delta = rhs, J = I + G0 diag(k) with gaps (k = 0), against a dense solve; the residual reported is J's."""
    nx, ny = 9, 10
    g, _, _, _ = _problem(nx, ny)
    conv = OffsetConvolution(g, (nx, ny))
    assert conv.lag0_even
    rng = np.random.default_rng(12)
    k = rng.uniform(1e4, 1e9, nx * ny)  # soft to stiff
    k[rng.random(nx * ny) < 0.4] = 0.0
    rhs = rng.standard_normal(nx * ny) * 1e-6
    pre = ComplianceBlockPreconditioner(conv, block)
    pre.update(k)
    jac = np.eye(nx * ny) + _dense_matrices(g, nx, ny)[0] * k[None, :]
    ref = np.linalg.solve(jac, rhs)
    delta, u, products, rnorm = compliance_cg(lambda v: conv.apply_lag(v, 0).ravel(),
                                              lambda r, out: pre.solve(r, out=out), k, rhs, 1e-20, 500)
    assert rnorm <= 1e-20 and 0 < products <= 2 * nx * ny
    assert _rel(k * delta, k * ref) < 1e-9 and _rel(delta, ref) < 1e-9
    assert np.all(u[k == 0] == 0.0) and _rel(u, k * ref) < 1e-9  # u = k delta lives on the loaded set
    assert np.linalg.norm(jac @ delta - rhs) < 1e-8 * np.linalg.norm(rhs)
    # nothing loaded: J = I
    same = compliance_cg(lambda v: conv.apply_lag(v, 0).ravel(), lambda r, out: pre.solve(r, out=out),
                         np.zeros(nx * ny), rhs, 1e-20, 10)
    assert np.array_equal(same[0], rhs) and same[2] == 0
    # an indefinite G breaks down (None: the caller falls back to GMRES)
    neg = compliance_cg(lambda v: -conv.apply_lag(v, 0).ravel(), lambda r, out: out.__setitem__(slice(None), r),
                        np.full(nx * ny, 1e9), rhs, 1e-20, 50)
    assert neg is None


def test_pruned_spectrum_and_reused_buffers():
    rng = np.random.default_rng(13)
    nx, ny = 6, 9
    g = rng.standard_normal((2 * nx - 1, 2 * ny - 1, 2))
    conv = OffsetConvolution(g, (nx, ny))
    assert not conv.lag0_even
    f1, f2 = rng.standard_normal((2, nx, ny))
    spec = conv.spectrum(f1)
    assert np.max(np.abs(spec - scipy.fft.rfft2(f1, s=conv.padded))) < 1e-13 * np.max(np.abs(spec))
    assert _rel(conv.field(spec.copy(), overwrite=True), f1) < 1e-14
    w1 = conv.apply_lag(f1, 0).copy()
    w2 = conv.apply_lag(f2, 0)
    mat = _dense_matrices(g, nx, ny)[0]
    assert _rel(w1.ravel(), mat @ f1.ravel()) < 1e-13 and _rel(w2.ravel(), mat @ f2.ravel()) < 1e-13


def test_fft_substrate_tangent_and_predictor():
    """K = 1^T [G0|C + diag(1/k)]^-1 1 and v = dzeta/dd against dense; the predictor only for the same state."""
    nx, ny = 9, 10
    g, _, _, _ = _problem(nx, ny)
    sub = FFTSubstrate(OffsetConvolution(g, (nx, ny)), 1e-12)
    assert sub.use_cg
    rng = np.random.default_rng(14)
    k = rng.uniform(1e5, 1e10, nx * ny)
    k[rng.random(nx * ny) < 0.5] = 0.0
    act = np.flatnonzero(k)
    g0 = _dense_matrices(g, nx, ny)[0]
    u_ref = np.linalg.solve(g0[np.ix_(act, act)] + np.diag(1.0 / k[act]), np.ones(act.size))
    tangent = sub.tangent(k)
    assert abs(tangent.stiffness / u_ref.sum() - 1) < 1e-12
    v_ref = np.linalg.solve(np.eye(nx * ny) + g0 * k[None, :], np.ones(nx * ny))
    shift = np.full(nx * ny, 2e-6)
    pred = tangent.predict(shift, k)
    assert _rel(pred, 2e-6 * v_ref) < 1e-9
    assert tangent.predict(shift, np.where(k > 0, 2 * k, 0.0)) is None  # another state
    assert tangent.predict(shift * np.linspace(1, 2, nx * ny), k) is None  # not a uniform shift
    assert sub.tangent_products > 0
    assert sub.tangent(np.zeros(nx * ny)).stiffness == 0.0
    # G0 F from the cache equals a fresh product
    f = rng.standard_normal(nx * ny)
    w = sub.instant(f)
    w[:] = 0.0  # the caller's copy
    assert _rel(sub.instant(f), g0 @ f) < 1e-13
    # GMRES (asked for here; the path of a lag-0 table that is not even): the same K, no predictor
    gm = FFTSubstrate(OffsetConvolution(g, (nx, ny)), 1e-12, krylov="gmres")
    assert not gm.use_cg
    by_gmres = gm.tangent(k)
    assert abs(by_gmres.stiffness / u_ref.sum() - 1) < 1e-9 and by_gmres.direction is None
    with pytest.raises(ValueError, match="krylov"):
        FFTSubstrate(OffsetConvolution(g, (nx, ny)), 1e-12, krylov="cg")


def test_fft_substrate_falls_back_to_gmres_with_fresh_tiles(caplog):
    """A correction CG cannot take (here a negative stiffness) after CG corrections of the same step:
    GMRES with tiles built for this stiffness, the dense solution, and one warning."""
    nx, ny = 9, 10
    g, _, _, _ = _problem(nx, ny)
    sub = FFTSubstrate(OffsetConvolution(g, (nx, ny)), 1e-14, refresh_after=100)
    assert sub.use_cg
    g0 = _dense_matrices(g, nx, ny)[0]
    rng = np.random.default_rng(21)
    k = rng.uniform(1e4, 5e4, nx * ny)
    r = rng.standard_normal(nx * ny) * 1e-6
    sub.begin_step()
    delta, products = sub.correction(k, r, polish=False)
    assert 0 < products <= sub.refresh_after  # few products: GMRES would have kept its (absent) tiles
    assert _rel(delta, np.linalg.solve(np.eye(nx * ny) + g0 * k[None, :], -r)) < 1e-6
    k2 = k.copy()
    k2[0] = -1e3
    with caplog.at_level("WARNING", logger="tyreroad.newton"):
        delta2, _ = sub.correction(k2, r, polish=False)
        sub.correction(k2, r, polish=False)
    assert _rel(delta2, np.linalg.solve(np.eye(nx * ny) + g0 * k2[None, :], -r)) < 1e-6
    assert sum("GMRES takes such corrections" in m for m in caplog.messages) == 1


def test_newton_krylov_warm_start_and_failure():
    nx = ny = 12
    g, spring_eval, rhs, table = _problem(nx, ny, seed=8)
    conv = OffsetConvolution(g, (nx, ny))
    sol = solve_step_newton_krylov(rhs, rhs, table, conv)
    again = solve_step_newton_krylov(rhs, sol.zeta, table, conv)
    assert again.newton_iterations == 0 and again.krylov_iterations == 0
    with pytest.raises(StepConvergenceError, match="did not converge in 1 iterations"):
        solve_step_newton_krylov(rhs, np.zeros_like(rhs), table, conv, max_iter=1)


def test_bad_input_is_named():
    g = np.zeros((5, 5, 2))
    with pytest.raises(ValueError, match="offset axis 0"):
        OffsetConvolution(g, (4, 3))
    conv = OffsetConvolution(g, (3, 3))
    with pytest.raises(ValueError, match="lag"):
        conv.apply_lag(np.zeros((3, 3)), 2)
    with pytest.raises(ValueError, match="forces"):
        conv.apply_lag(np.zeros((3, 4)), 0)
    with pytest.raises(ValueError, match="workers"):
        OffsetConvolution(g, (3, 3), workers=0)
    with pytest.raises(ValueError, match="NaN"):
        OffsetConvolution(np.full((5, 5, 1), np.nan), (3, 3))
