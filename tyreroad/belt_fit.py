r"""Fitting the flexible belt's part of the kernel (issue 26): the belt's correction table and the vector fit in z.

The construction, its measured accuracy and cost are described in :mod:`tyreroad.belt_kernel`, which holds the
fitted model (:class:`tyreroad.belt_kernel.BeltKernel`) that the contact runs read; this module is what the greens
stage runs.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np
from numba import njit

from . import checks
from .belt import BeltProperties, _sinc, belt_impedance, layer_two_port, ring_modes, ring_truncation
from .belt_kernel import BeltKernel, _check_shape, _closed, _pole_groups, belt_offsets, belt_table_index
from .greens import element_frf

logger = logging.getLogger(__name__)

__all__ = ["belt_correction_table", "fit_belt_kernel"]


# ----------------------------------------------------------------------------------------------
# the correction table


#: Width [rad/m] x h of the Chebyshev panels on which the two-port is interpolated in |k|, and nodes per panel.
_PANEL_WIDTH = 0.2
_PANEL_NODES = 12


@njit(cache=True)
def _mode_terms(kx, ky, c, width, t, bw, tau2, k_base, z_lin, z_quad, out):  # pragma: no cover - numba
    """Mode terms P tau^2 / (Z + K_b) of the ring sum with tau^2, K_b interpolated from Chebyshev panels.

    ``tau2``, ``k_base``: values at the panel nodes (n_panels, n_nodes); ``t``, ``bw``: the nodes on [-1, 1] and
    their barycentric weights. Z = z_quad[0] kx^4 + z_quad[1] kx^2 ky^2 + z_quad[2] ky^4 + z_lin[0] kx^2 +
    z_lin[1] ky^2 + z_lin[2] (complex coefficients). out (len(kx), len(ky)) complex.
    """
    n_panels, n_nodes = tau2.shape
    for i in range(kx.size):
        kx2 = kx[i] * kx[i]
        sx = 1.0 if kx[i] == 0.0 else math.sin(0.5 * c * kx[i]) / (0.5 * c * kx[i])
        for j in range(ky.size):
            ky2 = ky[j] * ky[j]
            k = math.sqrt(kx2 + ky2)
            p = min(int(k / width), n_panels - 1)
            u = 2.0 * (k - p * width) / width - 1.0
            num_t = 0.0 + 0.0j
            num_k = 0.0 + 0.0j
            den = 0.0
            hit = -1
            for q in range(n_nodes):
                d = u - t[q]
                if d == 0.0:
                    hit = q
                    break
                wq = bw[q] / d
                num_t += wq * tau2[p, q]
                num_k += wq * k_base[p, q]
                den += wq
            if hit >= 0:
                ta = tau2[p, hit]
                kb = k_base[p, hit]
            else:
                ta = num_t / den
                kb = num_k / den
            sy = 1.0 if ky[j] == 0.0 else math.sin(0.5 * c * ky[j]) / (0.5 * c * ky[j])
            z = (z_quad[0] * kx2 * kx2 + z_quad[1] * kx2 * ky2 + z_quad[2] * ky2 * ky2
                 + z_lin[0] * kx2 + z_lin[1] * ky2 + z_lin[2])
            out[i, j] = sx * sy * ta / (z + kb)


def _ring_grid(ax, ay, c, omega, e, poisson, density, thickness, belt, interpolate=True, cell=None):
    """Delta g on the separable offset grid ax x ay [m] at one frequency: (len(ax), len(ay)) complex [m/N].

    ``cell`` = (L_x, L_y) [m]: instead of the ring and strip, the patch as one cell of a footprint loaded
    periodically with it (period L_x, L_y), without the uniform (k = 0) mode -- the belt's response to the
    pressure's variation at the patch scale (:func:`belt_correction_table`).

    The mode sum of :func:`tyreroad.belt.belt_element_frf_correction_ring` (same modes, same truncation
    k_max = max(25 / h, 1.5 k_s + 20 / h), same two-port), with the cosine projections done as two matrix
    products C_x^T F C_y instead of a sum per offset (the offsets of a patch are a product grid) and, with
    ``interpolate``, tau^2 and K_b interpolated in |k| instead of solved per mode: they depend on |k| only and
    vary on the scale of 1 / h and, at high frequency, of the tread's damped wave numbers (relative width about
    its loss factor, >= 0.15), so Chebyshev panels of width 0.2 / h with 12 nodes hold the sum to about 1e-11
    of |Delta g_00| (tests/test_belt_kernel.py) with ~30 x fewer two-port solves.
    """
    h = thickness
    k_max = ring_truncation(omega, e, poisson, density, h)
    if cell is None:
        kx, ky, weight = ring_modes(belt, k_max)
    else:
        lx, ly = cell
        n = np.arange(0, int(k_max * lx / (2.0 * math.pi)) + 1, dtype=float)
        q = np.arange(0, int(k_max * ly / (2.0 * math.pi)) + 1, dtype=float)
        kx, ky = 2.0 * math.pi * n / lx, 2.0 * math.pi * q / ly
        weight = np.where(n == 0, 1.0, 2.0)[:, None] * np.where(q == 0, 1.0, 2.0)[None, :] / (lx * ly)
        weight[0, 0] = 0.0  # the uniform mode: the tyre's global deflection under the footprint's mean pressure
    if interpolate:
        width = _PANEL_WIDTH / h
        n_panels = max(1, int(math.ceil(math.hypot(kx[-1], ky[-1]) / width)))
        t = np.cos(np.pi * (np.arange(_PANEL_NODES) + 0.5) / _PANEL_NODES)
        bw = (-1.0) ** np.arange(_PANEL_NODES) * np.sin(np.pi * (np.arange(_PANEL_NODES) + 0.5) / _PANEL_NODES)
        nodes = (np.arange(n_panels)[:, None] + 0.5 + 0.5 * t[None, :]) * width
        port = layer_two_port(nodes.ravel(), omega, e, poisson, density, thickness)
        one_i = complex(belt.stiffness_factor(omega))
        z_quad = one_i * np.array([belt.bending_x, 2.0 * belt.bending_xy, belt.bending_y])
        z_lin = np.array([belt.tension_x, belt.tension_y, one_i * belt.bed - belt.mass * omega * omega], dtype=complex)
        f = np.empty((kx.size, ky.size), dtype=complex)
        _mode_terms(kx, ky, float(c), width, t, bw, np.ascontiguousarray((port["tau"] ** 2).reshape(nodes.shape)),
                    np.ascontiguousarray(port["k_base"].reshape(nodes.shape)), z_lin, z_quad, f)
    else:
        kxg, kyg = np.meshgrid(kx, ky, indexing="ij")
        port = layer_two_port(np.hypot(kxg, kyg), omega, e, poisson, density, thickness)
        f = (_sinc(0.5 * c * kxg) * _sinc(0.5 * c * kyg) * port["tau"] ** 2
             / (belt_impedance(kxg, kyg, omega, belt) + port["k_base"]))
    return np.cos(np.outer(ax, kx)) @ (weight * f) @ np.cos(np.outer(ky, ay))


def _material_modulus(material, omega) -> np.ndarray:
    """E(omega) [Pa] of ``material`` at angular frequencies ``omega`` (>= 0), with E(0) its zero-frequency
    modulus (``material.modulus(0)``, checked finite with Re > 0)."""
    omega = np.asarray(omega, dtype=float)
    e = np.asarray(material.modulus(omega), dtype=complex).reshape(omega.shape)
    if not np.all(np.isfinite(e)) or np.any(e.real <= 0.0) or np.any(e.imag < 0.0):
        name = getattr(material, "name", "material")
        raise ValueError(f"material {name!r}: modulus(omega) must be finite with Re E > 0 and Im E >= 0, also at "
                         "omega = 0 (the belt's static correction)")
    return e


def _check_material(material) -> None:
    for attr in ("modulus", "poisson", "density", "thickness"):
        if not hasattr(material, attr):
            raise ValueError(f"material: expected a tyreroad.material.Material (modulus(omega), poisson, density, "
                             f"thickness), got {type(material).__name__} without {attr!r}")


def _check_belt(belt) -> None:
    if not isinstance(belt, BeltProperties):
        raise ValueError(f"belt: expected a tyreroad.belt.BeltProperties, got {type(belt).__name__}")


def _correction(material, belt, shape, c, omega, modulus, label="belt correction", interpolate=True, cell=None):
    """Delta g on belt_offsets(shape) at angular frequencies omega with moduli ``modulus``: (n_f, nx ny)."""
    nx, ny = shape
    if cell is None and (ny - 1) * c >= 0.5 * belt.width:
        raise ValueError(f"shape: lateral offsets up to {(ny - 1) * c:g} m do not stay inside the belt "
                         f"(|y| < W / 2 = {0.5 * belt.width:g} m)")
    ax, ay = np.arange(nx) * c, np.arange(ny) * c
    out = np.empty((omega.size, nx * ny), dtype=complex)
    start = last = time.perf_counter()
    for i, (w, e) in enumerate(zip(omega, modulus)):
        out[i] = _ring_grid(ax, ay, c, float(w), complex(e), material.poisson, material.density,
                            material.thickness, belt, interpolate, cell).ravel()
        now = time.perf_counter()
        if now - last > 10.0:
            logger.info("%s: %d / %d frequencies (%.0f s)", label, i + 1, omega.size, now - start)
            last = now
    return out


def belt_correction_table(material, belt: BeltProperties, shape, element_size: float, frequencies,
                          cell=None) -> np.ndarray:
    """The belt's part Delta g of the element Green's function on a patch's distinct offsets [m/N].

    With ``cell`` = (L_x, L_y) [m] the patch is one cell of a footprint loaded periodically with it: Delta g is
    the belt's response to the pressure's variation at the patch scale, (1 / (L_x L_y)) sum over k = 2 pi (p / L_x,
    q / L_y), (p, q) != (0, 0), of P tau^2 / (Z + K_b) cos(k_x d_x) cos(k_y d_y) (the plate taken as wide and long:
    the footprint's mean pressure, k = 0, is the tyre's global deflection, left to the tyre model).

    Delta g from :func:`tyreroad.belt.belt_element_frf_correction_ring` (the ring-and-strip mode sum; the
    same modes, truncation and two-port, with the cosine projections factored over the patch's product grid
    of offsets and the two-port interpolated in |k|: equal to it to 1e-11 of |Delta g_00|), with the tread's
    E(omega) = ``material.modulus(omega)``; at f = 0 that is the material's zero-frequency modulus
    ``material.modulus(0)`` (E(omega -> 0), the modulus the kernel's sum rule refers to; the quasi-static modulus
    is used by :attr:`BeltKernel.static` only).

    Parameters
    ----------
    material : tyreroad.material.Material
        The tread (modulus(omega) [Pa], poisson [-], density [kg/m^3], thickness [m]).
    belt : BeltProperties
        The belt.
    shape : tuple of int
        Patch (nx, ny) [elements], x circumferential; the patch is centred on the belt's centre line.
    element_size : float
        c [m].
    frequencies : array_like
        f [Hz], >= 0.

    Returns
    -------
    numpy.ndarray
        Complex Delta g, shape (n_f, nx ny) [m/N], columns in the order of :func:`belt_offsets` (offsets
        (|dx|, |dy|) c).
    """
    _check_material(material)
    _check_belt(belt)
    shape = _check_shape(shape)
    c = checks.real("element_size", element_size, positive=True)
    f = np.atleast_1d(checks.nonnegative_array("frequencies", frequencies)).astype(float)
    omega = 2.0 * np.pi * f
    return _correction(material, belt, shape, c, omega, _material_modulus(material, omega), cell=cell)


# ----------------------------------------------------------------------------------------------
# vector fitting in z


def _clean_poles(p, stable=True) -> np.ndarray:
    """A conjugate-closed pole set from eigenvalues: tiny imaginary parts zeroed, pairs made exact, unstable
    poles (|p| >= 1) reflected into the unit disc (p -> 1 / conj p, same |G| on the circle)."""
    p = np.asarray(p, dtype=complex)
    if stable:
        big = np.abs(p) >= 1.0
        p = np.where(big, p / np.abs(p) ** 2 * (1.0 - 1e-9), p)
    tiny = np.abs(p.imag) <= 1e-12 * np.maximum(np.abs(p), 1e-300)
    real = np.sort(p[tiny].real)
    upper = p[(~tiny) & (p.imag > 0)]
    upper = upper[np.argsort(np.angle(upper))]
    return _closed(real, upper)


def _basis_z(x, poles, kind):
    """Real-parameter basis on the unit circle, x = 1 / z, (n_f, n_p) complex.

    ``kind`` 'pole': 1 / (z - p) = x / (1 - p x) (the relocation basis); 'march': 1 / (1 - p x) (the model's).
    Real pole: one column; pair (p, conj p): phi(p) + phi(conj p) and i (phi(p) - phi(conj p)).
    """
    real, upper = _pole_groups(poles)
    num = x[:, None] if kind == "pole" else 1.0

    def phi(q):
        return num / (1.0 - q[None, :] * x[:, None])

    cols = [phi(real.astype(complex))]
    if upper.size:
        a, b = phi(upper), phi(np.conj(upper))
        pair = np.empty((x.size, 2 * upper.size), dtype=complex)
        pair[:, 0::2] = a + b
        pair[:, 1::2] = 1j * (a - b)
        cols.append(pair)
    return np.concatenate(cols, axis=1)


def _realify(a, imag=None):
    """[Re a; Im a] stacked along the first axis; ``imag`` (n_f,) scales the imaginary rows (weights)."""
    if imag is None:
        return np.concatenate([a.real, a.imag], axis=0)
    scale = imag.reshape((-1,) + (1,) * (a.ndim - 1))
    return np.concatenate([a.real, a.imag * scale], axis=0)


def _relocate(x, data, weight, poles, fixed, imag=None):
    """One relaxed vector-fitting relocation of ``poles`` (Gustavsen 2006; QR-compressed columns, Deschrijver
    2008), with the ``fixed`` poles in the fit's basis but not relocated (the creep's real poles).

    data (n_f, n_col) complex, weight (n_f,) real, ``imag`` (n_f,) extra weight of the imaginary parts.
    Returns the zeros of sigma (the new poles, unstabilised).
    """
    n_f = x.size
    phi = _basis_z(x, poles, "pole")
    n = phi.shape[1]
    own = np.concatenate([_basis_z(x, fixed, "march"), phi, np.ones((n_f, 1))], axis=1) * weight[:, None]
    own = _realify(own, imag)
    own = own / np.linalg.norm(own, axis=0)
    q, _ = np.linalg.qr(own)
    sig_basis = np.concatenate([phi, np.ones((n_f, 1))], axis=1)
    blocks = []
    for k in range(data.shape[1]):
        sig = _realify(-sig_basis * (data[:, k] * weight)[:, None], imag)
        # sigma's equations in the orthogonal complement of this column's own unknowns
        proj = sig - q @ (q.T @ sig)
        blocks.append(np.linalg.qr(proj, mode="r"))
    mat = np.concatenate(blocks, axis=0)
    # relaxation: Re sum_i sigma(z_i) = n_f (keeps the trivial solution out without fixing d)
    scale = np.linalg.norm(data * weight[:, None]) / n_f
    cons = np.concatenate([phi.real.sum(axis=0), [float(n_f)]]) * scale
    a = np.concatenate([mat, cons[None, :]], axis=0)
    rhs = np.zeros(a.shape[0])
    rhs[-1] = n_f * scale
    sol = np.linalg.lstsq(a, rhs, rcond=None)[0]
    d = sol[-1]
    if abs(d) < 1e-8:
        # degenerate relaxation: fix d = 1 (classic VF)
        sol = np.append(np.linalg.lstsq(mat[:, :n], -mat[:, n], rcond=None)[0], 1.0)
        d = 1.0
    ct = sol[:n]
    real, upper = _pole_groups(poles)
    lam = np.zeros((n, n))
    b = np.zeros(n)
    nr = real.size
    lam[np.arange(nr), np.arange(nr)] = real
    b[:nr] = 1.0
    for i, p in enumerate(upper):
        j = nr + 2 * i
        lam[j:j + 2, j:j + 2] = [[p.real, p.imag], [-p.imag, p.real]]
        b[j] = 2.0
    return np.linalg.eigvals(lam - np.outer(b, ct) / d)


def _fit_residues(x, data, weight, poles, imag=None):
    """Least-squares residues and direct term of G = D + sum_j rho_j / (1 - p_j x) for fixed poles.

    Returns (rho (n_p, n_col) complex, conjugate-closed as ``poles``; D (n_col,) real).
    """
    basis = _realify(np.concatenate([_basis_z(x, poles, "march"), np.ones((x.size, 1))], axis=1) * weight[:, None],
                     imag)
    norm = np.linalg.norm(basis, axis=0)
    coef = np.linalg.lstsq(basis / norm, _realify(data * weight[:, None], imag), rcond=None)[0] / norm[:, None]
    real, upper = _pole_groups(poles)
    nr = real.size
    rho = np.empty((nr + 2 * upper.size, data.shape[1]), dtype=complex)
    rho[:nr] = coef[:nr]
    pair = coef[nr:-1:2] + 1j * coef[nr + 1:-1:2]
    rho[nr::2] = pair
    rho[nr + 1::2] = np.conj(pair)
    return rho, coef[-1]


def _evaluate(x, poles, rho, direct):
    """G(x) = D + sum_j rho_j / (1 - p_j x): (n_f, n_col) complex."""
    return direct[None, :] + (1.0 / (1.0 - poles[None, :] * x[:, None])) @ rho


def _initial_poles(n_pairs, sample_rate, f_low=20.0, damping=0.05):
    """Starting pole pairs log-spaced in frequency over f_low ... 0.95 fs / 2 with damping ratio ``damping``
    (z = exp(s / fs), s = 2 pi f (-damping + i))."""
    f = np.geomspace(f_low, 0.95 * sample_rate / 2.0, n_pairs)
    return _closed(np.zeros(0), np.exp(2.0 * np.pi * f * (-damping + 1j) / sample_rate))


def _creep_poles(sample_rate, f_low, f_high, per_decade):
    """Fixed real poles exp(-2 pi f_k / fs), f_k log-spaced over f_low ... f_high [Hz], ``per_decade``."""
    n = int(math.ceil(per_decade * math.log10(f_high / f_low))) + 1
    return np.exp(-2.0 * np.pi * np.geomspace(f_low, f_high, n) / sample_rate).astype(complex)


def _vector_fit(x, data, weight, n_pairs, fixed, sample_rate, n_iter=20, imag=None):
    """Relaxed VF of ``n_pairs`` pole pairs beside the ``fixed`` poles; returns the best iterate
    (poles (fixed first), rho, D, max weighted error)."""
    poles = _initial_poles(n_pairs, sample_rate)
    best = None
    for _ in range(n_iter):
        poles = _clean_poles(_relocate(x, data, weight, poles, fixed, imag))
        allp = np.concatenate([fixed, poles])
        rho, d = _fit_residues(x, data, weight, allp, imag)
        err = float(np.max(np.abs(_evaluate(x, allp, rho, d) - data) * weight[:, None]))
        if best is None or err < best[3]:
            best = (allp, rho, d, err)
    return best


# ----------------------------------------------------------------------------------------------
# the fit


def _frequency_grid(sample_rate, f_min, f_low, ratio, low_per_decade):
    """Fit grid [Hz]: 0 (the sum rule), ``low_per_decade`` per decade from f_min to f_low (the smooth creep
    range) and geometric from f_low to fs / 2 at ``ratio`` (the resonances)."""
    top = 0.5 * sample_rate
    n = int(math.ceil(math.log(top / f_low) / math.log(ratio))) + 1
    n_low = int(math.ceil(low_per_decade * math.log10(f_low / f_min))) + 1
    return np.concatenate([[0.0], np.geomspace(f_min, f_low, n_low)[:-1], np.geomspace(f_low, top, n)])


def _compress(data, weight, tolerance):
    """Weighted data as a few real-linear combinations of its columns.

    The real stack [Re(w H); Im(w H)] (2 n_f x n_col) is factored by an SVD; the r left vectors with
    singular values above ``tolerance`` (an entry-wise bound on what is dropped, in units of the weight) are
    the columns vector fitting sees: (n_f, r) complex (unweighted) and the (r, n_col) real map back.
    """
    n_f = data.shape[0]
    stack = _realify(data * weight[:, None])
    u, s, vt = np.linalg.svd(stack, full_matrices=False)
    r = max(1, int(np.sum(s > tolerance)))
    cols = (u[:n_f, :r] + 1j * u[n_f:, :r]) * s[:r] / weight[:, None]
    return cols, vt[:r], float(s[r]) if r < s.size else 0.0


def _fit_on(x, data, weight, n_pairs_list, fixed, sample_rate, compress_tol, n_iter, imag, select):
    """Vector fits with each pole count of ``n_pairs_list`` on compressed columns; residues for every
    column. Returns a list of (n_pairs, poles, rho, D, max weighted error of what was fitted on the grid, the same
    on the frequencies ``select``)."""
    cols, vt, dropped = _compress(data, weight, compress_tol)
    out = []
    for n_pairs in n_pairs_list:
        poles, rho_c, d_c, _ = _vector_fit(x, cols, weight, n_pairs, fixed, sample_rate, n_iter, imag)
        rho, d = rho_c @ vt, d_c @ vt
        diff = _evaluate(x, poles, rho, d) - data
        if imag is not None:
            diff = diff.real + 1j * diff.imag * imag[:, None]
        err = np.max(np.abs(diff) * weight[:, None], axis=1)
        out.append((n_pairs, poles, rho, d, float(err.max()), float(err[select].max())))
        logger.info("belt kernel fit: %d pole pairs + %d real poles, max error %.2e of |g_00| on %d frequencies, "
                    "%.2e above f_low (%d SVD columns, dropped %.1e)", n_pairs, fixed.size, err.max(), x.size,
                    err[select].max(), cols.shape[1], dropped)
    return out


def fit_belt_kernel(material, belt: BeltProperties, shape, element_size: float, sample_rate: float, n_lags: int,
                    tolerance: float = 1e-4, pole_pairs=(8, 12, 16, 20, 24, 28, 32, 40), f_min: float = 1e-4,
                    f_low: float = 1.0, grid_ratio: float = 1.04, low_per_decade: float = 6.0,
                    creep_per_decade: float = 2.0, n_iter: int = 20, compress_tolerance: float = 1e-5,
                    cell=None) -> "BeltKernel":
    r"""Fit the belt's part of the kernel as a discrete pole-residue model (see the module docstring).

    G_b(z) = D(d) + sum_j rho_j(d) / (1 - z_j z^-1) is fitted to Delta g(d, omega) at z = exp(i omega / fs) on
    the patch's offsets, with weight 1 / |g_00 + Delta g_00| (the error is measured relative to the total
    element FRF at the excitation element, the fidelity's scale).

    Parameters
    ----------
    material : tyreroad.material.Material
        The tread.
    belt : BeltProperties
        The belt.
    shape : tuple of int
        Patch (nx, ny) [elements], x circumferential.
    element_size : float
        c [m].
    sample_rate : float
        fs [Hz] of the march.
    n_lags : int
        L, the kept lags of the march kernel the belt's lags are added to (the memory starts there).
    tolerance : float
        Target max error relative to |g_00 total| on the fit grid above f_low [1]: the smallest pole count of
        ``pole_pairs`` reaching it is taken, else the smallest within 10 % of the best one.
    pole_pairs : sequence of int
        Pole-pair counts tried (relocated by vector fitting).
    f_min : float
        Lowest nonzero fit frequency [Hz]; below it only the sum rule at f = 0 is fitted (module docstring).
    f_low : float
        Where the resonance grid starts [Hz]; f_min ... f_low is sampled ``low_per_decade`` per decade and only the
        real part is fitted there (the imaginary part is the belt loss's non-causal part, module docstring).
    grid_ratio : float
        Ratio of neighbouring fit frequencies above f_low (> 1); the geometric midpoints of the whole grid are the
        validation set, and the grid is refined once if they miss.
    low_per_decade : float
        Fit frequencies per decade over f_min ... f_low.
    creep_per_decade : float
        Fixed real poles per decade over f_min / 10 ... 30 Hz (the tread's creep through the belt).
    n_iter : int
        Vector-fitting iterations per pole count.
    compress_tolerance : float
        Singular values of the weighted data dropped before pole identification [1 of |g_00|].
    cell : (float, float), optional
        (L_x, L_y) [m]: fit the belt's response to the patch repeated periodically over a footprint, without its
        uniform mode (:func:`belt_correction_table`); None: the loaded patch alone on the ring and strip.

    Returns
    -------
    BeltKernel
    """
    _check_material(material)
    _check_belt(belt)
    shape = _check_shape(shape)
    c = checks.real("element_size", element_size, positive=True)
    fs = checks.real("sample_rate", sample_rate, positive=True)
    n_lags = checks.integer("n_lags", n_lags)
    if n_lags < 1:
        raise ValueError(f"n_lags: expected >= 1, got {n_lags}")
    tol = checks.real("tolerance", tolerance, positive=True)
    ratio = checks.real("grid_ratio", grid_ratio, positive=True)
    if ratio <= 1.0:
        raise ValueError(f"grid_ratio: expected > 1, got {ratio}")
    f_low = checks.real("f_low", f_low, positive=True)
    f_min = checks.real("f_min", f_min, positive=True)
    if not f_min < f_low < 0.5 * fs:
        raise ValueError(f"f_min, f_low: expected 0 < f_min < f_low < fs / 2, got {f_min}, {f_low}")
    pole_pairs = sorted(int(p) for p in pole_pairs)
    if not pole_pairs or pole_pairs[0] < 1:
        raise ValueError(f"pole_pairs: expected positive counts, got {pole_pairs!r}")
    t_start = time.perf_counter()
    name = getattr(material, "name", "material")

    def data_at(f):
        omega = 2.0 * np.pi * f
        e = _material_modulus(material, omega)
        dg = _correction(material, belt, shape, c, omega, e, f"belt correction {name}", cell=cell)
        g00 = element_frf(np.zeros((1, 2)), c, omega, e, material.poisson, material.density, material.thickness)[:, 0]
        return dg, 1.0 / np.abs(g00 + dg[:, 0])

    f = _frequency_grid(fs, f_min, f_low, ratio, low_per_decade)
    dg, w = data_at(f)
    # f = 0: the sum rule. A real impulse response has a real G(1): the imaginary part of Delta g(0) (the belt's
    # frequency-independent loss factor, not causal) is dropped there and reported
    imag_at_zero = float(np.max(np.abs(dg[0].imag)) * w[0])
    dg[0] = dg[0].real
    w_fit = w.copy()
    w_fit[0] *= 10.0
    fixed = _creep_poles(fs, f_min / 10.0, 30.0, creep_per_decade)
    x = np.exp(-2j * np.pi * f / fs)
    mid = np.sqrt(f[1:-1] * f[2:])
    dg_mid, w_mid = data_at(mid)
    x_mid = np.exp(-2j * np.pi * mid / fs)
    for attempt in range(2):
        # below f_low only the real part is fitted: the imaginary part there is held by the belt's
        # frequency-independent loss, which is not causal (Im Delta g(omega -> 0) != 0); the causal model's own
        # imaginary part follows from its real part (module docstring)
        imag = np.where((f > 0.0) & (f < f_low), 0.0, 1.0)
        fits = _fit_on(x, dg, w_fit, pole_pairs, fixed, fs, compress_tolerance, n_iter, imag, f >= f_low)
        # the pole count is chosen on the resonance range: below f_low the error is the loss's non-causal part,
        # which more poles do not reduce
        errs = np.array([fit[5] for fit in fits])
        ok = np.flatnonzero((errs <= tol) | (errs <= 1.1 * errs.min()))
        n_pairs, poles, rho, direct, _, err_fit = fits[int(ok[0])]
        hi = mid >= f_low
        err_mid = float(np.max(np.abs(_evaluate(x_mid[hi], poles, rho, direct) - dg_mid[hi]) * w_mid[hi, None]))
        if attempt == 1 or err_mid <= max(1.5 * err_fit, tol):
            break
        logger.info("belt kernel fit: validation error %.2e > 1.5 x fit error %.2e: refining the grid", err_mid,
                    err_fit)
        # merge the midpoints into the fit grid; new midpoints validate the refined fit
        order = np.argsort(np.concatenate([f, mid]))
        f = np.concatenate([f, mid])[order]
        dg = np.concatenate([dg, dg_mid])[order]
        w = np.concatenate([w, w_mid])[order]
        w_fit = np.concatenate([w_fit, w_mid])[order]
        x = np.exp(-2j * np.pi * f / fs)
        mid = np.sqrt(f[1:-1] * f[2:])
        dg_mid, w_mid = data_at(mid)
        x_mid = np.exp(-2j * np.pi * mid / fs)
    # diagnostics on every frequency computed (fit grid and validation set)
    f_all = np.concatenate([f, mid])
    x_all = np.concatenate([x, x_mid])
    err_all = np.abs(_evaluate(x_all, poles, rho, direct) - np.concatenate([dg, dg_mid])) * np.concatenate(
        [w, w_mid])[:, None]
    band = (f_all >= 10.0) & (f_all <= 5000.0)
    worst = np.unravel_index(np.argmax(err_all), err_all.shape)
    nx, ny = shape
    offs = belt_offsets(shape)
    # the excitation element's phase error over 10 Hz - 5 kHz, and passivity on a dense grid
    fd = np.unique(np.concatenate([np.linspace(0.0, 0.5 * fs, 2049), np.geomspace(f_min, 0.5 * fs, 1000)]))
    omega_d = 2.0 * np.pi * fd
    e_d = _material_modulus(material, omega_d)
    g00_d = element_frf(np.zeros((1, 2)), c, omega_d, e_d, material.poisson, material.density, material.thickness)[:, 0]
    fit00 = _evaluate(np.exp(-2j * np.pi * fd / fs), poles, rho[:, :1], direct[:1])[:, 0]
    # -Im(g_00 + G_b,00) / |g_00| over f_min <= f <= fs / 2 (both are real at f = 0)
    passivity = float(np.min(-(g00_d + fit00).imag[fd > 0] / np.abs(g00_d[fd > 0])))
    # phase at the excitation element: arg((g00 + G_b) / (g00 + Delta g)) on the fit and validation points in band
    omega_b = 2.0 * np.pi * f_all[band]
    g00_b = element_frf(np.zeros((1, 2)), c, omega_b, _material_modulus(material, omega_b), material.poisson,
                        material.density, material.thickness)[:, 0]
    exact_b = np.concatenate([dg, dg_mid])[band, 0]
    model_b = _evaluate(x_all[band], poles, rho[:, :1], direct[:1])[:, 0]
    phase = float(np.max(np.abs(np.angle((g00_b + model_b) / (g00_b + exact_b)))))
    # static (quasi-static modulus) correction
    e_qs = checks.real(f"{name}: quasi_static_modulus", material.quasi_static_modulus, positive=True)
    static = _correction(material, belt, shape, c, np.zeros(1), np.array([e_qs + 0j]), interpolate=False,
                         cell=cell)[0]
    _, _, index = belt_table_index(shape)
    kernel = BeltKernel(
        poles=poles.copy(),
        residues=np.ascontiguousarray(rho[:, index]),
        direct=np.ascontiguousarray(direct[index]),
        static=np.ascontiguousarray(static.real[index]),
        sample_rate=fs,
        element_size=c,
        diagnostics={
            "max_error": float(err_all.max()),
            "max_error_band": float(err_all[band].max()),
            "max_error_below_f_low": float(err_all[f_all < f_low].max()),
            "max_error_f_low_to_10_hz": float(err_all[(f_all >= f_low) & (f_all < 10.0)].max(initial=0.0)),
            "max_error_above_5_khz": float(err_all[f_all > 5000.0].max(initial=0.0)),
            "error_at_nyquist": float(err_all[np.argmax(f_all)].max()),
            "validation_error": float(np.max(err_all[f.size:])) if mid.size else float("nan"),
            "worst_offset": (int(offs[worst[1], 0]), int(offs[worst[1], 1])),
            "worst_frequency": float(f_all[worst[0]]),
            "phase_error_band": phase,
            "band": (10.0, 5000.0),
            "n_poles": int(poles.size),
            "n_pole_pairs": int(n_pairs),
            "n_fixed_poles": int(fixed.size),
            "n_frequencies": int(f.size + mid.size),
            "passivity_min": passivity,
            "imag_at_zero": imag_at_zero,
            "static_imag": float(np.max(np.abs(static.imag))),
            "fit_seconds": time.perf_counter() - t_start,
            "n_lags": n_lags,
        },
    )
    logger.info("belt kernel %s: %s", name, kernel.describe())
    return kernel