r"""Contact stiffness of a preloaded contact: the quasi-static tangent and the dynamic K*(f; d0) (SPEC 11).

Linearised about a solved contact state, a small indentation increment delta (the flat tread
surface moved towards the road by delta, every spring's free compression grows by delta) changes
the spring compressions by dzeta, (I + G K) dzeta = delta 1, with K = diag(k_e) the tangent
spring stiffnesses k_e = dF_e/dzeta_e and G the layer's influence matrix. The total force changes
by 1^T K dzeta, so over the contact set C (the elements with k_e > 0)

    K = 1^T [G_C + diag(1/k_e)]^-1 1.

* **Quasi-static tangent** (:class:`TangentStiffness`): G = G_0 = g_static, the state of a
  quasi-static run. dF/dd of the quasi-static curve, exact between contact-set changes, so that
  quasi-static runs may take coarse indentation steps while K(d) stays exact.
* **Dynamic contact stiffness** (:func:`stiffness_spectrum`): G = G_C(f), the element FRF matrix
  g(e - m, f) of the layer (:func:`tyreroad.greens.element_frf`, the same layer machinery as the
  Green's functions, not the truncated time kernel), about the **relaxed preload state**: the
  quasi-static solution at d0 with the quasi-static kernel g_static (modulus E_qs). Convention
  exp(+i omega t): F_hat = K* delta_hat, storage stiffness K' = Re K*, loss stiffness K'' = Im K*
  >= 0 for a passive layer (Im g <= 0), loss factor K''/K'. As f -> 0, G_C(f) -> g_static when
  E_qs = E(omega -> 0) (the default quasi-static modulus), so K*(f -> 0) is the quasi-static tangent.
  A tread with slow creep (the default fractional model creeps for seconds) must be held that long
  before a small harmonic oscillation about d0 sees this state; at 10 Hz the fractional tread is
  still about 60 % stiffer than its relaxed modulus, so K*(10 Hz) is well above the tangent.

Both are solved in the symmetric form A y = s, A = I + S G S, S = diag(sqrt(k_e)), K = s^T y
(unconjugated): A has eigenvalues >= 1 in the static case and stays well conditioned when an
element has just touched (k_e -> 0), where the form with 1/k_e would not. Two solvers:

* dense (:func:`contact_set_stiffness`): LU of A over the contact set, for patches up to the
  contact solver's FFT threshold (:data:`tyreroad.contact.FFT_THRESHOLD` elements);
* matrix-free (:func:`contact_set_stiffness_krylov`): conjugate-orthogonal conjugate gradients
  (COCG; plain CG when G is real) on the Jacobi-scaled A, with G v by FFT convolution of the offset
  table on the padded grid of :func:`tyreroad.convolution.padded_shape` (exact linear convolution).
  A is complex symmetric (G_em = g(e - m) = g(m - e)), which is what COCG needs.

Choices (where the specification left one)
------------------------------------------
* The frequency grid is log-spaced from ``f_min`` to fs/2 (the greens file's sample rate) with the
  report frequencies (default 100 Hz, 1 kHz, 5 kHz) inserted, so the report reads K* there, not
  an interpolation.
* ``relaxed_stiffness`` is K*(f -> 0), from the element FRF at f = 0 with E(omega -> 0); it equals
  ``tangent_stiffness_qs`` (from g_static of the greens file and E_qs) when E_qs = E(0). Both are
  stored, so the f -> 0 check can be read from the file.
* The matrix-free solve warm-starts each frequency from the previous one's solution and stops at
  a relative residual ``krylov_tolerance`` (default 1e-12), which bounds the relative error of K*
  to about that times the condition number of the scaled A (measured: dense and matrix-free agree to
  < 1e-10 on the default patch).

References
----------
van der Vorst, H. A., & Melissen, J. B. M. (1990). A Petrov-Galerkin type method for solving Ax = b,
where A is symmetric complex. IEEE Trans. Magn. 26(2), 706-708. doi:10.1109/20.106415
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import scipy.fft
import scipy.linalg
import xarray as xr

from . import checks
from .convolution import check_offset_kernel, padded_shape

logger = logging.getLogger(__name__)

__all__ = [
    "SpectrumSettings",
    "frequency_grid",
    "contact_set_stiffness",
    "contact_set_stiffness_krylov",
    "OffsetOperator",
    "TangentStiffness",
    "PreloadStates",
    "preload_states",
    "element_frf_table",
    "stiffness_spectrum",
    "spectrum_from_datasets",
    "first_harmonic",
    "harmonic_stiffness",
]

#: Preloads of the default study [m].
DEFAULT_PRELOADS = (5.0e-5, 1.0e-4, 1.5e-4, 2.0e-4)
#: Frequencies at which the report reads K* [Hz] (inserted into the grid).
DEFAULT_REPORT_FREQUENCIES = (100.0, 1000.0, 5000.0)

_KEYS = {"preloads", "f_min", "n_frequencies", "report_frequencies", "figure_preload",
         "krylov_tolerance", "krylov_max_iterations"}


# --------------------------------------------------------------------------------------------
# settings
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SpectrumSettings:
    """What the stiffness spectrum stage computes (config section ``stiffness_spectrum``).

    Parameters
    ----------
    preloads : tuple of float
        Preload indentations d0 [m], increasing (default 0.05, 0.10, 0.15, 0.20 mm).
    f_min : float
        Lowest frequency of the log-spaced grid [Hz] (default 10); the highest is fs/2.
    n_frequencies : int
        Points of the log-spaced grid (default 61; the report frequencies come on top).
    report_frequencies : tuple of float
        Frequencies inserted into the grid, read by the report [Hz] (default 100, 1000, 5000).
    figure_preload : float or None
        The preload at which figure 9 compares the material variants [m]; one of ``preloads``
        (default: 0.1 mm when listed, else the middle preload).
    krylov_tolerance : float
        Relative residual at which the matrix-free solve stops (default 1e-12).
    krylov_max_iterations : int
        Iterations allowed per matrix-free solve before it is an error (default 3000).
    """

    preloads: tuple = DEFAULT_PRELOADS
    f_min: float = 10.0
    n_frequencies: int = 61
    report_frequencies: tuple = DEFAULT_REPORT_FREQUENCIES
    figure_preload: float | None = None
    krylov_tolerance: float = 1e-12
    krylov_max_iterations: int = 3000

    def __post_init__(self) -> None:
        where = "stiffness_spectrum"
        pre = _real_list(f"{where}.preloads", self.preloads)
        if pre.size == 0 or np.any(np.diff(pre) <= 0):
            raise ValueError(f"{where}.preloads: expected a non-empty increasing list of indentations > 0 [m], "
                             f"got {list(self.preloads)!r}")
        f_min = checks.real(f"{where}.f_min", self.f_min, positive=True)
        n = checks.integer(f"{where}.n_frequencies", self.n_frequencies, minimum=2)
        rep = _real_list(f"{where}.report_frequencies", self.report_frequencies)
        tol = checks.real(f"{where}.krylov_tolerance", self.krylov_tolerance, positive=True)
        if tol >= 1e-3:
            raise ValueError(f"{where}.krylov_tolerance: expected a relative residual < 1e-3, got {tol!r}")
        it = checks.integer(f"{where}.krylov_max_iterations", self.krylov_max_iterations)
        fig = self.figure_preload
        if fig is None:
            fig = 1.0e-4 if np.any(np.isclose(pre, 1.0e-4, rtol=1e-9, atol=0)) else float(pre[(pre.size - 1) // 2])
        fig = checks.real(f"{where}.figure_preload", fig, positive=True)
        if not np.any(np.isclose(pre, fig, rtol=1e-9, atol=0)):
            raise ValueError(f"{where}.figure_preload: expected one of the preloads {pre.tolist()} m, got {fig!r}")
        object.__setattr__(self, "preloads", tuple(pre.tolist()))
        object.__setattr__(self, "f_min", f_min)
        object.__setattr__(self, "n_frequencies", n)
        object.__setattr__(self, "report_frequencies", tuple(sorted(rep.tolist())))
        object.__setattr__(self, "figure_preload", float(pre[np.argmin(np.abs(pre - fig))]))
        object.__setattr__(self, "krylov_tolerance", tol)
        object.__setattr__(self, "krylov_max_iterations", it)

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "SpectrumSettings":
        """Build from the ``stiffness_spectrum`` config section; missing keys take the defaults.

        Raises
        ------
        ValueError
            Naming ``stiffness_spectrum.<key>`` for unknown keys and bad values.
        """
        section = dict(section or {})
        unknown = sorted(set(section) - _KEYS)
        if unknown:
            raise ValueError(f"stiffness_spectrum.{unknown[0]}: unknown key (expected one of {', '.join(sorted(_KEYS))})")
        for key in ("preloads", "report_frequencies"):
            if key in section:
                section[key] = tuple(_real_list(f"stiffness_spectrum.{key}", section[key]).tolist())
        return cls(**section)

    def frequencies(self, sample_rate: float) -> np.ndarray:
        """The analysis frequencies [Hz] for a kernel sampled at ``sample_rate`` (fs/2 the highest)."""
        return frequency_grid(self.f_min, 0.5 * checks.real("sample_rate", sample_rate, positive=True),
                              self.n_frequencies, self.report_frequencies)


def _real_list(name: str, value) -> np.ndarray:
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ValueError(f"{name}: expected a list of numbers, got {value!r}")
    out = np.array([checks.real(f"{name}[{i}]", v, positive=True) for i, v in enumerate(value)], dtype=float)
    return out


def frequency_grid(f_min: float, f_max: float, n: int, extra: Sequence[float] = ()) -> np.ndarray:
    """``n`` log-spaced frequencies from ``f_min`` to ``f_max`` [Hz], with ``extra`` inserted (sorted, unique).

    Raises
    ------
    ValueError
        When f_min >= f_max, or an extra frequency lies outside [f_min, f_max].
    """
    f_min = checks.real("f_min", f_min, positive=True)
    f_max = checks.real("f_max", f_max, positive=True)
    n = checks.integer("n", n, minimum=2)
    if not f_min < f_max:
        raise ValueError(f"frequency grid: f_min = {f_min:g} Hz must be below f_max = fs/2 = {f_max:g} Hz")
    grid = np.geomspace(f_min, f_max, n)
    for f in extra:
        f = float(f)
        if not f_min <= f <= f_max:
            raise ValueError(f"frequency grid: report frequency {f:g} Hz outside [{f_min:g}, {f_max:g}] Hz")
    grid = np.concatenate([grid, np.asarray(extra, dtype=float)])
    grid = np.unique(grid)
    # drop grid points that coincide with an inserted frequency to round-off
    keep = np.concatenate([[True], np.diff(grid) > 1e-9 * grid[1:]])
    return grid[keep]


# --------------------------------------------------------------------------------------------
# linear algebra over a contact set
# --------------------------------------------------------------------------------------------
def contact_set_stiffness(g_matrix, stiffness) -> complex | float:
    """K = 1^T [G_C + diag(1/k_e)]^-1 1 by a dense solve over the contact set C = {e : k_e > 0}.

    Parameters
    ----------
    g_matrix : array_like
        Influence matrix G[e, m] of the whole patch (or of the elements given), real or complex,
        shape (M, M) [m/N].
    stiffness : array_like
        Tangent spring stiffnesses k_e >= 0 [N/m], shape (M,).

    Returns
    -------
    float or complex
        K [N/m] (complex when G is); 0 when no element is loaded.
    """
    k = checks.nonnegative_array("stiffness", stiffness).ravel()
    g = np.asarray(g_matrix)
    if g.shape != (k.size, k.size):
        raise ValueError(f"g_matrix: expected shape ({k.size}, {k.size}), got {g.shape}")
    active = np.flatnonzero(k)
    if active.size == 0:
        return 0.0 * g.dtype.type(1)
    return _dense_solve(g[np.ix_(active, active)], np.sqrt(k[active]))


def _dense_solve(g_cc: np.ndarray, s: np.ndarray):
    """s^T (I + S G S)^-1 s for the contact-set block G_CC and s = sqrt(k_C)."""
    a = g_cc * s[:, None]
    a *= s[None, :]
    a[np.diag_indices_from(a)] += 1.0
    if np.iscomplexobj(a):
        y = np.linalg.solve(a, s.astype(a.dtype))
    else:  # symmetric positive definite (eigenvalues >= 1 for a positive definite G)
        y = scipy.linalg.solve(a, s, assume_a="pos", check_finite=False)
    return s @ y


def contact_set_stiffness_krylov(
    apply_g: Callable[[np.ndarray], np.ndarray],
    stiffness: np.ndarray,
    g_self,
    tolerance: float = 1e-12,
    max_iterations: int = 3000,
    start: np.ndarray | None = None,
):
    """K = 1^T [G_C + diag(1/k_e)]^-1 1, matrix-free, by Jacobi-scaled COCG (CG when G is real).

    Solves A^ y^ = b^ with A^ = D^-1 + P G P, P = diag(sqrt(k_e / d_e)), D = diag(1 + k_e g_self)
    (the Jacobi scaling of A = I + S G S), b^ = sqrt(k / d); K = b^T y^ (unconjugated).

    Parameters
    ----------
    apply_g : callable
        v -> G v for a field v of the patch shape (complex or real, the same shape back) [m/N x N].
    stiffness : numpy.ndarray
        k_e >= 0 on the patch [N/m] (0 outside the contact set).
    g_self : float or complex
        g(0, 0), the self-compliance [m/N] (the Jacobi scaling).
    tolerance : float
        Stop at ||b^ - A^ y^||_2 <= tolerance ||b^||_2.
    max_iterations : int
        Iterations (one G product each) allowed.
    start : numpy.ndarray, optional
        Initial y^ (e.g. the solution at a neighbouring frequency).

    Returns
    -------
    value : float or complex
        K [N/m].
    iterations : int
        G products used.
    solution : numpy.ndarray
        y^, to warm-start a neighbouring problem.

    Raises
    ------
    RuntimeError
        When the residual does not reach the tolerance in ``max_iterations`` iterations (or the
        recurrence breaks down), naming the residual reached.
    """
    k = np.asarray(stiffness, dtype=float)
    dtype = np.result_type(np.asarray(g_self).dtype, float)
    if not np.any(k > 0):
        return dtype.type(0.0), 0, np.zeros(k.shape, dtype=dtype)
    d = 1.0 + k * g_self
    p = np.sqrt(k / d).astype(dtype)
    inv_d = (1.0 / d).astype(dtype)

    def op(v):
        return inv_d * v + p * apply_g(p * v)

    b = p.copy()
    x = np.zeros(k.shape, dtype=dtype) if start is None else np.array(start, dtype=dtype)
    r = b - op(x) if start is not None else b.copy()
    products = 1 if start is not None else 0
    b_norm = float(np.linalg.norm(b))
    target = tolerance * b_norm
    r_norm = float(np.linalg.norm(r))
    direction = r.copy()
    rho = np.sum(r * r)
    while r_norm > target:
        if products >= max_iterations:
            raise RuntimeError(
                f"contact-set stiffness: Krylov solve stopped at relative residual {r_norm / b_norm:.2e} "
                f"> {tolerance:.1e} after {products} iterations"
            )
        q = op(direction)
        products += 1
        pq = np.sum(direction * q)
        if pq == 0 or rho == 0:
            raise RuntimeError(f"contact-set stiffness: COCG breakdown at relative residual {r_norm / b_norm:.2e}")
        alpha = rho / pq
        x += alpha * direction
        r -= alpha * q
        r_norm = float(np.linalg.norm(r))
        rho_new = np.sum(r * r)
        direction *= rho_new / rho
        direction += r
        rho = rho_new
    return np.sum(b * x), products, x


class OffsetOperator:
    """v -> G v for an offset table g[dx, dy] (real or complex) on an nx x ny patch, by FFT.

    The table (offsets -(n-1) ... n-1, index dx + n - 1) sits on the padded periodic grid of
    :func:`tyreroad.convolution.padded_shape`, where the circular convolution equals the linear
    one on the patch (no periodic image enters).

    Parameters
    ----------
    table : array_like
        g[dx, dy] [m/N], shape (2 nx - 1, 2 ny - 1) (a larger centred table is cropped).
    shape : tuple of int
        (nx, ny).
    workers : int
        scipy.fft threads.
    """

    def __init__(self, table, shape, workers: int = 1):
        nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
        self.shape = (nx, ny)
        self.workers = checks.integer("workers", workers)
        self.padded = padded_shape(self.shape)
        t = np.asarray(table)
        self.complex = np.iscomplexobj(t)
        if self.complex:
            re = check_offset_kernel(t.real[:, :, None], nx, ny, "table")[:, :, 0]
            im = check_offset_kernel(t.imag[:, :, None], nx, ny, "table")[:, :, 0]
            t = re + 1j * im
        else:
            t = check_offset_kernel(t[:, :, None], nx, ny, "table")[:, :, 0]
        self.g_self = t[nx - 1, ny - 1]
        buf = np.zeros(self.padded, dtype=t.dtype)
        buf[: 2 * nx - 1, : 2 * ny - 1] = t
        buf = np.roll(buf, (-(nx - 1), -(ny - 1)), axis=(0, 1))
        if self.complex:
            self._spec = scipy.fft.fft2(buf, workers=self.workers)
        else:
            self._spec = scipy.fft.rfft2(buf, workers=self.workers)

    def __call__(self, v: np.ndarray) -> np.ndarray:
        """G v on the patch, v of shape (nx, ny)."""
        nx, ny = self.shape
        if self.complex or np.iscomplexobj(v):
            if not self.complex:  # real kernel, complex field: two real convolutions
                return self(v.real) + 1j * self(v.imag)
            spec = scipy.fft.fft2(v, s=self.padded, workers=self.workers)
            spec *= self._spec
            return scipy.fft.ifft2(spec, workers=self.workers)[:nx, :ny]
        spec = scipy.fft.rfft2(v, s=self.padded, workers=self.workers)
        spec *= self._spec
        return scipy.fft.irfft2(spec, s=self.padded, workers=self.workers)[:nx, :ny]


def _offset_matrix_index(shape) -> tuple[np.ndarray, np.ndarray]:
    """Index arrays (ix, iy) with G[e, m] = table[ix[e, m], iy[e, m]] for a (2 nx - 1, 2 ny - 1) table."""
    nx, ny = shape
    ex, ey = np.divmod(np.arange(nx * ny), ny)
    return ex[:, None] - ex[None, :] + nx - 1, ey[:, None] - ey[None, :] + ny - 1


class TangentStiffness:
    """dF/dd of solved quasi-static states: K = 1^T [G0|C + diag(1/k)]^-1 1 (the f -> 0 case of K*).

    Called with the tangent spring stiffnesses k_e of a converged state, shape (M,) or (nx, ny),
    it returns dF/dd [N/m] for a flat tread surface (every free compression grows with d).

    Parameters
    ----------
    kernel_lag0 : array_like
        g[dx, dy] of the instantaneous (quasi-static) kernel [m/N], offsets -(n-1) ... n-1 (a
        larger centred table is cropped).
    shape : tuple of int
        Patch (nx, ny).
    method : {"dense", "fft"}
        Dense solve over the contact set, or matrix-free CG with FFT products.
    workers : int
        FFT threads.
    tolerance : float
        Relative residual of the CG solve (``fft``).

    Attributes
    ----------
    iterations : int
        CG products of the last call (0 for dense).
    """

    def __init__(self, kernel_lag0, shape, method: str = "dense", workers: int = 1, tolerance: float = 1e-12):
        if method not in ("dense", "fft"):
            raise ValueError(f"method: expected 'dense' or 'fft', got {method!r}")
        nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
        g = check_offset_kernel(np.asarray(kernel_lag0, dtype=float)[:, :, None], nx, ny, "kernel_lag0")[:, :, 0]
        self.shape = (nx, ny)
        self.method = method
        self.tolerance = checks.real("tolerance", tolerance, positive=True)
        self.iterations = 0
        self._start = None
        if method == "dense":
            ix, iy = _offset_matrix_index(self.shape)
            self._g = np.ascontiguousarray(g[ix, iy])
        else:
            self._op = OffsetOperator(g, self.shape, workers)

    def __call__(self, stiffness) -> float:
        k = np.asarray(stiffness, dtype=float)
        if self.method == "dense":
            self.iterations = 0
            return float(contact_set_stiffness(self._g, k.ravel()))
        k = k.reshape(self.shape)
        value, self.iterations, self._start = contact_set_stiffness_krylov(
            self._op, k, self._op.g_self, self.tolerance, start=self._start
        )
        return float(value)


# --------------------------------------------------------------------------------------------
# the relaxed preload states
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PreloadStates:
    """Quasi-static (relaxed) contact states at the preloads.

    Attributes
    ----------
    preload : numpy.ndarray
        d0 [m], shape (P,).
    compression : numpy.ndarray
        zeta_e [m], shape (P, nx, ny).
    spring_stiffness : numpy.ndarray
        k_e(zeta_e) [N/m], shape (P, nx, ny) (0 outside the contact set).
    force : numpy.ndarray
        Total force F(d0) [N], shape (P,).
    tangent_stiffness : numpy.ndarray
        dF/dd of the quasi-static curve at d0 [N/m], shape (P,).
    contact_count : numpy.ndarray
        Elements in contact, shape (P,).
    """

    preload: np.ndarray
    compression: np.ndarray
    spring_stiffness: np.ndarray
    force: np.ndarray
    tangent_stiffness: np.ndarray
    contact_count: np.ndarray


def preload_states(z1, springs, kernel_static, preloads, settings, threads: int = 1) -> PreloadStates:
    """Solve the quasi-static contact up to each preload (the relaxed preload states).

    The indentation path is the uniform grid of ``settings.quasistatic_step`` up to the largest
    preload with the preloads inserted (warm starts); each preload's state is read from the step
    at that preload.

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    springs : tyreroad.springs.SpringTable
        Spring tables, shape (nx, ny, n_zeta) or (M, n_zeta).
    kernel_static : array_like
        g_static[dx, dy] [m/N].
    preloads : sequence of float
        d0 [m], increasing.
    settings : tyreroad.contact.SolverSettings
        Tolerance, iteration limit, indentation step and method.
    threads : int
        numba threads and FFT workers.

    Returns
    -------
    PreloadStates
    """
    from .contact import solve_path
    from .loading import uniform_indentation_grid

    z1 = np.asarray(z1, dtype=float)
    pre = np.asarray(preloads, dtype=float)
    grid = uniform_indentation_grid(float(pre[-1]), settings.quasistatic_step)
    path = np.unique(np.concatenate([grid[grid < pre[-1]], pre]))
    g = np.asarray(kernel_static, dtype=float)
    if g.ndim != 2:
        raise ValueError(f"kernel_static: expected g_static[dx, dy], got shape {g.shape}")
    result = solve_path(z1, springs.stiffness, springs.force, springs.zeta_step, g[:, :, None], path, settings,
                        threads=threads)
    steps = np.searchsorted(path, pre)
    zeta = result.compression[steps]
    _, k = springs.evaluate(zeta.reshape((pre.size,) + springs.stiffness.shape[:-1]))
    k = k.reshape(zeta.shape)
    return PreloadStates(
        preload=pre,
        compression=zeta,
        spring_stiffness=k,
        force=result.force[steps],
        tangent_stiffness=np.asarray(result.tangent_stiffness)[steps],
        contact_count=result.contact_count[steps],
    )


# --------------------------------------------------------------------------------------------
# the spectrum
# --------------------------------------------------------------------------------------------
def element_frf_table(material, shape, element_size: float, frequencies) -> tuple[np.ndarray, np.ndarray]:
    """Element FRF of the layer at the unique offsets of a patch, and the offset-table index.

    Parameters
    ----------
    material : tyreroad.material.Material
        The layer (modulus(omega), poisson, density, thickness).
    shape : tuple of int
        Patch (nx, ny).
    element_size : float
        c [m].
    frequencies : array_like
        f [Hz], >= 0 (f = 0 uses E(omega -> 0)).

    Returns
    -------
    frf : numpy.ndarray
        g at the unique offsets (:func:`tyreroad.greens.unique_offsets`), shape (n_f, n_unique) [m/N].
    index : numpy.ndarray
        index[i, j] of table offset (dx_i, dy_j) into the unique offsets, shape (2 nx - 1, 2 ny - 1).
    """
    from .greens import element_frf, offset_table_index, unique_offsets

    c = checks.real("element_size", element_size, positive=True)
    uniq = unique_offsets(shape)
    _, _, index = offset_table_index(shape)
    omega = 2 * np.pi * np.asarray(frequencies, dtype=float)
    modulus = np.asarray(material.modulus(omega), dtype=complex)
    frf = element_frf(uniq * c, c, omega, modulus, material.poisson, material.density, material.thickness)
    return frf, index


def stiffness_spectrum(
    z1,
    springs,
    kernel_static,
    material,
    element_size: float,
    sample_rate: float,
    spectrum: SpectrumSettings,
    settings,
    threads: int = 1,
    method: str | None = None,
) -> xr.Dataset:
    """K*(f; d0) of a rough contact about its relaxed preload states (SPEC 11).

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    springs : tyreroad.springs.SpringTable
        Element spring tables.
    kernel_static : array_like
        g_static[dx, dy] [m/N] (the greens file's quasi-static kernel: the relaxed state).
    material : tyreroad.material.Material
        The tread layer (the element FRF).
    element_size : float
        c [m].
    sample_rate : float
        fs of the study [Hz]; the grid ends at fs/2.
    spectrum : SpectrumSettings
        Preloads and frequencies.
    settings : tyreroad.contact.SolverSettings
        The contact solver settings (the preload solve; ``method`` picks dense or matrix-free).
    threads : int
        numba threads and FFT workers.
    method : {"dense", "fft"}, optional
        Override of ``settings.resolved_method`` (tests, benchmarks).

    Returns
    -------
    xarray.Dataset
        See docs/data_contracts.md "Stiffness spectrum dataset".
    """
    t0 = time.perf_counter()
    z1 = np.asarray(z1, dtype=float)
    shape = z1.shape
    n_elem = z1.size
    method = settings.resolved_method(n_elem) if method is None else method
    if method not in ("dense", "fft"):
        raise ValueError(f"method: expected 'dense' or 'fft', got {method!r}")
    freq = spectrum.frequencies(sample_rate)
    states = preload_states(z1, springs, kernel_static, spectrum.preloads, settings, threads)
    t_states = time.perf_counter() - t0
    # f = 0 first: the relaxed limit, E(omega -> 0)
    frf, index = element_frf_table(material, shape, element_size, np.concatenate([[0.0], freq]))
    t_frf = time.perf_counter() - t0 - t_states
    n_p, n_f = states.preload.size, freq.size + 1
    values = np.zeros((n_p, n_f), dtype=complex)
    iterations = np.zeros((n_p, n_f), dtype=np.int64)
    k_flat = states.spring_stiffness.reshape(n_p, -1)
    if method == "dense":
        ix, iy = _offset_matrix_index(shape)
        uidx = index[ix, iy]
        for p in range(n_p):
            active = np.flatnonzero(k_flat[p])
            if active.size == 0:
                continue
            s = np.sqrt(k_flat[p, active])
            block = uidx[np.ix_(active, active)]
            for j in range(n_f):
                g_cc = frf[j][block]
                values[p, j] = _dense_solve(g_cc.real if j == 0 else g_cc, s)
    else:
        starts = [None] * n_p
        for j in range(n_f):
            table = frf[j][index]
            op = OffsetOperator(table.real if j == 0 else table, shape, threads)
            for p in range(n_p):
                k = states.spring_stiffness[p]
                start = starts[p]
                if start is not None and j == 1:
                    start = start.astype(complex)
                values[p, j], iterations[p, j], starts[p] = contact_set_stiffness_krylov(
                    op, k, op.g_self, spectrum.krylov_tolerance, spectrum.krylov_max_iterations, start)
    relaxed = values[:, 0].real
    k_star = values[:, 1:]
    elapsed = time.perf_counter() - t0
    logger.info(
        "stiffness spectrum %s: %d x %d patch, %d preloads x %d frequencies, %s; preload states %.2f s, "
        "element FRF %.2f s, solves %.2f s, total %.2f s%s",
        material.name, shape[0], shape[1], n_p, freq.size, method, t_states, t_frf, elapsed - t_states - t_frf,
        elapsed, f"; Krylov iterations per solve median {int(np.median(iterations))}, max {int(iterations.max())}"
        if method == "fft" else "",
    )
    for p in range(n_p):
        logger.info(
            "d0 = %.3g mm: %d elements in contact, F = %.4g N, K_qs = %.5g N/m, K*(f->0)/K_qs - 1 = %.2e, "
            "K'(%.4g Hz) = %.5g N/m", states.preload[p] * 1e3, states.contact_count[p], states.force[p],
            states.tangent_stiffness[p], relaxed[p] / states.tangent_stiffness[p] - 1, freq[0], k_star[p, 0].real,
        )
    e0 = float(np.real(material.modulus(0.0)))
    e_qs = float(material.quasi_static_modulus)
    if not math.isclose(e0, e_qs, rel_tol=1e-9):
        logger.warning("quasi-static modulus %.6g Pa differs from E(omega -> 0) = %.6g Pa: K*(f -> 0) is not the "
                       "tangent of the relaxed state", e_qs, e0)
    ds = _dataset(states, freq, k_star, relaxed, iterations[:, 1:], method, n_elem, material, element_size,
                  sample_rate, e0, e_qs)
    ds.attrs["report_frequencies"] = np.asarray(spectrum.report_frequencies, dtype=float)
    ds.attrs["figure_preload"] = float(spectrum.figure_preload)
    return ds


_PRELOAD_STATE = (
    "relaxed preload state: the quasi-static contact solution at the preload d0 with the quasi-static kernel "
    "g_static (modulus E_qs), i.e. after the tread has relaxed completely; K* is the small-amplitude stiffness "
    "F_hat/delta_hat of a harmonic indentation d0 + delta sin(2 pi f t) about that state (exp(+i omega t))"
)


def _dataset(states, freq, k_star, relaxed, iterations, method, n_elem, material, element_size, sample_rate,
             e0, e_qs) -> xr.Dataset:
    def attrs(units, long_name):
        return {"units": units, "long_name": long_name}

    pf = ("preload", "frequency")
    k_abs = np.abs(k_star)
    data = {
        "storage_stiffness": (pf, k_star.real, attrs("N/m", "storage contact stiffness K' = Re K*")),
        "loss_stiffness": (pf, k_star.imag, attrs("N/m", "loss contact stiffness K'' = Im K* (>= 0: passive)")),
        "loss_factor": (pf, k_star.imag / k_star.real, attrs("1", "loss factor of the contact K''/K'")),
        "stiffness_magnitude": (pf, k_abs, attrs("N/m", "magnitude |K*| of the complex contact stiffness")),
        "relaxed_stiffness": ("preload", relaxed, attrs(
            "N/m", "K*(f -> 0): the contact-set stiffness with the element FRF at f = 0 (modulus E(omega -> 0))")),
        "tangent_stiffness_qs": ("preload", states.tangent_stiffness, attrs(
            "N/m", "dF/dd of the quasi-static curve at d0 (tangent of the relaxed state, kernel g_static)")),
        "preload_force": ("preload", states.force, attrs("N", "total contact force of the relaxed state at d0")),
        "contact_fraction": ("preload", states.contact_count / n_elem, attrs(
            "1", "fraction of elements in contact at d0 (relaxed state)")),
        "contact_count": ("preload", states.contact_count, attrs("1", "elements in contact at d0 (relaxed state)")),
        "krylov_iterations": (pf, iterations, attrs(
            "1", "matrix-free solver iterations (G products) per solve; 0 for the dense solve")),
    }
    coords = {
        "preload": ("preload", states.preload, attrs("m", "preload indentation d0")),
        "frequency": ("frequency", freq, attrs("Hz", "frequency")),
    }
    return xr.Dataset(data, coords=coords, attrs={
        "material": str(material.name),
        "preload_state": _PRELOAD_STATE,
        "sign_convention": "exp(+i omega t); F_hat = K* delta_hat; Im K* >= 0 for a passive contact",
        "formula": "K* = 1^T [G_C(f) + diag(1/k_e)]^-1 1 over the contact set C of the relaxed state",
        "method": method,
        "sample_rate": float(sample_rate),
        "element_size": float(element_size),
        "quasi_static_modulus": e_qs,
        "zero_frequency_modulus": e0,
    })


def spectrum_from_datasets(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, material,
                           spectrum: SpectrumSettings, settings, threads: int = 1,
                           method: str | None = None) -> xr.Dataset:
    """:func:`stiffness_spectrum` from the stage datasets (surface, springs, greens of one material).

    The relaxed state uses the greens file's g_static (the kernel of the study's quasi-static runs);
    the element FRF is computed afresh at the analysis frequencies; fs is the greens file's.
    """
    from .springs import SpringTable

    z1 = surface["z1"].transpose("ex", "ey").values
    table = SpringTable.from_dataset(springs)
    c_surface, c_greens = surface.attrs.get("element_size"), greens.attrs.get("element_size")
    if c_greens is None:
        raise ValueError("greens dataset: no element_size attribute")
    if c_surface is not None and not math.isclose(float(c_surface), float(c_greens), rel_tol=1e-9):
        raise ValueError(f"element_size differs: surface {c_surface} m, greens {c_greens} m")
    g_static = greens["g_static"].transpose("dx", "dy").values
    return stiffness_spectrum(z1, table, g_static, material, float(c_greens), float(greens.attrs["sample_rate"]),
                              spectrum, settings, threads, method)


# --------------------------------------------------------------------------------------------
# time-domain check
# --------------------------------------------------------------------------------------------
def first_harmonic(time_s, signal, frequency: float, start: float = 0.0) -> complex:
    """Complex amplitude X of x(t) ~ a + b (t - start) + Re(X exp(i omega t)) by least squares over t >= start.

    Parameters
    ----------
    time_s : array_like
        t [s].
    signal : array_like
        x(t) (any unit).
    frequency : float
        f [Hz].
    start : float
        First time used [s] (after the transient).

    Returns
    -------
    complex
        X [unit of x]; exp(+i omega t) convention.
    """
    t = np.asarray(time_s, dtype=float)
    x = np.asarray(signal, dtype=float)
    f = checks.real("frequency", frequency, positive=True)
    sel = t >= start
    if np.count_nonzero(sel) < 8:
        raise ValueError(f"first_harmonic: {np.count_nonzero(sel)} samples after t = {start:g} s; need >= 8")
    t, x = t[sel], x[sel]
    w = 2 * np.pi * f
    design = np.column_stack([np.ones_like(t), t - t[0], np.cos(w * t), np.sin(w * t)])
    coef, *_ = np.linalg.lstsq(design, x, rcond=None)
    # c cos + s sin = Re((c - i s) exp(i w t))
    return complex(coef[2], -coef[3])


def harmonic_stiffness(result, frequency: float, settle: float) -> complex:
    """First-harmonic F_hat / delta_hat of a harmonic-loading run (:mod:`tyreroad.loading` kind harmonic).

    Parameters
    ----------
    result : tyreroad.contact.ContactResult
        A dynamic run with time and indentation.
    frequency : float
        The loading frequency [Hz].
    settle : float
        Time after which the response is taken as steady [s] (measured from t = 0).

    Returns
    -------
    complex
        F_hat / delta_hat [N/m].
    """
    if result.time is None:
        raise ValueError("harmonic_stiffness: the run has no time axis (a quasi-static run)")
    f_hat = first_harmonic(result.time, result.force, frequency, settle)
    d_hat = first_harmonic(result.time, result.indentation, frequency, settle)
    return f_hat / d_hat
