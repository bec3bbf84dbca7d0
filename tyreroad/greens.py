"""Element Green's functions of the tread layer (SPEC section 5).

g(x, y, omega) is the normal surface displacement [m] at an element centre offset (x, y) from a
unit force [N] spread uniformly over one c x c element of a visco-elastic layer (thickness h,
bonded to a rigid base, laterally infinite). It is split into

* the exact static half-space part: Love's uniformly loaded square with the complex modulus
  E(omega) (correspondence principle), which carries the 1/k singularity of the compliance and
  the near-field of the square load exactly, and
* the remainder R(k, omega) = H(k, omega) - 2 (1 - nu^2) / (E(omega) k), which is bounded, depends
  on |k| only and decays quickly in k. Its inverse 2-D Fourier transform against the square load's
  spectrum P(kx, ky) = sinc(kx c / 2) sinc(ky c / 2) is reduced to 1-D k integrals by expanding P
  in angular harmonics, P(k, theta) = sum_n a_n(k) cos(4 n theta) (the square's symmetry leaves only
  orders 4n), and using the Jacobi-Anger integral

      g_R(r, phi) = 1/(2 pi) int_0^inf k R(k) sum_n a_n(k) J_4n(k r) cos(4 n phi) dk.

  The k integral is a composite Gauss-Legendre rule (:func:`wavenumber_quadrature`) whose weights
  times the Bessel/harmonic factors, W[k_i, offset], do not depend on omega; all frequencies then
  follow from one matrix product R[omega, k] @ W[k, offset].

Time domain: the FRF is sampled on f_j = j fs / N_fft and g[n] = irfft (numpy's, which includes
1/N_fft, so that sum_n g[n] = g(omega = 0): a discrete impulse response in m/N that convolves a
force sequence [N] into displacements [m]). The first ``n_lags`` samples are kept, after removing the
slow creep that the N_fft-point transform folds back from beyond its period (the tread creeps for
seconds); the memory beyond the kept lags is stored as the tail of :mod:`tyreroad.memory`
(``tail_compliance`` R and the retardation spectrum of the creep fit). A causal material's
band-limited kernel rings before t = 0 (its FRF has not decayed at fs / 2); the march needs a causal
kernel, so that precursor is replaced by a correction of the first ``PRECURSOR_TAPS`` lags fitted to
its spectrum over 0 ... 0.15 fs, with its sum (the static compliance) and the kernel's Nyquist
response kept (:func:`precursor_correction`). Adding only the precursor's sum to lag 0 left the
kernel 3 % (excitation element) to 5 % (neighbours) off the FRF at fs / 10, mostly in phase; the
fit brings that to 0.4-0.7 %.

Laplace domain (convolution-quadrature kernels): :func:`element_laplace` is g(x, y, s) at complex s,
Re s >= 0, the analytic continuation of the FRF (omega^2 = -s^2, E(omega) -> E(s); equal to
:func:`element_frf` on the frequency axis), with the k rule's wave scales taken at |s| (see there).

The quasi-static kernel is g(omega = 0) computed with the material's quasi-static modulus and the
static layer compliance H0 = 2 (1 - nu^2) / (E k) L(kh).

Choices (where the specification left one)
------------------------------------------
* ``n_fft`` must be a power of two >= 4096 (exact binary frequency grid, fast FFT).
* The Nyquist bin enters irfft through its real part only (numpy's convention).
* ``precursor_energy_fraction`` is taken over the whole offset table (every (dx, dy) of the
  table, so each unique offset is weighted by how often it occurs): energy in samples
  n >= N_fft/2 (negative time) over the total energy.
* k quadrature (8-point Gauss-Legendre panels): one panel on [0, k0], geometric panels (ratio
  1 + eta_min/2, clipped to 1.01 ... 1.05, eta_min = smallest loss factor above half the first
  thickness resonance) from k0 = 0.05 min(1/h, 1/c) to 1.5 times the largest Rayleigh wavenumber in
  the band, so that lightly damped wave and guided-mode peaks are resolved; then a tail to
  k_max = max(40/c, 20/h, 10 k_wave). No panel is wider than one period 2 pi / r_max of the Bessel
  factor at the largest offset served. Beyond k_max the remainder is replaced by its leading
  asymptote R ~ beta(nu) eps_s / (E k^3) (eps_s = rho omega^2 / mu), whose transform is frequency
  independent and computed once.
* Offsets are processed in groups r <= 32c, (32c, 64c], (64c, 128c], ...; each group has its own
  rule (its own Bessel period), and groups beyond 32c stop at 20/c instead of 40/c (the cut then
  falls on an oscillating integrand and costs < 2e-7 of the self-compliance). This keeps large
  patches (150 x 200 elements) affordable.
* The quasi-static kernel's remainder R0 decays like exp(-2kh); its rule stops at 25/h.
* Measured accuracy (tests): refinement (panels halved, k_max doubled) changes the dynamic FRF by
  < 1e-7 and the static kernel by < 1e-9 of the self-compliance; a padded 2-D FFT agrees to 1e-4.

References
----------
Love, A. E. H. (1929), Phil. Trans. R. Soc. A 228, 377. doi:10.1098/rsta.1929.0009
The seed study, :data:`tyreroad.SEED_REFERENCE` (the element Green's function and its time-domain use).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Any, Mapping, NamedTuple

import numpy as np
import scipy.special as sp
import xarray as xr
from numba import njit, prange

from . import checks, layer
from .influence import offset_influences
from .memory import fit_retardation_spectrum, wrapped_creep
from .reference import love

logger = logging.getLogger(__name__)

__all__ = [
    "GreensSettings",
    "WavenumberQuadrature",
    "wavenumber_quadrature",
    "square_load_harmonics",
    "bessel_weights",
    "unique_offsets",
    "offset_table_index",
    "element_frf",
    "element_laplace",
    "ElementFRF",
    "static_element_kernel",
    "time_kernel",
    "precursor_correction",
    "greens_dataset",
]

_MIN_N_FFT = 4096
#: How the greens stage turns the element FRF into the march's kernel (config ``greens.construction``):
#: ``seed`` the paper's band-limited IFFT with the negative-time part discarded; ``fold`` the same IFFT
#: with a causal material's band-limit precursor replaced by a causal correction of the first lags;
#: ``passive`` (the default) ``fold`` plus a causal FIR on the excitation element that makes the march
#: stable for springs up to 1.2e5 N/m (:mod:`tyreroad.construction`, applied by the greens stage); ``radau`` the
#: Radau IIA-3 stage kernel (:mod:`tyreroad.stage`, three unknowns per element and step), stable for every spring
#: equal at the three stages of a step, hard contact included (the file also holds the ``fold`` kernel as ``g``).
KERNEL_CONSTRUCTIONS = ("seed", "fold", "passive", "radau")
#: Creep-fit error below which a material counts as causal, so that its precursor is band-limit ringing.
CAUSAL_FIT_ERROR = 1e-2
#: Lags that take the place of a causal material's discarded precursor (see precursor_correction).
PRECURSOR_TAPS = 5
#: Band [0, PRECURSOR_BAND fs] over which that correction matches the precursor's spectrum.
PRECURSOR_BAND = 0.15
# Relative size below which an angular harmonic a_n(k) of the square load is dropped.
_HARMONIC_TOL = 1e-13
# k rules for offsets r >= _FAR c may stop at 20/c instead of 40/c (see wavenumber_quadrature).
_FAR = 16.0
# Offsets are processed in groups r in [0, 32c], (32c, 64c], (64c, 128c], ...: each group gets a k rule
# whose panels resolve its own largest Bessel period (and, being beyond _FAR, the shorter k range).
_GROUP = 32.0


# ----------------------------------------------------------------------------------------------
# settings


@dataclass(frozen=True)
class GreensSettings:
    """Sampling of the time-domain Green's functions (config section ``greens``).

    Parameters
    ----------
    sample_rate : float
        Sampling rate fs of the contact simulation [Hz].
    n_lags : int
        Number of kept time lags L of the kernel (the paper: 256).
    n_fft : int
        Number of time samples of the inverse transform; the FRF is sampled at
        f_j = j fs / n_fft, j = 0 ... n_fft/2. A power of two >= 4096.
    construction : str
        How the kernel is built from the FRF, one of :data:`KERNEL_CONSTRUCTIONS`.
    """

    sample_rate: float = 51200.0
    n_lags: int = 256
    n_fft: int = 4096
    construction: str = "passive"

    def __post_init__(self):
        fs = checks.real("greens.sample_rate", self.sample_rate, positive=True)
        for key in ("n_lags", "n_fft"):
            v = getattr(self, key)
            if isinstance(v, float):
                raise ValueError(f"greens.{key}: expected an integer >= 1, got {v!r}")
            checks.integer(f"greens.{key}", v)
        n = int(self.n_fft)
        if n < _MIN_N_FFT or n & (n - 1):
            raise ValueError(f"greens.n_fft must be a power of two >= {_MIN_N_FFT}, got {n}")
        if self.n_lags > n // 2:
            raise ValueError(f"greens.n_lags must be <= n_fft/2 = {n // 2}, got {self.n_lags}")
        if self.construction not in KERNEL_CONSTRUCTIONS:
            raise ValueError(f"greens.construction: expected one of {list(KERNEL_CONSTRUCTIONS)}, got "
                             f"{self.construction!r}")
        object.__setattr__(self, "sample_rate", float(fs))
        object.__setattr__(self, "n_lags", int(self.n_lags))
        object.__setattr__(self, "n_fft", n)

    @classmethod
    def from_config(cls, section: Mapping[str, Any]) -> "GreensSettings":
        """Build from the ``greens`` config section; missing keys take the defaults (the paper's
        51.2 kHz, 256 lags, n_fft 4096), unknown keys raise ``ValueError``."""
        if not isinstance(section, Mapping):
            raise ValueError(f"config section 'greens' must be a mapping, got {type(section).__name__}")
        keys = {"sample_rate", "n_lags", "n_fft", "construction"}
        unknown = set(section) - keys
        if unknown:
            raise ValueError(f"greens: unknown key(s) {sorted(unknown)}; expected {sorted(keys)}")
        return cls(**{key: section[key] for key in keys if key in section})

    @property
    def frequencies(self) -> np.ndarray:
        """FRF sampling frequencies f_j = j fs / n_fft, j = 0 ... n_fft/2 [Hz]."""
        return np.arange(self.n_fft // 2 + 1) * (self.sample_rate / self.n_fft)


# ----------------------------------------------------------------------------------------------
# wavenumber quadrature and Bessel/harmonic weights


@dataclass(frozen=True)
class WavenumberQuadrature:
    """Composite Gauss-Legendre rule on [0, k_max] for the k integrals.

    Parameters
    ----------
    nodes : numpy.ndarray
        Wavenumbers k_i [rad/m].
    weights : numpy.ndarray
        Quadrature weights [rad/m].
    k_max : float
        Upper end of the rule [rad/m].
    """

    nodes: np.ndarray
    weights: np.ndarray
    k_max: float = np.inf


def wavenumber_quadrature(
    element_size: float,
    thickness: float,
    k_wave: float = 0.0,
    relative_width: float = 0.05,
    r_max: float = 0.0,
    refine: float = 1.0,
    nodes_per_panel: int = 8,
    r_min: float = 0.0,
    k_max: float | None = None,
) -> WavenumberQuadrature:
    """Composite Gauss-Legendre rule resolving wave peaks, guided modes and the Bessel oscillation.

    Parameters
    ----------
    element_size : float
        Element size c [m].
    thickness : float
        Layer thickness h [m].
    k_wave : float
        Largest wavenumber at which the compliance may peak (Rayleigh wavenumber at the top
        frequency) [rad/m]; 0 for a static kernel.
    relative_width : float
        Relative half-width of the narrowest peak, about eta_min / 2 [-]; sets the geometric panel
        ratio (clipped to 0.01 ... 0.05).
    r_max : float
        Largest offset the rule must serve [m]; panels are no wider than 2 pi / r_max.
    refine : float
        >= 1 shrinks all panels by this factor and extends k_max by it (convergence checks).
    nodes_per_panel : int
        Gauss-Legendre nodes per panel.
    r_min : float
        Smallest offset the rule must serve [m]. When r_min >= 16 c the default k_max uses 20/c
        instead of 40/c: there the truncated integrand oscillates (Bessel factor) and the cut costs
        < 2e-7 of the self-compliance.
    k_max : float, optional
        Upper end [rad/m] before refinement; default max(40/c or 20/c, 20/h, 10 k_wave).

    Returns
    -------
    WavenumberQuadrature
    """
    c = float(element_size)
    h = float(thickness)
    if not (c > 0 and h > 0):
        raise ValueError(f"element_size and thickness must be > 0, got {c}, {h}")
    if refine < 1:
        raise ValueError(f"refine must be >= 1, got {refine}")
    rel = min(max(float(relative_width), 0.01), 0.05) / refine
    width_cap = 2 * np.pi / r_max / refine if r_max > 0 else np.inf
    k0 = 0.05 * min(1 / h, 1 / c)
    k_hi = max(1.5 * k_wave, 2 * k0)
    if k_max is None:
        k_max = max((40.0 if r_min < _FAR * c else 20.0) / c, 20 / h, 10 * k_wave)
    k_max = refine * max(float(k_max), k_hi)
    edges = [0.0, k0]
    k = k0
    while k < k_hi:
        k = min(k + min(rel * k, width_cap), k_hi)
        edges.append(k)
    tail_ratio = 0.25 / refine
    while k < k_max:
        k = min(k + min(tail_ratio * k, width_cap), k_max)
        edges.append(k)
    edges = np.asarray(edges)
    x, w = np.polynomial.legendre.leggauss(int(nodes_per_panel))
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    nodes = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    weights = (half[:, None] * w[None, :]).ravel()
    return WavenumberQuadrature(nodes=nodes, weights=weights, k_max=float(edges[-1]))


def _sinc(x):
    """sin(x) / x with the limit 1 at x = 0."""
    small = np.abs(x) < 1e-4
    xs = np.where(small, 1.0, x)
    return np.where(small, 1.0 - x * x / 6.0, np.sin(xs) / xs)


def square_load_harmonics(kc) -> tuple[np.ndarray, np.ndarray]:
    """Angular harmonics of the spectrum of a uniformly loaded square.

    P(k, theta) = sinc(k c cos(theta) / 2) sinc(k c sin(theta) / 2) = sum_n a_n(k c) cos(4 n theta).

    Parameters
    ----------
    kc : array_like
        Dimensionless wavenumbers k c [-].

    Returns
    -------
    coeffs : numpy.ndarray
        a_n(k c), shape (len(kc), n_max) [-].
    count : numpy.ndarray
        Number of harmonics that matter at each k (|a_n| > 1e-13 for some n < count) [-].
    """
    kc = np.atleast_1d(np.asarray(kc, dtype=float))
    # the product is band-limited in theta to about (kc / sqrt 2) + O(1) harmonics
    m = 64
    while m < 2 * (kc.max(initial=0.0) + 80):
        m *= 2
    theta = 2 * np.pi * np.arange(m) / m
    p = _sinc(np.outer(kc / 2, np.cos(theta))) * _sinc(np.outer(kc / 2, np.sin(theta)))
    spec = np.fft.rfft(p, axis=1).real / m
    orders = np.arange(0, spec.shape[1], 4)
    coeffs = 2 * spec[:, orders]
    coeffs[:, 0] /= 2
    big = np.abs(coeffs) > _HARMONIC_TOL
    count = np.where(big.any(axis=1), coeffs.shape[1] - np.argmax(big[:, ::-1], axis=1), 1)
    n_used = int(count.max())
    if n_used >= coeffs.shape[1] - 2:
        raise RuntimeError("square_load_harmonics: angular sampling too coarse")  # guard, m above prevents it
    return coeffs[:, :n_used].copy(), count.astype(np.int64)


@njit(cache=True, parallel=True)
def _bessel_weights(k, wk, coeffs, count, r, cos4, j0, j1, out):
    """W[i, o] = wk_i k_i / (2 pi) sum_n a_n(k_i) J_4n(k_i r_o) cos(4 n phi_o).

    J_m by upward recurrence where it is stable (x >= m), by Miller's backward recurrence
    normalised with J_0 + 2 sum J_2k = 1 otherwise.
    """
    nk = k.shape[0]
    no = r.shape[0]
    two_pi = 2.0 * np.pi
    for i in prange(nk):
        ki = k[i]
        pref = wk[i] * ki / two_pi
        nh = count[i]
        mmax = 4 * (nh - 1)
        buf = np.empty(mmax + 2)
        for o in range(no):
            x = ki * r[o]
            if r[o] == 0.0:
                out[i, o] = pref * coeffs[i, 0]
                continue
            if nh == 1:
                out[i, o] = pref * coeffs[i, 0] * j0[i, o]
                continue
            if x >= mmax:
                buf[0] = j0[i, o]
                buf[1] = j1[i, o]
                for m in range(1, mmax):
                    buf[m + 1] = (2.0 * m / x) * buf[m] - buf[m - 1]
            else:
                start = 2 * ((mmax + int(math.sqrt(400.0 * mmax)) + 2) // 2)
                bjp = 0.0
                bj = 1.0
                total = 0.0
                add = False
                for m in range(mmax + 1):
                    buf[m] = 0.0
                for j in range(start, 0, -1):
                    bjm = (2.0 * j / x) * bj - bjp
                    bjp = bj
                    bj = bjm
                    if abs(bj) > 1e100:
                        bj *= 1e-100
                        bjp *= 1e-100
                        total *= 1e-100
                        for m in range(j, mmax + 1):
                            buf[m] *= 1e-100
                    if add:
                        total += bj
                    add = not add
                    if j - 1 <= mmax:
                        buf[j - 1] = bj
                norm = 2.0 * total - bj
                for m in range(mmax + 1):
                    buf[m] /= norm
            acc = 0.0
            for n in range(nh):
                acc += coeffs[i, n] * buf[4 * n] * cos4[o, n]
            out[i, o] = pref * acc


def bessel_weights(quadrature: WavenumberQuadrature, offsets, element_size: float) -> np.ndarray:
    """Frequency-independent weights W[k_i, offset] of the remainder transform.

    g_R(offset) = sum_i R(k_i) W[i, offset] is the inverse 2-D transform of R(|k|) times the
    spectrum of a unit force spread over one c x c element.

    Parameters
    ----------
    quadrature : WavenumberQuadrature
        k nodes and weights.
    offsets : array_like
        Offsets (x, y) from the loaded element's centre, shape (n, 2) [m].
    element_size : float
        Element size c [m].

    Returns
    -------
    numpy.ndarray
        W, shape (n_k, n) [1/m^2].
    """
    offsets = np.asarray(offsets, dtype=float)
    if offsets.ndim != 2 or offsets.shape[1] != 2:
        raise ValueError(f"offsets must have shape (n, 2), got {offsets.shape}")
    c = float(element_size)
    if not c > 0:
        raise ValueError(f"element_size must be > 0, got {element_size}")
    k = np.ascontiguousarray(quadrature.nodes, dtype=float)
    wk = np.ascontiguousarray(quadrature.weights, dtype=float)
    if k.shape != wk.shape or k.ndim != 1 or np.any(k <= 0):
        raise ValueError("quadrature nodes must be a 1-D array of positive wavenumbers matching the weights")
    coeffs, count = square_load_harmonics(k * c)
    r = np.hypot(offsets[:, 0], offsets[:, 1])
    phi = np.arctan2(offsets[:, 1], offsets[:, 0])
    cos4 = np.cos(4.0 * np.outer(phi, np.arange(coeffs.shape[1])))
    coeffs = np.ascontiguousarray(coeffs)
    out = np.empty((k.size, r.size))
    # chunks over offsets bound the J0/J1 temporaries (~2^22 values each)
    step = max(1, (1 << 22) // k.size)
    for start in range(0, r.size, step):
        sl = slice(start, start + step)
        x = np.outer(k, r[sl])
        chunk = np.empty(x.shape)
        _bessel_weights(k, wk, coeffs, count, r[sl], np.ascontiguousarray(cos4[sl]), sp.j0(x), sp.j1(x), chunk)
        out[:, sl] = chunk
    return out


# ----------------------------------------------------------------------------------------------
# offsets


def unique_offsets(n_elements) -> np.ndarray:
    """Unique offsets (a, b), a >= b >= 0, of an nx x ny patch, up to the x <-> y and sign symmetries.

    Parameters
    ----------
    n_elements : (int, int)
        Elements (nx, ny) of the patch.

    Returns
    -------
    numpy.ndarray
        Integer offsets in elements, shape (n, 2), sorted by a then b.
    """
    nx, ny = _check_n_elements(n_elements)
    big, small = max(nx, ny), min(nx, ny)
    pairs = [(a, b) for a in range(big) for b in range(min(a, small - 1) + 1)]
    return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)


def offset_table_index(n_elements) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index of each table offset (dx, dy) into :func:`unique_offsets`.

    Returns
    -------
    dx, dy : numpy.ndarray
        Offsets -(nx-1) ... nx-1 and -(ny-1) ... ny-1 [elements].
    index : numpy.ndarray
        index[i, j] = position of (max(|dx_i|, |dy_j|), min(...)) in ``unique_offsets``.
    """
    nx, ny = _check_n_elements(n_elements)
    uniq = unique_offsets((nx, ny))
    lookup = -np.ones((max(nx, ny), max(nx, ny)), dtype=np.int64)
    lookup[uniq[:, 0], uniq[:, 1]] = np.arange(len(uniq))
    dx = np.arange(-(nx - 1), nx)
    dy = np.arange(-(ny - 1), ny)
    ax, ay = np.abs(dx)[:, None], np.abs(dy)[None, :]
    index = lookup[np.maximum(ax, ay), np.minimum(ax, ay)]
    assert np.all(index >= 0)
    return dx, dy, index


def _check_n_elements(n_elements) -> tuple[int, int]:
    try:
        nx, ny = n_elements
    except (TypeError, ValueError):
        raise ValueError(f"n_elements: expected a pair of positive integers (nx, ny), got {n_elements!r}") from None
    return checks.integer("n_elements[0]", nx), checks.integer("n_elements[1]", ny)


# ----------------------------------------------------------------------------------------------
# kernels


def _rayleigh_wavenumber(omega, modulus, poisson, density) -> float:
    """Largest real part of the Rayleigh wavenumber over the band [rad/m] (c_R >= 0.87 c_s, nu >= 0)."""
    return float(np.max(_shear_wavenumber(omega, modulus, poisson, density), initial=0.0)) / 0.87


def _shear_wavenumber(omega, modulus, poisson, density) -> np.ndarray:
    """Re k_s = Re(omega sqrt(rho / mu(omega))) [rad/m]."""
    mu = np.asarray(modulus, dtype=complex) / (2 * (1 + poisson))
    return (np.asarray(omega, dtype=float) * np.sqrt(density / mu)).real


def _tail_coefficient(poisson: float) -> float:
    """beta(nu) of the large-k remainder R ~ beta eps_s / (E k^3), eps_s = rho omega^2 / mu [-].

    Second term of the expansion of the dynamic half-space compliance
    alpha eps_s / (mu (4 k^2 alpha beta - Q^2)) in eps_s / k^2 (the layer terms are O(exp(-2kh))).
    """
    gam = (1 - 2 * poisson) / (2 * (1 - poisson))  # mu / M
    return 2 * (1 - poisson**2) * ((1.5 - gam + gam**2 / 2) / (2 * (1 - gam)) - gam / 2)


def _tail_weights(k_max: float, offsets: np.ndarray, element_size: float) -> np.ndarray:
    """T[o] = 1/(2 pi) int_{k_max}^inf k^-2 sum_n a_n J_4n(k r) cos(4 n phi) dk [1/m].

    Only offsets within 3 elements get a tail: further out the integrand oscillates and its
    endpoint contribution is below 1e-8 of g(0) (amplitude ~ (k_max c)^-4.5 (c / r)^1.5).
    """
    c = element_size
    r = np.hypot(offsets[:, 0], offsets[:, 1])
    near = r <= 3.0 * c * (1 + 1e-12)
    out = np.zeros(len(offsets))
    if not near.any():
        return out
    cap = 2 * np.pi / max(r[near].max(), c)
    edges = [k_max]
    # the tail integrand decays like k^-4, so stopping at 8 k_max leaves 0.2 % of a term that is
    # itself ~ (k_s c)^2 / (k_max c)^3 of g(0)
    while edges[-1] < 8 * k_max:
        edges.append(edges[-1] + min(0.2 * edges[-1], cap))
    edges = np.asarray(edges)
    x, w = np.polynomial.legendre.leggauss(8)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    quad = WavenumberQuadrature(
        nodes=(mid[:, None] + half[:, None] * x).ravel(), weights=(half[:, None] * w).ravel()
    )
    weights = bessel_weights(quad, offsets[near], c)
    out[near] = (weights / quad.nodes[:, None] ** 3).sum(axis=0)
    return out


def element_frf(
    offsets,
    element_size: float,
    omega,
    modulus,
    poisson: float,
    density: float,
    thickness: float,
    refine: float = 1.0,
    block: int = 128,
) -> np.ndarray:
    """Element Green's function g(x, y, omega) of the layer at given offsets and frequencies.

    Parameters
    ----------
    offsets : array_like
        Offsets (x, y) of the field element centres from the loaded element's centre, (n, 2) [m].
    element_size : float
        Element size c [m].
    omega : array_like
        Angular frequencies [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus E(omega) at ``omega`` [Pa] (exp(+i omega t), Im E >= 0).
    poisson : float
        Poisson's ratio [-].
    density : float
        Density [kg/m^3].
    thickness : float
        Layer thickness h [m].
    refine : float
        k-quadrature refinement factor (>= 1), for convergence checks.
    block : int
        Frequencies per block (memory).

    Returns
    -------
    numpy.ndarray
        Complex g, shape (len(omega), n) [m/N].

    References
    ----------
    Love (1929), doi:10.1098/rsta.1929.0009
    """
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 2)
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    modulus = np.broadcast_to(np.asarray(modulus, dtype=complex), omega.shape)
    if np.any(omega < 0) or not np.all(np.isfinite(omega)):
        raise ValueError("element_frf: omega must be finite and >= 0")
    if np.any(modulus.real <= 0) or np.any(modulus.imag < 0):
        raise ValueError("element_frf: modulus must have Re E > 0 and Im E >= 0 (exp(+i omega t) convention)")
    _check_layer(poisson, density, thickness)
    c = float(element_size)
    nu = float(poisson)
    loss = modulus.imag / modulus.real
    # guided-mode and wave peaks exist only above about half the first thickness resonance
    # (k_s h >= pi/4); below it R is smooth in k and its damping does not matter
    wavy = _shear_wavenumber(omega, modulus, poisson, density) * thickness >= np.pi / 4
    eta_min = float(loss[wavy].min()) if wavy.any() else 0.1
    k_wave = _rayleigh_wavenumber(omega, modulus, nu, density)
    out = np.empty((omega.size, len(offsets)), dtype=complex)
    for group in _offset_groups(offsets, c):
        out[:, group] = _element_group(
            offsets[group], c, omega, modulus, nu, density, thickness, k_wave, eta_min, refine, block
        )
    return out


def _offset_groups(offsets: np.ndarray, element_size: float) -> list[np.ndarray]:
    """Indices of the offsets in r <= 32c, (32c, 64c], (64c, 128c], ... (non-empty groups only)."""
    r = np.hypot(offsets[:, 0], offsets[:, 1]) / (_GROUP * element_size)
    label = np.where(r <= 1.0, 0, np.ceil(np.log2(np.maximum(r, 1.0))).astype(np.int64))
    return [np.flatnonzero(label == g) for g in np.unique(label)]


def _element_group(offsets, c, omega, modulus, nu, density, thickness, k_wave, eta_min, refine, block,
                   laplace: bool = False):
    """element_frf (or, with ``laplace``, element_laplace: ``omega`` holds s and omega^2 = -s^2) for one
    group of offsets: one k rule, its weights, all frequencies."""
    r = np.hypot(offsets[:, 0], offsets[:, 1])
    quad = wavenumber_quadrature(c, thickness, k_wave, eta_min / 2, r.max(), refine, r_min=r.min())
    t0 = time.perf_counter()
    weights = bessel_weights(quad, offsets, c)
    logger.info(
        "element_frf: r <= %.1f c: %d k nodes (k_max c = %.1f), %d offsets, %d frequencies; weights in %.2f s",
        r.max() / c, quad.nodes.size, quad.k_max * c, len(offsets), omega.size, time.perf_counter() - t0,
    )
    love_unit = love.rectangle_potential(offsets[:, 0], offsets[:, 1], c, c) / (np.pi * c * c)
    k = quad.nodes
    # R beyond k_max is its leading asymptote beta eps_s / (E k^3), integrated once for all omega
    tail = _tail_coefficient(nu) * _tail_weights(quad.k_max, offsets, c)
    out = np.empty((omega.size, len(offsets)), dtype=complex)
    for start in range(0, omega.size, block):
        sl = slice(start, start + block)
        e = modulus[sl, None]
        halfspace = 2 * (1 - nu**2) / (e * k[None, :])
        if laplace:
            rem = layer.laplace_compliance(k[None, :], omega[sl, None], e, nu, density, thickness)
            omega2 = -omega[sl, None] ** 2
        else:
            rem = layer.compliance(k[None, :], omega[sl, None], e, nu, density, thickness)
            omega2 = omega[sl, None] ** 2
        rem -= halfspace
        if not np.all(np.isfinite(rem)):
            bad = np.argwhere(~np.isfinite(rem))[0]
            raise FloatingPointError(
                f"layer compliance not finite at {'s' if laplace else 'omega'} = {omega[sl][bad[0]]:.6g} rad/s, "
                f"k = {k[bad[1]]:.6g} rad/m"
            )
        # one real GEMM for both parts: W is real, R complex
        nb = rem.shape[0]
        product = np.concatenate([rem.real, rem.imag]) @ weights
        eps_over_e = 2 * (1 + nu) * density * omega2 / modulus[sl, None] ** 2
        out[sl] = (
            (1 - nu**2) / modulus[sl, None] * love_unit[None, :]
            + eps_over_e * tail[None, :]
            + product[:nb]
            + 1j * product[nb:]
        )
    logger.info("element_frf: done in %.2f s", time.perf_counter() - t0)
    return out


def _laplace_wave_scales(s, modulus_s, poisson, density):
    """Wave scales of the k rule at complex s: Re k_s at omega = |s| [rad/m] and eta_eff [-].

    The k integrand peaks near the Rayleigh and guided-mode wavenumbers. At complex s the pole of a wave
    with complex wavenumber k_s(s) = -i s sqrt(rho / mu(s)) lies at |k_s| ~ |s| sqrt(rho / |mu|) from the
    origin, so the scales of :func:`element_frf` are taken at omega = |s| with E(s): k_wave and the "wavy"
    test use Re(|s| sqrt(rho / mu(s))). Its relative distance from the real k axis, which the geometric panels
    must resolve, is about eta(s) / 2 + Re s / |s|: the material's part (eta(s) = |Im E(s)| / Re E(s), which
    shrinks away from the axis) plus the part Re s adds (a mode of group speed c_g and phase speed c gets
    Im k ~ Re s / c_g, relative Re s c / (|s| c_g) >= Re s / |s| where c_g <= c, i.e. for normally
    dispersive modes and for the bulk and Rayleigh waves; where a mode's c_g exceeds c the estimate is that
    much too wide, which the panel ratio's clip to 1.01 ... 1.05 bounds, and the refinement test off the
    axis (tests/test_greens.py) measures). So
    the damping that sets the panels is eta_eff(s) = |Im E(s)| / Re E(s) + 2 Re s / |s| (the floor
    2 Re s / |s| keeps the rule coarse where no peak can be sharp, e.g. on the real s axis where the
    integrand has no peak at all), its minimum over the s with waves in the layer (k_s h >= pi/4 as in
    element_frf), 0.1 if there are none. On the frequency axis (Re s = 0, Im s >= 0) all three equal
    element_frf's choices at omega = Im s, so the rule, hence g, is the same there.
    """
    mag = np.abs(s)
    k_s = _shear_wavenumber(mag, modulus_s, poisson, density)
    safe = np.where(mag > 0, mag, 1.0)
    eta_eff = np.abs(modulus_s.imag) / modulus_s.real + np.where(mag > 0, 2.0 * s.real / safe, 0.0)
    return k_s, eta_eff


def element_laplace(
    offsets,
    element_size: float,
    s,
    modulus_s,
    poisson: float,
    density: float,
    thickness: float,
    refine: float = 1.0,
    block: int = 128,
) -> np.ndarray:
    """Element Green's function g(x, y, s) [m/N] of the layer at complex Laplace frequencies, Re s >= 0.

    The analytic continuation of :func:`element_frf`, g(x, y, i omega) = element_frf(..., omega, E(omega)),
    for convolution-quadrature kernels, which need the transfer function at s = delta(zeta) / dt off the
    frequency axis (Lubich 1988). The same split and the same k integrals as :func:`element_frf`, with
    omega^2 = -s^2 and E(omega) -> E(s) wherever the frequency enters:

    * the Love part (1 - nu^2) / E(s) and the half-space term 2 (1 - nu^2) / (E(s) k) of the remainder;
    * the layer compliance, :func:`tyreroad.layer.laplace_compliance` (e_s = -rho (s h)^2 / mu(s));
    * the large-k tail beta eps_s / (E k^3): eps_over_e = -2 (1 + nu) rho s^2 / E(s)^2.

    Every term is analytic in s for a fixed k rule. The rule (panels, k_max) is chosen once per call from
    all the s of the call, like element_frf's from its band: wave scales at |s| and a damping floor
    (``_laplace_wave_scales``: eta_eff(s) = |Im E(s)| / Re E(s) + 2 Re s / |s|). Evaluate the s that must be
    mutually consistent (finite differences, one CQ contour) in one call; the rule's own error is that of
    element_frf (< 1e-7 of the self-compliance under refinement). On the frequency axis the rule is
    element_frf's, so g(i omega) equals element_frf to rounding.

    Parameters
    ----------
    offsets : array_like
        Offsets (x, y) of the field element centres from the loaded element's centre, (n, 2) [m].
    element_size : float
        Element size c [m].
    s : array_like of complex
        Laplace frequencies [rad/s], finite, Re s >= 0.
    modulus_s : array_like of complex
        E(s) at ``s`` [Pa] (``Material.laplace_modulus``): Re E > 0 and passive, Re(s / sqrt E) >= 0.
    poisson : float
        Poisson's ratio [-].
    density : float
        Density [kg/m^3].
    thickness : float
        Layer thickness h [m].
    refine : float
        k-quadrature refinement factor (>= 1), for convergence checks.
    block : int
        Laplace frequencies per block (memory).

    Returns
    -------
    numpy.ndarray
        Complex g, shape (len(s), n) [m/N]; g(conj s) = conj g(s); real for real s; g(0) is the static
        element kernel with E(0).

    References
    ----------
    Love (1929), doi:10.1098/rsta.1929.0009
    Lubich (1988), Numer. Math. 52, 129-145. doi:10.1007/BF01398686
    """
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 2)
    s = np.atleast_1d(layer._laplace_frequency(s))
    modulus_s = np.broadcast_to(layer._laplace_modulus_array(s, modulus_s), s.shape)
    _check_layer(poisson, density, thickness)
    c = float(element_size)
    nu = float(poisson)
    k_s, eta_eff = _laplace_wave_scales(s, modulus_s, nu, density)
    wavy = k_s * thickness >= np.pi / 4
    eta_min = float(eta_eff[wavy].min()) if wavy.any() else 0.1
    k_wave = float(np.max(k_s, initial=0.0)) / 0.87  # as _rayleigh_wavenumber, at omega = |s|
    out = np.empty((s.size, len(offsets)), dtype=complex)
    for group in _offset_groups(offsets, c):
        out[:, group] = _element_group(
            offsets[group], c, s, modulus_s, nu, density, thickness, k_wave, eta_min, refine, block, laplace=True
        )
    return out


def static_element_kernel(
    offsets,
    element_size: float,
    modulus: float,
    poisson: float,
    thickness: float,
    refine: float = 1.0,
) -> np.ndarray:
    """Static element Green's function of the layer (the quasi-static kernel) [m/N].

    Uses H0(k) = 2 (1 - nu^2) / (E k) L(kh) (:func:`tyreroad.layer.static_layer_factor`), so that
    the remainder R0 = 2 (1 - nu^2) / (E k) (L(kh) - 1) is formed without cancellation.

    Parameters
    ----------
    offsets : array_like
        Offsets (x, y), shape (n, 2) [m].
    element_size : float
        Element size c [m].
    modulus : float
        Static Young's modulus [Pa].
    poisson : float
        Poisson's ratio [-].
    thickness : float
        Layer thickness h [m].
    refine : float
        k-quadrature refinement factor (>= 1).

    Returns
    -------
    numpy.ndarray
        g_static, shape (n,) [m/N].
    """
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 2)
    e = float(modulus)
    if not e > 0:
        raise ValueError(f"static modulus must be > 0 [Pa], got {modulus}")
    _check_layer(poisson, 1.0, thickness)
    c = float(element_size)
    nu = float(poisson)
    out = (1 - nu**2) / e * love.rectangle_potential(offsets[:, 0], offsets[:, 1], c, c) / (np.pi * c * c)
    for group in _offset_groups(offsets, c):
        r_max = float(np.hypot(offsets[group, 0], offsets[group, 1]).max())
        # R0 ~ -(2 (1 - nu^2) / (E k)) 4 (kh)^2 exp(-2kh) / (3 - 4 nu): 25/h leaves < 1e-18
        quad = wavenumber_quadrature(c, thickness, 0.0, 0.05, r_max, refine, k_max=25.0 / thickness)
        k = quad.nodes
        rem = 2 * (1 - nu**2) / (e * k) * (layer.static_layer_factor(k * thickness, nu) - 1.0)
        out[group] += rem @ bessel_weights(quad, offsets[group], c)
    return out


def _check_layer(poisson, density, thickness):
    checks.poisson_ratio(poisson)
    checks.real("density", density, positive=True)
    checks.real("thickness", thickness, positive=True)


class TimeKernel(NamedTuple):
    """What :func:`time_kernel` returns (see there)."""

    kernel: np.ndarray
    precursor_energy: np.ndarray
    total_energy: np.ndarray
    second_half_sum: np.ndarray
    projected: np.ndarray | None


def time_kernel(frf, n_fft: int, n_lags: int, correction: np.ndarray | None = None) -> TimeKernel:
    """Discrete impulse responses from FRF samples on f_j = j fs / n_fft.

    Parameters
    ----------
    frf : array_like
        Complex FRF, shape (n_fft/2 + 1, ...) [m/N], first axis frequency.
    n_fft : int
        Transform length.
    n_lags : int
        Kept lags L.
    correction : numpy.ndarray, optional
        Matrix M of :func:`precursor_correction`, shape (taps, n_fft/2); if given, M applied to the
        negative-time samples g[-1], g[-2], ..., g[-n_fft/2] is returned as ``projected``.

    Returns
    -------
    TimeKernel
        A named tuple of:
    kernel : numpy.ndarray
        g[n], n < L, shape (L, ...) [m/N]; sum over all n_fft samples equals frf[0].
    precursor_energy : numpy.ndarray
        Energy sum g[n]^2 over n >= n_fft/2 (negative time), shape (...) [m^2/N^2].
    total_energy : numpy.ndarray
        Energy over all n_fft samples, shape (...) [m^2/N^2].
    second_half_sum : numpy.ndarray
        Sum of g[n] over n >= n_fft/2 [m/N] (the precursor and the causal creep there), shape (...).
    projected : numpy.ndarray or None
        With ``correction``: M @ (g[-1], ..., g[-n_fft/2]), shape (taps, ...) [m/N]; else None.
    """
    frf = np.asarray(frf)
    if frf.shape[0] != n_fft // 2 + 1:
        raise ValueError(f"frf has {frf.shape[0]} frequencies, expected n_fft/2 + 1 = {n_fft // 2 + 1}")
    if not 1 <= n_lags <= n_fft // 2:
        raise ValueError(f"n_lags must be in 1 ... n_fft/2, got {n_lags}")
    g = np.fft.irfft(frf, n=n_fft, axis=0)
    second_half = g[n_fft // 2 :]
    projected = None
    if correction is not None:
        if correction.shape[1:] != (n_fft // 2,):
            raise ValueError(f"correction must have shape (taps, {n_fft // 2}), got {correction.shape}")
        projected = np.tensordot(correction, second_half[::-1], axes=1)
    return TimeKernel(g[:n_lags].copy(), np.sum(second_half**2, axis=0), np.sum(g**2, axis=0),
                      second_half.sum(axis=0), projected)


def precursor_correction(n_precursor: int, taps: int = PRECURSOR_TAPS, band: float = PRECURSOR_BAND) -> np.ndarray:
    """Causal stand-in for a discarded precursor: c = M p on the first ``taps`` lags.

    The band-limited impulse response of a causal material rings before t = 0 (its FRF does not
    vanish at fs / 2). The time march needs a causal kernel, so the negative-time samples
    p_k = g[-k], k = 1 ... n_precursor, are replaced by a correction c_0 ... c_{taps-1} added to
    the first lags, the least-squares fit of the precursor's spectrum over the band
    0 <= omega <= Omega = 2 pi ``band`` (omega in rad per sample),

        min_c int_0^Omega | sum_l c_l e^{-i omega l} - sum_k p_k e^{i omega k} |^2 d omega,

    subject to

    * sum_l c_l = sum_k p_k: the DC gain, hence g(omega = 0) and the static compliance, stays exact;
    * sum_l (-1)^l c_l = sum_k p_k: the kernel's response at fs / 2 stays that of adding the
      precursor's sum to lag 0 alone (the previous treatment), so the fit does not change how the
      march behaves at the Nyquist frequency, where no causal kernel can match the FRF.

    The integrals have closed forms (int_0^Omega cos(n omega) d omega = sin(n Omega) / n), so M
    is exact. With the defaults (5 taps, band fs * 0.15) the kernel's DTFT error against the FRF up
    to fs / 10 drops from 3 % to 0.4 % at the excitation element (5 % to 0.7 % at other offsets),
    measured for the default tread and a generalised-Maxwell tread alike; tests/test_greens.py
    checks the latter, whose kernel has decayed within the kept lags. With fewer
    than 3 taps only the DC constraint is kept and the result is the plain sum on lag 0.

    Parameters
    ----------
    n_precursor : int
        Number of negative-time samples p_1 ... p_n (n_fft / 2).
    taps : int
        Number of corrected lags.
    band : float
        Upper end of the fitted band as a fraction of the sampling rate, 0 < band < 0.5 [1].

    Returns
    -------
    numpy.ndarray
        M, shape (taps, n_precursor) [1].
    """
    if n_precursor < 1 or taps < 1:
        raise ValueError(f"n_precursor and taps must be >= 1, got {n_precursor} and {taps}")
    if not 0.0 < band < 0.5:
        raise ValueError(f"band must be in (0, 0.5) of the sampling rate, got {band}")
    if taps < 3:
        out = np.zeros((taps, n_precursor))
        out[0] = 1.0
        return out
    omega = 2.0 * np.pi * band

    def cosine_integral(n):
        n = np.asarray(n, dtype=float)
        safe = np.where(n == 0, 1.0, n)
        return np.where(n == 0, omega, np.sin(omega * n) / safe)

    lag = np.arange(taps)
    k = np.arange(1, n_precursor + 1)
    gram = cosine_integral(lag[:, None] - lag[None, :])
    cross = cosine_integral(lag[:, None] + k[None, :])
    alternating = (-1.0) ** lag
    kkt = np.zeros((taps + 2, taps + 2))
    kkt[:taps, :taps] = gram
    kkt[:taps, taps], kkt[taps, :taps] = 1.0, 1.0
    kkt[:taps, taps + 1], kkt[taps + 1, :taps] = alternating, alternating
    rhs = np.vstack([cross, np.ones((2, n_precursor))])
    return np.linalg.solve(kkt, rhs)[:taps]


# ----------------------------------------------------------------------------------------------
# dataset


class ElementFRF:
    """The exact element FRF of a material's layer, g(dx, dy, f) (:func:`element_frf`).

    The layer's frequency response for :class:`tyreroad.kernel.LayerKernel` and the K*(f) solver
    (:mod:`tyreroad.stiffness`); f = 0 uses E(omega -> 0).

    Parameters
    ----------
    material : tyreroad.material.Material
        The layer (modulus(omega), poisson, density, thickness).
    element_size : float
        c [m].
    """

    def __init__(self, material, element_size: float):
        self.material = material
        self.element_size = checks.real("element_size", element_size, positive=True)

    def frequency_influences(self, frequencies, shape, workers: int = 1) -> list:
        """The influence operator G(f) of each frequency (:func:`tyreroad.influence.offset_influences`)."""
        return offset_influences(self.frequency_response(frequencies, shape), frequencies, shape, workers)

    def frequency_response(self, frequencies, shape) -> np.ndarray:
        """Complex offset tables g(dx, dy, f) [m/N], shape (n_f, 2 nx - 1, 2 ny - 1), at f [Hz]."""
        c, mat = self.element_size, self.material
        uniq = unique_offsets(shape)
        _, _, index = offset_table_index(shape)
        omega = 2 * np.pi * np.asarray(frequencies, dtype=float)
        modulus = np.asarray(mat.modulus(omega), dtype=complex)
        frf = element_frf(uniq * c, c, omega, modulus, mat.poisson, mat.density, mat.thickness)
        return frf[:, index]


def _attrs(units, long_name, **extra):
    return {"units": units, "long_name": long_name, **extra}


def greens_dataset(
    material,
    n_elements,
    element_size: float,
    sample_rate: float,
    n_lags: int,
    n_fft: int,
    frf_map=None,
    construction: str = "fold",
) -> xr.Dataset:
    """Time-domain and quasi-static element Green's functions of a material's tread layer.

    Parameters
    ----------
    material : tyreroad.material.Material
        Provides ``name``, ``poisson``, ``density`` [kg/m^3], ``thickness`` [m],
        ``modulus(omega)`` [Pa] and ``quasi_static_modulus`` [Pa].
    n_elements : (int, int)
        Elements (nx, ny) of the contact patch; offsets -(n-1) ... n-1 are tabulated.
    element_size : float
        Element size c [m].
    sample_rate : float
        Sampling rate [Hz].
    n_lags : int
        Kept lags.
    n_fft : int
        Transform length (power of two >= 4096).
    frf_map : callable, optional
        (frf, omega, offsets) -> frf: replaces the element FRF on the transform's grid before the
        time kernel is built (a candidate construction, e.g. :func:`tyreroad.cq.blend_map`; offsets
        in m, frf (n_frequencies, n_offsets)). None: the FRF itself.
    construction : str
        One of :data:`KERNEL_CONSTRUCTIONS` (``seed``: the precursor is discarded even for a causal
        material, as the paper did; ``fold``: it is replaced by a causal correction; ``passive``: as
        ``fold`` here, the stage then adds :func:`tyreroad.construction.correct_greens`; ``radau``: as
        ``fold`` here, the stage then adds the stage kernel, :func:`tyreroad.stage.radau_greens`).

    Returns
    -------
    xarray.Dataset
        ``g[dx, dy, lag]``, ``g_static[dx, dy]``, ``frf_real/frf_imag[frequency]`` at the excitation
        element, ``storage_modulus``/``loss_factor[frequency]``, ``kept_fraction``,
        ``precursor_energy_fraction``; attrs ``sample_rate``, ``n_fft``, ``element_size``.
    """
    settings = GreensSettings(sample_rate=sample_rate, n_lags=n_lags, n_fft=n_fft, construction=construction)
    nx, ny = _check_n_elements(n_elements)
    c = float(element_size)
    if not c > 0:
        raise ValueError(f"element_size must be > 0 [m], got {element_size}")
    t0 = time.perf_counter()
    freq = settings.frequencies
    omega = 2 * np.pi * freq
    modulus = np.asarray(material.modulus(omega), dtype=complex)
    uniq = unique_offsets((nx, ny))
    offsets = uniq * c
    logger.info(
        "greens %s: %d x %d patch, %d unique offsets, %d frequencies up to %.0f Hz",
        material.name, nx, ny, len(uniq), freq.size, freq[-1],
    )
    fs, n_fft, n_lags = settings.sample_rate, settings.n_fft, settings.n_lags
    taps = min(PRECURSOR_TAPS, n_lags)
    correction = precursor_correction(n_fft // 2, taps)
    kernel = np.empty((n_lags, len(uniq)))
    pre = np.empty(len(uniq))
    tot = np.empty(len(uniq))
    g_zero = np.empty(len(uniq))
    second_half = np.empty(len(uniq))
    projected = np.empty((taps, len(uniq)))
    # group by group keeps the FRF of a 150 x 200 patch (2049 x 19k complex) out of memory
    for group in _offset_groups(offsets, c):
        frf = element_frf(offsets[group], c, omega, modulus, material.poisson, material.density, material.thickness)
        if frf_map is not None:
            frf = frf_map(frf, omega, offsets[group])
        kernel[:, group], pre[group], tot[group], second_half[group], projected[:, group] = time_kernel(
            frf, n_fft, n_lags, correction
        )
        g_zero[group] = frf[0].real
        if group[0] == 0:
            frf_excitation = frf[:, 0]
    g_static = static_element_kernel(offsets, c, material.quasi_static_modulus, material.poisson, material.thickness)

    # long memory (SPEC 9, tyreroad.memory): remove the creep the n_fft-point transform folded back
    # onto the kept lags; replace the discarded non-causal precursor by a causal correction on the
    # first lags that keeps its sum (the DC gain); the tail then holds exactly what the kept lags
    # miss of g(0)
    creep = fit_retardation_spectrum(material, fs / 2)
    wrapped = wrapped_creep(creep, n_fft, n_lags, fs)
    # the second half of the transform (n >= n_fft/2) is the precursor plus the causal creep between
    # n_fft/2 and n_fft samples and what wrapped onto it from beyond; per unit g(0):
    second_half_lags = np.arange(n_fft // 2, n_fft + 1) - 0.5
    causal_second_half = wrapped_creep(creep, n_fft, n_fft // 2, fs, first=n_fft // 2) + np.diff(
        creep.creep(second_half_lags / fs) / creep.relaxed_compliance
    )
    precursor_sum = second_half - g_zero * causal_second_half.sum()
    # For a causal material the precursor is the band limit's ringing: it belongs to t >= 0
    # (precursor_correction); a material that is not causal itself (the seed's loss-scaled
    # variants) has a negative-time response of its own, which stays discarded as the seed
    # discarded it.
    causal = creep.fit_error <= CAUSAL_FIT_ERROR
    fold_precursor = causal and construction != "seed"  # passive: fold here, its FIR is added after
    kept_before = float(kernel[:, 0].sum() / g_zero[0])
    kernel -= wrapped[:, None] * g_zero[None, :]
    if fold_precursor:
        kernel[:taps] += projected - (correction @ causal_second_half[::-1])[:, None] * g_zero[None, :]
    tail_compliance = g_zero - kernel.sum(axis=0)

    dx, dy, index = offset_table_index((nx, ny))
    multiplicity = np.bincount(index.ravel(), minlength=len(uniq))
    precursor = float(np.sum(multiplicity * pre) / np.sum(multiplicity * tot))
    kept = float(kernel[:, 0].sum() / frf_excitation[0].real)
    logger.info(
        "greens %s: g(0) = %.4g m/N, static %.4g m/N, kept fraction %.4f (%.4f before removing the wrapped "
        "creep %.4f and %s the precursor sum %.4f), precursor energy %.2e; %.1f s",
        material.name, frf_excitation[0].real, g_static[0], kept, kept_before, wrapped.sum(),
        f"correcting lags 0-{taps - 1} for" if fold_precursor else
        ("discarding (material not causal)" if not causal else "discarding (the seed's construction)"),
        precursor_sum[0] / g_zero[0], precursor, time.perf_counter() - t0,
    )
    g_table = np.ascontiguousarray(np.moveaxis(kernel[:, index], 0, -1))
    ds = xr.Dataset(
        {
            "g": (("dx", "dy", "lag"), g_table, _attrs("m/N", "element Green's function, discrete impulse response")),
            "g_static": (("dx", "dy"), g_static[index], _attrs("m/N", "quasi-static element Green's function")),
            "frf_real": ("frequency", frf_excitation.real, _attrs("m/N", "real part of g at the excitation element")),
            "frf_imag": (
                "frequency",
                frf_excitation.imag,
                _attrs("m/N", "imaginary part of g at the excitation element"),
            ),
            "storage_modulus": ("frequency", modulus.real, _attrs("Pa", "storage modulus E'")),
            "loss_factor": ("frequency", modulus.imag / modulus.real, _attrs("1", "loss factor E''/E'")),
            "kept_fraction": ((), kept, _attrs("1", "sum of kept lags over g(omega=0) at the excitation element")),
            "precursor_energy_fraction": (
                (),
                precursor,
                _attrs("1", "energy of the discarded non-causal part (n >= n_fft/2) over total energy"),
            ),
            "precursor_sum_fraction": (
                (),
                float(precursor_sum[0] / g_zero[0]),
                _attrs("1", "sum of the non-causal precursor over g(omega=0) at the excitation element (replaced "
                       "by a causal correction of the first precursor_taps lags with the same sum when "
                       "precursor_folded = 1, discarded otherwise)"),
            ),
            "wrapped_creep_fraction": (
                (),
                float(wrapped.sum()),
                _attrs("1", "creep beyond n_fft samples the inverse FFT had folded onto the kept lags, "
                       "removed from g, over g(omega=0)"),
            ),
            "tail_compliance": (
                ("dx", "dy"),
                tail_compliance[index],
                _attrs("m/N", "static compliance beyond the kept lags, R = g(omega=0) - sum of g over the lags"),
            ),
            "retardation_time": (
                "retardation",
                creep.times,
                _attrs("s", "retardation times tau_k of the creep fit J(t) = J_g + sum J_k (1 - exp(-t/tau_k))"),
            ),
            "retardation_compliance": (
                "retardation",
                creep.compliances,
                _attrs("1/Pa", "retardation compliances J_k of the creep fit"),
            ),
        },
        coords={
            "dx": ("dx", dx, _attrs("1", "offset in x [elements]")),
            "dy": ("dy", dy, _attrs("1", "offset in y [elements]")),
            "lag": ("lag", np.arange(settings.n_lags), _attrs("1", "time lag [samples]")),
            "frequency": ("frequency", freq, _attrs("Hz", "frequency")),
        },
        attrs={
            "material": str(material.name),
            "sample_rate": settings.sample_rate,
            "n_fft": settings.n_fft,
            "n_lags": settings.n_lags,
            "element_size": c,
            "quasi_static_modulus": float(material.quasi_static_modulus),
            "poisson": float(material.poisson),
            "density": float(material.density),
            "thickness": float(material.thickness),
            "glassy_compliance": creep.glassy_compliance,
            "construction": construction,
            "causal_material": int(causal),
            "precursor_folded": int(fold_precursor),
            "precursor_taps": int(taps) if fold_precursor else 0,
            "precursor_band": PRECURSOR_BAND * settings.sample_rate if fold_precursor else 0.0,
            "creep_fit_error": creep.fit_error,
            # a DMA table run at a study temperature (tyreroad.material): E(f; T) = b_T E_ref(f a_T)
            **({} if getattr(material, "temperature", None) is None else {
                "temperature": float(material.temperature),
                "shift_factor": float(material.shift_factor),
                "vertical_shift_factor": float(material.vertical_shift_factor),
            }),
        },
    )
    return ds
