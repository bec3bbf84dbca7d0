"""Tests of tyreroad.layer: the stable layer compliance against extended precision and its limits (SPEC 5)."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from tyreroad.layer import (
    _branch_sqrt,
    _compliance_numpy,
    _shc,
    backing_force_transfer,
    compliance,
    halfspace_compliance,
    laplace_compliance,
    static_compliance,
    static_layer_factor,
)
from tyreroad.material import FractionalKelvinVoigt, GeneralizedMaxwell
from tyreroad.reference.layer1d import (
    layer1d_compliance,
    layer1d_static_compliance,
    pwave_modulus,
    rayleigh_speed_ratio,
)

H = 0.01  # m
RHO = 1100.0  # kg/m^3
NUS = (0.45, 0.49, 0.4999)
ETAS = (0.01, 0.3)
KH = np.geomspace(1e-3, 500.0, 12)
FREQ = np.geomspace(1e-3, 25600.0, 8)
# |E| rising from 20 to 100 MPa over the frequency grid: exercises modulus broadcast with omega
ABS_E = np.geomspace(20e6, 100e6, FREQ.size)


def _mp_closed_form(k, w, e, nu, rho, h):
    """SPEC 5 closed form, literally, in mpmath (the working precision must cover the cancellation)."""
    w = mp.mpf(float(w))
    return _mp_closed_form_w2(k, w**2, e, nu, rho, h)


def _mp_closed_form_w2(k, w2, e, nu, rho, h):
    """:func:`_mp_closed_form` with omega^2 given (complex in the Laplace domain: omega^2 = -s^2)."""
    k, nu, rho, h = (mp.mpf(float(v)) for v in (k, nu, rho, h))
    e = mp.mpc(complex(e))
    mu = e / (2 * (1 + nu))
    m = e * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    es, ep = rho * w2 / mu, rho * w2 / m
    a, b = mp.sqrt(k**2 - ep), mp.sqrt(k**2 - es)
    q = 2 * k**2 - es
    sa, ca, sb, cb = mp.sinh(a * h), mp.cosh(a * h), mp.sinh(b * h), mp.cosh(b * h)
    num = a * es * (k**2 * ca * sb - a * b * sa * cb)
    den = mu * (a * b * (q**2 + 4 * k**4) * ca * cb - k**2 * (q**2 + 4 * a**2 * b**2) * sa * sb - 4 * a * b * k**2 * q)
    return num / den


def _mp_halfspace(k, w, e, nu, rho):
    k, w, nu, rho = (mp.mpf(float(v)) for v in (k, w, nu, rho))
    e = mp.mpc(complex(e))
    mu = e / (2 * (1 + nu))
    m = e * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    es, ep = rho * w**2 / mu, rho * w**2 / m
    a, b = mp.sqrt(k**2 - ep), mp.sqrt(k**2 - es)
    q = 2 * k**2 - es
    return a * es / (mu * (4 * k**2 * a * b - q**2))


def _digits_needed(kh, w, e, nu):
    """Working precision: the closed form cancels ~2 log10((kh)^2 / |eps_p h^2|) digits as w -> 0."""
    e_p = RHO * (w * H) ** 2 / abs(complex(pwave_modulus(e, nu)))
    return 40 + int(2 * np.log10(max(1.0, (kh * kh + 1.0) / e_p)))


@pytest.fixture(scope="module")
def mp_grid():
    """H on the 12 kh x 8 f x 3 nu x 2 eta grid at two mpmath precisions (computed once)."""
    kk, ff = np.meshgrid(KH / H, FREQ, indexing="ij")
    ww = 2 * np.pi * ff
    out = {}
    for nu in NUS:
        for eta in ETAS:
            e = ABS_E * (1 + 1j * eta) / np.sqrt(1 + eta**2)
            ref = np.empty(kk.shape, complex)
            ref_hi = np.empty(kk.shape, complex)
            for i in range(kk.shape[0]):
                for j in range(kk.shape[1]):
                    dps = _digits_needed(KH[i], ww[i, j], e[j], nu)
                    with mp.workdps(dps):
                        ref[i, j] = complex(_mp_closed_form(kk[i, j], ww[i, j], e[j], nu, RHO, H))
                    with mp.workdps(dps + 25):
                        ref_hi[i, j] = complex(_mp_closed_form(kk[i, j], ww[i, j], e[j], nu, RHO, H))
            out[nu, eta] = (kk, ww, e, ref, ref_hi)
    return out


@pytest.mark.parametrize("nu", NUS)
@pytest.mark.parametrize("eta", ETAS)
def test_compliance_matches_extended_precision(mp_grid, nu, eta):
    kk, ww, e, ref, ref_hi = mp_grid[nu, eta]
    # the reference is converged: 25 more digits change nothing
    assert np.max(np.abs(ref_hi - ref) / np.abs(ref)) < 1e-15
    got = compliance(kk, ww, e[None, :], nu, RHO, H)
    assert got.shape == kk.shape
    rel = np.abs(got - ref) / np.abs(ref)
    # measured worst 1.9e-12 (nu = 0.4999, small kh: the static numerator (3-4nu) sinh 2x - 2x cancels)
    assert rel.max() < 1e-10, (rel.max(), np.unravel_index(rel.argmax(), rel.shape))


def test_halfspace_matches_extended_precision():
    nu, eta = 0.49, 0.05
    e = 50e6 * (1 + 1j * eta)
    kk, ww = np.meshgrid(np.geomspace(1e-1, 1e5, 15), 2 * np.pi * np.geomspace(1e-3, 25600, 9), indexing="ij")
    got = halfspace_compliance(kk, ww, e, nu, RHO)
    ref = np.empty(kk.shape, complex)
    for idx in np.ndindex(kk.shape):
        e_p = RHO * ww[idx] ** 2 / abs(complex(pwave_modulus(e, nu)))
        with mp.workdps(40 + int(2 * np.log10(max(1.0, (kk[idx] ** 2 + 1) / e_p)))):
            ref[idx] = complex(_mp_halfspace(kk[idx], ww[idx], e, nu, RHO))
    assert np.max(np.abs(got - ref) / np.abs(ref)) < 1e-12


@pytest.mark.parametrize("nu", NUS)
@pytest.mark.parametrize("eta", (0.0, 0.01, 0.3))
def test_k_zero_is_one_dimensional_layer(nu, eta):
    w = 2 * np.pi * np.concatenate([[0.0], np.geomspace(1e-3, 25600.0, 200)])
    e = np.geomspace(20e6, 100e6, w.size) * (1 + 1j * eta)
    got = compliance(0.0, w, e, nu, RHO, H)
    ref = layer1d_compliance(w, e, nu, RHO, H)
    assert np.max(np.abs(got - ref) / np.abs(ref)) < 1e-12
    assert got[0] == pytest.approx(complex(layer1d_static_compliance(e[0], nu, H)), rel=1e-15)


@pytest.mark.parametrize("nu", NUS)
def test_static_limits(nu):
    e = 22e6
    # omega = 0 exactly: the stable form reproduces the independent static formula
    k = np.geomspace(1e-3, 500.0, 60) / H
    h0 = static_compliance(k, e, nu, H)
    assert np.max(np.abs(compliance(k, 0.0, e, nu, RHO, H) - h0) / h0) < 1e-12
    # omega -> 0 (1 mHz, a damped modulus with the same real part): dynamic -> static
    e_dyn = e * (1 + 0.3j)
    h0c = static_compliance(k, e_dyn, nu, H)
    assert np.max(np.abs(compliance(k, 2 * np.pi * 1e-3, e_dyn, nu, RHO, H) - h0c) / np.abs(h0c)) < 1e-9
    # static formula itself, literally, where it is harmless (0.05 <= kh <= 5)
    x = np.linspace(0.05, 5, 40)
    lit = ((3 - 4 * nu) * np.sinh(2 * x) - 2 * x) / ((3 - 4 * nu) * np.cosh(2 * x) + 2 * x**2 + 5 - 12 * nu + 8 * nu**2)
    assert np.allclose(static_compliance(x / H, e, nu, H), 2 * (1 - nu**2) / (e * x / H) * lit, rtol=1e-13, atol=0)
    # kh -> inf: half-space 2 (1 - nu^2) / (E k)
    kbig = np.array([300.0, 500.0, 5e3]) / H
    assert np.allclose(static_compliance(kbig, e, nu, H), 2 * (1 - nu**2) / (e * kbig), rtol=1e-14, atol=0)
    # kh -> 0: h / M, with relative correction O((kh)^2)
    hm = float(layer1d_static_compliance(e, nu, H))
    assert static_compliance(0.0, e, nu, H) == pytest.approx(hm, rel=1e-15)
    assert static_compliance(1e-6 / H, e, nu, H) == pytest.approx(hm, rel=1e-10)
    assert compliance(1e-6 / H, 2 * np.pi * 1e-3, e * (1 + 0.3j), nu, RHO, H) == pytest.approx(
        complex(layer1d_static_compliance(e * (1 + 0.3j), nu, H)), rel=1e-10
    )
    assert compliance(0.0, 0.0, e, nu, RHO, H) == pytest.approx(hm, rel=1e-15)


@pytest.mark.parametrize("nu", NUS)
def test_large_kh_is_dynamic_halfspace(nu):
    e = np.geomspace(20e6, 100e6, 30) * (1 + 0.2j)
    w = 2 * np.pi * np.geomspace(1e-3, 25600.0, 30)
    for kh in (50.0, 500.0):
        got = compliance(kh / H, w, e, nu, RHO, H)
        ref = halfspace_compliance(kh / H, w, e, nu, RHO)
        assert np.max(np.abs(got - ref) / np.abs(ref)) < 1e-13
    # static half-space and the 1-D half-space impedance at k = 0
    k = np.geomspace(1.0, 1e5, 20)
    assert np.allclose(halfspace_compliance(k, 0.0, 22e6, nu, RHO), 2 * (1 - nu**2) / (22e6 * k), rtol=1e-14, atol=0)
    c_p = np.sqrt(pwave_modulus(e, nu) / RHO)
    assert np.allclose(halfspace_compliance(0.0, w, e, nu, RHO), -1j / (RHO * c_p * w), rtol=1e-14, atol=0)


def test_rayleigh_speed_oracle():
    assert round(rayleigh_speed_ratio(0.49), 4) == 0.9541
    assert round(rayleigh_speed_ratio(0.25), 4) == 0.9194  # classic value for nu = 1/4
    # for nu = 1/4 the root is known in closed form: xi^2 = 2 - 2/sqrt(3)
    assert rayleigh_speed_ratio(0.25) == pytest.approx(np.sqrt(2 - 2 / np.sqrt(3)), rel=1e-14)


@pytest.mark.parametrize("nu", (0.25, 0.49))
def test_halfspace_rayleigh_pole(nu):
    e_abs, w = 50e6, 2 * np.pi * 2000.0
    mu = e_abs / (2 * (1 + nu))
    k_r = w / (rayleigh_speed_ratio(nu) * np.sqrt(mu / RHO))
    # lossless: 4 k^2 alpha beta - Q^2 vanishes at k_R
    eps_s, eps_p = RHO * w**2 / mu, RHO * w**2 / complex(pwave_modulus(e_abs, nu))
    a, b = np.sqrt(k_r**2 - eps_p), np.sqrt(k_r**2 - eps_s)
    q = 2 * k_r**2 - eps_s
    assert abs(4 * k_r**2 * a * b - q**2) < 1e-12 * q**2
    # small loss: |H| peaks at k_R (grid step 1e-5 relative); the layer with kh >> 1 peaks there too
    k = k_r * np.linspace(0.99, 1.01, 2001)
    e = e_abs * (1 + 1e-4j)
    peak = k[np.argmax(np.abs(halfspace_compliance(k, w, e, nu, RHO)))]
    assert peak / k_r == pytest.approx(1.0, abs=2e-5)
    h_thick = 1.0  # kh ~ 90 at k_R
    peak_layer = k[np.argmax(np.abs(compliance(k, w, e, nu, RHO, h_thick)))]
    assert peak_layer / k_r == pytest.approx(1.0, abs=2e-5)


def test_passive_on_random_grid():
    rng = np.random.default_rng(12345)
    n = 20000
    nu = rng.uniform(0.05, 0.4999, n)
    h = 10 ** rng.uniform(-3, -1, n)
    e = 10 ** rng.uniform(6, 9, n) * (1 + 1j * 10 ** rng.uniform(-4, 0, n))
    k = np.where(rng.random(n) < 0.05, 0.0, 10 ** rng.uniform(-3, 3, n) / h)
    w = 2 * np.pi * 10 ** rng.uniform(-3, 5, n)
    rho = 10 ** rng.uniform(2.5, 3.5, n)
    got = np.array([compliance(k[i], w[i], e[i], nu[i], rho[i], h[i]) for i in range(0, n, 200)])
    assert np.all(np.isfinite(got))
    assert np.all(got.imag <= 0.0)
    # vectorised over everything except the scalar material constants
    for nu_i in (0.1, 0.49, 0.4999):
        hv = compliance(k, w, e, nu_i, RHO, H)
        assert np.all(np.isfinite(hv)) and np.all(hv.imag <= 0.0)
        hv = compliance(k, w, e, nu_i, RHO, 0.1)
        assert np.all(np.isfinite(hv)) and np.all(hv.imag <= 0.0)


def test_broadcasting_matches_pointwise():
    k = np.geomspace(1.0, 1e5, 7)[:, None]
    w = 2 * np.pi * np.array([0.0, 10.0, 1e3, 2e4])
    e = np.array([22e6, 30e6 + 5e6j, 50e6 + 12e6j, 100e6 + 30e6j])
    got = compliance(k, w, e, 0.49, RHO, H)
    assert got.shape == (7, 4)
    for i in range(7):
        for j in range(4):
            assert got[i, j] == pytest.approx(compliance(k[i, 0], w[j], e[j], 0.49, RHO, H), rel=1e-14)


def test_backing_force_transfer_consistent_with_k0_compliance():
    # 1-D layer: base/surface stress = 1/cos(kappa h) and H(0) = tan(kappa h)/(M kappa): 1/cos^2 = 1 + tan^2
    w = 2 * np.pi * np.geomspace(1.0, 25600.0, 50)
    e = 50e6 * (1 + 0.2j)
    nu = 0.49
    m = complex(pwave_modulus(e, nu))
    kappa = w / np.sqrt(m / RHO)
    t = backing_force_transfer(w, e, nu, RHO, H)
    tan = compliance(0.0, w, e, nu, RHO, H) * m * kappa
    assert np.allclose(t**2, 1 + tan**2, rtol=1e-10, atol=0)
    assert backing_force_transfer(0.0, e, nu, RHO, H) == 1.0
    # first thickness resonance of the lossless layer: |transfer| blows up at w h / c_p = pi / 2
    w_res = 0.5 * np.pi * np.sqrt(m.real / RHO) / H
    assert abs(backing_force_transfer(w_res * (1 - 1e-9), 50e6, nu, RHO, H)) > 1e8


def test_kernel_matches_numpy_reference():
    """The numba kernel and the plain-numpy version of the same stable form agree to round-off."""
    rng = np.random.default_rng(7)
    n = 5000
    nu = 0.49
    r = (1 - 2 * nu) / (2 * (1 - nu))
    x = np.where(rng.random(n) < 0.05, 0.0, 10 ** rng.uniform(-4, 3, n))
    e = 10 ** rng.uniform(6.5, 8.5, n) * (1 + 1j * rng.choice([0.0, 1e-3, 0.3, 1.0], n))
    mu = e / (2 * (1 + nu))
    w = np.where(rng.random(n) < 0.05, 0.0, 2 * np.pi * 10 ** rng.uniform(-3, 5, n))
    x[0], w[0] = 0.0, 0.0  # the origin k = w = 0
    got = compliance(x / H, w, e, nu, RHO, H)
    ref = _compliance_numpy(x, RHO * (w * H) ** 2 / mu, mu, r, H)
    assert np.all(np.isfinite(ref))
    # both are ~1e-12 accurate (mpmath test); they differ by round-off amplified in the small-kh
    # cancellation of the static numerator (measured 2.5e-13)
    assert np.max(np.abs(got - ref) / np.abs(ref)) < 1e-11


def test_helpers():
    z = np.array([0.0, 1e-8 + 1e-9j, 0.05 - 0.07j, 0.099j, 0.3 + 2j, 5 - 40j])
    ref = [1.0 if v == 0 else complex(mp.sinh(mp.mpc(complex(v))) / mp.mpc(complex(v))) for v in z]
    assert np.allclose(_shc(z), ref, rtol=1e-15, atol=0)
    s = _branch_sqrt(np.array([complex(-4.0, -0.0), complex(-4.0, 0.0), 4.0 + 1e-3j]))
    assert s[0] == 2j and s[1] == 2j and s[2].real > 0


def test_static_layer_factor_limits():
    # L ~ kh (1 - 2 nu) / (2 (1 - nu)^2) as kh -> 0 and -> 1 as kh -> inf
    for nu in NUS:
        assert static_layer_factor(1e-8, nu) / 1e-8 == pytest.approx((1 - 2 * nu) / (2 * (1 - nu) ** 2), rel=1e-9)
        assert static_layer_factor(400.0, nu) == pytest.approx(1.0, rel=1e-15)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"k": -1.0}, "k: expected finite values >= 0"),
        ({"omega": -1.0}, "omega: expected finite values >= 0"),
        ({"modulus": 1e6 - 1e5j}, "modulus"),
        ({"poisson": 0.5}, "poisson"),
        ({"density": 0.0}, "density"),
        ({"thickness": -0.01}, "thickness"),
    ],
)
def test_compliance_rejects_bad_input(kwargs, match):
    args = {"k": 1.0, "omega": 1.0, "modulus": 1e6, "poisson": 0.49, "density": RHO, "thickness": H}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        compliance(**args)


# ---------------------------------------------------------------------------------------------- Laplace domain
# H(k, s) at complex s, Re s >= 0 (convolution quadrature, issue 23)

LAPLACE_MODELS = {
    "fractional": FractionalKelvinVoigt(25e6, 50e6, 0.24, 1000.0),
    "maxwell": GeneralizedMaxwell(20e6, (8e6, 15e6, 12e6, 25e6, 30e6), (3e-2, 2e-3, 3.3e-4, 4e-5, 6e-6)),
}
# |s| from 1e2 to 1e5 rad/s, arg s from -45 to 85 degrees
S_MAG = (1e2, 1e3, 1e4, 1e5)
S_ARG = (-45.0, 0.0, 30.0, 60.0, 85.0)
S_RHP = np.array([m * np.exp(1j * np.deg2rad(a)) for m in S_MAG for a in S_ARG])
KH_LAPLACE = np.array([0.0, 0.1, 1.0, 10.0, 100.0])


@pytest.mark.parametrize("model", LAPLACE_MODELS.values(), ids=LAPLACE_MODELS.keys())
@pytest.mark.parametrize("nu", NUS)
def test_laplace_compliance_on_the_frequency_axis_is_the_compliance(model, nu):
    w = 2 * np.pi * FREQ[:, None]
    k = KH[None, :] / H
    expected = compliance(k, w, model.modulus(w), nu, RHO, H)
    # same E: the same kernel on the same e_s
    same = laplace_compliance(k, 1j * w, model.modulus(w), nu, RHO, H)
    assert np.max(np.abs(same - expected) / np.abs(expected)) < 1e-14
    # E(s) by continuation: differs from modulus(w) by rounding only
    cont = laplace_compliance(k, 1j * w, model.laplace_modulus(1j * w), nu, RHO, H)
    assert np.max(np.abs(cont - expected) / np.abs(expected)) < 1e-12


@pytest.mark.parametrize("model", LAPLACE_MODELS.values(), ids=LAPLACE_MODELS.keys())
@pytest.mark.parametrize("nu", NUS)
def test_laplace_compliance_is_analytic(model, nu):
    """Cauchy-Riemann by central differences: dH/ds along Re s equals dH/ds along Im s.

    A non-analytic step (a root or power on the wrong branch, |s| or conj(s) instead of s) gives an O(1)
    mismatch; the analytic function gives the O(step^2) truncation error (measured <= 6e-7)."""
    k = KH_LAPLACE[:, None] / H
    worst = 0.0
    for s0 in S_RHP:
        d = 1e-4 * abs(s0)
        s = np.array([s0 + d, s0 - d, s0 + 1j * d, s0 - 1j * d, s0])
        g = laplace_compliance(k, s[None, :], model.laplace_modulus(s)[None, :], nu, RHO, H)
        along_re = (g[:, 0] - g[:, 1]) / (2 * d)
        along_im = (g[:, 2] - g[:, 3]) / (2j * d)
        scale = np.maximum(np.abs(along_re), np.abs(g[:, 4]) / abs(s0))
        worst = max(worst, float(np.max(np.abs(along_re - along_im) / scale)))
    assert worst < 1e-5


def test_laplace_branch_decays_and_continues_from_the_frequency_axis():
    model = LAPLACE_MODELS["fractional"]
    nu = 0.49
    r = (1 - 2 * nu) / (2 * (1 - nu))
    s = np.concatenate([S_RHP, np.geomspace(1e2, 1e6, 5)])
    mu = model.laplace_modulus(s) / (2 * (1 + nu))
    e_s = -RHO * (s * H) ** 2 / mu
    for x in KH_LAPLACE:
        for ratio in (r, 1.0):
            z = x * x - ratio * e_s
            # the root's argument stays in the half plane of Im s (on the positive real axis for real s):
            # it never reaches the cut of the principal root, so the root is analytic and decays
            assert np.all(z.imag * s.imag >= 0) and np.all(z.imag[s.imag == 0] == 0)
            assert np.all(z.real[s.imag == 0] > 0)
            assert np.all(_branch_sqrt(z).real > 0)
    # continuity onto the axis: H(k, eps + i w) -> compliance(k, w) linearly in eps
    w = 2 * np.pi * np.array([100.0, 3000.0, 20000.0])
    k = np.array([0.0, 50.0, 500.0, 5000.0])[:, None]
    on_axis = compliance(k, w, model.modulus(w), nu, RHO, H)
    errors = []
    for eps in (1e-2, 1e-4, 1e-6):
        s = eps * w + 1j * w
        near = laplace_compliance(k, s, model.laplace_modulus(s), nu, RHO, H)
        errors.append(np.max(np.abs(near - on_axis) / np.abs(on_axis)))
    assert errors[2] < 1e-4 and errors[1] / errors[2] == pytest.approx(100, rel=0.1)


@pytest.mark.parametrize("model", LAPLACE_MODELS.values(), ids=LAPLACE_MODELS.keys())
def test_laplace_compliance_reflection_real_axis_and_static_limit(model):
    nu = 0.49
    k = KH[:, None] / H
    s = S_RHP[None, :]
    g = laplace_compliance(k, s, model.laplace_modulus(s), nu, RHO, H)
    gc = laplace_compliance(k, np.conj(s), model.laplace_modulus(np.conj(s)), nu, RHO, H)
    np.testing.assert_allclose(gc, np.conj(g), rtol=1e-13, atol=0)
    # passive: the mobility s H is positive real (Re s H > 0 for Re s > 0)
    assert np.all((s * g).real > 0)
    # real s: real and positive; s = 0: the static compliance with E(0)
    sr = np.geomspace(1e-1, 1e6, 15)[None, :]
    gr = laplace_compliance(k, sr, model.laplace_modulus(sr), nu, RHO, H)
    assert np.all(gr.imag == 0) and np.all(gr.real > 0)
    e0 = model.laplace_modulus(0.0).real
    g0 = laplace_compliance(KH / H, 0.0, model.laplace_modulus(0.0), nu, RHO, H)
    np.testing.assert_allclose(g0, static_compliance(KH / H, e0, nu, H), rtol=1e-13, atol=0)


def _mp_laplace_closed_form(k, s, e, nu, rho, h):
    """SPEC 5 closed form in mpmath with eps_s = -rho s^2 / mu(s) (w^2 = -s^2)."""
    s = mp.mpc(complex(s))
    return _mp_closed_form_w2(k, -(s**2), e, nu, rho, h)


@pytest.mark.parametrize("nu", NUS)
def test_laplace_compliance_matches_extended_precision(nu):
    """The stable form off the frequency axis against the literal closed form in mpmath (measured 1.1e-12 at
    nu = 0.4999, 1.4e-14 at 0.49: the physical small-kh cancellation of the static numerator, as on the axis)."""
    model = LAPLACE_MODELS["fractional"]
    kh = np.array([1e-3, 0.05, 1.0, 7.0, 60.0, 500.0])
    s = np.outer([1e-1, 1e2, 1e4, 1.6e5], np.exp(1j * np.deg2rad([-60.0, 0.0, 45.0, 85.0]))).ravel()
    e = model.laplace_modulus(s)
    got = laplace_compliance(kh[:, None] / H, s[None, :], e[None, :], nu, RHO, H)
    worst = 0.0
    for i, x in enumerate(kh):
        for j, sj in enumerate(s):
            e_p = RHO * abs(sj * H) ** 2 / abs(complex(pwave_modulus(e[j], nu)))
            with mp.workdps(40 + int(2 * np.log10(max(1.0, (x * x + 1.0) / e_p)))):
                ref = complex(_mp_laplace_closed_form(x / H, sj, e[j], nu, RHO, H))
            worst = max(worst, abs(got[i, j] - ref) / abs(ref))
    assert worst < 1e-11


def test_laplace_kernel_matches_numpy_reference():
    """Off the frequency axis e_s leaves the first quadrant (negative real for real s): the numba kernel and
    the plain-numpy form still agree to round-off there."""
    rng = np.random.default_rng(11)
    n = 5000
    nu = 0.49
    r = (1 - 2 * nu) / (2 * (1 - nu))
    x = np.where(rng.random(n) < 0.05, 0.0, 10 ** rng.uniform(-4, 3, n))
    s = 10 ** rng.uniform(-1, 6, n) * np.exp(1j * rng.uniform(-np.pi / 2, np.pi / 2, n))
    s[:200] = np.abs(s[:200])  # real s
    e = LAPLACE_MODELS["fractional"].laplace_modulus(s)
    mu = e / (2 * (1 + nu))
    got = laplace_compliance(x / H, s, e, nu, RHO, H)
    ref = _compliance_numpy(x, -RHO * (s * H) ** 2 / mu, mu, r, H)
    assert np.all(np.isfinite(ref))
    assert np.max(np.abs(got - ref) / np.abs(ref)) < 1e-11


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"s": -1.0 + 1j}, "Re s >= 0"),
        ({"s": np.inf}, "finite"),
        ({"modulus_s": -1e7}, "Re E"),
        # an active modulus on the axis (Im E < 0 at s = i w): the shear wave would grow into the layer
        ({"modulus_s": 1e7 * (1 - 1j), "s": 1e3j}, "not passive"),
    ],
)
def test_laplace_compliance_rejects_bad_input(kwargs, match):
    args = {"k": 10.0, "s": 1e3 + 1e3j, "modulus_s": 3e7 + 1e6j, "poisson": 0.49, "density": RHO, "thickness": H}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        laplace_compliance(**args)
