r"""The influence of surface forces on surface displacements over a patch, and the stiffness of a contact set.

An offset table g[dx, dy] [m/N] (one lag of the layer's Green's functions, its quasi-static kernel,
or its element FRF at one frequency) acts on the forces of an nx x ny patch as the matrix
G[e, m] = g[e - m]. :class:`OffsetInfluence` is that operator, once for every use: a dense matrix
(:meth:`OffsetInfluence.matrix`, :meth:`OffsetInfluence.block`) for the paper's 20 x 20 patch, or
an FFT product (:meth:`OffsetInfluence.apply`) on the padded grid of
:func:`tyreroad.convolution.padded_shape` for footprint-size patches. The contact solver's
substrates (:mod:`tyreroad.newton`) hold G_0 as one; the quasi-static tangent and the dynamic contact
stiffness K*(f) (:mod:`tyreroad.stiffness`) solve over it with the contact-set solvers below.

Linearised about a solved contact state, a small indentation increment delta changes the spring
compressions by dzeta, (I + G K) dzeta = delta 1, K = diag(k_e), so over the contact set C
(elements with k_e > 0) the contact stiffness is

    K = 1^T [G_C + diag(1/k_e)]^-1 1,

solved in the symmetric form A y = s, A = I + S G S, S = diag(sqrt(k_e)), K = s^T y (unconjugated):
A has eigenvalues >= 1 in the static case and stays well conditioned when an element has just
touched (k_e -> 0). :func:`contact_set_stiffness` solves it densely,
:func:`contact_set_stiffness_krylov` matrix-free (Jacobi-scaled COCG; plain CG for a real G). A
solved quasi-static state's result is a :class:`Tangent`, which also predicts the next state of a
quasi-static path (the exact linear prediction while the contact set does not change).

References
----------
van der Vorst, H. A., & Melissen, J. B. M. (1990). A Petrov-Galerkin type method for solving Ax = b,
where A is symmetric complex. IEEE Trans. Magn. 26(2), 706-708. doi:10.1109/20.106415
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.fft
import scipy.linalg

from . import checks
from .convolution import OffsetConvolution, check_offset_kernel, padded_shape

__all__ = [
    "offset_matrix_index",
    "offset_matrix",
    "OffsetInfluence",
    "offset_influences",
    "Tangent",
    "contact_set_stiffness",
    "contact_set_solve",
    "contact_set_stiffness_krylov",
]


def offset_matrix_index(shape) -> tuple[np.ndarray, np.ndarray]:
    """Index arrays (ix, iy) with G[e, m] = table[ix[e, m], iy[e, m]] for a (2 nx - 1, 2 ny - 1) table.

    Elements are numbered in C order, e = ex ny + ey.
    """
    nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
    ex, ey = np.divmod(np.arange(nx * ny), ny)
    return ex[:, None] - ex[None, :] + nx - 1, ey[:, None] - ey[None, :] + ny - 1


def offset_matrix(table: np.ndarray) -> np.ndarray:
    """Dense M x M influence matrix G[e, m] = g[e - m] of an offset table (real or complex).

    Parameters
    ----------
    table : numpy.ndarray
        g[dx, dy] for offsets -(nx-1) ... nx-1, -(ny-1) ... ny-1, shape (2 nx - 1, 2 ny - 1).
    """
    nx, ny = (table.shape[0] + 1) // 2, (table.shape[1] + 1) // 2
    ix, iy = offset_matrix_index((nx, ny))
    return np.ascontiguousarray(table[ix, iy])


def _crop_table(table, nx: int, ny: int, name: str) -> np.ndarray:
    """A real or complex offset table checked and cropped to the patch's offsets."""
    t = np.asarray(table)
    if t.ndim != 2:
        raise ValueError(f"{name}: expected g[dx, dy], got shape {t.shape}")
    if np.iscomplexobj(t):
        re = check_offset_kernel(t.real[:, :, None], nx, ny, name)[:, :, 0]
        im = check_offset_kernel(t.imag[:, :, None], nx, ny, name)[:, :, 0]
        return re + 1j * im
    return check_offset_kernel(t[:, :, None], nx, ny, name)[:, :, 0]


class OffsetInfluence:
    """v -> G v with G[e, m] = g[e - m] for one offset table on an nx x ny patch.

    The one influence operator of the package: the contact substrates' G_0, the quasi-static
    tangent's and the K*(f) solver's G_C(f). Dense forms are built on first use; FFT products use
    the pruned transforms of :class:`tyreroad.convolution.OffsetConvolution` for a real table (its
    lag 0, shared with the history when the operator is made :meth:`from_convolution`) and full
    complex transforms for a complex one.

    Parameters
    ----------
    table : array_like
        g[dx, dy] [m/N], real or complex, shape (2 nx - 1, 2 ny - 1) (a larger centred table is
        cropped).
    shape : tuple of int
        Patch (nx, ny) [elements].
    workers : int
        FFT threads.

    Attributes
    ----------
    table : numpy.ndarray
        The cropped table.
    g_self : float or complex
        g[0, 0], the self-compliance [m/N].
    even : bool
        A real table even in dx and dy (to 1e-14): G is symmetric.
    """

    def __init__(self, table, shape, workers: int = 1, convolution: OffsetConvolution | None = None):
        nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
        self.shape = (nx, ny)
        self.workers = checks.integer("workers", workers)
        self.table = _crop_table(table, nx, ny, "influence table")
        self.complex = bool(np.iscomplexobj(self.table))
        self.g_self = self.table[nx - 1, ny - 1]
        self._conv = convolution
        self._matrix = None
        self._spec = None
        if self.complex:
            self.even = False
        else:
            t = self.table
            odd = max(float(np.max(np.abs(t - t[::-1]))), float(np.max(np.abs(t - t[:, ::-1]))))
            self.even = bool(odd <= 1e-14 * float(np.max(np.abs(t))))

    @classmethod
    def from_convolution(cls, conv: OffsetConvolution) -> "OffsetInfluence":
        """Lag 0 of a multi-lag convolution (the FFT path's G_0, sharing its spectra and buffers)."""
        if not isinstance(conv, OffsetConvolution):
            raise TypeError(f"conv: expected OffsetConvolution, got {type(conv).__name__}")
        return cls(conv.lag0, conv.shape, conv.workers, convolution=conv)

    @property
    def convolution(self) -> OffsetConvolution:
        """The real table's :class:`OffsetConvolution` (built on first use)."""
        if self.complex:
            raise TypeError("a complex influence table has no real OffsetConvolution")
        if self._conv is None:
            self._conv = OffsetConvolution(self.table[:, :, None], self.shape, workers=self.workers)
        return self._conv

    def matrix(self) -> np.ndarray:
        """The dense M x M matrix G (built once) [m/N]."""
        if self._matrix is None:
            self._matrix = offset_matrix(self.table)
        return self._matrix

    def block(self, active: np.ndarray) -> np.ndarray:
        """G[active, active] without forming the whole matrix or its index [m/N]."""
        nx, ny = self.shape
        ex, ey = np.divmod(np.asarray(active), ny)
        return self.table[ex[:, None] - ex[None, :] + nx - 1, ey[:, None] - ey[None, :] + ny - 1]

    def apply(self, values: np.ndarray) -> np.ndarray:
        """G v by FFT; v flat (M,) or a field (nx, ny), real or complex; the result has v's shape."""
        v = np.asarray(values)
        out_shape = v.shape
        field = v.reshape(self.shape)
        nx, ny = self.shape
        if not self.complex:
            if np.iscomplexobj(field):  # real kernel, complex field: two real convolutions
                w = self._apply_real(field.real) + 1j * self._apply_real(field.imag)
            else:
                w = self._apply_real(field)
            return w.reshape(out_shape)
        if self._spec is None:
            padded = padded_shape(self.shape)
            buf = np.zeros(padded, dtype=complex)
            buf[: 2 * nx - 1, : 2 * ny - 1] = self.table
            buf = np.roll(buf, (-(nx - 1), -(ny - 1)), axis=(0, 1))
            self._spec = scipy.fft.fft2(buf, workers=self.workers)
        spec = scipy.fft.fft2(field, s=self._spec.shape, workers=self.workers)
        spec *= self._spec
        return scipy.fft.ifft2(spec, workers=self.workers)[:nx, :ny].reshape(out_shape)

    __call__ = apply

    def _apply_real(self, field: np.ndarray) -> np.ndarray:
        return self.convolution.apply_lag(field, 0)


def offset_influences(tables, frequencies, shape, workers: int = 1) -> list[OffsetInfluence]:
    """One :class:`OffsetInfluence` per frequency of a frequency response given as offset tables.

    The tables at f = 0 are taken real (the static response: a real, symmetric operator that the
    contact-set solvers treat by Cholesky or CG).

    Parameters
    ----------
    tables : array_like
        G(dx, dy, f) [m/N], shape (n_f, 2 nx - 1, 2 ny - 1), complex.
    frequencies : array_like
        f [Hz], shape (n_f,).
    shape : tuple of int
        Patch (nx, ny).
    workers : int
        FFT threads.
    """
    f = np.asarray(frequencies, dtype=float)
    return [OffsetInfluence(t.real if fj == 0.0 else t, shape, workers) for t, fj in zip(tables, f)]


@dataclass(frozen=True)
class Tangent:
    """The linearisation of a solved quasi-static state.

    Attributes
    ----------
    stiffness : float
        dF/dd = 1^T [G_0|C + diag(1/k)]^-1 1 [N/m] for a flat tread surface.
    spring_stiffness : numpy.ndarray
        The tangent spring stiffnesses k_e of the state [N/m], shape (M,).
    direction : numpy.ndarray or None
        dzeta/dd [1], shape (M,), where the solver kept it (the FFT path's CG): then
        :meth:`predict` gives the next state's first step.
    """

    stiffness: float
    spring_stiffness: np.ndarray
    direction: np.ndarray | None = None

    def predict(self, shift: np.ndarray, spring_stiffness: np.ndarray) -> np.ndarray | None:
        """First compression step c dzeta/dd of a step whose free compression moved by shift = c 1, or None.

        The prediction holds for this very state (``spring_stiffness`` equal to the state's) and a
        uniform shift (to 1e-9 of it); otherwise None.
        """
        if self.direction is None:
            return None
        c = float(np.mean(shift))
        if c == 0.0 or float(np.max(np.abs(shift - c))) > 1e-9 * abs(c):
            return None
        if not np.array_equal(np.asarray(spring_stiffness, dtype=float).ravel(), self.spring_stiffness):
            return None
        return c * self.direction


def contact_set_stiffness(g_matrix, stiffness) -> complex | float:
    """K = 1^T [G_C + diag(1/k_e)]^-1 1 by a dense solve over the contact set C = {e : k_e > 0}.

    Parameters
    ----------
    g_matrix : array_like
        Influence matrix G[e, m] of the whole patch, real or complex, shape (M, M) [m/N].
    stiffness : array_like
        Tangent spring stiffnesses k_e >= 0 [N/m], shape (M,).

    Returns
    -------
    float or complex
        K [N/m] (complex when G is); 0 when no element is loaded.
    """
    k = checks.nonnegative_array("stiffness", stiffness).ravel()
    active = np.flatnonzero(k)
    g = np.asarray(g_matrix)
    if g.shape != (k.size, k.size):
        raise ValueError(f"g_matrix: expected shape ({k.size}, {k.size}), got {g.shape}")
    if active.size == 0:
        return 0.0 * g.dtype.type(1)
    return contact_set_solve(g[np.ix_(active, active)], np.sqrt(k[active]))


def contact_set_solve(g_cc: np.ndarray, s: np.ndarray):
    """s^T (I + S G S)^-1 s for the contact-set block G_CC [m/N] and s = sqrt(k_C) [sqrt(N/m)].

    Cholesky for a real symmetric block (the layer's, positive definite), LU otherwise.
    """
    symmetric = not np.iscomplexobj(g_cc) and np.array_equal(g_cc, g_cc.T)
    a = g_cc * s[:, None]
    a *= s[None, :]
    a[np.diag_indices_from(a)] += 1.0
    if not symmetric:
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
    (the Jacobi scaling of A = I + S G S), b^ = sqrt(k / d); K = b^T y^ (unconjugated). A is
    complex symmetric (G_em = g(e - m) = g(m - e) for an even table), which is what COCG needs.

    Parameters
    ----------
    apply_g : callable
        v -> G v for a field v of the patch shape (complex or real, the same shape back) [m/N x N],
        e.g. an :class:`OffsetInfluence`.
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
