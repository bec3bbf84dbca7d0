"""Long memory (SPEC 9): creep fit, wrap-around, tail history, and the two oracles of the spec."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tyreroad.contact import SolverSettings, solve_path
from tyreroad.greens import greens_dataset
from tyreroad.history import TailHistory, _tail_update
from tyreroad.material import material_from_config
from tyreroad.memory import TailModel, fit_retardation_spectrum, wrapped_creep
from tyreroad.influence import offset_matrix
from tyreroad.kernel import LayerKernel
from tyreroad.reference.creep import creep_by_inversion, fractional_kv_creep, mittag_leffler_neg

FS = 51200.0
TREAD = {  # the default tread of config/config.yaml
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01, "quasi_static_modulus": "zero_frequency",
}


def tread(**changes):
    return material_from_config("tread", {"tread": {**TREAD, **changes}})


def creep_oracle(t):
    return fractional_kv_creep(t, TREAD["E0"], TREAD["E1"], TREAD["alpha"], TREAD["f1"])


# --------------------------------------------------------------------------------------------
# Creep compliance: Mittag-Leffler form, numerical inversion, retardation fit
# --------------------------------------------------------------------------------------------
def test_mittag_leffler_limits_and_known_values():
    # E_1/2(-x) = exp(x^2) erfc(x); alpha -> 1 would be exp(-x)
    for x in (0.1, 1.0, 3.0):
        assert mittag_leffler_neg(x, 0.5) == pytest.approx(math.exp(x * x) * math.erfc(x), rel=1e-9)
    assert mittag_leffler_neg(0.0, 0.24) == 1.0
    # large x: E_alpha(-x) ~ x^-1 / Gamma(1 - alpha)
    assert mittag_leffler_neg(1e4, 0.24) == pytest.approx(1e-4 / math.gamma(0.76), rel=2e-3)


def test_creep_oracle_equals_numerical_inversion():
    mat = tread()
    for t in (1e-3, 1e-2, 0.1, 1.0):
        assert creep_by_inversion(mat.modulus, t) == pytest.approx(creep_oracle(t)[0], rel=1e-4)
    # the default tread is still ~15 % short of 1/E0 after 1 s (SPEC 9)
    assert 0.80 < creep_oracle(1.0)[0] * TREAD["E0"] < 0.86


def test_retardation_fit_reproduces_the_creep():
    spectrum = fit_retardation_spectrum(tread(), FS / 2)
    assert spectrum.fit_error < 1e-3
    t = np.array([1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0])
    np.testing.assert_allclose(spectrum.creep(t), creep_oracle(t), rtol=1e-5)
    assert spectrum.relaxed_compliance * TREAD["E0"] == pytest.approx(1.0, rel=1e-9)
    # increments telescope: sum over lags 0 ... n-1 is J(t_{n - 1/2})
    inc = spectrum.creep_increments(0, 5000, FS)
    assert inc.sum() == pytest.approx(float(spectrum.creep((5000 - 0.5) / FS)), rel=1e-12)
    assert np.all(inc > 0)


def test_loss_scaled_variant_is_fitted_as_nearest_causal_creep():
    """eta x 0.5 at constant |E| is not causal: the fit holds it to ~0.13, refused only for garbage."""
    mat = material_from_config("v", {"t": TREAD, "v": {"base": "t", "loss_scale": 0.5}})
    spectrum = fit_retardation_spectrum(mat, FS / 2)
    assert 0.02 < spectrum.fit_error < 0.25
    assert spectrum.relaxed_compliance * TREAD["E0"] == pytest.approx(1.0, rel=1e-6)


def test_wrapped_creep_is_the_folded_tail():
    spectrum = fit_retardation_spectrum(tread(), FS / 2)
    n_fft, n_lags = 4096, 256
    w = wrapped_creep(spectrum, n_fft, n_lags, FS)
    # brute force: sum of the creep increments at l + p N, p = 1 ... 4000 (320 s), plus the rest
    ref = np.zeros(n_lags)
    for p in range(1, 4001):
        ref += spectrum.creep_increments(p * n_fft, p * n_fft + n_lags, FS)
    rest = (spectrum.relaxed_compliance - spectrum.creep((4001 * n_fft - 0.5) / FS)) / spectrum.relaxed_compliance
    ref /= spectrum.relaxed_compliance
    # beyond 320 s the creep is so slow that it folds evenly: rest / n_fft onto every kept lag
    np.testing.assert_allclose(w - ref, rest / n_fft, rtol=1e-3)
    # the default tread still creeps after 80 ms: ~1.9 % of g(0) was folded into the kept lags
    assert 0.01 < w.sum() < 0.03


# --------------------------------------------------------------------------------------------
# Tail history against a direct sum
# --------------------------------------------------------------------------------------------
def test_tail_update_kernel_equals_numpy():
    rng = np.random.default_rng(4)
    states = rng.normal(size=(7, 30))
    decays, weights, entering = rng.uniform(0, 1, 7), rng.uniform(0, 1, 7), rng.normal(size=30)
    ref_states = decays[:, None] * states + entering[None, :]
    out = np.empty(30)
    _tail_update(states, decays, weights, entering, out)
    np.testing.assert_allclose(states, ref_states, rtol=1e-15)
    np.testing.assert_allclose(out, weights @ ref_states, rtol=1e-14)


@pytest.mark.parametrize("method", ["dense", "fft"])
def test_tail_history_equals_direct_convolution(method):
    rng = np.random.default_rng(2)
    nx, ny, n_lags, n_steps = 5, 4, 8, 60
    spectrum = fit_retardation_spectrum(tread(), FS / 2)
    r = rng.uniform(0.5, 1.0, (2 * nx - 1, 2 * ny - 1)) * 1e-6
    r = r + r[::-1] + r[:, ::-1] + r[::-1, ::-1]
    tail = TailModel.from_spectrum(r, spectrum, FS, n_lags)
    history = TailHistory(tail, (nx, ny), method)
    forces = rng.uniform(0, 3, (n_steps, nx * ny))
    c = tail.sequence(n_steps)  # c[l] for l = L ... n_steps - 1
    matrix = offset_matrix(r)
    worst = 0.0
    for n in range(n_steps):
        h = history.displacement(n)
        assert np.array_equal(history.displacement(n), h)  # asking twice does not advance the filter
        history.record(n, forces[n])
        ref = np.zeros(nx * ny)
        for lag in range(n_lags, n + 1):
            ref += c[lag - n_lags] * (matrix @ forces[n - lag])
        if n < n_lags:
            assert np.all(h == 0)
        else:
            worst = max(worst, np.max(np.abs(h - ref)) / np.max(np.abs(ref)))
    assert worst < 1e-12
    # the sequence sums to 1 (sum rule) and is positive, decreasing
    # (1 - decay) of an 18-day retardation time keeps only ~4 digits in double precision
    assert np.sum(tail.weights / (1 - tail.decays)) == pytest.approx(1.0, rel=1e-5)
    # over 20 s the tail holds the creep J(20 s) - J(t_L) of J(inf) - J(t_L): the tread still creeps then
    long = tail.sequence(n_lags + 10**6).sum()
    j = spectrum.creep(np.array([n_lags - 0.5, n_lags + 10**6 - 0.5]) / FS)
    assert long == pytest.approx((j[1] - j[0]) / (spectrum.relaxed_compliance - j[0]), rel=1e-9)
    assert np.all(np.diff(c) < 0) and np.all(c > 0)


# --------------------------------------------------------------------------------------------
# SPEC 9 oracles
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tread_greens_6x6():
    """The default tread (with its density) on a 6 x 6 patch: offsets up to 5 mm."""
    return greens_dataset(tread(), (6, 6), 1e-3, FS, 256, 4096)


def test_step_response_with_tail_is_the_creep(tread_greens_6x6):
    """Creep check: cumulative sum of the kernel with its tail -> g_static E0 J(t) once t >> h/c_s."""
    ds = tread_greens_6x6
    g = ds["g"].transpose("dx", "dy", "lag").values
    g_static = ds["g_static"].transpose("dx", "dy").values
    tail = LayerKernel.from_greens(ds, "dynamic").memory
    centre = (g.shape[0] - 1) // 2
    times = np.array([0.01, 0.1, 1.0])
    steps = np.round(times * FS).astype(int)
    c_cum = np.cumsum(tail.sequence(steps.max() + 1))
    for offset in (0, 5):  # the excitation element and a 5 mm offset
        ix = centre + offset
        kept = g[ix, centre].sum()
        for t, n in zip(times, steps):
            response = kept + tail.residual_compliance[ix, centre] * c_cum[n - tail.delay]
            expected = g_static[ix, centre] * TREAD["E0"] * creep_oracle((n + 0.5) / FS)[0]
            assert response == pytest.approx(expected, rel=5e-3), (offset, t)
    # sum rule at every offset: kept lags plus tail = g(omega = 0)
    total = g.sum(axis=2) + tail.residual_compliance
    np.testing.assert_allclose(total, g_static, rtol=1e-6)


def test_correspondence_oracle_ramp_and_hold():
    """Flat road, full contact through rigid springs, massless layer: F(t) = (K_s / E0) int E_rel(t - s) v ds."""
    n = 5
    mat = tread(density=1e-6)  # kg/m^3: a massless layer
    ds = greens_dataset(mat, (n, n), 1e-3, FS, 256, 4096)
    layer = LayerKernel.from_greens(ds, "dynamic")
    g_static = ds["g_static"].transpose("dx", "dy").values
    k_spring = 1e9  # N/m per element: rigid against the layer's ~3e4 N/m
    k_tab = np.full((n * n, 3), k_spring)
    f_tab = k_spring * 1e-3 * np.arange(3)[None, :] * np.ones((n * n, 1))
    t1, v = 2e-3, 0.1e-3 / 2e-3  # ramp to 0.1 mm in 2 ms, then hold
    time = np.arange(int(round(1.0 * FS)) + 1) / FS
    d = np.minimum(v * time, v * t1)
    z1 = np.zeros((n, n))
    res = solve_path(z1, k_tab, f_tab, 1e-3, layer, d, SolverSettings(method="dense"), time=time)
    assert np.all(res.contact_count[1:] == n * n)
    compliance = offset_matrix(g_static) + np.eye(n * n) / k_spring
    k_patch = np.linalg.solve(compliance, np.ones(n * n)).sum()  # quasi-static patch stiffness [N/m]
    e0, e1, alpha, w1 = TREAD["E0"], TREAD["E1"], TREAD["alpha"], 2 * math.pi * TREAD["f1"]

    def closed_form(t):
        tt = min(t, t1)
        fractional = t ** (1 - alpha) - (t - tt) ** (1 - alpha) if t > t1 else t ** (1 - alpha)
        return k_patch / e0 * v * (e0 * tt + e1 * w1 ** (-alpha) * fractional / math.gamma(2 - alpha))

    for t_ms, tol in ((1, 0.02), (2, 0.02), (5, 5e-3), (50, 5e-3), (500, 5e-3), (1000, 5e-3)):
        i = int(round(t_ms * 1e-3 * FS))
        assert res.force[i] == pytest.approx(closed_form(time[i]), rel=tol), t_ms
    # without the tail the same run forgets the creep after 5 ms: the relaxed force is far too high
    short = solve_path(z1, k_tab, f_tab, 1e-3, layer, d[:300], SolverSettings(method="dense"), time=time[:300])
    np.testing.assert_array_equal(short.force, res.force[:300])
    with pytest.raises(ValueError, match=r"needs 51201 steps .* greens.n_lags = 256"):
        solve_path(z1, k_tab, f_tab, 1e-3, layer, d, SolverSettings(long_memory=False), time=time)
