r"""Convolution-quadrature kernels of the tread layer and the stability margin of any time-march kernel (issue 23).

Convolution quadrature (CQ; Lubich 1988) turns a Laplace-domain transfer function G(s) into the weights
g_n of a discrete convolution w[n] = sum_l g_l F[n - l] through the generating function delta(zeta) of a
linear multistep method:

    G(delta(zeta) / dt) = sum_n g_n zeta^n,          |zeta| < 1.

The weights are the Taylor coefficients of the left side, computed by the trapezoidal rule on a circle of
radius rho < 1 (Lubich 1988, eq. 4.4; Banjai & Schanz 2012, sec. 3):

    g_n = rho^(-n) / N  sum_{j=0}^{N-1} G(delta(rho e^{2 pi i j / N}) / dt) e^{-2 pi i j n / N},

with rho^N = eps^(N / (N + L)): the aliasing error (rho^N g_{n+N}) and the rounding amplification
(eps rho^(-n)) balance at the last kept weight n = L (N = 2 L by default: about 2e-11 relative, where the
classical rho^N = sqrt(eps) leaves 1e-8 aliasing of a slowly decaying sequence). G is real on the real axis (G(conj s) = conj G(s)) and delta has real coefficients, so
only j = 0 ... N/2 are evaluated and the weights come out of one inverse real FFT.

Methods (``delta``): backward Euler, delta = 1 - zeta; BDF2, delta = (1 - zeta) + (1 - zeta)^2 / 2. Both are
A-stable: delta maps the closed unit disk into Re s >= 0, so the march kernel's transfer function on the
unit circle, G_d(z) = sum_l g_l z^(-l) = G(delta(1/z) / dt), is the layer's own (passive) G at a point of the
right half plane: Herm G_d >= 0 there for a passive layer, and the march is stable for every spring set
S >= 0 -- for the full (infinite) weight sequence. The kept lags alone are not the full sequence: the
tread creeps for seconds, and a CQ kernel of L lags needs its own tail (its creep terms are rational, so
their CQ images are exact geometric sequences); that tail is not built here (see :func:`weight_decay`).

The stability margin (:func:`stability_margin`) of any kernel whose transfer function is G_d(e^{i theta})
over the patch (complex symmetric M x M, M = nx ny):

    p(theta) = max_{|phi| <= pi/2} lambda_min Herm(e^{i phi} G_d(e^{i theta}))
             = max_phi lambda_min(cos phi Re G_d - sin phi Im G_d).

p > 0 on the whole circle means I + S^(1/2) G_d S^(1/2) is nonsingular for every S = diag(k_e) >= 0
(if v != 0 were a null vector, u = S^(1/2) v: Re e^{i phi}(|v|^2 + u^H G_d u) = 0 with both terms >= 0 and
u = 0 forcing v = 0). Note p(pi) = max(lambda_min G_d(-1), 0): a real indefinite G_d gives p = 0 (at
phi = +-pi/2), not a negative p -- a failure shows as p <= 0, and how bad it is as k_safe. Where p(theta) < 0, a root of the march on |z| = 1 at theta needs a spring
of at least

    k_safe(theta) = max_phi cos phi / (-lambda_min Herm(e^{i phi} G_d)),

(from v^H e^{i phi}(I + S^(1/2) G_d S^(1/2)) v = 0 with |S^(1/2) v|^2 <= k |v|^2), a lower bound that is
exact at theta = pi for uniform springs (-1 / lambda_min G_d(-1), :mod:`tyreroad.stability`).

References
----------
Lubich, C. (1988), Convolution quadrature and discretized operational calculus I. Numer. Math. 52,
129-145. doi:10.1007/BF01398686
Banjai, L. and Schanz, M. (2012), Wave propagation problems treated with convolution quadrature and BEM.
In: Fast Boundary Element Methods in Engineering and Industrial Applications, LNACM 63, 145-184.
doi:10.1007/978-3-642-25670-7_5
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.optimize

from .greens import element_frf, element_laplace, offset_table_index, unique_offsets
from .influence import offset_matrix
from .kernel import LayerKernel

logger = logging.getLogger(__name__)

__all__ = [
    "CQ_METHODS", "generating_function", "cq_weights", "element_cq_weights", "cq_kernel", "cq_symbol",
    "MarginResult", "stability_margin", "kernel_margin", "symbol_margin", "fidelity", "weight_decay",
    "blend_map", "exact_frf", "unique_entries",
]


def _backward_euler(zeta):
    return 1.0 - zeta


def _bdf2(zeta):
    d = 1.0 - zeta
    return d + 0.5 * d * d


#: Generating functions delta(zeta) of the single-stage CQ methods, by name.
CQ_METHODS: dict[str, Callable] = {"backward_euler": _backward_euler, "bdf2": _bdf2}


def generating_function(method: str) -> Callable:
    """delta(zeta) of a CQ method (``backward_euler`` or ``bdf2``)."""
    try:
        return CQ_METHODS[method]
    except KeyError:
        raise ValueError(f"CQ method: expected one of {sorted(CQ_METHODS)}, got {method!r}") from None


def cq_weights(laplace: Callable, n_weights: int, dt: float, method: str = "bdf2",
               n_contour: int | None = None, eps: float = 1e-16) -> np.ndarray:
    """CQ weights g_0 ... g_{n_weights - 1} of a Laplace-domain transfer function.

    Parameters
    ----------
    laplace : callable
        s (1-D complex array, Re s >= 0) -> G(s), shape (len(s), ...) complex, with G(conj s) = conj G(s)
        (a real-valued impulse response). Called once with all contour points (so that a quadrature inside
        it is the same analytic function on the whole contour).
    n_weights : int
        Weights wanted.
    dt : float
        Time step [s].
    method : str
        ``backward_euler`` or ``bdf2``.
    n_contour : int, optional
        Trapezoidal points N on the circle (even; default 2 n_weights rounded up to even).
    eps : float
        Rounding level of G's values; rho = eps^(1 / (N + n_weights)) (see the code).

    Returns
    -------
    numpy.ndarray
        Real weights, shape (n_weights, ...) [G's units: sum_n g_n = G(0), a convolution with F gives w].
    """
    delta = generating_function(method)
    n = int(n_contour) if n_contour is not None else 2 * int(n_weights)
    n += n % 2
    if n < n_weights:
        raise ValueError(f"n_contour = {n} < n_weights = {n_weights}")
    # aliasing ~ rho^N |g_{n+N}|, rounding ~ eps rho^(-n) max|G|: balanced at the last weight n = L by
    # rho^N = eps^(N / (N + L)) (eps^(2/3) for N = 2 L; the classical rho^N = sqrt(eps) leaves 1e-8 aliasing)
    rho = eps ** (1.0 / (n + n_weights))
    zeta = rho * np.exp(2j * np.pi * np.arange(n // 2 + 1) / n)
    s = delta(zeta) / dt
    s = np.where(np.abs(s.imag) < 1e-300, s.real + 0j, s)  # j = 0, N/2: real s
    values = np.asarray(laplace(s), dtype=complex)
    # (1/N) sum_j G_j e^{-2 pi i j n / N} with G_{N-j} = conj G_j is irfft of conj(G_half)
    w = np.fft.irfft(np.conj(values), n=n, axis=0)[:n_weights]
    scale = rho ** (-np.arange(n_weights, dtype=float))
    return w * scale.reshape((-1,) + (1,) * (w.ndim - 1))


def _element_laplace_fn(material, offsets, element_size):
    def fn(s):
        return element_laplace(offsets, element_size, s, material.laplace_modulus(s), material.poisson,
                               material.density, material.thickness)
    return fn


def element_cq_weights(material, shape, element_size: float, sample_rate: float, n_lags: int,
                       method: str = "bdf2") -> np.ndarray:
    """CQ weights of the layer's element Green's function at the unique offsets of a patch, (n_lags, n_offsets) [m/N].

    G(s) = :func:`tyreroad.greens.element_laplace` with ``material.laplace_modulus`` (one call over the contour).
    """
    c = float(element_size)
    offsets = unique_offsets(shape) * c
    return cq_weights(_element_laplace_fn(material, offsets, c), n_lags, 1.0 / sample_rate, method)


def cq_kernel(material, shape, element_size: float, sample_rate: float, n_lags: int = 256,
              method: str = "bdf2") -> LayerKernel:
    """A dynamic :class:`LayerKernel` of the CQ weights over a patch (kept lags only: no tail yet)."""
    weights = element_cq_weights(material, shape, element_size, sample_rate, n_lags, method)
    _, _, index = offset_table_index(shape)
    table = np.ascontiguousarray(np.moveaxis(weights[:, index], 0, -1))
    return LayerKernel.dynamic(table, sample_rate, element_size=element_size, name=f"{material.name} CQ {method}")


def cq_symbol(material, shape, element_size: float, sample_rate: float, theta, method: str = "bdf2") -> np.ndarray:
    """The full (infinite-lag) CQ kernel's transfer function on |z| = 1, G(delta(e^{-i theta}) fs), as complex
    offset tables (n_theta, 2 nx - 1, 2 ny - 1) [m/N]. theta in [0, pi]."""
    delta = generating_function(method)
    theta = np.asarray(theta, dtype=float)
    s = delta(np.exp(-1j * theta)) * float(sample_rate)
    s = np.where(np.abs(s.imag) < 1e-300, s.real + 0j, s)
    s = s.real.clip(min=0.0) + 1j * s.imag  # rounding: Re s = (1 - cos theta)^2 >= 0 (BDF2), 1 - cos theta (BE)
    c = float(element_size)
    g = _element_laplace_fn(material, unique_offsets(shape) * c, c)(s)
    _, _, index = offset_table_index(shape)
    return g[:, index]


def blend_map(material, element_size: float, sample_rate: float, crossover: float, width: float = 0.05,
              method: str = "bdf2") -> Callable:
    """An FRF map for :func:`tyreroad.greens.greens_dataset`: the FRF below the crossover, the CQ symbol above.

    H(f) = w(f) G(i omega) + (1 - w(f)) G(delta(e^{-i omega / fs}) fs), w = 1 below (crossover - width) fs,
    0 above (crossover + width) fs, a raised cosine between (crossover, width in units of fs). The symbol
    is evaluated (element_laplace, one call) only where w < 1. The greens stage then folds it into a causal
    kernel as it does the FRF (IFFT, precursor correction, creep tail).
    """
    delta = generating_function(method)
    fs = float(sample_rate)
    lo, hi = (crossover - width) * fs, (crossover + width) * fs

    def fmap(frf, omega, offsets):
        f = np.asarray(omega) / (2 * np.pi)
        x = np.clip((f - lo) / (hi - lo), 0.0, 1.0)
        w = 0.5 * (1 + np.cos(np.pi * x))
        sel = w < 1.0
        s = delta(np.exp(-1j * np.asarray(omega)[sel] / fs)) * fs
        s = s.real.clip(min=0.0) + 1j * s.imag
        sym = element_laplace(offsets, element_size, s, material.laplace_modulus(s), material.poisson,
                              material.density, material.thickness)
        out = np.array(frf, dtype=complex)
        out[sel] = w[sel, None] * out[sel] + (1 - w[sel, None]) * sym
        return out

    return fmap


def weight_decay(kernel: LayerKernel) -> float:
    """|g_{L-1}| / |g_0| at the excitation element: how much memory the kept lags cut off."""
    cx, cy = (kernel.lags.shape[0] - 1) // 2, (kernel.lags.shape[1] - 1) // 2
    g = kernel.lags[cx, cy]
    return float(abs(g[-1]) / abs(g[0]))


# ----------------------------------------------------------------------------------------------
# stability margin


@dataclass
class MarginResult:
    """The stability margin of a kernel over the unit circle (see the module docstring).

    Attributes
    ----------
    theta : numpy.ndarray
        The grid of theta in [0, pi] [rad] (plus refined points, sorted).
    lower : numpy.ndarray
        lambda_min Herm(e^{i phi} G_d(e^{i theta})) on it at a tracked phi, a lower bound of p [m/N].
    p : numpy.ndarray
        p(theta) where evaluated in full (NaN elsewhere: there lower >= min p already) [m/N].
    k_safe : numpy.ndarray
        The spring bound at each theta [N/m] (inf where p > 0; from the tracked phi alone where p was not
        evaluated: lower bound 1 / -lower, conservative).
    min_p : float
        min over theta of p [m/N].
    theta_min : float
        Where [rad].
    k_crit : float
        min over theta of k_safe [N/m] (inf: no spring set S >= 0 puts a root on the circle).
    theta_k : float
        Where k_crit is reached [rad] (NaN when inf).
    k_nyquist : float
        -1 / lambda_min G_d(-1) (inf if >= 0) [N/m].
    evaluations : int
        Eigen-solves done.
    seconds : float
        Wall time.
    """

    theta: np.ndarray
    lower: np.ndarray
    p: np.ndarray
    k_safe: np.ndarray
    min_p: float
    theta_min: float
    k_crit: float
    theta_k: float
    k_nyquist: float
    evaluations: int
    seconds: float

    def failing_bands(self) -> list[tuple[float, float]]:
        """theta intervals [rad] (grid points) where k_safe is finite: p <= 0 where p was evaluated, lower < 0
        (not excluded) where it was not."""
        bad = np.isfinite(self.k_safe)
        bands, start = [], None
        for i, b in enumerate(bad):
            if b and start is None:
                start = i
            if not b and start is not None:
                bands.append((float(self.theta[start]), float(self.theta[i - 1])))
                start = None
        if start is not None:
            bands.append((float(self.theta[start]), float(self.theta[-1])))
        return bands


def _lambda_min(matrix: np.ndarray) -> float:
    return float(np.linalg.eigvalsh(matrix)[0])


class _Margin:
    """p(theta), its lower bound and k_safe for one symbol (tables -> dense matrices on demand)."""

    def __init__(self, symbol: Callable, shape):
        self.symbol = symbol
        self.shape = shape
        self.evaluations = 0

    def matrices(self, theta: float):
        a = offset_matrix(self.symbol(np.array([theta]))[0])
        return a.real.copy(), a.imag.copy()

    def f(self, b, c, phi):
        self.evaluations += 1
        return _lambda_min(math.cos(phi) * b - math.sin(phi) * c)

    def lower(self, theta: float) -> float:
        b, _ = self.matrices(theta)
        self.evaluations += 1
        return _lambda_min(b)

    def full(self, theta: float, n_phi: int = 11) -> tuple[float, float]:
        """(p, k_safe) at theta: phi grid of n_phi points on [-pi/2, pi/2], then Brent around the best."""
        b, c = self.matrices(theta)
        phis = np.linspace(-np.pi / 2, np.pi / 2, n_phi)
        values = {float(phi): self.f(b, c, phi) for phi in phis}
        best = max(values, key=values.get)
        step = phis[1] - phis[0]
        res = scipy.optimize.minimize_scalar(
            lambda phi: -self.f(b, c, phi), bounds=(max(best - step, -np.pi / 2), min(best + step, np.pi / 2)),
            method="bounded", options={"xatol": 1e-5 * step})
        values[float(res.x)] = -float(res.fun)
        p = max(values.values())
        # p within rounding of 0 (a real G_d at theta = 0, pi gives exactly 0 at phi = +-pi/2) is no margin
        if p > 1e-9 * max(np.abs(b).max(), np.abs(c).max()):
            return p, math.inf
        k = max((math.cos(phi) / -v for phi, v in values.items() if v < 0), default=0.0)
        return p, k


def stability_margin(symbol: Callable, shape, n_theta: int = 2001, max_full: int = 400,
                     refine_minima: int = 12) -> MarginResult:
    """The stability margin p(theta) of a march kernel over theta in [0, pi], densely (see the module docstring).

    Parameters
    ----------
    symbol : callable
        theta (1-D array) -> complex offset tables G_d(e^{i theta}) (n_theta, 2 nx - 1, 2 ny - 1) [m/N].
    shape : tuple of int
        Patch (nx, ny).
    n_theta : int
        Uniform grid points on [0, pi] (>= 2000 recommended: a narrow failing band is 0.001 pi wide).
    max_full : int
        Most theta at which p is optimised over phi (the rest keep the phi = 0 lower bound).
    refine_minima : int
        Local minima of the phi = 0 bound that are refined in theta (bounded Brent) before p is evaluated.

    Method
    ------
    1. lower(theta) = lambda_min Herm(e^{i phi} G_d) on the grid at a phi tracked along theta (three phi per
       theta, hill climbing): p >= lower everywhere.
    2. The ``refine_minima`` deepest local minima of ``lower`` are refined in theta (phi = 0 there; a band
       narrower than the grid step shows as a dip of the neighbours), and added to the grid.
    3. p is evaluated in order of increasing ``lower`` until lower >= min p found (branch and bound: no
       other theta can be lower) or ``max_full`` evaluations; if stopped early, min p is bracketed by
       [min unevaluated lower, min p] and the log says so.
    """
    t0 = time.perf_counter()
    nx, ny = shape
    theta = np.linspace(0.0, np.pi, int(n_theta))
    tables = symbol(theta)
    m = _Margin(symbol, shape)
    lower = np.empty(theta.size)
    phis = np.zeros(theta.size)
    scale = np.zeros(theta.size)
    # a lower bound of p at every grid theta from any phi: track the best phi along theta (hill climbing,
    # three phi per theta; a passive compliance's best phi is about arg s, which moves with theta)
    phi, h = 0.0, np.pi / 40
    for i in range(theta.size):
        a = offset_matrix(tables[i])
        b, c = a.real, a.imag
        trial = {q: m.f(b, c, q) for q in (phi, max(phi - h, -np.pi / 2), min(phi + h, np.pi / 2))}
        phi = max(trial, key=trial.get)
        lower[i], phis[i] = trial[phi], phi
        scale[i] = max(np.abs(b).max(), np.abs(c).max())
    # refine the deepest local minima in theta
    interior = np.flatnonzero((lower[1:-1] <= lower[:-2]) & (lower[1:-1] <= lower[2:])) + 1
    ends = [i for i in (0, theta.size - 1) if (i == 0 and lower[0] <= lower[1]) or (i > 0 and lower[i] <= lower[i - 1])]
    minima = np.concatenate([interior, np.asarray(ends, dtype=int)])
    minima = minima[np.argsort(lower[minima])][:refine_minima]
    h = theta[1] - theta[0]
    extra_t, extra_l = [], []
    for i in minima:
        lo, hi = max(theta[i] - h, 0.0), min(theta[i] + h, np.pi)
        res = scipy.optimize.minimize_scalar(m.lower, bounds=(lo, hi), method="bounded", options={"xatol": 1e-4 * h})
        extra_t.append(float(res.x))
        extra_l.append(float(res.fun))
    theta = np.concatenate([theta, extra_t])
    lower = np.concatenate([lower, extra_l])
    phis = np.concatenate([phis, np.zeros(len(extra_t))])
    scale = np.concatenate([scale, np.full(len(extra_t), scale.max())])
    order = np.argsort(theta)
    theta, lower, phis, scale = theta[order], lower[order], phis[order], scale[order]
    tol = 1e-9 * scale  # a lower bound within rounding of 0 excludes nothing (p must be > 0)
    p = np.full(theta.size, np.nan)
    # where p is not evaluated: the bound of the one phi tried, cos phi / -lower (conservative)
    k_safe = np.where(lower < -tol, np.cos(phis) / np.maximum(-lower, 1e-300), np.inf)
    k_safe[np.abs(lower) <= tol] = 0.0  # no bound at all unless p is evaluated there
    best = math.inf
    done = 0
    # the ends (z = 1, z = -1: a real G_d) first, then by increasing lower bound
    order = np.argsort(lower)
    order = np.concatenate([[0, theta.size - 1], order[(order != 0) & (order != theta.size - 1)]])
    for n, i in enumerate(order):
        if n >= 2 and ((lower[i] >= best and lower[i] > tol[i]) or done >= max_full):
            break
        p[i], k_full = m.full(float(theta[i]))
        k_safe[i] = k_full
        best = min(best, p[i])
        done += 1
    unevaluated = np.isnan(p)
    bracket_low = float(lower[unevaluated].min()) if unevaluated.any() else math.inf
    if bracket_low < best:
        logger.warning("stability_margin: stopped after %d full evaluations; min p in [%.3e, %.3e] m/N",
                       done, bracket_low, best)
    i_min = int(np.nanargmin(p))
    i_k = int(np.argmin(k_safe))
    g_pi = offset_matrix(symbol(np.array([np.pi]))[0]).real
    lam_pi = _lambda_min(g_pi)
    return MarginResult(
        theta, lower, p, k_safe, float(p[i_min]), float(theta[i_min]),
        float(k_safe[i_k]), float(theta[i_k]) if np.isfinite(k_safe[i_k]) else math.nan,
        -1.0 / lam_pi if lam_pi < 0 else math.inf, m.evaluations + 1, time.perf_counter() - t0,
    )


def kernel_margin(kernel: LayerKernel, shape, **kwargs) -> MarginResult:
    """:func:`stability_margin` of a march kernel's own transfer function (kept lags + memory,
    :meth:`LayerKernel.own_frequency_response`)."""
    fs = kernel.sample_rate

    def symbol(theta):
        return kernel.own_frequency_response(np.asarray(theta) * fs / (2 * np.pi), shape)

    return stability_margin(symbol, shape, **kwargs)


def symbol_margin(material, shape, element_size: float, sample_rate: float, method: str = "bdf2",
                  **kwargs) -> MarginResult:
    """:func:`stability_margin` of the full (infinite-lag) CQ kernel, G(delta(e^{-i theta}) fs) (one
    element_laplace call for the grid, one per refined point)."""
    cache = {}

    def symbol(theta):
        theta = np.asarray(theta, dtype=float)
        key = theta.tobytes()
        if key not in cache:
            cache[key] = cq_symbol(material, shape, element_size, sample_rate, theta, method)
        return cache[key]

    return stability_margin(symbol, shape, **kwargs)


# ----------------------------------------------------------------------------------------------
# fidelity


def fidelity(response: np.ndarray, exact: np.ndarray) -> dict:
    """Magnitude and phase error of a transfer function against the exact one, per offset.

    Parameters
    ----------
    response, exact : numpy.ndarray
        Complex, shape (n_f, n_offsets) (offset 0 the excitation element).

    Returns
    -------
    dict
        ``magnitude`` [1] and ``phase`` [rad]: worst over frequency per offset, |(|K| / |G|) - 1| and
        |arg(K / G)|; ``excitation`` (magnitude, phase) at offset 0; ``worst`` (magnitude, phase) over all
        offsets and ``worst_offset`` (the offset indices of each).
    """
    ratio = np.asarray(response) / np.asarray(exact)
    mag = np.max(np.abs(np.abs(ratio) - 1.0), axis=0)
    phase = np.max(np.abs(np.angle(ratio)), axis=0)
    return {
        "magnitude": mag, "phase": phase,
        "excitation": (float(mag[0]), float(phase[0])),
        "worst": (float(mag.max()), float(phase.max())),
        "worst_offset": (int(mag.argmax()), int(phase.argmax())),
    }


def exact_frf(material, shape, element_size: float, frequencies) -> np.ndarray:
    """The exact element FRF at the unique offsets of a patch, (n_f, n_offsets) [m/N]."""
    c = float(element_size)
    omega = 2 * np.pi * np.asarray(frequencies, dtype=float)
    return element_frf(unique_offsets(shape) * c, c, omega, material.modulus(omega), material.poisson,
                       material.density, material.thickness)


def unique_entries(tables: np.ndarray, shape) -> np.ndarray:
    """Offset tables (n, 2 nx - 1, 2 ny - 1) -> their values at :func:`unique_offsets` (n, n_offsets)."""
    nx, ny = shape
    uniq = unique_offsets(shape)
    a, b = uniq[:, 0], uniq[:, 1]
    if nx >= ny:
        return tables[:, a + nx - 1, b + ny - 1]
    return tables[:, b + nx - 1, a + ny - 1]
