"""Radau IIA-3 convolution quadrature: block weights against a slow reference, the rational anchor (CQ of
1 / (s + a) = the Radau IIA solution of y' = -a y + f), and the symbol against the exact element FRF."""

from __future__ import annotations

import numpy as np
import pytest

from tyreroad import radau
from tyreroad.cq import _element_laplace_fn, exact_frf
from tyreroad.greens import unique_offsets
from tyreroad.material import material_from_config

FS = 51200.0
DT = 1.0 / FS
TREAD = material_from_config("tread", {"tread": {
    "model": "fractional_kelvin_voigt", "E0": 2.5e7, "E1": 5.0e7, "alpha": 0.24, "f1": 1000.0,
    "poisson_ratio": 0.49, "density": 1100.0, "thickness": 0.01}})


def test_butcher_tableau():
    a, b, c = radau.RADAU_A, radau.RADAU_B, radau.RADAU_C
    np.testing.assert_allclose(a.sum(axis=1), c, atol=1e-15)  # row sums = c
    # order conditions up to stage order 3: A c^(k-1) = c^k / k
    for k in (1, 2, 3):
        np.testing.assert_allclose(a @ c ** (k - 1), c**k / k, atol=1e-15)
    for k in range(1, 6):  # quadrature order 5: b . c^(k-1) = 1 / k
        assert b @ c ** (k - 1) == pytest.approx(1.0 / k, abs=1e-15)
    # A-stability of the generating function: eig Delta(zeta) in Re s > 0 on |zeta| < 1
    zeta = 0.999 * np.exp(1j * np.linspace(0, 2 * np.pi, 101)[:, None]) * np.linspace(0, 1, 11)[None, :]
    assert np.linalg.eigvals(radau.radau_delta(zeta.ravel())).real.min() > 0


def _radau_solution(a, forces):
    """Radau IIA stages of y' = -a y + f from y(0) = 0, with stage inputs forces[n, i] (plain stepping)."""
    y, out = 0.0, []
    m = np.eye(3) + a * DT * radau.RADAU_A
    for f in forces:
        stages = np.linalg.solve(m, y * np.ones(3) + DT * radau.RADAU_A @ f)
        out.append(stages)
        y = stages[2]
    return np.array(out)


@pytest.mark.parametrize("a", [0.0, 300.0, 5e4, 1e7])
def test_rational_anchor(a):
    """The CQ of 1 / (s + a) is the Radau IIA solution of y' = -a y + f: contour weights, the closed-form
    recursion and direct stepping agree."""
    n = 256
    w = radau.radau_weights(lambda s: 1.0 / (s + a), n, DT, n_contour=4 * n if a == 0 else None)
    closed = radau.rational_weights(a, n, DT)
    assert np.max(np.abs(w - closed)) < 1e-9 * np.abs(closed[0]).max()
    forces = np.random.default_rng(1).standard_normal((60, 3))
    conv = np.array([sum(closed[l] @ forces[k - l] for l in range(k + 1)) for k in range(60)])
    stepped = _radau_solution(a, forces)
    assert np.max(np.abs(conv - stepped)) < 1e-13 * np.abs(stepped).max()


def test_rational_images_vector_valued():
    rates = np.array([10.0, 1e3, 1e6])
    w = radau.radau_weights(lambda s: 1.0 / (s[:, None] + rates[None, :]), 64, DT)
    for k, a in enumerate(rates):
        closed = radau.rational_weights(a, 64, DT)
        assert np.max(np.abs(w[..., k] - closed)) < 1e-9 * np.abs(closed[0]).max()


def _slow_weights(laplace, n_weights, dt):
    """Reference: G(Delta / dt) by the Lagrange-Sylvester formula (eigenvalues only, no eigenvectors) at each
    contour point, and the Taylor coefficients by the trapezoidal sum written out (no FFT)."""
    n = 2 * n_weights
    rho = 1e-16 ** (1.0 / (n + n_weights))
    zetas = rho * np.exp(2j * np.pi * np.arange(n) / n)
    mats = [radau.radau_delta(z) / dt for z in zetas]
    lams = [np.linalg.eigvals(d) for d in mats]
    values = laplace(np.concatenate(lams))  # one call: one quadrature rule for the whole contour
    out = np.zeros((n_weights, 3, 3) + values.shape[1:], dtype=complex)
    eye = np.eye(3)
    for j, (zeta, d, lam) in enumerate(zip(zetas, mats, lams)):
        g = values[3 * j: 3 * j + 3]
        fm = 0
        for k in range(3):
            p = eye.astype(complex)
            for i in range(3):
                if i != k:
                    p = p @ (d - lam[i] * eye) / (lam[k] - lam[i])
            fm = fm + np.multiply.outer(p, g[k])
        for l in range(n_weights):
            out[l] += fm * zeta ** (-l) / n
    return out.real


def test_weights_against_slow_reference():
    """Layer Green's function on a 2 x 2 patch (3 unique offsets), 48 block weights."""
    c = 1e-3
    fn = _element_laplace_fn(TREAD, unique_offsets((2, 2)) * c, c)
    fast = radau.radau_weights(fn, 48, DT)
    slow = _slow_weights(fn, 48, DT)
    scale = np.abs(fast[0]).max()
    assert np.max(np.abs(fast - slow)) < 1e-9 * scale
    # the stage-3 row of W_0 is the step's end response: positive at the excitation element
    assert fast[0, 2, 2, 0] > 0


def test_symbol_follows_the_element_frf():
    """The 3-stage symbol (infinite lags), read at the step's end for a harmonic force sampled at the stages,
    against the exact element FRF, 10 Hz - 5 kHz, every offset of a 6 x 6 patch."""
    c, shape = 1e-3, (6, 6)
    freq = np.geomspace(10.0, 5000.0, 60)
    fn = _element_laplace_fn(TREAD, unique_offsets(shape) * c, c)
    sym = radau.radau_symbol(fn, 2 * np.pi * freq / FS, DT)
    k = radau.stage_transfer(sym, freq, FS)
    exact = exact_frf(TREAD, shape, c, freq)
    ratio = k / exact
    mag, phase = np.abs(np.abs(ratio) - 1), np.abs(np.angle(ratio))
    assert mag[:, 0].max() < 2e-4 and phase[:, 0].max() < 1e-4
    assert mag.max() < 2e-4 and phase.max() < 2e-4
