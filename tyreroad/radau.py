r"""Radau IIA (3 stages) convolution quadrature: block weights, symbol and rational images (issue 23).

Runge-Kutta convolution quadrature (Lubich & Ostermann 1993; Banjai & Schanz 2012) approximates
y = G(d/dt) f at the stage times t_{n-1} + c_i h of step n (steps of h = 1 / fs; step n spans
(t_{n-1}, t_n]) by

    Y_{n,i} = sum_{l >= 0} sum_j W_l[i, j] F_{n-l, j},

with 3 x 3 block weights W_l, the Taylor coefficients of G evaluated at a matrix argument:

    G(Delta(zeta) / h) = sum_l W_l zeta^l,      Delta(zeta) = (A + zeta / (1 - zeta) 1 b^T)^(-1),

A the Butcher matrix of Radau IIA-3, b its weights (= its last row: the method is stiffly accurate,
so the last stage c_3 = 1 is the step's end value). Radau IIA is A-stable (L-stable): the eigenvalues
of Delta(zeta) lie in Re s > 0 for |zeta| < 1, so G is only ever asked at points of the right half
plane, where a passive layer is passive.

Weights (:func:`radau_weights`) are computed like the single-stage ones (:func:`tyreroad.cq.cq_weights`):
the trapezoidal rule on a circle |zeta| = rho < 1, rho^N = eps^(N / (N + L)); at every contour point
Delta = V diag(lambda) V^(-1) is diagonalised (three distinct eigenvalues) and
G(Delta / h) = V diag(G(lambda_k / h)) V^(-1): one call of G at 3 (N/2 + 1) points s, one real FFT per
block entry. G is real on the real axis and Delta has real coefficients, so G(Delta(conj zeta)) is the
conjugate of G(Delta(zeta)) and only half the contour is evaluated.

Rational images (:func:`rational_images`). For G(s) = 1 / (s + a) the CQ *is* the Radau IIA
solution of y' = -a y + f (an exact identity, the anchor of the tests):

    W_0 = h (I + a h A)^(-1) A,      W_l = u r^(l-1) v^T (l >= 1),
    u = (I + a h A)^(-1) 1,  r = e_3^T u = R(-a h) (the stability function),  v^T = e_3^T W_0,

so a retardation term of the creep is a rank-one, geometric (stage-coupled) recursion with one scalar
state per element: this is how :mod:`tyreroad.stage` carries the tread's creep beyond the kept lags.

References
----------
Lubich, C. and Ostermann, A. (1993), Runge-Kutta methods for parabolic equations and convolution
quadrature. Math. Comp. 60, 105-131. doi:10.1090/S0025-5718-1993-1153166-7
Banjai, L. and Schanz, M. (2012), Wave propagation problems treated with convolution quadrature and BEM.
LNACM 63, 145-184. doi:10.1007/978-3-642-25670-7_5
Schädle, A., López-Fernández, M. and Lubich, C. (2006), Fast and oblivious convolution quadrature.
SIAM J. Sci. Comput. 28(2), 421-438. doi:10.1137/050623139
Hairer, E. and Wanner, G. (1996), Solving Ordinary Differential Equations II, sec. IV.5 (Radau IIA).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

__all__ = ["RADAU_A", "RADAU_B", "RADAU_C", "STAGES", "radau_delta", "radau_weights", "radau_symbol",
           "stage_transfer", "rational_images", "rational_weights"]

_S6 = math.sqrt(6.0)
#: Butcher matrix of Radau IIA with 3 stages (order 5, stage order 3).
RADAU_A = np.array([
    [(88.0 - 7.0 * _S6) / 360.0, (296.0 - 169.0 * _S6) / 1800.0, (-2.0 + 3.0 * _S6) / 225.0],
    [(296.0 + 169.0 * _S6) / 1800.0, (88.0 + 7.0 * _S6) / 360.0, (-2.0 - 3.0 * _S6) / 225.0],
    [(16.0 - _S6) / 36.0, (16.0 + _S6) / 36.0, 1.0 / 9.0],
])
#: Weights b (the last row of A).
RADAU_B = RADAU_A[2].copy()
#: Stage times c_i (fractions of the step): (4 - sqrt 6) / 10, (4 + sqrt 6) / 10, 1.
RADAU_C = np.array([(4.0 - _S6) / 10.0, (4.0 + _S6) / 10.0, 1.0])
#: Stages per step.
STAGES = 3


def radau_delta(zeta) -> np.ndarray:
    """Delta(zeta) = (A + zeta / (1 - zeta) 1 b^T)^(-1), shape zeta.shape + (3, 3) (|zeta| < 1 or on the circle
    without zeta = 1)."""
    zeta = np.asarray(zeta, dtype=complex)
    q = (zeta / (1.0 - zeta))[..., None, None]
    m = RADAU_A + q * np.outer(np.ones(STAGES), RADAU_B)
    return np.linalg.inv(m)


def _matrix_function(laplace: Callable, delta: np.ndarray, dt: float) -> np.ndarray:
    """G(Delta / dt) for a stack of 3 x 3 matrices Delta (J, 3, 3): shape (J, 3, 3) + G's trailing shape.

    Diagonalisation (distinct eigenvalues: A^(-1) has one real and a complex pair, and the rank-one update keeps
    them apart on the contour); G is called once with all 3 J eigenvalues / dt.
    """
    lam, vec = np.linalg.eig(delta)
    inv = np.linalg.inv(vec)
    s = (lam / dt).ravel()
    # real for real zeta (up to rounding); on the unit circle Re s >= 0 holds up to rounding near theta = 0
    s = np.where(np.abs(s.imag) < 1e-300, s.real + 0j, s)
    s = s.real.clip(min=0.0) + 1j * s.imag
    values = np.asarray(laplace(s), dtype=complex)
    trailing = values.shape[1:]
    values = values.reshape((delta.shape[0], STAGES) + trailing)
    # V diag(g) V^-1 per contour point, for every trailing entry (offsets)
    vals = values.reshape(delta.shape[0], STAGES, -1)
    out = np.einsum("jik,jkq,jkl->jilq", vec, vals, inv)
    return out.reshape((delta.shape[0], STAGES, STAGES) + trailing)


def radau_weights(laplace: Callable, n_weights: int, dt: float, n_contour: int | None = None,
                  eps: float = 1e-16) -> np.ndarray:
    """Radau IIA-3 CQ block weights W_0 ... W_{n_weights - 1} of a Laplace-domain transfer function.

    Parameters
    ----------
    laplace : callable
        s (1-D complex array, Re s > 0) -> G(s), shape (len(s), ...) complex, G(conj s) = conj G(s). Called once
        with every point (3 per contour point).
    n_weights : int
        L, the block weights wanted.
    dt : float
        h [s].
    n_contour : int, optional
        Trapezoidal points N on the circle (even; default 2 L).
    eps : float
        Rounding level of G's values (sets rho as in :func:`tyreroad.cq.cq_weights`).

    Returns
    -------
    numpy.ndarray
        Real weights, shape (L, 3, 3, ...) [G's units]: W[l, i, j] maps the force of stage j, l steps back,
        to the response at stage i.
    """
    n = int(n_contour) if n_contour is not None else 2 * int(n_weights)
    n += n % 2
    if n < n_weights:
        raise ValueError(f"n_contour = {n} < n_weights = {n_weights}")
    rho = eps ** (1.0 / (n + n_weights))
    zeta = rho * np.exp(2j * np.pi * np.arange(n // 2 + 1) / n)
    values = _matrix_function(laplace, radau_delta(zeta), dt)
    w = np.fft.irfft(np.conj(values), n=n, axis=0)[:n_weights]
    scale = rho ** (-np.arange(n_weights, dtype=float))
    return w * scale.reshape((-1,) + (1,) * (w.ndim - 1))


def circle_laplace_points(n_theta: int, sample_rate: float) -> tuple[np.ndarray, np.ndarray]:
    """theta = pi k / n_theta (k = 1 ... n_theta) [rad] and the Laplace frequencies s = d_i(e^{-i theta}) / h of the
    three eigenvalues d_i of Delta there, shape (n_theta, 3) [rad/s]: where the Radau march evaluates a transfer
    function on the unit circle (Re s >= 0; rounding below 0 clipped, as :func:`_matrix_function` does)."""
    theta = np.pi * np.arange(1, int(n_theta) + 1) / int(n_theta)
    s = np.linalg.eigvals(radau_delta(np.exp(-1j * theta))) * float(sample_rate)
    return theta, s.real.clip(min=0.0) + 1j * s.imag


def radau_symbol(laplace: Callable, theta, dt: float) -> np.ndarray:
    """The full (infinite-lag) kernel's block transfer function sum_l W_l e^{-i theta l} = G(Delta(e^{-i theta}) / h),
    shape (n_theta, 3, 3, ...). theta in (0, pi] (Delta is singular at theta = 0)."""
    theta = np.asarray(theta, dtype=float)
    return _matrix_function(laplace, radau_delta(np.exp(-1j * theta)), dt)


def stage_transfer(block_symbol: np.ndarray, frequencies, sample_rate: float) -> np.ndarray:
    """The march's transfer function from a harmonic force to the step's end value: the last stage's response
    to F(t) = e^{i omega t} sampled at the stage times, divided by e^{i omega t_n}:

        K(omega) = sum_j S[2, j] exp(i omega (c_j - 1) h),     S = block_symbol at theta = omega h,

    shape (n_f, ...) complex [G's units]; the exact answer is G(i omega)."""
    omega = 2 * np.pi * np.asarray(frequencies, dtype=float)
    phase = np.exp(1j * omega[:, None] * (RADAU_C[None, :] - 1.0) / float(sample_rate))  # (n_f, 3)
    s = np.asarray(block_symbol)
    return np.einsum("fj...,fj->f...", s[:, 2], phase)


def rational_images(rates, dt: float):
    """The Radau IIA-3 CQ images of 1 / (s + a_k): (W_0, u, r, v), shapes (K, 3, 3), (K, 3), (K,), (K, 3).

    W_l = u r^(l - 1) v^T for l >= 1 (module docstring); exact for every a_k >= 0."""
    a = np.atleast_1d(np.asarray(rates, dtype=float))
    eye = np.eye(STAGES)
    m = eye[None] + (a * dt)[:, None, None] * RADAU_A[None]
    inv = np.linalg.inv(m)
    w0 = dt * inv @ RADAU_A
    u = inv @ np.ones(STAGES)
    r = u[:, 2].copy()
    v = w0[:, 2, :].copy()
    return w0, u, r, v


def rational_weights(rate: float, n_weights: int, dt: float) -> np.ndarray:
    """W_0 ... W_{L-1} of G(s) = 1 / (s + rate) by the recursion of :func:`rational_images`, shape (L, 3, 3)."""
    w0, u, r, v = (x[0] for x in rational_images([rate], dt))
    out = np.empty((int(n_weights), STAGES, STAGES))
    out[0] = w0
    for l in range(1, int(n_weights)):
        out[l] = np.outer(u, v) * r ** (l - 1)
    return out
