"""FFT offset convolution of force fields with the layer kernel, and the linear solvers of the FFT path.

The contact solver (SPEC 6) needs, at every time step n, sums over the offset table
g[dx, dy, lag] of the layer's element Green's functions (seed Eq. 3-4):

    (G_l F)_e = sum_m g[e - m, l] F_m                         (one lag, e, m on the nx x ny patch)
    h_e[n]    = sum_{l=1}^{L-1} (G_l F[n - l])_e               (history of the past forces)

and it solves R(zeta) = zeta - b + G_0 F(zeta) = 0 with b = z1 - z2[n] - h[n]. Dense matrices
cost M^2 per lag and step and a dense Jacobian M^3 (M = nx ny); for tyre footprints of 150 x 200
elements with L = 256 lags neither fits. Because g depends only on the offset e - m, every lag is
a 2-D convolution, done here by FFT (:class:`OffsetConvolution`). The history sum over the lags
is :class:`tyreroad.history.FFTHistory`; the matrix-free Newton step is
:class:`tyreroad.newton.FFTSubstrate`, which uses :func:`compliance_cg` (or :func:`gmres`) and the
block preconditioners of this module.

Linear convolution on a padded grid
-----------------------------------
Only offsets |dx| <= nx - 1, |dy| <= ny - 1 occur between two elements of the patch. Place the
table on a periodic grid of P_x x P_y points at index (dx mod P_x, dy mod P_y) and the forces at
[0, nx) x [0, ny), zero elsewhere. The circular convolution at an output element e reads the
table at (e - m) mod P for every source m; the offsets -(n-1) ... n-1 map to 2n - 1 distinct
residues whenever P >= 2n - 1, so every product is exactly g[e - m] F_m and no periodic image
enters: on the patch the circular convolution *equals* the linear one (outputs outside the
patch, which would wrap, are discarded). Hence P = next_fast_len(2n - 1) per axis, not the
3n - 2 of a general full linear convolution. The error is FFT round-off only (~1e-16 relative
to sum |g| |F|).

Spectra
-------
The spectra G^_l of all lags are precomputed. Everything is double precision: the FFT path must
reproduce the dense sum to ~1e-13 relative, which single precision cannot. A table even in dx and
in dy (the layer kernel is, SPEC 5) has real spectra, which halves the kernel's memory and the
history's memory traffic; other tables keep complex spectra. Memory for 150 x 200 elements and
L = 256: kernel spectra 119 MiB (real) or 238 MiB (complex).

Linear solvers
--------------
The Jacobian J = I + G_0 diag(k) is never formed: J v = v + G_0 (k v) is one lag-0 FFT
convolution. For an even lag-0 table (the layer kernel) each Newton correction is solved by
conjugate gradients on the compliance form (G_0|C + diag(1/k_C)) u = -R_C over the loaded set C
(:func:`compliance_cg`, symmetric positive definite; delta = u / k on C), preconditioned by the
exact inverses of that matrix on square tiles of elements (:class:`ComplianceBlockPreconditioner`);
otherwise by right-preconditioned GMRES on J (:func:`gmres`; the residual it minimises is the true
linear residual) with the exact inverse of J on each tile (:class:`BlockJacobiPreconditioner`).
Tiles of 1 element are plain Jacobi.

Cost of one lag-0 product: the transforms are pruned (the real transform along y runs over the
nx force rows only, the inverse one over the nx patch rows only) and run on reused buffers; fresh
padded temporaries of several MB per call cost as much as the transforms themselves (page
faults): 300 x 400 elements (600 x 800 grid), 1 thread, 14.6 ms -> 4.8 ms per product.

References
----------
Saad, Y., & Schultz, M. H. (1986). GMRES: A generalized minimal residual algorithm for solving
nonsymmetric linear systems. SIAM J. Sci. Stat. Comput. 7(3), 856-869. doi:10.1137/0907058
"""

from __future__ import annotations

import logging
import math
import numbers

import numpy as np
import scipy.fft
from numba import njit
from scipy.linalg import solve_triangular

from . import checks

logger = logging.getLogger(__name__)

__all__ = [
    "BlockJacobiPreconditioner",
    "ComplianceBlockPreconditioner",
    "OffsetConvolution",
    "check_offset_kernel",
    "compliance_cg",
    "gmres",
    "padded_shape",
    "pivoted_solve",
]

#: Lags transformed per batch when the kernel spectra are built (bounds the temporary memory).
_LAG_CHUNK = 16
#: Largest odd part of g (relative to max|g|) still treated as an even table.
_SYMMETRY_TOL = 1e-14


def padded_shape(shape) -> tuple[int, int]:
    """FFT grid on which the circular convolution equals the linear one on the patch.

    Parameters
    ----------
    shape : tuple of int
        Patch size (nx, ny) [elements].

    Returns
    -------
    tuple of int
        (P_x, P_y) = next_fast_len(2 n - 1, real=True) per axis: offsets -(n-1) ... n-1 need
        2 n - 1 distinct residues modulo P (see the module docstring).
    """
    if len(shape) != 2:
        raise ValueError(f"shape: expected (nx, ny), got {shape!r}")
    nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
    return (scipy.fft.next_fast_len(2 * nx - 1, real=True), scipy.fft.next_fast_len(2 * ny - 1, real=True))


def check_offset_kernel(kernel, nx: int, ny: int, name: str = "kernel") -> np.ndarray:
    """Validate an offset table g[dx, dy, lag] for an nx x ny patch and return it as floats.

    The table holds offsets -(n-1) ... n-1 along each axis (odd length, centred); a larger
    centred table is cropped to the patch's offsets.

    Raises
    ------
    ValueError
        Naming ``name`` when the table has the wrong rank, an even or too short offset axis, or
        non-finite values.
    """
    g = np.asarray(kernel, dtype=float)
    if g.ndim != 3 or g.shape[2] < 1:
        raise ValueError(f"{name}: expected g[dx, dy, lag] with 3 dimensions and >= 1 lag, got shape {g.shape}")
    need = (2 * nx - 1, 2 * ny - 1)
    for axis in (0, 1):
        if g.shape[axis] % 2 != 1 or g.shape[axis] < need[axis]:
            raise ValueError(
                f"{name}: offset axis {axis} must have odd length (offsets -(n-1)..n-1) covering the "
                f"patch shape {(nx, ny)}, need >= {need[axis]}, got {g.shape[axis]}"
            )
    cx, cy = (g.shape[0] - 1) // 2, (g.shape[1] - 1) // 2
    g = g[cx - (nx - 1) : cx + nx, cy - (ny - 1) : cy + ny, :]
    if not np.all(np.isfinite(g)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return g


class OffsetConvolution:
    """Linear 2-D convolution of force fields with every lag of an offset table, by FFT.

    Parameters
    ----------
    kernel : array_like
        g[dx, dy, lag] [m/N], shape (2 nx - 1, 2 ny - 1, L), index dx + nx - 1 (a larger centred
        table with odd offset axes is cropped to the patch).
    shape : tuple of int
        Patch size (nx, ny) [elements].
    workers : int
        Threads for scipy.fft and for the numba accumulation kernel.

    Attributes
    ----------
    shape : tuple of int
        (nx, ny).
    n_lags : int
        L.
    padded : tuple of int
        FFT grid (P_x, P_y), see :func:`padded_shape`.
    lag0 : numpy.ndarray
        g[:, :, 0] [m/N] (used by the block preconditioner).
    symmetric : bool
        Lags 1 ... L-1 are even in dx and dy (to 1e-14 of their largest value): their spectra
        are stored real.
    lag0_even : bool
        Lag 0 is even in dx and dy (to 1e-14): its spectrum is stored real, and G_0 is a
        symmetric matrix (:class:`tyreroad.newton.FFTSubstrate` then solves by conjugate gradients).
    """

    def __init__(self, kernel, shape, workers: int = 1):
        if len(shape) != 2:
            raise ValueError(f"shape: expected (nx, ny), got {shape!r}")
        nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
        self.workers = checks.integer("workers", workers)
        g = check_offset_kernel(kernel, nx, ny)
        self.shape = (nx, ny)
        self.n_lags = g.shape[2]
        self.padded = padded_shape(self.shape)
        px, py = self.padded
        self.spectrum_shape = (px, py // 2 + 1)
        self.n_bins = px * (py // 2 + 1)
        self.lag0 = np.ascontiguousarray(g[:, :, 0])
        g0 = self.lag0
        odd0 = max(float(np.max(np.abs(g0 - g0[::-1]))), float(np.max(np.abs(g0 - g0[:, ::-1]))))
        self.lag0_even = bool(odd0 <= _SYMMETRY_TOL * float(np.max(np.abs(g0))))
        spec0 = self._spectra(g[:, :, 0:1])[:, 0].reshape(self.spectrum_shape)
        # an even lag 0 (the layer kernel's) has a real spectrum: half the multiply's traffic
        self._spec0 = np.ascontiguousarray(spec0.real) if self.lag0_even else spec0
        # work buffers of the lag-0 products (the Newton-Krylov hot loop): no large temporaries per call
        self._rows = np.zeros((nx, py))
        self._work = np.empty(self.spectrum_shape, dtype=complex)
        # A table even in dx and in dy (SPEC 5: the layer kernel is) stays even on the periodic
        # grid, so its spectra are real: half the memory traffic of the hot loop. Tables even to
        # round-off (_SYMMETRY_TOL of max|g|) use the real spectra of their even part, which
        # moves h by at most that fraction; any other table keeps complex spectra.
        self.symmetric = False
        if self.n_lags > 1:
            gh = g[:, :, 1:]
            odd = max(float(np.max(np.abs(gh - gh[::-1]))), float(np.max(np.abs(gh - gh[:, ::-1]))))
            self.symmetric = bool(odd <= _SYMMETRY_TOL * float(np.max(np.abs(gh))))
        depth = self.n_lags - 1
        # bin-major (bins, lag - 1): the accumulation streams one contiguous row per bin;
        # real and imaginary parts in separate arrays so the loop vectorises
        self._lag_re = np.empty((self.n_bins, depth))
        self._lag_im = np.empty((self.n_bins, 0 if self.symmetric else depth))
        for l0 in range(1, self.n_lags, _LAG_CHUNK):
            l1 = min(l0 + _LAG_CHUNK, self.n_lags)
            spec = self._spectra(g[:, :, l0:l1])
            self._lag_re[:, l0 - 1 : l1 - 1] = spec.real
            if not self.symmetric:
                self._lag_im[:, l0 - 1 : l1 - 1] = spec.imag
        logger.debug(
            "OffsetConvolution: patch %s, FFT grid %s, %d lags, symmetric %s, spectra %.1f MB",
            self.shape, self.padded, self.n_lags, self.symmetric, self.nbytes / 1e6,
        )

    def _spectra(self, g_chunk: np.ndarray) -> np.ndarray:
        """rfft2 of lags placed at (dx mod P_x, dy mod P_y); returns (bins, lags)."""
        nx, ny = self.shape
        px, py = self.padded
        buf = np.zeros((px, py, g_chunk.shape[2]))
        buf[: 2 * nx - 1, : 2 * ny - 1] = g_chunk
        buf = np.roll(buf, (-(nx - 1), -(ny - 1)), axis=(0, 1))
        spec = scipy.fft.rfft2(buf, axes=(0, 1), workers=self.workers)
        return spec.reshape(self.n_bins, g_chunk.shape[2])

    @property
    def nbytes(self) -> int:
        """Memory held by the kernel spectra [B]."""
        return self._spec0.nbytes + self._lag_re.nbytes + self._lag_im.nbytes + self.lag0.nbytes

    def check_field(self, forces, name: str = "forces") -> np.ndarray:
        """``forces`` as an (nx, ny) float array (a flat array of nx ny entries is reshaped)."""
        f = np.asarray(forces, dtype=float)
        if f.shape != self.shape:
            if f.size == self.shape[0] * self.shape[1] and f.ndim == 1:
                return f.reshape(self.shape)
            raise ValueError(f"{name}: expected shape {self.shape} (or flat {self.shape[0] * self.shape[1]}), got {f.shape}")
        return f

    def spectrum(self, forces, out: np.ndarray | None = None) -> np.ndarray:
        """Spectrum of a zero-padded force field, shape (P_x, P_y // 2 + 1), complex.

        Pruned 2-D transform: the real transform along y runs over the nx rows that hold forces
        only (the padding rows are zero), then the complex one along x, in place. ``out`` (complex,
        the spectrum's shape) receives the result and is returned; by default a new array.
        """
        f = self.check_field(forces)
        nx, ny = self.shape
        spec = np.empty(self.spectrum_shape, dtype=complex) if out is None else out
        self._rows[:, :ny] = f
        spec[:nx] = scipy.fft.rfft(self._rows, axis=1, workers=self.workers)
        spec[nx:] = 0.0
        return scipy.fft.fft(spec, axis=0, overwrite_x=True, workers=self.workers)

    def field(self, spec: np.ndarray, overwrite: bool = False) -> np.ndarray:
        """Patch values [.] of a padded-grid spectrum (the inverse of :meth:`spectrum`, cropped).

        Pruned like :meth:`spectrum`: the inverse along y runs over the nx patch rows only.
        ``overwrite``: ``spec`` may be used as work space (then it is destroyed).
        """
        nx, ny = self.shape
        cols = scipy.fft.ifft(spec, axis=0, overwrite_x=overwrite, workers=self.workers)
        return scipy.fft.irfft(cols[:nx], n=self.padded[1], axis=1, workers=self.workers)[:, :ny]

    def apply_lag(self, forces, lag: int) -> np.ndarray:
        """One lag of the convolution: w_e = sum_m g[e - m, lag] F_m.

        Parameters
        ----------
        forces : array_like
            F [N], shape (nx, ny) (or flat nx ny).
        lag : int
            0 <= lag < L.

        Returns
        -------
        numpy.ndarray
            [m], shape (nx, ny) (a view of a new array: copy or ravel before keeping it).
        """
        if isinstance(lag, bool) or not isinstance(lag, numbers.Integral) or not 0 <= lag < self.n_lags:
            raise ValueError(f"lag: expected an integer in [0, {self.n_lags - 1}], got {lag!r}")
        if lag == 0:
            # the Newton-Krylov hot loop: the persistent work spectrum, no large temporaries
            spec = self.spectrum(forces, out=self._work)
            spec *= self._spec0
        else:
            spec = self.spectrum(forces)
            gl = self._lag_re[:, lag - 1] if self.symmetric else self._lag_re[:, lag - 1] + 1j * self._lag_im[:, lag - 1]
            spec *= gl.reshape(self.spectrum_shape)
        return self.field(spec, overwrite=True)

    @property
    def lag_spectra(self) -> tuple[np.ndarray, np.ndarray]:
        """Spectra of lags 1 ... L-1, (real, imaginary) parts, shape (bins, L - 1) each (bin-major).

        The imaginary part has zero columns when the table is :attr:`symmetric`.
        """
        return self._lag_re, self._lag_im


@njit(cache=True)
def pivoted_solve(a, x):  # pragma: no cover - numba
    """Solve a X = x in place by Gaussian elimination with partial pivoting and back substitution.

    a (n, n) is destroyed; x (n, m) holds the m right-hand sides and receives the solution. Done
    in numba rather than LAPACK so that small dense solves do not spawn BLAS threads that
    oversubscribe the cores shared with other pipeline jobs. Returns False for an exactly singular
    pivot (x is then partly eliminated).
    """
    n = a.shape[0]
    m = x.shape[1]
    for col in range(n):
        piv = col
        amax = abs(a[col, col])
        for r in range(col + 1, n):
            if abs(a[r, col]) > amax:
                amax = abs(a[r, col])
                piv = r
        if amax == 0.0:
            return False
        if piv != col:
            for c in range(n):
                tmp = a[col, c]
                a[col, c] = a[piv, c]
                a[piv, c] = tmp
            for q in range(m):
                tmp = x[col, q]
                x[col, q] = x[piv, q]
                x[piv, q] = tmp
        inv = 1.0 / a[col, col]
        for r in range(col + 1, n):
            fct = a[r, col] * inv
            if fct != 0.0:
                for c in range(col + 1, n):
                    a[r, c] -= fct * a[col, c]
                for q in range(m):
                    x[r, q] -= fct * x[col, q]
    for q in range(m):
        for r in range(n - 1, -1, -1):
            acc = x[r, q]
            for c in range(r + 1, n):
                acc -= a[r, c] * x[c, q]
            x[r, q] = acc / a[r, r]
    return True


@njit(cache=True)
def _tile_inverses(g_tile, k, bx, by, inv, loaded):  # pragma: no cover - numba
    """inv[t] = (I + G_tile diag(k_t))^-1 of every tile t with a loaded element (:func:`pivoted_solve`).

    k: (nx, ny) field; tile (tx, ty) covers [tx bx, tx bx + bx) x [ty by, ty by + by), elements
    beyond the patch count as k = 0 (unit Jacobian columns). loaded[t] = False: inv[t] is unused
    (the identity). Returns False for an exactly singular pivot.
    """
    nx, ny = k.shape
    n_ty = inv.shape[0] // ((nx + bx - 1) // bx)
    nb = bx * by
    kt = np.empty(nb)
    a = np.empty((nb, nb))
    for t in range(inv.shape[0]):
        tx = t // n_ty
        ty = t - tx * n_ty
        any_k = False
        for p in range(nb):
            px = tx * bx + p // by
            py = ty * by + p % by
            kt[p] = k[px, py] if px < nx and py < ny else 0.0
            if kt[p] != 0.0:
                any_k = True
        loaded[t] = any_k
        if not any_k:
            continue
        for i in range(nb):
            for j in range(nb):
                a[i, j] = g_tile[i, j] * kt[j]
                inv[t, i, j] = 0.0
            a[i, i] += 1.0
            inv[t, i, i] = 1.0
        if not pivoted_solve(a, inv[t]):
            return False
    return True


@njit(cache=True)
def _tile_apply(inv, loaded, r, bx, by, out):  # pragma: no cover - numba
    """out = blockdiag(inv) r on the (nx, ny) field (tiles as in :func:`_tile_inverses`)."""
    nx, ny = r.shape
    n_tx = (nx + bx - 1) // bx
    n_ty = inv.shape[0] // n_tx
    nb = bx * by
    rt = np.empty(nb)
    for tx in range(n_tx):
        x0 = tx * bx
        wx = min(bx, nx - x0)
        for ty in range(n_ty):
            t = tx * n_ty + ty
            y0 = ty * by
            wy = min(by, ny - y0)
            if not loaded[t]:
                for a in range(wx):
                    for c in range(wy):
                        out[x0 + a, y0 + c] = r[x0 + a, y0 + c]
                continue
            for p in range(nb):
                rt[p] = 0.0
            for a in range(wx):
                for c in range(wy):
                    rt[a * by + c] = r[x0 + a, y0 + c]
            for a in range(wx):
                for c in range(wy):
                    i = a * by + c
                    acc = 0.0
                    for j in range(nb):
                        acc += inv[t, i, j] * rt[j]
                    out[x0 + a, y0 + c] = acc


def _tile_block(lag0: np.ndarray, bx: int, by: int) -> np.ndarray:
    """The lag-0 block of one bx x by tile, G_tile[p, q] = g[x_p - x_q, y_p - y_q, 0] [m/N].

    Element p of a tile sits at (p // by, p % by). By translation invariance every tile of the
    patch shares this block; the tile preconditioners differ only in the springs k.

    Parameters
    ----------
    lag0 : numpy.ndarray
        g[:, :, 0] [m/N], shape (2 nx - 1, 2 ny - 1) (offset dx at index dx + nx - 1).
    bx, by : int
        Tile size [elements], <= nx, ny.

    Returns
    -------
    numpy.ndarray
        Shape (bx by, bx by), C-contiguous.
    """
    nx, ny = (lag0.shape[0] + 1) // 2, (lag0.shape[1] + 1) // 2
    px, py = np.divmod(np.arange(bx * by), by)
    return np.ascontiguousarray(lag0[px[:, None] - px[None, :] + nx - 1, py[:, None] - py[None, :] + ny - 1])


class _TilePreconditioner:
    """The tiling shared by the block preconditioners: b x b tiles of the patch and their lag-0 block.

    Attributes
    ----------
    block : int
        Requested tile edge b [elements].
    shape : tuple of int
        Patch (nx, ny).
    bx, by : int
        Tile size, b clipped to the patch.
    tiles : tuple of int
        Number of tiles along x and y (the last ones may stick out of the patch).
    """

    def __init__(self, conv: OffsetConvolution, block: int):
        self.block = checks.integer("block", block)
        nx, ny = conv.shape
        self.shape = conv.shape
        self.bx, self.by = min(self.block, nx), min(self.block, ny)
        self.tiles = (-(-nx // self.bx), -(-ny // self.by))
        self._g_tile = _tile_block(conv.lag0, self.bx, self.by)
        self._ready = False

    @property
    def n_tiles(self) -> int:
        """Number of tiles."""
        return self.tiles[0] * self.tiles[1]

    def _check_ready(self) -> None:
        if not self._ready:
            raise RuntimeError(f"{type(self).__name__}.solve called before update(stiffness)")


class BlockJacobiPreconditioner(_TilePreconditioner):
    """Exact inverse of J = I + G_0 diag(k) restricted to square tiles of elements.

    The patch is cut into tiles of b x b elements (the last row/column of tiles padded with
    k = 0 elements, whose Jacobian columns are unit vectors, so the padding leaves the real
    block unchanged). All tiles share one lag-0 block G_tile[p, q] = g[x_p - x_q, y_p - y_q, 0]
    by translation invariance; only k differs. An update inverts the tiles that hold a loaded
    element (compiled Gauss-Jordan, no full-size temporaries); tiles without contact are the
    identity.

    Parameters
    ----------
    conv : OffsetConvolution
        Supplies g[:, :, 0] and the patch shape.
    block : int
        Tile edge b [elements]; 1 is Jacobi diag(1 + g[0, 0, 0] k). Clipped to the patch.
    """

    def __init__(self, conv: OffsetConvolution, block: int = 4):
        super().__init__(conv, block)
        nb = self.bx * self.by
        self._inv = np.empty((self.n_tiles, nb, nb))
        self._loaded = np.zeros(self.n_tiles, dtype=np.bool_)

    def update(self, stiffness) -> None:
        """Factorise the tile blocks for spring stiffnesses k [N/m], shape (nx, ny)."""
        k = np.ascontiguousarray(np.asarray(stiffness, dtype=float).reshape(self.shape))
        if not _tile_inverses(self._g_tile, k, self.bx, self.by, self._inv, self._loaded):
            raise np.linalg.LinAlgError("BlockJacobiPreconditioner: singular tile block")
        self._ready = True

    def solve(self, residual, out: np.ndarray | None = None) -> np.ndarray:
        """Apply the tile inverses to a field [m], shape (nx, ny) or flat; returns (nx, ny).

        ``out``: a C-contiguous float array of nx ny entries to write into (returned reshaped).
        """
        self._check_ready()
        r = np.ascontiguousarray(np.asarray(residual, dtype=float).reshape(self.shape))
        out = np.empty(self.shape) if out is None else out.reshape(self.shape)
        _tile_apply(self._inv, self._loaded, r, self.bx, self.by, out)
        return out


@njit(cache=True)
def _tile_cholesky(g_tile, k, bx, by, inv, idx, pos, count):  # pragma: no cover - numba
    """Inverses of B_t = G_tile[L, L] + diag(1/k_L) over the loaded elements L of every tile, by Cholesky.

    Tiles as in :func:`_tile_inverses`. idx[t, :count[t]] are the local indices (a by + c) of the
    loaded elements of tile t, pos[t, :count[t]] their flat indices x ny + y on the patch;
    inv[t] (n = count[t]) receives B_t^-1 = L^-T L^-1, symmetric, packed by rows: entry (i, j),
    j <= i < n, at i (i + 1) / 2 + j (half the memory traffic of the apply).
    Returns False at a non-positive pivot (B_t not positive definite).
    """
    nx, ny = k.shape
    n_tx = (nx + bx - 1) // bx
    n_ty = inv.shape[0] // n_tx
    nb = bx * by
    low = np.zeros((nb, nb))
    linv = np.zeros((nb, nb))
    for tx in range(n_tx):
        x0 = tx * bx
        wx = min(bx, nx - x0)
        for ty in range(n_ty):
            t = tx * n_ty + ty
            y0 = ty * by
            wy = min(by, ny - y0)
            n = 0
            for a in range(wx):
                for c in range(wy):
                    if k[x0 + a, y0 + c] > 0.0:
                        idx[t, n] = a * by + c
                        pos[t, n] = (x0 + a) * ny + y0 + c
                        n += 1
            count[t] = n
            if n == 0:
                continue
            for i in range(n):  # Cholesky B = L L^T
                pi = idx[t, i]
                for j in range(i + 1):
                    acc = g_tile[pi, idx[t, j]]
                    if i == j:
                        acc += 1.0 / k.ravel()[pos[t, i]]
                    for m in range(j):
                        acc -= low[i, m] * low[j, m]
                    if i == j:
                        if not acc > 0.0:
                            return False
                        low[i, i] = math.sqrt(acc)
                    else:
                        low[i, j] = acc / low[j, j]
            for j in range(n):  # L^-1, column by column
                linv[j, j] = 1.0 / low[j, j]
                for i in range(j + 1, n):
                    acc = 0.0
                    for m in range(j, i):
                        acc -= low[i, m] * linv[m, j]
                    linv[i, j] = acc / low[i, i]
            for i in range(n):  # B^-1 = L^-T L^-1, lower triangle packed by rows
                row = i * (i + 1) // 2
                for j in range(i + 1):
                    acc = 0.0
                    for m in range(i, n):
                        acc += linv[m, i] * linv[m, j]
                    inv[t, row + j] = acc
    return True


@njit(cache=True)
def _tile_loaded_apply(inv, pos, count, r, out):  # pragma: no cover - numba
    """out = blockdiag(B_t^-1) r on the loaded elements of every tile, 0 elsewhere (flat fields).

    inv[t] holds the symmetric B_t^-1 packed by rows (:func:`_tile_cholesky`).
    """
    nb = pos.shape[1]
    y = np.empty(nb)
    z = np.empty(nb)
    for e in range(out.size):
        out[e] = 0.0
    for t in range(inv.shape[0]):
        n = count[t]
        for j in range(n):
            y[j] = r[pos[t, j]]
            z[j] = 0.0
        for i in range(n):
            row = i * (i + 1) // 2
            yi = y[i]
            acc = 0.0
            for j in range(i):
                a = inv[t, row + j]
                acc += a * y[j]
                z[j] += a * yi
            z[i] += acc + inv[t, row + i] * yi
        for i in range(n):
            out[pos[t, i]] = z[i]


class ComplianceBlockPreconditioner(_TilePreconditioner):
    """Block Jacobi for the compliance form G_0|C + diag(1/k_C) of the Newton Jacobian (conjugate gradients).

    Per square tile of b x b elements, the exact inverse of the compliance-form block over the
    tile's loaded elements L, B_t = G_tile[L, L] + diag(1/k_L) (= k (I + G_tile k)^-1, the
    tile inverse of J of :class:`BlockJacobiPreconditioner` in compliance form), inverted through
    a Cholesky factor of the loaded elements only: symmetric positive definite, as CG needs; a
    tile with n_L loaded elements costs ~ n_L^3 to factorise and n_L^2 to apply (memory traffic
    of its packed symmetric inverse, n_L (n_L + 1) / 2 numbers), tiles without contact nothing.

    Parameters
    ----------
    conv : OffsetConvolution
        Supplies g[:, :, 0] (even: G_0 symmetric) and the patch shape.
    block : int
        Tile edge b [elements]; 1 is Jacobi 1 / (g[0, 0, 0] + 1/k). Clipped to the patch.
    """

    def __init__(self, conv: OffsetConvolution, block: int = 4):
        super().__init__(conv, block)
        nb = self.bx * self.by
        self._inv = np.empty((self.n_tiles, nb * (nb + 1) // 2))
        self._idx = np.zeros((self.n_tiles, nb), dtype=np.int64)
        self._pos = np.zeros((self.n_tiles, nb), dtype=np.int64)
        self._count = np.zeros(self.n_tiles, dtype=np.int64)

    def update(self, stiffness) -> None:
        """Factorise the tiles for spring stiffnesses k >= 0 [N/m], shape (nx, ny) or flat."""
        k = np.ascontiguousarray(np.asarray(stiffness, dtype=float).reshape(self.shape))
        if not _tile_cholesky(self._g_tile, k, self.bx, self.by, self._inv, self._idx, self._pos, self._count):
            raise np.linalg.LinAlgError("ComplianceBlockPreconditioner: a tile block is not positive definite")
        self._ready = True

    def solve(self, residual, out: np.ndarray | None = None) -> np.ndarray:
        """blockdiag(B_t^-1) r [N] for a field r [m] (0 outside the loaded set); returns (nx, ny)."""
        self._check_ready()
        r = np.ascontiguousarray(np.asarray(residual, dtype=float).ravel())
        if r.size != self.shape[0] * self.shape[1]:
            raise ValueError(f"residual: expected {self.shape[0] * self.shape[1]} entries, got {r.size}")
        out = np.empty(r.size) if out is None else out.reshape(-1)
        _tile_loaded_apply(self._inv, self._pos, self._count, r, out)
        return out.reshape(self.shape)


def _norm(x: np.ndarray) -> float:
    """Euclidean norm without BLAS (see :func:`_orthogonalize`)."""
    x = x.ravel()
    return math.sqrt(float(np.einsum("i,i->", x, x)))


def _dot(x: np.ndarray, y: np.ndarray) -> float:
    """x . y without BLAS (see :func:`_orthogonalize`)."""
    return float(np.einsum("i,i->", x, y))


@njit(cache=True)
def _orthogonalize(basis, w, coef):  # pragma: no cover - numba
    """Classical Gram-Schmidt applied twice: w -= V^T (V w), coef = the summed projections.

    Serial loops on purpose: the equivalent BLAS-2 calls on thin matrices stalled for
    milliseconds in multi-threaded OpenBLAS on a busy machine (measured).
    """
    m, n = basis.shape
    proj = np.empty(m)
    for i in range(m):
        coef[i] = 0.0
    for _ in range(2):
        for i in range(m):
            s = 0.0
            for p in range(n):
                s += basis[i, p] * w[p]
            proj[i] = s
        for i in range(m):
            c = proj[i]
            for p in range(n):
                w[p] -= c * basis[i, p]
            coef[i] += c


@njit(cache=True)
def _combine(coef, basis, out):  # pragma: no cover - numba
    """out = V^T coef (serial, see :func:`_orthogonalize`)."""
    m, n = basis.shape
    for p in range(n):
        out[p] = 0.0
    for i in range(m):
        c = coef[i]
        for p in range(n):
            out[p] += c * basis[i, p]


@njit(cache=True)
def _cg_curvature(p, gp, kinv, q):  # pragma: no cover - numba
    """q = G p + p / k on the loaded elements (kinv > 0), 0 elsewhere; returns p . q."""
    s = 0.0
    for e in range(p.size):
        if kinv[e] > 0.0:
            v = gp[e] + kinv[e] * p[e]
            q[e] = v
            s += p[e] * v
        else:
            q[e] = 0.0
    return s


@njit(cache=True)
def _cg_update(alpha, p, gp, q, u, gu, res):  # pragma: no cover - numba
    """u += alpha p, gu += alpha G p, res -= alpha q; returns ||res||_2^2."""
    s = 0.0
    for e in range(p.size):
        u[e] += alpha * p[e]
        gu[e] += alpha * gp[e]
        r = res[e] - alpha * q[e]
        res[e] = r
        s += r * r
    return s


@njit(cache=True)
def _cg_direction(beta, z, p):  # pragma: no cover - numba
    """p = z + beta p, in place."""
    for e in range(p.size):
        p[e] = z[e] + beta * p[e]


def compliance_cg(apply_g, precondition, stiffness: np.ndarray, rhs: np.ndarray, atol: float, max_iter: int):
    """Preconditioned conjugate gradients on the compliance form of J delta = rhs, J = I + G diag(k).

    With C = {k > 0} and the force increment u = k delta on C,

        (G|C + diag(1/k_C)) u = rhs_C,    delta_C = u / k_C,    delta_I = rhs_I - (G u)_I,

    (columns of J outside C are unit vectors). For a symmetric positive definite G the matrix is
    symmetric positive definite; its residual is the linear residual rhs - J delta on C, and zero
    elsewhere (G u is accumulated from the products). The preconditioner must be symmetric positive
    definite on C (:class:`ComplianceBlockPreconditioner`). Serial fused loops (numba) for the
    vector updates.

    Parameters
    ----------
    apply_g : callable
        v -> G v, flat fields of M entries.
    precondition : callable
        (r, out) -> writes M^-1 r into ``out`` (flat, M entries, 0 outside C).
    stiffness : numpy.ndarray
        k >= 0 [N/m], shape (M,).
    rhs : numpy.ndarray
        Right-hand side [m], shape (M,).
    atol : float
        Stop when ||rhs_C - A u||_2 <= atol (the recursively updated residual).
    max_iter : int
        Products with G allowed.

    Returns
    -------
    (delta, u, products, residual_norm), or None on a breakdown (a non-positive curvature: the
    matrix is not positive definite).

    References
    ----------
    Hestenes, M. R., & Stiefel, E. (1952). Methods of conjugate gradients for solving linear
    systems. J. Res. Natl. Bur. Stand. 49(6), 409-436. doi:10.6028/jres.049.044
    """
    k = np.ascontiguousarray(stiffness, dtype=float)
    n = k.size
    mask = k > 0.0
    u = np.zeros(n)
    if not mask.any():
        return rhs.copy(), u, 0, 0.0
    gu = np.zeros(n)
    kinv = np.zeros(n)
    np.divide(1.0, k, out=kinv, where=mask)
    res = np.where(mask, rhs, 0.0)
    rnorm = _norm(res)
    z, q = np.empty(n), np.empty(n)
    precondition(res, z)
    rz = _dot(res, z)
    p = z.copy()
    products = 0
    while rnorm > atol and products < max_iter:
        if not rz > 0.0:
            return None
        gp = np.ascontiguousarray(apply_g(p), dtype=float)
        products += 1
        pq = _cg_curvature(p, gp, kinv, q)
        if not pq > 0.0:
            return None
        alpha = rz / pq
        rnorm = math.sqrt(_cg_update(alpha, p, gp, q, u, gu, res))
        if rnorm <= atol:
            break
        precondition(res, z)
        rz_new = _dot(res, z)
        _cg_direction(rz_new / rz, z, p)
        rz = rz_new
    delta = np.where(mask, kinv * u, rhs - gu)
    return delta, u, products, rnorm


def gmres(matvec, psolve, b: np.ndarray, atol: float, restart: int, max_iter: int):
    """Right-preconditioned restarted GMRES from x0 = 0 (Saad & Schultz 1986).

    Minimises the true residual ||b - A x||_2 over x = M^-1 V y, stops when it is <= atol or
    after ``max_iter`` matrix-vector products. Classical Gram-Schmidt with one
    re-orthogonalisation (as accurate as modified Gram-Schmidt, but BLAS-2). Returns
    (x, products, ||b - A x||_2), the last norm recomputed from the true residual.
    """
    n = b.size
    x = np.zeros(n)
    r = b.copy()
    beta = _norm(r)
    done = 0
    while beta > atol and done < max_iter:
        m = min(restart, max_iter - done)
        v = np.empty((m + 1, n))
        h = np.zeros((m + 1, m))
        cs = np.zeros(m)
        sn = np.zeros(m)
        gvec = np.zeros(m + 1)
        v[0] = r / beta
        gvec[0] = beta
        j_used = 0
        for j in range(m):
            w = matvec(psolve(v[j]))
            done += 1
            coef = np.empty(j + 1)
            _orthogonalize(v[: j + 1], w, coef)
            h[: j + 1, j] = coef
            h_next = _norm(w)
            h[j + 1, j] = h_next
            if h_next > 0.0:
                v[j + 1] = w / h_next
            for i in range(j):
                hi = cs[i] * h[i, j] + sn[i] * h[i + 1, j]
                h[i + 1, j] = -sn[i] * h[i, j] + cs[i] * h[i + 1, j]
                h[i, j] = hi
            rho = math.hypot(h[j, j], h[j + 1, j])
            cs[j], sn[j] = h[j, j] / rho, h[j + 1, j] / rho
            h[j, j] = rho
            h[j + 1, j] = 0.0
            gvec[j + 1] = -sn[j] * gvec[j]
            gvec[j] = cs[j] * gvec[j]
            j_used = j + 1
            if abs(gvec[j + 1]) <= atol or h_next == 0.0:
                break
        y = solve_triangular(h[:j_used, :j_used], gvec[:j_used])
        comb = np.empty(n)
        _combine(y, v[:j_used], comb)
        x += psolve(comb)
        r = b - matvec(x)
        beta_new = _norm(r)
        if beta_new >= beta:
            # stagnation (breakdown or loss of orthogonality): restarting cannot help
            beta = beta_new
            break
        beta = beta_new
    return x, done, beta
